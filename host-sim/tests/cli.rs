//! The `host-sim` binary as a user runs it: JSON output, exit codes, and the exact error
//! text for each kind of bad input (file, line and field named; never a panic).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use estimator_core::laws;

fn host_sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(relative)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `estimate` on a bad file: exit code 1, no panic, and the error line.
fn estimate_error(path: &Path) -> String {
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        path.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err.lines()
        .find(|l| l.starts_with("error: "))
        .unwrap_or_default()
        .to_string()
}

#[test]
fn estimate_json_has_the_documented_shape() {
    let file = data("afm/cell-stress-relaxation.tab");
    let o = host_sim(&[
        "estimate",
        "--model",
        "hammerstein",
        "--json",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8(o.stdout.clone()).unwrap();
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(v["model"], "hammerstein");
    for name in [
        "gamma1",
        "gamma2",
        "a1",
        "b1",
        "contact_position_m",
        "force_offset_n",
    ] {
        assert!(v["parameters"][name].is_f64(), "{name} missing in {v}");
    }
    assert!(v["nrmse_percent"].as_f64().unwrap() < 5.0);
    assert!(v["contact_position_m"].is_f64() && v["force_offset_n"].is_f64());
    // Human summary on stderr, data only on stdout.
    assert!(stderr(&o).contains("gamma2"));
    assert_eq!(stdout.trim().lines().count(), 1);
}

#[test]
fn estimate_writes_csv_json_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let file = data("nanoindentation/steel-hysitron.txt");
    let o = host_sim(&[
        "estimate",
        "--model",
        "hunt-crossley-single-stage",
        "--phase",
        "loading",
        "--out",
        dir.path().to_str().unwrap(),
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("steel-hysitron");
    for f in [
        "estimates_hunt-crossley-single-stage.csv",
        "summary_hunt-crossley-single-stage.json",
        "hysteresis_hunt-crossley-single-stage.png",
        "hysteresis_hunt-crossley-single-stage.svg",
        "power_hunt-crossley-single-stage.png",
        "parameters_hunt-crossley-single-stage.svg",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
}

#[test]
fn simulate_one_scenario_writes_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let o = host_sim(&[
        "simulate",
        "--scenario",
        "gel-kv",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("gel-kv");
    for f in [
        "log.csv",
        "estimates_kelvin-voigt.csv",
        "summary.json",
        "hysteresis_kelvin-voigt.png",
        "power_kelvin-voigt.svg",
    ] {
        assert!(out.join(f).exists(), "{f} missing");
    }
    assert!(dir.path().join("summary.md").exists());
    let o = host_sim(&[
        "simulate",
        "--scenario",
        "no-such",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("unknown scenario `no-such`; known: all, plastic-hc"));
}

#[test]
fn error_empty_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "empty.csv", "");
    assert_eq!(
        estimate_error(&path),
        format!("error: {}: the file is empty", path.display())
    );
}

#[test]
fn error_wrong_columns() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "cols.csv",
        "time_s,position_m,load\n0,0,0\n0.001,0,0\n",
    );
    assert_eq!(
        estimate_error(&path),
        format!(
            "error: {}:1: field `force_n`: missing column; expected `time_s`, `position_m`, `force_n`; found `time_s`, `position_m`, `load`",
            path.display()
        )
    );
}

#[test]
fn error_non_numeric_cell() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "text.csv",
        "time_s,position_m,force_n\n0,0,0\n0.001,0,abc\n",
    );
    assert_eq!(
        estimate_error(&path),
        format!(
            "error: {}:3: field `force_n`: not a number: \"abc\"",
            path.display()
        )
    );
}

#[test]
fn error_nan_cell() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "nan.csv",
        "time_s,position_m,force_n\n0,0,0\n0.001,NaN,0\n",
    );
    assert_eq!(
        estimate_error(&path),
        format!(
            "error: {}:3: field `position_m`: not finite: \"NaN\"",
            path.display()
        )
    );
}

