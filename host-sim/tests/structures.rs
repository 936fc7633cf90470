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

use host_sim::recordings::{cases, run_case, table_row, Score, Structure, TABLE_HEADER};

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
            for name in ["k", "kappa", "n"] {
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
/// seed 1006 leaves 80 % of its force's variance unexplained as read (RMS 5.9 N), and the
/// negated force's Kelvin-Voigt law fits the loading curve alone at 2.3 N. Taken, it
/// reversed the axis; the negated force is taken only where its law fits the whole record
/// (`files::Loaded::with_force_sign_of`).
#[test]
fn a_misfit_record_is_not_negated_for_a_fit_of_its_loading_curve() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let case = cases()
        .into_iter()
        .find(|c| {
            c.structure == Structure::Chirp
                && c.model == estimator_core::ModelKind::KelvinVoigt
                && !c.give_offset
        })
        .expect("the Kelvin-Voigt chirp case");
    let [score] = &run_case(case, &[1006], dir.path())[..] else {
        panic!("one score");
    };
    assert!(score.error.is_none(), "{:?}", score.error);
    assert!(score.axis_right, "{}", score.describe());
}
