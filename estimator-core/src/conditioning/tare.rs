//! The load cell's force offset (tare) and noise level, estimated online without assuming
//! that the probe starts in free space.
//!
//! The paper tares before the impact (Sec. 5): its rig always starts in free space. A board
//! that boots while pressing, or a log that starts mid-interaction, would tare a contact
//! force and then see no contact at all. Here the offset is only *confirmed* by evidence
//! that the probe is free:
//!
//! - a **free-space stretch**: the probe travels at least
//!   [`TareConfig::free_space_travel_m`] while the force stays flat (within
//!   [`TareConfig::flat_band_sigmas`] noise deviations of the stretch's mean, and with no
//!   significant slope against the position) — in contact the force changes with the
//!   position, in free space it does not. Once a contact point is known, a stretch counts
//!   only behind it (the first 100 µm of a soft gel rise within a noise band, and a creep
//!   clamp moves the probe under a constant load: both lie beyond the contact point), so
//!   each lift-off re-tares. Inside contact it also has to be at the lowest force since the
//!   contact began (a lift-off the detector missed because the offset in use is wrong).
//!   Before any contact, once the offset is confirmed, a stretch may lower it but raise it
//!   only by an insignificant amount (free space is the floor: an approach that creeps up
//!   is touching the material);
//! - an operator's command ([`ForceTare::command`]).
//!
//! Until then the offset is the prior ([`OffsetPrior`]) and [`crate::Status::OFFSET_UNCERTAIN`]
//! is raised on every sample.

use crate::error::{check, ConfigError};
use crate::fmath::{max, max_finite, min, min_finite};

/// What is known of the force offset before the first sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OffsetPrior {
    /// Nothing: the mean force of the first [`TareConfig::startup_samples`] is used
    /// provisionally (as the paper's rig, which starts in free space) and flagged uncertain
    /// until a free-space stretch confirms or corrects it.
    #[default]
    Unknown,
    /// A stored calibration zero \[N\] (the firmware's two-point calibration). The mean of
    /// the first samples replaces it only if it lies within the release threshold of it (a
    /// probe at rest in free space, small drift); otherwise the probe may be pressing and
    /// the prior is kept: a contact force is never tared. Flagged uncertain until
    /// confirmed.
    Calibrated {
        /// The calibration's zero \[N\].
        offset_n: f32,
    },
    /// Known (e.g. a host's estimate from the whole record): used as is, never
    /// re-estimated, never flagged.
    Known {
        /// The offset \[N\].
        offset_n: f32,
    },
}

/// Configuration of [`ForceTare`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TareConfig {
    /// What is known of the offset at start.
    pub prior: OffsetPrior,
    /// Samples averaged for the provisional offset and the initial noise level.
    pub startup_samples: u32,
    /// Outside contact the offset follows slow drift with this time constant, in samples
    /// (0 = no drift tracking).
    pub tracking_samples: u32,
    /// Drift is only learned while the probe moves slower than this \[m/s\]: an
    /// approaching probe whose force creeps up is touching a soft material, not drifting
    /// (a 10 mm/min compression of a soft silicone was otherwise taken for drift).
    pub tracking_max_speed_m_per_s: f32,
    /// Probe travel \[m\] with a flat force that proves free space (well above the
    /// position sensor's resolution: 30 encoder counts of 1 µm by default).
    pub free_space_travel_m: f32,
    /// Fewest samples of a free-space stretch.
    pub min_stretch_samples: u32,
    /// Half-width of "flat", in force-noise standard deviations (at least the release
    /// threshold).
    pub flat_band_sigmas: f32,
}

impl Default for TareConfig {
    fn default() -> Self {
        TareConfig {
            prior: OffsetPrior::Unknown,
            startup_samples: 200,
            tracking_samples: 2000,
            tracking_max_speed_m_per_s: 0.2e-3,
            free_space_travel_m: 30.0e-6,
            min_stretch_samples: 20,
            flat_band_sigmas: 4.0,
        }
    }
}

