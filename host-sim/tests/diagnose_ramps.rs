//! The discrepancy workflow on constant-speed indentations (the most common lab test),
//! written as CSV files and read back like a user's: at one speed, damping λ·δ^q·δ̇ is
//! (λv)·δ^q, a power-law spring, and the elastic reading is the physical one. A record
//! that loads and unloads at that speed separates them (damping would show hysteresis),
//! but not damping from Coulomb friction (both ±F at ±v) or a mass (δ̈ = 0 but at the
//! reversal): those two are listed, not tried.
//!
//! Also records shaped after an independent generator's failures (2026-11-28): a
//! staircase of ramp-and-holds on a relaxing gel, a chirp pressed in contact behind a
//! delayed force channel, and an unloading from a hold in contact, with and without a
//! delay.

use std::io::Write as _;
use std::path::Path;

use estimator_core::ModelKind;
use host_sim::diagnose::catalogue::Param;
use host_sim::diagnose::{Diagnosis, Options};
use host_sim::files::diagnose_file;
use host_sim::setup::Overrides;
use rand::{Rng as _, SeedableRng as _};
use rand_distr::StandardNormal;

/// F = k·δⁿ with k = 2e6 N/m^n, approached from 1 mm out at 1 mm/s, loaded to 3 mm,
/// optionally unloaded back out; 1 kHz; white noise of `noise_n`.
fn ramp(dir: &Path, name: &str, n: f64, noise_n: f64, unload: bool, seed: u64) -> Diagnosis {
    let (v, dt) = (1e-3, 1e-3);
    let mut x: Vec<f64> = (0..4000).map(|i| -1e-3 + v * dt * i as f64).collect();
    if unload {
        let back: Vec<f64> = x.iter().rev().copied().collect();
        x.extend(back);
    }
    let force: Vec<f64> = x.iter().map(|xi| 2e6 * xi.max(0.0).powf(n)).collect();
    diagnose_record(dir, name, &x, &force, noise_n, seed)
}

/// Writes positions `x` \[m\] and forces `force` \[N\] at 1 kHz with white noise of
/// `noise_n` added to the force, and diagnoses the file from Kelvin-Voigt.
fn diagnose_record(
    dir: &Path,
    name: &str,
    x: &[f64],
    force: &[f64],
    noise_n: f64,
    seed: u64,
) -> Diagnosis {
    diagnose_record_at(
        dir,
        name,
        x,
        force,
        noise_n,
        1e-3,
        seed,
        &Options::default(),
    )
}

/// [`diagnose_record`] at a sample time of `dt` \[s\], with the workflow's `options`.
#[allow(clippy::too_many_arguments)]
fn diagnose_record_at(
    dir: &Path,
    name: &str,
    x: &[f64],
    force: &[f64],
    noise_n: f64,
    dt: f64,
    seed: u64,
    options: &Options,
) -> Diagnosis {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let path = dir.join(name);
    let mut f = std::fs::File::create(&path).expect("create");
    writeln!(f, "time_s,position_m,force_n").expect("write");
    for (i, (xi, fi)) in x.iter().zip(force).enumerate() {
        let e: f64 = rng.sample(StandardNormal);
        writeln!(
            f,
            "{:.6},{:.9e},{:.9e}",
            i as f64 * dt,
            xi,
            fi + noise_n * e
        )
        .expect("write");
    }
    drop(f);
    diagnose_written_with(&path, name, options)
}

/// Diagnoses the file at `path` from Kelvin-Voigt as a user would; panics naming `name`.
fn diagnose_written(path: &Path, name: &str) -> Diagnosis {
    diagnose_written_with(path, name, &Options::default())
}

/// [`diagnose_written`] with the workflow's `options` (its baseline).
fn diagnose_written_with(path: &Path, name: &str, options: &Options) -> Diagnosis {
    diagnose_file(path, "auto", options, &Overrides::default(), None)
        .unwrap_or_else(|e| panic!("{name}: {e:#}"))
        .diagnosis
}

