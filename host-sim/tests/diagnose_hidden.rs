//! The discrepancy workflow on logs in which the effect is hidden: the generator's plant
//! presses a material with one effect, a pair, or none, at random parameters; the
//! workflow gets only the log, as a CSV file diagnosed as `host-sim diagnose` does.
//!
//! The sweep (`#[ignore]`d: 340 logs, minutes; `.ci/run` runs it with `-- --ignored
//! --nocapture`, which prints one table row per case): 20 seeds per case (500-519, never
//! used to tune the workflow, which was developed on seeds 1-10 and 101-105):
//! - one hidden effect: named first in ≥ 90 % of the logs;
//! - a pair: both found in ≥ 80 %;
//! - none: nothing added in ≥ 95 %;
//! - the gap shrinks: final NRMSE within 1.5× the generator's noise floor (the NRMSE of
//!   the noise alone) for the median log of every case, in ≥ 75 % of the logs of every
//!   case, and never above 3×. Measured (README, 2026-11-24): 322 of the 340 logs (95 %)
//!   are within 1.5×, none above 2.2×; the misses gather in the Coulomb-friction cases
//!   (17/20 single, 15/20 with inertia: the smoothed sign law fitted from block-mean
//!   velocities leaves 1.5-1.9×), depth damping + force offset (17/20) and the force
//!   offset alone (18/20).
//!
//! `cargo test` runs every case once, on seed 520 (also never used to tune), and asserts
//! the same rates over the cases: ≥ 9 of the 10 singles named first, ≥ 4 of the 5 pairs
//! both found, nothing added to the clean log, no final NRMSE above 3× the floor.

use std::ops::Range;

use host_sim::diagnose::catalogue::Effect;
use host_sim::diagnose::Options;
use host_sim::files::{diagnose_file, FileDiagnosis};
use host_sim::generator;
use host_sim::report::write_simulated_log;
use host_sim::setup::Overrides;

/// The sweep's seeds.
const SEEDS: Range<u64> = 500..520;
/// The quick run's seed.
const QUICK_SEED: u64 = 520;

struct Outcome {
    /// Effects named, per seed, in order of addition (final model's list).
    found: Vec<Vec<&'static str>>,
    /// First effect added, per seed.
    first: Vec<Option<&'static str>>,
    /// Final NRMSE over the noise floor, per seed.
    ratio: Vec<f64>,
}

/// The generated log `g` written into `dir` as the simulated log's CSV (`host-sim
/// simulate`'s format) and diagnosed as `host-sim diagnose` diagnoses a file; panics
/// naming `what` if it cannot be.
fn diagnose_as_a_user(
    dir: &std::path::Path,
    g: &generator::Generated,
    what: &str,
) -> FileDiagnosis {
    let path = dir.join("log.csv");
    write_simulated_log(&path, &g.log).expect("write the log");
    diagnose_csv(&path, what)
}

/// The CSV file at `path` diagnosed as `host-sim diagnose` diagnoses it (default
/// options); panics naming `what` if it cannot be.
fn diagnose_csv(path: &std::path::Path, what: &str) -> FileDiagnosis {
    diagnose_file(
        path,
        "csv",
        &Options::default(),
        &Overrides::default(),
        None,
    )
    .unwrap_or_else(|e| panic!("{what}: {e:#}"))
}

/// Each log is written as the simulated log's CSV (`host-sim simulate`'s format) and
/// diagnosed as `host-sim diagnose` diagnoses a file: the front end finds the axis, the
/// offset and the contact point from the whole record (the workflow users run; the
/// sweep once prepared the log from the generator's arrays with the older impact
/// detector, which hid that an exponential material's contact point was placed behind
/// its free space, and under-counted the drift).
fn run(effects: &[Effect], seeds: Range<u64>) -> Outcome {
    let mut out = Outcome {
        found: Vec::new(),
        first: Vec::new(),
        ratio: Vec::new(),
    };
    let dir = tempfile::tempdir().expect("a temporary directory");
    for seed in seeds {
        let g = generator::generate(effects, seed);
        let run = diagnose_as_a_user(dir.path(), &g, &format!("{effects:?} seed {seed}"));
        let d = &run.diagnosis;
        out.first.push(d.steps.first().map(|s| s.effect.id()));
        out.found.push(d.effects_added());
        out.ratio
            .push(d.final_fit.nrmse_percent / generator::noise_floor_percent(&g, &run.prepared));
    }
    out
}

