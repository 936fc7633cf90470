//! Synthetic contact data for the estimator tests: a material (any core contact model)
//! pressed by a smooth motion, sampled at 1 kHz with the sensor imperfections of the
//! paper's rig (encoder quantisation, load-cell noise), and conditioned as the pipeline
//! does (state-variable filter on position and force).
#![allow(dead_code)]

use estimator_core::conditioning::{StateVariableFilter, StateVariableFilterConfig};
use estimator_core::models::ContactModel;
use estimator_core::{ContactSample, SignalConditioning};
use rand::{rngs::StdRng, SeedableRng};
use rand_distr::{Distribution, Normal};

pub const T: f32 = 1.0e-3;

/// Sensor imperfections at the paper's level.
#[derive(Clone, Copy, Debug)]
pub struct Sensors {
    /// Load-cell noise standard deviation [N].
    pub force_noise_n: f32,
    /// Encoder resolution [m].
    pub encoder_m: f32,
}

pub const PAPER_SENSORS: Sensors = Sensors {
    force_noise_n: 0.03,
    encoder_m: 1.0e-6,
};

/// Depth trajectory: in contact, δ between `min_m` and `max_m`, sinusoidal with a
/// frequency that sweeps between `f0_hz` and `f1_hz` (period `sweep_s`) so that
/// stiffness and damping are both excited.
#[derive(Clone, Copy, Debug)]
pub struct Motion {
    pub min_m: f32,
    pub max_m: f32,
    pub f0_hz: f32,
    pub f1_hz: f32,
    pub sweep_s: f32,
}

impl Motion {
    pub fn depth(&self, t: f32) -> f32 {
        // Phase of a frequency that moves sinusoidally between f0 and f1.
        let fm = 0.5 * (self.f0_hz + self.f1_hz);
        let fa = 0.5 * (self.f1_hz - self.f0_hz);
        let wm = 2.0 * std::f32::consts::PI / self.sweep_s;
        let phase = 2.0 * std::f32::consts::PI * (fm * t + fa * (1.0 - (wm * t).cos()) / wm);
        self.min_m + (self.max_m - self.min_m) * 0.5 * (1.0 - phase.cos())
    }
}

/// Generates `seconds` of samples of `model` under `motion`, conditioned as the pipeline
/// does by default (all signals through the 100 Hz state-variable filter).
pub fn generate(
    model: &mut dyn ContactModel,
    motion: &Motion,
    sensors: &Sensors,
    seconds: f32,
    seed: u64,
) -> (Vec<ContactSample>, Vec<f32>) {
    generate_with(
        model,
        motion,
        sensors,
        seconds,
        seed,
        SignalConditioning::AllFiltered,
        100.0,
    )
}

/// As [`generate`], choosing the conditioning and the filter bandwidth [Hz]; returns
/// (samples, true forces).
pub fn generate_with(
    model: &mut dyn ContactModel,
    motion: &Motion,
    sensors: &Sensors,
    seconds: f32,
    seed: u64,
    conditioning: SignalConditioning,
    bandwidth_hz: f32,
) -> (Vec<ContactSample>, Vec<f32>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0f32, sensors.force_noise_n.max(1e-12)).unwrap();
    let svf_cfg = StateVariableFilterConfig {
        bandwidth_hz,
        ..StateVariableFilterConfig::default()
    };
    let mut pos_f = StateVariableFilter::try_new(&svf_cfg).unwrap();
    let mut force_f = StateVariableFilter::try_new(&svf_cfg).unwrap();
    let n = (seconds / T) as usize;
    let mut out = Vec::with_capacity(n);
    let mut truth = Vec::with_capacity(n);
    let mut previous = motion.depth(0.0);
    for h in 0..n {
        let t = h as f32 * T;
        let d = motion.depth(t);
        let v = (d - previous) / T;
        previous = d;
        let f = model.step(d, v);
        let d_meas = (d / sensors.encoder_m).round() * sensors.encoder_m;
        let f_meas = f + noise.sample(&mut rng);
        let (d_f, v_f) = pos_f.step(d_meas);
        let (f_f, _) = force_f.step(f_meas);
        let filtered = conditioning == SignalConditioning::AllFiltered;
        out.push(ContactSample {
            depth_m: if filtered { d_f } else { d_meas },
            depth_rate_m_per_s: v_f,
            force_n: if filtered { f_f } else { f_meas },
        });
        truth.push(f);
    }
    (out, truth)
}