/// Nothing added to the Kelvin-Voigt baseline of the diagnosis `d` of the file `name`,
/// whose damping both readings were fitted for and the free one won by more than the
/// acceptance threshold, λ within 10 % of `lambda` \[N·s/m\].
fn assert_damping_fitted_from_its_step(d: &Diagnosis, name: &str, lambda: f64) {
    assert!(d.effects_added().is_empty(), "{name}: {}", d.final_model());
    assert!(!d.damping_held, "{name}");
    let drop = d.onset_damping_delta_bic.expect("both readings compared");
    assert!(
        drop < -Options::default().min_bic_drop,
        "{name}: ΔBIC {drop}"
    );
    let fitted = d.final_fit.parameter(Param::Lambda).expect("λ");
    assert!(
        (fitted / lambda - 1.0).abs() < 0.1,
        "{name}: λ = {fitted:.4e} against {lambda:.4e}"
    );
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
        // The ramp starts in free space: the damping free was fitted too, and lost.
        assert!(d.damping_held, "{name}");
        assert!(d.onset_damping_delta_bic.is_some(), "{name}");
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

/// A Kelvin-Voigt material (κ = 2e4 N/m, λ = 2e3 N·s/m) loaded at 1 mm/s: its damping is
/// the step λv = 2 N where the contact begins, which no elastic law makes. From free space
/// the record shows that step, so the baseline's damping is fitted and nothing is added
/// (the damping held at 0, a power law with n < 1 would take up the step); starting in
/// contact, the step is the tare's and the damping is held.
#[test]
fn kelvin_voigt_ramp_from_free_space_fits_the_onset_step_as_damping() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (kappa, lambda, v, dt) = (2e4, 2e3, 1e-3, 1e-3);
    let kv = |x: &[f64]| -> Vec<f64> {
        x.iter()
            .map(|&xi| {
                if xi > 0.0 {
                    kappa * xi + lambda * v
                } else {
                    0.0
                }
            })
            .collect()
    };
    for seed in [11, 12, 13] {
        let x: Vec<f64> = (0..4000).map(|i| -1e-3 + v * dt * i as f64).collect();
        let name = format!("kv-from-free-space-{seed}.csv");
        let d = diagnose_record(dir.path(), &name, &x, &kv(&x), 0.05, seed);
        assert_damping_fitted_from_its_step(&d, &name, lambda);
        let stiffness = d.final_fit.parameter(Param::Kappa).expect("κ");
        assert!(
            (stiffness / kappa - 1.0).abs() < 0.05,
            "{name}: κ = {stiffness:.4e} against {kappa:.4e}"
        );
    }
    // The same material pressed from 0.5 mm in contact on: no onset, no step.
    let x: Vec<f64> = (0..3000).map(|i| 0.5e-3 + v * dt * i as f64).collect();
    let d = diagnose_record(dir.path(), "kv-in-contact.csv", &x, &kv(&x), 0.05, 14);
    assert!(d.damping_held, "{}", d.final_model());
    assert_eq!(
        d.onset_damping_delta_bic, None,
        "no onset, nothing compared"
    );
    assert_eq!(d.final_fit.parameter(Param::Lambda), Some(0.0));
}

/// The two materials [`unloading_from_a_hold`] is made of.
#[derive(Clone, Copy)]
enum Material {
    /// Kelvin-Voigt (eq. 1): κ = 2e4 N/m, λ = 1e3 N·s/m; diagnosed from Kelvin-Voigt.
    KelvinVoigt,
    /// Hunt-Crossley (eq. 3): F = k·δⁿ + λ·δⁿ·δ̇, k = 4.5e5 N/m^1.5, n = 1.5,
    /// λ = 1.1e7 N·s/m^2.5 (40 N and a 2 N damping step at 2 mm, as Kelvin-Voigt's);
    /// diagnosed from Hunt-Crossley.
    HuntCrossley,
}

