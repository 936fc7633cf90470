//! Readers on the four real files of `shared/data` (sample counts, monotonic time, sign
//! conventions, segments, sampling), `Record::resample`, the exact text of every error
//! kind, a CSV round trip, and "no panic on any bytes".

use std::path::{Path, PathBuf};

use host_sim::readers::{detect, read, read_bytes, ReadErrorKind};
use host_sim::record::{Format, Record, Segment};
use proptest::prelude::*;

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel)
}

const JPK: &str = "afm/brain-creep-jpk.txt";
const AFM_TAB: &str = "afm/cell-stress-relaxation.tab";
const HYSITRON: &str = "nanoindentation/steel-hysitron.txt";
const INSTRON: &str = "silicone-compression/ecoflex-00-10-A1.csv";

/// Reads a real file with auto-detection and with its explicit format; both must agree.
fn read_both(rel: &str, format: Format) -> Record {
    let path = data(rel);
    let auto = read(&path, None).unwrap_or_else(|e| panic!("auto-detect: {e}"));
    let explicit = read(&path, Some(format)).unwrap_or_else(|e| panic!("explicit: {e}"));
    assert_eq!(auto.format, format);
    assert_eq!(auto, explicit);
    assert_eq!(auto.source, path);
    assert_eq!(auto.time_s.len(), auto.position_m.len());
    assert_eq!(auto.time_s.len(), auto.force_n.len());
    assert!(
        auto.time_s.windows(2).all(|w| w[1] > w[0]),
        "time strictly increasing"
    );
    assert!(auto
        .position_m
        .iter()
        .chain(&auto.force_n)
        .all(|v| v.is_finite()));
    auto
}

fn seg<'r>(record: &'r Record, name: &str) -> &'r Segment {
    record
        .segment(name)
        .unwrap_or_else(|| panic!("segment `{name}` in {:?}", record.segments))
}

fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}

/// Median sampling interval of `time_s[range]` [s].
fn median_dt(time_s: &[f64]) -> f64 {
    let mut dt: Vec<f64> = time_s.windows(2).map(|w| w[1] - w[0]).collect();
    dt.sort_by(f64::total_cmp);
    dt[dt.len() / 2]
}

fn names(record: &Record) -> Vec<(&str, usize, usize)> {
    record
        .segments
        .iter()
        .map(|s| (s.name.as_str(), s.start, s.end))
        .collect()
}

// ---------------------------------------------------------------- real files

#[test]
fn jpk_creep_record() {
    let r = read_both(JPK, Format::Jpk);
    assert_eq!(r.len(), 9000);
    assert_eq!(
        names(&r),
        vec![
            ("extend", 0, 3000),
            ("pause", 3000, 6000),
            ("retract", 6000, 9000)
        ]
    );
    // seriesTime is continuous across the segments: 0.0005 ... 8.9995 s at 1 kHz.
    assert!((r.time_s[0] - 0.0005).abs() < 1e-12);
    assert!((r.time_s[8999] - 8.9995).abs() < 1e-9);
    let rate = r.sample_rate_hz().expect("uniform");
    assert!((rate - 1000.0).abs() < 1e-6, "{rate}");

    // Extend: the probe moves ~30 µm into the material and, after contact (~1.8 s),
    // the force rises ~10 nN above the baseline (+11.23 nN sensor offset).
    let extend = seg(&r, "extend").range();
    let baseline = mean(&r.force_n[0..1000]);
    assert!((baseline - 11.23e-9).abs() < 0.1e-9, "baseline {baseline}");
    assert!(r.position_m[extend.end - 1] - r.position_m[extend.start] > 29e-6);
    assert!(r.force_n[extend.end - 1] - baseline > 9e-9);
    let contact = r.force_n[..extend.end]
        .iter()
        .position(|&f| f - baseline > 1e-9)
        .expect("contact");
    assert!(
        (r.time_s[contact] - 1.8).abs() < 0.2,
        "contact at {} s",
        r.time_s[contact]
    );

    // Pause (force clamp): force constant while the tip creeps 1.58 µm INTO the tissue.
    let pause = seg(&r, "pause").range();
    let creep = r.position_m[pause.end - 1] - r.position_m[pause.start];
    assert!((creep - 1.58e-6).abs() < 0.02e-6, "creep {creep}");
    let (f0, f1) = (r.force_n[pause.start], r.force_n[pause.end - 1]);
    assert!((f1 - f0).abs() < 0.1e-9);
    // Creep is monotonic at the 10 ms scale.
    let p = &r.position_m[pause.clone()];
    assert!(p.windows(10).all(|w| w[9] > w[0] - 2e-9));

    // Retract: the probe leaves the material, the force falls below the baseline
    // (adhesion) at some point.
    let retract = seg(&r, "retract").range();
    assert!(r.position_m[retract.end - 1] < r.position_m[retract.start] - 20e-6);
    let min_retract = r.force_n[retract]
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    assert!(min_retract < baseline);

    assert!(
        r.notes.iter().any(|n| n.contains("k = 0.061 N/m")),
        "{:?}",
        r.notes
    );
}

