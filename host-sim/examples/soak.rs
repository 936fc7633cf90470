//! Soak run: one simulated hour (3.6 M samples at 1 kHz) of position-controlled pressing
//! on materials that change every 30-60 s (the paper's plastic layer and soft gel as
//! Hunt-Crossley, the soft gel as Kelvin-Voigt), with a sensor or acquisition fault every
//! 3-7 s drawn from the plant's `Faults` (NaN and infinite force, dropped samples, ADC
//! overload, encoder spikes and slips). Two pipelines run on the same raw samples, as the
//! firmware would: the double-stage Hunt-Crossley and the Kelvin-Voigt estimator, both
//! with the adaptive forgetting of eq. (24); each material is judged by the one of its
//! family.
//!
//! It reports: any non-finite output (there must be none); the largest parameter and
//! standard error (σ̂·√P_ii) each pipeline ever showed (the covariance itself is not
//! exposed by the pipeline; its trace is capped by construction); per event, whether the
//! estimates were back in the band (see `BAND_*`) in time — just before the next event
//! for a fault, 15 s after it for a material change; the status-flag counts; and the
//! wall-clock time, split between the plant simulation and the two pipelines.
//!
//! ```sh
//! cargo run --release -p host-sim --example soak               # the full hour
//! cargo run --release -p host-sim --example soak -- --minutes 5
//! ```
//!
//! Exits with status 1 if any output was non-finite.

use std::collections::BTreeMap;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use estimator_core::hunt_crossley::adaptive_forgetting;
use estimator_core::{AnyEstimator, AnyParameters, Estimator, ModelKind, Pipeline, PipelineOutput};
use host_sim::plant::{
    Acquisition, EncoderGlitch, FaultWindow, Faults, MaterialChange, Plant, PlantConfig, Trajectory,
};
use host_sim::runner::RunOptions;
use host_sim::scenarios::{gel_hunt_crossley, gel_kelvin_voigt, plastic, Truth};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

#[derive(Parser)]
#[command(about = "Soak run: materials and faults over a simulated hour at 1 kHz")]
struct Args {
    /// Simulated minutes.
    #[arg(long, default_value_t = 60.0)]
    minutes: f64,
    /// Seed of the schedule (materials, faults) and of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

/// Sample time \[s\].
const T: f64 = 1.0e-3;
/// Hunt-Crossley band: n and k·(1 mm)ⁿ within 5 %, λ·(1 mm)ⁿ within 15 %.
const BAND_HC: [(&str, f64); 3] = [("n", 0.05), ("k·", 0.05), ("lambda·", 0.15)];
/// Kelvin-Voigt band: κ within 5 %, λ within 15 %.
const BAND_KV: [(&str, f64); 2] = [("kappa", 0.05), ("lambda", 0.15)];
/// A material change is judged this long after it \[s\].
const MATERIAL_SETTLE_S: f64 = 15.0;

/// The materials, with the motion each is pressed with.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Material {
    PlasticHuntCrossley,
    GelHuntCrossley,
    GelKelvinVoigt,
}

impl Material {
    const ALL: [Material; 3] = [
        Material::PlasticHuntCrossley,
        Material::GelHuntCrossley,
        Material::GelKelvinVoigt,
    ];

    fn name(self) -> &'static str {
        match self {
            Material::PlasticHuntCrossley => "plastic (Hunt-Crossley)",
            Material::GelHuntCrossley => "soft gel (Hunt-Crossley)",
            Material::GelKelvinVoigt => "soft gel (Kelvin-Voigt)",
        }
    }

    fn truth(self) -> Truth {
        match self {
            Material::PlasticHuntCrossley => Truth::HuntCrossley(plastic()),
            Material::GelHuntCrossley => Truth::HuntCrossley(gel_hunt_crossley()),
            Material::GelKelvinVoigt => Truth::KelvinVoigt(gel_kelvin_voigt()),
        }
    }

    fn model(self) -> MaterialChange {
        let model: Box<dyn estimator_core::models::ContactModel> = match self {
            Material::PlasticHuntCrossley => Box::new(plastic()),
            Material::GelHuntCrossley => Box::new(gel_hunt_crossley()),
            Material::GelKelvinVoigt => Box::new(gel_kelvin_voigt()),
        };
        MaterialChange { at_s: 0.0, model }
    }

    /// The scenarios' pressing for this material, starting just off the surface.
    fn pressing(self) -> Trajectory {
        let (max_depth_m, f0_hz, f1_hz, sweep_s) = match self {
            Material::PlasticHuntCrossley => (1.0e-3, 1.0, 3.0, 2.0),
            Material::GelHuntCrossley | Material::GelKelvinVoigt => (5.0e-3, 0.5, 1.5, 3.0),
        };
        Trajectory::SineSweep {
            approach_depth_m: -0.05e-3,
            start_s: 0.0,
            min_depth_m: -0.05e-3,
            max_depth_m,
            f0_hz,
            f1_hz,
            sweep_s,
        }
    }

    /// Index of the pipeline that judges it: 0 Hunt-Crossley, 1 Kelvin-Voigt.
    fn pipeline(self) -> usize {
        usize::from(self == Material::GelKelvinVoigt)
    }
}

