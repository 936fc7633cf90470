//! `estimate` on recordings of every structure of `host_sim::recordings` (start in or out
//! of contact; approach or none; brief, long or no lift-offs; sines, a chirp, constant-speed
//! ramps loading only / loading and unloading / three speeds, ramp-and-hold, taps;
//! 100 Hz-10 kHz; offsets of either sign up to half the force range; both axis
//! orientations; white or AR(1) noise with ADC and encoder quantisation), on seeds never
//! used while tuning (tuning used seeds 0-5; these use 2000+ and 1000-1019).
//!
//! What always holds, and is asserted on every run: `estimate` succeeds, finds the axis
//! orientation, flags the offset (and what depends on it) when the record never leaves
//! contact. What holds on most runs, asserted as a rate: every parameter reported
//! identifiable is within the tolerance (n, F(1 mm) 5 %, κ 3 %, λ 30 %), or the
//! run warns that its online estimate differs from the whole-record fit. The per-case
//! table of the 20-seed run is in the README.

use estimator_core::{AnyParameters, ModelKind};
use host_sim::files::estimate_file;
use host_sim::frontend::{OffsetSource, Options};
use host_sim::recordings::{
    cases, generate, run_case, table_row, MaterialKind, Score, Structure, TABLE_HEADER,
};
use host_sim::setup::Overrides;

fn run(seeds: &[u64]) -> Vec<Score> {
    let dir = tempfile::tempdir().expect("a temporary directory");
    println!("{TABLE_HEADER}");
    let mut all = Vec::new();
    for case in cases() {
        let scores = run_case(case, seeds, dir.path());
        println!("{}", table_row(case, &scores));
        all.extend(scores);
    }
    all
}

/// The guarantees every run must keep.
fn assert_guarantees(scores: &[Score]) {
    for s in scores {
        let what = format!(
            "{} {:?} {} seed {}",
            s.structure.name(),
            s.material,
            s.model,
            s.seed
        );
        assert!(s.error.is_none(), "{what}: {:?}", s.error);
        assert!(s.axis_right, "{what}: wrong axis orientation");
        if s.structure == Structure::NeverLeaves && !s.offset_given {
            assert!(!s.offset_determined, "{what}: offset claimed determined");
        }
        if !s.offset_determined {
            // (κ may be: a linear law that pushes throughout trades its offset with the
            // contact point alone, `FrontEnd::linear_law_pushes_throughout`; its value is
            // then held to the tolerance by the pass rate.)
            for name in ["k", "n"] {
                assert!(
                    !(s.identifiable.contains_key(name) && s.is_identifiable(name)),
                    "{what}: {name} reported identifiable with the offset undetermined"
                );
            }
        }
    }
}

/// Runs every case on `seeds`, asserts the guarantees, prints the failures, and asserts
/// the fractions of runs passing (at least `min_pass`) and silently wrong (at most
/// `max_silent`).
fn check(seeds: &[u64], min_pass: f64, max_silent: f64) {
    let scores = run(seeds);
    assert_guarantees(&scores);
    for s in scores.iter().filter(|s| !s.passes()) {
        println!("{}", s.describe());
    }
    let n = scores.len() as f64;
    let pass = scores.iter().filter(|s| s.passes()).count() as f64 / n;
    let silent = scores.iter().filter(|s| s.fails_silently()).count() as f64 / n;
    println!(
        "pass {:.1} %, silently wrong {:.1} %",
        100.0 * pass,
        100.0 * silent
    );
    assert!(pass >= min_pass, "pass rate {pass}");
    assert!(silent <= max_silent, "silently wrong {silent}");
}

#[test]
fn every_structure_runs_with_its_axis_and_offset_flags_and_mostly_within_tolerance() {
    // Measured on seeds 1000-1019 (README): see `structure_table_on_unseen_seeds`.
    check(&[2000, 2001], 0.80, 0.08);
}

/// The README's table: 20 unseen seeds per structure × estimator (6 min on 2 cores in the
/// test profile; `.ci/run` runs it with `-- --ignored --nocapture`).
#[test]
#[ignore]
fn structure_table_on_unseen_seeds() {
    let seeds: Vec<u64> = (1000..1020).collect();
    check(&seeds, 0.85, 0.05);
}

