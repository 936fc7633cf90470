//! Logs with hidden effects, for testing the discrepancy workflow: the plant of
//! [`crate::plant`] (motor under position control, 12-bit ADC with noise, 1 µm encoder)
//! presses a material made of the core's model pieces — the QLV elastic response
//! (linear, power law or exponential) and relaxation mode, Hunt-Crossley damping
//! λ·δ^q·δ̇ — plus the mechanical and measurement effects the workflow names. Parameters
//! are drawn at random from a seed; the workflow only ever sees the log.

use estimator_core::laws;
use estimator_core::models::{ContactModel, ElasticResponse};
use rand::{rngs::StdRng, Rng, SeedableRng};

use crate::diagnose::catalogue::Effect;
use crate::plant::{MaterialChange, Plant, PlantConfig, Trajectory};
use crate::report::SimulatedLog;

/// The true material and sensor effects of a generated log.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
pub struct Truth {
    /// Linear stiffness \[N/m\] (also sets the scale of the other elastic laws).
    pub kappa: f64,
    /// Damping \[N·s/m^(q+1)\].
    pub lambda: f64,
    /// Power-law exponent (1 if absent).
    pub n: f64,
    /// Exponential rate b \[1/m\] (0 if absent).
    pub b: f64,
    /// Damping exponent q (0 if absent).
    pub q: f64,
    /// Relaxing fraction and rate \[1/s\] (0 if absent).
    pub relaxed_fraction: f64,
    /// Relaxation rate \[1/s\].
    pub rate_per_s: f64,
    /// Load-cell bias step after the tare \[N\].
    pub force_offset_n: f64,
    /// Where in the free stretch after the first contact that step falls: 0 at the
    /// lift-off, 1 at the next touch (a zero that shifts with the load need not shift
    /// the moment the load comes off).
    pub force_offset_at: f64,
    /// When that step falls \[s\] from the log's first sample (0 without one).
    pub force_offset_step_s: f64,
    /// Drift of the load cell's zero \[N/s\] from the log's start.
    pub force_drift_n_per_s: f64,
    /// Surface shift after the first tap \[m\] (the workflow sees −shift as contact offset).
    pub surface_shift_m: f64,
    /// Tissue mass \[kg\].
    pub mass_kg: f64,
    /// Force-channel delay \[s\].
    pub delay_s: f64,
    /// Coulomb friction \[N\].
    pub coulomb_n: f64,
    /// Plastic-set fraction of the deepest indentation.
    pub plastic_fraction: f64,
    /// Deepest reference indentation \[m\].
    pub depth_m: f64,
}

/// A generated log.
pub struct Generated {
    /// The acquisition (1 kHz): what the workflow gets.
    pub log: SimulatedLog,
    /// The same force without noise or quantisation, through the same sensor effects.
    pub noiseless_force_n: Vec<f64>,
    /// The hidden effects.
    pub effects: Vec<Effect>,
    /// The truth behind them.
    pub truth: Truth,
}

/// Sample time of the plant \[s\].
const T: f64 = 1.0e-3;
/// End of the first tap \[s\]: the contact point is taken there.
const TAP_END_S: f64 = 0.9;

/// The generator's material: elastic response with relaxation (QLV), damping, tissue mass,
/// Coulomb friction, plastic set and a surface that may shift after the first tap.
struct Material {
    elastic: ElasticResponse,
    /// Relaxing fraction c of the relaxation mode and its [`laws::relaxing_step`]
    /// coefficients at ν.
    relaxed_fraction: f32,
    relaxation: (f32, f32),
    /// The relaxing state z (z' = −ν·z + dF_e/dt) and the last F_e.
    relaxing: f32,
    previous_elastic_n: f32,
    lambda: f32,
    q: f32,
    mass: f32,
    coulomb: f32,
    plastic: f32,
    shift_m: f32,
    deepest: f32,
    previous_rate: f32,
    /// The probe has touched the surface / has left it after the first touch.
    touched: bool,
    left: bool,
}