/// The fault kinds drawn every 3-7 s.
const FAULT_KINDS: [&str; 6] = [
    "NaN force",
    "+inf force (5 ms)",
    "dropped samples (1, 5 or 50 ms)",
    "ADC overload (20 ms)",
    "encoder spike (200 counts)",
    "encoder slip (±20 counts for 3 s)",
];

/// One scheduled event and how it is judged.
struct Event {
    at_s: f64,
    /// `None` for a material change, else an index into [`FAULT_KINDS`].
    fault: Option<usize>,
    judge_at_s: f64,
    material: Material,
    in_band: Option<bool>,
}

/// The schedule: material segments (start, material) and the events.
fn schedule(duration_s: f64, rng: &mut StdRng) -> (Vec<(f64, Material)>, Vec<Event>, Faults) {
    let mut segments = vec![(0.0, Material::PlasticHuntCrossley)];
    loop {
        let &(start, material) = segments.last().expect("first segment");
        let planned = start + rng.random_range(30.0..60.0);
        if planned >= duration_s {
            break;
        }
        // Switch where the probe is just off the surface, at rest.
        let local = shallowest_near(&material.pressing(), planned - start);
        let next = loop {
            let m = Material::ALL[rng.random_range(0..Material::ALL.len())];
            if m != material {
                break m;
            }
        };
        segments.push((start + local, next));
    }
    let material_at = |t: f64| {
        segments
            .iter()
            .rev()
            .find(|(s, _)| *s <= t)
            .map_or(Material::PlasticHuntCrossley, |(_, m)| *m)
    };
    let mut faults = Faults {
        seed: rng.random(),
        ..Faults::default()
    };
    let mut events: Vec<Event> = segments
        .iter()
        .skip(1)
        .map(|&(at_s, material)| Event {
            at_s,
            fault: None,
            judge_at_s: at_s + MATERIAL_SETTLE_S,
            material,
            in_band: None,
        })
        .collect();
    let mut t = 10.0;
    while t < duration_s {
        let kind = rng.random_range(0..FAULT_KINDS.len());
        let window = |duration_s: f64| FaultWindow {
            start_s: t,
            duration_s,
        };
        match kind {
            0 => faults.nan_force.push(FaultWindow::at(t)),
            1 => faults.infinite_force.push(window(0.005)),
            2 => faults
                .dropped
                .push(window([0.0, 0.005, 0.05][rng.random_range(0..3)])),
            3 => faults.adc_overload.push(window(0.020)),
            4 => faults.encoder_glitches.push(EncoderGlitch {
                at_s: t,
                counts: 200,
                duration_s: 0.0,
            }),
            _ => faults.encoder_glitches.push(EncoderGlitch {
                at_s: t,
                counts: if rng.random() { 20 } else { -20 },
                duration_s: 3.0,
            }),
        }
        events.push(Event {
            at_s: t,
            fault: Some(kind),
            judge_at_s: 0.0,
            material: material_at(t),
            in_band: None,
        });
        t += rng.random_range(3.0..7.0);
    }
    events.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
    // A fault is judged just before the next event (or the end).
    for i in 0..events.len() {
        if events[i].fault.is_some() {
            let next = events.get(i + 1).map_or(duration_s, |e| e.at_s);
            events[i].judge_at_s = next - T;
        }
    }
    (segments, events, faults)
}

fn shallowest_near(trajectory: &Trajectory, around_s: f64) -> f64 {
    (0..=1000)
        .map(|i| (around_s - 0.5 + f64::from(i) * 1.0e-3).max(0.0))
        .min_by(|a, b| trajectory.depth_m(*a).total_cmp(&trajectory.depth_m(*b)))
        .unwrap_or(around_s)
}

