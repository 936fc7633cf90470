//! The shipped real files (../shared/data) through the same pipeline as the firmware,
//! configured from each record by host_sim::setup (never per file). The assertions are
//! physical sanity, from the data README: the numbers themselves are in the README table.

use estimator_core::{AnyParameters, ModelKind};
use host_sim::files::{estimate_file, FileRun};
use host_sim::phases::Phase;
use host_sim::setup::Overrides;

fn run(file: &str, model: ModelKind, phase: Option<Phase>) -> FileRun {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(file);
    let run = estimate_file(
        model,
        &path,
        "auto",
        &Overrides::default(),
        phase.map(|p| vec![p]),
    )
    .unwrap_or_else(|e| panic!("{file}: {e:#}"));
    println!(
        "{file} {}: {:?} NRMSE {:?} contact {:.4e} m offset {:.4e} N",
        model.name(),
        run.result.parameters,
        run.result.nrmse_percent,
        run.front_end.contact_position_m,
        run.front_end.force_offset_n
    );
    run
}

fn exponent(p: &AnyParameters) -> f32 {
    match *p {
        AnyParameters::HuntCrossley(p) => p.n,
        AnyParameters::Hammerstein { gamma2, .. } => gamma2,
        _ => f32::NAN,
    }
}

/// Slope of ln F against ln δ over the loading samples of a run (the phase the estimator
/// saw as loading, forces from 10 % of the range up: the first tenth is the indenter
/// tip's rounding, excluded as in nanoindentation practice), with δ and F measured from
/// the front end's contact point and offset.
fn log_log_slope(run: &FileRun) -> f64 {
    let t = &run.result.trace;
    let range = t.force_n.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - t.force_n.iter().copied().fold(f64::INFINITY, f64::min);
    let pts: Vec<(f64, f64)> = (0..t.depth_m.len())
        .filter(|&i| {
            t.phase[i] == Phase::Loading && t.depth_m[i] > 0.0 && t.force_n[i] > 0.1 * range
        })
        .map(|i| (t.depth_m[i].ln(), t.force_n[i].ln()))
        .collect();
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum::<f64>()
}

#[test]
fn steel_nanoindentation_is_fitted_on_its_loading_curve() {
    // Plastic: the unloading returns to zero force ~140 nm deep, which no elastic law
    // describes, so the front end fits (and the estimator runs on) the loading curve, and
    // both Hunt-Crossley estimators return the exponent a direct log-log fit of that
    // curve gives (the criterion, 5 %). Measured: n = 1.75 (double stage) and
    // 1.79 (single), log-log 1.79 with the front end's zero (1.48 with the instrument's:
    // the onset is not one power law, see the README).
    for model in [ModelKind::HuntCrossley, ModelKind::HuntCrossleySingleStage] {
        let r = run("nanoindentation/steel-hysitron.txt", model, None);
        assert!(r.front_end.loading_only);
        assert!(r.front_end.offset_identifiable());
        let n = f64::from(exponent(&r.result.parameters));
        let slope = log_log_slope(&r);
        println!("{}: n = {n:.3}, log-log slope {slope:.3}", model.name());
        assert!((n / slope - 1.0).abs() < 0.05, "n = {n}, log-log {slope}");
        // Between Hertz (1.5) and Kick (2), not at a bound.
        assert!((1.4..=2.1).contains(&n), "n = {n}");
        assert_eq!(r.identifiable.get("n"), Some(&true));
        assert_eq!(r.held.get("lambda"), Some(&0.0));
        // Found within 20 nm of the instrument's own zero, with a load offset under 1 %
        // of the 3000 µN peak.
        assert!(r.front_end.contact_position_m.abs() < 20e-9);
        assert!(r.front_end.force_offset_n.abs() < 30e-6);
        let phases: Vec<Phase> = host_sim::phases::segments(&r.result.trace.phase)
            .iter()
            .map(|s| s.0)
            .collect();
        for p in [Phase::Loading, Phase::Hold, Phase::Unloading] {
            assert!(phases.contains(&p), "{p:?} not detected: {phases:?}");
        }
    }
}

