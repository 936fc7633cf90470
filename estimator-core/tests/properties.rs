//! Properties of the core under arbitrary input (proptest): never a panic, never a
//! non-finite estimate, covariance symmetric positive definite with bounded trace, and a
//! status flag for every non-finite input.

use estimator_core::rls::{Forgetting, Rls, RlsConfig};
use estimator_core::{
    AnyEstimator, ContactSample, Estimator, ModelKind, Pipeline, PipelineConfig, RawSample,
    Scaling, Status,
};
use nalgebra::Vector3;
use proptest::prelude::*;

/// Any f32, weighted towards the values that break numerics.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        2 => -1.0e-3f32..1.0e-3,
        1 => proptest::num::f32::ANY,
        1 => prop_oneof![
            Just(0.0f32),
            Just(-0.0),
            Just(f32::NAN),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            Just(f32::MAX),
            Just(f32::MIN_POSITIVE),
            Just(1.0e30),
            Just(-1.0e30),
        ],
    ]
}

fn finite_f32() -> impl Strategy<Value = f32> {
    any_f32().prop_filter("finite", |v| v.is_finite())
}

fn check_covariance<const N: usize>(rls: &Rls<N>, max_trace: f32) {
    let p = rls.covariance();
    for i in 0..N {
        for j in 0..N {
            assert!(p[(i, j)].is_finite(), "P not finite: {p}");
            assert_eq!(p[(i, j)], p[(j, i)], "P not symmetric: {p}");
        }
    }
    assert!(
        p.trace() <= max_trace * 1.0001,
        "trace {} > {max_trace}",
        p.trace()
    );
    // Positive definite: Cholesky in f64 succeeds.
    let p64 = p.map(f64::from);
    assert!(p64.cholesky().is_some(), "P not positive definite: {p}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn rls_stays_finite_symmetric_positive_definite(
        steps in proptest::collection::vec((finite_f32(), finite_f32(), finite_f32(), finite_f32(), 0.5f32..=1.0), 1..200)
    ) {
        let config = RlsConfig { initial_covariance: 100.0, forgetting: Forgetting::Fixed { beta: 0.95 }, ..RlsConfig::default() };
        let mut rls = Rls::<3>::try_new(&config).unwrap();
        for (a, b, c, y, beta) in steps {
            let u = rls.update(&Vector3::new(a, b, c), y, beta);
            prop_assert!(rls.theta().iter().all(|v| v.is_finite()));
            prop_assert!(!u.status.contains(Status::NON_FINITE_INPUT));
            check_covariance(&rls, 300.0);
        }
    }

    #[test]
    fn rls_non_finite_input_is_flagged_and_skipped(
        a in any_f32(), y in any_f32(), w in any_f32()
    ) {
        let mut rls = Rls::<3>::try_new(&RlsConfig::default()).unwrap();
        let before = rls;
        let u = rls.update_weighted(&Vector3::new(a, 1.0, 2.0), y, 0.99, w);
        if !(a.is_finite() && y.is_finite() && w.is_finite() && w > 0.0) {
            prop_assert!(u.status.contains(Status::NON_FINITE_INPUT));
            prop_assert_eq!(rls, before);
        }
    }

    #[test]
    fn estimators_never_return_non_finite_parameters(
        kind in proptest::sample::select(ModelKind::ALL.to_vec()),
        samples in proptest::collection::vec((any_f32(), any_f32(), any_f32()), 1..300)
    ) {
        let mut est = AnyEstimator::try_default(kind, Scaling::default()).unwrap();
        for (d, v, f) in samples {
            let s = ContactSample { depth_m: d, depth_rate_m_per_s: v, force_n: f };
            let e = est.step(&s);
            for (name, value) in e.parameters.iter() {
                prop_assert!(value.is_finite(), "{kind:?} {name} = {value} after {s:?}");
            }
            prop_assert!(e.predicted_force_n.is_finite());
            if !s.is_finite() {
                prop_assert!(e.status.contains(Status::NON_FINITE_INPUT), "{kind:?} {:?}", e.status);
            }
        }
    }

    #[test]
    fn pipeline_never_returns_non_finite_output(
        kind in proptest::sample::select(ModelKind::ALL.to_vec()),
        samples in proptest::collection::vec((any_f32(), any_f32(), any::<bool>()), 1..400)
    ) {
        let est = AnyEstimator::try_default(kind, Scaling::default()).unwrap();
        let mut pipeline = Pipeline::try_new(PipelineConfig::default(), est).unwrap();
        for (x, f, saturated) in samples {
            let out = pipeline.step(&RawSample { position_m: x, force_n: f, saturated });
            for (name, value) in out.estimate.parameters.iter() {
                prop_assert!(value.is_finite(), "{kind:?} {name} = {value}");
            }
            prop_assert!(out.sample.is_finite(), "{:?}", out.sample);
            prop_assert!(out.force_offset_n.is_finite());
            prop_assert!(out.estimate.predicted_force_n.is_finite());
            if !(x.is_finite() && f.is_finite()) {
                prop_assert!(out.status.contains(Status::SAMPLE_DROPPED));
            }
        }
    }
}

// Minimal failing inputs proptest found, kept as plain regression tests.

#[test]
fn regression_kelvin_voigt_nan_rate_gives_finite_prediction() {
    let mut est = AnyEstimator::try_default(ModelKind::KelvinVoigt, Scaling::default()).unwrap();
    let e = est.step(&ContactSample {
        depth_m: 0.0,
        depth_rate_m_per_s: f32::NAN,
        force_n: 0.0,
    });
    assert!(e.predicted_force_n.is_finite());
    assert!(e.status.contains(Status::NON_FINITE_INPUT));
}

#[test]
fn regression_hunt_crossley_huge_force_holds_finite_parameters() {
    let mut est = AnyEstimator::try_default(ModelKind::HuntCrossley, Scaling::default()).unwrap();
    let e = est.step(&ContactSample {
        depth_m: 1.5349329,
        depth_rate_m_per_s: 0.0005840915,
        force_n: f32::MAX,
    });
    assert!(e.parameters.iter().all(|(_, v)| v.is_finite()));
    assert!(e.status.contains(Status::NONPHYSICAL));
}

#[test]
fn regression_pipeline_huge_force_does_not_poison_the_tare() {
    let est = AnyEstimator::try_default(ModelKind::KelvinVoigt, Scaling::default()).unwrap();
    let mut pipeline = Pipeline::try_new(PipelineConfig::default(), est).unwrap();
    let out = pipeline.step(&RawSample {
        position_m: 0.0,
        force_n: 9.706146e37,
        saturated: false,
    });
    assert!(out.status.contains(Status::SAMPLE_DROPPED));
    for _ in 0..10 {
        let out = pipeline.step(&RawSample {
            position_m: 0.0,
            force_n: 0.5,
            saturated: false,
        });
        assert!(out.force_offset_n.is_finite() && out.sample.is_finite());
    }
    assert!((pipeline.force_offset_n() - 0.5).abs() < 1e-6);
}
