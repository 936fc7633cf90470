//! Configuration errors.
//!
//! Configs are validated once, when an estimator or filter is built (`try_new`); the 1 kHz
//! `step` never returns an error (it reports through [`crate::Status`] instead).

use core::fmt;

/// A configuration value was rejected. Each variant names the field (as spelled in the
/// config struct) so that a user can find it.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// The field is NaN or ±∞.
    NonFinite {
        /// Name of the offending field.
        field: &'static str,
    },
    /// The field is finite but outside its valid range.
    OutOfRange {
        /// Name of the offending field.
        field: &'static str,
        /// The rejected value.
        value: f32,
        /// The valid range, in words (e.g. `"(0, 1]"`).
        expected: &'static str,
    },
    /// Two or more fields are individually valid but inconsistent with each other.
    Inconsistent {
        /// Name of the field reported as the cause.
        field: &'static str,
        /// Why the combination is invalid.
        reason: &'static str,
    },
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ConfigError::NonFinite { field } => write!(f, "config field `{field}` is not finite"),
            ConfigError::OutOfRange {
                field,
                value,
                expected,
            } => write!(
                f,
                "config field `{field}` = {value} is out of range (expected {expected})"
            ),
            ConfigError::Inconsistent { field, reason } => {
                write!(f, "config field `{field}` is inconsistent: {reason}")
            }
        }
    }
}

impl core::error::Error for ConfigError {}

/// Checks that `value` is finite and satisfies `ok`; otherwise names `field`.
pub(crate) fn check(
    field: &'static str,
    value: f32,
    ok: impl FnOnce(f32) -> bool,
    expected: &'static str,
) -> Result<f32, ConfigError> {
    if !value.is_finite() {
        return Err(ConfigError::NonFinite { field });
    }
    if ok(value) {
        Ok(value)
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value,
            expected,
        })
    }
}

/// `value > 0`, finite.
pub(crate) fn positive(field: &'static str, value: f32) -> Result<f32, ConfigError> {
    check(field, value, |v| v > 0.0, "> 0")
}

/// `value >= 0`, finite.
pub(crate) fn non_negative(field: &'static str, value: f32) -> Result<f32, ConfigError> {
    check(field, value, |v| v >= 0.0, ">= 0")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_field() {
        let e = positive("sample_time_s", -1.0).unwrap_err();
        assert_eq!(
            e,
            ConfigError::OutOfRange {
                field: "sample_time_s",
                value: -1.0,
                expected: "> 0"
            }
        );
        extern crate std;
        use std::string::ToString;
        assert_eq!(
            e.to_string(),
            "config field `sample_time_s` = -1 is out of range (expected > 0)"
        );
        assert_eq!(
            non_negative("x", f32::NAN),
            Err(ConfigError::NonFinite { field: "x" })
        );
    }
}