#[test]
fn silicone_compression_starts_in_contact_and_says_the_offset_is_not_determined() {
    let r = run(
        "silicone-compression/ecoflex-00-10-A1.csv",
        ModelKind::HuntCrossley,
        None,
    );
    // The test starts touching the sample and never leaves it: the offset is held at 0
    // (the machine's own zero) and flagged, the contact point extrapolated near the first
    // position.
    assert!(!r.front_end.offset_identifiable());
    assert_eq!(r.front_end.force_offset_n, 0.0);
    assert!(r
        .warnings
        .iter()
        .any(|w| w.contains("force offset is not identifiable")));
    assert!(
        r.front_end.contact_position_m.abs() < 0.1e-3,
        "{}",
        r.front_end.contact_position_m
    );
    // Strong stiffening (local slope 1.1 → 2.3): one exponent between them, reported as
    // not determined (it rests on the held offset), and a single power law fits only
    // roughly.
    let n = exponent(&r.result.parameters);
    assert!((1.1..=2.3).contains(&n), "n = {n}");
    assert_eq!(r.identifiable.get("n"), Some(&false));
    assert!(r.result.nrmse_percent.unwrap() > 5.0);
    // One constant speed: damping is the stiffness's own regressor, held at 0.
    assert_eq!(r.held.get("lambda"), Some(&0.0));
}

#[test]
fn afm_brain_creep_offset_and_contact() {
    let r = run("afm/brain-creep-jpk.txt", ModelKind::Hammerstein1, None);
    // README: force offset +11.23 nN, larger than the contact force. The relaxation law
    // is fitted to the whole record, whose retract dips below the baseline (adhesion, not
    // a candidate): measured 10.72 nN; the loading-curve fit below finds 11.24 nN.
    assert!(
        (r.front_end.force_offset_n - 11.23e-9).abs() < 1e-9,
        "{}",
        r.front_end.force_offset_n
    );
    // Contact near t = 1.8 s.
    let first = r.result.first_contact.unwrap() as f64 * 1e-3;
    assert!((1.4..=2.0).contains(&first), "first contact at {first} s");
    assert!(r.result.nrmse_percent.unwrap() < 6.0);
    // The force clamp creeps (the probe moves in at constant force): a memoryless law
    // describes the approach's loading curve only.
    let single = run("afm/brain-creep-jpk.txt", ModelKind::HuntCrossley, None);
    assert!(single.front_end.loading_only);
    assert!((single.front_end.force_offset_n - 11.23e-9).abs() < 0.1e-9);
    assert!(single.result.nrmse_percent.unwrap() < 6.0);
}

#[test]
fn afm_cell_stress_relaxation_shows_relaxation() {
    // The approach's force rises from the first sample: whether the 1 s pause before it
    // is free space or already a light contact, the record cannot tell (both fit); the
    // offset is flagged as not determined.
    let r = run(
        "afm/cell-stress-relaxation.tab",
        ModelKind::Hammerstein1,
        None,
    );
    assert!(!r.front_end.offset_identifiable());
    // With the offset the data README gives (−116.7 nN, the pause's mean), the
    // relaxation is found.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/afm/cell-stress-relaxation.tab");
    let given = Overrides {
        front_end: host_sim::frontend::Options {
            force_offset_n: Some(-116.7e-9),
            ..host_sim::frontend::Options::default()
        },
        ..Overrides::default()
    };
    let r = estimate_file(ModelKind::Hammerstein1, &path, "auto", &given, None).unwrap();
    let AnyParameters::Hammerstein { a, b, .. } = r.result.parameters else {
        panic!()
    };
    // README: the force relaxes by 64 % over the 30 s hold (several time constants).
    let c0 = (1.0 + f64::from(b[0])) / (1.0 + f64::from(a[0]));
    let rate = -(-f64::from(a[0])).ln() / 1e-3;
    println!(
        "relaxed fraction c0 = {c0:.3}, rate = {rate:.3} 1/s, NRMSE {:?}",
        r.result.nrmse_percent
    );
    assert!((0.2..=0.6).contains(&c0), "c0 = {c0}");
    assert!((0.05..=2.0).contains(&rate), "rate = {rate}");
    assert!(r.result.nrmse_percent.unwrap() < 5.0);
}