/// A material held 2 mm deep from the record's start, then unloaded at 2 mm/s to 1 mm
/// out and held there; 500 Hz, white noise of 50 mN, the force channel `delay_s` behind
/// the position's. One speed and no onset from free space, but the probe starts moving
/// in contact: the force steps by the damping's λv (λ·δⁿ·v on Hunt-Crossley) there (the
/// elastic force is continuous), and a delayed channel steps τ later. Held at 0, the
/// damping's step was read as a stiffening law: an independent generator's clean
/// Kelvin-Voigt unloading from a hold took an exponential law at 8× its noise floor,
/// and two with a 50 ms delay the same, the delay not tried at one speed.
fn unloading_from_a_hold(
    dir: &Path,
    name: &str,
    material: Material,
    delay_s: f64,
    seed: u64,
) -> Diagnosis {
    let (v, dt) = (2e-3, 2e-3);
    let position = |t: f64| (2e-3 - v * (t - 2.0).max(0.0)).max(-1e-3);
    let law = |t: f64| -> f64 {
        let (x, moving) = (position(t), t > 2.0 && position(t) > -1e-3);
        let rate = if moving { -v } else { 0.0 };
        if x <= 0.0 {
            return 0.0;
        }
        let force = match material {
            Material::KelvinVoigt => 2e4 * x + 1e3 * rate,
            Material::HuntCrossley => x.powf(1.5) * (4.5e5 + 1.1e7 * rate),
        };
        force.max(0.0)
    };
    let samples = (4.5 / dt) as usize;
    let x: Vec<f64> = (0..samples).map(|i| position(i as f64 * dt)).collect();
    let force: Vec<f64> = (0..samples).map(|i| law(i as f64 * dt - delay_s)).collect();
    let options = Options {
        baseline: match material {
            Material::KelvinVoigt => ModelKind::KelvinVoigt,
            Material::HuntCrossley => ModelKind::HuntCrossley,
        },
        ..Options::default()
    };
    diagnose_record_at(dir, name, &x, &force, 0.05, dt, seed, &options)
}

/// The delay named first on the diagnosis `d` of the file `name`, τ within 10 % of 40 ms.
fn assert_delay_named(d: &Diagnosis, name: &str) {
    let first = d.steps.first().map(|s| s.effect.id());
    assert_eq!(first, Some("time_delay"), "{name}: {}", d.final_model());
    let tau = d.final_fit.parameter(Param::DelayS).expect("a delay");
    assert!((tau / 0.04 - 1.0).abs() < 0.1, "{name}: τ = {tau}");
}

#[test]
fn an_unloading_from_a_hold_in_contact_fits_the_step_as_damping_and_names_a_delay() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seed in [21, 22, 23] {
        let name = format!("kv-unloading-from-a-hold-{seed}.csv");
        let d = unloading_from_a_hold(dir.path(), &name, Material::KelvinVoigt, 0.0, seed);
        assert_damping_fitted_from_its_step(&d, &name, 1e3);

        let name = format!("kv-unloading-from-a-hold-delayed-{seed}.csv");
        let d = unloading_from_a_hold(dir.path(), &name, Material::KelvinVoigt, 0.04, seed);
        assert_delay_named(&d, &name);
    }
}

/// The same on a Hunt-Crossley material from its own baseline: at the hold δ > 0, so its
/// depth-dependent damping steps by λ·δⁿ·v there too (the hold rule once copied the
/// onset rule's exclusion of such a damping, right only at δ = 0: the damping stayed
/// held and the delay untried).
#[test]
fn a_hunt_crossley_unloading_from_a_hold_names_its_delay() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seed in [31, 32, 33] {
        let name = format!("hc-unloading-from-a-hold-{seed}.csv");
        let d = unloading_from_a_hold(dir.path(), &name, Material::HuntCrossley, 0.0, seed);
        assert!(d.effects_added().is_empty(), "{name}: {}", d.final_model());

        let name = format!("hc-unloading-from-a-hold-delayed-{seed}.csv");
        let d = unloading_from_a_hold(dir.path(), &name, Material::HuntCrossley, 0.04, seed);
        assert_delay_named(&d, &name);
    }
}

