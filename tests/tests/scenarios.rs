//! The paper's experiments (Sec. 5) end to end: simulated plant with sensor noise and
//! quantisation → the firmware's per-sample pipeline (tare, impact detection, state
//! variable filter) → estimator. Each scenario states its tolerance (host_sim::scenarios);
//! the worst errors over plant seeds 1-40 are in the README.

use host_sim::report::{run_scenario, ScenarioOutcome};
use host_sim::scenarios;

fn run(name: &str) -> ScenarioOutcome {
    let scenario = scenarios::by_name(name).expect("scenario exists");
    let outcome = run_scenario(&scenario, None).expect("scenario runs");
    for e in &outcome.estimators {
        for c in &e.checks {
            println!(
                "{name} {}: {} true {:.4e} estimated {:.4e} error {:.2} % (tolerance {})",
                e.model,
                c.name,
                c.truth,
                c.estimate,
                100.0 * c.relative_error,
                c.tolerance
                    .map_or("reported".into(), |t| format!("{:.0} %", 100.0 * t))
            );
        }
    }
    outcome
}

fn assert_all_pass(outcome: &ScenarioOutcome) {
    for e in &outcome.estimators {
        for c in &e.checks {
            assert!(
                c.passes(),
                "{} {}: {} off by {:.2} %",
                outcome.name,
                e.model,
                c.name,
                100.0 * c.relative_error
            );
        }
        let nrmse = e.run.nrmse_percent.expect("fit quality");
        assert!(
            nrmse < 3.0,
            "{} {}: NRMSE {nrmse:.2} %",
            outcome.name,
            e.model
        );
    }
}

#[test]
fn plastic_layer_hunt_crossley_within_3_percent() {
    let o = run("plastic-hc");
    assert_all_pass(&o);
    // The paper's Fig. 12: the estimates settle within 1-2 s of contact; here the double
    // stage is within 5 % on every asserted quantity before the end of the 10 s record.
    assert!(o.estimators[0].within_5_percent_from_s.is_some());
}

#[test]
fn soft_gel_kelvin_voigt_within_2_percent() {
    let o = run("gel-kv");
    assert_all_pass(&o);
    assert!(o.estimators[0].within_2_percent_from_s.unwrap() < 1.5);
}

#[test]
fn soft_gel_hunt_crossley_within_4_percent() {
    let o = run("gel-hc");
    assert_all_pass(&o);
    assert!(o.estimators[0].within_5_percent_from_s.unwrap() < 8.0);
}

#[test]
fn gel_to_plastic_switch_reconverges_within_3_percent() {
    let o = run("gel-to-plastic");
    assert_all_pass(&o);
    // Counted from the switch at 8 s, in a 20 s record.
    assert!(o.estimators[0].within_5_percent_from_s.unwrap() < 12.0);
}

#[test]
fn polyurethane_hammerstein_within_10_percent() {
    let o = run("polyurethane-hammerstein");
    assert_all_pass(&o);
    let e = &o.estimators[0];
    // The relaxation is the point of this model: rate and relaxed fraction are tighter.
    for c in &e.checks {
        if c.name.starts_with("relaxation rate") || c.name.starts_with("relaxed fraction") {
            assert!(
                c.relative_error < 0.05,
                "{}: {:.2} %",
                c.name,
                100.0 * c.relative_error
            );
        }
    }
}

/// Contact points (measured: pressing scenarios within 6 µm; the polyurethane's single
/// 30 mm/s ramp 27.5 µm early, because its force rises slower than the power law while the
/// material already relaxes, and the filtered rise is distorted at that speed). Asserted:
/// 10 µm for the pressing scenarios, 1 % of the deepest indentation (30 µm) for the ramp.
#[test]
fn contact_point_is_found_within_10_micrometres_or_1_percent() {
    for name in scenarios::names() {
        let o = run(name);
        for e in &o.estimators {
            let (found, truth) = e.contact_position_m;
            let bound = if name == "polyurethane-hammerstein" {
                30e-6
            } else {
                10e-6
            };
            println!(
                "{name} {}: contact {:+.1} µm",
                e.model,
                (found - truth) * 1e6
            );
            assert!(
                (found - truth).abs() < bound,
                "{name} {}: contact {found:e} vs {truth:e}",
                e.model
            );
        }
    }
}