#[test]
fn error_time_going_backwards() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        &dir,
        "time.csv",
        "time_s,position_m,force_n\n0,0,0\n0.002,0,0\n0.001,0,0\n",
    );
    assert_eq!(
        estimate_error(&path),
        format!(
            "error: {}:4: field `time_s`: time not strictly increasing: 0.001 s here, 0.002 s on line 3",
            path.display()
        )
    );
}

#[test]
fn error_file_without_contact() {
    let dir = tempfile::tempdir().unwrap();
    // One second of free space: noise only.
    let mut text = String::from("time_s,position_m,force_n\n");
    for i in 0..1000 {
        let noise = ((i * 7919) % 13) as f64 * 1e-3 - 6e-3;
        text.push_str(&format!(
            "{},{},{}\n",
            i as f64 * 1e-3,
            i as f64 * 1e-6,
            noise
        ));
    }
    let path = write(&dir, "free.csv", &text);
    let line = estimate_error(&path);
    assert!(
        line.starts_with(&format!(
            "error: {}: no contact: the force does not follow the position",
            path.display()
        )),
        "{line}"
    );
}

#[test]
fn error_constant_force() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("time_s,position_m,force_n\n");
    for i in 0..500 {
        text.push_str(&format!("{},{},0.125\n", i as f64 * 1e-3, i as f64 * 1e-6));
    }
    let path = write(&dir, "flat.csv", &text);
    let line = estimate_error(&path);
    assert_eq!(
        line,
        format!(
            "error: {}: no contact: the force never changes (it is 1.25e-1 N in all 500 samples)",
            path.display()
        )
    );
}

#[test]
fn error_values_beyond_f32_and_the_pipeline_range() {
    let dir = tempfile::tempdir().unwrap();
    for (name, value, expected) in [
        ("huge.csv", "1e40", "field `force_n`: 1e40 N overflows f32"),
        (
            "mega.csv",
            "2.5e7",
            "field `force_n`: 2.5e7 N is beyond the estimator's input range",
        ),
    ] {
        let text = format!("time_s,position_m,force_n\n0,0,0\n0.001,1e-6,{value}\n0.002,2e-6,0\n");
        let path = write(&dir, name, &text);
        let line = estimate_error(&path);
        assert!(
            line.starts_with(&format!("error: {}:3: {expected}", path.display())),
            "{line}"
        );
    }
}

#[test]
fn error_missing_file_and_unknown_format() {
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        "/nonexistent/log.csv",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("/nonexistent/log.csv: I/O error"),
        "{}",
        stderr(&o)
    );
    let dir = tempfile::tempdir().unwrap();
    let path = write(&dir, "mystery.txt", "hello\nworld\n");
    let line = estimate_error(&path);
    assert!(
        line.contains("mystery.txt") && line.contains("format"),
        "{line}"
    );
}

