//! Simulated plant: the paper's rig at 1 kHz (Sec. 5, Fig. 10).
//!
//! A 1-DOF linear motor (moving mass, viscous and Coulomb friction, force limit) under a
//! position or force controller drives a probe, from free space, into a material given by
//! any contact model of the core (which may be swapped mid-run). Sensors are what the
//! firmware sees: a load cell behind a 12-bit ADC (offset, gain, noise, quantisation,
//! saturation) and a quadrature encoder behind a 16-bit wrapping counter. All parameters
//! are in one serialisable config with units in the names; a seed makes a run repeatable.

use estimator_core::models::ContactModel;
use estimator_core::sensors::{EncoderUnwrapper, LoadCellCalibration};
use estimator_core::RawSample;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Motor and moving parts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotorConfig {
    /// Moving mass (forcer, probe, load cell) \[kg\].
    pub moving_mass_kg: f64,
    /// Viscous friction \[N·s/m\].
    pub viscous_friction_n_s_per_m: f64,
    /// Coulomb friction \[N\].
    pub coulomb_friction_n: f64,
    /// Largest force the amplifier can produce \[N\].
    pub force_limit_n: f64,
}

/// Feedback controller of the motor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ControllerConfig {
    /// PD on position with velocity and acceleration feed-forward.
    Position {
        /// Proportional gain \[N/m\].
        kp_n_per_m: f64,
        /// Derivative gain \[N·s/m\].
        kd_n_s_per_m: f64,
    },
    /// PI on the measured contact force, with active damping; the trajectory's depth is
    /// read as a force reference scaled by `newtons_per_metre`.
    Force {
        /// Proportional gain (dimensionless: N of motor force per N of error).
        kp: f64,
        /// Integral gain \[1/s\].
        ki_per_s: f64,
        /// Active damping \[N·s/m\].
        damping_n_s_per_m: f64,
        /// Force reference per metre of trajectory depth \[N/m\].
        newtons_per_metre: f64,
    },
}

/// Load cell behind the ADC: the true calibration and the sensor's noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LoadCellConfig {
    /// Reference voltage \[V\].
    pub reference_v: f32,
    /// ADC resolution \[bits\] (12).
    pub adc_bits: u8,
    /// Amplifier output at zero force \[V\] (the true offset: may differ from the
    /// nominal calibration the acquisition uses, as on a real board).
    pub offset_v: f32,
    /// Sensitivity \[V/N\].
    pub sensitivity_v_per_n: f32,
    /// White force noise before the ADC, standard deviation \[N\].
    pub noise_n: f32,
    /// Offset drift \[V/s\] (0 for none).
    pub offset_drift_v_per_s: f32,
}

impl LoadCellConfig {
    /// Calibration with the true offset at time `t` \[s\].
    pub fn calibration_at(&self, time_s: f64) -> LoadCellCalibration {
        LoadCellCalibration {
            reference_v: self.reference_v,
            full_scale_code: ((1u32 << self.adc_bits) - 1) as u16,
            offset_v: self.offset_v + self.offset_drift_v_per_s * time_s as f32,
            sensitivity_v_per_n: self.sensitivity_v_per_n,
        }
    }
}

/// Quadrature encoder.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EncoderConfig {
    /// Counts per metre after ×4 decoding (1e6: 1 µm).
    pub counts_per_m: f64,
}