/// A Kelvin-Voigt material (κ = 2e4 N/m, λ = 1e3 N·s/m) that never leaves contact: held
/// 2 mm deep, pressed to 3 mm at 2 mm/s, held, back to 2 mm and held again; 500 Hz, white
/// noise of 50 mN, the force channel `delay_s` behind. One speed each way in contact
/// throughout, as a sine at one frequency, where a delay only rotates the phase; but the
/// holds' edges show it (the force still moving τ after the probe stops). Listed as not
/// identifiable there, a delayed preload-ramp-hold record of an independent generator took
/// a power law at 5× its noise floor.
fn preload_press_and_hold(dir: &Path, name: &str, delay_s: f64, seed: u64) -> Diagnosis {
    press_record(dir, name, (2e-3, 1e-3, 4.5), delay_s, 0.0, seed)
}

/// A Kelvin-Voigt material (κ = 2e4 N/m, λ = 1e3 N·s/m, unilateral) under
/// [`press_and_back`]`(t, start_m, back_m)` for `duration_s` (`motion`), sampled at 500 Hz
/// with white noise of 50 mN, the force channel `delay_s` behind the position's and the
/// load cell's zero drifting by `drift_n_per_s`; diagnosed from Kelvin-Voigt.
fn press_record(
    dir: &Path,
    name: &str,
    motion: (f64, f64, f64),
    delay_s: f64,
    drift_n_per_s: f64,
    seed: u64,
) -> Diagnosis {
    let ((start_m, back_m, duration_s), dt) = (motion, 2e-3);
    let samples = (duration_s / dt) as usize;
    let x: Vec<f64> = (0..samples)
        .map(|i| press_and_back(i as f64 * dt, start_m, back_m).0)
        .collect();
    let force: Vec<f64> = (0..samples)
        .map(|i| {
            let t = i as f64 * dt;
            let (x, rate) = press_and_back(t - delay_s, start_m, back_m);
            let contact = if x > 0.0 {
                (2e4 * x + 1e3 * rate).max(0.0)
            } else {
                0.0
            };
            contact + drift_n_per_s * t
        })
        .collect();
    diagnose_record_at(dir, name, &x, &force, 0.05, dt, seed, &Options::default())
}

/// The position \[m\] and rate \[m/s\] at `t` \[s\] of a probe held at `start_m` that presses
/// 1 mm deeper at 2 mm/s from t = 1 s, holds, and from t = 3 s moves `back_m` out at
/// 2 mm/s, then holds.
fn press_and_back(t: f64, start_m: f64, back_m: f64) -> (f64, f64) {
    let v = 2e-3;
    let x = start_m + (v * (t - 1.0)).clamp(0.0, 1e-3) - (v * (t - 3.0)).clamp(0.0, back_m);
    let rate = if (1.0..1.0 + 1e-3 / v).contains(&t) {
        v
    } else if (3.0..3.0 + back_m / v).contains(&t) {
        -v
    } else {
        0.0
    };
    (x, rate)
}

#[test]
fn a_press_between_holds_in_contact_names_its_delay() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seed in [41, 42, 43] {
        let name = format!("kv-press-between-holds-{seed}.csv");
        let d = preload_press_and_hold(dir.path(), &name, 0.0, seed);
        assert!(d.effects_added().is_empty(), "{name}: {}", d.final_model());

        let name = format!("kv-press-between-holds-delayed-{seed}.csv");
        let d = preload_press_and_hold(dir.path(), &name, 0.04, seed);
        assert_delay_named(&d, &name);
    }
}

/// A Kelvin-Voigt material (κ = 2e4 N/m, λ = 1e3 N·s/m) held 1 mm deep from the record's
/// start, pressed to 2 mm at 2 mm/s, held, then retracted at 2 mm/s to 1 mm out and held
/// there for 4 s; 500 Hz, white noise of 50 mN, and the load cell's zero drifting by
/// `drift_n_per_s` over the whole record. One stretch of free space, at the end: its two
/// ends see the zero 4 s apart. Listed as not identifiable with one free stretch, an
/// independent generator's drifts on such records were left at 2-9× their noise floor.
fn preload_ramp_hold_retract(dir: &Path, name: &str, drift_n_per_s: f64, seed: u64) -> Diagnosis {
    press_record(dir, name, (1e-3, 3e-3, 8.5), 0.0, drift_n_per_s, seed)
}

