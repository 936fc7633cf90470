//! Simulated plant: the paper's rig at 1 kHz (Sec. 5, Fig. 10).
//!
//! A 1-DOF linear motor (moving mass, viscous and Coulomb friction, force limit) under a
//! position or force controller drives a probe, from free space, into a material given by
//! any contact model of the core (which may be swapped mid-run). Sensors are what the
//! firmware sees: a load cell behind a 12-bit ADC (offset, gain, noise, quantisation,
//! saturation) and a quadrature encoder behind a 16-bit wrapping counter. All parameters
//! are in one serialisable config with units in the names; a seed makes a run repeatable.
//!
//! [`Faults`] injects what goes wrong on a real rig, for robustness tests: NaN or infinite
//! force readings, dropped samples (at given times or at a rate), the ADC driven beyond
//! full scale, encoder glitches (a jump of N counts, for one sample or kept), on top of
//! what the plant does anyway (load-cell offset drift, `LoadCellConfig::offset_drift_v_per_s`;
//! the 16-bit counter wrapping every 65.536 mm of travel; contact loss and re-contact from
//! the trajectory; abrupt material changes, [`MaterialChange`]).

use estimator_core::models::ContactModel;
use estimator_core::sensors::{EncoderUnwrapper, LoadCellCalibration};
use estimator_core::RawSample;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
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
                // First waypoint at or after t (binary search: long recorded motions
                // have one waypoint per sample).
                let k = points.partition_point(|p| p.0 < t);
                if k >= points.len() {
                    return points.last().map_or(0.0, |p| p.1);
                }
                let ((t0, d0), (t1, d1)) = (points[k - 1], points[k]);
                if t1 > t0 {
                    d0 + (d1 - d0) * (t - t0) / (t1 - t0)
                } else {
                    d1
                }
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

/// A span of samples hit by a fault: from `start_s` \[s\] for `duration_s` \[s\], at least
/// one sample (a duration of 0 hits the one sample nearest `start_s`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FaultWindow {
    /// Start \[s\].
    pub start_s: f64,
    /// Length \[s\] (≥ 0).
    pub duration_s: f64,
}

impl FaultWindow {
    /// One sample at `at_s` \[s\].
    pub fn at(at_s: f64) -> Self {
        FaultWindow {
            start_s: at_s,
            duration_s: 0.0,
        }
    }

    /// The indices of the samples (of sample time `sample_time_s` \[s\]) in the window;
    /// times before 0 clamp to sample 0.
    pub fn samples(&self, sample_time_s: f64) -> std::ops::Range<u64> {
        let first = (self.start_s / sample_time_s).round();
        let count = (self.duration_s / sample_time_s).round().max(1.0);
        // `as` saturates: negative times give sample 0.
        first as u64..(first + count) as u64
    }

    fn is_valid(&self) -> bool {
        self.start_s.is_finite() && self.duration_s.is_finite() && self.duration_s >= 0.0
    }
}

/// An encoder glitch: from `at_s` \[s\] the counter reads `counts` more than the true
/// position (negative: fewer) for `duration_s` \[s\] — one sample time for a spike (a
/// noise burst on the A/B lines that the counter later undoes), longer than the run for a
/// slip (counts lost for good: the measured position stays offset). The motor's position
/// loop reads the same counter, so a slip also moves the probe by the opposite amount.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EncoderGlitch {
    /// When the glitch starts \[s\].
    pub at_s: f64,
    /// Extra counts read (after ×4 decoding).
    pub counts: i32,
    /// How long the extra counts stay \[s\] (≥ one sample).
    pub duration_s: f64,
}

/// Faults injected into the acquisition, for robustness tests; the default injects none.
///
/// The NaN, infinite and dropped samples reach the estimator as a [`RawSample`] holding
/// NaN or ∞ (the firmware marks a sample it could not acquire with NaN); the motor's own
/// loop keeps running on the sensor codes. ADC overload and encoder glitches act on the
/// raw codes, which both the acquisition and the motor's loop read. Random faults draw
/// from their own generator (`seed`), so adding them does not change the sensor noise.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Faults {
    /// Samples whose force reads NaN (a corrupted conversion); the position is good.
    pub nan_force: Vec<FaultWindow>,
    /// Samples whose force reads +∞.
    pub infinite_force: Vec<FaultWindow>,
    /// Samples that were not acquired at all: position and force NaN.
    pub dropped: Vec<FaultWindow>,
    /// Probability \[per sample\] that a sample's force reads NaN.
    pub nan_force_probability_per_sample: f64,
    /// Probability \[per sample\] that a sample is dropped.
    pub dropped_probability_per_sample: f64,
    /// Windows during which the load cell is driven beyond the ADC's range (a knock, an
    /// electrical spike): the ADC reads its top code, flagged as saturated.
    pub adc_overload: Vec<FaultWindow>,
    /// Encoder glitches.
    pub encoder_glitches: Vec<EncoderGlitch>,
    /// Seed of the random faults.
    pub seed: u64,
}

