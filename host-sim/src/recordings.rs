//! Recordings of many structures, for testing what the project is judged on: data shaped
//! unlike its own paper scenarios. A [`Structure`] fixes how a recording starts (out of
//! contact with an approach, already pressing with brief or long lift-offs, or never
//! leaving contact) and its motion (sines, a chirp, constant-speed ramps loading only or
//! loading and unloading at one or several speeds, ramp-and-hold, cycles, taps); each seed
//! then draws the material's parameters, the sample rate (100 Hz to 10 kHz), the force
//! offset (either sign, up to half the force range), the axis orientation, the position
//! constant, white or AR(1) force noise with ADC quantisation, and encoder quantisation.
//!
//! The forces come from the core's own contact models ([`estimator_core::models`], the
//! laws of [`estimator_core::laws`]): memoryless laws are evaluated at the sample times
//! with the exact rate of the motion, the quasi-linear viscoelastic model is stepped at
//! 0.1 ms (never coarser than the recording).

use estimator_core::laws;
use estimator_core::models::{ContactModel, ElasticResponse, QuasiLinearViscoelastic};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// How a recording starts and how the probe moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Structure {
    /// Out of contact, an approach, then a sum of sines that lifts off every cycle.
    ApproachSines,
    /// Already pressing at the first sample; sines with brief lift-offs (< 100 ms).
    ContactSinesBrief,
    /// Already pressing; sines with long lift-offs (≥ 0.4 s behind the surface).
    ContactSinesLong,
    /// Already pressing and never leaving the material.
    NeverLeaves,
    /// A chirp (0.2 → 4 Hz) starting in contact, with brief lift-offs.
    Chirp,
    /// An approach and one constant-speed loading ramp.
    RampLoad,
    /// An approach and a constant-speed triangle (loading, then unloading out of contact).
    RampLoadUnload,
    /// Three triangles at speeds a factor 3 apart.
    RampSpeeds,
    /// An approach, a fast ramp, a hold (relaxation), and the release.
    RampHold,
    /// An approach and minimum-jerk taps separated by rests out of contact.
    Taps,
}

impl Structure {
    /// All structures.
    pub const ALL: [Structure; 10] = [
        Structure::ApproachSines,
        Structure::ContactSinesBrief,
        Structure::ContactSinesLong,
        Structure::NeverLeaves,
        Structure::Chirp,
        Structure::RampLoad,
        Structure::RampLoadUnload,
        Structure::RampSpeeds,
        Structure::RampHold,
        Structure::Taps,
    ];

    /// Kebab-case name.
    pub fn name(self) -> &'static str {
        match self {
            Structure::ApproachSines => "approach-sines",
            Structure::ContactSinesBrief => "contact-sines-brief-lift-offs",
            Structure::ContactSinesLong => "contact-sines-long-lift-offs",
            Structure::NeverLeaves => "never-leaves-contact",
            Structure::Chirp => "chirp-from-contact",
            Structure::RampLoad => "ramp-loading-only",
            Structure::RampLoadUnload => "ramp-load-unload",
            Structure::RampSpeeds => "ramps-three-speeds",
            Structure::RampHold => "ramp-and-hold",
            Structure::Taps => "taps",
        }
    }

    /// The recording starts in contact.
    pub fn starts_in_contact(self) -> bool {
        matches!(
            self,
            Structure::ContactSinesBrief
                | Structure::ContactSinesLong
                | Structure::NeverLeaves
                | Structure::Chirp
        )
    }

    /// The rate varies within spans of a few seconds (the damping is excited online), as
    /// opposed to constant-speed strokes.
    pub fn varies_rate(self) -> bool {
        !matches!(
            self,
            Structure::RampLoad
                | Structure::RampLoadUnload
                | Structure::RampSpeeds
                | Structure::RampHold
        )
    }
}

/// The material's law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MaterialKind {
    /// Kelvin-Voigt, eq. (1).
    KelvinVoigt,
    /// Hunt-Crossley, eq. (3), q = n.
    HuntCrossley,
    /// Hunt-Crossley without damping: F = k·δⁿ.
    PowerLaw,
    /// Quasi-linear viscoelastic, power-law elasticity, one relaxation mode (eqs. 10, 14).
    Qlv,
}

