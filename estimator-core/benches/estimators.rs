//! Cost of one `step` of every estimator, and of the whole per-sample pipeline, on the
//! host (criterion). Instruction counts on the Cortex-M4F are measured under QEMU by the
//! firmware; these are the host numbers for batch work (files, sweeps, soak runs).
//!
//! Each benchmark steps a fresh copy of the estimator through a 10 s record at 1 kHz
//! (10 000 samples) of its own material pressed by a 2 Hz sinusoid, with 20 mN of force
//! noise; throughput is reported in samples (elements) per second, and the time per
//! `step` is the iteration time divided by 10 000.
//!
//! `cargo bench -p estimator-core --bench estimators`

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use estimator_core::hammerstein::{Hammerstein1, Hammerstein2, HammersteinConfig};
use estimator_core::hunt_crossley::{
    HuntCrossleyConfig, HuntCrossleyEstimator, SingleStageHuntCrossleyConfig,
    SingleStageHuntCrossleyEstimator,
};
use estimator_core::kelvin_voigt::{KelvinVoigtConfig, KelvinVoigtEstimator};
use estimator_core::models::{
    ContactModel, ElasticResponse, HuntCrossley, KelvinVoigt, QuasiLinearViscoelastic, Zener,
};
use estimator_core::zener::{ZenerConfig, ZenerEstimator};
use estimator_core::{
    AnyEstimator, ContactSample, Estimator, ModelKind, Pipeline, PipelineConfig, RawSample, Scaling,
};

/// Sample time \[s\].
const T: f32 = 1.0e-3;
/// Samples per benchmark iteration (10 s at 1 kHz, a whole number of 2 Hz cycles).
const SAMPLES: usize = 10_000;
/// Pressing frequency \[Hz\].
const PRESS_HZ: f32 = 2.0;
/// Load-cell noise \[N\].
const NOISE_N: f32 = 0.02;

/// Deterministic Gaussian-ish noise (sum of 12 uniforms), σ = `sigma`.
struct Noise(u64);

impl Noise {
    fn next(&mut self, sigma: f32) -> f32 {
        let mut s = 0.0;
        for _ in 0..12 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            s += (self.0 >> 40) as f32 / (1u64 << 24) as f32;
        }
        sigma * (s - 6.0)
    }
}

/// The material each estimator is benchmarked on, and the depth range \[m\] it is
/// pressed over.
fn material(kind: ModelKind) -> (Box<dyn ContactModel>, f32, f32) {
    // The paper's plastic layer (Sec. 5.1) in SI.
    let plastic = HuntCrossley::try_new(4.578e4, 2.787e5, 1.2).expect("valid");
    match kind {
        // The paper's soft gel, Kelvin-Voigt.
        ModelKind::KelvinVoigt => (
            Box::new(KelvinVoigt::try_new(2260.0, 123.0).expect("valid")),
            0.5e-3,
            5.0e-3,
        ),
        ModelKind::Zener => (
            Box::new(Zener::try_new(2000.0, 1000.0, 150.0, T).expect("valid")),
            0.5e-3,
            5.0e-3,
        ),
        ModelKind::HuntCrossley | ModelKind::HuntCrossleySingleStage => {
            (Box::new(plastic), 0.1e-3, 1.0e-3)
        }
        // Polyurethane (README): γ1 = 7.3e4 N/m^1.5, γ2 = 1.5, one relaxation mode.
        ModelKind::Hammerstein1 | ModelKind::Hammerstein2 => (
            Box::new(
                QuasiLinearViscoelastic::try_new(
                    ElasticResponse::PowerLaw {
                        gamma1: 7.3e4,
                        gamma2: 1.5,
                    },
                    [0.4],
                    [0.2],
                    T,
                )
                .expect("valid"),
            ),
            0.5e-3,
            3.0e-3,
        ),
    }
}

/// Depth \[m\] and depth rate \[m/s\] of the 2 Hz pressing at sample `h`.
fn pressing(h: usize, min_m: f32, max_m: f32) -> (f32, f32) {
    let w = 2.0 * std::f32::consts::PI * PRESS_HZ;
    let t = h as f32 * T;
    let (mid, amp) = (0.5 * (min_m + max_m), 0.5 * (max_m - min_m));
    (mid - amp * (w * t).cos(), amp * w * (w * t).sin())
}

