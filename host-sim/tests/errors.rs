//! Malformed input through the `host-sim estimate` binary: the exact error line for the
//! kinds `tests/cli.rs` does not pin down (it covers the empty file, wrong columns, a
//! non-numeric cell, NaN, time going backwards and a record without contact, and checks
//! the unknown format only loosely). Each case: exit code 1, no panic, the file, line and
//! field named.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("temporary file");
    path
}

/// Runs `estimate` on `path` (with `--format` when given): exit code 1, no panic; returns
/// the first `error: ` line of stderr.
fn estimate_error(path: &Path, format: Option<&str>) -> String {
    let mut args = vec!["estimate", "--model", "kelvin-voigt"];
    if let Some(f) = format {
        args.extend(["--format", f]);
    }
    args.push(path.to_str().expect("UTF-8 path"));
    let o = host_sim(&args);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err.lines()
        .find(|l| l.starts_with("error: "))
        .unwrap_or_default()
        .to_string()
}

/// The shipped Hysitron file's first 4 header lines and 100 data lines.
fn truncated_hysitron() -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/nanoindentation/steel-hysitron.txt");
    let full = std::fs::read(path).expect("the shared Hysitron file");
    let cut = full
        .iter()
        .enumerate()
        .filter(|(_, &b)| b == b'\n')
        .nth(103)
        .map(|(i, _)| i + 1)
        .expect("enough lines");
    full[..cut].to_vec()
}

#[test]
fn error_truncated_hysitron() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "steel.txt", &truncated_hysitron());
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}:3: field `Number of Points`: the header declares 5304 points but 100 \
             data rows were found (lines 5-104)",
            path.display()
        )
    );
}

#[test]
fn error_unknown_format_lists_every_signature() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "mystery.txt", b"t;x;f\n0;0;0\n");
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}: unknown format; tried jpk (first line `# TEXT EXPORT`), afm-tab (first \
             line starting `# afmformats`), hysitron (a line `Number of Points =` and a header \
             with `Depth (nm)`), instron (a header line starting `Time (s),` with `Load (N)`), \
             csv (a header with `time_s`)",
            path.display()
        )
    );
}

#[test]
fn error_unknown_format_name() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "log.csv",
        b"time_s,position_m,force_n\n0,0,0\n0.001,0,0\n",
    );
    let line = estimate_error(&path, Some("tab"));
    assert!(
        line.contains("unknown format `tab`; expected one of csv, jpk, afm-tab, hysitron, instron"),
        "{line}"
    );
}

#[test]
fn error_infinite_cell() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "inf.csv",
        b"time_s,position_m,force_n\n0,0,0\n0.001,0,inf\n",
    );
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}:3: field `force_n`: not finite: \"inf\"",
            path.display()
        )
    );
}

#[test]
fn error_repeated_time() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "same.csv",
        b"time_s,position_m,force_n\n0,0,0\n0.001,0,0\n0.001,0,0\n",
    );
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}:4: field `time_s`: time not strictly increasing: 0.001 s here, 0.001 s \
             on line 3",
            path.display()
        )
    );
}

#[test]
fn error_row_length() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "short.csv",
        b"time_s,position_m,force_n\n0,0,0\n0.001,0\n",
    );
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}:3: row has 2 cells, the header on line 1 has 3",
            path.display()
        )
    );
}

#[test]
fn error_header_without_rows_and_single_row() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "header.csv", b"time_s,position_m,force_n\n");
    assert_eq!(
        estimate_error(&path, None),
        format!("error: {}:1: no data rows", path.display())
    );
    let path = write(&dir, "one.csv", b"time_s,position_m,force_n\n0,0,0\n");
    assert_eq!(
        estimate_error(&path, None),
        format!(
            "error: {}:2: only 1 data row(s); at least 2 are needed",
            path.display()
        )
    );
}

#[test]
fn error_whitespace_only_file_is_empty() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "blank.csv", b" \n\r\n\t\n");
    assert_eq!(
        estimate_error(&path, None),
        format!("error: {}: the file is empty", path.display())
    );
}

#[test]
fn error_hysitron_without_point_count() {
    let dir = tempfile::tempdir().expect("tempdir");
    // A forced format: auto-detection needs the `Number of Points` line.
    let path = write(
        &dir,
        "nocount.txt",
        b"date\n\nDepth (nm)\tLoad (\xb5N)\tTime (s)\n1\t2\t0\n2\t3\t1\n",
    );
    assert_eq!(
        estimate_error(&path, Some("hysitron")),
        format!(
            "error: {}:3: field `Number of Points`: no `Number of Points = N` line before the \
             header",
            path.display()
        )
    );
}

#[test]
fn error_is_reported_per_file_and_the_others_still_run() {
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = write(
        &dir,
        "bad.csv",
        b"time_s,position_m,force_n\n0,0,x\n0.001,0,0\n",
    );
    let empty = write(&dir, "empty.csv", b"");
    // The summary goes into the temporary folder, not ./out (the shipped outputs).
    let summary = dir.path().join("summary");
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        "--summary",
        summary.to_str().expect("UTF-8 path"),
        bad.to_str().expect("UTF-8 path"),
        empty.to_str().expect("UTF-8 path"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    let errors: Vec<&str> = err.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(
        errors,
        [
            format!(
                "error: {}:2: field `force_n`: not a number: \"x\"",
                bad.display()
            ),
            format!("error: {}: the file is empty", empty.display()),
            "error: 2 of 2 files failed".to_string(),
        ]
    );
    let rows = std::fs::read_to_string(summary.join("summary.csv")).expect("summary.csv");
    assert_eq!(rows.lines().count(), 3, "{rows}");
    assert!(
        rows.lines().skip(1).all(|l| l.contains(",error,")),
        "{rows}"
    );
}

/// Three samples spread over 2.5 h: resampling to 1 kHz would build 9 M points out of
/// nothing (and once allocated over 3 GB). Refused with the file named.
#[test]
fn error_sparse_record_is_not_resampled() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(
        &dir,
        "sparse.csv",
        b"time_s,position_m,force_n\n0,0,0\n4500,0.001,1\n9000,0,0\n",
    );
    let line = estimate_error(&path, None);
    assert!(
        line.starts_with(&format!(
            "error: {}: cannot resample to 1 kHz",
            path.display()
        )),
        "{line}"
    );
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        path.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("field `time_s`: 3 samples over 9000 s are too sparse"),
        "{err}"
    );
}
