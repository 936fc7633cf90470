//! Hunt-Crossley estimators: the paper's double-stage Γ1/Γ2 in feedback (eqs. 25-37) and,
//! for comparison, a single-stage log-linear RLS from the literature.

use nalgebra::{Vector1, Vector2, Vector3};

use crate::error::{check, non_negative, ConfigError};
use crate::estimator::{finite_or, ContactSample, Estimate, Estimator, Scaling};
use crate::rls::{Rls, RlsConfig};
use crate::Status;

/// Hunt-Crossley parameters, eq. (3) with q = n.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HuntCrossleyParameters {
    /// Stiffness coefficient k \[N/m^n\].
    pub k: f32,
    /// Damping coefficient λ \[N·s/m^(n+1)\].
    pub lambda: f32,
    /// Exponent n (dimensionless).
    pub n: f32,
}

/// Guards and bounds shared by both Hunt-Crossley estimators.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct HuntCrossleyGuards {
    /// Samples with δ ≤ this \[m\] are not used where ln δ is needed (eq. 26/31).
    pub min_depth_m: f32,
    /// Samples with F ≤ this \[N\] are not used where ln F is needed (eq. 26/31).
    /// Close to zero force the logarithm turns additive noise into unbounded error.
    pub min_force_n: f32,
    /// n̂ is kept in \[min_exponent, max_exponent\] (projection).
    pub min_exponent: f32,
    /// See `min_exponent`.
    pub max_exponent: f32,
}

impl Default for HuntCrossleyGuards {
    /// For the paper's rig (mm, N): 20 µm and 0.2 N, n ∈ \[0.5, 3\].
    fn default() -> Self {
        HuntCrossleyGuards {
            min_depth_m: 20.0e-6,
            min_force_n: 0.2,
            min_exponent: 0.5,
            max_exponent: 3.0,
        }
    }
}

impl HuntCrossleyGuards {
    /// Validates the guards.
    ///
    /// # Errors
    /// [`ConfigError`] naming `min_depth_m`, `min_force_n`, `min_exponent` or `max_exponent`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        non_negative("min_depth_m", self.min_depth_m)?;
        non_negative("min_force_n", self.min_force_n)?;
        check("min_exponent", self.min_exponent, |v| v > 0.0, "> 0")?;
        let lo = self.min_exponent;
        check(
            "max_exponent",
            self.max_exponent,
            |v| v > lo && v <= 10.0,
            "(min_exponent, 10]",
        )?;
        Ok(())
    }
}

/// Configuration of [`HuntCrossleyEstimator`] (double stage).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct HuntCrossleyConfig {
    /// Internal units.
    pub scaling: Scaling,
    /// Γ1: RLS for θ1 = \[k, λ\] (eq. 25).
    pub stage1: RlsConfig,
    /// Γ2: RLS for θ2 = n (eqs. 26-29).
    pub stage2: RlsConfig,
    /// n̂(0), dimensionless (1 = start from Kelvin-Voigt).
    pub initial_exponent: f32,
    /// Logarithm guards and exponent bounds.
    pub guards: HuntCrossleyGuards,
}

impl Default for HuntCrossleyConfig {
    fn default() -> Self {
        HuntCrossleyConfig {
            scaling: Scaling::default(),
            stage1: RlsConfig {
                initial_covariance: 1.0e3,
                ..RlsConfig::default()
            },
            stage2: RlsConfig {
                initial_covariance: 1.0,
                ..RlsConfig::default()
            },
            initial_exponent: 1.0,
            guards: HuntCrossleyGuards::default(),
        }
    }
}

impl HuntCrossleyConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.scaling.validate()?;
        self.stage1.validate()?;
        self.stage2.validate()?;
        self.guards.validate()?;
        let g = self.guards;
        check(
            "initial_exponent",
            self.initial_exponent,
            |v| v >= g.min_exponent && v <= g.max_exponent,
            "[min_exponent, max_exponent]",
        )?;
        Ok(())
    }
}

/// SI value of an internal Hunt-Crossley parameter set (k_s, λ_s, n).
fn hunt_crossley_to_si(s: &Scaling, k: f32, lambda: f32, n: f32) -> HuntCrossleyParameters {
    let l_pow_n = libm::expf(n * libm::logf(s.length_m));
    HuntCrossleyParameters {
        k: k * s.force_n / l_pow_n,
        lambda: lambda * s.force_n / (l_pow_n * s.length_m),
        n,
    }
}

/// The paper's double-stage Hunt-Crossley estimator (Fig. 6, eqs. 25-37).
///
/// Γ1 (eq. 25): y1 = F, φ1 = \[δ^n̂, δ^n̂·δ̇\]ᵀ, θ1 = \[k, λ\]ᵀ.
/// Γ2 (eqs. 26-29, 31): y2 = ln(F/(k̂ + λ̂·δ̇)), φ2 = ln δ, θ2 = n, using the k̂, λ̂ that Γ1
/// has just produced. Each logarithm is guarded (δ, F ≤ minimum; k̂ + λ̂·δ̇ ≤ 0) and n̂ is
/// projected into its configured range. δ^n̂ is computed as e^{n̂·ln δ}, reusing ln δ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HuntCrossleyEstimator {
    config: HuntCrossleyConfig,
    gamma1: Rls<2>,
    gamma2: Rls<1>,
    min_depth: f32,
    min_force: f32,
}