#[test]
fn afm_tab_relaxation_record() {
    let r = read_both(AFM_TAB, Format::AfmTab);
    assert_eq!(r.len(), 11_935);
    assert_eq!(
        names(&r),
        vec![
            ("pre-pause", 0, 256),
            ("approach", 256, 2304),
            ("hold", 2304, 9984),
            ("retract", 9984, 11_935)
        ]
    );
    assert_eq!(r.sample_rate_hz(), None, "nonuniform by segment");
    // The retract is at 2048 Hz, not 1951 Hz as the metadata `rate retract` (and the data
    // README) say: 1951 is its number of samples, spanning 32.0 ... 32.952148 s.
    for (name, hz) in [
        ("pre-pause", 256.0),
        ("approach", 2048.0),
        ("hold", 256.0),
        ("retract", 2048.0),
    ] {
        let s = seg(&r, name).range();
        let rate = (s.len() - 1) as f64 / (r.time_s[s.end - 1] - r.time_s[s.start]);
        assert!((rate - hz).abs() / hz < 1e-4, "{name}: {rate} Hz");
    }
    assert_eq!(seg(&r, "retract").len(), 1951);

    let baseline = mean(&r.force_n[seg(&r, "pre-pause").range()]);
    assert!((baseline + 116.7e-9).abs() < 0.1e-9, "baseline {baseline}");

    // Approach: the probe moves ~20 µm into the cell and the force rises.
    let approach = seg(&r, "approach").range();
    let dx = r.position_m[approach.end - 1] - r.position_m[approach.start];
    assert!((dx - 19.65e-6).abs() < 0.1e-6, "approach {dx}");
    assert!(r.force_n[approach.end - 1] - baseline > 300e-9);

    // Hold (constant height): the force relaxes +324 -> +116 nN above the baseline while
    // the tip sinks only 0.19 µm further in (cantilever unloading).
    let hold = seg(&r, "hold").range();
    let first = r.force_n[hold.start] - baseline;
    let last = r.force_n[hold.end - 1] - baseline;
    assert!((first - 324e-9).abs() < 2e-9, "hold start {first}");
    assert!((last - 116e-9).abs() < 2e-9, "hold end {last}");
    let sink = r.position_m[hold.end - 1] - r.position_m[hold.start];
    assert!(sink > 0.0 && sink < 0.25e-6, "tip during hold {sink}");
    assert!(sink < 0.02 * dx);

    assert!(
        r.notes.iter().any(|n| n.contains("k = 1.0677 N/m")),
        "{:?}",
        r.notes
    );
}

