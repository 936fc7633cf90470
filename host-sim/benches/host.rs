//! Throughput of the host's estimate path: `runner::run` (the core's per-sample pipeline
//! plus the per-sample trace, phase classification and the final fit-quality
//! simulation) over a 60 s, 1 kHz record of the simulated plant (soft gel, the `gel-hc`
//! scenario's motion and sensors, stretched to 60 s). The plant simulation itself is
//! timed separately, and so is the discrepancy workflow (`diagnose` from the
//! Kelvin-Voigt baseline, candidates fitted on both cores) on the same record.
//!
//! `cargo bench -p host-sim --bench host`

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use estimator_core::conditioning::ImpactConfig;
use estimator_core::ModelKind;
use host_sim::diagnose::data::prepare;
use host_sim::diagnose::{diagnose, Options};
use host_sim::report::simulate_plant;
use host_sim::runner::{run, RunOptions};
use host_sim::scenarios;

/// Length of the benchmarked record \[s\].
const DURATION_S: f64 = 60.0;

fn host(c: &mut Criterion) {
    let mut scenario = scenarios::by_name("gel-hc").expect("scenario exists");
    scenario.duration_s = DURATION_S;
    let log = simulate_plant(&scenario).expect("plant runs");
    let samples = log.position_m.len() as u64;

    let mut group = c.benchmark_group("estimate_60s_1khz");
    group.throughput(Throughput::Elements(samples));
    for model in [
        ModelKind::HuntCrossley,
        ModelKind::HuntCrossleySingleStage,
        ModelKind::KelvinVoigt,
    ] {
        let options = RunOptions::for_model(model);
        group.bench_function(BenchmarkId::new("runner_run", model.name()), |b| {
            b.iter(|| {
                run(
                    &options,
                    black_box(&log.position_m),
                    black_box(&log.force_n),
                    &log.saturated,
                    &mut |_| {},
                )
                .expect("the record has contact")
            })
        });
    }
    group.bench_function("plant_simulation", |b| {
        b.iter(|| simulate_plant(black_box(&scenario)).expect("plant runs"))
    });
    group.finish();

    let mut group = c.benchmark_group("diagnose_60s_1khz");
    group.throughput(Throughput::Elements(samples));
    let time_s: Vec<f64> = (0..log.position_m.len()).map(|i| i as f64 * 1e-3).collect();
    group.bench_function("prepare_and_diagnose", |b| {
        b.iter(|| {
            let prepared = prepare(
                &time_s,
                black_box(&log.position_m),
                black_box(&log.force_n),
                ImpactConfig::default(),
            )
            .expect("the record has contact");
            diagnose(&prepared, &Options::default()).expect("baseline fits")
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(8));
    targets = host
}
criterion_main!(benches);