fn check_gap(name: &str, o: &Outcome) {
    let within = o.ratio.iter().filter(|r| **r <= 1.5).count();
    let worst = o.ratio.iter().copied().fold(0.0, f64::max);
    let mut sorted = o.ratio.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(
        median <= 1.5,
        "{name}: median final/floor {median:.2}: {:?}",
        o.ratio
    );
    assert!(
        within * 4 >= o.ratio.len() * 3,
        "{name}: final NRMSE within 1.5× the floor in {within}/{} logs: {:?}",
        o.ratio.len(),
        o.ratio
    );
    assert!(
        worst <= 3.0,
        "{name}: worst final/floor {worst:.2}: {:?}",
        o.ratio
    );
}

/// Logs whose final model has an effect that was not hidden.
fn with_extra(o: &Outcome, hidden: &[Effect]) -> usize {
    o.found
        .iter()
        .filter(|f| f.iter().any(|e| hidden.iter().all(|h| h.id() != *e)))
        .count()
}

/// At most 4 of 20 logs keep an effect that was not hidden (measured 2026-11-23 with the
/// backward check: at most 3 of 20 in a case, 13 of 320 in all; 34 without it).
fn check_extras(name: &str, o: &Outcome, hidden: &[Effect]) {
    let extra = with_extra(o, hidden);
    assert!(
        extra * 5 <= o.found.len(),
        "{name}: an effect that was not hidden in {extra}/{}: {:?}",
        o.found.len(),
        o.found
    );
}

/// One row of the README's table: the case, the identification count, the logs within
/// 1.5× the floor, the median / worst final ÷ floor, and the logs with an extra effect.
fn print_row(name: &str, identified: usize, o: &Outcome, hidden: &[Effect]) {
    let mut sorted = o.ratio.clone();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    let within = sorted.iter().filter(|r| **r <= 1.5).count();
    println!(
        "| {name} | {identified}/{n} | {within}/{n} | {:.2} / {:.2} | {}/{n} |",
        sorted[n / 2],
        sorted[n - 1],
        with_extra(o, hidden)
    );
}

fn single(effect: Effect) {
    let o = run(&[effect], SEEDS);
    let right = o.first.iter().filter(|f| **f == Some(effect.id())).count();
    print_row(effect.id(), right, &o, &[effect]);
    assert!(
        right * 10 >= o.first.len() * 9,
        "{}: named first in {right}/{}: {:?}",
        effect.id(),
        o.first.len(),
        o.first
    );
    check_gap(effect.id(), &o);
    check_extras(effect.id(), &o, &[effect]);
}

fn both_found(o: &Outcome, a: Effect, b: Effect) -> usize {
    o.found
        .iter()
        .filter(|f| f.contains(&a.id()) && f.contains(&b.id()))
        .count()
}