/// A folder of files (two of the same name below it, one that is not a record) runs as a
/// batch: every file gets its row, the bad one an error row naming it, the exit code says
/// one failed, and the summary CSV and JSON agree with each file's own `--json` object.
#[test]
fn a_folder_runs_as_a_batch_with_one_summary() {
    let dir = tempfile::tempdir().unwrap();
    let records = dir.path().join("records");
    std::fs::create_dir_all(records.join("b")).unwrap();
    for (name, k) in [("a.csv", 2.0e4), ("b/a.csv", 5.0e4)] {
        let mut text = String::from("time_s,position_m,force_n\n");
        for i in 0..4000 {
            let t = i as f64 * 1e-3;
            let x = -0.5e-3 + 1.5e-3 * (0.5 - 0.5 * (2.0 * std::f64::consts::PI * t).cos());
            let v = 1.5e-3 * std::f64::consts::PI * (2.0 * std::f64::consts::PI * t).sin();
            let f = if x > 0.0 { k * x + 40.0 * v } else { 0.0 };
            let noise = 0.003 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5);
            text.push_str(&format!("{t:.3},{x:.9},{:.6}\n", f + 0.2 + noise));
        }
        std::fs::write(records.join(name), text).unwrap();
    }
    std::fs::write(records.join("notes.txt"), "not a record\n").unwrap();
    let summary = dir.path().join("summary");
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        "--json",
        "--summary",
        summary.to_str().unwrap(),
        records.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("1 of 3 files failed"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let objects: Vec<serde_json::Value> = String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(objects.len(), 2);
    let rows: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(summary.join("summary.json")).unwrap())
            .unwrap();
    let rows = rows.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    // sorted paths: a.csv, b/a.csv, notes.txt
    for (row, (object, k)) in rows.iter().zip(objects.iter().zip([2.0e4, 5.0e4])) {
        assert_eq!(row["status"], "ok");
        assert_eq!(row["file"], object["file"]);
        assert_eq!(row["parameters"]["kappa"], object["parameters"]["kappa"]);
        let kappa = row["parameters"]["kappa"].as_f64().unwrap();
        assert!((kappa / k - 1.0).abs() < 0.03, "κ {kappa} for {k}");
        assert_eq!(row["identifiable"]["kappa"], true);
    }
    assert_eq!(rows[2]["status"], "error");
    let why = rows[2]["error"].as_str().unwrap();
    assert!(why.contains("notes.txt"), "{why}");
    let csv = std::fs::read_to_string(summary.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4);
    assert!(lines[0].contains(",kappa,") && lines[0].contains("kappa_identifiable"));
    assert!(lines[3].contains(",error,"));
}

/// A file whose force column is compression-negative (many load frames export it so) gives
/// the same estimate and diagnosis as the compression-positive file, to the bit, whether
/// `--force-sign -1` says so or the sign is detected (no contact law fits the force as
/// read; one fits it negated); the notes say which. The compression-positive file is read
/// as it is. (Before detection such a file stopped with "the contact law could not be
/// fitted" or, on taps, ended as a Kelvin-Voigt fit with a VAF near 0 % on the reversed
/// axis.)
#[test]
fn a_compression_negative_force_is_negated_given_or_detected() {
    let dir = tempfile::tempdir().unwrap();
    // Kelvin-Voigt taps at 2 Hz, 0.2 mm out to 1 mm deep, a 0.3 N offset, a little
    // deterministic wobble for noise.
    let (mut positive, mut negative) = (
        String::from("time_s,position_m,force_n\n"),
        String::from("time_s,position_m,force_n\n"),
    );
    for i in 0..4000 {
        let t = i as f64 * 1e-3;
        let w = std::f64::consts::TAU * 2.0;
        let d = -0.2e-3 + 1.2e-3 * (0.5 - 0.5 * (w * t).cos());
        let v = 0.6e-3 * w * (w * t).sin();
        let contact = laws::unilateral(laws::kelvin_voigt(d, v, 3000.0, 20.0));
        let f = 0.3 + contact + 0.01 * (1.3 * i as f64).sin();
        positive.push_str(&format!("{t:.3},{d:e},{f:e}\n"));
        negative.push_str(&format!("{t:.3},{d:e},{:e}\n", -f));
    }
    let positive = write(&dir, "positive.csv", &positive);
    let negative = write(&dir, "negative.csv", &negative);
    // (JSON on stdout, notes on stderr.)
    let run = |args: &[&str]| -> (serde_json::Value, String) {
        let o = host_sim(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        (serde_json::from_slice(&o.stdout).unwrap(), stderr(&o))
    };
    fn with_sign<'a>(args: &[&'a str], sign: Option<&'a str>) -> Vec<&'a str> {
        let mut args = args.to_vec();
        if let Some(sign) = sign {
            args.extend(["--force-sign", sign]);
        }
        args
    }
    let (p, n) = (positive.to_str().unwrap(), negative.to_str().unwrap());
    let estimate = |file: &str, sign| {
        let mut args = with_sign(&["estimate", "--model", "kelvin-voigt", "--json"], sign);
        args.push(file);
        run(&args)
    };
    let out = dir.path().join("out");
    let diagnose = |file: &str, sign| {
        let out = out.join(format!("{sign:?}"));
        let out = out.to_str().unwrap();
        let mut args = with_sign(&["diagnose", "--json", "--out", out], sign);
        args.push(file);
        run(&args).0
    };
    let (reference, as_read) = (estimate(p, Some("1")), estimate(p, None));
    assert!(
        reference.0["parameters"]["kappa"].as_f64().unwrap() > 2000.0,
        "{reference:?}"
    );
    assert_eq!(reference.0["parameters"], as_read.0["parameters"]);
    assert!(!as_read.1.contains("force negated"), "{}", as_read.1);
    let (given, detected) = (estimate(n, Some("-1")), estimate(n, None));
    for run in [&given, &detected] {
        assert_eq!(reference.0["parameters"], run.0["parameters"]);
    }
    assert!(
        given.1.contains("force negated (--force-sign -1)"),
        "{}",
        given.1
    );
    assert!(
        detected
            .1
            .contains("force negated: the file reads compression negative (detected"),
        "{}",
        detected.1
    );
    let reference = diagnose(p, Some("1"));
    for run in [
        diagnose(p, None),
        diagnose(n, Some("-1")),
        diagnose(n, None),
    ] {
        for key in ["effects_added", "final_parameters", "nrmse_percent_final"] {
            assert_eq!(reference[key], run[key], "{key}");
        }
    }
    // Given as read, the negative file is read as it is (and misfits).
    let o = host_sim(&[
        "estimate",
        "--model",
        "kelvin-voigt",
        "--force-sign",
        "1",
        n,
    ]);
    assert!(!stderr(&o).contains("force negated"), "{}", stderr(&o));
}