impl ContactModel for Material {
    fn step(&mut self, depth_m: f32, depth_rate_m_per_s: f32) -> f32 {
        let accel = (depth_rate_m_per_s - self.previous_rate) / T as f32;
        self.previous_rate = depth_rate_m_per_s;
        // The surface moves once the probe has left it after the first tap.
        if self.touched && depth_m <= 0.0 {
            self.left = true;
        }
        self.touched |= depth_m > 0.0;
        let surface = if self.left { self.shift_m } else { 0.0 };
        let depth = depth_m - surface;
        self.deepest = self.deepest.max(depth);
        let effective = depth - self.plastic * self.deepest.max(0.0);
        // QLV with one mode (eqs. 9-10): F = (1 − c)·F_e + c·z, z' = −ν·z + dF_e/dt, the
        // state following F_e through separation; only the total force is clipped (the core's
        // QLV clips its own output before damping is added, which no batch model can
        // separate from the damping).
        let fe = self.elastic.force_n(effective);
        let (one_minus_decay, gain) = self.relaxation;
        self.relaxing = laws::relaxing_step(
            self.relaxing,
            fe - self.previous_elastic_n,
            one_minus_decay,
            gain,
        );
        self.previous_elastic_n = fe;
        let elastic = (1.0 - self.relaxed_fraction) * fe + self.relaxed_fraction * self.relaxing;
        if effective <= 0.0 {
            return 0.0;
        }
        let damping = if self.q == 0.0 {
            self.lambda * depth_rate_m_per_s
        } else {
            self.lambda * effective.powf(self.q) * depth_rate_m_per_s
        };
        let coulomb = self.coulomb * (depth_rate_m_per_s / 2.5e-3).tanh();
        (elastic + damping + self.mass * accel + coulomb).max(0.0)
    }

    fn reset(&mut self) {
        self.relaxing = 0.0;
        self.previous_elastic_n = 0.0;
        self.deepest = 0.0;
        self.touched = false;
        self.left = false;
    }
}

/// Reference depth of the generator's motion \[m\], one point per millisecond: free
/// space (tare), a shallow first tap, 12 s of pressing whose depth grows from 35 % to
/// 100 % of `depth` with a frequency sweeping between `f0` and `f1` \[Hz\] plus an
/// operator's unsteadiness (Gaussian noise through two critically damped second-order
/// low-passes at `fc` \[Hz\], RMS 5 % of `depth`), a ramp-and-hold, and release.
fn motion(depth: f64, f0: f64, f1: f64, fc: f64, rng: &mut StdRng) -> Trajectory {
    use rand_distr::{Distribution, StandardNormal};
    let mut points = vec![
        (0.0, -1.0e-3),
        (0.6, -1.0e-3),
        (0.75, 0.25 * depth),
        (TAP_END_S, -0.5e-3),
        (1.2, -0.1e-3),
    ];
    let (t0, t1) = (1.2, 13.2);
    let samples = ((t1 - t0) / T) as usize;
    let w = 2.0 * std::f64::consts::PI * fc;
    let mut state = [0.0f64; 4];
    let mut unsteady: Vec<f64> = (0..samples + 2000)
        .map(|_| {
            let e: f64 = StandardNormal.sample(rng);
            // Two cascaded x'' + 2w x' + w² x = w² u, explicit Euler at 1 ms.
            let a1 = w * w * (e - state[0]) - 2.0 * w * state[1];
            state[1] += a1 * T;
            state[0] += state[1] * T;
            let a2 = w * w * (state[0] - state[2]) - 2.0 * w * state[3];
            state[3] += a2 * T;
            state[2] += state[3] * T;
            state[2]
        })
        .collect();
    unsteady.drain(..2000);
    let rms = (unsteady.iter().map(|x| x * x).sum::<f64>() / samples as f64)
        .sqrt()
        .max(1e-300);
    let mut phase = 0.0;
    for (k, x) in unsteady.iter().enumerate() {
        let t = t0 + k as f64 * T;
        let u = (t - t0) / (t1 - t0);
        let f = f0 + (f1 - f0) * 0.5 * (1.0 - (std::f64::consts::PI * 3.0 * u).cos());
        phase += 2.0 * std::f64::consts::PI * f * T;
        let amplitude = (0.35 + 0.65 * u) * depth;
        let blend = ((t - t0) / 0.5).min(1.0);
        points.push((
            t,
            -0.1e-3
                + (amplitude + 0.1e-3) * 0.5 * (1.0 - phase.cos())
                + blend * 0.05 * depth * x / rms,
        ));
    }
    points.extend([
        (13.6, 0.6 * depth),
        (16.0, 0.6 * depth),
        (16.5, -1.0e-3),
        (17.0, -1.0e-3),
    ]);
    // A hand has no corners: resample at 1 ms and smooth twice with a 25 ms moving
    // average (the ramps' velocity steps become 50 ms blends).
    let coarse = Trajectory::Waypoints { points };
    let raw: Vec<f64> = (0..(17.0 / T) as usize)
        .map(|k| coarse.depth_m(k as f64 * T))
        .collect();
    let smooth = |x: &[f64]| -> Vec<f64> {
        const W: usize = 25;
        (0..x.len())
            .map(|k| {
                let (a, b) = (k.saturating_sub(W / 2), (k + W / 2 + 1).min(x.len()));
                x[a..b].iter().sum::<f64>() / (b - a) as f64
            })
            .collect()
    };
    let smoothed = smooth(&smooth(&raw));
    let points = smoothed
        .into_iter()
        .enumerate()
        .map(|(k, d)| (k as f64 * T, d))
        .collect();
    Trajectory::Waypoints { points }
}