#[test]
fn a_drift_shows_across_the_one_free_stretch_after_a_retract() {
    let dir = tempfile::tempdir().expect("tempdir");
    for seed in [51, 52, 53] {
        let name = format!("kv-preload-retract-{seed}.csv");
        let d = preload_ramp_hold_retract(dir.path(), &name, 0.0, seed);
        assert!(d.effects_added().is_empty(), "{name}: {}", d.final_model());

        let name = format!("kv-preload-retract-drifting-{seed}.csv");
        let d = preload_ramp_hold_retract(dir.path(), &name, -0.1, seed);
        assert_eq!(
            d.effects_added(),
            ["force_drift"],
            "{name}: {}",
            d.final_model()
        );
        let drift = d
            .final_fit
            .parameter(Param::ForceDriftNPerS)
            .expect("a drift");
        assert!((drift / -0.1 - 1.0).abs() < 0.1, "{name}: {drift} N/s");
    }
}

/// A staircase stress-relaxation test on a gel (κ = 198 N/m, λ = 3.3 N·s/m, one relaxation
/// mode: 27 % relaxed at ν = 0.92 /s through the core's `laws::relaxing_step`), four
/// 0.86 mm steps at 13.6 mm/s each held 6.5 s, then a retract; 500 Hz, AR(1) force noise
/// (σ = 3 mN, φ = 0.55); the record begins two samples before the contact. The structure
/// of an independent generator's record that made `diagnose` panic (index out of
/// bounds, 2026-11-28): there the delay candidate's moved evaluations lacked the
/// relaxation's start column, which exists only where the fit window's first sample is
/// in contact, and its coefficients were read by index (now by name,
/// `regressors::aligned_coefficients`, tested on its own). This record does not reach
/// that toggle; it holds the diagnosis of the structure: the relaxation named first,
/// its rate within 10 %.
#[test]
fn a_staircase_relaxation_beginning_at_the_contact_names_the_relaxation() {
    let dir = tempfile::tempdir().expect("tempdir");
    let dt = 2e-3;
    let (kappa, lambda, fraction, nu) = (198.0, 3.3, 0.27, 0.92);
    let (v, step_m, hold_s) = (13.6e-3, 0.86e-3, 6.5);
    // Motion: 2 samples out (the third 0.3 µm in), four ramp-and-holds, a retract to
    // 1.2 mm out.
    let mut x = vec![0.3e-6 - 2.0 * v * dt, 0.3e-6 - v * dt];
    for k in 1..=4 {
        let target = k as f64 * step_m;
        while *x.last().unwrap() < target {
            let next = (x.last().unwrap() + v * dt).min(target);
            x.push(next);
        }
        x.extend(std::iter::repeat_n(target, (hold_s / dt) as usize));
    }
    while *x.last().unwrap() > -1.2e-3 {
        let next = x.last().unwrap() - 7.7e-3 * dt;
        x.push(next);
    }
    x.extend(std::iter::repeat_n(-1.2e-3, 100));
    let (one_minus_decay, gain) = estimator_core::laws::relaxation_coefficients(nu, dt);
    let (mut z, mut previous_elastic) = (0.0, 0.0);
    let mut rng = rand::rngs::StdRng::seed_from_u64(154);
    let mut noise = 0.0;
    let path = dir.path().join("staircase.csv");
    let mut f = std::fs::File::create(&path).expect("create");
    writeln!(f, "time_s,position_m,force_n").expect("write");
    for i in 0..x.len() {
        let delta = x[i].max(0.0);
        let rate = if i == 0 { 0.0 } else { (x[i] - x[i - 1]) / dt };
        let elastic = kappa * delta;
        z = estimator_core::laws::relaxing_step(
            z,
            elastic - previous_elastic,
            one_minus_decay,
            gain,
        );
        previous_elastic = elastic;
        let force = if delta > 0.0 {
            ((1.0 - fraction) * elastic + fraction * z + lambda * rate).max(0.0)
        } else {
            0.0
        };
        let e: f64 = rng.sample(StandardNormal);
        noise = 0.55 * noise + (1.0f64 - 0.55 * 0.55).sqrt() * 3e-3 * e;
        writeln!(f, "{:.6},{:.9e},{:.9e}", i as f64 * dt, x[i], force + noise).expect("write");
    }
    drop(f);
    let d = diagnose_written(&path, "staircase");
    let first = d.steps.first().map(|s| s.effect.id());
    assert_eq!(first, Some("relaxation"), "{:?}", d.final_fit.effects);
    let rate = d
        .final_fit
        .parameter(Param::RatePerS)
        .expect("a relaxation rate");
    assert!((rate / nu - 1.0).abs() < 0.1, "ν = {rate} against {nu}");
}