/// Depth reference of the motion, relative to the material surface (positive into it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Trajectory {
    /// Free space at `approach_depth_m` (< 0) until `start_s`, then a sinusoid between
    /// `min_depth_m` and `max_depth_m` whose frequency sweeps between `f0_hz` and `f1_hz`
    /// with period `sweep_s` (realistic pressing; excites stiffness and damping).
    SineSweep {
        /// Depth before the pressing starts \[m\] (negative: out of contact).
        approach_depth_m: f64,
        /// Start of the pressing \[s\].
        start_s: f64,
        /// Shallowest depth \[m\] (negative: the probe leaves the surface every cycle).
        min_depth_m: f64,
        /// Deepest depth \[m\].
        max_depth_m: f64,
        /// Lowest frequency \[Hz\].
        f0_hz: f64,
        /// Highest frequency \[Hz\].
        f1_hz: f64,
        /// Period of the frequency sweep \[s\].
        sweep_s: f64,
    },
    /// Piecewise-linear depth through `(time_s, depth_m)` waypoints (steps are ramps
    /// between two close waypoints), held after the last one.
    Waypoints {
        /// (time \[s\], depth \[m\]), times increasing.
        points: Vec<(f64, f64)>,
    },
    /// One trajectory after another: part i runs from its start time (its own t = 0)
    /// until the next part starts.
    Sequence {
        /// (start \[s\], trajectory), start times increasing.
        parts: Vec<(f64, Trajectory)>,
    },
}

impl Trajectory {
    /// Reference depth \[m\] at time `t` \[s\].
    pub fn depth_m(&self, t: f64) -> f64 {
        match self {
            Trajectory::SineSweep {
                approach_depth_m,
                start_s,
                min_depth_m,
                max_depth_m,
                f0_hz,
                f1_hz,
                sweep_s,
            } => {
                if t < *start_s {
                    return *approach_depth_m;
                }
                let tau = t - start_s;
                let fm = 0.5 * (f0_hz + f1_hz);
                let fa = 0.5 * (f1_hz - f0_hz);
                let wm = 2.0 * std::f64::consts::PI / sweep_s;
                let phase =
                    2.0 * std::f64::consts::PI * (fm * tau + fa * (1.0 - (wm * tau).cos()) / wm);
                // Blend from the approach depth to the sinusoid over the first 0.2 s.
                let blend = (tau / 0.2).min(1.0);
                let sine = min_depth_m + (max_depth_m - min_depth_m) * 0.5 * (1.0 - phase.cos());
                approach_depth_m + blend * (sine - approach_depth_m)
            }
            Trajectory::Waypoints { points } => {
                let Some(first) = points.first() else {
                    return 0.0;
                };
                if t <= first.0 {
                    return first.1;
                }
                for w in points.windows(2) {
                    let (t0, d0) = w[0];
                    let (t1, d1) = w[1];
                    if t <= t1 {
                        return if t1 > t0 {
                            d0 + (d1 - d0) * (t - t0) / (t1 - t0)
                        } else {
                            d1
                        };
                    }
                }
                points.last().map_or(0.0, |p| p.1)
            }
            Trajectory::Sequence { parts } => {
                let part = parts
                    .iter()
                    .rev()
                    .find(|(start, _)| t >= *start)
                    .or(parts.first());
                part.map_or(0.0, |(start, traj)| traj.depth_m(t - start))
            }
        }
    }
}

/// Everything that defines a plant run, with units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlantConfig {
    /// Sample time T \[s\] of the acquisition and control.
    pub sample_time_s: f64,
    /// Mechanical integration steps per sample.
    pub substeps: u32,
    /// Motor.
    pub motor: MotorConfig,
    /// Controller.
    pub controller: ControllerConfig,
    /// Load cell and ADC.
    pub load_cell: LoadCellConfig,
    /// Encoder.
    pub encoder: EncoderConfig,
    /// Position of the material surface in encoder coordinates \[m\].
    pub surface_position_m: f64,
    /// Motion.
    pub trajectory: Trajectory,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl Default for PlantConfig {
    /// The paper's kind of rig: 1 kg moving mass, ±33 N load cell on a 12-bit ADC with
    /// 20 mN noise, 1 µm encoder, stiff position control at 1 kHz.
    fn default() -> Self {
        PlantConfig {
            sample_time_s: 1.0e-3,
            substeps: 10,
            motor: MotorConfig {
                moving_mass_kg: 1.0,
                viscous_friction_n_s_per_m: 5.0,
                coulomb_friction_n: 0.5,
                force_limit_n: 100.0,
            },
            controller: ControllerConfig::Position {
                kp_n_per_m: 2.0e5,
                kd_n_s_per_m: 600.0,
            },
            load_cell: LoadCellConfig {
                reference_v: 3.3,
                adc_bits: 12,
                offset_v: 1.65,
                sensitivity_v_per_n: 0.05,
                noise_n: 0.02,
                offset_drift_v_per_s: 0.0,
            },
            encoder: EncoderConfig {
                counts_per_m: 1.0e6,
            },
            surface_position_m: 0.010,
            trajectory: Trajectory::Waypoints {
                points: vec![(0.0, -1.0e-3)],
            },
            seed: 1,
        }
    }
}