/// What a recording was made from.
#[derive(Debug, Clone, Serialize)]
pub struct Truth {
    /// Structure.
    pub structure: Structure,
    /// Material.
    pub material: MaterialKind,
    /// κ \[N/m\] (Kelvin-Voigt) or k \[N/mⁿ\] (Hunt-Crossley) or γ1 (QLV, instantaneous).
    pub stiffness: f64,
    /// λ (Kelvin-Voigt \[N·s/m\], Hunt-Crossley \[N·s/m^(n+1)\]); 0 for power law and QLV.
    pub lambda: f64,
    /// n (1 for Kelvin-Voigt; γ2 for QLV).
    pub n: f64,
    /// QLV relaxed fraction c0 and rate ν \[1/s\] (0 otherwise).
    pub relaxed_fraction: f64,
    /// QLV relaxation rate \[1/s\].
    pub rate_per_s: f64,
    /// Force offset \[N\].
    pub offset_n: f64,
    /// +1: position increases into the material; −1: it decreases.
    pub axis_sign: f64,
    /// Position of the surface on the file's axis \[m\].
    pub contact_position_m: f64,
    /// Sample rate \[Hz\].
    pub rate_hz: f64,
    /// Force noise σ \[N\] and its AR(1) coefficient per sample.
    pub noise_n: f64,
    /// AR(1) coefficient (0: white).
    pub noise_rho: f64,
    /// Deepest penetration \[m\].
    pub max_depth_m: f64,
    /// Typical speed of the motion \[m/s\] (the ramps' speed; the material's damping
    /// carries 5-25 % of the force at it).
    pub speed_m_s: f64,
}

impl Truth {
    /// The elastic force at 1 mm \[N\].
    pub fn force_at_1mm_n(&self) -> f64 {
        self.stiffness * 1e-3f64.powf(self.n)
    }

    /// λ·(1 mm)ⁿ \[N·s/m\] (λ for Kelvin-Voigt).
    pub fn damping_at_1mm(&self) -> f64 {
        self.lambda
            * 1e-3f64.powf(
                self.n
                    - if self.material == MaterialKind::KelvinVoigt {
                        1.0
                    } else {
                        0.0
                    },
            )
    }
}

/// A generated recording in the project's CSV convention (position on the file's axis).
#[derive(Debug, Clone)]
pub struct Recording {
    /// Time \[s\].
    pub time_s: Vec<f64>,
    /// Position \[m\] on the file's axis (may point out of the material).
    pub position_m: Vec<f64>,
    /// Force \[N\] with offset, noise and quantisation.
    pub force_n: Vec<f64>,
    /// What it was made from.
    pub truth: Truth,
}

impl Recording {
    /// The recording as CSV text (`time_s,position_m,force_n`).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("time_s,position_m,force_n\n");
        for i in 0..self.time_s.len() {
            s.push_str(&format!(
                "{:.7},{:.9e},{:.9e}\n",
                self.time_s[i], self.position_m[i], self.force_n[i]
            ));
        }
        s
    }
}

/// The motion: penetration δ(t) \[m\] (negative behind the surface) and its exact rate.
struct Motion {
    segments: Vec<Segment>,
}

/// One piece of motion from `t0` for `duration` \[s\].
#[derive(Debug, Clone, Copy)]
enum Shape {
    /// Constant at `from`.
    Hold,
    /// Linear from `from` to `to`.
    Ramp { to: f64 },
    /// Minimum-jerk move from `from` to `to`.
    MinJerk { to: f64 },
    /// mean + Σ aᵢ·sin(2π fᵢ t + φᵢ).
    Sines {
        mean: f64,
        terms: [(f64, f64, f64); 3],
    },
    /// mean + a·sin(φ(t)), frequency sweeping linearly from f0 to f1.
    Chirp {
        mean: f64,
        amplitude: f64,
        f0: f64,
        f1: f64,
    },
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    t0: f64,
    duration: f64,
    from: f64,
    shape: Shape,
}

impl Motion {
    fn new() -> Motion {
        Motion {
            segments: Vec::new(),
        }
    }

    fn end(&self) -> (f64, f64) {
        self.segments
            .last()
            .map_or((0.0, 0.0), |s| (s.t0 + s.duration, s.value(s.duration).0))
    }

    fn push(&mut self, duration: f64, shape: Shape) {
        let (t0, from) = self.end();
        self.segments.push(Segment {
            t0,
            duration,
            from,
            shape,
        });
    }

