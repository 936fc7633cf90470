//! Online residual monitor: raises [`Status::MODEL_MISMATCH`] when the running
//! estimator's innovation stays outside its expected band for longer than a set time.
//!
//! A model that captures the material leaves an innovation (a-priori force error
//! F − F̂) close to the sensor noise. A missing effect (relaxation, a wrong exponent,
//! an offset) leaves a structured residual that the forgetting factor cannot absorb. The
//! monitor keeps an exponential average of the squared innovation over `window_samples`
//! and compares its root with `band_factor` × the free-space force noise σ (measured by
//! the tare, never below `min_noise_n`). The flag rises after `hold_samples` consecutive
//! samples outside the band and falls as soon as the average is back inside.

use crate::error::{check, positive, ConfigError};
use crate::fmath::max;
use crate::Status;

/// Configuration of [`ResidualMonitor`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ResidualMonitorConfig {
    /// Length of the exponential average of the squared innovation \[samples\].
    pub window_samples: u32,
    /// Band half-width in noise standard deviations (RMS innovation ≤ factor·σ is normal).
    pub band_factor: f32,
    /// Floor on the noise level used for the band \[N\] (a noiseless simulation would
    /// otherwise flag every rounding error).
    pub min_noise_n: f32,
    /// Consecutive samples outside the band before the flag rises.
    pub hold_samples: u32,
}

impl Default for ResidualMonitorConfig {
    /// 200-sample average, 3σ band, 0.5 s hold at 1 kHz, σ ≥ 10 mN.
    fn default() -> Self {
        ResidualMonitorConfig {
            window_samples: 200,
            band_factor: 3.0,
            min_noise_n: 0.01,
            hold_samples: 500,
        }
    }
}

impl ResidualMonitorConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming `window_samples`, `band_factor`, `min_noise_n` or
    /// `hold_samples`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.window_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "window_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        check("band_factor", self.band_factor, |v| v >= 1.0, ">= 1")?;
        positive("min_noise_n", self.min_noise_n)?;
        if self.hold_samples == 0 {
            return Err(ConfigError::OutOfRange {
                field: "hold_samples",
                value: 0.0,
                expected: ">= 1",
            });
        }
        Ok(())
    }
}

/// Innovation-band monitor, see the module docs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResidualMonitor {
    config: ResidualMonitorConfig,
    rate: f32,
    mean_square_n2: f32,
    samples: u32,
    outside: u32,
}

impl ResidualMonitor {
    /// Builds the monitor.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: ResidualMonitorConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(ResidualMonitor {
            rate: 1.0 / config.window_samples as f32,
            config,
            mean_square_n2: 0.0,
            samples: 0,
            outside: 0,
        })
    }

    /// RMS innovation \[N\] over the averaging window.
    pub fn rms_innovation_n(&self) -> f32 {
        libm::sqrtf(self.mean_square_n2)
    }

    /// Feeds one innovation `innovation_n` = F − F̂ \[N\] with the current noise estimate
    /// `noise_n` \[N\]; returns [`Status::MODEL_MISMATCH`] or empty. Non-finite
    /// innovations are ignored.
    pub fn update(&mut self, innovation_n: f32, noise_n: f32) -> Status {
        if !innovation_n.is_finite() {
            return Status::empty();
        }
        self.mean_square_n2 += self.rate * (innovation_n * innovation_n - self.mean_square_n2);
        self.samples = self.samples.saturating_add(1);
        let sigma = if noise_n.is_finite() {
            max(noise_n, self.config.min_noise_n)
        } else {
            self.config.min_noise_n
        };
        let band = self.config.band_factor * sigma;
        // Only judge once the window is full.
        if self.samples >= self.config.window_samples && self.mean_square_n2 > band * band {
            self.outside = self.outside.saturating_add(1);
        } else {
            self.outside = 0;
        }
        if self.outside >= self.config.hold_samples {
            Status::MODEL_MISMATCH
        } else {
            Status::empty()
        }
    }

    /// Clears the average and the counter (new contact).
    pub fn reset(&mut self) {
        self.mean_square_n2 = 0.0;
        self.samples = 0;
        self.outside = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_is_not_a_mismatch_but_a_bias_is() {
        let mut m = ResidualMonitor::try_new(ResidualMonitorConfig::default()).unwrap();
        let mut state = 12345u32;
        let mut flagged = false;
        for _ in 0..10_000 {
            state = state.wrapping_mul(1664525).wrapping_add(1013904223);
            let u = (state >> 8) as f32 / (1u32 << 24) as f32 - 0.5;
            // Uniform noise with σ = 0.05 N.
            flagged |= !m.update(u * 0.05 * 3.464, 0.05).is_empty();
        }
        assert!(!flagged);
        let mut first = None;
        for h in 0..2000 {
            if !m.update(0.3, 0.05).is_empty() && first.is_none() {
                first = Some(h);
            }
        }
        // Needs the average to cross the band, then 500 samples of hold.
        let h = first.expect("bias must be flagged");
        assert!((500..900).contains(&h), "{h}");
    }
}