impl PlantConfig {
    /// The calibration the acquisition uses: nominal, i.e. the load cell's at t = 0.
    pub fn nominal_calibration(&self) -> LoadCellCalibration {
        self.load_cell.calibration_at(0.0)
    }
}

/// A material and the time it comes under the probe.
pub struct MaterialChange {
    /// Time of the change \[s\].
    pub at_s: f64,
    /// The new material.
    pub model: Box<dyn ContactModel>,
}

/// One sample of the plant: the raw sensor codes and the truth behind them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlantSample {
    /// Sample time \[s\].
    pub time_s: f64,
    /// 16-bit encoder counter.
    pub encoder_raw: u16,
    /// ADC code of the load cell.
    pub adc_code: u16,
    /// True probe position \[m\].
    pub true_position_m: f64,
    /// True penetration \[m\] (negative out of contact).
    pub true_depth_m: f64,
    /// True contact force \[N\].
    pub true_force_n: f64,
    /// Motor force commanded \[N\] (after the limit).
    pub motor_force_n: f64,
}

/// The running plant.
pub struct Plant {
    config: PlantConfig,
    materials: Vec<MaterialChange>,
    active: usize,
    position_m: f64,
    velocity_m_per_s: f64,
    contact_force_n: f64,
    force_integral: f64,
    previous_depth_m: f64,
    rng: StdRng,
    noise: Normal<f64>,
    step: u64,
}

impl Plant {
    /// Builds the plant at rest at the trajectory's start. `materials` are sorted by time;
    /// the first one applies from t = 0.
    ///
    /// # Errors
    /// If the config is not usable (non-positive mass or sample time, no material, noise
    /// not finite).
    pub fn new(config: PlantConfig, mut materials: Vec<MaterialChange>) -> anyhow::Result<Self> {
        anyhow::ensure!(config.sample_time_s > 0.0, "sample_time_s must be > 0");
        anyhow::ensure!(
            config.motor.moving_mass_kg > 0.0,
            "motor.moving_mass_kg must be > 0"
        );
        anyhow::ensure!(config.substeps >= 1, "substeps must be >= 1");
        anyhow::ensure!(!materials.is_empty(), "the plant needs a material");
        config.nominal_calibration().validate()?;
        materials.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let noise = Normal::new(0.0, f64::from(config.load_cell.noise_n.max(0.0)))?;
        let start = config.surface_position_m + config.trajectory.depth_m(0.0);
        Ok(Plant {
            rng: StdRng::seed_from_u64(config.seed),
            noise,
            position_m: start,
            velocity_m_per_s: 0.0,
            contact_force_n: 0.0,
            force_integral: 0.0,
            previous_depth_m: start - config.surface_position_m,
            materials,
            active: 0,
            step: 0,
            config,
        })
    }

    /// The config.
    pub fn config(&self) -> &PlantConfig {
        &self.config
    }

    /// Index of the material under the probe.
    pub fn active_material(&self) -> usize {
        self.active
    }

