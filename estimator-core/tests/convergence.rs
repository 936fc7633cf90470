//! Each estimator on data made by the core's own models with the paper's sensor noise
//! (30 mN load-cell noise, 1 µm encoder steps), conditioned as the pipeline does. Seeds
//! 1001+ were never used while choosing the defaults (those were tuned on seeds 1-5).
//!
//! Times quoted in the test docs are the measured worst case over the seeds of the test
//! ("within 2 % from t" = the estimate stays within 2 % of the truth for every later
//! sample). `cargo test -p estimator-core --test convergence -- --nocapture` prints them.

mod common;

use common::*;
use estimator_core::hammerstein::{Hammerstein1, HammersteinConfig};
use estimator_core::hunt_crossley::{
    adaptive_forgetting, HuntCrossleyConfig, HuntCrossleyEstimator, SingleStageHuntCrossleyConfig,
    SingleStageHuntCrossleyEstimator,
};
use estimator_core::kelvin_voigt::{KelvinVoigtConfig, KelvinVoigtEstimator};
use estimator_core::models::{
    ContactModel, ElasticResponse, HuntCrossley, KelvinVoigt, QuasiLinearViscoelastic, Zener,
};
use estimator_core::zener::{ZenerConfig, ZenerEstimator};
use estimator_core::{ContactSample, Estimator, Scaling, SignalConditioning};

const SEEDS: [u64; 3] = [1001, 1002, 1003];

fn plastic() -> HuntCrossley {
    HuntCrossley::try_new(paper_k_si(1.15e4, 1.2), paper_lambda_si(70.0, 1.2), 1.2).unwrap()
}

fn gel_hc() -> HuntCrossley {
    HuntCrossley::try_new(paper_k_si(1.35e3, 1.35), paper_lambda_si(36.0, 1.35), 1.35).unwrap()
}

fn hc_track<E: Estimator<Parameters = estimator_core::hunt_crossley::HuntCrossleyParameters>>(
    est: &mut E,
    data: &[ContactSample],
    truth: &HuntCrossley,
) -> Track {
    let mut track = Track::new(&["k", "lambda", "n"]);
    for s in data {
        let p = est.step(s).parameters;
        track.push(&[p.k, p.lambda, p.n], &[truth.k, truth.lambda, truth.n]);
    }
    track
}