    /// Starts the motion at `position` (a zero-length hold the next segments continue from).
    fn start_at(&mut self, position: f64) {
        self.segments.push(Segment {
            t0: 0.0,
            duration: 0.0,
            from: position,
            shape: Shape::Hold,
        });
    }

    fn hold(&mut self, duration: f64) {
        self.push(duration, Shape::Hold);
    }

    fn ramp_to(&mut self, to: f64, speed: f64) {
        let from = self.end().1;
        self.push(((to - from).abs() / speed).max(1e-3), Shape::Ramp { to });
    }

    fn min_jerk_to(&mut self, to: f64, duration: f64) {
        self.push(duration, Shape::MinJerk { to });
    }

    fn duration(&self) -> f64 {
        self.end().0
    }

    /// (δ, δ̇) at `t`.
    fn at(&self, t: f64) -> (f64, f64) {
        let k = self.segments.partition_point(|s| s.t0 <= t).max(1) - 1;
        let s = &self.segments[k];
        s.value((t - s.t0).clamp(0.0, s.duration))
    }
}

impl Segment {
    fn value(&self, tau: f64) -> (f64, f64) {
        use std::f64::consts::PI;
        match self.shape {
            Shape::Hold => (self.from, 0.0),
            Shape::Ramp { to } => {
                let v = (to - self.from) / self.duration;
                (self.from + v * tau, v)
            }
            Shape::MinJerk { to } => {
                let s = tau / self.duration;
                let p = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
                let dp = (30.0 * s * s - 60.0 * s.powi(3) + 30.0 * s.powi(4)) / self.duration;
                (self.from + (to - self.from) * p, (to - self.from) * dp)
            }
            Shape::Sines { mean, terms } => {
                let mut x = mean;
                let mut v = 0.0;
                for (a, f, phi) in terms {
                    x += a * (2.0 * PI * f * tau + phi).sin();
                    v += a * 2.0 * PI * f * (2.0 * PI * f * tau + phi).cos();
                }
                (x, v)
            }
            Shape::Chirp {
                mean,
                amplitude,
                f0,
                f1,
            } => {
                let rate = (f1 - f0) / self.duration;
                let phase = 2.0 * PI * (f0 * tau + 0.5 * rate * tau * tau);
                let freq = f0 + rate * tau;
                (
                    mean + amplitude * phase.sin(),
                    amplitude * 2.0 * PI * freq * phase.cos(),
                )
            }
        }
    }
}

/// Sines between `lo` and `hi`: one dominant term (0.4-1.2 Hz) whose every trough reaches
/// within 2.5 % of `lo`, and two small incommensurate ones; with `start_high` the
/// recording begins near the top.
fn sines(rng: &mut StdRng, lo: f64, hi: f64, start_high: bool) -> Shape {
    let mean = 0.5 * (lo + hi);
    let amp = 0.5 * (hi - lo);
    let f = rng.random_range(0.4..1.2);
    let phase = |rng: &mut StdRng| rng.random_range(0.0..std::f64::consts::TAU);
    let first = if start_high {
        0.5 * std::f64::consts::PI
    } else {
        phase(rng)
    };
    Shape::Sines {
        mean,
        terms: [
            (0.975 * amp, f, first),
            (0.015 * amp, f * 1.73, phase(rng)),
            (0.01 * amp, f * 2.91, phase(rng)),
        ],
    }
}