impl TareConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming `startup_samples`, `tracking_max_speed_m_per_s`,
    /// `free_space_travel_m`, `min_stretch_samples`, `flat_band_sigmas` or the prior's
    /// `offset_n`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.startup_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "startup_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        if self.min_stretch_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "min_stretch_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        check(
            "tracking_max_speed_m_per_s",
            self.tracking_max_speed_m_per_s,
            |v| v >= 0.0,
            ">= 0",
        )?;
        check(
            "free_space_travel_m",
            self.free_space_travel_m,
            |v| v > 0.0,
            "> 0",
        )?;
        check(
            "flat_band_sigmas",
            self.flat_band_sigmas,
            |v| v > 0.0,
            "> 0",
        )?;
        match self.prior {
            OffsetPrior::Unknown => Ok(()),
            OffsetPrior::Calibrated { offset_n } | OffsetPrior::Known { offset_n } => {
                check("offset_n", offset_n, |_| true, "finite").map(|_| ())
            }
        }
    }
}

/// What one [`ForceTare::update`] did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TareUpdate {
    /// A free-space stretch set the offset at this sample.
    pub confirmed: bool,
    /// Change of the offset it made \[N\] (0 when not confirmed).
    pub correction_n: f32,
}

/// A run of samples whose force stays within a band of its mean, with the sums of a
/// straight-line fit of force on position (relative to its first sample, for f32).
#[derive(Debug, Clone, Copy, PartialEq)]
struct FlatStretch {
    count: u32,
    origin: (f32, f32),
    sum_x: f32,
    sum_f: f32,
    sum_xx: f32,
    sum_xf: f32,
    min_position_m: f32,
    max_position_m: f32,
}

/// Longest stretch kept (a probe resting for minutes would otherwise grow f32 sums past
/// their precision); a longer one starts again.
const MAX_STRETCH_SAMPLES: u32 = 100_000;

impl FlatStretch {
    const EMPTY: FlatStretch = FlatStretch {
        count: 0,
        origin: (0.0, 0.0),
        sum_x: 0.0,
        sum_f: 0.0,
        sum_xx: 0.0,
        sum_xf: 0.0,
        min_position_m: f32::INFINITY,
        max_position_m: f32::NEG_INFINITY,
    };

    fn mean_n(&self) -> f32 {
        self.origin.1 + self.sum_f / self.count.max(1) as f32
    }

    fn push(&mut self, position_m: f32, force_n: f32) {
        if self.count == 0 || self.count >= MAX_STRETCH_SAMPLES {
            *self = FlatStretch::EMPTY;
            self.origin = (position_m, force_n);
        }
        let (x, f) = (position_m - self.origin.0, force_n - self.origin.1);
        self.count += 1;
        self.sum_x += x;
        self.sum_f += f;
        self.sum_xx += x * x;
        self.sum_xf += x * f;
        // Positions are finite (see `Tare::update`): no NaN tests.
        self.min_position_m = min_finite(self.min_position_m, position_m);
        self.max_position_m = max_finite(self.max_position_m, position_m);
    }

    fn travel_m(&self) -> f32 {
        self.max_position_m - self.min_position_m
    }

    /// `true` when the force does not follow the position: the least-squares slope of
    /// force on position is within 3 standard errors of zero for a force noise `noise_n`
    /// \[N\] (in contact the force rises with the position, however slowly: the first
    /// 100 µm of a soft gel stay within a noise band but not within a zero slope).
    fn is_level(&self, noise_n: f32) -> bool {
        let n = self.count as f32;
        let sxx = self.sum_xx - self.sum_x * self.sum_x / n;
        let sxf = self.sum_xf - self.sum_x * self.sum_f / n;
        // NaN or no spread of positions: nothing says the stretch is level.
        if sxx.is_nan() || sxx <= 0.0 {
            return false;
        }
        let slope = sxf / sxx;
        let standard_error = noise_n / libm::sqrtf(sxx);
        slope.abs() <= 3.0 * standard_error
    }
}

/// Online force offset and noise level (see the module docs).
///
/// The noise level is the robust one of second differences, σ² = E\[(Δ²F)²\]/6: slow signal
/// (a ramp, a pressing motion) cancels in Δ², so it is right in contact as well as in free
/// space. It is the plain mean over the start-up samples, then an exponential average with
/// the start-up length as time constant, each sample clipped at 25σ² so that an impact does
/// not inflate it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceTare {
    config: TareConfig,
    offset_n: f32,
    startup_sum_n: f32,
    variance_n2: f32,
    /// √variance_n2, kept with it (the pipeline asks for it more than once a sample) and
    /// tracked by a Newton step a sample after the start-up (see `update_noise`).
    noise_n: f32,
    samples: u32,
    previous_n: [f32; 2],
    confirmed: bool,
    stretch: FlatStretch,
    lowest_in_contact_n: f32,
}