/// A record whose law misfits as read is not taken for a compression-negative one because
/// its negated force fits its loading curve better: the Kelvin-Voigt chirp from contact of
/// seed 1006 (offset −9.94 N), given a wrong offset of 0 N (`--force-offset-n 0`), leaves
/// 80 % of its force's variance unexplained as read (RMS 5.9 N), and the negated force's
/// Kelvin-Voigt law fits the loading curve alone at 2.3 N on the reversed axis. Taken, it
/// reversed the axis; the negated force is taken only where its law fits the whole record
/// (`files::Loaded::with_force_sign_of`). (Until 2026-11-27 the front end itself held this
/// record's offset at 0, its points behind the contact point too close to it to pin the
/// offset; the points where the damped material lets go of the probe now pin it, and the
/// record as read fits: `the_points_a_damped_material_lets_go_pin_the_offset`.)
#[test]
fn a_misfit_record_is_not_negated_for_a_fit_of_its_loading_curve() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let recording = generate(Structure::Chirp, MaterialKind::KelvinVoigt, 1006);
    let path = dir.path().join("chirp-1006.csv");
    std::fs::write(&path, recording.to_csv()).expect("writable");
    let overrides = Overrides {
        front_end: Options {
            position_sign: None,
            force_offset_n: Some(0.0),
        },
        ..Default::default()
    };
    let run = estimate_file(ModelKind::KelvinVoigt, &path, "csv", &overrides, None)
        .expect("estimate runs");
    assert_eq!(
        run.front_end.position_sign, recording.truth.axis_sign,
        "{:?}",
        run.notes
    );
    assert!(
        !run.notes.iter().any(|n| n.contains("force negated")),
        "{:?}",
        run.notes
    );
    // It is the misfit the rule guards against: the law leaves most of the variance.
    assert!(run.result.vaf_percent.is_some_and(|v| v < 50.0));
}

/// The Kelvin-Voigt chirp from contact of seed 1006 lifts off only 0.11 mm behind its
/// contact point (within 5 noise deviations of contact force: a linear law could trade
/// offset for contact point there), but the damped material lets go of the probe on the
/// chirp's fast retracts (κδ + λδ̇ < 0), and 2448 samples read the offset there. They pin
/// it: the offset, κ and λ are determined and right. Before 2026-11-27 the offset was held
/// at 0 N against the truth's −9.94 N (NRMSE 24 %, VAF −19 %, κ 31 % low).
#[test]
fn the_points_a_damped_material_lets_go_pin_the_offset() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let recording = generate(Structure::Chirp, MaterialKind::KelvinVoigt, 1006);
    let path = dir.path().join("chirp-1006.csv");
    std::fs::write(&path, recording.to_csv()).expect("writable");
    let run = estimate_file(
        ModelKind::KelvinVoigt,
        &path,
        "csv",
        &Overrides::default(),
        None,
    )
    .expect("estimate runs");
    let truth = &recording.truth;
    assert!(
        matches!(run.front_end.offset, OffsetSource::FreeSpace { released, .. } if released > 1000),
        "{:?}",
        run.front_end.offset
    );
    // Within a quarter of one sample's noise deviation (0.14 N).
    assert!(
        (run.front_end.force_offset_n - truth.offset_n).abs() < 0.25 * truth.noise_n,
        "{} against {}",
        run.front_end.force_offset_n,
        truth.offset_n
    );
    let AnyParameters::KelvinVoigt(p) = run.result.parameters else {
        panic!("Kelvin-Voigt parameters");
    };
    assert!(
        (f64::from(p.kappa) / truth.stiffness - 1.0).abs() < 0.01,
        "{p:?}"
    );
    assert!(
        (f64::from(p.lambda) / truth.lambda - 1.0).abs() < 0.02,
        "{p:?}"
    );
    assert!(
        run.identifiable.values().all(|&i| i),
        "{:?}",
        run.identifiable
    );
}