impl Faults {
    /// Checks windows (finite, duration ≥ 0) and probabilities (in \[0, 1\]).
    ///
    /// # Errors
    /// Naming the bad field.
    pub fn validate(&self) -> anyhow::Result<()> {
        for (name, windows) in [
            ("nan_force", &self.nan_force),
            ("infinite_force", &self.infinite_force),
            ("dropped", &self.dropped),
            ("adc_overload", &self.adc_overload),
        ] {
            anyhow::ensure!(
                windows.iter().all(FaultWindow::is_valid),
                "faults.{name}: start_s and duration_s must be finite, duration_s >= 0"
            );
        }
        anyhow::ensure!(
            self.encoder_glitches
                .iter()
                .all(|g| g.at_s.is_finite() && g.duration_s.is_finite() && g.duration_s >= 0.0),
            "faults.encoder_glitches: at_s and duration_s must be finite, duration_s >= 0"
        );
        for (name, p) in [
            (
                "nan_force_probability_per_sample",
                self.nan_force_probability_per_sample,
            ),
            (
                "dropped_probability_per_sample",
                self.dropped_probability_per_sample,
            ),
        ] {
            anyhow::ensure!(
                (0.0..=1.0).contains(&p),
                "faults.{name} must be in [0, 1], got {p}"
            );
        }
        Ok(())
    }
}

/// [`Faults`] as sorted sample ranges, built once per plant, so that each sample's
/// look-up is a binary search (an hour's soak injects hundreds of faults).
#[derive(Debug, Clone, Default)]
struct FaultSchedule {
    nan_force: Vec<(u64, u64)>,
    infinite_force: Vec<(u64, u64)>,
    dropped: Vec<(u64, u64)>,
    adc_overload: Vec<(u64, u64)>,
    /// (first sample, extra encoder counts from it on), samples increasing.
    encoder_offset: Vec<(u64, i64)>,
    nan_force_probability: f64,
    dropped_probability: f64,
}

impl FaultSchedule {
    fn new(faults: &Faults, sample_time_s: f64) -> Self {
        let range = |w: &FaultWindow| {
            let r = w.samples(sample_time_s);
            (r.start, r.end)
        };
        let merged = |windows: &[FaultWindow]| {
            let mut r: Vec<(u64, u64)> = windows.iter().map(range).collect();
            r.sort_unstable();
            let mut out: Vec<(u64, u64)> = Vec::with_capacity(r.len());
            for (a, b) in r {
                match out.last_mut() {
                    Some(last) if a <= last.1 => last.1 = last.1.max(b),
                    _ => out.push((a, b)),
                }
            }
            out
        };
        let mut changes: Vec<(u64, i64)> = Vec::new();
        for g in &faults.encoder_glitches {
            let (a, b) = range(&FaultWindow {
                start_s: g.at_s,
                duration_s: g.duration_s,
            });
            changes.push((a, i64::from(g.counts)));
            changes.push((b, -i64::from(g.counts)));
        }
        changes.sort_unstable_by_key(|c| c.0);
        let mut total = 0;
        let encoder_offset = changes
            .into_iter()
            .map(|(step, delta)| {
                total += delta;
                (step, total)
            })
            .collect();
        FaultSchedule {
            nan_force: merged(&faults.nan_force),
            infinite_force: merged(&faults.infinite_force),
            dropped: merged(&faults.dropped),
            adc_overload: merged(&faults.adc_overload),
            encoder_offset,
            nan_force_probability: faults.nan_force_probability_per_sample,
            dropped_probability: faults.dropped_probability_per_sample,
        }
    }

    fn hit(ranges: &[(u64, u64)], step: u64) -> bool {
        let i = ranges.partition_point(|r| r.0 <= step);
        i > 0 && step < ranges[i - 1].1
    }

    /// Extra encoder counts at sample `step`.
    fn encoder_offset_counts(&self, step: u64) -> i64 {
        let i = self.encoder_offset.partition_point(|c| c.0 <= step);
        if i == 0 {
            0
        } else {
            self.encoder_offset[i - 1].1
        }
    }

    fn adc_overloaded(&self, step: u64) -> bool {
        Self::hit(&self.adc_overload, step)
    }