/// The motion of `structure` reaching `depth` \[m\] at typical speed `speed` \[m/s\], for a
/// recording at `rate_hz` (a ramp-and-hold's ramp lasts at least 30 samples).
fn motion(structure: Structure, rng: &mut StdRng, depth: f64, speed: f64, rate_hz: f64) -> Motion {
    let mut m = Motion::new();
    let behind = -0.15 * depth;
    match structure {
        Structure::ApproachSines => {
            // A minimum-jerk approach from behind the surface to where the sines start
            // (no jump in position: a step would be a glitch, not an approach).
            let shape = sines(rng, 1.5 * behind, depth, false);
            let start = Segment {
                t0: 0.0,
                duration: 20.0,
                from: 0.0,
                shape,
            }
            .value(0.0)
            .0;
            m.start_at(2.0 * behind);
            m.min_jerk_to(start, 0.3 + (start - 2.0 * behind).abs() / speed);
            m.push(20.0, shape);
        }
        Structure::ContactSinesBrief | Structure::Chirp => {
            // Every trough dips 2-4.5 % of the depth behind the surface: lift-offs of
            // 40-120 ms at these frequencies.
            let lo = -0.03 * depth;
            if structure == Structure::Chirp {
                let shape = Shape::Chirp {
                    mean: 0.5 * (lo + depth),
                    amplitude: 0.5 * (depth - lo),
                    f0: 0.2,
                    f1: 4.0,
                };
                m.push(20.0, shape);
                // Start in contact: the chirp begins at its mean.
            } else {
                let shape = sines(rng, lo, depth, true);
                m.push(20.0, shape);
            }
        }
        Structure::ContactSinesLong => {
            let start = rng.random_range(0.4..0.8) * depth;
            m.start_at(start);
            for _ in 0..6 {
                m.min_jerk_to(
                    depth * rng.random_range(0.7..1.0),
                    rng.random_range(0.3..0.8),
                );
                m.min_jerk_to(
                    behind * rng.random_range(1.5..3.0),
                    rng.random_range(0.3..0.8),
                );
                m.hold(rng.random_range(0.4..1.0));
                m.min_jerk_to(
                    depth * rng.random_range(0.2..0.5),
                    rng.random_range(0.3..0.8),
                );
            }
        }
        Structure::NeverLeaves => {
            let shape = sines(rng, 0.3 * depth, depth, true);
            m.push(20.0, shape);
        }
        Structure::RampLoad => {
            m.start_at(2.0 * behind);
            m.hold(0.3);
            m.ramp_to(depth, speed);
        }
        Structure::RampLoadUnload => {
            m.start_at(2.0 * behind);
            m.hold(0.3);
            m.ramp_to(depth, speed);
            m.ramp_to(2.0 * behind, speed);
            m.hold(0.3);
        }
        Structure::RampSpeeds => {
            m.start_at(2.0 * behind);
            for factor in [0.3, 1.0, 3.0] {
                m.hold(0.3);
                m.ramp_to(depth, factor * speed);
                m.ramp_to(2.0 * behind, factor * speed);
            }
            m.hold(0.3);
        }
        Structure::RampHold => {
            m.start_at(2.0 * behind);
            m.hold(0.5);
            // The paper's polyurethane: a fast ramp (here 10-40 depths per second, and at
            // least 30 samples).
            let fastest = depth * rate_hz / 30.0;
            m.ramp_to(depth, (rng.random_range(10.0..40.0) * depth).min(fastest));
            m.hold(rng.random_range(8.0..15.0));
            m.ramp_to(
                2.0 * behind,
                (rng.random_range(10.0..40.0) * depth).min(fastest),
            );
            m.hold(0.5);
        }
        Structure::Taps => {
            m.start_at(2.0 * behind);
            for _ in 0..10 {
                m.hold(rng.random_range(0.2..0.8));
                m.min_jerk_to(
                    depth * rng.random_range(0.5..1.0),
                    rng.random_range(0.2..0.6),
                );
                m.min_jerk_to(2.0 * behind, rng.random_range(0.2..0.6));
            }
        }
    }
    m
}

/// The material of `kind`, with parameters drawn so that the force at the deepest point
/// is 3-30 N and the damping (if any) carries 5-25 % of it at the typical speed.
fn material(
    kind: MaterialKind,
    rng: &mut StdRng,
    depth: f64,
    speed: f64,
) -> (f64, f64, f64, f64, f64) {
    let f_max = rng.random_range(3.0..30.0);
    let share = rng.random_range(0.05..0.25);
    match kind {
        MaterialKind::KelvinVoigt => {
            let kappa = f_max / depth;
            (kappa, share * kappa * depth / speed, 1.0, 0.0, 0.0)
        }
        MaterialKind::HuntCrossley | MaterialKind::PowerLaw => {
            let n = rng.random_range(1.15..1.8);
            let k = f_max / depth.powf(n);
            let lambda = if kind == MaterialKind::PowerLaw {
                0.0
            } else {
                share * k / speed
            };
            (k, lambda, n, 0.0, 0.0)
        }
        MaterialKind::Qlv => {
            let n = rng.random_range(1.2..1.9);
            (
                f_max / depth.powf(n),
                0.0,
                n,
                rng.random_range(0.4..0.8),
                rng.random_range(0.15..1.0),
            )
        }
    }
}

