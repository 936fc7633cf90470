//! The discrepancy workflow on constant-speed indentations (the most common lab test),
//! written as CSV files and read back like a user's: at one speed, damping λ·δ^q·δ̇ is
//! (λv)·δ^q, a power-law spring, and the elastic reading is the physical one. A record
//! that loads and unloads at that speed separates them (damping would show hysteresis),
//! but not damping from Coulomb friction (both ±F at ±v) or a mass (δ̈ = 0 but at the
//! reversal): those two are listed, not tried.

use std::io::Write as _;
use std::path::Path;

use host_sim::diagnose::catalogue::Param;
use host_sim::diagnose::{Diagnosis, Options};
use host_sim::files::diagnose_file;
use host_sim::setup::Overrides;
use rand::{Rng as _, SeedableRng as _};
use rand_distr::StandardNormal;

/// F = k·δⁿ with k = 2e6 N/m^n, approached from 1 mm out at 1 mm/s, loaded to 3 mm,
/// optionally unloaded back out; 1 kHz; white noise of `noise_n`.
fn ramp(dir: &Path, name: &str, n: f64, noise_n: f64, unload: bool, seed: u64) -> Diagnosis {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let (v, dt) = (1e-3, 1e-3);
    let mut x: Vec<f64> = (0..4000).map(|i| -1e-3 + v * dt * i as f64).collect();
    if unload {
        let back: Vec<f64> = x.iter().rev().copied().collect();
        x.extend(back);
    }
    let path = dir.join(name);
    let mut f = std::fs::File::create(&path).expect("create");
    writeln!(f, "time_s,position_m,force_n").expect("write");
    for (i, xi) in x.iter().enumerate() {
        let e: f64 = rng.sample(StandardNormal);
        let force = 2e6 * xi.max(0.0).powf(n) + noise_n * e;
        writeln!(f, "{:.6},{:.9e},{:.9e}", i as f64 * dt, xi, force).expect("write");
    }
    drop(f);
    diagnose_file(
        &path,
        "auto",
        &Options::default(),
        &Overrides::default(),
        None,
    )
    .unwrap_or_else(|e| panic!("{name}: {e:#}"))
    .diagnosis
}

fn exponent(d: &Diagnosis) -> f64 {
    d.final_fit.parameter(Param::N).expect("a power law")
}

#[test]
fn loading_ramp_names_the_power_law_never_damping() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (name, n, noise) in [
        ("clean-1.3.csv", 1.3, 0.0),
        ("noisy-1.3.csv", 1.3, 0.05),
        ("noisy-1.75.csv", 1.75, 0.05),
    ] {
        let d = ramp(dir.path(), name, n, noise, false, 7);
        assert_eq!(
            d.effects_added(),
            ["power_law_stiffness"],
            "{name}: {}",
            d.final_model()
        );
        assert!(
            (exponent(&d) / n - 1.0).abs() < 0.02,
            "{name}: n = {}",
            exponent(&d)
        );
        assert!(
            d.unidentifiable
                .iter()
                .any(|e| e.id() == "depth_dependent_damping"),
            "{name}: damping not reported unidentifiable"
        );
        assert_eq!(d.final_fit.parameter(Param::Lambda), Some(0.0), "{name}");
    }
}

#[test]
fn load_unload_ramp_tries_damping_and_still_names_the_power_law() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = ramp(dir.path(), "triangle.csv", 1.4, 0.05, true, 8);
    // Damping is tried (loading and unloading separate it from the law); at one speed
    // each way a sign law is ±λv and δ̈ vanishes: Coulomb friction and inertia are not.
    let untried: Vec<&str> = d.unidentifiable.iter().map(|e| e.id()).collect();
    assert_eq!(untried, ["inertia", "coulomb_friction"]);
    assert_eq!(
        d.effects_added(),
        ["power_law_stiffness"],
        "{}",
        d.final_model()
    );
    assert!(
        (exponent(&d) / 1.4 - 1.0).abs() < 0.02,
        "n = {}",
        exponent(&d)
    );
}
