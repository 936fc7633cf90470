//! Robustness of the estimator core against what goes wrong on a real rig: the simulated
//! plant (host_sim::plant) with injected faults (`Faults`) or hard conditions, its raw
//! codes converted as the firmware converts them, and the core's per-sample pipeline with
//! the double-stage Hunt-Crossley estimator on the paper's plastic layer, stepped sample
//! by sample.
//!
//! Each test asserts that every output stays finite, that the fault raises its status
//! flag where the pipeline can see it, and that the estimates are back in the band some
//! time after the fault and stay there until the next one. The numbers in the docs were
//! measured with plant seed 1 (`cargo test -p integration-tests --test faults --
//! --nocapture --test-threads 1` prints them); the asserted bounds leave a margin.
//!
//! The band ([`BAND`]): n and k·(1 mm)ⁿ within 3 % of the truth, λ·(1 mm)ⁿ within 10 %
//! (the quantities the scenarios judge, host_sim::scenarios::Truth::checks). Without any
//! fault the same pressing stays inside it from 5 s to 60 s, with worst errors n 1.4 %,
//! k·(1 mm)ⁿ 0.32 %, λ·(1 mm)ⁿ 6.2 %: the damping estimate wanders with the 2 s memory.

use estimator_core::conditioning::ContactState;
use estimator_core::hunt_crossley::{adaptive_forgetting, HUNT_CROSSLEY_RLS};
use estimator_core::rls::Rls;
use estimator_core::{
    AnyEstimator, AnyParameters, Estimator, ModelKind, Pipeline, PipelineOutput, RawSample, Status,
};
use host_sim::plant::{
    Acquisition, EncoderGlitch, FaultWindow, Faults, MaterialChange, Plant, PlantConfig,
    PlantSample, SampleFault, Trajectory,
};
use host_sim::runner::RunOptions;
use host_sim::scenarios::{gel_hunt_crossley, plastic, Truth};

/// Sample time \[s\].
const T: f64 = 1.0e-3;

/// The band the estimates must return to after a fault: relative tolerance on each
/// judged quantity, by the start of its check name (see the module docs).
const BAND: [(&str, f64); 3] = [("n", 0.03), ("k·", 0.03), ("lambda·", 0.10)];

/// The plastic-hc scenario's pressing: from 1 mm above the surface, from 0.5 s a
/// sinusoid between 50 µm out of contact and `max_depth_m`, 1-3 Hz sweeping over 2 s.
fn pressing(max_depth_m: f64) -> Trajectory {
    pressing_from(-1.0e-3, 0.5, max_depth_m)
}

/// As [`pressing`], starting at `approach_depth_m` \[m\] and pressing from `start_s` \[s\].
fn pressing_from(approach_depth_m: f64, start_s: f64, max_depth_m: f64) -> Trajectory {
    Trajectory::SineSweep {
        approach_depth_m,
        start_s,
        min_depth_m: -0.05e-3,
        max_depth_m,
        f0_hz: 1.0,
        f1_hz: 3.0,
        sweep_s: 2.0,
    }
}

/// The time within 0.5 s of `around_s` at which `trajectory` is shallowest (or deepest,
/// with `deepest`): switching to another motion at the shallowest point is smooth, the
/// probe having just left the surface at rest.
fn extreme_near(trajectory: &Trajectory, around_s: f64, deepest: bool) -> f64 {
    let depth = |t: f64| {
        let d = trajectory.depth_m(t);
        if deepest {
            -d
        } else {
            d
        }
    };
    (0..=1000)
        .map(|i| around_s - 0.5 + f64::from(i) * 1.0e-3)
        .min_by(|a, b| depth(*a).total_cmp(&depth(*b)))
        .unwrap_or(around_s)
}

/// Pressing until the shallowest point near `until_s`, then moving linearly to `depth_m`
/// over 0.3 s and holding it. Returns the trajectory and the switch time.
fn press_then_hold(until_s: f64, depth_m: f64) -> (Vec<(f64, Trajectory)>, f64) {
    let switch = extreme_near(&pressing(1.0e-3), until_s, false);
    let parts = vec![
        (0.0, pressing(1.0e-3)),
        (
            switch,
            Trajectory::Waypoints {
                points: vec![(0.0, -0.05e-3), (0.3, depth_m)],
            },
        ),
    ];
    (parts, switch)
}

/// One simulated run: what the plant did and what the pipeline said, per sample.
struct Run {
    plant: Vec<PlantSample>,
    raw: Vec<RawSample>,
    out: Vec<PipelineOutput<AnyParameters>>,
    pipeline: Pipeline<AnyEstimator>,
}

/// How the estimate came back after one fault.
#[derive(Debug)]
struct Recovery {
    /// Fault time \[s\].
    at_s: f64,
    /// Time after the fault from which the estimates stay in the band until the next
    /// fault \[s\]; `None` if they never do.
    within_s: Option<f64>,
}

impl Run {
    fn index(&self, time_s: f64) -> usize {
        ((time_s / T).round().max(0.0) as usize).min(self.out.len() - 1)
    }

