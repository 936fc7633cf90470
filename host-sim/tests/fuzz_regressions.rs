//! The fuzzing corpus kept as a regression suite on stable Rust: every file under
//! `tests/fuzz_regressions/` goes through every reader (each format forced, and
//! auto-detection) and through the telemetry decoder. None may panic; a record that is
//! returned keeps the readers' invariants.
//!
//! Files named `seed-*` are small valid inputs built from the first lines of the real
//! files (and, for telemetry, three encoded frames): the fuzzers' seeds, checked here to
//! read as their format. Files named `crash-<target>-*` are inputs on which a fuzz
//! target (`fuzz/`, cargo-fuzz) once panicked.

use std::path::{Path, PathBuf};

use host_sim::readers::{detect, read_bytes};
use host_sim::record::{Format, Record};
use host_sim::telemetry;

fn corpus() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("the corpus directory exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

fn check_invariants(record: &Record, file: &Path) {
    let n = record.len();
    assert!(n >= 2, "{}", file.display());
    assert_eq!(record.position_m.len(), n, "{}", file.display());
    assert_eq!(record.force_n.len(), n, "{}", file.display());
    assert!(
        record.time_s.windows(2).all(|w| w[1] > w[0]),
        "{}",
        file.display()
    );
    let values = record
        .time_s
        .iter()
        .chain(&record.position_m)
        .chain(&record.force_n);
    assert!(values.copied().all(f64::is_finite), "{}", file.display());
}

#[test]
fn no_reader_panics_on_the_corpus() {
    let files = corpus();
    assert!(files.len() >= 6, "{files:?}");
    for file in &files {
        let bytes = std::fs::read(file).expect("readable file");
        let _ = detect(&bytes);
        let formats = Format::ALL.into_iter().map(Some).chain([None]);
        for format in formats {
            if let Ok(record) = read_bytes(&bytes, file, format) {
                check_invariants(&record, file);
            }
        }
    }
}

#[test]
fn the_telemetry_decoder_does_not_panic_on_the_corpus() {
    for file in corpus() {
        let bytes = std::fs::read(&file).expect("readable file");
        let d = telemetry::decode(&bytes);
        // Every 0x00 that ends a non-empty frame yields one message or one error; a tail
        // without a 0x00 is reported as truncated.
        let (frames, tail) = telemetry::frame_counts(&bytes);
        assert_eq!(
            d.messages.len() + d.errors.len(),
            frames,
            "{}",
            file.display()
        );
        assert_eq!(d.truncated, tail, "{}", file.display());
    }
}

#[test]
fn the_seeds_read_as_their_format() {
    let seeds = [
        ("seed-csv.csv", Format::Csv),
        ("seed-jpk.txt", Format::Jpk),
        ("seed-afm-tab.tab", Format::AfmTab),
        ("seed-hysitron.txt", Format::Hysitron),
        ("seed-instron.csv", Format::Instron),
    ];
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_regressions");
    for (name, format) in seeds {
        let path = dir.join(name);
        let bytes = std::fs::read(&path).expect("seed exists");
        assert_eq!(detect(&bytes), Some(format), "{name}");
        let record = read_bytes(&bytes, &path, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        check_invariants(&record, &path);
    }
    let stream = std::fs::read(dir.join("seed-telemetry.bin")).expect("seed exists");
    let d = telemetry::decode(&stream);
    assert_eq!((d.frames.len(), d.errors.len(), d.missing), (3, 0, 2));
}