/// A recording of `structure` into a material of `kind`, from `seed`.
pub fn generate(structure: Structure, kind: MaterialKind, seed: u64) -> Recording {
    let mut rng = StdRng::seed_from_u64(seed ^ 0xC0FFEE_u64.wrapping_mul(structure as u64 + 1));
    let depth = rng.random_range(2.0e-3..5.0e-3);
    let speed = rng.random_range(1.0..4.0) * depth;
    let rate_hz = *[100.0, 250.0, 500.0, 1000.0, 2000.0, 5000.0, 10_000.0]
        .get(rng.random_range(0..7))
        .unwrap_or(&1000.0);
    let motion = motion(structure, &mut rng, depth, speed, rate_hz);
    let (stiffness, lambda, n, relaxed, nu) = material(kind, &mut rng, depth, speed);
    let dt = 1.0 / rate_hz;
    let samples = (motion.duration() / dt) as usize;
    let time: Vec<f64> = (0..samples).map(|i| i as f64 * dt).collect();
    let mut force: Vec<f64> = Vec::with_capacity(samples);
    match kind {
        MaterialKind::Qlv => {
            let step = 1.0e-4f64.min(dt);
            let per_sample = (dt / step).round().max(1.0) as usize;
            let step = dt / per_sample as f64;
            let elastic = ElasticResponse::PowerLaw {
                gamma1: stiffness as f32,
                gamma2: n as f32,
            };
            let mut qlv = QuasiLinearViscoelastic::<1>::try_new(
                elastic,
                [(1.0 - relaxed) as f32],
                [nu as f32],
                step as f32,
            )
            .expect("valid QLV parameters");
            for &t in &time {
                let mut f = 0.0;
                for j in 1..=per_sample {
                    let (d, v) = motion.at(t - dt + j as f64 * step);
                    f = qlv.step(d as f32, v as f32);
                }
                force.push(f64::from(f));
            }
        }
        _ => {
            for &t in &time {
                let (d, v) = motion.at(t);
                let f = match kind {
                    MaterialKind::KelvinVoigt => laws::kelvin_voigt(d, v, stiffness, lambda),
                    _ => laws::hunt_crossley(d, v, stiffness, lambda, n, n),
                };
                force.push(laws::unilateral(f));
            }
        }
    }
    // Sensors.
    let range = force.iter().copied().fold(0.0, f64::max).max(1e-12);
    let offset = rng.random_range(-0.5..0.5) * range;
    let sigma = rng.random_range(0.002..0.01) * range;
    let rho: f64 = if rng.random_bool(0.5) {
        0.0
    } else {
        rng.random_range(0.8..0.97)
    };
    let bits = rng.random_range(12..17);
    let lsb = 1.6 * range / f64::from(1u32 << bits);
    let normal = Normal::new(0.0, 1.0).expect("valid");
    let mut e = 0.0;
    let innovation = sigma * (1.0 - rho * rho).sqrt();
    for f in &mut force {
        e = rho * e + innovation * normal.sample(&mut rng);
        *f = ((*f + offset + e) / lsb).round() * lsb;
    }
    let axis_sign = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
    let constant = rng.random_range(-0.05..0.05);
    let encoder = rng.random_range(0.1e-6..1.0e-6);
    let position: Vec<f64> = time
        .iter()
        .map(|&t| {
            let x = axis_sign * motion.at(t).0 + constant;
            (x / encoder).round() * encoder
        })
        .collect();
    let max_depth = (0..samples)
        .map(|i| motion.at(time[i]).0)
        .fold(0.0, f64::max);
    Recording {
        time_s: time,
        position_m: position,
        force_n: force,
        truth: Truth {
            structure,
            material: kind,
            stiffness,
            lambda,
            n,
            relaxed_fraction: relaxed,
            rate_per_s: nu,
            offset_n: offset,
            axis_sign,
            contact_position_m: constant,
            rate_hz,
            noise_n: sigma,
            noise_rho: rho,
            max_depth_m: max_depth,
            speed_m_s: speed,
        },
    }
}