    /// Largest [`band_use`] over [from_s, to_s).
    fn worst_band_use(&self, from_s: f64, to_s: f64, truth: &Truth) -> f64 {
        (self.index(from_s)..self.index(to_s))
            .map(|i| band_use(&self.out[i].estimate.parameters, truth))
            .fold(0.0, f64::max)
    }

    /// Largest relative error of each judged quantity over [from_s, to_s), as
    /// "n a %, k b %, lambda c %".
    fn worst_errors(&self, from_s: f64, to_s: f64, truth: &Truth) -> String {
        BAND.iter()
            .map(|(name, _)| {
                let worst = (self.index(from_s)..self.index(to_s))
                    .map(|i| relative_error(&self.out[i].estimate.parameters, truth, name))
                    .fold(0.0, f64::max);
                format!("{} {:.2} %", name.trim_end_matches('·'), 100.0 * worst)
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Time after `from_s` from which the estimates stay in the band until `to_s`.
    fn within_after(&self, from_s: f64, to_s: f64, truth: &Truth) -> Option<f64> {
        let (a, b) = (self.index(from_s), self.index(to_s));
        let last_bad = (a..b)
            .rev()
            .find(|&i| band_use(&self.out[i].estimate.parameters, truth) > 1.0);
        match last_bad {
            None => Some(0.0),
            Some(i) if i + 1 < b => Some((i + 1 - a) as f64 * T),
            Some(_) => None,
        }
    }

    /// One [`Recovery`] per fault in `faults_s` (sorted), each judged until the next
    /// fault or `end_s`; printed under `label`.
    fn recoveries(
        &self,
        faults_s: &[f64],
        end_s: f64,
        truth: &Truth,
        label: &str,
    ) -> Vec<Recovery> {
        let mut all = Vec::new();
        for (i, &at_s) in faults_s.iter().enumerate() {
            let next = faults_s.get(i + 1).copied().unwrap_or(end_s);
            let r = Recovery {
                at_s,
                within_s: self.within_after(at_s, next, truth),
            };
            println!(
                "{label}: fault at {at_s:.3} s: worst until {next:.2} s: {}; back in the band \
                 {:?} s after",
                self.worst_errors(at_s, next, truth),
                r.within_s
            );
            all.push(r);
        }
        all
    }

    fn all_finite(&self) -> bool {
        self.out.iter().all(|o| {
            o.sample.is_finite()
                && o.estimate.parameters.iter().all(|(_, v)| v.is_finite())
                && o.estimate.predicted_force_n.is_finite()
                && o.force_offset_n.is_finite()
        })
    }

    fn count(&self, flag: Status) -> usize {
        self.out.iter().filter(|o| o.status.contains(flag)).count()
    }
}

/// Asserts that every fault was recovered from within `max_s`.
fn assert_recovered(recoveries: &[Recovery], max_s: f64) {
    for r in recoveries {
        assert!(
            r.within_s.is_some_and(|s| s <= max_s),
            "fault at {} s: not back in the band after {max_s} s: {r:?}",
            r.at_s
        );
    }
}

/// Relative error of the judged quantity whose check name starts with `name`.
fn relative_error(parameters: &AnyParameters, truth: &Truth, name: &str) -> f64 {
    truth
        .checks(parameters, 1.0)
        .iter()
        .filter(|c| c.tolerance.is_some() && c.name.starts_with(name))
        .map(|c| c.relative_error)
        .fold(0.0, f64::max)
}

/// The largest ratio of a judged quantity's relative error to its tolerance in [`BAND`]:
/// ≤ 1 inside the band.
fn band_use(parameters: &AnyParameters, truth: &Truth) -> f64 {
    BAND.iter()
        .map(|(name, tolerance)| relative_error(parameters, truth, name) / tolerance)
        .fold(0.0, f64::max)
}

/// Runs the plant and the pipeline of `options` for `seconds`.
fn simulate(
    plant: PlantConfig,
    materials: Vec<MaterialChange>,
    seconds: f64,
    options: &RunOptions,
) -> Run {
    let mut acquisition = Acquisition::new(&plant, 0.0).expect("valid acquisition");
    let mut p = Plant::new(plant, materials).expect("valid plant");
    let estimator = AnyEstimator::try_new(options.model, &options.settings).expect("valid");
    let mut pipeline = Pipeline::try_new(options.pipeline, estimator).expect("valid");
    let n = (seconds / T).round() as usize;
    let mut run = Run {
        plant: Vec::with_capacity(n),
        raw: Vec::with_capacity(n),
        out: Vec::with_capacity(n),
        pipeline,
    };
    for _ in 0..n {
        let s = p.step();
        let raw = acquisition.convert(&s);
        run.out.push(pipeline.step(&raw));
        run.plant.push(s);
        run.raw.push(raw);
    }
    run.pipeline = pipeline;
    run
}

fn plastic_run(plant: PlantConfig, seconds: f64) -> Run {
    simulate(
        plant,
        vec![MaterialChange {
            at_s: 0.0,
            model: Box::new(plastic()),
        }],
        seconds,
        &RunOptions::for_model(ModelKind::HuntCrossley),
    )
}

fn plastic_truth() -> Truth {
    Truth::HuntCrossley(plastic())
}

fn pressing_plant(faults: Faults) -> PlantConfig {
    PlantConfig {
        trajectory: pressing(1.0e-3),
        faults,
        ..PlantConfig::default()
    }
}

/// No fault, 60 s: the reference. Measured: in the band from 5 s to the end, worst
/// errors n 1.36 %, k·(1 mm)ⁿ 0.32 %, λ·(1 mm)ⁿ 6.18 %.
#[test]
fn reference_without_faults_stays_in_the_band() {
    let run = plastic_run(pressing_plant(Faults::default()), 60.0);
    assert!(run.all_finite());
    assert_eq!(
        run.count(Status::SAMPLE_DROPPED) + run.count(Status::SATURATED),
        0
    );
    let truth = plastic_truth();
    println!("reference 5-60 s: {}", run.worst_errors(5.0, 60.0, &truth));
    assert!(run.worst_band_use(5.0, 60.0, &truth) <= 1.0);
}

/// NaN and +∞ force readings in contact: one every 2.5 s from 10.3 s (NaN single
/// samples, +∞ for 5 ms) and NaN at random on 1 sample in 1000. The pipeline treats a
/// non-finite raw input as a dropped sample (its filters coast on the last good sample,
/// the estimator skips it, so the estimators' own `NON_FINITE_INPUT` never arises) and
/// flags `SAMPLE_DROPPED` on exactly the faulty samples. The estimates never leave the
/// band. Measured: 52 faulty samples; worst from 10.3 s to 30 s n 1.17 %, k·(1 mm)ⁿ
/// 0.32 %, λ·(1 mm)ⁿ 4.21 % (4.28 % without faults).
#[test]
fn nan_and_infinite_force_samples_are_skipped() {
    let times: Vec<f64> = (0..8).map(|i| 10.3 + 2.5 * f64::from(i)).collect();
    let run = plastic_run(
        pressing_plant(Faults {
            nan_force: times
                .iter()
                .step_by(2)
                .map(|&t| FaultWindow::at(t))
                .collect(),
            infinite_force: times
                .iter()
                .skip(1)
                .step_by(2)
                .map(|&t| FaultWindow {
                    start_s: t,
                    duration_s: 0.005,
                })
                .collect(),
            nan_force_probability_per_sample: 1.0e-3,
            seed: 3,
            ..Faults::default()
        }),
        30.0,
    );
    assert!(run.all_finite());
    let faulty: Vec<bool> = run
        .plant
        .iter()
        .map(|s| s.fault != SampleFault::None)
        .collect();
    for (i, o) in run.out.iter().enumerate() {
        assert_eq!(
            o.status.contains(Status::SAMPLE_DROPPED),
            faulty[i],
            "sample {i}"
        );
    }
    let n_faulty = faulty.iter().filter(|f| **f).count();
    let truth = plastic_truth();
    println!(
        "nan/inf: {n_faulty} faulty samples; {}",
        run.worst_errors(times[0], 30.0, &truth)
    );
    assert!(n_faulty >= 40, "{n_faulty}");
    assert!(run.worst_band_use(times[0], 30.0, &truth) <= 1.0);
}

/// Dropped samples (position and force NaN), 6 s apart: single samples, bursts of 5 ms
/// and of 50 ms. Flagged `SAMPLE_DROPPED` on exactly those samples. While samples are
/// missing the filters coast on the last good one; when they return the position and
/// force have moved on, and that step passes through the state-variable filter into the
/// δ̇ and F of the next ≈ 10 ms, which the estimator does use: a 50 ms gap in mid-stroke
/// throws the damping estimate off. Measured: after the single samples and 5 ms bursts
/// λ·(1 mm)ⁿ stays within 6 % (in the band throughout); after the 50 ms bursts it peaks
/// at 18.6-18.7 % and is back in the band 2.5 s and 1.7 s later (n within 0.9 %,
/// k·(1 mm)ⁿ within 0.3 % throughout). Asserted: back in the band after at most 4 s.
#[test]
fn dropped_samples_are_flagged_and_bridged() {
    let times = [10.3, 16.3, 22.3, 28.3, 34.3, 40.3];
    let lengths = [0.0, 0.005, 0.05, 0.0, 0.005, 0.05];
    let run = plastic_run(
        pressing_plant(Faults {
            dropped: times
                .iter()
                .zip(lengths)
                .map(|(&start_s, duration_s)| FaultWindow {
                    start_s,
                    duration_s,
                })
                .collect(),
            ..Faults::default()
        }),
        46.0,
    );
    assert!(run.all_finite());
    for (i, o) in run.out.iter().enumerate() {
        let dropped = run.plant[i].fault == SampleFault::Dropped;
        assert_eq!(
            o.status.contains(Status::SAMPLE_DROPPED),
            dropped,
            "sample {i}"
        );
    }
    assert_eq!(run.count(Status::SAMPLE_DROPPED), 2 * (1 + 5 + 50));
    let recoveries = run.recoveries(&times, 46.0, &plastic_truth(), "dropped");
    assert_recovered(&recoveries, 4.0);
}

/// Dropped samples at random, 1 in 500 (single-sample gaps, 2 per second), for 40 s.
/// Measured: 71 dropped, all flagged; in the band from 10 s to the end, worst n 1.20 %,
/// k·(1 mm)ⁿ 0.34 %, λ·(1 mm)ⁿ 5.98 %.
#[test]
fn random_single_dropped_samples_do_not_disturb() {
    let run = plastic_run(
        pressing_plant(Faults {
            dropped_probability_per_sample: 2.0e-3,
            seed: 4,
            ..Faults::default()
        }),
        40.0,
    );
    assert!(run.all_finite());
    let dropped = run
        .plant
        .iter()
        .filter(|s| s.fault == SampleFault::Dropped)
        .count();
    assert_eq!(run.count(Status::SAMPLE_DROPPED), dropped);
    let truth = plastic_truth();
    println!(
        "random drops: {dropped} dropped; {}",
        run.worst_errors(10.0, 40.0, &truth)
    );
    assert!(dropped > 40, "{dropped}");
    assert!(run.worst_band_use(10.0, 40.0, &truth) <= 1.0);
}

/// The load cell driven beyond the ADC's range in contact for 20 ms, 8 s apart (a knock,
/// an electrical spike: the ADC reads its top code, 33 N). Every such sample is marked
/// saturated by the acquisition and flagged `SATURATED` by the pipeline, which skips the
/// estimator on it; but the clipped force still enters the force filter, so the next
/// ≈ 10 ms of filtered force carry a transient of up to +20 N that the estimator does
/// use. Measured: λ·(1 mm)ⁿ peaks at 17.4-18.7 % (n and k·(1 mm)ⁿ within 0.8 %), back in
/// the band 1.0-1.3 s after each window; at the bottom of a stroke (δ̇ ≈ 0) the same
/// windows stay in the band, and 3 s apart (before recovering from the previous one) the
/// peaks reached 57 %. Asserted: all 80 samples flagged, back in the band after at most
/// 3 s.
#[test]
fn adc_overload_in_contact_is_flagged_and_recovered_from() {
    let times = [12.0, 20.0, 28.0, 36.0];
    let run = plastic_run(
        pressing_plant(Faults {
            adc_overload: times
                .iter()
                .map(|&start_s| FaultWindow {
                    start_s,
                    duration_s: 0.020,
                })
                .collect(),
            ..Faults::default()
        }),
        44.0,
    );
    assert!(run.all_finite());
    let saturated_raw = run.raw.iter().filter(|r| r.saturated).count();
    assert_eq!(saturated_raw, 80);
    assert!(run
        .raw
        .iter()
        .zip(&run.out)
        .filter(|(r, _)| r.saturated)
        .all(|(_, o)| o.status.contains(Status::SATURATED)));
    assert_eq!(run.count(Status::SATURATED), saturated_raw);
    let recoveries = run.recoveries(&times, 44.0, &plastic_truth(), "overload");
    assert_recovered(&recoveries, 3.0);
}

/// The material's own force beyond the ADC's range: the plastic pressed to 3 mm peaks
/// above 33 N, so the bottom of every stroke saturates. Those samples are flagged
/// `SATURATED` and skipped; the estimates stay in the band. Measured: 26.4 % of the
/// in-contact samples saturated; from 10 s to 30 s worst n 1.50 %, k·(1 mm)ⁿ 1.01 %,
/// λ·(1 mm)ⁿ 0.78 %.
#[test]
fn force_beyond_full_scale_is_flagged_and_skipped() {
    let plant = PlantConfig {
        trajectory: pressing(3.0e-3),
        ..PlantConfig::default()
    };
    let run = plastic_run(plant, 30.0);
    assert!(run.all_finite());
    let contact = run
        .out
        .iter()
        .filter(|o| o.contact == ContactState::InContact)
        .count();
    let saturated = run.count(Status::SATURATED);
    assert_eq!(saturated, run.raw.iter().filter(|r| r.saturated).count());
    let truth = plastic_truth();
    println!(
        "beyond full scale: {saturated} of {contact} in-contact samples saturated ({:.1} %); {}",
        100.0 * saturated as f64 / contact as f64,
        run.worst_errors(10.0, 30.0, &truth)
    );
    assert!(saturated * 10 > contact, "{saturated} of {contact}");
    assert!(run.worst_band_use(10.0, 30.0, &truth) <= 1.0);
}

/// Encoder glitches 6 s apart: spikes of 200 counts (0.2 mm) for one sample, and slips of
/// +20 and −20 counts that stay (lost counts: the measured position is off for good, and
/// the motor's position loop, reading the same counter, moves the probe by the opposite
/// amount). The pipeline cannot tell a glitch from motion, so no flag is expected. A
/// slip shifts the depth only until the next impact, which re-measures the contact point
/// (`RecontactPolicy::EachImpact`; the pressing leaves the surface every stroke).
/// Measured: λ·(1 mm)ⁿ peaks at 6.9-11.3 %, n within 2.6 %, k·(1 mm)ⁿ within 0.33 %; back
/// in the band after at most 0.8 s. Asserted: at most 2 s.
#[test]
fn encoder_spikes_and_slips_are_absorbed_at_the_next_contact() {
    let times = [10.3, 16.3, 22.3, 28.3, 34.3, 40.3];
    let glitches = times
        .iter()
        .enumerate()
        .map(|(i, &at_s)| {
            let (counts, duration_s) = [(200, 0.0), (20, 1.0e3), (-20, 1.0e3)][i % 3];
            EncoderGlitch {
                at_s,
                counts,
                duration_s,
            }
        })
        .collect();
    let run = plastic_run(
        pressing_plant(Faults {
            encoder_glitches: glitches,
            ..Faults::default()
        }),
        46.0,
    );
    assert!(run.all_finite());
    let recoveries = run.recoveries(&times, 46.0, &plastic_truth(), "encoder");
    assert_recovered(&recoveries, 2.0);
}

/// The 16-bit encoder counter wrapping: the surface sits at 65.5 mm from the counter's
/// zero, so the counter passes 65 535 → 0 twice per stroke. The unwrapped position is
/// continuous and the run matches the one without wrapping. Measured: 119 wraps in 30 s;
/// final parameters equal to the run with the surface at 10 mm to 1e-3; in the band
/// from 10 s (λ·(1 mm)ⁿ 4.28 %, as without wrapping).
#[test]
fn sixteen_bit_counter_wraps_every_stroke() {
    let wrapping = PlantConfig {
        surface_position_m: 0.0655,
        ..pressing_plant(Faults::default())
    };
    let run = plastic_run(wrapping, 30.0);
    let reference = plastic_run(pressing_plant(Faults::default()), 30.0);
    assert!(run.all_finite());
    let wraps = run
        .plant
        .windows(2)
        .filter(|w| w[1].encoder_raw.abs_diff(w[0].encoder_raw) > 30_000)
        .count();
    let truth = plastic_truth();
    println!(
        "wrap: {wraps} wraps; {}",
        run.worst_errors(10.0, 30.0, &truth)
    );
    assert!(wraps >= 20, "{wraps}");
    assert!(run.worst_band_use(10.0, 30.0, &truth) <= 1.0);
    let last = |r: &Run| r.out.last().expect("samples").estimate.parameters;
    for ((name, a), (_, b)) in last(&run).iter().zip(last(&reference).iter()) {
        assert!((a / b - 1.0).abs() < 1.0e-3, "{name}: {a} vs {b}");
    }
}

/// Contact loss and re-contact: pressing for 12 s, 5 s held 1 mm above the surface,
/// pressing again. Contact loss is flagged (`CONTACT_LOST`, then `NO_CONTACT` while
/// away), the estimate is held unchanged while out of contact, the new contact is flagged
/// `CONTACT_ONSET`, and the estimates stay in the band. Measured: held bit for bit;
/// after re-contact worst n 2.48 %, k·(1 mm)ⁿ 0.35 %, λ·(1 mm)ⁿ 7.82 %.
#[test]
fn contact_loss_holds_the_estimate_and_recontact_resumes() {
    let (mut parts, away) = press_then_hold(12.0, -1.0e-3);
    parts.push((away + 5.0, pressing_from(-1.0e-3, 0.0, 1.0e-3)));
    let plant = PlantConfig {
        trajectory: Trajectory::Sequence { parts },
        ..PlantConfig::default()
    };
    let run = plastic_run(plant, 30.0);
    assert!(run.all_finite());
    let truth = plastic_truth();
    let (a, b) = (run.index(away + 0.1), run.index(away + 5.0));
    assert!(run.out[a..b]
        .iter()
        .all(|o| o.status.contains(Status::NO_CONTACT)));
    assert!(run.out[run.index(away - 0.5)..a]
        .iter()
        .any(|o| o.status.contains(Status::CONTACT_LOST)));
    let held = run.out[a].estimate.parameters;
    assert!(run.out[a..b].iter().all(|o| o.estimate.parameters == held));
    let recontact = (b..run.out.len())
        .find(|&i| run.out[i].status.contains(Status::CONTACT_ONSET))
        .expect("re-contact");
    let t = recontact as f64 * T;
    println!(
        "recontact at {t:.3} s: after it {}",
        run.worst_errors(t, 30.0, &truth)
    );
    assert!(run.worst_band_use(t, 30.0, &truth) <= 1.0);
}

/// Abrupt material changes, plastic → soft gel → plastic (≈ 12 s each, switched between
/// strokes), with the adaptive forgetting of eq. (24) as in the gel-to-plastic scenario.
/// The residual monitor flags `MODEL_MISMATCH` after the switch to the gel, while the
/// plastic's parameters mispredict it; after the switch back the adaptive forgetting
/// follows fast enough that the monitor never fires. Measured: in the gel's band 4.1 s
/// after the switch, in the plastic's 5.0 s after the switch back; `MODEL_MISMATCH`
/// first 2.3 s after the switch to gel. Asserted: in the band after at most 8 s, the flag
/// within 3 s of the switch to gel.
#[test]
fn abrupt_material_changes_are_flagged_and_tracked() {
    let to_gel = extreme_near(&pressing(1.0e-3), 12.0, false);
    let gel_pressing = Trajectory::SineSweep {
        approach_depth_m: -0.05e-3,
        start_s: 0.0,
        min_depth_m: -0.05e-3,
        max_depth_m: 5.0e-3,
        f0_hz: 0.5,
        f1_hz: 1.5,
        sweep_s: 3.0,
    };
    let to_plastic = to_gel + extreme_near(&gel_pressing, 12.0, false);
    let plant = PlantConfig {
        trajectory: Trajectory::Sequence {
            parts: vec![
                (0.0, pressing(1.0e-3)),
                (to_gel, gel_pressing),
                (to_plastic, pressing_from(-0.05e-3, 0.0, 1.0e-3)),
            ],
        },
        ..PlantConfig::default()
    };
    let materials = vec![
        MaterialChange {
            at_s: 0.0,
            model: Box::new(plastic()),
        },
        MaterialChange {
            at_s: to_gel,
            model: Box::new(gel_hunt_crossley()),
        },
        MaterialChange {
            at_s: to_plastic,
            model: Box::new(plastic()),
        },
    ];
    let end = to_plastic + 12.0;
    let mut options = RunOptions::for_model(ModelKind::HuntCrossley);
    options.settings.forgetting = Some(adaptive_forgetting(0.3));
    let run = simulate(plant, materials, end, &options);
    assert!(run.all_finite());
    let gel = Truth::HuntCrossley(gel_hunt_crossley());
    let plastic = plastic_truth();
    let mut first_mismatch = Vec::new();
    for (switch, until, truth, name) in [
        (to_gel, to_plastic, &gel, "gel"),
        (to_plastic, end, &plastic, "plastic"),
    ] {
        let within = run.within_after(switch, until, truth);
        let mismatch = (run.index(switch)..run.index(until))
            .find(|&i| run.out[i].status.contains(Status::MODEL_MISMATCH))
            .map(|i| i as f64 * T - switch);
        println!(
            "switch to {name} at {switch:.3} s: in the band after {within:?} s, \
             MODEL_MISMATCH first after {mismatch:?} s; last 2 s: {}",
            run.worst_errors(until - 2.0, until, truth)
        );
        assert!(within.is_some_and(|r| r <= 8.0), "{name}: {within:?}");
        first_mismatch.push(mismatch);
    }
    assert!(
        first_mismatch[0].is_some_and(|t| t <= 3.0),
        "{first_mismatch:?}"
    );
}

/// A long hold without excitation: pressing for 12 s, then 60 s held still at 0.7 mm
/// (δ̇ = 0: the damping regressor δⁿ·δ̇ vanishes and Γ2 sees a single ln δ), then
/// pressing again. The covariance's trace is capped (`COVARIANCE_BOUNDED`; see the RLS
/// test below, `AnyEstimator` does not expose P), so nothing overflows, and n and
/// k·(1 mm)ⁿ, which the hold still determines, stay put. The damping is not observable
/// in a hold: with P at its cap in that direction, noise walks λ̂ away (to zero and
/// below, flagged `NONPHYSICAL`), and pressing restores it within seconds.
/// Measured: n and k·(1 mm)ⁿ within 0.48 % through the hold; λ·(1 mm)ⁿ off by up to
/// 109 %; `COVARIANCE_BOUNDED` on 43 824 of the 59 500 hold samples; standard errors
/// (σ̂·√P_ii) n 0.0007 → 0.0014, k 6.4 → 1.1, λ 1.7e3 → 1.7e4 from before to the end of
/// the hold; back in the band 0.13 s after pressing resumes. Asserted: n and k·(1 mm)ⁿ in
/// the band through the hold, standard errors finite and below n 0.1, k and λ their true
/// values; back in the band after at most 2 s of pressing.
#[test]
fn long_hold_without_excitation_does_not_wind_up() {
    let (mut parts, hold) = press_then_hold(12.0, 0.7e-3);
    let resume = hold + 60.0;
    parts.push((resume, pressing_from(0.7e-3, 0.0, 1.0e-3)));
    let trajectory = Trajectory::Sequence { parts };
    let plant = |trajectory: Trajectory| PlantConfig {
        trajectory,
        ..PlantConfig::default()
    };
    let truth = plastic_truth();
    let end = resume + 15.0;
    let run = plastic_run(plant(trajectory.clone()), end);
    assert!(run.all_finite());
    let (a, b) = (run.index(hold + 0.5), run.index(resume));
    assert!(run.out[a..b]
        .iter()
        .all(|o| o.contact == ContactState::InContact));
    let worst = |name: &str| {
        (a..b)
            .map(|i| relative_error(&run.out[i].estimate.parameters, &truth, name))
            .fold(0.0, f64::max)
    };
    let bounded = run.out[a..b]
        .iter()
        .filter(|o| o.status.contains(Status::COVARIANCE_BOUNDED))
        .count();
    let within = run.within_after(resume, end, &truth);
    println!(
        "hold: n {:.2} %, k at 1 mm {:.2} %, damping at 1 mm {:.1} %; COVARIANCE_BOUNDED on \
         {bounded} of {} samples; back in the band {within:?} s after pressing resumes",
        100.0 * worst("n"),
        100.0 * worst("k·"),
        100.0 * worst("lambda·"),
        b - a,
    );
    assert!(worst("n") <= 0.03 && worst("k·") <= 0.03);
    assert!(bounded > 0);
    assert!(within.is_some_and(|s| s <= 2.0), "{within:?}");
    let AnyParameters::HuntCrossley(t) = truth.parameters().expect("Hunt-Crossley") else {
        panic!("Hunt-Crossley truth")
    };
    for (label, seconds) in [
        ("before the hold", hold),
        ("at the end of the hold", resume),
    ] {
        let cut = plastic_run(plant(trajectory.clone()), seconds);
        let AnyParameters::HuntCrossley(se) = cut.pipeline.estimator().standard_errors() else {
            panic!("Hunt-Crossley estimator")
        };
        println!("hold: standard errors {label}: {se:?}");
        assert!(se.n.is_finite() && se.n < 0.1, "{se:?}");
        assert!(se.k.is_finite() && se.k < t.k, "{se:?}");
        assert!(se.lambda.is_finite() && se.lambda < t.lambda, "{se:?}");
    }
}

/// The covariance bound itself, on the core's RLS with the Hunt-Crossley stages'
/// configuration (β = 0.9995, start-up 0.99, P(0) = 1e3·I, trace bound 2e3): 600 000
/// updates (10 min at 1 kHz) with a regressor that excites one direction only (Γ1 in a
/// hold: \[δⁿ, 0\]) and noise on y. trace(P) never exceeds the bound, P stays positive
/// definite, θ stays finite, `COVARIANCE_BOUNDED` is raised, and when the second
/// direction is excited again θ converges as from start-up. Measured: the trace reaches
/// the bound (2000.0) and is held there on 599 929 of the 600 000 updates.
#[test]
fn rls_covariance_stays_bounded_through_a_long_hold() {
    let config = HUNT_CROSSLEY_RLS;
    let mut rls = Rls::<2>::try_new(&config).expect("valid");
    let bound = config.max_covariance_trace_factor * config.initial_covariance * 2.0;
    let beta = 0.9995;
    let mut noise = 0.0f32;
    let mut bounded = 0;
    let mut max_trace = 0.0f32;
    for h in 0..600_000u32 {
        // Truth θ = [11.5, 70e-3]; in the hold only φ = [0.65, 0].
        noise = (noise * 1.7 + 0.37 + (h % 13) as f32 * 0.11).fract();
        let y = 11.5 * 0.65 + 0.02 * (noise - 0.5);
        let u = rls.update(&[0.65, 0.0].into(), y, beta);
        if u.status.contains(Status::COVARIANCE_BOUNDED) {
            bounded += 1;
        }
        let p = rls.covariance();
        max_trace = max_trace.max(p.trace());
        assert!(p.trace() <= bound * 1.0001, "h {h}: {p:?}");
        assert!(
            p[(0, 0)] > 0.0 && p[(1, 1)] > 0.0 && p.determinant() > 0.0,
            "h {h}: {p:?}"
        );
        assert!(rls.theta().iter().all(|v| v.is_finite()));
    }
    println!("rls hold: max trace {max_trace:.1} (bound {bound}), bounded on {bounded} updates");
    assert!(bounded > 0);
    assert!((rls.theta()[0] - 11.5).abs() < 0.01, "{:?}", rls.theta());
    // Excitation returns: both parameters within 1 % after 2 s.
    for h in 0..2000u32 {
        let v = (h as f32 * 0.0126).sin() * 3.0;
        rls.update(
            &[0.65, 0.65 * v].into(),
            11.5 * 0.65 + 70.0e-3 * 0.65 * v,
            beta,
        );
    }
    let th = rls.theta();
    assert!(
        (th[0] / 11.5 - 1.0).abs() < 0.01 && (th[1] / 70.0e-3 - 1.0).abs() < 0.01,
        "{th:?}"
    );
}

/// Pressing for 4 s, then `dwell_s` held still 1 mm above the surface, repeated for
/// `seconds`; returns the trajectory and the end time of each dwell.
fn press_and_dwell(dwell_s: f64, seconds: f64) -> (Trajectory, Vec<f64>) {
    let mut parts = Vec::new();
    let mut dwell_ends = Vec::new();
    let mut t = 0.0;
    while t < seconds {
        let press = pressing_from(-1.0e-3, 0.0, 1.0e-3);
        let away = t + extreme_near(&press, 4.0, false);
        parts.push((t, press));
        parts.push((
            away,
            Trajectory::Waypoints {
                points: vec![(0.0, -0.05e-3), (0.3, -1.0e-3)],
            },
        ));
        t = away + dwell_s;
        dwell_ends.push(t);
    }
    (Trajectory::Sequence { parts }, dwell_ends)
}

/// Load-cell offset drift of 0.025 mV/s (0.5 mN/s, 30 mN over the minute). The
/// pipeline's tare only learns drift in free space while the probe is still (slower than
/// 0.2 mm/s: an approaching probe whose force creeps up is touching, not drifting), so
/// the motion alternates 4 s of pressing with 10 s held still 1 mm above the surface.
///
/// The tracking is slower than its nominal 2 s time constant (`TareConfig::tracking_samples`):
/// it only uses samples within the release threshold of the current offset (a quarter of
/// the onset threshold, ≈ 30 mN = 1.5 σ with the rig's 20 mN noise), and that truncated
/// mean pulls each correction towards the current estimate. Measured on a 20 mN step of
/// the offset with the probe still: 63 % learned after ≈ 5 s at 20 mN noise, after
/// ≈ 1.8 s without noise. An offset error beyond the release threshold keeps the
/// detector in contact; the next free-space stretch (the probe travelling behind the
/// contact point with a flat force) then re-tares even so. And Γ2's logarithm of the
/// force down to its 0.2 N guard makes n̂ sensitive to the residual offset.
///
/// Measured here: the offset found at the end of each dwell is 3.7, −0.4, 2.5, 4.3 mN
/// behind the truth (each dwell's free-space stretch re-tares), the contact released
/// every time; from 10 s to 60 s n 1.9 %, k·(1 mm)ⁿ 0.3 %, λ·(1 mm)ⁿ 9.0 %. Under
/// continuous pressing the probe leaves the surface by only 50 µm per stroke, too little
/// for a free-space stretch behind the contact point (30 µm of travel, 30 µm behind it):
/// the offset is 25 mN behind at 60 s. Asserted: every dwell ends in free space with the
/// offset less than 20 mN behind, the continuous run more than 20 mN behind; with dwells
/// k·(1 mm)ⁿ and λ·(1 mm)ⁿ in the band and n within 8 %.
#[test]
fn load_cell_offset_drift_is_tracked_while_the_probe_is_still() {
    let drift_v_per_s = 0.025e-3;
    let (trajectory, dwell_ends) = press_and_dwell(10.0, 60.0);
    let with_dwells = PlantConfig {
        trajectory,
        ..PlantConfig::default()
    };
    let mut runs = Vec::new();
    for mut plant in [with_dwells, pressing_plant(Faults::default())] {
        plant.load_cell.offset_drift_v_per_s = drift_v_per_s;
        let run = plastic_run(plant, 60.0);
        assert!(run.all_finite());
        runs.push(run);
    }
    let sensitivity = f64::from(PlantConfig::default().load_cell.sensitivity_v_per_n);
    let true_offset = |t: f64| f64::from(drift_v_per_s) * t / sensitivity;
    let truth = plastic_truth();
    let dwelling = &runs[0];
    let mut behind = Vec::new();
    for &end in dwell_ends.iter().filter(|&&e| e < 60.0) {
        let o = &dwelling.out[dwelling.index(end - 0.01)];
        assert_eq!(
            o.contact,
            ContactState::FreeSpace,
            "dwell ending at {end} s"
        );
        behind.push(true_offset(end) - f64::from(o.force_offset_n));
    }
    let pressing_only = &runs[1];
    let untracked =
        true_offset(60.0) - f64::from(pressing_only.out.last().expect("samples").force_offset_n);
    println!(
        "drift: offset behind at the dwells' ends {:.1?} mN, 10-60 s {}; continuous \
         pressing: offset {:.1} mN behind, 10-60 s {}",
        behind.iter().map(|b| 1e3 * b).collect::<Vec<_>>(),
        dwelling.worst_errors(10.0, 60.0, &truth),
        1e3 * untracked,
        pressing_only.worst_errors(10.0, 60.0, &truth),
    );
    assert!(behind.iter().all(|b| b.abs() < 0.020), "{behind:?}");
    assert!(untracked > 0.020, "{untracked}");
    let (a, b) = (dwelling.index(10.0), dwelling.index(60.0));
    let worst = |name: &str| {
        (a..b)
            .map(|i| relative_error(&dwelling.out[i].estimate.parameters, &truth, name))
            .fold(0.0, f64::max)
    };
    assert!(worst("k·") <= 0.03 && worst("lambda·") <= 0.10 && worst("n") <= 0.08);
}