/// As [`generate_with`] for an arbitrary depth profile `depth(t)` (all signals filtered,
/// bandwidth in Hz); the rate passed to the model is the finite difference.
pub fn generate_from(
    model: &mut dyn ContactModel,
    depth: impl Fn(f32) -> f32,
    sensors: &Sensors,
    seconds: f32,
    seed: u64,
    bandwidth_hz: f32,
) -> (Vec<ContactSample>, Vec<f32>) {
    let mut rng = StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0f32, sensors.force_noise_n.max(1e-12)).unwrap();
    let cfg = StateVariableFilterConfig {
        bandwidth_hz,
        ..StateVariableFilterConfig::default()
    };
    let mut pos_f = StateVariableFilter::try_new(&cfg).unwrap();
    let mut force_f = StateVariableFilter::try_new(&cfg).unwrap();
    let n = (seconds / T) as usize;
    let (mut out, mut truth) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let mut previous = depth(0.0);
    for h in 0..n {
        let d = depth(h as f32 * T);
        let f = model.step(d, (d - previous) / T);
        previous = d;
        let (d_f, v_f) = pos_f.step((d / sensors.encoder_m).round() * sensors.encoder_m);
        let (f_f, _) = force_f.step(f + noise.sample(&mut rng));
        out.push(ContactSample {
            depth_m: d_f,
            depth_rate_m_per_s: v_f,
            force_n: f_f,
        });
        truth.push(f);
    }
    (out, truth)
}

/// Relative error |est − truth| / |truth|.
pub fn rel(est: f32, truth: f32) -> f32 {
    (est - truth).abs() / truth.abs()
}

/// First time [s] after which every listed relative error stays below `tol` for good.
pub fn settling_time(errors: &[Vec<f32>], tol: f32) -> Option<f32> {
    let n = errors.first()?.len();
    let mut last_bad = None;
    for h in 0..n {
        // NaN counts as outside the band.
        if errors.iter().any(|e| e[h].is_nan() || e[h] > tol) {
            last_bad = Some(h);
        }
    }
    match last_bad {
        None => Some(0.0),
        Some(h) if h + 1 < n => Some((h + 1) as f32 * T),
        Some(_) => None,
    }
}

/// The paper's Hunt-Crossley numbers (mN, mm) in SI (EQUATIONS.md): k·1e-3·1000ⁿ.
pub fn paper_k_si(k_mn_mm: f32, n: f32) -> f32 {
    k_mn_mm * 1.0e-3 * 1000f32.powf(n)
}

/// The paper's Hunt-Crossley damping (mN, mm, mm/s) in SI: λ·1000ⁿ.
pub fn paper_lambda_si(lambda_mn_mm: f32, n: f32) -> f32 {
    lambda_mn_mm * 1000f32.powf(n)
}

/// Pressing motion for the thin plastic layer: 0.05-1 mm, 1-3 Hz (≈ 13 N at 1 mm).
pub const PLASTIC_MOTION: Motion = Motion {
    min_m: 0.05e-3,
    max_m: 1.0e-3,
    f0_hz: 1.0,
    f1_hz: 3.0,
    sweep_s: 2.0,
};

/// Pressing motion for the soft gel: 0.1-5 mm, 0.5-1.5 Hz (≈ 12 N at 5 mm).
pub const GEL_MOTION: Motion = Motion {
    min_m: 0.1e-3,
    max_m: 5.0e-3,
    f0_hz: 0.5,
    f1_hz: 1.5,
    sweep_s: 3.0,
};

/// Per-parameter relative-error histories of one run.
pub struct Track {
    pub names: Vec<&'static str>,
    pub errors: Vec<Vec<f32>>,
}

impl Track {
    pub fn new(names: &[&'static str]) -> Self {
        Track {
            names: names.to_vec(),
            errors: vec![Vec::new(); names.len()],
        }
    }

    pub fn push(&mut self, estimates: &[f32], truth: &[f32]) {
        for (i, e) in self.errors.iter_mut().enumerate() {
            e.push(rel(estimates[i], truth[i]));
        }
    }

    /// Final relative errors.
    pub fn final_errors(&self) -> Vec<f32> {
        self.errors.iter().map(|e| *e.last().unwrap()).collect()
    }

    /// Largest final relative error.
    pub fn worst_final(&self) -> f32 {
        self.final_errors().into_iter().fold(0.0, f32::max)
    }

    pub fn settling(&self, tol: f32) -> Option<f32> {
        settling_time(&self.errors, tol)
    }

    pub fn report(&self, label: &str) {
        let finals: Vec<String> = self
            .names
            .iter()
            .zip(self.final_errors())
            .map(|(n, e)| format!("{n} {:.2}%", 100.0 * e))
            .collect();
        println!(
            "{label}: final [{}], within 5% from {:?} s, within 2% from {:?} s",
            finals.join(", "),
            self.settling(0.05),
            self.settling(0.02)
        );
    }
}
