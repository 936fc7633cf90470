//! Refinement of a detected contact point for materials whose force rises from zero as a
//! power law, F ∝ (x − x_c)ⁿ (Hunt-Crossley, eq. 3; the Hammerstein elastic law, eq. 39).
//!
//! A force threshold finds such a contact too deep by (threshold/k)^(1/n) — 50-90 µm on a
//! soft gel with 20 mN of noise — which biases the exponent estimate by several percent.
//! The refiner records two points of the filtered force rise: (x1, F1), the last sample at
//! or below half the onset threshold, and (x2, F2), the first at or above twice it. Along
//! the power law the contact point is x_c = x1 − (x2 − x1)/(r − 1), r = (F2/F1)^(1/n).
//! On a damped material the caller hands in the elastic part of the force,
//! F/(1 + (λ/k)·δ̇) for a Hunt-Crossley onset F = δⁿ·(k + λ·δ̇): the impact speed changes
//! during the onset and the raw force is not a pure power law.
//!
//! The refiner does not need the model: the exponent is an argument of
//! [`OnsetPair::contact_point`], evaluated whenever the caller's exponent changes.

use crate::error::ConfigError;
use crate::fmath::{self, max, min};

/// Configuration of [`OnsetRefiner`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RefinementConfig {
    /// Samples after which an unfinished refinement (the force never reached twice the
    /// onset threshold) gives up and keeps the threshold's point.
    pub timeout_samples: u32,
}

impl Default for RefinementConfig {
    fn default() -> Self {
        RefinementConfig {
            timeout_samples: 500,
        }
    }
}

impl RefinementConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming `timeout_samples` if 0.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.timeout_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "timeout_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        Ok(())
    }
}

/// Lower and upper force levels of the refinement, in onset thresholds.
const REFINE_LOW: f32 = 0.5;
const REFINE_HIGH: f32 = 2.0;

/// One point of a force rise: filtered position \[m\] and the elastic part of the tared,
/// filtered force \[N\].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RisePoint {
    /// Position \[m\].
    pub position_m: f32,
    /// Elastic force \[N\].
    pub force_n: f32,
}

/// The two points of a contact's force rise (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnsetPair {
    /// Last point at or below half the onset threshold.
    pub low: RisePoint,
    /// First point at or above twice the onset threshold.
    pub high: RisePoint,
    /// ln(F2/F1), once per pair: the contact point is extrapolated again each time the
    /// exponent moves, with one `expf` and no `logf`.
    ln_force_ratio: f32,
}

impl OnsetPair {
    /// The pair through `low` and `high` (forces > 0 for an extrapolation).
    pub fn new(low: RisePoint, high: RisePoint) -> Self {
        OnsetPair {
            low,
            high,
            ln_force_ratio: libm::logf(high.force_n / low.force_n),
        }
    }

    /// Contact point \[m\] along F ∝ (x − x_c)ⁿ through the pair, or `provisional_m` (the
    /// threshold's point) if the extrapolation is not
    /// plausible: deeper than the provisional point, further back than five times the
    /// pair's spacing, or non-finite. Never behind `free_space_min_m`, the shallowest
    /// free-space position before this contact (a test that starts touching its sample
    /// cannot have its contact before its first sample).
    ///
    /// `exponent` n ∈ (0.2, 10) (else `provisional_m`).
    pub fn contact_point(&self, exponent: f32, provisional_m: f32, free_space_min_m: f32) -> f32 {
        if !(exponent.is_finite() && exponent > 0.2 && exponent < 10.0) {
            return provisional_m;
        }
        let x1 = self.low.position_m;
        let x2 = self.high.position_m;
        // (F2/F1)^(1/n) as one expf of the pair's ln(F2/F1): a sixth of powf on the
        // Cortex-M4F.
        let r = fmath::exp(self.ln_force_ratio / exponent);
        let candidate = x1 - (x2 - x1) / (r - 1.0);
        if candidate.is_finite() && candidate < provisional_m && candidate > x1 - 5.0 * (x2 - x1) {
            max(candidate, min(free_space_min_m, provisional_m))
        } else {
            provisional_m
        }
    }
}