/// Largest ratio of a judged quantity's relative error to its tolerance (≤ 1 in band).
fn band_use(parameters: &AnyParameters, truth: &Truth) -> f64 {
    let band: &[(&str, f64)] = match truth {
        Truth::KelvinVoigt(_) => &BAND_KV,
        _ => &BAND_HC,
    };
    let checks = truth.checks(parameters, 1.0);
    band.iter()
        .map(|(name, tolerance)| {
            checks
                .iter()
                .filter(|c| c.tolerance.is_some() && c.name.starts_with(name))
                .map(|c| c.relative_error / tolerance)
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

fn finite(o: &PipelineOutput<AnyParameters>) -> bool {
    o.sample.is_finite()
        && o.estimate.parameters.iter().all(|(_, v)| v.is_finite())
        && o.estimate.predicted_force_n.is_finite()
        && o.force_offset_n.is_finite()
}

/// What one pipeline showed over the run.
#[derive(Default)]
struct Extremes {
    non_finite: u64,
    max_parameter: BTreeMap<&'static str, f32>,
    max_standard_error: BTreeMap<&'static str, f32>,
    flags: BTreeMap<&'static str, u64>,
}

impl Extremes {
    fn observe(&mut self, o: &PipelineOutput<AnyParameters>) {
        if !finite(o) {
            self.non_finite += 1;
        }
        for (name, v) in o.estimate.parameters.iter() {
            let m = self.max_parameter.entry(name).or_insert(0.0);
            *m = m.max(v.abs());
        }
        if !o.status.is_empty() {
            for (name, _) in o.status.iter_names() {
                *self.flags.entry(name).or_default() += 1;
            }
        }
    }

    fn observe_standard_errors(&mut self, se: &AnyParameters) {
        for (name, v) in se.iter() {
            let m = self.max_standard_error.entry(name).or_insert(0.0);
            // NaN would not compare: count it as infinite.
            *m = if v.is_finite() {
                m.max(v.abs())
            } else {
                f32::INFINITY
            };
        }
    }
}

fn main() -> anyhow::Result<ExitCode> {
    let args = Args::parse();
    let duration_s = args.minutes * 60.0;
    let mut rng = StdRng::seed_from_u64(args.seed);
    let (segments, mut events, faults) = schedule(duration_s, &mut rng);

    let mut parts = vec![(
        0.0,
        Trajectory::SineSweep {
            approach_depth_m: -1.0e-3,
            start_s: 0.5,
            min_depth_m: -0.05e-3,
            max_depth_m: 1.0e-3,
            f0_hz: 1.0,
            f1_hz: 3.0,
            sweep_s: 2.0,
        },
    )];
    parts.extend(segments.iter().skip(1).map(|&(s, m)| (s, m.pressing())));
    let plant_config = PlantConfig {
        trajectory: Trajectory::Sequence { parts },
        faults,
        seed: args.seed,
        ..PlantConfig::default()
    };
    let materials = segments
        .iter()
        .map(|&(at_s, m)| MaterialChange { at_s, ..m.model() })
        .collect();
    let mut acquisition = Acquisition::new(&plant_config, 0.0)?;
    let mut plant = Plant::new(plant_config, materials)?;
    let mut pipelines = Vec::new();
    for kind in [ModelKind::HuntCrossley, ModelKind::KelvinVoigt] {
        let mut options = RunOptions::for_model(kind);
        options.settings.forgetting = Some(adaptive_forgetting(0.3));
        let estimator = AnyEstimator::try_new(kind, &options.settings)?;
        pipelines.push(Pipeline::try_new(options.pipeline, estimator)?);
    }
    let mut extremes = [Extremes::default(), Extremes::default()];

    let mut judge_order: Vec<usize> = (0..events.len()).collect();
    judge_order.sort_by(|&a, &b| events[a].judge_at_s.total_cmp(&events[b].judge_at_s));
    let mut next_judgement = 0;

    let n = (duration_s / T).round() as u64;
    let (mut plant_time, mut pipeline_time) = (Duration::ZERO, Duration::ZERO);
    let start = Instant::now();
    let mut last = [None, None];
    for h in 0..n {
        let t0 = Instant::now();
        let s = plant.step();
        let raw = acquisition.convert(&s);
        let t1 = Instant::now();
        for (k, p) in pipelines.iter_mut().enumerate() {
            let o = p.step(&raw);
            extremes[k].observe(&o);
            last[k] = Some(o.estimate.parameters);
        }
        let t2 = Instant::now();
        plant_time += t1 - t0;
        pipeline_time += t2 - t1;
        if h % 100 == 0 {
            for (k, p) in pipelines.iter().enumerate() {
                extremes[k].observe_standard_errors(&p.estimator().standard_errors());
            }
        }
        let time_s = h as f64 * T;
        while let Some(&e) = judge_order.get(next_judgement) {
            if events[e].judge_at_s > time_s {
                break;
            }
            let event = &mut events[e];
            if let Some(parameters) = last[event.material.pipeline()] {
                event.in_band = Some(band_use(&parameters, &event.material.truth()) <= 1.0);
            }
            next_judgement += 1;
        }
        if (h + 1) % 600_000 == 0 {
            eprintln!(
                "{:.0} simulated minutes, {:.1} s wall",
                (h + 1) as f64 * T / 60.0,
                start.elapsed().as_secs_f64()
            );
        }
    }
    let wall = start.elapsed();

    println!(
        "soak: {n} samples ({:.1} simulated minutes) in {:.2} s wall ({:.2} M samples/s): \
         plant simulation {:.2} s, two pipelines {:.2} s ({:.0} ns per pipeline step)",
        duration_s / 60.0,
        wall.as_secs_f64(),
        n as f64 / wall.as_secs_f64() / 1e6,
        plant_time.as_secs_f64(),
        pipeline_time.as_secs_f64(),
        pipeline_time.as_secs_f64() / (2.0 * n as f64) * 1e9
    );
    println!(
        "materials: {} segments ({}), switched every 30-60 s",
        segments.len(),
        Material::ALL
            .iter()
            .map(|m| format!(
                "{} × {}",
                segments.iter().filter(|(_, s)| s == m).count(),
                m.name()
            ))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for (k, name) in ["hunt-crossley", "kelvin-voigt"].iter().enumerate() {
        let e = &extremes[k];
        println!(
            "{name}: non-finite outputs {}; over the whole run (all materials) max |parameter| \
             {:?}, max standard error {:?}",
            e.non_finite, e.max_parameter, e.max_standard_error
        );
        println!("{name}: status flags {:?}", e.flags);
    }
    let judged = |fault: Option<usize>, material: Option<Material>| {
        let sel: Vec<&Event> = events
            .iter()
            .filter(|e| e.fault == fault && material.is_none_or(|m| e.material == m))
            .collect();
        let ok = sel.iter().filter(|e| e.in_band == Some(true)).count();
        let failed = sel.iter().filter(|e| e.in_band == Some(false)).count();
        (ok, failed)
    };
    println!(
        "band: Hunt-Crossley n and k·(1 mm)^n within 5 %, λ·(1 mm)^n within 15 %; \
         Kelvin-Voigt κ within 5 %, λ within 15 %"
    );
    let (mut total_ok, mut total_failed) = (0, 0);
    for m in Material::ALL {
        let (ok, failed) = judged(None, Some(m));
        total_ok += ok;
        total_failed += failed;
        println!(
            "material change to {}: {ok} back in the band {MATERIAL_SETTLE_S} s later, {failed} not",
            m.name()
        );
    }
    for (kind, name) in FAULT_KINDS.iter().enumerate() {
        let (ok, failed) = judged(Some(kind), None);
        total_ok += ok;
        total_failed += failed;
        println!("fault {name}: {ok} in the band before the next event, {failed} not");
    }
    println!(
        "events: {} ({} faults), recovered {total_ok}, not recovered {total_failed}, not \
         judged (judgement time after the end) {}",
        events.len(),
        events.iter().filter(|e| e.fault.is_some()).count(),
        events.iter().filter(|e| e.in_band.is_none()).count()
    );
    let failures: Vec<String> = events
        .iter()
        .filter(|e| e.in_band == Some(false))
        .take(10)
        .map(|e| {
            format!(
                "{:.1} s {} on {}",
                e.at_s,
                e.fault.map_or("material change", |k| FAULT_KINDS[k]),
                e.material.name()
            )
        })
        .collect();
    if !failures.is_empty() {
        println!("first not recovered: {}", failures.join("; "));
    }
    let non_finite = extremes.iter().map(|e| e.non_finite).sum::<u64>();
    Ok(if non_finite == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