/// Tolerances of [`Score::passes`]: the acceptance (n and the force at 1 mm within
/// 5 %, Kelvin-Voigt κ within 3 %, damping within 30 % where the record determines it).
pub const N_TOLERANCE: f64 = 0.05;
/// Relative tolerance on the elastic force at 1 mm (Hunt-Crossley).
pub const FORCE_TOLERANCE: f64 = 0.05;
/// Relative tolerance on κ (Kelvin-Voigt).
pub const KAPPA_TOLERANCE: f64 = 0.03;
/// Relative tolerance on λ where the record determines it.
pub const DAMPING_TOLERANCE: f64 = 0.30;
/// Largest damping share λ·δⁿ·v / (k·δⁿ) at the typical speed an estimate may report for
/// a material without damping.
pub const SPURIOUS_DAMPING_SHARE: f64 = 0.05;

/// How one `estimate` run did on one recording.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    /// Structure.
    pub structure: Structure,
    /// Material.
    pub material: MaterialKind,
    /// Estimator.
    pub model: String,
    /// Seed.
    pub seed: u64,
    /// The force offset was given to the estimate (`--force-offset-n`).
    pub offset_given: bool,
    /// The run's error, if it failed.
    pub error: Option<String>,
    /// Relative error of n (Hunt-Crossley; `None` for Kelvin-Voigt).
    pub n_error: Option<f64>,
    /// Relative error of the elastic force at 1 mm (κ·1 mm for Kelvin-Voigt).
    pub force_error: Option<f64>,
    /// Relative error of λ (truth > 0), or the damping share at the typical speed (truth 0).
    pub damping_error: Option<f64>,
    /// Per-parameter identifiability the run reported.
    pub identifiable: std::collections::BTreeMap<String, bool>,
    /// The front end determined the offset from the record (or it was given).
    pub offset_determined: bool,
    /// The axis orientation the front end chose matches the truth.
    pub axis_right: bool,
    /// The run reported its online estimate settled (no warning that it differs from the
    /// whole-record fit or fits much worse).
    pub converged: bool,
}

impl Score {
    /// Whether the parameter was reported identifiable (absent = yes).
    pub fn is_identifiable(&self, name: &str) -> bool {
        self.identifiable.get(name).copied().unwrap_or(true)
    }

    /// The acceptance test: the run succeeded with the right axis, and every parameter is
    /// either within tolerance or flagged as not determined by the record. A record that
    /// never leaves contact cannot determine the offset unless given: then k (κ) and n
    /// must be flagged.
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let Some(e) = &self.error {
            out.push(format!("error: {e}"));
            return out;
        }
        if !self.axis_right {
            out.push("wrong axis orientation".into());
        }
        let stiffness = if self.material == MaterialKind::KelvinVoigt {
            ("kappa", KAPPA_TOLERANCE)
        } else {
            ("k", FORCE_TOLERANCE)
        };
        let check = |out: &mut Vec<String>, name: &str, err: Option<f64>, tol: f64| {
            if let Some(e) = err {
                if self.is_identifiable(name) && e.abs() > tol {
                    out.push(format!(
                        "{name} error {:+.1} % (reported identifiable)",
                        100.0 * e
                    ));
                }
            }
        };
        // A power law's k and n depend on the offset; a linear law's κ does not where it
        // pushes throughout (its offset trades with the contact point alone:
        // `FrontEnd::linear_law_pushes_throughout`), and is judged by its tolerance.
        if !self.offset_determined {
            for name in ["k", "n"] {
                if self.identifiable.contains_key(name) && self.is_identifiable(name) {
                    out.push(format!(
                        "offset not determined but {name} reported identifiable"
                    ));
                }
            }
        }
        check(&mut out, stiffness.0, self.force_error, stiffness.1);
        check(&mut out, "n", self.n_error, N_TOLERANCE);
        let damping_tolerance = if self.material == MaterialKind::PowerLaw {
            SPURIOUS_DAMPING_SHARE
        } else {
            DAMPING_TOLERANCE
        };
        check(&mut out, "lambda", self.damping_error, damping_tolerance);
        out
    }

    /// Passes [`Score::failures`].
    pub fn passes(&self) -> bool {
        self.failures().is_empty()
    }

    /// One line for a run that does not pass: `SILENT` or `warned`, the case, the seed and
    /// [`Score::failures`].
    pub fn describe(&self) -> String {
        format!(
            "{} {}{} {:?} {} seed {}: {}",
            if self.fails_silently() {
                "SILENT"
            } else {
                "warned"
            },
            self.structure.name(),
            if self.offset_given {
                " (offset given)"
            } else {
                ""
            },
            self.material,
            self.model,
            self.seed,
            self.failures().join("; ")
        )
    }

    /// Fails silently: outside tolerance on a parameter reported identifiable, without the
    /// warning that the online estimate has not settled. (A wrong axis or a failed run is
    /// always silent-or-loud as it is: counted here.)
    pub fn fails_silently(&self) -> bool {
        !self.passes() && (self.converged || self.error.is_some() || !self.axis_right)
    }
}

