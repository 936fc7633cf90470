//! Hunt-Crossley estimators: the paper's double-stage Γ1/Γ2 in feedback (eqs. 25-37) and,
//! for comparison, a single-stage log-linear RLS from the literature.

use nalgebra::{Vector2, Vector3};

use crate::error::{check, non_negative, ConfigError};
use crate::estimator::{finite_or, ContactSample, Estimator, SampleUpdate, Scaling};
use crate::fmath;
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
    /// Give Γ2 an intercept: y2 = c + n·ln δ instead of y2 = n·ln δ (beyond the paper).
    ///
    /// Without it an error in k̂ enters Γ2's regression as ln(k/k̂) and biases n̂ towards
    /// the value that compensates it; the feedback loop then closes the gap in n by only
    /// a fraction 1 − E\[ln δ\]²/E\[ln² δ\] per memory length of the RLS, which depends on the
    /// length unit (ln δ must be centred near 0). The intercept absorbs ln(k/k̂), so Γ2
    /// converges independently of Γ1: the condition under eq. (34) holds by construction.
    pub exponent_intercept: bool,
    /// Hold λ at 0 instead of estimating it, for records that cannot determine it (a
    /// constant-speed ramp: δⁿ·δ̇ = v·δⁿ is collinear with δⁿ, and the damping would absorb
    /// part of the stiffness and, through Γ2, of the exponent). See [`crate::rls::Rls::hold`].
    pub hold_damping: bool,
}

/// Forgetting used by both stages by default: β = 0.9995 (2 s memory at 1 kHz) after a
/// start-up that begins at 0.99 and relaxes over 1000 samples. The feedback between Γ1
/// and Γ2 advances by one "iteration" per memory length, so it needs forgetting early;
/// once converged, a long memory keeps the noise in the estimates low. Chosen on
/// simulated plastic and gel (seeds 1-4): an earlier start of 0.97 made the gel diverge.
///
/// For material changes use adaptive forgetting (eq. 24) with α1 ≤ 0.005, e.g.
/// [`adaptive_forgetting`]: the coupled stages need a memory of a good part of a motion
/// cycle. With α1 = 0.01 (β down to 0.99, 100 samples) the simulated gel oscillated: δ and
/// δ̇ co-vary within one stroke, so k, λ and n are not separable over so short a window and
/// n̂ swung between its bounds.
pub const HUNT_CROSSLEY_RLS: RlsConfig = RlsConfig {
    initial_covariance: 1.0e3,
    max_covariance_trace_factor: 1.0,
    forgetting: crate::rls::Forgetting::Fixed { beta: 0.9995 },
    startup_forgetting: 0.99,
    startup_samples: 1000.0,
};

/// Adaptive forgetting (eq. 24) for tracking material changes with the Hunt-Crossley
/// estimators: β ≈ 0.99984 while |F − F̂| stays well under `threshold_n` \[N\], falling
/// towards 0.995 above it (α1 = 0.005, α3 = 3.2, α2 = α3/threshold). Choose the
/// threshold at ≈ 10× the force noise.
pub fn adaptive_forgetting(threshold_n: f32) -> crate::rls::Forgetting {
    crate::rls::Forgetting::Adaptive(crate::rls::AdaptiveForgetting {
        alpha1: 0.005,
        alpha2: 3.2 / threshold_n,
        alpha3: 3.2,
    })
}

impl Default for HuntCrossleyConfig {
    /// Paper's structure with the intercept in Γ2 (see `exponent_intercept`) and
    /// [`HUNT_CROSSLEY_RLS`] forgetting; n̂(0) = 1.
    fn default() -> Self {
        HuntCrossleyConfig {
            scaling: Scaling::default(),
            stage1: HUNT_CROSSLEY_RLS,
            stage2: RlsConfig {
                initial_covariance: 1.0,
                ..HUNT_CROSSLEY_RLS
            },
            initial_exponent: 1.0,
            guards: HuntCrossleyGuards::default(),
            exponent_intercept: true,
            hold_damping: false,
        }
    }
}