#[test]
fn hysitron_steel_record() {
    let r = read_both(HYSITRON, Format::Hysitron);
    assert_eq!(r.len(), 5304);
    // The header's unit is Latin-1 0xB5, decoded as µ.
    assert!(
        r.notes.iter().any(|n| n.contains("`Load (µN)`")),
        "{:?}",
        r.notes
    );
    assert!(r
        .notes
        .iter()
        .any(|n| n.contains("Mon Apr 29 10:41:06 2019")));

    // Blank lines split the data into 5 sections: lift (200 Hz), approach (100 Hz), load,
    // hold, unload (200 Hz).
    assert_eq!(
        names(&r),
        vec![
            ("section 1", 0, 201),
            ("section 2", 201, 305),
            ("section 3", 305, 2305),
            ("section 4", 2305, 3305),
            ("section 5", 3305, 5304)
        ]
    );
    // Not uniform over the whole record (section 2 is at half rate), 199.8 Hz elsewhere.
    assert_eq!(r.sample_rate_hz(), None);
    let rate = 1.0 / median_dt(&r.time_s);
    assert!((rate - 199.8).abs() < 0.1, "{rate}");
    let rate2 = 1.0 / median_dt(&r.time_s[seg(&r, "section 2").range()]);
    assert!((rate2 - 100.0).abs() < 0.1, "{rate2}");

    // Load 3000 µN at ~160 nm: force and depth rise together.
    let (i_max, f_max) = r
        .force_n
        .iter()
        .copied()
        .enumerate()
        .fold((0, f64::MIN), |a, (i, f)| if f > a.1 { (i, f) } else { a });
    assert!((f_max - 3e-3).abs() < 1e-6, "max load {f_max}");
    assert!((r.position_m[i_max] - 158.5e-9).abs() < 2e-9);
    let x_max = r.position_m.iter().copied().fold(f64::MIN, f64::max);
    assert!((x_max - 159.7e-9).abs() < 0.5e-9, "max depth {x_max}");
    let load = seg(&r, "section 3").range();
    assert!(r.position_m[load.end - 1] > r.position_m[load.start] + 150e-9);
    assert!(r.force_n[load.end - 1] > r.force_n[load.start] + 2.9e-3);
    // Hold: creep 155.2 -> 159.4 nm at constant load.
    let hold = seg(&r, "section 4").range();
    assert!((r.position_m[hold.start] - 155.4e-9).abs() < 0.5e-9);
    assert!((r.position_m[hold.end - 1] - 159.4e-9).abs() < 0.5e-9);
    // Unload: plastic residual depth ~135 nm at ~2 µN.
    assert!((r.position_m[5303] - 135.0e-9).abs() < 1e-9);
}

#[test]
fn instron_silicone_record() {
    let r = read_both(INSTRON, Format::Instron);
    // 1201 rows at 10 Hz (0 ... 120.0 s) plus a final row at 120.021 s (test stopped at
    // 20 mm): 1202 data rows.
    assert_eq!(r.len(), 1202);
    assert!((r.time_s[1201] - 120.021).abs() < 1e-12);
    assert!(r.segments.is_empty());
    // One late sample breaks uniformity: no single rate, honestly.
    assert_eq!(r.sample_rate_hz(), None);
    let rate = 1.0 / median_dt(&r.time_s);
    assert!((rate - 10.0).abs() < 1e-6);
    let uniform_part = Record {
        time_s: r.time_s[..1201].to_vec(),
        position_m: r.position_m[..1201].to_vec(),
        force_n: r.force_n[..1201].to_vec(),
        ..r.clone()
    };
    let rate = uniform_part
        .sample_rate_hz()
        .expect("uniform without the last row");
    assert!((rate - 10.0).abs() < 1e-6);

    assert!((r.force_n[0] + 0.00912).abs() < 1e-12, "raw offset kept");
    assert!((r.position_m[1201] - 20.00004e-3).abs() < 1e-12);
    assert!((r.force_n[1201] - 499.32315).abs() < 1e-9);
    // Loading only: compression and load both grow.
    assert!(r.position_m.windows(2).all(|w| w[1] >= w[0]));
    let i_6mm = r.position_m.iter().position(|&x| x > 6e-3).expect("6 mm");
    assert!(r.force_n[i_6mm] > 10.0 && r.force_n[i_6mm] < r.force_n[1201] / 10.0);
    assert!(
        r.notes
            .iter()
            .any(|n| n == "metadata: Machine: INSTRON 5900"),
        "{:?}",
        r.notes
    );
    assert!(r.notes.iter().any(|n| n == "metadata: EF10_0T_A_sample_1"));
}