fn pair(a: Effect, b: Effect) {
    let o = run(&[a, b], SEEDS);
    let both = both_found(&o, a, b);
    let name = format!("{}+{}", a.id(), b.id());
    print_row(&name, both, &o, &[a, b]);
    assert!(
        both * 10 >= o.found.len() * 8,
        "{name}: both found in {both}/{}: {:?}",
        o.found.len(),
        o.found
    );
    check_gap(&name, &o);
    check_extras(&name, &o, &[a, b]);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_power_law_stiffness() {
    single(Effect::PowerLawStiffness);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_exponential_stiffness() {
    single(Effect::ExponentialStiffness);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_depth_dependent_damping() {
    single(Effect::DepthDependentDamping);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_relaxation() {
    single(Effect::Relaxation);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_force_offset() {
    single(Effect::ForceOffset);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_force_drift() {
    // A drift is accepted only where the free space shows it
    // (`diagnose::scoring::free_space_trend`, |t| ≥ 3). Prepared from the generator's
    // arrays with the impact detector (before 2026-11-24), 5 logs of 20 showed it at
    // t = 2.84 only and named a mass or a later offset instead; diagnosed as files (the
    // front end's offset, contact point and noise), all 20 name it first.
    single(Effect::ForceDrift);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_contact_point_offset() {
    single(Effect::ContactPointOffset);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_inertia() {
    single(Effect::Inertia);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_time_delay() {
    single(Effect::TimeDelay);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_coulomb_friction() {
    single(Effect::CoulombFriction);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_plastic_set() {
    single(Effect::PlasticSet);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_pair_power_law_and_relaxation() {
    pair(Effect::PowerLawStiffness, Effect::Relaxation);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_pair_depth_damping_and_force_offset() {
    pair(Effect::DepthDependentDamping, Effect::ForceOffset);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_pair_inertia_and_coulomb_friction() {
    pair(Effect::Inertia, Effect::CoulombFriction);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_pair_time_delay_and_plastic_set() {
    pair(Effect::TimeDelay, Effect::PlasticSet);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn hidden_pair_exponential_stiffness_and_contact_offset() {
    pair(Effect::ExponentialStiffness, Effect::ContactPointOffset);
}

#[test]
#[ignore = "the 340-log sweep: minutes; .ci/run runs it"]
fn nothing_hidden_nothing_added() {
    let o = run(&[], SEEDS);
    let clean = o.found.iter().filter(|f| f.is_empty()).count();
    print_row("none", clean, &o, &[]);
    assert!(
        clean * 100 >= o.found.len() * 95,
        "nothing added in {clean}/{}: {:?}",
        o.found.len(),
        o.found
    );
    check_gap("none", &o);
}

const PAIRS: [(Effect, Effect); 5] = [
    (Effect::PowerLawStiffness, Effect::Relaxation),
    (Effect::DepthDependentDamping, Effect::ForceOffset),
    (Effect::Inertia, Effect::CoulombFriction),
    (Effect::TimeDelay, Effect::PlasticSet),
    (Effect::ExponentialStiffness, Effect::ContactPointOffset),
];

/// Every case of the sweep once, on a seed the sweep does not use: the same rates, counted
/// over the cases instead of the seeds.
#[test]
fn every_case_once_on_an_unseen_seed() {
    use rayon::prelude::*;
    let seeds = QUICK_SEED..QUICK_SEED + 1;
    // Every effect hidden alone.
    let singles: Vec<(Effect, Outcome)> = Effect::ALL
        .par_iter()
        .map(|&e| (e, run(&[e], seeds.clone())))
        .collect();
    let pairs: Vec<((Effect, Effect), Outcome)> = PAIRS
        .par_iter()
        .map(|&(a, b)| ((a, b), run(&[a, b], seeds.clone())))
        .collect();
    let clean = run(&[], seeds.clone());

    let mut worst: Vec<(String, f64)> = Vec::new();
    let named: Vec<&str> = singles
        .iter()
        .filter(|(e, o)| o.first[0] == Some(e.id()))
        .map(|(e, _)| e.id())
        .collect();
    for (e, o) in &singles {
        println!(
            "{}: first {:?}, final/floor {:.2}",
            e.id(),
            o.first[0],
            o.ratio[0]
        );
        worst.push((e.id().to_string(), o.ratio[0]));
    }
    let found = pairs
        .iter()
        .filter(|((a, b), o)| both_found(o, *a, *b) == 1)
        .count();
    for ((a, b), o) in &pairs {
        println!(
            "{}+{}: found {:?}, final/floor {:.2}",
            a.id(),
            b.id(),
            o.found[0],
            o.ratio[0]
        );
        worst.push((format!("{}+{}", a.id(), b.id()), o.ratio[0]));
    }
    println!(
        "none: found {:?}, final/floor {:.2}",
        clean.found[0], clean.ratio[0]
    );
    worst.push(("none".to_string(), clean.ratio[0]));

    assert!(named.len() >= 9, "singles named first: only {named:?}");
    assert!(found >= 4, "pairs with both found: {found}/5");
    assert!(
        clean.found[0].is_empty(),
        "clean log: added {:?}",
        clean.found[0]
    );
    for (name, ratio) in worst {
        assert!(ratio <= 3.0, "{name}: final/floor {ratio:.2}");
    }
}

/// An exponential material whose surface moves after the first tap (seed 521: the sweep
/// uses 500-519, the quick run 520), diagnosed as a user would. The front end takes the
/// exponential law: with the power law alone it put the contact point 2 mm behind the
/// record's free space (its exponent at the range's end, a shifted power law being the
/// nearest stiffening curve), the record showed one contact onset, and the later
/// contacts' shift was "not identifiable" (the sweep's exponential + contact-offset row:
/// 1/20 as a user, when the sweep prepared the generator's arrays instead of files).
#[test]
fn an_exponential_material_keeps_its_free_space_and_its_later_contacts() {
    use host_sim::diagnose::catalogue::Param;
    let seed = 521;
    let hidden = [Effect::ExponentialStiffness, Effect::ContactPointOffset];
    let g = generator::generate(&hidden, seed);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let run = diagnose_as_a_user(dir.path(), &g, "exponential + contact offset, seed 521");
    let d = &run.diagnosis;
    // Free space after the first contact: the later contacts are contacts of their own.
    assert!(
        run.prepared.first_contact_end < run.prepared.len(),
        "the first contact never ends: {:?}",
        run.notes
    );
    assert_eq!(
        d.effects_added(),
        vec![
            Effect::ExponentialStiffness.id(),
            Effect::ContactPointOffset.id()
        ],
        "{:?}",
        run.notes
    );
    // The first tap's surface on the file's axis: where the true depth turns positive.
    let first = g
        .log
        .true_depth_m
        .iter()
        .position(|d| *d > 0.0)
        .expect("a contact");
    let surface_m = g.log.position_m[first] - g.log.true_depth_m[first];
    let fit = &d.final_fit;
    let value = |p: Param| fit.parameter(p).expect("fitted");
    let contact_m = value(Param::ContactPositionM);
    assert!(
        (contact_m - surface_m).abs() < 0.02 * g.truth.depth_m,
        "contact position {contact_m:.4e} m, the surface at {surface_m:.4e} m"
    );
    let relative = |fitted: f64, truth: f64| ((fitted - truth) / truth).abs();
    let shift_error = relative(value(Param::ContactShiftM), g.truth.surface_shift_m);
    let b_error = relative(value(Param::B), g.truth.b);
    assert!(shift_error < 0.1, "contact shift off by {shift_error:.3}");
    assert!(b_error < 0.1, "exponential rate b off by {b_error:.3}");
    let floor = generator::noise_floor_percent(&g, &run.prepared);
    assert!(
        fit.nrmse_percent <= 1.5 * floor,
        "final NRMSE {:.3} % against a floor of {floor:.3} %",
        fit.nrmse_percent
    );
}

/// A load-cell zero that shifts late in the free stretch after the first contact, not
/// at the lift-off (a zero that shifts with the load need not shift the moment the load
/// comes off), is named first, placed where it shifts (within two fitting samples) and
/// sized within 10 %. With the step fixed at the lift-off, the stretch's samples before
/// it read as a misfit of the old zero: an independent generator's multi-speed records
/// with the step in the middle of a long hover named a drift or a contact shift instead
/// in 4 of 8 logs.
#[test]
fn a_load_cell_zero_that_shifts_late_in_the_free_stretch_is_named_where_it_shifts() {
    use host_sim::diagnose::catalogue::Param;
    // The first seed past the quick run's whose step falls in the stretch's last 40 %.
    let (seed, g) = (QUICK_SEED + 1..QUICK_SEED + 50)
        .map(|s| (s, generator::generate(&[Effect::ForceOffset], s)))
        .find(|(_, g)| g.truth.force_offset_at > 0.6)
        .expect("a seed with a late step");
    let dir = tempfile::tempdir().expect("a temporary directory");
    let run = diagnose_as_a_user(dir.path(), &g, &format!("late step, seed {seed}"));
    let d = &run.diagnosis;
    assert_eq!(
        d.steps.first().map(|s| s.effect),
        Some(Effect::ForceOffset),
        "seed {seed}: {}",
        d.final_model()
    );
    let offset = d
        .final_fit
        .parameter(Param::ForceOffsetN)
        .expect("the offset's parameter");
    assert!(
        (offset / g.truth.force_offset_n - 1.0).abs() < 0.1,
        "seed {seed}: {offset} N against {} N",
        g.truth.force_offset_n
    );
    let placed = run.prepared.offset_step_s();
    assert!(
        (placed - g.truth.force_offset_step_s).abs() <= 2.0 * run.prepared.dt,
        "seed {seed}: step at {placed} s, truly {} s (fitting samples of {} s)",
        g.truth.force_offset_step_s,
        run.prepared.dt
    );
}

/// Driven impacts of 8-100 ms into a Kelvin-Voigt material (the probe cruises in at
/// 0.08-0.4 m/s, presses 1-2 mm along a half-sine or a parabola and leaves at the same
/// speed; 12 impacts in 10 s, 2 kHz, AR(1) force noise with ρ = 0.6 and a 16-bit load
/// cell), a structure the hidden-effect generator never draws: nothing is added and the
/// law's κ and λ are within 3 % (at 5 ms blocks λ was 4 % off on this seed, and 4-18 %
/// off with Coulomb friction named in 2 of 5 seeds). Fitted on 5 ms blocks (2-12 per
/// contact, across which the rate reverses and the damping's step λ·v₀ at impact is a
/// tenth of the force) an independent generator's clean impacts named Coulomb friction
/// or a power law in 3 of 8 (and in 33 of 114 records of every case, unseen seeds); the
/// fitting samples are now
/// 2 ms where the typical contact is at most [`SHORT_CONTACT_S`].
///
/// [`SHORT_CONTACT_S`]: host_sim::diagnose::data::SHORT_CONTACT_S
#[test]
fn driven_impacts_are_fitted_on_samples_short_against_their_contacts() {
    use host_sim::diagnose::catalogue::Param;
    use rand::{rngs::StdRng, Rng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};
    use std::io::Write;
    let mut rng = StdRng::seed_from_u64(7);
    let fs = 2000.0;
    let dt = 1.0 / fs;
    let (kappa, lambda, surface_m, tare_n) = (4.0e3, 12.0, 0.04, -3.0);
    let hover = 3.0e-3;
    // Position: rest behind the surface, accelerate over hover/2 to v₀, cruise hover/2,
    // the contact, then the mirror image, a rest of 0.3-0.6 s.
    let mut position = Vec::new();
    let mut t = 0.0f64;
    let rest = |position: &mut Vec<f64>, t: &mut f64, until: f64| {
        while *t < until {
            position.push(surface_m - hover);
            *t += dt;
        }
    };
    rest(&mut position, &mut t, 0.5);
    for i in 0..12 {
        let v0: f64 = 0.08 * 5f64.powf(rng.random_range(0.0..1.0));
        let depth: f64 = rng.random_range(1.0e-3..2.0e-3);
        let parabolic = i % 2 == 0;
        let accel_s = hover / v0;
        let cruise_s = 0.5 * hover / v0;
        let a_c = v0 * v0 / (2.0 * depth);
        let contact_s = if parabolic {
            2.0 * v0 / a_c
        } else {
            std::f64::consts::PI * depth / v0
        };
        let start = t;
        let phases = [accel_s, cruise_s, contact_s, cruise_s, accel_s];
        let end = start + phases.iter().sum::<f64>();
        while t < end {
            // The phase the time falls in and the time since it began.
            let (mut phase, mut s) = (0, t - start);
            while phase < 4 && s >= phases[phase] {
                s -= phases[phase];
                phase += 1;
            }
            let x = match phase {
                0 => -hover + 0.5 * (v0 / accel_s) * s * s,
                1 => -0.5 * hover + v0 * s,
                2 if parabolic => v0 * s - 0.5 * a_c * s * s,
                2 => depth * (std::f64::consts::PI * s / contact_s).sin(),
                3 => -v0 * s,
                _ => -0.5 * hover - v0 * s + 0.5 * (v0 / accel_s) * s * s,
            };
            position.push(surface_m + x);
            t += dt;
        }
        let until = t + rng.random_range(0.3..0.6);
        rest(&mut position, &mut t, until);
    }
    let n = position.len();
    let rho = 0.6;
    let mut ar = 0.0f64;
    let lsb = 40.0 / 65536.0;
    let path_dir = tempfile::tempdir().expect("a temporary directory");
    let path = path_dir.path().join("impacts.csv");
    let mut file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
    writeln!(file, "time_s,position_m,force_n").expect("write");
    for i in 0..n {
        let depth = position[i] - surface_m;
        let rate = (position[(i + 1).min(n - 1)] - position[i.saturating_sub(1)])
            / (((i + 1).min(n - 1) - i.saturating_sub(1)) as f64 * dt);
        let law = if depth > 0.0 {
            (kappa * depth + lambda * rate).max(0.0)
        } else {
            0.0
        };
        let e: f64 = StandardNormal.sample(&mut rng);
        ar = rho * ar + (1.0 - rho * rho).sqrt() * e;
        let force = ((tare_n + law + 0.03 * ar) / lsb).round() * lsb;
        writeln!(file, "{:.7},{:.9},{:.6}", i as f64 * dt, position[i], force).expect("write");
    }
    drop(file);
    let run = diagnose_csv(&path, "impacts");
    let d = &run.diagnosis;
    assert!(
        run.prepared.dt <= 3.0e-3,
        "fitting samples of {} ms",
        1e3 * run.prepared.dt
    );
    assert!(
        d.effects_added().is_empty(),
        "added {:?} ({:?})",
        d.effects_added(),
        run.notes
    );
    let fit = &d.final_fit;
    let kappa_fit = fit.parameter(Param::Kappa).expect("κ");
    let lambda_fit = fit.parameter(Param::Lambda).expect("λ");
    assert!(
        (kappa_fit / kappa - 1.0).abs() < 0.03 && (lambda_fit / lambda - 1.0).abs() < 0.03,
        "κ = {kappa_fit:.4e}, λ = {lambda_fit:.4e}"
    );
}

/// What [`pink_ramp_and_hold`] hides (0: nothing).
#[derive(Clone, Copy, Default)]
struct PinkHidden {
    /// The later presses' contact point, deeper by \[m\].
    shift_m: f64,
    /// The load cell's zero's step after the first press \[N\].
    step_n: f64,
    /// The load cell's zero's drift over the whole record \[N/s\].
    drift_n_per_s: f64,
}

/// A ramp-and-hold log written as a CSV, a structure and a noise the hidden-effect
/// generator never draws: three presses into a Kelvin-Voigt material (κ = 750 N/m,
/// λ = 75 N·s/m; 0.5 mm/s to 2 mm, a 12 s hold, out at the same speed, 5 s apart in free
/// space), 1 kHz, a 16-bit load cell, a 1 µm encoder, and 1/f (pink) force noise of
/// `sigma_n`: five AR(1) processes of time constants 10 ms to 100 s, one per decade,
/// equal variance each (equal power per decade). The presses after the first meet the
/// surface `shift_m` deeper (a later contacts' shift of the contact point, as
/// `contact_point_offset` names it), and the load cell's zero steps by `step_n` halfway
/// through the free stretch after the first press (a `force_offset`). Returns the file's
/// path in `dir`.
fn pink_ramp_and_hold(
    dir: &std::path::Path,
    seed: u64,
    sigma_n: f64,
    hidden: PinkHidden,
    presses: usize,
) -> std::path::PathBuf {
    let PinkHidden {
        shift_m,
        step_n,
        drift_n_per_s,
    } = hidden;
    use rand::{rngs::StdRng, Rng, SeedableRng};
    use rand_distr::{Distribution, StandardNormal};
    use std::io::Write;
    let mut rng = StdRng::seed_from_u64(seed);
    let dt = 1.0e-3;
    let (kappa, lambda, surface_m, tare_n) = (750.0, 75.0, 0.02, 1.2);
    let (back, depth, speed) = (0.5e-3, 2.0e-3, 0.5e-3);
    // (position, later contact) per sample, and the load-cell step's first sample.
    let mut motion: Vec<(f64, bool)> = Vec::new();
    let mut step_at = usize::MAX;
    let hold = |motion: &mut Vec<(f64, bool)>, x: f64, s: f64, later: bool| {
        motion.extend((0..(s / dt) as usize).map(|_| (x, later)));
    };
    let ramp = |motion: &mut Vec<(f64, bool)>, from: f64, to: f64, later: bool| {
        let steps = ((to - from).abs() / speed / dt) as usize;
        motion.extend((0..steps).map(|i| (from + (to - from) * i as f64 / steps as f64, later)));
    };
    hold(
        &mut motion,
        surface_m - back,
        3.0 + rng.random_range(0.0..1.0),
        false,
    );
    for press in 0..presses {
        let later = press > 0;
        ramp(&mut motion, surface_m - back, surface_m + depth, later);
        hold(&mut motion, surface_m + depth, 12.0, later);
        ramp(&mut motion, surface_m + depth, surface_m - back, later);
        let free_s = 5.0 + rng.random_range(0.0..1.0);
        if press == 0 {
            step_at = motion.len() + (free_s / 2.0 / dt) as usize;
        }
        hold(&mut motion, surface_m - back, free_s, later);
    }
    let taus = [0.01, 0.1, 1.0, 10.0, 100.0];
    let mut states: Vec<f64> = taus
        .iter()
        .map(|_| StandardNormal.sample(&mut rng))
        .collect();
    let lsb = 40.0 / 65536.0;
    let path = dir.join(format!("pink-ramp-hold-{seed}.csv"));
    let mut file = std::io::BufWriter::new(std::fs::File::create(&path).expect("create"));
    writeln!(file, "time_s,position_m,force_n").expect("write");
    let n = motion.len();
    for i in 0..n {
        let (x, later) = motion[i];
        let surface = if later {
            surface_m - shift_m
        } else {
            surface_m
        };
        let rate = (motion[(i + 1).min(n - 1)].0 - motion[i.saturating_sub(1)].0)
            / (((i + 1).min(n - 1) - i.saturating_sub(1)) as f64 * dt);
        let law = if x > surface {
            (kappa * (x - surface) + lambda * rate).max(0.0)
        } else {
            0.0
        };
        let mut pink = 0.0;
        for (state, tau) in states.iter_mut().zip(taus) {
            let a: f64 = (-dt / tau).exp();
            let e: f64 = StandardNormal.sample(&mut rng);
            *state = a * *state + (1.0 - a * a).sqrt() * e;
            pink += *state;
        }
        let zero = tare_n + if i >= step_at { step_n } else { 0.0 } + drift_n_per_s * i as f64 * dt;
        let force =
            ((zero + law + sigma_n * pink / (taus.len() as f64).sqrt()) / lsb).round() * lsb;
        let position = (x / 1.0e-6).round() * 1.0e-6;
        writeln!(file, "{:.3},{position:.6},{force:.6}", i as f64 * dt).expect("write");
    }
    path
}

/// On [`pink_ramp_and_hold`] records (30 mN of 1/f noise), per (seed, presses) of
/// `cases`: nothing is named on the clean record, and on the one hiding `hidden`, only
/// `effect`, its `param` within 10 % of `truth` (in magnitude: a shift's sign follows
/// the file's axis).
fn named_only_where_hidden(
    cases: &[(u64, usize)],
    hidden: PinkHidden,
    effect: Effect,
    (param, truth): (host_sim::diagnose::catalogue::Param, f64),
) {
    let dir = tempfile::tempdir().expect("a temporary directory");
    for &(seed, presses) in cases {
        for hidden in [PinkHidden::default(), hidden] {
            let clean =
                hidden.shift_m == 0.0 && hidden.step_n == 0.0 && hidden.drift_n_per_s == 0.0;
            let path = pink_ramp_and_hold(dir.path(), seed, 0.03, hidden, presses);
            let run = diagnose_csv(&path, &format!("seed {seed}"));
            let d = &run.diagnosis;
            if clean {
                assert!(
                    d.effects_added().is_empty(),
                    "seed {seed}, clean: added {:?}",
                    d.effects_added()
                );
                continue;
            }
            assert_eq!(
                d.effects_added(),
                [effect.id()],
                "seed {seed}, {}",
                effect.id()
            );
            let fitted = d
                .final_fit
                .parameter(param)
                .expect("the effect's parameter");
            assert!(
                (fitted.abs() / truth - 1.0).abs() < 0.1,
                "seed {seed}: {param:?} = {fitted}, truly {truth}"
            );
        }
    }
}

/// A later contacts' shift of the contact point is not named where it moves their force
/// by no more than the load cell's zero wanders between free stretches
/// ([`MIN_SHIFT_OVER_WANDER`]): on two presses under 1/f noise (30 mN, 2 % of the force
/// range) the slow part of the noise sets the second press's zero apart from the first's,
/// and a shift of some µm took that up on 11 of 40 seeds (100-139), these three among
/// them, each with a held-out error better on most folds. A true shift of 0.5 mm (0.38 N,
/// 12× the noise) on the same records is named, within 10 % (a shift of 0.2 mm is named
/// too, but the wander enters its estimate: 13 % off on seed 105).
///
/// [`MIN_SHIFT_OVER_WANDER`]: host_sim::diagnose::scoring::MIN_SHIFT_OVER_WANDER
#[test]
fn a_contact_shift_within_the_zero_wander_of_pink_noise_is_not_named() {
    let shift_m = 5.0e-4;
    named_only_where_hidden(
        &[(105, 2), (107, 2), (137, 2)],
        PinkHidden {
            shift_m,
            ..PinkHidden::default()
        },
        Effect::ContactPointOffset,
        (host_sim::diagnose::catalogue::Param::ContactShiftM, shift_m),
    );
}

/// Nor where it moves their force by no more than 1.5 times the slow part of the zero's
/// wander between adjacent windows of the free space ([`MIN_SHIFT_OVER_ZERO_WANDER`]),
/// which sees a 1/f wander the stretch means' spread, from two or three free stretches,
/// can miss: on the same 1/f recipe's seeds 200-259 (two and three presses; fresh when
/// the rule was first checked on them, but its bar then moved from 2 to 1.5 on these
/// records), 14 of 120 clean records took a shift past the first measure, at
/// 0.43-1.56 times the whole wander, these three among them (2 of the 14 keep theirs).
/// A true shift of 0.5 mm on the same records is named, within 10 %.
///
/// [`MIN_SHIFT_OVER_ZERO_WANDER`]: host_sim::diagnose::scoring::MIN_SHIFT_OVER_ZERO_WANDER
#[test]
fn a_contact_shift_within_the_adjacent_window_wander_of_pink_noise_is_not_named() {
    let shift_m = 5.0e-4;
    named_only_where_hidden(
        &[(219, 2), (223, 3), (251, 3)],
        PinkHidden {
            shift_m,
            ..PinkHidden::default()
        },
        Effect::ContactPointOffset,
        (host_sim::diagnose::catalogue::Param::ContactShiftM, shift_m),
    );
}

/// A load-cell step is not named where it is no larger than a few times the zero's own
/// wander between adjacent stretches of the free space
/// ([`MIN_STEP_OVER_WANDER`]): on three presses under 1/f noise (30 mN, five AR(1)
/// processes of 10 ms-100 s) the zero after the first press sits apart from its level
/// before by the noise's slow part, and a step took that up on 16 of 80 clean records
/// (seeds 100-139, two and three presses), these three among them; with the rule 1 of 80.
/// A true step of 0.3 N (10× the noise) on the same records is named, within 10 %. (A
/// step of 0.09 N was named on 77 of those 80 records with and without the rule, its
/// estimate 0.06-0.12 N: the wander enters it.)
///
/// [`MIN_STEP_OVER_WANDER`]: host_sim::diagnose::scoring::MIN_STEP_OVER_WANDER
#[test]
fn a_load_cell_step_within_the_zero_wander_of_pink_noise_is_not_named() {
    let step_n = 0.3;
    named_only_where_hidden(
        &[(101, 3), (105, 3), (111, 3)],
        PinkHidden {
            step_n,
            ..PinkHidden::default()
        },
        Effect::ForceOffset,
        (host_sim::diagnose::catalogue::Param::ForceOffsetN, step_n),
    );
}

/// A drift of the load cell's zero is not named where its change over the free space's
/// span is no larger than a few times the slow part of the zero's wander, grown to
/// windows that far apart ([`MIN_DRIFT_OVER_WANDER`]): under 1/f noise (30 mN, five
/// AR(1) processes of 10 ms-100 s) the slow part is a trend over any record, and a
/// drift took it up on 6 of 80 clean records (seeds 100-139, two and three presses),
/// these three among them; with the rule none. A true drift of 15 mN/s (0.6-0.9 N over
/// the record) on the same records is named, within 10 %. (One of 3 mN/s was named on 74
/// of those 80 records with and without the rule, 36 of them within 10 %: the wander
/// enters its estimate.)
///
/// [`MIN_DRIFT_OVER_WANDER`]: host_sim::diagnose::scoring::MIN_DRIFT_OVER_WANDER
#[test]
fn a_drift_within_the_zero_wander_of_pink_noise_is_not_named() {
    let drift_n_per_s = 0.015;
    named_only_where_hidden(
        &[(114, 3), (117, 2), (119, 2)],
        PinkHidden {
            drift_n_per_s,
            ..PinkHidden::default()
        },
        Effect::ForceDrift,
        (
            host_sim::diagnose::catalogue::Param::ForceDriftNPerS,
            drift_n_per_s,
        ),
    );
}