    /// Advances one sample: sensors read at the start of the sample, controller output
    /// held over it, mechanics integrated in `substeps`, contact force updated at its end.
    pub fn step(&mut self) -> PlantSample {
        let c = &self.config;
        let t = self.step as f64 * c.sample_time_s;
        // Sensors.
        let counts = (self.position_m * c.encoder.counts_per_m).floor() as i64;
        let encoder_raw = counts.rem_euclid(1 << 16) as u16;
        let noisy_force = self.contact_force_n + self.noise.sample(&mut self.rng);
        let adc_code = c.load_cell.calibration_at(t).code(noisy_force as f32);
        let depth_m = self.position_m - c.surface_position_m;
        let sample = PlantSample {
            time_s: t,
            encoder_raw,
            adc_code,
            true_position_m: self.position_m,
            true_depth_m: depth_m,
            true_force_n: self.contact_force_n,
            motor_force_n: 0.0,
        };

        // Controller (on the measured signals).
        let measured_position = counts as f64 / c.encoder.counts_per_m;
        let measured_force = f64::from(c.nominal_calibration().force_n(adc_code).0);
        let dt = c.sample_time_s;
        let reference = |tt: f64| c.surface_position_m + c.trajectory.depth_m(tt);
        let (x_ref, x_ref_next, x_ref_prev) = (reference(t), reference(t + dt), reference(t - dt));
        let v_ref = (x_ref_next - x_ref_prev) / (2.0 * dt);
        let a_ref = (x_ref_next - 2.0 * x_ref + x_ref_prev) / (dt * dt);
        let m = &c.motor;
        let u = match c.controller {
            ControllerConfig::Position {
                kp_n_per_m,
                kd_n_s_per_m,
            } => {
                let feedforward = m.moving_mass_kg * a_ref + m.viscous_friction_n_s_per_m * v_ref;
                kp_n_per_m * (x_ref - measured_position)
                    + kd_n_s_per_m * (v_ref - self.velocity_m_per_s)
                    + feedforward
            }
            ControllerConfig::Force {
                kp,
                ki_per_s,
                damping_n_s_per_m,
                newtons_per_metre,
            } => {
                let f_ref = (c.trajectory.depth_m(t) * newtons_per_metre).max(0.0);
                let error = f_ref - measured_force;
                self.force_integral += error * dt;
                f_ref + kp * error + ki_per_s * self.force_integral
                    - damping_n_s_per_m * self.velocity_m_per_s
            }
        };
        let u = u.clamp(-m.force_limit_n, m.force_limit_n);

        // Mechanics with the contact force held over the sample.
        let h = dt / c.substeps as f64;
        for _ in 0..c.substeps {
            let v = self.velocity_m_per_s;
            let coulomb = if v.abs() > 1e-6 {
                m.coulomb_friction_n * v.signum()
            } else {
                0.0
            };
            let a = (u - m.viscous_friction_n_s_per_m * v - coulomb - self.contact_force_n)
                / m.moving_mass_kg;
            self.velocity_m_per_s += a * h;
            self.position_m += self.velocity_m_per_s * h;
        }

        // Material schedule and contact force at the end of the sample.
        let t_next = t + dt;
        while self.active + 1 < self.materials.len()
            && self.materials[self.active + 1].at_s <= t_next
        {
            self.active += 1;
        }
        let depth = self.position_m - self.config.surface_position_m;
        let rate = (depth - self.previous_depth_m) / dt;
        self.previous_depth_m = depth;
        let model = &mut self.materials[self.active].model;
        self.contact_force_n = f64::from(model.step(depth as f32, rate as f32));
        self.step += 1;
        PlantSample {
            motor_force_n: u,
            ..sample
        }
    }
}

/// Converts the plant's raw codes to SI exactly as the firmware does (core sensor
/// conversions with the nominal calibration).
pub struct Acquisition {
    calibration: LoadCellCalibration,
    encoder: EncoderUnwrapper,
}

impl Acquisition {
    /// For a plant config (nominal calibration; the encoder's first read is position
    /// `initial_position_m`).
    ///
    /// # Errors
    /// If the calibration or encoder config is invalid.
    pub fn new(config: &PlantConfig, initial_position_m: f64) -> anyhow::Result<Self> {
        let calibration = config.nominal_calibration();
        calibration.validate()?;
        Ok(Acquisition {
            calibration,
            encoder: EncoderUnwrapper::try_new(
                config.encoder.counts_per_m as f32,
                initial_position_m as f32,
            )?,
        })
    }