#[test]
fn detect_recognises_every_real_file() {
    for (rel, format) in [
        (JPK, Format::Jpk),
        (AFM_TAB, Format::AfmTab),
        (HYSITRON, Format::Hysitron),
        (INSTRON, Format::Instron),
    ] {
        let bytes = std::fs::read(data(rel)).expect("data file");
        assert_eq!(detect(&bytes), Some(format), "{rel}");
    }
    assert_eq!(
        detect(b"# a comment\ntime_s,position_m,force_n\n0,0,0\n"),
        Some(Format::Csv)
    );
}

#[test]
fn format_names_round_trip() {
    for f in Format::ALL {
        assert_eq!(f.to_string().parse::<Format>(), Ok(f));
    }
    assert_eq!("afm-tab".parse::<Format>(), Ok(Format::AfmTab));
    assert_eq!(
        "tab".parse::<Format>().unwrap_err().to_string(),
        "unknown format `tab`; expected one of csv, jpk, afm-tab, hysitron, instron"
    );
}

// ---------------------------------------------------------------- resample

#[test]
fn resample_afm_tab_to_1khz() {
    let r = read(&data(AFM_TAB), Some(Format::AfmTab)).expect("read");
    let u = r.resample(1000.0);
    // 0 ... 32.952 s on a 1 ms grid.
    assert_eq!(u.len(), 32_953);
    let rate = u.sample_rate_hz().expect("uniform");
    assert!((rate - 1000.0).abs() < 1e-6, "{rate}");
    assert_eq!(u.time_s[0], r.time_s[0]);
    // Segments start at their first grid time: 1.0 s, 2.0 s, 32.0 s.
    assert_eq!(
        names(&u),
        vec![
            ("pre-pause", 0, 1000),
            ("approach", 1000, 2000),
            ("hold", 2000, 32_000),
            ("retract", 32_000, 32_953)
        ]
    );
    for s in &u.segments {
        let orig = seg(&r, &s.name);
        let (t_lo, t_hi) = (
            r.time_s[orig.start],
            r.time_s.get(orig.end).copied().unwrap_or(f64::INFINITY),
        );
        assert!(
            u.time_s[s.range()].iter().all(|&t| t >= t_lo && t < t_hi),
            "{}",
            s.name
        );
    }
    // The hold's force level (time average, start and end) is preserved within 1 %.
    let hold_r = seg(&r, "hold").range();
    let hold_u = seg(&u, "hold").range();
    let (mr, mu) = (
        mean(&r.force_n[hold_r.clone()]),
        mean(&u.force_n[hold_u.clone()]),
    );
    assert!((mu - mr).abs() < 0.01 * mr.abs(), "hold mean {mr} -> {mu}");
    let head_r = mean(&r.force_n[hold_r.start..hold_r.start + 26]);
    let head_u = mean(&u.force_n[hold_u.start..hold_u.start + 100]);
    assert!(
        (head_u - head_r).abs() < 0.01 * head_r.abs(),
        "{head_r} -> {head_u}"
    );
    // The approach (2048 Hz -> 1000 Hz) is averaged, the hold (256 Hz) interpolated.
    assert!(u
        .notes
        .last()
        .is_some_and(|n| n.contains("resampled to 1000 Hz")));
    assert!(u.position_m.iter().chain(&u.force_n).all(|v| v.is_finite()));
}