/// Soft gel, Kelvin-Voigt (paper: K ≈ 2.26e3 N/m, B ≈ 123 N·s/m): within 2 % from
/// ≤ 0.2 s of a 6 s record.
#[test]
fn kelvin_voigt_soft_gel_within_2_percent_in_0_2_s() {
    for seed in SEEDS {
        let mut material = KelvinVoigt::try_new(2.26e3, 123.0).unwrap();
        let (data, _) = generate(&mut material, &GEL_MOTION, &PAPER_SENSORS, 6.0, seed);
        let mut est = KelvinVoigtEstimator::try_new(KelvinVoigtConfig::default()).unwrap();
        let mut track = Track::new(&["kappa", "lambda"]);
        for s in &data {
            let p = est.step(s).parameters;
            track.push(&[p.kappa, p.lambda], &[2.26e3, 123.0]);
        }
        track.report(&format!("KV gel seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.02).unwrap() < 0.2);
    }
}

/// Zener (κ1 = 2000 N/m, κ2 = 1000 N/m, λ = 150 N·s/m, τ = 50 ms) pressed 2.5-4 mm at
/// 1-3 Hz (ωτ ≈ 0.3-1, and contact is never lost): the ARX form (18)-(19) ends within
/// 2 % of a 20 s record and stays within 5 % from ≤ 4.6 s (λ, from the pole, is last). Excitation matters: pressed 1-4 mm at 0.2-1 Hz
/// (ωτ ≈ 0.2) λ was 4-6 % off on 10 seeds.
#[test]
fn zener_arx_within_2_percent() {
    let motion = Motion {
        min_m: 2.5e-3,
        max_m: 4.0e-3,
        f0_hz: 1.0,
        f1_hz: 3.0,
        sweep_s: 3.0,
    };
    let truth = [2000.0, 1000.0, 150.0];
    for seed in SEEDS {
        let mut material = Zener::try_new(truth[0], truth[1], truth[2], T).unwrap();
        let (data, forces) = generate(&mut material, &motion, &PAPER_SENSORS, 20.0, seed);
        assert!(
            forces.iter().all(|&f| f > 0.0),
            "the motion must keep contact"
        );
        let mut est = ZenerEstimator::try_new(ZenerConfig::default()).unwrap();
        let mut track = Track::new(&["kappa1", "kappa2", "lambda"]);
        for s in &data {
            let p = est.step(s).parameters;
            track.push(&[p.kappa1, p.kappa2, p.lambda], &truth);
        }
        track.report(&format!("Zener seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.05).unwrap() < 5.0);
    }
}

/// Thin plastic layer (paper: k ≈ 4.58e4 N/m^1.2, λ ≈ 2.79e5 N·s/m^2.2, n ≈ 1.2), the
/// paper's double-stage estimator: within 5 % from ≤ 2.5 s (the paper's Fig. 12: settles
/// in 1-2 s of its 3 s record), within 2 % from ≤ 9 s of a 12 s record.
#[test]
fn hunt_crossley_plastic_within_2_percent_in_9_s() {
    let truth = plastic();
    for seed in SEEDS {
        let mut material = truth;
        let (data, _) = generate(&mut material, &PLASTIC_MOTION, &PAPER_SENSORS, 12.0, seed);
        let mut est = HuntCrossleyEstimator::try_new(HuntCrossleyConfig::default()).unwrap();
        let track = hc_track(&mut est, &data, &truth);
        track.report(&format!("HC double plastic seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.05).unwrap() < 2.5);
        assert!(track.settling(0.02).unwrap() < 9.0);
    }
}

/// Soft gel (paper: k ≈ 1.51e4 N/m^1.35, λ ≈ 4.04e5 N·s/m^2.35, n ≈ 1.35): within 5 %
/// from ≤ 7 s, within 2 % at the end of a 16 s record. Slower than the plastic: one stroke
/// per second and a damping term half the force. With a 2 s memory the estimates keep
/// wandering by ≈ ±1 % (10 seeds: final errors 0.2-1.8 %; "within 2 % for good" reached
/// between 6 and 16 s), so 2 % is asserted at the end, not as a settling time.
#[test]
fn hunt_crossley_gel_within_5_percent_in_7_s() {
    let truth = gel_hc();
    for seed in SEEDS {
        let mut material = truth;
        let (data, _) = generate(&mut material, &GEL_MOTION, &PAPER_SENSORS, 16.0, seed);
        let mut est = HuntCrossleyEstimator::try_new(HuntCrossleyConfig::default()).unwrap();
        let track = hc_track(&mut est, &data, &truth);
        track.report(&format!("HC double gel seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.05).unwrap() < 7.0);
    }
}

/// The paper's Γ2 taken literally (no intercept) converges only if the internal length
/// unit centres ln δ: on the plastic (δ ≤ 1 mm) it works in units of 0.5 mm and stalls in
/// units of 2 mm. This is why the default adds the intercept (see
/// `HuntCrossleyConfig::exponent_intercept`).
#[test]
fn paper_literal_double_stage_depends_on_the_length_unit() {
    let truth = plastic();
    let mut material = truth;
    let (data, _) = generate(&mut material, &PLASTIC_MOTION, &PAPER_SENSORS, 12.0, 1004);
    let run = |length_m: f32| {
        let mut c = HuntCrossleyConfig::paper_literal();
        c.scaling = Scaling {
            length_m,
            force_n: 1.0,
        };
        let mut est = HuntCrossleyEstimator::try_new(c).unwrap();
        let track = hc_track(&mut est, &data, &truth);
        track.report(&format!("HC paper-literal, unit {length_m} m"));
        track.worst_final()
    };
    assert!(run(0.5e-3) < 0.03);
    assert!(run(2.0e-3) > 0.10);
    // The default (with intercept) is insensitive to the unit.
    for length_m in [0.5e-3, 2.0e-3] {
        let mut est = HuntCrossleyEstimator::try_new(HuntCrossleyConfig {
            scaling: Scaling {
                length_m,
                force_n: 1.0,
            },
            ..HuntCrossleyConfig::default()
        })
        .unwrap();
        assert!(hc_track(&mut est, &data, &truth).worst_final() < 0.02);
    }
}

/// Single-stage (log-linear, Haddadi & Hashtrudi-Zaad) next to the double stage on the
/// same records. Plastic: within 2 %, and within 5 % from ≤ 2.5 s. Gel: the literature's
/// ln(1 + λδ̇/k) ≈ λδ̇/k drops −u²/2 with u up to 0.4, which biased λ high by 4-10 %; the
/// estimator now carries that remainder in its target (measured: λ within 0.2 %, k 0.1 %,
/// n 0.02 %).
#[test]
fn single_stage_hunt_crossley_side_by_side() {
    for seed in SEEDS {
        let truth = plastic();
        let mut material = truth;
        let (data, _) = generate(&mut material, &PLASTIC_MOTION, &PAPER_SENSORS, 12.0, seed);
        let mut single =
            SingleStageHuntCrossleyEstimator::try_new(SingleStageHuntCrossleyConfig::default())
                .unwrap();
        let track = hc_track(&mut single, &data, &truth);
        track.report(&format!("HC single plastic seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.05).unwrap() < 2.5);

        let truth = gel_hc();
        let mut material = truth;
        let (data, _) = generate(&mut material, &GEL_MOTION, &PAPER_SENSORS, 12.0, seed);
        let mut single =
            SingleStageHuntCrossleyEstimator::try_new(SingleStageHuntCrossleyConfig::default())
                .unwrap();
        let track = hc_track(&mut single, &data, &truth);
        track.report(&format!("HC single gel seed {seed}"));
        let errors = track.final_errors();
        assert!(
            errors[0] < 0.02 && errors[1] < 0.02 && errors[2] < 0.01,
            "{errors:?}"
        );
    }
}

/// Gel for 8 s, then the plastic layer (the paper's Fig. 16-17), with the adaptive
/// forgetting of eq. (24): the plastic parameters are back within 5 % ≤ 7 s and within
/// 2 % ≤ 9 s after the switch; a fixed forgetting factor does not get there in 12 s.
#[test]
fn hunt_crossley_reconverges_after_gel_to_plastic_switch() {
    let (gel, plastic) = (gel_hc(), plastic());
    for seed in SEEDS {
        let mut g = gel;
        let mut p = plastic;
        let (mut data, _) = generate(&mut g, &GEL_MOTION, &PAPER_SENSORS, 8.0, seed);
        let (after, _) = generate(&mut p, &PLASTIC_MOTION, &PAPER_SENSORS, 12.0, seed + 50);
        let switch = data.len();
        data.extend(after);
        let run = |forgetting| {
            let mut c = HuntCrossleyConfig::default();
            c.stage1.forgetting = forgetting;
            c.stage2.forgetting = forgetting;
            let mut est = HuntCrossleyEstimator::try_new(c).unwrap();
            for s in &data[..switch] {
                est.step(s);
            }
            hc_track(&mut est, &data[switch..], &plastic)
        };
        let track = run(adaptive_forgetting(0.3));
        track.report(&format!("HC switch, adaptive, seed {seed}"));
        assert!(track.worst_final() < 0.02);
        assert!(track.settling(0.05).unwrap() < 7.0);
        assert!(track.settling(0.02).unwrap() < 9.0);
        let fixed = run(estimator_core::rls::Forgetting::Fixed { beta: 0.9995 });
        fixed.report(&format!("HC switch, fixed β, seed {seed}"));
        assert!(fixed.worst_final() > 0.05);
    }
}

/// Polyurethane gel, the paper's Hammerstein experiment (Sec. 5.2, Fig. 18-20): a ramp at
/// 30 mm/s to 3 mm, then 50 s at constant depth. The material is a QLV with a power-law
/// elastic response (γ1 = 7.3e4 N/m^1.5, γ2 = 1.5: 12 N at 3 mm) and one relaxation mode
/// (c1 = 0.4, τ = 5 s), whose exact discrete equivalent gives the true a1, b1.
///
/// Asserted within 2 %: γ2; the elastic response F̂_e(δ) at 1, 2 and 3 mm (γ1 in the
/// paper's units N/mm^γ2 is F̂_e at 1 mm); the relaxation rate ν = −ln(−a1)/T; the
/// relaxed fraction c0 = (1 + b1)/(1 + a1). γ1 in SI is F_e at δ = 1 m, 330× deeper than
/// any sample: it carries γ2's error times ln(1 m/1 mm) ≈ 7, so it is reported, and
/// asserted within 5 %. Only the ramp's ≈ 100 samples inform Γ1.
#[test]
fn hammerstein_polyurethane_step() {
    let (g1, g2, c1, nu1) = (7.3e4f32, 1.5f32, 0.4f32, 0.2f32);
    for seed in SEEDS {
        let elastic = ElasticResponse::PowerLaw {
            gamma1: g1,
            gamma2: g2,
        };
        let mut qlv = QuasiLinearViscoelastic::<1>::try_new(elastic, [c1], [nu1], T).unwrap();
        let (_, _, b0) = qlv.hammerstein_filter();
        let true_elastic = ElasticResponse::PowerLaw {
            gamma1: g1 * b0,
            gamma2: g2,
        };
        let motion = |t: f32| {
            if t < 0.5 {
                0.0
            } else {
                (0.03 * (t - 0.5)).min(3.0e-3)
            }
        };
        let (data, _) = generate_from(&mut qlv, motion, &PAPER_SENSORS, 50.5, seed, 240.0);
        let mut est = Hammerstein1::try_new(HammersteinConfig::default()).unwrap();
        for s in data.iter().filter(|s| s.depth_m > 0.0) {
            est.step(s);
        }
        let p = est.parameters();
        let fitted = ElasticResponse::PowerLaw {
            gamma1: p.gamma1,
            gamma2: p.gamma2,
        };
        let nu = -libm::logf(-p.a[0]) / T;
        let c0 = p.static_gain();
        println!(
            "Hammerstein seed {seed}: γ1 {:+.2}% (SI), γ2 {:+.2}%, F_e(1 mm) {:+.2}%, ν {:+.2}%, c0 {:+.2}%, a1 {:.6}, b1 {:.6}",
            100.0 * (p.gamma1 / (g1 * b0) - 1.0),
            100.0 * (p.gamma2 / g2 - 1.0),
            100.0 * (fitted.force_n(1e-3) / true_elastic.force_n(1e-3) - 1.0),
            100.0 * (nu / nu1 - 1.0),
            100.0 * (c0 / (1.0 - c1) - 1.0),
            p.a[0],
            p.b[0]
        );
        assert!(rel(p.gamma2, g2) < 0.02);
        for depth in [1.0e-3, 2.0e-3, 3.0e-3] {
            assert!(rel(fitted.force_n(depth), true_elastic.force_n(depth)) < 0.02);
        }
        assert!(rel(nu, nu1) < 0.02);
        assert!(rel(c0, 1.0 - c1) < 0.02);
        assert!(rel(p.gamma1, g1 * b0) < 0.05);
    }
}

#[test]
fn estimator_sizes_fit_the_firmware_budget() {
    use core::mem::size_of;
    let sizes = [
        ("KelvinVoigtEstimator", size_of::<KelvinVoigtEstimator>()),
        ("ZenerEstimator", size_of::<ZenerEstimator>()),
        ("HuntCrossleyEstimator", size_of::<HuntCrossleyEstimator>()),
        (
            "SingleStageHuntCrossleyEstimator",
            size_of::<SingleStageHuntCrossleyEstimator>(),
        ),
        ("Hammerstein1", size_of::<Hammerstein1>()),
        (
            "Hammerstein2",
            size_of::<estimator_core::hammerstein::Hammerstein2>(),
        ),
        ("AnyEstimator", size_of::<estimator_core::AnyEstimator>()),
        (
            "Pipeline<AnyEstimator>",
            size_of::<estimator_core::Pipeline<estimator_core::AnyEstimator>>(),
        ),
    ];
    for (name, bytes) in sizes {
        println!("size_of::<{name}>() = {bytes} B");
    }
    // Target from the benchmarks issue: each estimator ≤ 512 B.
    for (name, bytes) in &sizes[..6] {
        assert!(*bytes <= 512, "{name} is {bytes} B");
    }
}

#[allow(dead_code)]
fn _assert_models_are_contact_models(m: &mut dyn ContactModel) {
    let _ = m.step(0.0, 0.0);
}

#[allow(dead_code)]
const _CONDITIONING: SignalConditioning = SignalConditioning::AllFiltered;