impl ForceTare {
    /// Builds the tare.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: TareConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let (offset_n, confirmed) = match config.prior {
            OffsetPrior::Unknown => (0.0, false),
            OffsetPrior::Calibrated { offset_n } => (offset_n, false),
            OffsetPrior::Known { offset_n } => (offset_n, true),
        };
        Ok(ForceTare {
            config,
            offset_n,
            startup_sum_n: 0.0,
            variance_n2: 0.0,
            noise_n: 0.0,
            samples: 0,
            previous_n: [0.0; 2],
            confirmed,
            stretch: FlatStretch::EMPTY,
            lowest_in_contact_n: f32::INFINITY,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &TareConfig {
        &self.config
    }

    /// Force offset \[N\] being removed.
    pub fn offset_n(&self) -> f32 {
        self.offset_n
    }

    /// Standard deviation of the force noise \[N\].
    pub fn noise_n(&self) -> f32 {
        self.noise_n
    }

    /// `true` once the offset is backed by a free-space stretch, a command or a known
    /// prior; `false` while it is the provisional value ([`crate::Status::OFFSET_UNCERTAIN`]).
    pub fn is_confirmed(&self) -> bool {
        self.confirmed
    }

    /// `true` while the start-up samples are still being averaged.
    pub fn in_startup(&self) -> bool {
        self.samples < self.config.startup_samples
    }

    /// Samples seen so far (saturating).
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// Called by the pipeline at each contact onset: the lowest force of the new contact
    /// starts afresh.
    pub fn contact_started(&mut self) {
        self.lowest_in_contact_n = f32::INFINITY;
    }

    /// Operator command "tare now": `force_n` \[N\] is the offset from now on, confirmed.
    pub fn command(&mut self, force_n: f32) {
        if force_n.is_finite() {
            self.offset_n = force_n;
            self.confirmed = true;
            self.samples = self.samples.max(self.config.startup_samples);
            self.stretch = FlatStretch::EMPTY;
        }
    }

    fn update_noise(&mut self, force_n: f32) {
        if self.samples >= 2 {
            let d2 = force_n - 2.0 * self.previous_n[1] + self.previous_n[0];
            let s = d2 * d2 / 6.0;
            if self.samples < self.config.startup_samples {
                let n = (self.samples - 1) as f32;
                self.variance_n2 += (s - self.variance_n2) / n;
            } else {
                let s = min(s, 25.0 * self.variance_n2);
                self.variance_n2 += (s - self.variance_n2) / self.config.startup_samples as f32;
            }
            // √variance by one Newton step from the last sample's root once the average
            // is exponential: it then moves by at most 12 % a sample (an impact clipped
            // at 25σ²), where one step is within 0.2 % of the root (ε²/8) and the next
            // one within f32 rounding; `sqrtf` is software on the Cortex-M4F (≈ 76
            // instructions, 5 for the step). During the start-up mean, and whenever
            // the step is not a positive finite number, the root itself.
            let step = 0.5 * (self.noise_n + self.variance_n2 / self.noise_n);
            // (Finite when step·0 is 0: a plain `< INFINITY` becomes integer bit tests on
            // the Cortex-M4F.)
            self.noise_n =
                if self.samples >= self.config.startup_samples && step > 0.0 && step * 0.0 == 0.0 {
                    step
                } else {
                    libm::sqrtf(max(self.variance_n2, 0.0))
                };
        }
        self.previous_n = [self.previous_n[1], force_n];
    }

    /// Processes one sample: raw `position_m` \[m\] and `force_n` \[N\] (finite), the
    /// probe's filtered speed \[m/s\], whether the impact detector has the probe in contact,
    /// the contact point of the current or last contact \[m\] (NaN before the first), and
    /// `release_threshold_n` \[N\], the smallest half-width of "flat".
    pub fn update(
        &mut self,
        position_m: f32,
        force_n: f32,
        speed_m_per_s: f32,
        in_contact: bool,
        contact_position_m: f32,
        release_threshold_n: f32,
    ) -> TareUpdate {
        if let OffsetPrior::Known { .. } = self.config.prior {
            self.update_noise(force_n);
            self.samples = self.samples.saturating_add(1);
            return TareUpdate::default();
        }
        self.update_noise(force_n);
        self.samples = self.samples.saturating_add(1);
        if self.samples <= self.config.startup_samples && !self.confirmed {
            self.startup_sum_n += force_n;
            let mean = self.startup_sum_n / self.samples as f32;
            match self.config.prior {
                OffsetPrior::Unknown => self.offset_n = mean,
                OffsetPrior::Calibrated { offset_n } => {
                    if self.samples == self.config.startup_samples
                        && (mean - offset_n).abs() <= release_threshold_n
                    {
                        self.offset_n = mean;
                    }
                }
                OffsetPrior::Known { .. } => {}
            }
        }
        if in_contact {
            self.lowest_in_contact_n = min_finite(self.lowest_in_contact_n, force_n);
        }
        let band = max(
            self.config.flat_band_sigmas * self.noise_n(),
            release_threshold_n,
        );
        if self.stretch.count > 0 && (force_n - self.stretch.mean_n()).abs() > band {
            self.stretch = FlatStretch::EMPTY;
        }
        self.stretch.push(position_m, force_n);
        let mut update = TareUpdate::default();
        if self.stretch.count >= self.config.min_stretch_samples
            && self.stretch.travel_m() >= self.config.free_space_travel_m
            && self.stretch.is_level(self.noise_n())
        {
            let level = self.stretch.mean_n();
            let behind_contact = if contact_position_m.is_finite() {
                self.stretch.max_position_m < contact_position_m - self.config.free_space_travel_m
            } else {
                // No contact yet: the floor may fall, and rise only within its own noise.
                let floor = self.noise_n() * 3.0 / libm::sqrtf(self.stretch.count as f32);
                !self.confirmed || level <= self.offset_n + floor
            };
            let at_lowest = !in_contact || level <= self.lowest_in_contact_n + band;
            if behind_contact && at_lowest {
                update = TareUpdate {
                    confirmed: true,
                    correction_n: level - self.offset_n,
                };
                self.offset_n = level;
                self.confirmed = true;
            }
            self.stretch = FlatStretch::EMPTY;
        } else if !in_contact
            && !self.in_startup()
            && self.config.tracking_samples > 0
            && speed_m_per_s.abs() <= self.config.tracking_max_speed_m_per_s
        {
            let tared = force_n - self.offset_n;
            if tared.abs() <= release_threshold_n {
                self.offset_n += tared / self.config.tracking_samples as f32;
            }
        }
        update
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tare(prior: OffsetPrior) -> ForceTare {
        ForceTare::try_new(TareConfig {
            prior,
            ..TareConfig::default()
        })
        .unwrap()
    }

    /// ±`amplitude` alternating noise (σ = amplitude).
    fn wiggle(i: u32, amplitude: f32) -> f32 {
        if i.is_multiple_of(2) {
            amplitude
        } else {
            -amplitude
        }
    }

    #[test]
    fn the_tracked_noise_level_stays_the_root_of_the_variance() {
        // Pseudo-random noise whose level steps ×10 up and down, with an impact (a 50σ
        // jump, clipped at 25σ²) every 700 samples: the Newton step stays within 0.2 % of
        // √variance, and within f32 rounding once the variance settles.
        let mut t = tare(OffsetPrior::Unknown);
        let mut state = 12345u32;
        let (mut worst, mut last) = (0.0f32, 0.0f32);
        for i in 0..6000u32 {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let uniform = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            let level = if (2000..4000).contains(&i) { 0.1 } else { 0.01 };
            let jump = if i % 700 == 699 { 50.0 * level } else { 0.0 };
            t.update(0.0, level * uniform + jump, 0.0, false, f32::NAN, 0.03);
            if !t.in_startup() {
                let exact = libm::sqrtf(t.variance_n2);
                let error = (t.noise_n() - exact).abs() / exact;
                worst = worst.max(error);
                last = error;
            }
        }
        assert!(worst < 2e-3, "worst relative error {worst}");
        assert!(last < 1e-6, "settled relative error {last}");
    }

    #[test]
    fn free_space_approach_confirms_the_startup_mean() {
        let mut t = tare(OffsetPrior::Unknown);
        // 300 samples at rest at +0.8 N, then a 10 mm/s approach with the force flat.
        for i in 0..300 {
            t.update(0.0, 0.8 + wiggle(i, 0.01), 0.0, false, f32::NAN, 0.03);
        }
        assert!(!t.is_confirmed(), "at rest nothing proves free space");
        assert!((t.offset_n() - 0.8).abs() < 1e-3);
        assert!((t.noise_n() - 0.0163).abs() < 0.003, "{}", t.noise_n());
        let mut confirmed_at = None;
        for i in 0..100 {
            let u = t.update(
                1.0e-5 * i as f32,
                0.8 + wiggle(i, 0.01),
                1e-2,
                false,
                f32::NAN,
                0.03,
            );
            if u.confirmed && confirmed_at.is_none() {
                confirmed_at = Some(i);
                assert!(u.correction_n.abs() < 0.01);
            }
        }
        assert!(t.is_confirmed());
        // The stretch began at rest (flat force, no travel); 30 µm of travel at 10 µm per
        // sample complete it on the fourth approach sample.
        assert_eq!(confirmed_at, Some(3));
    }

    #[test]
    fn a_start_in_contact_is_not_tared_and_the_lift_off_sets_the_offset() {
        let mut t = tare(OffsetPrior::Calibrated { offset_n: 0.0 });
        // Pressing at 12 N (true offset +2 N) and moving: the force follows the position.
        for i in 0..400 {
            let x = 2.0e-3 + 0.5e-3 * libm::sinf(i as f32 * 0.01);
            t.update(
                x,
                2.0 + 5000.0 * x + wiggle(i, 0.01),
                0.0,
                true,
                1.5e-3,
                0.03,
            );
        }
        assert_eq!(t.offset_n(), 0.0, "the calibration zero is kept");
        assert!(!t.is_confirmed());
        // Lift-off: the probe backs out 0.2 mm with the force flat at the true offset.
        let mut confirmed = false;
        for i in 0..200 {
            let u = t.update(
                -1.0e-6 * i as f32,
                2.0 + wiggle(i, 0.01),
                -1e-3,
                true,
                1.5e-3,
                0.03,
            );
            confirmed |= u.confirmed;
        }
        assert!(confirmed && t.is_confirmed());
        assert!((t.offset_n() - 2.0).abs() < 0.01, "{}", t.offset_n());
    }

    #[test]
    fn a_creep_clamp_is_not_taken_for_free_space() {
        let mut t = tare(OffsetPrior::Known { offset_n: 0.0 });
        let mut t2 = tare(OffsetPrior::Unknown);
        for i in 0..300 {
            t2.update(0.0, wiggle(i, 0.01), 0.0, false, f32::NAN, 0.03);
        }
        t2.contact_started();
        // Loading to 10 N, then the probe creeps 0.1 mm in under a constant 10 N.
        for i in 0..100 {
            t2.update(1e-6 * i as f32, 0.1 * i as f32, 1e-3, true, 0.0, 0.03);
        }
        let offset = t2.offset_n();
        for i in 0..500 {
            let u = t2.update(
                1e-4 + 2e-7 * i as f32,
                10.0 + wiggle(i, 0.01),
                2e-4,
                true,
                0.0,
                0.03,
            );
            assert!(!u.confirmed);
        }
        assert_eq!(t2.offset_n(), offset);
        // A known offset never moves.
        for i in 0..500 {
            t.update(1e-6 * i as f32, 3.0, 1e-3, false, f32::NAN, 0.03);
        }
        assert_eq!(t.offset_n(), 0.0);
    }

    #[test]
    fn a_command_sets_and_confirms_the_offset() {
        let mut t = tare(OffsetPrior::Unknown);
        t.update(0.0, 5.0, 0.0, true, f32::NAN, 0.03);
        t.command(1.5);
        assert!(t.is_confirmed());
        assert_eq!(t.offset_n(), 1.5);
        t.command(f32::NAN);
        assert_eq!(t.offset_n(), 1.5);
    }
}