impl HuntCrossleyEstimator {
    /// Builds the estimator: θ1(0) = 0, n̂(0) = `initial_exponent`.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: HuntCrossleyConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(HuntCrossleyEstimator {
            gamma1: Rls::try_new(&config.stage1)?,
            gamma2: Rls::try_with_initial(&config.stage2, Vector1::new(config.initial_exponent))?,
            min_depth: config.guards.min_depth_m / config.scaling.length_m,
            min_force: config.guards.min_force_n / config.scaling.force_n,
            config,
        })
    }

    fn exponent(&self) -> f32 {
        self.gamma2.theta()[0]
    }
}

impl Estimator for HuntCrossleyEstimator {
    type Parameters = HuntCrossleyParameters;

    fn step(&mut self, sample: &ContactSample) -> Estimate<HuntCrossleyParameters> {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        if !sample.is_finite() {
            return Estimate {
                parameters: self.parameters(),
                predicted_force_n: 0.0,
                status: Status::NON_FINITE_INPUT,
            };
        }
        if d <= self.min_depth {
            return Estimate {
                parameters: self.parameters(),
                predicted_force_n: 0.0,
                status: Status::GUARD_DEPTH,
            };
        }
        let ln_d = libm::logf(d);
        let d_pow_n = libm::expf(self.exponent() * ln_d);
        let phi1 = Vector2::new(d_pow_n, d_pow_n * v);
        let predicted = self.gamma1.predict(&phi1);
        let abs_error_n = (f - predicted).abs() * s.force_n;

        // Γ1: k, λ given n̂ (eq. 25, 30).
        let beta1 = self.config.stage1.forgetting.beta(abs_error_n);
        let mut status = self.gamma1.update(&phi1, f, beta1).status;

        // Γ2: n given k̂, λ̂ (eq. 26, 31), with the guards the logarithms need.
        let th1 = self.gamma1.theta();
        let impedance = th1[0] + th1[1] * v;
        if f <= self.min_force {
            status |= Status::GUARD_FORCE;
        } else if impedance <= 0.0 {
            status |= Status::GUARD_IMPEDANCE;
        } else {
            let y2 = libm::logf(f) - libm::logf(impedance);
            let beta2 = self.config.stage2.forgetting.beta(abs_error_n);
            status |= self.gamma2.update(&Vector1::new(ln_d), y2, beta2).status;
            let g = self.config.guards;
            let n = self.exponent();
            let clamped = n.clamp(g.min_exponent, g.max_exponent);
            if clamped != n {
                self.gamma2.set_theta(Vector1::new(clamped));
                status |= Status::NONPHYSICAL;
            }
        }
        let parameters = self.parameters();
        if parameters.k < 0.0 || parameters.lambda < 0.0 {
            status |= Status::NONPHYSICAL;
        }
        Estimate {
            parameters,
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> HuntCrossleyParameters {
        let th = self.gamma1.theta();
        hunt_crossley_to_si(&self.config.scaling, th[0], th[1], self.exponent())
    }

    fn standard_errors(&self) -> HuntCrossleyParameters {
        let se1 = self.gamma1.standard_errors();
        let mut p = hunt_crossley_to_si(&self.config.scaling, se1[0], se1[1], self.exponent());
        p.n = self.gamma2.standard_errors()[0];
        p
    }

    fn reset(&mut self) {
        self.gamma1.reset();
        self.gamma2.reset();
    }
}

/// Weighting of the log-domain residual in [`SingleStageHuntCrossleyEstimator`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum LogWeighting {
    /// Ordinary RLS on ln F (the literature's form).
    #[default]
    Uniform,
    /// Weights e^{y} = F, as the paper does for the Hammerstein elastic stage (eq. 41).
    Force,
    /// Weights e^{2y} = F²: additive force noise of variance σ² becomes log noise of
    /// variance σ²/F², so this is the maximum-likelihood weighting.
    ForceSquared,
}

/// Configuration of [`SingleStageHuntCrossleyEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SingleStageHuntCrossleyConfig {
    /// Internal units.
    pub scaling: Scaling,
    /// RLS for θ = \[ln k, λ/k, n\].
    pub rls: RlsConfig,
    /// Logarithm guards and exponent bounds.
    pub guards: HuntCrossleyGuards,
    /// Samples with |λ̂/k̂·δ̇| above this are skipped: the linearisation
    /// ln(1 + u) ≈ u is then off by more than u²/2.
    pub max_damping_ratio: f32,
    /// Residual weighting.
    pub weighting: LogWeighting,
}

impl Default for SingleStageHuntCrossleyConfig {
    fn default() -> Self {
        SingleStageHuntCrossleyConfig {
            scaling: Scaling::default(),
            rls: RlsConfig {
                initial_covariance: 1.0e2,
                ..RlsConfig::default()
            },
            guards: HuntCrossleyGuards::default(),
            max_damping_ratio: 0.5,
            weighting: LogWeighting::Uniform,
        }
    }
}

impl SingleStageHuntCrossleyConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.scaling.validate()?;
        self.rls.validate()?;
        self.guards.validate()?;
        check(
            "max_damping_ratio",
            self.max_damping_ratio,
            |v| v > 0.0 && v < 1.0,
            "(0, 1)",
        )?;
        Ok(())
    }
}

/// Single-stage Hunt-Crossley estimator (log-linear RLS), after Haddadi & Hashtrudi-Zaad,
/// "Real-time identification of Hunt-Crossley dynamic models of contact environments",
/// IEEE T-RO 28(3), 2012.
///
/// ln F = ln k + n·ln δ + ln(1 + (λ/k)·δ̇) ≈ ln k + n·ln δ + (λ/k)·δ̇, so one RLS with
/// y = ln F, φ = \[1, δ̇, ln δ\]ᵀ, θ = \[ln k, λ/k, n\]ᵀ estimates all three parameters;
/// k = e^{θ1}, λ = θ2·e^{θ1}, n = θ3. The linearisation holds for |λδ̇/k| ≪ 1. This form
/// was confirmed from a public implementation, not from the paper's own text (which
/// was not available to us); see DESIGN notes in the README.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingleStageHuntCrossleyEstimator {
    config: SingleStageHuntCrossleyConfig,
    rls: Rls<3>,
    min_depth: f32,
    min_force: f32,
}

impl SingleStageHuntCrossleyEstimator {
    /// Builds the estimator with θ(0) = \[0, 0, 1\] (k = 1 internal unit, no damping,
    /// n = 1).
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: SingleStageHuntCrossleyConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        Ok(SingleStageHuntCrossleyEstimator {
            rls: Rls::try_with_initial(&config.rls, Vector3::new(0.0, 0.0, 1.0))?,
            min_depth: config.guards.min_depth_m / config.scaling.length_m,
            min_force: config.guards.min_force_n / config.scaling.force_n,
            config,
        })
    }

    fn internal(&self) -> (f32, f32, f32) {
        let th = self.rls.theta();
        let k = libm::expf(th[0].clamp(-80.0, 80.0));
        (k, th[1] * k, th[2])
    }
}

impl Estimator for SingleStageHuntCrossleyEstimator {
    type Parameters = HuntCrossleyParameters;

    fn step(&mut self, sample: &ContactSample) -> Estimate<HuntCrossleyParameters> {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        let mut status = Status::empty();
        if !sample.is_finite() {
            status |= Status::NON_FINITE_INPUT;
        } else if d <= self.min_depth {
            status |= Status::GUARD_DEPTH;
        }
        if !status.is_empty() {
            return Estimate {
                parameters: self.parameters(),
                predicted_force_n: 0.0,
                status,
            };
        }
        let ln_d = libm::logf(d);
        let (k, lambda, n) = self.internal();
        let predicted = libm::expf(n * ln_d) * (k + lambda * v).max(0.0);
        let ratio = self.rls.theta()[1] * v;
        if f <= self.min_force {
            status |= Status::GUARD_FORCE;
        } else if ratio.abs() > self.config.max_damping_ratio {
            status |= Status::GUARD_IMPEDANCE;
        } else {
            let y = libm::logf(f);
            let weight = match self.config.weighting {
                LogWeighting::Uniform => 1.0,
                LogWeighting::Force => f,
                LogWeighting::ForceSquared => f * f,
            };
            let beta = self
                .config
                .rls
                .forgetting
                .beta((f - predicted).abs() * s.force_n);
            status |= self
                .rls
                .update_weighted(&Vector3::new(1.0, v, ln_d), y, beta, weight)
                .status;
            let g = self.config.guards;
            let mut th = *self.rls.theta();
            if th[2] < g.min_exponent || th[2] > g.max_exponent {
                th[2] = th[2].clamp(g.min_exponent, g.max_exponent);
                self.rls.set_theta(th);
                status |= Status::NONPHYSICAL;
            }
        }
        let parameters = self.parameters();
        if parameters.lambda < 0.0 {
            status |= Status::NONPHYSICAL;
        }
        Estimate {
            parameters,
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> HuntCrossleyParameters {
        let (k, lambda, n) = self.internal();
        hunt_crossley_to_si(&self.config.scaling, k, lambda, n)
    }

    fn standard_errors(&self) -> HuntCrossleyParameters {
        let se = self.rls.standard_errors();
        let th = self.rls.theta();
        let (k, lambda, n) = self.internal();
        let se_k = k * se[0];
        let se_lambda =
            libm::sqrtf((k * se[1]) * (k * se[1]) + (lambda * se[0]) * (lambda * se[0]));
        let _ = th;
        let mut p = hunt_crossley_to_si(&self.config.scaling, se_k, se_lambda, n);
        p.n = se[2];
        p
    }

    fn reset(&mut self) {
        self.rls.reset();
    }
}