    /// The acquisition fault of sample `step`, drawing the random ones from `rng`.
    fn sample_fault(&self, step: u64, rng: &mut StdRng) -> SampleFault {
        let mut draw = |p: f64| p > 0.0 && rng.random::<f64>() < p;
        let dropped_at_random = draw(self.dropped_probability);
        let nan_at_random = draw(self.nan_force_probability);
        if dropped_at_random || Self::hit(&self.dropped, step) {
            SampleFault::Dropped
        } else if nan_at_random || Self::hit(&self.nan_force, step) {
            SampleFault::NanForce
        } else if Self::hit(&self.infinite_force, step) {
            SampleFault::InfiniteForce
        } else {
            SampleFault::None
        }
    }
}

/// What the acquisition got wrong on one sample (see [`Faults`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SampleFault {
    /// A good sample.
    #[default]
    None,
    /// The force reads NaN.
    NanForce,
    /// The force reads +∞.
    InfiniteForce,
    /// Not acquired: position and force NaN.
    Dropped,
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
    /// Injected faults (none by default).
    #[serde(default)]
    pub faults: Faults,
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
            faults: Faults::default(),
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
    /// The acquisition fault injected on this sample ([`Faults`]).
    pub fault: SampleFault,
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
    rng: StdRng,
    fault_rng: StdRng,
    fault_schedule: FaultSchedule,
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
        config.faults.validate()?;
        materials.sort_by(|a, b| a.at_s.total_cmp(&b.at_s));
        let noise = Normal::new(0.0, f64::from(config.load_cell.noise_n.max(0.0)))?;
        let start = config.surface_position_m + config.trajectory.depth_m(0.0);
        Ok(Plant {
            rng: StdRng::seed_from_u64(config.seed),
            fault_rng: StdRng::seed_from_u64(config.faults.seed),
            fault_schedule: FaultSchedule::new(&config.faults, config.sample_time_s),
            noise,
            position_m: start,
            velocity_m_per_s: 0.0,
            contact_force_n: 0.0,
            force_integral: 0.0,
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
        // Sensors (with the injected faults on their codes).
        let counts = (self.position_m * c.encoder.counts_per_m).floor() as i64
            + self.fault_schedule.encoder_offset_counts(self.step);
        let encoder_raw = counts.rem_euclid(1 << 16) as u16;
        let noisy_force = self.contact_force_n + self.noise.sample(&mut self.rng);
        let calibration = c.load_cell.calibration_at(t);
        let adc_code = if self.fault_schedule.adc_overloaded(self.step) {
            calibration.full_scale_code
        } else {
            calibration.code(noisy_force as f32)
        };
        let fault = self
            .fault_schedule
            .sample_fault(self.step, &mut self.fault_rng);
        let depth_m = self.position_m - c.surface_position_m;
        let sample = PlantSample {
            time_s: t,
            encoder_raw,
            adc_code,
            true_position_m: self.position_m,
            true_depth_m: depth_m,
            true_force_n: self.contact_force_n,
            motor_force_n: 0.0,
            fault,
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
        // The probe's velocity at the end of the sample, what the material feels (a
        // backward difference would delay the damping force by half a sample).
        let rate = self.velocity_m_per_s;
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

    /// Raw codes → SI sample, with the sample's injected fault: a dropped sample is all
    /// NaN (and the encoder counter is not read), a NaN or infinite force replaces the
    /// converted force.
    pub fn convert(&mut self, sample: &PlantSample) -> RawSample {
        if sample.fault == SampleFault::Dropped {
            return RawSample {
                position_m: f32::NAN,
                force_n: f32::NAN,
                saturated: false,
            };
        }
        let (force_n, saturated) = self.calibration.force_n(sample.adc_code);
        let force_n = match sample.fault {
            SampleFault::NanForce => f32::NAN,
            SampleFault::InfiniteForce => f32::INFINITY,
            SampleFault::None | SampleFault::Dropped => force_n,
        };
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
    fn faults_hit_the_samples_they_name() {
        let kv = KelvinVoigt::try_new(2000.0, 0.0).unwrap();
        let mut cfg = config(Trajectory::Waypoints {
            points: vec![(0.0, -1.0e-3)],
        });
        cfg.faults = Faults {
            nan_force: vec![FaultWindow::at(0.010)],
            infinite_force: vec![FaultWindow::at(0.020)],
            dropped: vec![FaultWindow {
                start_s: 0.030,
                duration_s: 0.003,
            }],
            adc_overload: vec![FaultWindow::at(0.040)],
            encoder_glitches: vec![EncoderGlitch {
                at_s: 0.050,
                counts: 100,
                duration_s: 0.0,
            }],
            ..Faults::default()
        };
        let mut plant = Plant::new(
            cfg.clone(),
            vec![MaterialChange {
                at_s: 0.0,
                model: Box::new(kv),
            }],
        )
        .unwrap();
        let mut acq = Acquisition::new(&cfg, 0.0).unwrap();
        let raw: Vec<RawSample> = (0..60).map(|_| acq.convert(&plant.step())).collect();
        assert!(raw[10].force_n.is_nan() && raw[10].position_m.is_finite());
        assert_eq!(raw[20].force_n, f32::INFINITY);
        assert!((30..33).all(|i| raw[i].force_n.is_nan() && raw[i].position_m.is_nan()));
        assert!(raw[33].position_m.is_finite());
        assert!(raw[40].saturated && !raw[39].saturated && !raw[41].saturated);
        // A 100-count spike for one sample, then back. The position loop reads the same
        // counter, so the spike kicks the motor: 20 N for 1 ms moves it ≈ 10 µm.
        assert!((raw[50].position_m - raw[49].position_m - 100e-6).abs() < 3e-6);
        assert!((raw[51].position_m - raw[49].position_m).abs() < 20e-6);
        let faulty = [10, 20, 30, 31, 32, 40, 50];
        for (i, r) in raw.iter().enumerate() {
            if !faulty.contains(&i) {
                assert!(r.force_n.is_finite() && r.position_m.is_finite() && !r.saturated);
            }
        }
    }

    #[test]
    fn fault_schedule_merges_windows_and_sums_glitches() {
        let faults = Faults {
            dropped: vec![
                FaultWindow {
                    start_s: 0.010,
                    duration_s: 0.005,
                },
                FaultWindow {
                    start_s: 0.012,
                    duration_s: 0.010,
                },
                FaultWindow::at(0.030),
            ],
            encoder_glitches: vec![
                EncoderGlitch {
                    at_s: 0.010,
                    counts: 5,
                    duration_s: 0.010,
                },
                EncoderGlitch {
                    at_s: 0.015,
                    counts: -2,
                    duration_s: 1.0,
                },
            ],
            ..Faults::default()
        };
        let s = FaultSchedule::new(&faults, 1.0e-3);
        let dropped: Vec<u64> = (0..40)
            .filter(|&k| FaultSchedule::hit(&s.dropped, k))
            .collect();
        assert_eq!(dropped, (10..22).chain([30]).collect::<Vec<_>>());
        let offsets: Vec<i64> = [9, 10, 14, 15, 19, 20, 500, 1015]
            .iter()
            .map(|&k| s.encoder_offset_counts(k))
            .collect();
        assert_eq!(offsets, [0, 5, 5, 3, 3, -2, -2, 0]);
    }

    #[test]
    fn random_faults_do_not_change_the_noise() {
        let run = |faults: Faults| {
            let cfg = PlantConfig {
                faults,
                ..config(Trajectory::Waypoints {
                    points: vec![(0.0, -1.0e-3)],
                })
            };
            let kv = KelvinVoigt::try_new(2000.0, 0.0).unwrap();
            let mut plant = Plant::new(
                cfg,
                vec![MaterialChange {
                    at_s: 0.0,
                    model: Box::new(kv),
                }],
            )
            .unwrap();
            (0..2000).map(|_| plant.step()).collect::<Vec<_>>()
        };
        let clean = run(Faults::default());
        let faulty = run(Faults {
            dropped_probability_per_sample: 0.01,
            nan_force_probability_per_sample: 0.01,
            seed: 9,
            ..Faults::default()
        });
        let dropped = faulty
            .iter()
            .filter(|s| s.fault == SampleFault::Dropped)
            .count();
        let nan = faulty
            .iter()
            .filter(|s| s.fault == SampleFault::NanForce)
            .count();
        assert!(
            (5..=40).contains(&dropped) && (5..=40).contains(&nan),
            "{dropped} {nan}"
        );
        assert!(clean
            .iter()
            .zip(&faulty)
            .all(|(a, b)| a.adc_code == b.adc_code));
    }

    #[test]
    fn fault_config_is_validated_and_optional_in_json() {
        let mut cfg = PlantConfig::default();
        cfg.faults.dropped_probability_per_sample = 1.5;
        let kv = KelvinVoigt::try_new(2000.0, 0.0).unwrap();
        let material = |m: KelvinVoigt| {
            vec![MaterialChange {
                at_s: 0.0,
                model: Box::new(m),
            }]
        };
        let err = Plant::new(cfg, material(kv)).err().unwrap();
        assert!(err
            .to_string()
            .contains("faults.dropped_probability_per_sample"));
        // A config written before faults existed still reads.
        let mut json = serde_json::to_value(PlantConfig::default()).unwrap();
        json.as_object_mut().unwrap().remove("faults");
        let back: PlantConfig = serde_json::from_value(json).unwrap();
        assert_eq!(back, PlantConfig::default());
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
