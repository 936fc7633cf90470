//! What every online estimator shares: the per-sample input, the output, the internal
//! unit scaling and the [`Estimator`] trait.

use crate::error::{positive, ConfigError};
use crate::Status;

/// Internal units of an estimator.
///
/// In SI the regressors of a contact model differ by many orders of magnitude (δ ≈ 1e-3 m
/// next to F ≈ 10 N for the paper's rig; δ ≈ 1e-6 m and F ≈ 1e-9 N for an AFM), and the
/// parameters with them (k ≈ 4.6e4 N/m^1.2 next to n ≈ 1.2). Each estimator therefore
/// works in units of `length_m` and `force_n` (time stays in seconds) so that its
/// parameters are of order one, which keeps P(0) = c·I a sensible prior and the logarithms
/// of eqs. (26) and (40) well centred. Inputs and outputs are SI; the scaling is
/// invisible outside the estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Scaling {
    /// Internal unit of length \[m\] (1e-3 for the paper's rig: millimetres).
    pub length_m: f32,
    /// Internal unit of force \[N\] (1.0 for the paper's rig).
    pub force_n: f32,
}

impl Default for Scaling {
    /// Millimetres and newtons: the paper's rig (δ ≈ 1-5 mm, F ≈ 1-15 N).
    fn default() -> Self {
        Scaling {
            length_m: 1.0e-3,
            force_n: 1.0,
        }
    }
}

impl Scaling {
    /// Validates both units (finite, > 0).
    ///
    /// # Errors
    /// [`ConfigError`] naming `length_m` or `force_n`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("length_m", self.length_m)?;
        positive("force_n", self.force_n)?;
        Ok(())
    }

    /// Powers of ten closest to the typical magnitudes `depth_m` and `force_n` of a record.
    /// Non-positive or non-finite magnitudes fall back to the default (mm, N).
    pub fn for_magnitudes(depth_m: f32, force_n: f32) -> Self {
        let pow10 = |v: f32, fallback: f32| {
            if v.is_finite() && v > 0.0 {
                libm::powf(10.0, libm::roundf(libm::log10f(v)))
            } else {
                fallback
            }
        };
        let d = Scaling::default();
        Scaling {
            length_m: pow10(depth_m, d.length_m),
            force_n: pow10(force_n, d.force_n),
        }
    }

    /// `sample` in internal units: (δ/L, δ̇/L \[1/s\], F/F0).
    #[inline]
    pub fn to_internal(&self, sample: &ContactSample) -> (f32, f32, f32) {
        (
            sample.depth_m / self.length_m,
            sample.depth_rate_m_per_s / self.length_m,
            sample.force_n / self.force_n,
        )
    }
}

/// One sample of the contact, in SI, as handed to an estimator by the pipeline.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ContactSample {
    /// Penetration δ = x − x_contact \[m\], positive into the material.
    pub depth_m: f32,
    /// Penetration rate δ̇ \[m/s\] (from the state-variable filter).
    pub depth_rate_m_per_s: f32,
    /// Contact force F \[N\], offset removed, positive when the material pushes back.
    pub force_n: f32,
}

impl ContactSample {
    /// `true` when all three fields are finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        // v·0 is 0 for finite v, NaN otherwise: one comparison instead of three bit tests
        // (this runs every sample on the Cortex-M4F).
        self.depth_m * 0.0 + self.depth_rate_m_per_s * 0.0 + self.force_n * 0.0 == 0.0
    }
}

/// Output of one estimator step.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Estimate<P> {
    /// Physical parameters after this sample, SI (see each estimator's parameter type).
    pub parameters: P,
    /// Force predicted for this sample before the update (a-priori), \[N\]. This is the
    /// F̂ of eq. (24) and the innovation reference of the residual monitor.
    pub predicted_force_n: f32,
    /// What happened during the step.
    pub status: Status,
}

/// What one estimator update did, without the SI parameters: [`Estimator::parameters`]
/// converts those on demand (on the Cortex-M4F the Hunt-Crossley conversion is an `expf`
/// of its own, needed only when the parameters are published, not every sample).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleUpdate {
    /// Force predicted for this sample before the update (a-priori), \[N\]; see
    /// [`Estimate::predicted_force_n`].
    pub predicted_force_n: f32,
    /// What happened during the update.
    pub status: Status,
}

/// An online estimator of a contact model's parameters, stepped once per sample.
///
/// `update` and `step` never panic and `parameters` is never non-finite: a sample an
/// estimator cannot use is skipped with a [`Status`] flag and the last parameters are
/// held. The 1 kHz task calls `update` and reads `parameters` (SI) only when it publishes
/// them; `step` does both.
pub trait Estimator {
    /// Physical parameter set (SI units).
    type Parameters: Copy + core::fmt::Debug + PartialEq;

    /// Processes one in-contact sample (eq. 23 and the model-specific regression); the
    /// parameters it leaves are read with [`Estimator::parameters`].
    fn update(&mut self, sample: &ContactSample) -> SampleUpdate;

    /// [`Estimator::update`], then the parameters it leaves (SI).
    fn step(&mut self, sample: &ContactSample) -> Estimate<Self::Parameters> {
        let update = self.update(sample);
        Estimate {
            parameters: self.parameters(),
            predicted_force_n: update.predicted_force_n,
            status: update.status,
        }
    }

    /// Current physical parameters (SI).
    fn parameters(&self) -> Self::Parameters;

    /// Standard error of each parameter (SI, same layout as [`Estimator::parameters`]),
    /// from σ̂²·P by the delta method; see [`crate::rls::Rls::standard_errors`].
    fn standard_errors(&self) -> Self::Parameters;

    /// Exponent n of the power law F ∝ δⁿ this model's force follows from zero at the
    /// onset of contact (current Hunt-Crossley n, Hammerstein γ2); `None` for models whose
    /// force jumps at impact (Kelvin-Voigt, Zener: λ·δ̇). The pipeline hands it to the
    /// contact detector to refine each contact point (see
    /// [`crate::conditioning::refinement`]).
    fn onset_exponent(&self) -> Option<f32> {
        None
    }

    /// For a power-law onset with velocity-dependent damping, F = δⁿ·(k + λ·δ̇): the
    /// current λ/k \[s/m\] (Hunt-Crossley), else 0. Helps the contact detector isolate
    /// the elastic part of the force rise.
    fn onset_damping_ratio(&self) -> f32 {
        0.0
    }

    /// Called by the pipeline when a new contact begins: estimators with memory of
    /// past samples (ARX forms) restart it from the undeformed state (δ = 0, F = 0).
    fn start_contact(&mut self) {}

    /// Starts from known parameters (SI) instead of the defaults, e.g. a host's
    /// whole-record fit or a material stored on the board: the estimate begins there and
    /// [`Estimator::reset`] returns there. Held parameters stay held; non-finite or
    /// non-positive values (where the model needs a logarithm) are ignored. The default
    /// does nothing.
    fn start_from(&mut self, parameters: &Self::Parameters) {
        let _ = parameters;
    }

    /// Full reset to the initial parameters and covariance.
    fn reset(&mut self);
}

/// Returns `value` if finite, otherwise `fallback`.
#[inline]
pub(crate) fn finite_or(value: f32, fallback: f32) -> f32 {
    if value.is_finite() {
        value
    } else {
        fallback
    }
}