impl HuntCrossleyConfig {
    /// The paper taken literally: Γ2 without intercept (eqs. 26-29), otherwise as
    /// [`Default`]. Converges only when ln δ is centred near 0 in the internal length unit
    /// (see `exponent_intercept`).
    pub fn paper_literal() -> Self {
        HuntCrossleyConfig {
            exponent_intercept: false,
            ..HuntCrossleyConfig::default()
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

impl HuntCrossleyParameters {
    /// `true` when k, λ and n are all finite.
    pub fn is_finite(&self) -> bool {
        // v·0 is 0 for finite v, NaN otherwise: one comparison (1 kHz path).
        self.k * 0.0 + self.lambda * 0.0 + self.n * 0.0 == 0.0
    }
}

/// Internal (k_s, λ_s, n) of an SI parameter set, `None` unless k > 0, λ and n finite
/// and n in (0, 10].
fn hunt_crossley_to_internal(s: &Scaling, p: &HuntCrossleyParameters) -> Option<(f32, f32, f32)> {
    if !(p.is_finite() && p.k > 0.0 && p.n > 0.0 && p.n <= 10.0) {
        return None;
    }
    let l_pow_n = libm::expf(p.n * libm::logf(s.length_m));
    let k = p.k * l_pow_n / s.force_n;
    let lambda = p.lambda * l_pow_n * s.length_m / s.force_n;
    (k.is_finite() && k > 0.0 && lambda.is_finite()).then_some((k, lambda, p.n))
}

/// Largest |λ̂/k̂·δ̇| the double stage's Γ2 uses (with the intercept): the damping share of
/// the force it removes before the log-regression.
const MAX_DAMPING_SHARE: f32 = 0.5;

/// SI value of an internal Hunt-Crossley parameter set (k_s, λ_s, n); `ln_length` is
/// ln(`s.length_m`), taken once by each estimator's constructor.
fn hunt_crossley_to_si(
    s: &Scaling,
    ln_length: f32,
    k: f32,
    lambda: f32,
    n: f32,
) -> HuntCrossleyParameters {
    let l_pow_n = fmath::exp(n * ln_length);
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
/// has just produced; with an intercept (the default, see
/// [`HuntCrossleyConfig::exponent_intercept`]) y2 = ln(F/(1 + (λ̂/k̂)·δ̇)) = c + n·ln δ, the
/// intercept c standing for ln k. Each logarithm is guarded (δ, F ≤ minimum; k̂ + λ̂·δ̇ ≤ 0) and n̂ is
/// projected into its configured range. δ^n̂ is computed as e^{n̂·ln δ}, reusing ln δ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HuntCrossleyEstimator {
    config: HuntCrossleyConfig,
    gamma1: Rls<2>,
    /// θ2 = \[c, n\]; c stays 0 unless `exponent_intercept` (its regressor is then 0).
    gamma2: Rls<2>,
    intercept_regressor: f32,
    /// ln of the internal length unit, for the SI conversion.
    ln_length: f32,
    min_depth: f32,
    min_force: f32,
    /// Last internal (k_s, λ_s, n) whose SI values are finite (held when a conversion
    /// would overflow); [`Estimator::parameters`] converts them on demand.
    held_internal: [f32; 3],
    /// |k_s| and |λ_s| up to which the SI values are certainly finite (see
    /// [`certainly_finite_bounds`]).
    finite_bounds: (f32, f32),
}

/// Largest |k_s| and |λ_s| (internal units) whose SI values, (k_s·F0)/Lⁿ and
/// (λ_s·F0)/(Lⁿ·L) as [`hunt_crossley_to_si`] computes them, are finite for every exponent
/// in the guards' range: the products and quotients are bounded by f32::MAX/4 (the 4
/// covers rounding). (0, 0) when the units allow no such bound. It lets the double stage
/// flag an overflowing conversion without converting every sample.
fn certainly_finite_bounds(s: &Scaling, ln_length: f32, g: &HuntCrossleyGuards) -> (f32, f32) {
    let (lo, hi) = (
        libm::expf(g.min_exponent * ln_length),
        libm::expf(g.max_exponent * ln_length),
    );
    let l_pow_min = if lo < hi { lo } else { hi };
    let l_pow_min_l = l_pow_min * s.length_m;
    if !(l_pow_min >= f32::MIN_POSITIVE && l_pow_min_l >= f32::MIN_POSITIVE) {
        return (0.0, 0.0);
    }
    let bound = |divisor: f32| {
        let g = 4.0 * s.force_n * (1.0 / divisor).max(1.0);
        if g.is_finite() {
            f32::MAX / g
        } else {
            0.0
        }
    };
    (bound(l_pow_min), bound(l_pow_min_l))
}

impl HuntCrossleyEstimator {
    /// Builds the estimator: θ1(0) = 0, n̂(0) = `initial_exponent`.
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: HuntCrossleyConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut gamma1 = Rls::try_new(&config.stage1)?;
        if config.hold_damping {
            gamma1.hold(1, 0.0);
        }
        let ln_length = libm::logf(config.scaling.length_m);
        Ok(HuntCrossleyEstimator {
            gamma1,
            gamma2: Rls::try_with_initial(
                &config.stage2,
                Vector2::new(0.0, config.initial_exponent),
            )?,
            intercept_regressor: if config.exponent_intercept { 1.0 } else { 0.0 },
            ln_length,
            min_depth: config.guards.min_depth_m / config.scaling.length_m,
            min_force: config.guards.min_force_n / config.scaling.force_n,
            held_internal: [0.0, 0.0, config.initial_exponent],
            finite_bounds: certainly_finite_bounds(&config.scaling, ln_length, &config.guards),
            config,
        })
    }

    fn exponent(&self) -> f32 {
        self.gamma2.theta()[1]
    }

    /// Holds the current estimate unless its SI values do not fit in f32 (`NONPHYSICAL`).
    /// Within [`certainly_finite_bounds`] they fit without converting (n̂ is always in the
    /// guards' range: it starts there, `start_from` clamps it, every Γ2 update projects it).
    /// Inline in every update (the 1 kHz path); the conversion beyond the bounds is a call
    /// of its own.
    #[inline(always)]
    fn refresh(&mut self) -> Status {
        let th = self.gamma1.theta();
        let n = self.exponent();
        let certain = th[0].abs() <= self.finite_bounds.0 && th[1].abs() <= self.finite_bounds.1;
        if certain || self.converts_to_finite_si(th[0], th[1], n) {
            self.held_internal = [th[0], th[1], n];
            Status::empty()
        } else {
            Status::NONPHYSICAL
        }
    }

    /// Whether the internal (k_s, λ_s, n) have finite SI values: [`Self::refresh`] beyond
    /// [`certainly_finite_bounds`], rare after the start-up.
    #[inline(never)]
    #[cold]
    fn converts_to_finite_si(&self, k: f32, lambda: f32, n: f32) -> bool {
        hunt_crossley_to_si(&self.config.scaling, self.ln_length, k, lambda, n).is_finite()
    }
}

impl Estimator for HuntCrossleyEstimator {
    type Parameters = HuntCrossleyParameters;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        if !sample.is_finite() {
            return SampleUpdate {
                predicted_force_n: 0.0,
                status: Status::NON_FINITE_INPUT,
            };
        }
        if d <= self.min_depth {
            return SampleUpdate {
                predicted_force_n: 0.0,
                status: Status::GUARD_DEPTH,
            };
        }
        let ln_d = fmath::ln(d);
        let d_pow_n = fmath::exp(self.exponent() * ln_d);
        let phi1 = Vector2::new(d_pow_n, d_pow_n * v);
        let predicted = self.gamma1.predict(&phi1);
        let abs_error_n = (f - predicted).abs() * s.force_n;

        // Γ1: k, λ given n̂ (eq. 25, 30).
        let beta1 = self.config.stage1.forgetting.beta(abs_error_n);
        let mut status = self.gamma1.update_inline(&phi1, f, beta1).status;

        // Γ2: n given k̂, λ̂ (eq. 26, 31), with the guards the logarithms need.
        let th1 = self.gamma1.theta();
        let impedance = th1[0] + th1[1] * v;
        // With the intercept, ln k̂ is redundant with it: only the damping part of the
        // impedance, ln(1 + (λ̂/k̂)·δ̇), is subtracted. The paper's y2 = ln(F/(k̂ + λ̂·δ̇))
        // would carry k̂'s own drift into the slope n: on a monotonic ramp k̂ follows F/δ^n̂
        // as δ grows, and n̂ stays where it started.
        // The ratio (λ̂/k̂)·δ̇ is bounded to ±MAX_DAMPING_SHARE: early in a contact, k̂ and λ̂
        // come from a few collinear samples and their ratio can be anything.
        // y2 = ln F − ln(damping part) is taken as one logarithm of the quotient.
        if f <= self.min_force {
            status |= Status::GUARD_FORCE;
        } else if impedance <= 0.0 || th1[0] <= 0.0 {
            status |= Status::GUARD_IMPEDANCE;
        } else {
            let damping_part = if self.config.exponent_intercept {
                1.0 + (th1[1] / th1[0] * v).clamp(-MAX_DAMPING_SHARE, MAX_DAMPING_SHARE)
            } else {
                impedance
            };
            let y2 = fmath::ln(f / damping_part);
            let beta2 = self.config.stage2.forgetting.beta(abs_error_n);
            let phi2 = Vector2::new(self.intercept_regressor, ln_d);
            status |= self.gamma2.update_inline(&phi2, y2, beta2).status;
            let g = self.config.guards;
            let mut th2 = *self.gamma2.theta();
            if th2[1] < g.min_exponent || th2[1] > g.max_exponent {
                th2[1] = th2[1].clamp(g.min_exponent, g.max_exponent);
                self.gamma2.set_theta(th2);
                status |= Status::NONPHYSICAL;
            }
        }
        status |= self.refresh();
        // The SI values have the signs of the internal ones (positive units).
        if self.held_internal[0] < 0.0 || self.held_internal[1] < 0.0 {
            status |= Status::NONPHYSICAL;
        }
        SampleUpdate {
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> HuntCrossleyParameters {
        let [k, lambda, n] = self.held_internal;
        hunt_crossley_to_si(&self.config.scaling, self.ln_length, k, lambda, n)
    }

    fn onset_exponent(&self) -> Option<f32> {
        Some(self.held_internal[2])
    }

    fn onset_damping_ratio(&self) -> f32 {
        // λ/k in SI is λ_s/(k_s·L): the pipeline asks every sample, without a conversion.
        let [k, lambda, _] = self.held_internal;
        if k > 0.0 {
            lambda / (k * self.config.scaling.length_m)
        } else {
            0.0
        }
    }

    fn standard_errors(&self) -> HuntCrossleyParameters {
        let se1 = self.gamma1.standard_errors();
        let mut p = hunt_crossley_to_si(
            &self.config.scaling,
            self.ln_length,
            se1[0],
            se1[1],
            self.exponent(),
        );
        p.n = self.gamma2.standard_errors()[1];
        p
    }

    /// n outside the guards' range starts at the nearer bound (the projection every Γ2
    /// update applies), k and λ converted with it.
    fn start_from(&mut self, p: &HuntCrossleyParameters) {
        let g = &self.config.guards;
        let p = HuntCrossleyParameters {
            n: p.n.clamp(g.min_exponent, g.max_exponent),
            ..*p
        };
        let Some((k, lambda, n)) = hunt_crossley_to_internal(&self.config.scaling, &p) else {
            return;
        };
        self.gamma1.restart_from(Vector2::new(k, lambda));
        let c = if self.config.exponent_intercept {
            libm::logf(k)
        } else {
            0.0
        };
        self.gamma2.restart_from(Vector2::new(c, n));
        let _ = self.refresh();
    }

    fn reset(&mut self) {
        self.gamma1.reset();
        self.gamma2.reset();
        let _ = self.refresh();
    }
}

/// Largest |λ̂/k̂·δ̇| at which the single stage corrects its linearisation (see
/// [`SingleStageHuntCrossleyEstimator`]).
const CORRECTED_RATIO: f32 = 0.8;

/// Updates over which the single stage's linearisation correction follows λ̂/k̂.
const RATIO_SMOOTHING_UPDATES: f32 = 200.0;

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
    /// |λ̂/k̂·δ̇| is kept at or below this (the ratio is projected back before the update,
    /// [`Status::GUARD_IMPEDANCE`]): 0.9 by default, away from u = −1 where ln(1 + u)
    /// diverges.
    pub max_damping_ratio: f32,
    /// Residual weighting.
    pub weighting: LogWeighting,
    /// Hold λ at 0 (see [`HuntCrossleyConfig::hold_damping`]).
    pub hold_damping: bool,
}

impl Default for SingleStageHuntCrossleyConfig {
    fn default() -> Self {
        SingleStageHuntCrossleyConfig {
            scaling: Scaling::default(),
            rls: RlsConfig {
                initial_covariance: 1.0e2,
                ..HUNT_CROSSLEY_RLS
            },
            guards: HuntCrossleyGuards::default(),
            max_damping_ratio: 0.9,
            weighting: LogWeighting::Uniform,
            hold_damping: false,
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
/// k = e^{θ1}, λ = θ2·e^{θ1}, n = θ3. The literature's linearisation holds for
/// |λδ̇/k| ≪ 1; here the target also carries its remainder ln(1 + u) − u at the current
/// estimate u = θ̂2·δ̇ (smoothed, |u| ≤ 0.8), so the regression is exact once θ̂2 has
/// converged (beyond the literature). This form was confirmed from a public implementation, not from the
/// paper's own text (which was not available to us); see DESIGN notes in the README.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingleStageHuntCrossleyEstimator {
    config: SingleStageHuntCrossleyConfig,
    rls: Rls<3>,
    /// λ̂/k̂ averaged over [`RATIO_SMOOTHING_UPDATES`], for the linearisation correction.
    smoothed_ratio: f32,
    /// ln of the internal length unit, for the SI conversion.
    ln_length: f32,
    min_depth: f32,
    min_force: f32,
    /// Last finite SI parameters (held when a conversion overflows).
    held: HuntCrossleyParameters,
}

impl SingleStageHuntCrossleyEstimator {
    /// Builds the estimator with θ(0) = \[0, 0, 1\] (k = 1 internal unit, no damping,
    /// n = 1).
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: SingleStageHuntCrossleyConfig) -> Result<Self, ConfigError> {
        config.validate()?;
        let mut rls = Rls::try_with_initial(&config.rls, Vector3::new(0.0, 0.0, 1.0))?;
        if config.hold_damping {
            rls.hold(1, 0.0);
        }
        let ln_length = libm::logf(config.scaling.length_m);
        Ok(SingleStageHuntCrossleyEstimator {
            rls,
            smoothed_ratio: 0.0,
            ln_length,
            min_depth: config.guards.min_depth_m / config.scaling.length_m,
            min_force: config.guards.min_force_n / config.scaling.force_n,
            held: hunt_crossley_to_si(&config.scaling, ln_length, 1.0, 0.0, 1.0),
            config,
        })
    }

    fn refresh(&mut self) -> Status {
        let (k, lambda, n) = self.internal();
        let si = hunt_crossley_to_si(&self.config.scaling, self.ln_length, k, lambda, n);
        if si.is_finite() {
            self.held = si;
            Status::empty()
        } else {
            Status::NONPHYSICAL
        }
    }

    fn internal(&self) -> (f32, f32, f32) {
        let th = self.rls.theta();
        let k = libm::expf(th[0].clamp(-80.0, 80.0));
        (k, th[1] * k, th[2])
    }
}

impl Estimator for SingleStageHuntCrossleyEstimator {
    type Parameters = HuntCrossleyParameters;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        let mut status = Status::empty();
        if !sample.is_finite() {
            status |= Status::NON_FINITE_INPUT;
        } else if d <= self.min_depth {
            status |= Status::GUARD_DEPTH;
        }
        if !status.is_empty() {
            return SampleUpdate {
                predicted_force_n: 0.0,
                status,
            };
        }
        let ln_d = fmath::ln(d);
        let (k, lambda, n) = self.internal();
        let predicted = fmath::exp(n * ln_d) * (k + lambda * v).max(0.0);
        if f <= self.min_force {
            status |= Status::GUARD_FORCE;
        } else {
            // The linearisation ln(1 + u) ≈ u, u = (λ/k)·δ̇, holds for |u| ≤
            // max_damping_ratio. An estimate beyond it for this δ̇ is projected back to the
            // bound (not skipped: on a constant-speed ramp every later sample would then be
            // skipped too, and the estimator would stay locked on a wrong ratio).
            let bound = self.config.max_damping_ratio / v.abs().max(f32::MIN_POSITIVE);
            let mut th = *self.rls.theta();
            if th[1].abs() > bound {
                th[1] = th[1].clamp(-bound, bound);
                self.rls.set_theta(th);
                status |= Status::GUARD_IMPEDANCE | Status::NONPHYSICAL;
            }
            // ln F = ln k + n·ln δ + ln(1 + r·δ̇), r = λ/k, regressed on r·δ̇: the target
            // carries the linearisation's remainder ln(1 + u) − u at u = r̄·δ̇, so that the
            // regression is exact once r̂ has converged (without it λ is biased by ≈ u/2:
            // 20-40 % at damping shares of 20-30 %). r̄ follows r̂ slowly (over
            // RATIO_SMOOTHING_UPDATES): fed back at once, a poorly excited r̂ that jumps at
            // the turn of a constant-speed stroke made the update diverge.
            self.smoothed_ratio += (th[1] - self.smoothed_ratio) / RATIO_SMOOTHING_UPDATES;
            let u = (self.smoothed_ratio * v).clamp(-CORRECTED_RATIO, CORRECTED_RATIO);
            let y = fmath::ln(f) - (libm::log1pf(u) - u);
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
        status |= self.refresh();
        let parameters = self.held;
        if parameters.lambda < 0.0 {
            status |= Status::NONPHYSICAL;
        }
        SampleUpdate {
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> HuntCrossleyParameters {
        self.held
    }

    fn onset_exponent(&self) -> Option<f32> {
        Some(self.held.n)
    }

    fn onset_damping_ratio(&self) -> f32 {
        let p = self.held;
        if p.k > 0.0 {
            p.lambda / p.k
        } else {
            0.0
        }
    }

    fn standard_errors(&self) -> HuntCrossleyParameters {
        let se = self.rls.standard_errors();
        let (k, lambda, n) = self.internal();
        let se_k = k * se[0];
        let se_lambda =
            libm::sqrtf((k * se[1]) * (k * se[1]) + (lambda * se[0]) * (lambda * se[0]));
        let mut p = hunt_crossley_to_si(&self.config.scaling, self.ln_length, se_k, se_lambda, n);
        p.n = se[2];
        p
    }

    fn start_from(&mut self, p: &HuntCrossleyParameters) {
        let Some((k, lambda, n)) = hunt_crossley_to_internal(&self.config.scaling, p) else {
            return;
        };
        self.rls
            .restart_from(Vector3::new(libm::logf(k), lambda / k, n));
        self.smoothed_ratio = self.rls.theta()[1];
        let _ = self.refresh();
    }

    fn reset(&mut self) {
        self.rls.reset();
        self.smoothed_ratio = self.rls.theta()[1];
        let _ = self.refresh();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Within the bounds the double stage skips the conversion, so every value inside
    /// them must convert to finite SI, for the paper's units and for extreme ones.
    #[test]
    fn values_within_the_finite_bounds_convert_to_finite_si() {
        let g = HuntCrossleyGuards::default();
        for (length_m, force_n) in [
            (1.0e-3, 1.0),
            (1.0e-9, 1.0e-9),
            (1.0e3, 1.0e6),
            (1.0e-6, 1.0e3),
        ] {
            let s = Scaling { length_m, force_n };
            let ln_length = libm::logf(length_m);
            let (k_max, lambda_max) = certainly_finite_bounds(&s, ln_length, &g);
            assert!(k_max > 0.0 && lambda_max > 0.0, "{length_m} {force_n}");
            for i in 0..=20 {
                let n = g.min_exponent + (g.max_exponent - g.min_exponent) * i as f32 / 20.0;
                for (k, lambda) in [(k_max, lambda_max), (-k_max, -lambda_max), (k_max, 0.0)] {
                    let p = hunt_crossley_to_si(&s, ln_length, k, lambda, n);
                    assert!(p.is_finite(), "{length_m} {force_n} n={n}: {p:?}");
                }
            }
        }
        // Units with which some exponent overflows the conversion give no bound.
        let s = Scaling {
            length_m: 1.0e-30,
            force_n: 1.0,
        };
        assert_eq!(
            certainly_finite_bounds(&s, libm::logf(1.0e-30), &g),
            (0.0, 0.0)
        );
    }

    /// n̂ never leaves the guards' range, a start outside it included: `refresh` relies on
    /// it (it no longer tests n̂). k and λ are kept in SI, converted with the clamped n.
    #[test]
    fn a_start_outside_the_exponent_range_starts_at_its_bound() {
        let mut e = HuntCrossleyEstimator::try_new(HuntCrossleyConfig::default()).unwrap();
        let g = HuntCrossleyGuards::default();
        for (n, bound) in [(5.0, g.max_exponent), (0.1, g.min_exponent)] {
            let start = HuntCrossleyParameters {
                k: 2.0e5,
                lambda: 3.0e3,
                n,
            };
            e.start_from(&start);
            assert_eq!(e.onset_exponent(), Some(bound));
            let p = e.parameters();
            assert_eq!(p.n, bound);
            assert!((p.k / start.k - 1.0).abs() < 1e-5, "{p:?}");
            assert!((p.lambda / start.lambda - 1.0).abs() < 1e-5, "{p:?}");
            // reset() returns to the clamped start.
            e.reset();
            assert_eq!(e.parameters().n, bound);
        }
    }
}