/// Records the force rise of each new contact (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OnsetRefiner {
    config: RefinementConfig,
    min_span_samples: u32,
    low: Option<RisePoint>,
    low_sample: u32,
    samples: u32,
    active: bool,
}

impl OnsetRefiner {
    /// Builds the refiner. `min_span_samples`: fewest samples between the two points. A
    /// filtered force rise is convex-distorted by ≈ ½·n(n−1)·(v·s/δ)² (s the filter's time
    /// spread): the points are only trusted when they span several spreads, as on soft
    /// materials. On stiff ones the force rises within a spread and the threshold's point
    /// is already within a few µm. The pipeline uses 3 spreads of its state-variable filter.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: RefinementConfig, min_span_samples: u32) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(OnsetRefiner {
            config,
            min_span_samples,
            low: None,
            low_sample: 0,
            samples: 0,
            active: false,
        })
    }

    /// Starts recording a new contact's rise (at its onset).
    pub fn begin(&mut self) {
        self.active = true;
    }

    /// Stops recording (contact lost, or the refinement is not wanted).
    pub fn cancel(&mut self) {
        self.active = false;
    }

    /// `true` between [`OnsetRefiner::begin`] and the completion or timeout of the pair:
    /// depths are provisional meanwhile.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// One sample of the filtered rise; `onset_threshold_n` \[N\] is the detector's. Returns
    /// the pair when it completes (at most once per [`OnsetRefiner::begin`]); `None` while
    /// recording, after a timeout, or when the pair is implausible (F2 < 1.5·F1, no
    /// progress, too short a span).
    pub fn update(&mut self, point: RisePoint, onset_threshold_n: f32) -> Option<OnsetPair> {
        self.samples = self.samples.wrapping_add(1);
        if point.force_n <= REFINE_LOW * onset_threshold_n {
            self.low = Some(point);
            self.low_sample = self.samples;
            return None;
        }
        if !self.active {
            return None;
        }
        let elapsed = self.samples.wrapping_sub(self.low_sample);
        let timed_out = elapsed >= self.config.timeout_samples;
        if point.force_n < REFINE_HIGH * onset_threshold_n && !timed_out {
            return None;
        }
        self.active = false;
        let low = self.low?;
        (low.force_n > 0.0
            && point.force_n >= 1.5 * low.force_n
            && point.position_m > low.position_m
            && elapsed >= self.min_span_samples
            && !timed_out)
            .then(|| OnsetPair::new(low, point))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_power_law_rise_is_extrapolated_to_its_contact_point() {
        // F = 2e5·(x − 1 mm)^1.5 approached at 1 mm/s (1 µm per sample), threshold 0.1 N
        // (crossed 63 µm deep): the pair spans 40 → 100 µm, 60 samples.
        let mut refiner = OnsetRefiner::try_new(RefinementConfig::default(), 10).unwrap();
        let mut pair = None;
        for h in 0..400 {
            let x = 0.9e-3 + 1.0e-6 * h as f32;
            let f = 2.0e5 * libm::powf((x - 1.0e-3).max(0.0), 1.5);
            if h == 164 {
                refiner.begin();
            }
            let point = RisePoint {
                position_m: x,
                force_n: f,
            };
            if let Some(p) = refiner.update(point, 0.1) {
                pair = Some(p);
            }
        }
        let pair = pair.expect("completed");
        let x_c = pair.contact_point(1.5, 1.2e-3, 0.0);
        assert!((x_c - 1.0e-3).abs() < 1e-6, "{x_c}");
        // A wrong exponent moves it; an implausible one leaves the provisional point.
        assert!((pair.contact_point(1.0, 1.2e-3, 0.0) - 1.0e-3).abs() > 5e-6);
        assert_eq!(pair.contact_point(f32::NAN, 1.2e-3, 0.0), 1.2e-3);
        // Never behind the shallowest free-space position.
        assert_eq!(pair.contact_point(1.5, 1.2e-3, 1.01e-3), 1.01e-3);
    }
}
