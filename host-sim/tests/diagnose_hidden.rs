//! The discrepancy workflow on logs in which the effect is hidden: the generator's plant
//! presses a material with one effect, a pair, or none, at random parameters; the
//! workflow gets only the log. Over 20 seeds per case (seeds 500-519, never used to tune
//! the workflow, which was developed on seeds 1-10 and 101-105):
//! - one hidden effect: named first in ≥ 90 % of the logs;
//! - a pair: both found in ≥ 80 %;
//! - none: nothing added in ≥ 95 %;
//! - the gap shrinks: final NRMSE within 1.5× the generator's noise floor (the NRMSE of
//!   the noise alone) for the median log of every case, in ≥ 75 % of the logs of every
//!   case, and never above 3×. Measured (README): 305 of the 320 logs (95 %) are within
//!   1.5×; the misses gather in the Coulomb-friction cases (17/20 single, 15/20 with
//!   inertia: the smoothed sign law fitted from block-mean velocities leaves 1.5-1.9×)
//!   and in two pairs with one log each at 2.5-2.6×.

use std::ops::Range;

use estimator_core::conditioning::ImpactConfig;
use host_sim::diagnose::model::Effect;
use host_sim::diagnose::{data, diagnose, Options};
use host_sim::generator;

const SEEDS: Range<u64> = 500..520;

struct Outcome {
    /// Effects named, per seed, in order of addition (final model's list).
    found: Vec<Vec<&'static str>>,
    /// First effect added, per seed.
    first: Vec<Option<&'static str>>,
    /// Final NRMSE over the noise floor, per seed.
    ratio: Vec<f64>,
}

fn run(effects: &[Effect]) -> Outcome {
    let mut out = Outcome {
        found: Vec::new(),
        first: Vec::new(),
        ratio: Vec::new(),
    };
    for seed in SEEDS {
        let g = generator::generate(effects, seed);
        let prepared = data::prepare(
            &g.log.time_s,
            &g.log.position_m,
            &g.log.force_n,
            ImpactConfig::default(),
        )
        .unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        let d = diagnose(&prepared, &Options::default())
            .unwrap_or_else(|| panic!("seed {seed}: baseline fit"));
        out.first.push(d.steps.first().map(|s| s.effect.id()));
        out.found.push(d.effects_added());
        out.ratio
            .push(d.final_fit.nrmse_percent / generator::noise_floor_percent(&g, &prepared));
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

fn single(effect: Effect) {
    let o = run(&[effect]);
    let right = o.first.iter().filter(|f| **f == Some(effect.id())).count();
    assert!(
        right * 10 >= o.first.len() * 9,
        "{}: named first in {right}/{}: {:?}",
        effect.id(),
        o.first.len(),
        o.first
    );
    check_gap(effect.id(), &o);
}

fn pair(a: Effect, b: Effect) {
    let o = run(&[a, b]);
    let both = o
        .found
        .iter()
        .filter(|f| f.contains(&a.id()) && f.contains(&b.id()))
        .count();
    let name = format!("{}+{}", a.id(), b.id());
    assert!(
        both * 10 >= o.found.len() * 8,
        "{name}: both found in {both}/{}: {:?}",
        o.found.len(),
        o.found
    );
    check_gap(&name, &o);
}

#[test]
fn hidden_power_law_stiffness() {
    single(Effect::PowerLawStiffness);
}

#[test]
fn hidden_exponential_stiffness() {
    single(Effect::ExponentialStiffness);
}

#[test]
fn hidden_depth_dependent_damping() {
    single(Effect::DepthDependentDamping);
}

#[test]
fn hidden_relaxation() {
    single(Effect::Relaxation);
}

#[test]
fn hidden_force_offset() {
    single(Effect::ForceOffset);
}

#[test]
fn hidden_contact_point_offset() {
    single(Effect::ContactPointOffset);
}

#[test]
fn hidden_inertia() {
    single(Effect::Inertia);
}

#[test]
fn hidden_time_delay() {
    single(Effect::TimeDelay);
}

#[test]
fn hidden_coulomb_friction() {
    single(Effect::CoulombFriction);
}

#[test]
fn hidden_plastic_set() {
    single(Effect::PlasticSet);
}

#[test]
fn hidden_pair_power_law_and_relaxation() {
    pair(Effect::PowerLawStiffness, Effect::Relaxation);
}

#[test]
fn hidden_pair_depth_damping_and_force_offset() {
    pair(Effect::DepthDependentDamping, Effect::ForceOffset);
}

#[test]
fn hidden_pair_inertia_and_coulomb_friction() {
    pair(Effect::Inertia, Effect::CoulombFriction);
}

#[test]
fn hidden_pair_time_delay_and_plastic_set() {
    pair(Effect::TimeDelay, Effect::PlasticSet);
}

#[test]
fn hidden_pair_exponential_stiffness_and_contact_offset() {
    pair(Effect::ExponentialStiffness, Effect::ContactPointOffset);
}

#[test]
fn nothing_hidden_nothing_added() {
    let o = run(&[]);
    let clean = o.found.iter().filter(|f| f.is_empty()).count();
    assert!(
        clean * 100 >= o.found.len() * 95,
        "nothing added in {clean}/{}: {:?}",
        o.found.len(),
        o.found
    );
    check_gap("none", &o);
}
