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
            m.push(0.3, Shape::Ramp { to: behind });
            m.segments[0].from = 2.0 * behind;
            m.push(20.0, sines(rng, 1.5 * behind, depth, false));
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
                m.segments.push(Segment {
                    t0: 0.0,
                    duration: 20.0,
                    from: 0.0,
                    shape,
                });
                // Start in contact: the chirp begins at its mean.
            } else {
                let shape = sines(rng, lo, depth, true);
                m.segments.push(Segment {
                    t0: 0.0,
                    duration: 20.0,
                    from: 0.0,
                    shape,
                });
            }
        }
        Structure::ContactSinesLong => {
            let start = rng.random_range(0.4..0.8) * depth;
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: start,
                shape: Shape::Hold,
            });
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
            m.segments.push(Segment {
                t0: 0.0,
                duration: 20.0,
                from: 0.0,
                shape,
            });
        }
        Structure::RampLoad => {
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: 2.0 * behind,
                shape: Shape::Hold,
            });
            m.hold(0.3);
            m.ramp_to(depth, speed);
        }
        Structure::RampLoadUnload => {
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: 2.0 * behind,
                shape: Shape::Hold,
            });
            m.hold(0.3);
            m.ramp_to(depth, speed);
            m.ramp_to(2.0 * behind, speed);
            m.hold(0.3);
        }
        Structure::RampSpeeds => {
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: 2.0 * behind,
                shape: Shape::Hold,
            });
            for factor in [0.3, 1.0, 3.0] {
                m.hold(0.3);
                m.ramp_to(depth, factor * speed);
                m.ramp_to(2.0 * behind, factor * speed);
            }
            m.hold(0.3);
        }
        Structure::RampHold => {
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: 2.0 * behind,
                shape: Shape::Hold,
            });
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
            m.segments.push(Segment {
                t0: 0.0,
                duration: 0.0,
                from: 2.0 * behind,
                shape: Shape::Hold,
            });
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
        },
    }
}

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