/// Generates a 17 s log with `effects` hidden, parameters drawn from `seed`.
///
/// # Panics
/// Never for the parameter ranges drawn here (the models' constructors validate them).
pub fn generate(effects: &[Effect], seed: u64) -> Generated {
    let mut rng = StdRng::seed_from_u64(seed);
    let has = |e: Effect| effects.contains(&e);
    let depth = rng.random_range(3.0e-3..5.0e-3);
    let kappa = rng.random_range(1500.0..4000.0);
    let (f0, f1) = (rng.random_range(0.4..0.8), rng.random_range(1.5..2.5));
    let trajectory = motion(depth, f0, f1, rng.random_range(4.0..8.0), &mut rng);
    let f_max = kappa * depth;
    let mut truth = Truth {
        kappa,
        lambda: rng.random_range(20.0..120.0),
        n: 1.0,
        depth_m: depth,
        ..Truth::default()
    };
    let elastic = if has(Effect::PowerLawStiffness) {
        truth.n = rng.random_range(1.3..1.8);
        ElasticResponse::PowerLaw {
            gamma1: (kappa * depth / depth.powf(truth.n)) as f32,
            gamma2: truth.n as f32,
        }
    } else if has(Effect::ExponentialStiffness) {
        truth.b = rng.random_range(1.5..4.0) / depth;
        let m = kappa * depth * truth.b / (truth.b * depth).exp_m1();
        ElasticResponse::Exponential {
            m: m as f32,
            b: truth.b as f32,
        }
    } else {
        ElasticResponse::PowerLaw {
            gamma1: kappa as f32,
            gamma2: 1.0,
        }
    };
    if has(Effect::DepthDependentDamping) {
        truth.q = rng.random_range(1.0..2.0);
        // The same damping force at half the depth.
        truth.lambda /= (0.5 * depth).powf(truth.q);
    }
    if has(Effect::Relaxation) {
        truth.relaxed_fraction = rng.random_range(0.2..0.45);
        truth.rate_per_s = rng.random_range(0.5..3.0);
    }
    let signed = |rng: &mut StdRng, lo: f64, hi: f64| {
        if rng.random_bool(0.5) {
            rng.random_range(lo..hi)
        } else {
            -rng.random_range(lo..hi)
        }
    };
    if has(Effect::ForceOffset) {
        truth.force_offset_n = signed(&mut rng, 0.02, 0.06) * f_max;
        truth.force_offset_at = rng.random_range(0.0..1.0);
    }
    if has(Effect::ForceDrift) {
        // 2-6 % of the peak force over the log's 17 s.
        truth.force_drift_n_per_s = signed(&mut rng, 0.02, 0.06) * f_max / 17.0;
    }
    if has(Effect::ContactPointOffset) {
        truth.surface_shift_m = signed(&mut rng, 0.05, 0.1) * depth;
    }
    if has(Effect::Inertia) {
        // A probe tip and the tissue moving with it.
        truth.mass_kg = rng.random_range(0.1..0.3);
    }
    if has(Effect::TimeDelay) {
        truth.delay_s = rng.random_range(0.005..0.02);
    }
    if has(Effect::CoulombFriction) {
        truth.coulomb_n = rng.random_range(0.02..0.05) * f_max;
    }
    if has(Effect::PlasticSet) {
        truth.plastic_fraction = rng.random_range(0.05..0.12);
    }
    let material = Material {
        elastic,
        relaxed_fraction: truth.relaxed_fraction as f32,
        relaxation: laws::relaxation_coefficients(truth.rate_per_s.max(1e-9) as f32, T as f32),
        relaxing: 0.0,
        previous_elastic_n: 0.0,
        lambda: truth.lambda as f32,
        q: truth.q as f32,
        mass: truth.mass_kg as f32,
        coulomb: truth.coulomb_n as f32,
        plastic: truth.plastic_fraction as f32,
        shift_m: truth.surface_shift_m as f32,
        deepest: 0.0,
        previous_rate: 0.0,
        touched: false,
        left: false,
    };
    let config = PlantConfig {
        trajectory,
        seed: seed ^ 0x5EED,
        ..PlantConfig::default()
    };
    let mut plant = Plant::new(
        config.clone(),
        vec![MaterialChange {
            at_s: 0.0,
            model: Box::new(material),
        }],
    )
    .expect("valid plant");
    let mut acquisition = crate::plant::Acquisition::new(&config, 0.0).expect("valid calibration");
    let n = (17.0 / T) as usize;
    let mut log = crate::report::record_plant(&mut plant, &mut acquisition, n);
    let mut noiseless = log.true_force_n.clone();
    // End of the first contact: the probe back above the surface after the first touch.
    let first_touch = log.true_depth_m.iter().position(|d| *d > 0.0).unwrap_or(n);
    let first_left = (first_touch..n)
        .find(|i| log.true_depth_m[*i] <= 0.0)
        .unwrap_or(n);
    let next_touch = (first_left..n)
        .find(|i| log.true_depth_m[*i] > 0.0)
        .unwrap_or(n);
    let offset_step =
        first_left + (truth.force_offset_at * (next_touch - first_left) as f64) as usize;
    if truth.force_offset_n != 0.0 {
        truth.force_offset_step_s = offset_step as f64 * T;
    }
    for f in [&mut log.force_n, &mut noiseless] {
        if truth.delay_s > 0.0 {
            let shift = truth.delay_s / T;
            let original = f.clone();
            for (i, v) in f.iter_mut().enumerate() {
                let x = i as f64 - shift;
                *v = if x <= 0.0 {
                    original[0]
                } else {
                    let k = x.floor() as usize;
                    let frac = x - k as f64;
                    original[k] * (1.0 - frac) + original[(k + 1).min(original.len() - 1)] * frac
                };
            }
        }
        if truth.force_offset_n != 0.0 {
            // The load cell's zero shifts after its first load: the tare no longer holds.
            for v in f.iter_mut().skip(offset_step) {
                *v += truth.force_offset_n;
            }
        }
        if truth.force_drift_n_per_s != 0.0 {
            for (i, v) in f.iter_mut().enumerate() {
                *v += truth.force_drift_n_per_s * i as f64 * T;
            }
        }
    }
    Generated {
        log,
        noiseless_force_n: noiseless,
        effects: effects.to_vec(),
        truth,
    }
}

/// NRMSE \[%\] of the generator's noise alone over the workflow's fit window: the
/// measured force against the noiseless one, block-averaged like the workflow's data,
/// range-normalised like its NRMSE. The floor a perfect model reaches.
pub fn noise_floor_percent(generated: &Generated, data: &crate::diagnose::data::Prepared) -> f64 {
    let block = data.block;
    let start = data.fit_start();
    let blocks = data.len();
    let avg =
        |v: &[f64], b: usize| v[b * block..(b + 1) * block].iter().sum::<f64>() / block as f64;
    let diff: Vec<f64> = (start..blocks)
        .map(|b| avg(&generated.log.force_n, b) - avg(&generated.noiseless_force_n, b))
        .collect();
    let mean = diff.iter().sum::<f64>() / diff.len() as f64;
    let rms =
        (diff.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / diff.len() as f64).sqrt();
    let y = &data.force_n[start..];
    let range = y.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - y.iter().copied().fold(f64::INFINITY, f64::min);
    100.0 * rms / range
}