/// `estimate` and `diagnose` report the contact position on the file's own axis, also
/// where the position decreases into the material: the same point, the same sign, and
/// `diagnose --json` says which way the axis points (`"position_sign"`). (Before
/// 2026-11-27 `diagnose` gave the penetration axis's value, the negative of the file's, on
/// such a file: an independent generator's 13 reversed clean files showed it.)
#[test]
fn estimate_and_diagnose_report_the_contact_position_on_the_file_axis() {
    let dir = tempfile::tempdir().unwrap();
    // Kelvin-Voigt taps at 2 Hz, the surface at x = 0.0338 m, the probe moving to lower x
    // into the material, 0.2 mm out to 1 mm deep.
    let surface = 0.0338;
    let mut text = String::from("time_s,position_m,force_n\n");
    for i in 0..4000 {
        let t = i as f64 * 1e-3;
        let w = std::f64::consts::TAU * 2.0;
        let d = -0.2e-3 + 1.2e-3 * (0.5 - 0.5 * (w * t).cos());
        let v = 0.6e-3 * w * (w * t).sin();
        let f = 0.3
            + laws::unilateral(laws::kelvin_voigt(d, v, 3000.0, 20.0))
            + 0.01 * (1.3 * i as f64).sin();
        text.push_str(&format!("{t:.3},{:e},{f:e}\n", surface - d));
    }
    let file = write(&dir, "reversed.csv", &text);
    let file = file.to_str().unwrap();
    let out = dir.path().join("out");
    let json = |args: &[&str]| -> serde_json::Value {
        let o = host_sim(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let estimate = json(&["estimate", "--model", "kelvin-voigt", "--json", file]);
    let diagnose = json(&["diagnose", "--json", "--out", out.to_str().unwrap(), file]);
    let estimated = estimate["parameters"]["contact_position_m"]
        .as_f64()
        .unwrap();
    let diagnosed = diagnose["final_parameters"]["contact_position_m"]
        .as_f64()
        .unwrap();
    assert_eq!(diagnose["position_sign"].as_f64(), Some(-1.0));
    for found in [estimated, diagnosed] {
        assert!((found - surface).abs() < 20e-6, "{found} against {surface}");
    }
}