/// Runs `model` on `recording` through [`crate::files::estimate_file`] (written as CSV
/// into `dir`, read back as a user's file would be), with the true offset given if
/// `give_offset`, and scores the result against the truth.
pub fn score(
    recording: &Recording,
    model: estimator_core::ModelKind,
    seed: u64,
    dir: &std::path::Path,
    give_offset: bool,
) -> Score {
    use estimator_core::{AnyParameters, ModelKind};
    let t = &recording.truth;
    let mut out = Score {
        structure: t.structure,
        material: t.material,
        model: model.name().to_string(),
        seed,
        offset_given: give_offset,
        error: None,
        n_error: None,
        force_error: None,
        damping_error: None,
        identifiable: Default::default(),
        offset_determined: give_offset,
        axis_right: false,
        converged: false,
    };
    let path = dir.join(format!(
        "{}-{:?}-{}-{seed}.csv",
        t.structure.name(),
        t.material,
        model.name()
    ));
    if let Err(e) = std::fs::write(&path, recording.to_csv()) {
        out.error = Some(format!("{}: {e}", path.display()));
        return out;
    }
    let overrides = crate::setup::Overrides {
        front_end: crate::frontend::Options {
            position_sign: None,
            force_offset_n: give_offset.then_some(t.offset_n),
        },
        ..Default::default()
    };
    let run = crate::files::estimate_file(model, &path, "csv", &overrides, None);
    let _ = std::fs::remove_file(&path);
    let run = match run {
        Ok(run) => run,
        Err(e) => {
            out.error = Some(format!("{e:#}"));
            return out;
        }
    };
    out.identifiable = run.identifiable.clone();
    out.converged = run.converged;
    out.axis_right = run.front_end.position_sign == t.axis_sign;
    if !give_offset {
        out.offset_determined = !matches!(
            run.front_end.offset,
            crate::frontend::OffsetSource::NotIdentifiable { .. }
        );
    }
    let rel = |est: f64, truth: f64| (est - truth) / truth;
    let depth_ref: f64 = 1.0e-3;
    match (run.result.parameters, model) {
        (AnyParameters::KelvinVoigt(p), _) => {
            out.force_error = Some(rel(f64::from(p.kappa), t.stiffness));
            out.damping_error = Some(if t.lambda > 0.0 {
                rel(f64::from(p.lambda), t.lambda)
            } else {
                f64::from(p.lambda) * t.speed_m_s / t.stiffness
            });
        }
        (AnyParameters::HuntCrossley(p), _) => {
            let (k, lambda, n) = (f64::from(p.k), f64::from(p.lambda), f64::from(p.n));
            out.n_error = Some(rel(n, t.n));
            out.force_error = Some(rel(k * depth_ref.powf(n), t.force_at_1mm_n()));
            out.damping_error = Some(if t.lambda > 0.0 {
                rel(lambda, t.lambda)
            } else {
                lambda * t.speed_m_s / k
            });
        }
        (
            AnyParameters::Hammerstein { gamma2, .. },
            ModelKind::Hammerstein1 | ModelKind::Hammerstein2,
        ) => {
            out.n_error = Some(rel(f64::from(gamma2), t.n));
        }
        _ => {}
    }
    out
}

/// One cell of the structure × estimator table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Case {
    /// Structure.
    pub structure: Structure,
    /// Material.
    pub material: MaterialKind,
    /// Estimator.
    pub model: estimator_core::ModelKind,
    /// `--force-offset-n` given with the true offset.
    pub give_offset: bool,
}

