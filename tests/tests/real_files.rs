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
        run.result.contact_position_m,
        run.result.force_offset_n
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

#[test]
fn steel_nanoindentation_loading_exponent_is_near_1_5() {
    // README: P ~ h^1.50 on loading (log-log slope with the instrument's zero: 1.49).
    let single = run(
        "nanoindentation/steel-hysitron.txt",
        ModelKind::HuntCrossleySingleStage,
        Some(Phase::Loading),
    );
    let n = exponent(&single.result.parameters);
    assert!((1.45..=1.65).contains(&n), "n = {n}");
    assert!(single.result.nrmse_percent.unwrap() < 6.0);
    // The power-law elastic stage of the Hammerstein model agrees.
    let ham = run(
        "nanoindentation/steel-hysitron.txt",
        ModelKind::Hammerstein1,
        None,
    );
    let g2 = exponent(&ham.result.parameters);
    assert!((g2 - n).abs() < 0.05, "gamma2 {g2} vs n {n}");
    // The contact is found within a few nm of the instrument's own zero.
    assert!(single.result.contact_position_m.abs() < 5e-9);
    // Load-controlled: ~2.5 s out of contact, then loading, hold, unloading.
    let phases: Vec<Phase> = host_sim::phases::segments(&single.result.trace.phase)
        .iter()
        .map(|s| s.0)
        .collect();
    for p in [
        Phase::FreeSpace,
        Phase::Loading,
        Phase::Hold,
        Phase::Unloading,
    ] {
        assert!(phases.contains(&p), "{p:?} not detected: {phases:?}");
    }
}

#[test]
fn silicone_compression_starts_in_contact_and_stiffens() {
    let r = run(
        "silicone-compression/ecoflex-00-10-A1.csv",
        ModelKind::HuntCrossleySingleStage,
        None,
    );
    // The test starts touching the sample: the contact point is the first position.
    assert!(
        r.result.contact_position_m.abs() < 0.1e-3,
        "{}",
        r.result.contact_position_m
    );
    // Strong stiffening (local slope 1.1 → 2.3): one exponent between them, and a single
    // power law fits only roughly (README).
    let n = exponent(&r.result.parameters);
    assert!((1.1..=2.3).contains(&n), "n = {n}");
    assert!(r.result.nrmse_percent.unwrap() > 5.0);
    // Kelvin-Voigt, linear, fits no better.
    let kv = run(
        "silicone-compression/ecoflex-00-10-A1.csv",
        ModelKind::KelvinVoigt,
        None,
    );
    assert!(kv.result.nrmse_percent.unwrap() >= r.result.nrmse_percent.unwrap() - 1.0);
}

#[test]
fn afm_brain_creep_offset_and_contact() {
    let r = run("afm/brain-creep-jpk.txt", ModelKind::Hammerstein1, None);
    // README: force offset +11.23 nN, larger than the contact force.
    assert!(
        (r.result.force_offset_n - 11.23e-9).abs() < 0.1e-9,
        "{}",
        r.result.force_offset_n
    );
    // Contact near t = 1.8 s.
    let first = r.result.first_contact.unwrap() as f64 * 1e-3;
    assert!((1.4..=2.0).contains(&first), "first contact at {first} s");
    assert!(r.result.nrmse_percent.unwrap() < 5.0);
    // The clamp creeps (position into the material grows at constant force), which a
    // relaxation filter can only follow as a pole at the unit circle.
    let single = run(
        "afm/brain-creep-jpk.txt",
        ModelKind::HuntCrossleySingleStage,
        Some(Phase::Loading),
    );
    assert!(single.result.nrmse_percent.unwrap() < 6.0);
}

#[test]
fn afm_cell_stress_relaxation_shows_relaxation() {
    let r = run(
        "afm/cell-stress-relaxation.tab",
        ModelKind::Hammerstein1,
        None,
    );
    let AnyParameters::Hammerstein { a, b, .. } = r.result.parameters else {
        panic!()
    };
    // README: the force relaxes by 64 % over the 30 s hold (several time constants).
    let c0 = (1.0 + f64::from(b[0])) / (1.0 + f64::from(a[0]));
    let rate = -(-f64::from(a[0])).ln() / 1e-3;
    println!("relaxed fraction c0 = {c0:.3}, rate = {rate:.3} 1/s");
    assert!((0.2..=0.6).contains(&c0), "c0 = {c0}");
    assert!((0.05..=2.0).contains(&rate), "rate = {rate}");
    assert!(r.result.nrmse_percent.unwrap() < 5.0);
    // README: offset −116.7 nN.
    assert!(
        (r.result.force_offset_n + 116.7e-9).abs() < 1e-9,
        "{}",
        r.result.force_offset_n
    );
}