#[test]
fn resample_interpolates_and_averages() {
    let r = Record {
        time_s: vec![0.0, 1.0, 2.0],
        position_m: vec![0.0, 1.0, 0.0],
        force_n: vec![0.0, 10.0, 20.0],
        source: PathBuf::from("mem"),
        format: Format::Csv,
        segments: vec![Segment {
            name: "all".into(),
            start: 0,
            end: 3,
        }],
        notes: vec![],
    };
    let up = r.resample(4.0);
    assert_eq!(up.len(), 9);
    assert_eq!(
        up.force_n,
        vec![0.0, 2.5, 5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0]
    );
    assert_eq!(
        up.segments,
        vec![Segment {
            name: "all".into(),
            start: 0,
            end: 9
        }]
    );
    // 0.5 Hz: intervals of ±1 s; each sample holds over its own cell, ±0.5 s (the end
    // samples' as wide outside); t = 0 averages [−1, 1) s: 0 over 1 s, 10 over 0.5 s;
    // t = 2 averages [1, 3) s: 10 over 0.5 s, 20 over 1 s.
    let down = r.resample(0.5);
    assert_eq!(down.time_s, vec![0.0, 2.0]);
    let expected = [10.0 / 3.0, 50.0 / 3.0];
    for (got, want) in down.force_n.iter().zip(expected) {
        assert!((got - want).abs() < 1e-12, "{:?}", down.force_n);
    }
    // A refused rate leaves the record and says why.
    let same = r.resample(f64::NAN);
    assert_eq!(same.time_s, r.time_s);
    assert_eq!(
        same.notes.last().map(String::as_str),
        Some("resample not done: field `rate_hz`: must be finite and > 0, got NaN")
    );
}