    /// Raw codes → SI sample.
    pub fn convert(&mut self, sample: &PlantSample) -> RawSample {
        let (force_n, saturated) = self.calibration.force_n(sample.adc_code);
        RawSample {
            position_m: self.encoder.position_m(sample.encoder_raw),
            force_n,
            saturated,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator_core::models::{HuntCrossley, KelvinVoigt};

    fn config(trajectory: Trajectory) -> PlantConfig {
        PlantConfig {
            trajectory,
            ..PlantConfig::default()
        }
    }

    #[test]
    fn free_space_then_contact_reads_the_material() {
        let kv = KelvinVoigt::try_new(2000.0, 0.0).unwrap();
        let cfg = config(Trajectory::Waypoints {
            points: vec![(0.0, -1.0e-3), (0.5, -1.0e-3), (1.0, 2.0e-3), (2.0, 2.0e-3)],
        });
        let mut plant = Plant::new(
            cfg.clone(),
            vec![MaterialChange {
                at_s: 0.0,
                model: Box::new(kv),
            }],
        )
        .unwrap();
        let mut acq = Acquisition::new(&cfg, 0.0).unwrap();
        let mut last = None;
        for _ in 0..2000 {
            let s = plant.step();
            let raw = acq.convert(&s);
            last = Some((s, raw));
        }
        let (s, raw) = last.unwrap();
        // Position control holds 2 mm in the material: F ≈ 4 N, within the control error.
        assert!(
            (s.true_depth_m - 2.0e-3).abs() < 0.1e-3,
            "{}",
            s.true_depth_m
        );
        assert!((s.true_force_n - 2000.0 * s.true_depth_m).abs() < 1e-3);
        // The acquisition sees the same force within noise and quantisation.
        assert!((f64::from(raw.force_n) - s.true_force_n).abs() < 0.1);
        // And the position relative to the start (encoder starts at 0).
        let start = cfg.surface_position_m - 1.0e-3;
        assert!((f64::from(raw.position_m) - (s.true_position_m - start)).abs() < 2e-6);
    }

    #[test]
    fn encoder_counter_wraps_but_position_does_not() {
        // 1 µm counts and 80 mm of travel: the 16-bit counter wraps once.
        let cfg = PlantConfig {
            surface_position_m: 1.0,
            ..config(Trajectory::Waypoints {
                points: vec![(0.0, -0.09), (1.0, -0.01)],
            })
        };
        let hc = HuntCrossley::try_new(4.58e4, 2.79e5, 1.2).unwrap();
        let mut plant = Plant::new(
            cfg.clone(),
            vec![MaterialChange {
                at_s: 0.0,
                model: Box::new(hc),
            }],
        )
        .unwrap();
        let mut acq = Acquisition::new(&cfg, 0.0).unwrap();
        let mut wrapped = false;
        let mut previous = None;
        let mut last = (0.0, 0.0);
        for _ in 0..1500 {
            let s = plant.step();
            if let Some(p) = previous {
                wrapped |= s.encoder_raw < p;
            }
            previous = Some(s.encoder_raw);
            last = (acq.convert(&s).position_m, s.true_position_m);
        }
        assert!(wrapped);
        let start = 1.0 - 0.09;
        assert!(
            (f64::from(last.0) - (last.1 - start)).abs() < 5e-6,
            "{last:?}"
        );
    }

    #[test]
    fn adc_saturates_at_full_scale() {
        let stiff = KelvinVoigt::try_new(1.0e6, 0.0).unwrap();
        let cfg = config(Trajectory::Waypoints {
            points: vec![(0.0, -1.0e-4), (0.2, 1.0e-3)],
        });
        let mut plant = Plant::new(
            cfg.clone(),
            vec![MaterialChange {
                at_s: 0.0,
                model: Box::new(stiff),
            }],
        )
        .unwrap();
        let mut acq = Acquisition::new(&cfg, 0.0).unwrap();
        let saturated = (0..400).any(|_| acq.convert(&plant.step()).saturated);
        assert!(saturated);
    }
}