/// A chirp pressed in contact (0.15 mm about 0.2 mm deep, 0.5 → 3 Hz over 12 s, reached
/// from 5 µm out at 0.4 mm/s and left by a retract to 0.25 mm out at 1 mm/s) of a
/// power-law material with eq. 1's damping, k = 2.5e7 N/m^1.83, λ = 200 N·s/m, its force
/// channel 10 ms behind the position's, at 200 Hz with white noise of 18 mN and a −0.47 N
/// tare: κ·τ of the law's slope (≈ 7e2 N·s/m) exceeds λ, so the force lags as no passive
/// damping does, and the delay is named with its τ. (An independent generator's record
/// like it, whose one onset and lift-off both models missed alike, was refused by a
/// strict "no worse at the edges", 3.6113 against 3.6097 N², and ended at the power law
/// alone, 47× its noise floor; "no worse" is now within the noise of the edges' RSS.
/// This record names the delay under either rule.)
#[test]
fn a_lag_beyond_any_damping_on_a_chirp_in_contact_is_named_a_delay() {
    let dir = tempfile::tempdir().expect("tempdir");
    let dt = 5e-3;
    let (k, n, lambda, delay) = (2.5e7, 1.83, 200.0, 0.01);
    let chirp = |s: f64| {
        let phase = 2.0 * std::f64::consts::PI * (0.5 * s + 2.5 / 24.0 * s * s);
        0.2e-3 + 0.15e-3 * phase.sin()
    };
    let depth = |t: f64| -> f64 {
        if t < 0.5 {
            -5e-6 + 0.205e-3 * t / 0.5
        } else if t < 12.5 {
            chirp(t - 0.5)
        } else {
            (chirp(12.0) - 1e-3 * (t - 12.5)).max(-0.25e-3)
        }
    };
    let rate = |t: f64| (depth(t + 1e-5) - depth(t - 1e-5)) / 2e-5;
    let law = |t: f64| -> f64 {
        let d = depth(t);
        if d > 0.0 {
            (k * d.powf(n) + lambda * rate(t)).max(0.0)
        } else {
            0.0
        }
    };
    let mut rng = rand::rngs::StdRng::seed_from_u64(392);
    let path = dir.path().join("chirp.csv");
    let mut f = std::fs::File::create(&path).expect("create");
    writeln!(f, "time_s,position_m,force_n").expect("write");
    let samples = (13.4 / dt) as usize;
    for i in 0..samples {
        let t = i as f64 * dt;
        let e: f64 = rng.sample(StandardNormal);
        let force = law(t - delay) - 0.47 + 0.018 * e;
        writeln!(f, "{t:.6},{:.9e},{force:.9e}", depth(t)).expect("write");
    }
    drop(f);
    let d = diagnose_written(&path, "chirp");
    let effects = d.effects_added();
    assert!(effects.contains(&"time_delay"), "{effects:?}");
    let tau = d.final_fit.parameter(Param::DelayS).expect("a delay");
    assert!((tau / delay - 1.0).abs() < 0.1, "τ = {tau}");
    assert!(
        d.final_fit.nrmse_percent < 0.2,
        "{}",
        d.final_fit.nrmse_percent
    );
}