/// In-contact samples as the estimator sees them (offset removed, noisy force).
fn contact_samples(kind: ModelKind) -> Vec<ContactSample> {
    let (mut model, min_m, max_m) = material(kind);
    let mut noise = Noise(1);
    (0..SAMPLES)
        .map(|h| {
            let (depth_m, depth_rate_m_per_s) = pressing(h, min_m, max_m);
            let force_n = model.step(depth_m, depth_rate_m_per_s) + noise.next(NOISE_N);
            ContactSample {
                depth_m,
                depth_rate_m_per_s,
                force_n,
            }
        })
        .collect()
}

/// Raw samples as the acquisition delivers them: 0.5 s in free space 1 mm above the
/// surface (at x = 2 mm), then the pressing, leaving the surface by 50 µm every cycle;
/// 1 µm encoder, +0.8 N load-cell offset, 20 mN noise.
fn raw_samples(kind: ModelKind) -> Vec<RawSample> {
    let (mut model, _, max_m) = material(kind);
    let mut noise = Noise(2);
    let surface_m = 2.0e-3;
    (0..SAMPLES)
        .map(|h| {
            let (depth_m, rate) = if h < 500 {
                (-1.0e-3, 0.0)
            } else {
                pressing(h - 500, -0.05e-3, max_m)
            };
            let force_n = model.step(depth_m, rate) + 0.8 + noise.next(NOISE_N);
            RawSample {
                position_m: ((surface_m + depth_m) * 1.0e6).round() * 1.0e-6,
                force_n,
                saturated: false,
            }
        })
        .collect()
}

/// Steps a fresh copy of `estimator` over `samples`.
fn run<E: Estimator + Clone>(estimator: &E, samples: &[ContactSample]) -> E {
    let mut e = estimator.clone();
    for s in samples {
        black_box(e.step(black_box(s)));
    }
    e
}

fn bench_one<E: Estimator + Clone>(c: &mut Criterion, name: &str, kind: ModelKind, e: E) {
    let samples = contact_samples(kind);
    let mut group = c.benchmark_group("estimator_step");
    group.throughput(Throughput::Elements(SAMPLES as u64));
    group.bench_function(BenchmarkId::from_parameter(name), |b| {
        b.iter(|| run(&e, &samples))
    });
    group.finish();
}

fn estimators(c: &mut Criterion) {
    let kv = KelvinVoigtEstimator::try_new(KelvinVoigtConfig::default()).expect("valid");
    bench_one(c, "kelvin-voigt", ModelKind::KelvinVoigt, kv);
    let zener = ZenerEstimator::try_new(ZenerConfig::default()).expect("valid");
    bench_one(c, "zener", ModelKind::Zener, zener);
    let hc = HuntCrossleyEstimator::try_new(HuntCrossleyConfig::default()).expect("valid");
    bench_one(c, "hunt-crossley", ModelKind::HuntCrossley, hc);
    let single =
        SingleStageHuntCrossleyEstimator::try_new(SingleStageHuntCrossleyConfig::default())
            .expect("valid");
    bench_one(
        c,
        "hunt-crossley-single-stage",
        ModelKind::HuntCrossleySingleStage,
        single,
    );
    let h1 = Hammerstein1::try_new(HammersteinConfig::default()).expect("valid");
    bench_one(c, "hammerstein", ModelKind::Hammerstein1, h1);
    let h2 = Hammerstein2::try_new(HammersteinConfig::default()).expect("valid");
    bench_one(c, "hammerstein2", ModelKind::Hammerstein2, h2);
}

fn pipeline(c: &mut Criterion) {
    let mut group = c.benchmark_group("pipeline_step");
    group.throughput(Throughput::Elements(SAMPLES as u64));
    for kind in ModelKind::ALL {
        let raw = raw_samples(kind);
        let estimator = AnyEstimator::try_default(kind, Scaling::default()).expect("valid");
        let template = Pipeline::try_new(PipelineConfig::default(), estimator).expect("valid");
        group.bench_function(BenchmarkId::from_parameter(kind.name()), |b| {
            b.iter(|| {
                let mut p = template;
                for s in &raw {
                    black_box(p.step(black_box(s)));
                }
                p
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .sample_size(30);
    targets = estimators, pipeline
}
criterion_main!(benches);