/// A file at an integer multiple of 1 kHz has samples on the edges of the 1 kHz grid's
/// intervals: each grid point must average the same neighbourhood, centred on it,
/// whatever the rounding or the jitter of the time stamps. Before, a plain mean of the
/// samples inside `[t_k − h/2, t_k + h/2)` took one, two or three of a 2 kHz file's
/// samples as each stamp rounded (or jittered), and the means' times moved by a quarter
/// of a millisecond (a mass on 6.5 Hz taps was fitted 29-70 % low). Now each sample
/// weighs by its own cell's overlap with the interval (2 kHz: ¼, ½, ¼).
#[test]
fn resample_of_a_faster_file_averages_a_neighbourhood_centred_on_each_grid_point() {
    for (rate, per_bin) in [(2000usize, 2usize), (4000, 4), (5000, 5)] {
        // Jitter of the time stamps, in sampling intervals: none, then up to ±10 %.
        for jitter in [0.0, 0.1] {
            // Position and force are the sample's index, so a grid point's value says
            // which samples it averaged and with what weights.
            let mut text = String::from("time_s,position_m,force_n\n");
            for i in 0..3 * rate {
                let wobble = if i == 0 {
                    0.0
                } else {
                    jitter * (i as f64 * 1.7).sin()
                };
                let t = (i as f64 + wobble) / rate as f64;
                text.push_str(&format!("{t:.7},{i},{i}\n"));
            }
            let r = read_bytes(text.as_bytes(), Path::new("mem.csv"), None).expect("read");
            let u = r.resample(1000.0);
            assert_eq!(u.len(), 3000, "{rate} Hz");
            for k in 1..u.len() - 1 {
                // Centred: the mean index is the grid point's own, per_bin·k (exactly
                // on the steady grid; within the jitter's tenth of an interval with it).
                let centre = (per_bin * k) as f64;
                let tolerance = if jitter == 0.0 { 1e-9 } else { jitter };
                for value in [u.position_m[k], u.force_n[k]] {
                    assert!(
                        (value - centre).abs() <= tolerance,
                        "{rate} Hz, jitter {jitter}, grid point {k}: {value} against {centre}"
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------- errors

/// Writes `contents` to `name` in a fresh temporary directory.
fn temp_file(contents: &[u8], name: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join(name);
    std::fs::write(&path, contents).expect("write");
    (dir, path)
}

fn error_text(contents: &[u8], format: Option<Format>) -> (String, PathBuf, tempfile::TempDir) {
    let (dir, path) = temp_file(contents, "bad.txt");
    let err = read(&path, format).expect_err("must fail");
    (err.to_string(), path, dir)
}

#[test]
fn error_empty_file() {
    for format in [None, Some(Format::Csv), Some(Format::Hysitron)] {
        let (text, path, _dir) = error_text(b"", format);
        assert_eq!(text, format!("{}: the file is empty", path.display()));
    }
}

#[test]
fn error_missing_file() {
    let path = Path::new("/nonexistent/record.csv");
    let err = read(path, None).expect_err("no file");
    assert!(matches!(err.kind, ReadErrorKind::Io(_)));
    assert_eq!(
        err.to_string(),
        "/nonexistent/record.csv: I/O error: No such file or directory (os error 2)"
    );
}

#[test]
fn error_csv_missing_column() {
    let (text, path, _dir) = error_text(
        b"time_s,position_m,force\n0,0,0\n1,1,1\n",
        Some(Format::Csv),
    );
    assert_eq!(
        text,
        format!(
            "{}:1: field `force_n`: missing column; expected `time_s`, `position_m`, \
             `force_n`; found `time_s`, `position_m`, `force`",
            path.display()
        )
    );
}

#[test]
fn error_non_numeric_cell() {
    let (text, path, _dir) =
        error_text(b"time_s,position_m,force_n\n0,0,0\n0.001,1e-6,abc\n", None);
    assert_eq!(
        text,
        format!(
            "{}:3: field `force_n`: not a number: \"abc\"",
            path.display()
        )
    );
}

#[test]
fn error_nan_cell() {
    let (text, path, _dir) = error_text(b"time_s,position_m,force_n\n0,0,0\n0.001,NaN,1\n", None);
    assert_eq!(
        text,
        format!(
            "{}:3: field `position_m`: not finite: \"NaN\"",
            path.display()
        )
    );
}

#[test]
fn error_time_backwards() {
    let csv = b"# comment line\ntime_s,position_m,force_n\n0,0,0\n0.002,0,0\n\n0.001,0,0\n";
    let (text, path, _dir) = error_text(csv, None);
    assert_eq!(
        text,
        format!(
            "{}:6: field `time_s`: time not strictly increasing: 0.001 s here, 0.002 s on \
             line 4",
            path.display()
        )
    );
    // A repeated timestamp is refused too.
    let (text, path, _dir) = error_text(b"time_s,position_m,force_n\n0,0,0\n0,0,0\n", None);
    assert_eq!(
        text,
        format!(
            "{}:3: field `time_s`: time not strictly increasing: 0 s here, 0 s on line 2",
            path.display()
        )
    );
}

#[test]
fn error_too_few_samples_and_no_data() {
    let (text, path, _dir) = error_text(b"time_s,position_m,force_n\n0,0,0\n", None);
    assert_eq!(
        text,
        format!(
            "{}:2: only 1 data row(s); at least 2 are needed",
            path.display()
        )
    );
    let (text, path, _dir) = error_text(b"time_s,position_m,force_n\n", None);
    assert_eq!(text, format!("{}:1: no data rows", path.display()));
}

#[test]
fn error_row_length() {
    let (text, path, _dir) = error_text(b"time_s,position_m,force_n\n0,0,0\n1,1\n", None);
    assert_eq!(
        text,
        format!(
            "{}:3: row has 2 cells, the header on line 1 has 3",
            path.display()
        )
    );
}

#[test]
fn error_truncated_hysitron() {
    let full = std::fs::read(data(HYSITRON)).expect("data file");
    // Keep the 4 header lines and the first 100 data lines (lines 5-104).
    let cut = full
        .iter()
        .enumerate()
        .filter(|(_, &b)| b == b'\n')
        .nth(103)
        .map(|(i, _)| i + 1)
        .expect("enough lines");
    let (text, path, _dir) = error_text(&full[..cut], None);
    assert_eq!(
        text,
        format!(
            "{}:3: field `Number of Points`: the header declares 5304 points but 100 data \
             rows were found (lines 5-104)",
            path.display()
        )
    );
}

#[test]
fn error_undetectable_format() {
    let (text, path, _dir) = error_text(b"t;x;f\n0;0;0\n", None);
    assert_eq!(
        text,
        format!(
            "{}: unknown format; tried jpk (first line `# TEXT EXPORT`), afm-tab (first line \
             starting `# afmformats`), hysitron (a line `Number of Points =` and a header with \
             `Depth (nm)`), instron (a header line starting `Time (s),` with `Load (N)`), csv \
             (a header with `time_s`)",
            path.display()
        )
    );
}

#[test]
fn error_hysitron_missing_column_names_latin1_header() {
    let bytes =
        b"date\n\nNumber of Points = 2\nDepth (nm)\tForce (\xb5N)\tTime (s)\n1\t2\t0\n2\t3\t1\n";
    let (text, path, _dir) = error_text(bytes, None);
    assert_eq!(
        text,
        format!(
            "{}:4: field `Load (µN)`: missing column; expected `Depth (nm)`, `Load (µN)`, \
             `Time (s)`; found `Depth (nm)`, `Force (µN)`, `Time (s)`",
            path.display()
        )
    );
}

#[test]
fn error_csv_without_header() {
    let (text, path, _dir) = error_text(b"# only a comment\n\n", Some(Format::Csv));
    assert_eq!(
        text,
        format!(
            "{}: field `time_s`: missing column; expected `time_s`, `position_m`, \
             `force_n`; found none",
            path.display()
        )
    );
}

#[test]
fn hysitron_accepts_utf8_micro_sign() {
    // Same header with the µ in UTF-8 (0xC2 0xB5) instead of Latin-1.
    let bytes =
        b"date\n\nNumber of Points = 2\nDepth (nm)\tLoad (\xc2\xb5N)\tTime (s)\n1\t2\t0\n2\t3\t1\n";
    let r = read_bytes(bytes, Path::new("mem"), None).expect("read");
    assert_eq!(r.force_n, vec![2e-6, 3e-6]);
    assert_eq!(r.position_m, vec![1e-9, 2e-9]);
}

#[test]
fn error_jpk_and_afm_tab_headers() {
    let jpk = b"# TEXT EXPORT\r\n# segment: extend\r\n# columns: vDeflection measuredHeight seriesTime\r\n\
                # units: nN m s\r\n# springConstant: 0.1\r\n1 2 3\r\n";
    let (text, path, _dir) = error_text(jpk, None);
    assert_eq!(
        text,
        format!(
            "{}:4: field `vDeflection`: unit `nN`, expected `N`",
            path.display()
        )
    );
    let tab = b"# afmformats 0.18.7\n# BEGIN METADATA\n# {\"k\": 1}\n# END METADATA\n\
                # force\theight (measured)\ttime\n1\t2\t0\n";
    let (text, path, _dir) = error_text(tab, None);
    assert_eq!(
        text,
        format!(
            "{}: field `spring constant`: missing from the metadata",
            path.display()
        )
    );
}

// ---------------------------------------------------------------- round trip

#[test]
fn csv_round_trip_keeps_values_and_segments() {
    let r = read(&data(AFM_TAB), None).expect("read");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("log.csv");
    r.write_csv(&path).expect("write");
    let back = read(&path, None).expect("read back");
    assert_eq!(back.format, Format::Csv);
    assert_eq!(back.time_s, r.time_s);
    assert_eq!(back.position_m, r.position_m);
    assert_eq!(back.force_n, r.force_n);
    assert_eq!(back.segments, r.segments);

    // Column order is free and extra columns are ignored.
    let (_d, p) = temp_file(
        b"force_n,extra,time_s,position_m\n1,x,0,2\n3,y,1,4\n",
        "free.csv",
    );
    let free = read(&p, None).expect("read");
    assert_eq!(
        (free.time_s, free.position_m, free.force_n),
        (vec![0.0, 1.0], vec![2.0, 4.0], vec![1.0, 3.0])
    );
}

#[test]
fn write_csv_reports_the_path() {
    let r = read(&data(INSTRON), None).expect("read");
    let err = r
        .write_csv(Path::new("/nonexistent/dir/out.csv"))
        .expect_err("no dir");
    assert!(
        err.to_string()
            .starts_with("/nonexistent/dir/out.csv: I/O error: "),
        "{err}"
    );
}

// ---------------------------------------------------------------- robustness

/// A small valid file of each format, seeds for the mutation proptest.
const SAMPLES: [(&[u8], Format); 5] = [
    (
        b"time_s,position_m,force_n,segment\n0,0,0,a\n0.001,1e-6,2e-3,a\n0.002,2e-6,3e-3,b\n",
        Format::Csv,
    ),
    (
        b"# TEXT EXPORT\r\n# segment: extend\r\n# recorded-num-points: 2\r\n\
          # columns: vDeflection measuredHeight seriesTime\r\n# units: N m s\r\n\
          # springConstant: 0.061\r\n1e-9 2e-5 0.1\r\n2e-9 1e-5 0.2\r\n",
        Format::Jpk,
    ),
    (
        b"# afmformats 0.18.7\n# BEGIN METADATA\n\
          # {\"spring constant\": 1.0, \"imaging mode\": \"stress-relaxation\"}\n\
          # END METADATA\n# force\theight (measured)\tsegment\ttime\n\
          1e-9\t1e-4\t0\t0\n2e-9\t1e-4\t3\t1\n",
        Format::AfmTab,
    ),
    (
        b"date\n\nNumber of Points = 2\nDepth (nm)\tLoad (\xb5N)\tTime (s)\n1\t2\t0\n\n2\t3\t1\n",
        Format::Hysitron,
    ),
    (
        b"meta;\nTime (s),Compression (mm),Load (N)\n0,0,0\n0.1,1,2\n",
        Format::Instron,
    ),
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// No reader panics on arbitrary bytes.
    #[test]
    fn readers_never_panic_on_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let path = Path::new("fuzz");
        let _ = read_bytes(&bytes, path, None);
        for f in Format::ALL {
            let _ = read_bytes(&bytes, path, Some(f));
        }
    }

    /// ... nor on mutations of realistic headers.
    #[test]
    fn readers_never_panic_on_mutated_files(
        which in 0usize..5,
        cut in 0usize..3000,
        flips in proptest::collection::vec((0usize..3000, any::<u8>()), 0..8),
    ) {
        let sample = SAMPLES[which].0;
        let mut bytes = sample.to_vec();
        for (at, b) in flips {
            if let Some(slot) = bytes.get_mut(at % sample.len()) {
                *slot = b;
            }
        }
        bytes.truncate(cut);
        let path = Path::new("fuzz");
        let _ = read_bytes(&bytes, path, None);
        for f in Format::ALL {
            if let Ok(r) = read_bytes(&bytes, path, Some(f)) {
                prop_assert!(r.len() >= 2);
                prop_assert!(r.time_s.windows(2).all(|w| w[1] > w[0]));
                prop_assert!(r.segments.iter().all(|s| s.start <= s.end && s.end <= r.len()));
                let u = r.resample(1000.0);
                prop_assert!(u.segments.iter().all(|s| s.start <= s.end && s.end <= u.len()));
            }
        }
    }
}

#[test]
fn mutated_samples_are_valid_before_mutation() {
    // The unmutated samples of the proptest read cleanly (so the proptest explores the
    // neighbourhood of valid files, not only of garbage).
    for (bytes, format) in SAMPLES {
        let r =
            read_bytes(bytes, Path::new("mem"), None).unwrap_or_else(|e| panic!("{format}: {e}"));
        assert_eq!(r.format, format);
        assert!(r.len() >= 2);
    }
}
