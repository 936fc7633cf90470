//! Raw sensor codes to SI: the load cell behind an ADC and the quadrature encoder behind a
//! 16-bit hardware counter. Shared by the firmware (which reads the codes from
//! peripherals) and the host plant (which synthesises them), so both convert identically.

use crate::error::{check, positive, ConfigError};

/// Calibration of a load cell read through an ADC:
/// F \[N\] = (code · V_ref / full_scale − offset_V) / sensitivity_V_per_N.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LoadCellCalibration {
    /// ADC reference voltage \[V\] (code full_scale ↔ V_ref).
    pub reference_v: f32,
    /// Largest ADC code (4095 for 12 bits).
    pub full_scale_code: u16,
    /// Amplifier output at zero force \[V\].
    pub offset_v: f32,
    /// Amplifier sensitivity \[V/N\].
    pub sensitivity_v_per_n: f32,
}

impl LoadCellCalibration {
    /// Validates the calibration.
    ///
    /// # Errors
    /// [`ConfigError`] naming `reference_v`, `full_scale_code`, `offset_v` or
    /// `sensitivity_v_per_n`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("reference_v", self.reference_v)?;
        if self.full_scale_code == 0 {
            return Err(ConfigError::OutOfRange {
                field: "full_scale_code",
                value: 0.0,
                expected: ">= 1",
            });
        }
        check("offset_v", self.offset_v, |_| true, "finite")?;
        check(
            "sensitivity_v_per_n",
            self.sensitivity_v_per_n,
            |v| v != 0.0,
            "!= 0",
        )?;
        Ok(())
    }

    /// Newtons per ADC code.
    #[inline]
    pub fn newtons_per_code(&self) -> f32 {
        self.reference_v / (self.full_scale_code as f32 * self.sensitivity_v_per_n)
    }

    /// Force \[N\] for an ADC `code`, and whether the code sits at either rail (the
    /// converter saturated: the true force may be beyond it).
    #[inline]
    pub fn force_n(&self, code: u16) -> (f32, bool) {
        let volts = code as f32 * self.reference_v / self.full_scale_code as f32;
        let saturated = code == 0 || code >= self.full_scale_code;
        (
            (volts - self.offset_v) / self.sensitivity_v_per_n,
            saturated,
        )
    }

    /// The ADC code a force \[N\] produces (rounded, clamped to the rails): the inverse of
    /// [`LoadCellCalibration::force_n`], used by simulations.
    pub fn code(&self, force_n: f32) -> u16 {
        let volts = self.offset_v + self.sensitivity_v_per_n * force_n;
        let code = libm::roundf(volts / self.reference_v * self.full_scale_code as f32);
        if code.is_nan() {
            return 0;
        }
        code.clamp(0.0, self.full_scale_code as f32) as u16
    }
}

/// Quadrature encoder behind a 16-bit up/down counter that wraps.
///
/// The counter is read once per sample; the signed 16-bit difference from the previous
/// read is accumulated, which is exact as long as the probe moves less than 32767 counts
/// per sample (32 m/s at 1e6 counts/m and 1 kHz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EncoderUnwrapper {
    metres_per_count: f32,
    last_raw: u16,
    count: i32,
    started: bool,
}

impl EncoderUnwrapper {
    /// New unwrapper for an encoder of `counts_per_m` counts per metre (after quadrature).
    /// The first read defines position `initial_position_m`.
    ///
    /// # Errors
    /// [`ConfigError`] naming `counts_per_m` or `initial_position_m`.
    pub fn try_new(counts_per_m: f32, initial_position_m: f32) -> Result<Self, ConfigError> {
        positive("counts_per_m", counts_per_m)?;
        check("initial_position_m", initial_position_m, |_| true, "finite")?;
        Ok(EncoderUnwrapper {
            metres_per_count: 1.0 / counts_per_m,
            last_raw: 0,
            count: libm::roundf(initial_position_m * counts_per_m) as i32,
            started: false,
        })
    }

    /// Feeds one raw counter value; returns the unwrapped position \[m\].
    #[inline]
    pub fn position_m(&mut self, raw: u16) -> f32 {
        if self.started {
            let delta = raw.wrapping_sub(self.last_raw) as i16;
            self.count = self.count.wrapping_add(delta as i32);
        }
        self.started = true;
        self.last_raw = raw;
        self.count as f32 * self.metres_per_count
    }

    /// Unwrapped count.
    pub fn count(&self) -> i32 {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell() -> LoadCellCalibration {
        LoadCellCalibration {
            reference_v: 3.3,
            full_scale_code: 4095,
            offset_v: 1.65,
            sensitivity_v_per_n: 0.05,
        }
    }

    #[test]
    fn load_cell_round_trip_and_saturation() {
        let c = cell();
        c.validate().unwrap();
        for f in [-10.0f32, 0.0, 3.21, 15.0] {
            let (back, sat) = c.force_n(c.code(f));
            assert!(
                (back - f).abs() <= 0.5 * c.newtons_per_code() + 1e-5,
                "{f} {back}"
            );
            assert!(!sat);
        }
        assert_eq!(c.code(1000.0), 4095);
        assert!(c.force_n(4095).1);
        assert!(c.force_n(0).1);
    }

    #[test]
    fn encoder_unwraps_the_16_bit_counter() {
        let mut e = EncoderUnwrapper::try_new(1.0e6, 0.0).unwrap();
        let mut raw: u16 = 65_000;
        assert_eq!(e.position_m(raw), 0.0);
        // 2000 steps of +100 counts cross the wrap several times.
        for _ in 0..2000 {
            raw = raw.wrapping_add(100);
            e.position_m(raw);
        }
        assert_eq!(e.count(), 200_000);
        for _ in 0..2000 {
            raw = raw.wrapping_sub(100);
            e.position_m(raw);
        }
        assert_eq!(e.count(), 0);
    }
}