/// The cases the tests assert: every structure with a Kelvin-Voigt material (its
/// estimator), a Hunt-Crossley and a pure power-law material (both Hunt-Crossley
/// estimators); a record that never leaves contact once without and once with the offset
/// given.
pub fn cases() -> Vec<Case> {
    use estimator_core::ModelKind;
    let mut out = Vec::new();
    for structure in Structure::ALL {
        let offsets: &[bool] = if structure == Structure::NeverLeaves {
            &[false, true]
        } else {
            &[false]
        };
        for &give_offset in offsets {
            for (material, model) in [
                (MaterialKind::KelvinVoigt, ModelKind::KelvinVoigt),
                (MaterialKind::HuntCrossley, ModelKind::HuntCrossley),
                (
                    MaterialKind::HuntCrossley,
                    ModelKind::HuntCrossleySingleStage,
                ),
                (MaterialKind::PowerLaw, ModelKind::HuntCrossley),
                (MaterialKind::PowerLaw, ModelKind::HuntCrossleySingleStage),
            ] {
                out.push(Case {
                    structure,
                    material,
                    model,
                    give_offset,
                });
            }
        }
    }
    out
}

/// Runs `case` for every seed (in parallel) and returns the scores.
pub fn run_case(case: Case, seeds: &[u64], dir: &std::path::Path) -> Vec<Score> {
    use rayon::prelude::*;
    seeds
        .par_iter()
        .map(|&seed| {
            let r = generate(case.structure, case.material, seed);
            score(&r, case.model, seed, dir, case.give_offset)
        })
        .collect()
}

/// A Markdown table row summarising `scores` of one case: passes, median and worst
/// |error| of n, F(1 mm) (κ) and λ over the runs that reported them identifiable, and how
/// often each was flagged not identifiable.
pub fn table_row(case: Case, scores: &[Score]) -> String {
    let stat = |name: &str, pick: &dyn Fn(&Score) -> Option<f64>| {
        let mut v: Vec<f64> = scores
            .iter()
            .filter(|s| s.error.is_none() && s.is_identifiable(name))
            .filter_map(|s| pick(s).map(f64::abs))
            .collect();
        let flagged = scores
            .iter()
            .filter(|s| s.error.is_none() && !s.is_identifiable(name))
            .count();
        v.sort_by(f64::total_cmp);
        let cell = if v.is_empty() {
            "–".to_string()
        } else {
            format!(
                "{:.1} / {:.1}",
                100.0 * v[v.len() / 2],
                100.0 * v[v.len() - 1]
            )
        };
        if flagged > 0 {
            format!("{cell} ({flagged} flagged)")
        } else {
            cell
        }
    };
    let stiffness = if case.material == MaterialKind::KelvinVoigt {
        "kappa"
    } else {
        "k"
    };
    let n = if case.material == MaterialKind::KelvinVoigt {
        "–".to_string()
    } else {
        stat("n", &|s| s.n_error)
    };
    let passes = scores.iter().filter(|s| s.passes()).count();
    let warned = scores
        .iter()
        .filter(|s| !s.passes() && !s.fails_silently())
        .count();
    let silent = scores.iter().filter(|s| s.fails_silently()).count();
    format!(
        "| {}{} | {:?} | {} | {}/{} | {warned} | {silent} | {} | {} | {} |",
        case.structure.name(),
        if case.give_offset {
            " (offset given)"
        } else {
            ""
        },
        case.material,
        case.model.name(),
        passes,
        scores.len(),
        n,
        stat(stiffness, &|s| s.force_error),
        stat("lambda", &|s| s.damping_error),
    )
}

/// Header of [`table_row`]'s table.
pub const TABLE_HEADER: &str = "| structure | material | estimator | pass | warned | silent | n err % (median / worst) | F(1 mm) or κ err % | λ err % (share if none) |\n|---|---|---|---|---|---|---|---|---|";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structures_start_and_move_as_named() {
        for s in Structure::ALL {
            let r = generate(s, MaterialKind::HuntCrossley, 7);
            let t = &r.truth;
            let depth: Vec<f64> = r
                .position_m
                .iter()
                .map(|x| t.axis_sign * (x - t.contact_position_m))
                .collect();
            let in_contact = |d: f64| d > 1e-6;
            assert_eq!(
                in_contact(depth[0]),
                s.starts_in_contact(),
                "{}: starts at δ = {}",
                s.name(),
                depth[0]
            );
            let leaves = depth.iter().any(|d| *d < 0.0);
            assert_eq!(leaves, s != Structure::NeverLeaves, "{}", s.name());
            assert!(r.time_s.len() > 500, "{}", s.name());
        }
    }
}
