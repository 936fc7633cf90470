//! Kelvin-Voigt estimator: RLS (eq. 23) on the linear regression of eq. (1).
//!
//! y = F, φ = \[δ, δ̇\]ᵀ, θ = \[κ, λ\]ᵀ (internal units, see [`Scaling`]).

use nalgebra::Vector2;

use crate::error::ConfigError;
use crate::estimator::{finite_or, ContactSample, Estimator, SampleUpdate, Scaling};
use crate::rls::{Rls, RlsConfig};
use crate::Status;

/// Kelvin-Voigt parameters, eq. (1).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KelvinVoigtParameters {
    /// Stiffness κ \[N/m\].
    pub kappa: f32,
    /// Damping λ \[N·s/m\].
    pub lambda: f32,
}

/// Configuration of [`KelvinVoigtEstimator`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct KelvinVoigtConfig {
    /// Internal units.
    pub scaling: Scaling,
    /// RLS settings (P(0) in internal units: (N/mm)² for the default scaling).
    pub rls: RlsConfig,
    /// Hold λ at 0 instead of estimating it (a record without velocity excitation); see
    /// [`crate::rls::Rls::hold`].
    pub hold_damping: bool,
}

impl KelvinVoigtConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.scaling.validate()?;
        self.rls.validate()
    }
}

/// Online Kelvin-Voigt estimator (eqs. 1, 20-24).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KelvinVoigtEstimator {
    config: KelvinVoigtConfig,
    rls: Rls<2>,
    /// Last finite SI parameters (held when a conversion overflows).
    held: KelvinVoigtParameters,
}

impl KelvinVoigtEstimator {
    /// Builds the estimator with θ̂(0) = 0.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: KelvinVoigtConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut rls = Rls::try_new(&config.rls)?;
        if config.hold_damping {
            rls.hold(1, 0.0);
        }
        Ok(KelvinVoigtEstimator {
            config,
            rls,
            held: KelvinVoigtParameters::default(),
        })
    }

    fn parameters_si(&self, theta: &Vector2<f32>) -> KelvinVoigtParameters {
        let s = self.config.scaling;
        KelvinVoigtParameters {
            kappa: theta[0] * s.force_n / s.length_m,
            lambda: theta[1] * s.force_n / s.length_m,
        }
    }
}

impl Estimator for KelvinVoigtEstimator {
    type Parameters = KelvinVoigtParameters;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        let phi = Vector2::new(d, v);
        let predicted = self.rls.predict(&phi);
        let mut status = Status::empty();
        if !sample.is_finite() {
            status |= Status::NON_FINITE_INPUT;
        } else if d <= 0.0 {
            status |= Status::GUARD_DEPTH;
        } else {
            let beta = self
                .config
                .rls
                .forgetting
                .beta((f - predicted).abs() * s.force_n);
            status |= self.rls.update(&phi, f, beta).status;
        }
        let si = self.parameters_si(self.rls.theta());
        if si.kappa.is_finite() && si.lambda.is_finite() {
            self.held = si;
        } else {
            status |= Status::NONPHYSICAL;
        }
        let parameters = self.held;
        if parameters.kappa < 0.0 || parameters.lambda < 0.0 {
            status |= Status::NONPHYSICAL;
        }
        SampleUpdate {
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> KelvinVoigtParameters {
        self.held
    }

    fn standard_errors(&self) -> KelvinVoigtParameters {
        self.parameters_si(&self.rls.standard_errors())
    }

    fn start_from(&mut self, p: &KelvinVoigtParameters) {
        let s = self.config.scaling;
        let scale = s.length_m / s.force_n;
        self.rls
            .restart_from(Vector2::new(p.kappa * scale, p.lambda * scale));
        self.held = self.parameters_si(self.rls.theta());
    }

    fn reset(&mut self) {
        self.rls.reset();
        self.held = self.parameters_si(self.rls.theta());
    }
}
