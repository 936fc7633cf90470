//! Hammerstein (quasi-linear viscoelastic) two-phase estimator, eqs. (38)-(42), Fig. 9.
//!
//! Phase 1, Γ1 (eqs. 39-42): while the probe loads fast (δ̇ > δ̇*), F ≈ F_e and the power
//! law F_e = γ1·δ^γ2 is fitted on its logarithm, y1 = ln F, φ1 = \[1, ln δ\]ᵀ,
//! θ1 = \[ln γ1, γ2\]ᵀ, by weighted RLS with weights β^{N−h}·e^{y1(h)} (eq. 41).
//!
//! Phase 2, Γ2 (footnote 4): every in-contact sample, the filter G_L(z⁻¹) of eq. (38)
//! (b0 = 1, order R) is fitted as an ARX model from F̂_e to F:
//! y2 = F(h) − F̂_e(h), φ2 = \[F(h−1)…F(h−R), F̂_e(h−1)…F̂_e(h−R)\]ᵀ,
//! θ2 = \[−a1…−aR, b1…bR\]ᵀ, with F̂_e computed from the γ̂ just updated.

use nalgebra::{SVector, Vector2};

use crate::error::{non_negative, ConfigError};
use crate::estimator::{finite_or, ContactSample, Estimator, SampleUpdate, Scaling};
use crate::rls::{Rls, RlsConfig};
use crate::Status;

/// Hammerstein parameters: power-law elastic response (eq. 39) and filter (eq. 38).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HammersteinParameters<const R: usize> {
    /// γ1 \[N/m^γ2\]: F_e = γ1·δ^γ2.
    pub gamma1: f32,
    /// γ2 (dimensionless).
    pub gamma2: f32,
    /// Denominator a1..aR of G_L(z⁻¹) (dimensionless, at the sample rate).
    pub a: [f32; R],
    /// Numerator b1..bR of G_L(z⁻¹) (b0 = 1).
    pub b: [f32; R],
}

impl<const R: usize> Default for HammersteinParameters<R> {
    fn default() -> Self {
        HammersteinParameters {
            gamma1: 0.0,
            gamma2: 0.0,
            a: [0.0; R],
            b: [0.0; R],
        }
    }
}

impl<const R: usize> HammersteinParameters<R> {
    /// Static (DC) gain of G_L: (1 + Σb_i)/(1 + Σa_i), the fully relaxed fraction c0 of
    /// the reduced relaxation function (eq. 10) when the model is a QLV one.
    pub fn static_gain(&self) -> f32 {
        let num: f32 = 1.0 + self.b.iter().sum::<f32>();
        let den: f32 = 1.0 + self.a.iter().sum::<f32>();
        num / den
    }
}

/// Configuration of [`HammersteinEstimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct HammersteinConfig {
    /// Internal units.
    pub scaling: Scaling,
    /// Γ1: weighted RLS for \[ln γ1, γ2\] (eq. 42).
    pub elastic_stage: RlsConfig,
    /// Γ2: RLS for \[−a_i, b_i\].
    pub filter_stage: RlsConfig,
    /// δ̇* \[m/s\]: Γ1 is updated only while δ̇ exceeds it (fast loading, F ≈ F_e).
    pub min_depth_rate_m_per_s: f32,
    /// Γ1 skips samples with δ at or below this \[m\] (ln δ guard).
    pub min_depth_m: f32,
    /// Γ1 skips samples with F at or below this \[N\] (ln F guard).
    pub min_force_n: f32,
    /// Corner frequency \[Hz\] of the first-order low-pass L(z⁻¹) applied to both F and
    /// F̂_e before Γ2 (0 disables it). The ARX relation A·F = B·F_e is linear, so L leaves
    /// it unchanged, while measurement noise in the regressor F(h−1) would otherwise bias
    /// the slow pole (errors in variables): prefiltering as in Ljung & Söderström, the
    /// paper's ref. \[23\]. Must lie well above the relaxation rates of interest.
    pub filter_prefilter_hz: f32,
    /// Weight of each Γ1 sample: the paper's e^{y1} = F (eq. 41) or F².
    pub elastic_weighting: crate::hunt_crossley::LogWeighting,
}

impl Default for HammersteinConfig {
    /// The paper's polyurethane experiment: loading at 30 mm/s, so δ̇* = 10 mm/s.
    fn default() -> Self {
        HammersteinConfig {
            scaling: Scaling::default(),
            elastic_stage: RlsConfig {
                initial_covariance: 1.0e2,
                forgetting: crate::rls::Forgetting::Fixed { beta: 1.0 },
                ..RlsConfig::default()
            },
            filter_stage: RlsConfig {
                initial_covariance: 1.0e2,
                forgetting: crate::rls::Forgetting::Fixed { beta: 1.0 },
                ..RlsConfig::default()
            },
            min_depth_rate_m_per_s: 10.0e-3,
            min_depth_m: 20.0e-6,
            min_force_n: 0.1,
            filter_prefilter_hz: 5.0,
            elastic_weighting: crate::hunt_crossley::LogWeighting::Force,
        }
    }
}

impl HammersteinConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming the bad field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        self.scaling.validate()?;
        self.elastic_stage.validate()?;
        self.filter_stage.validate()?;
        non_negative("min_depth_rate_m_per_s", self.min_depth_rate_m_per_s)?;
        non_negative("min_depth_m", self.min_depth_m)?;
        non_negative("min_force_n", self.min_force_n)?;
        non_negative("filter_prefilter_hz", self.filter_prefilter_hz)?;
        Ok(())
    }
}

/// Two-phase Hammerstein estimator with filter order `R`; `NP` must equal 2·R (the size
/// of θ2; checked at compile time). Use the aliases [`Hammerstein1`], [`Hammerstein2`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HammersteinEstimator<const R: usize, const NP: usize> {
    config: HammersteinConfig,
    elastic: Rls<2>,
    filter: Rls<NP>,
    /// F(h−1)…F(h−R), internal units.
    past_force: [f32; R],
    /// F̂_e(h−1)…F̂_e(h−R), internal units.
    past_elastic: [f32; R],
    /// Prefiltered F and F̂_e histories (Γ2 regression), internal units.
    past_force_lp: [f32; R],
    past_elastic_lp: [f32; R],
    /// Prefilter states and gain κ = 1 − e^{−2π f T} (κ = 1: no prefilter).
    force_lp: f32,
    elastic_lp: f32,
    prefilter_gain: f32,
    /// θ_nom: coefficients of A = B = (1 − z⁻¹)^R in θ2's layout \[−a_i, b_i\].
    nominal: SVector<f32, NP>,
    min_depth: f32,
    min_force: f32,
    min_rate: f32,
    /// Last finite SI parameters (held when a conversion overflows).
    held: HammersteinParameters<R>,
}

/// Hammerstein estimator with a first-order filter (the paper's experiment, r = 1).
pub type Hammerstein1 = HammersteinEstimator<1, 2>;
/// Hammerstein estimator with a second-order filter.
pub type Hammerstein2 = HammersteinEstimator<2, 4>;

impl<const R: usize, const NP: usize> HammersteinEstimator<R, NP> {
    /// Builds the estimator with θ1(0) = \[0, 1\] (γ1 = 1 internal unit, γ2 = 1) and
    /// θ2(0) = 0 (G_L = 1).
    ///
    /// # Errors
    /// [`ConfigError`] if the config is invalid.
    pub fn try_new(config: HammersteinConfig) -> Result<Self, ConfigError> {
        const { assert!(NP == 2 * R, "HammersteinEstimator<R, NP> needs NP = 2·R") };
        config.validate()?;
        let s = config.scaling;
        // (1 − z⁻¹)^R: coefficient of z^{−i} is (−1)^i·C(R, i).
        let mut binomial = [0.0f32; R];
        let mut c = 1.0f32;
        for i in 1..=R {
            c = c * (R + 1 - i) as f32 / i as f32;
            binomial[i - 1] = if i % 2 == 0 { c } else { -c };
        }
        let nominal = SVector::from_fn(|i, _| if i < R { -binomial[i] } else { binomial[i - R] });
        let prefilter_gain = if config.filter_prefilter_hz > 0.0 {
            -libm::expm1f(-2.0 * core::f32::consts::PI * config.filter_prefilter_hz * 1.0e-3)
        } else {
            1.0
        };
        let mut est = HammersteinEstimator {
            nominal,
            past_force_lp: [0.0; R],
            past_elastic_lp: [0.0; R],
            force_lp: 0.0,
            elastic_lp: 0.0,
            prefilter_gain,
            elastic: Rls::try_with_initial(&config.elastic_stage, Vector2::new(0.0, 1.0))?,
            filter: Rls::try_new(&config.filter_stage)?,
            past_force: [0.0; R],
            past_elastic: [0.0; R],
            min_depth: config.min_depth_m / s.length_m,
            min_force: config.min_force_n / s.force_n,
            min_rate: config.min_depth_rate_m_per_s / s.length_m,
            held: HammersteinParameters::default(),
            config,
        };
        est.held = est.parameters_si().unwrap_or_default();
        Ok(est)
    }

    /// SI parameters from θ1, θ2, or `None` if they do not fit in f32.
    fn parameters_si(&self) -> Option<HammersteinParameters<R>> {
        let s = self.config.scaling;
        let th1 = self.elastic.theta();
        let th2 = self.filter.theta() + self.nominal;
        let gamma2 = th1[1];
        let gamma1 = libm::expf(th1[0]) * s.force_n / libm::expf(gamma2 * libm::logf(s.length_m));
        let mut p = HammersteinParameters {
            gamma1,
            gamma2,
            ..HammersteinParameters::default()
        };
        for i in 0..R {
            p.a[i] = -th2[i];
            p.b[i] = th2[R + i];
        }
        let finite = p.gamma1.is_finite()
            && p.gamma2.is_finite()
            && p.a.iter().chain(p.b.iter()).all(|v| v.is_finite());
        finite.then_some(p)
    }

    fn elastic_force(&self, depth: f32) -> f32 {
        if depth <= 0.0 {
            return 0.0;
        }
        let th = self.elastic.theta();
        libm::expf(th[0] + th[1] * libm::logf(depth))
    }

    /// Stability of 1/A(z⁻¹) for the current θ2 (Jury conditions for R ≤ 2; higher
    /// orders are not checked).
    fn filter_is_stable(&self) -> bool {
        let th = self.filter.theta() + self.nominal;
        match R {
            1 => (-th[0]).abs() < 1.0,
            2 => {
                let (a1, a2) = (-th[0], -th[1]);
                a2.abs() < 1.0 && a1.abs() < 1.0 + a2
            }
            _ => true,
        }
    }

    fn regressor(force: &[f32; R], elastic: &[f32; R]) -> SVector<f32, NP> {
        SVector::from_fn(|i, _| if i < R { force[i] } else { elastic[i - R] })
    }

    fn push(history: &mut [f32; R], value: f32) {
        if R > 0 {
            history.copy_within(0..R - 1, 1);
            history[0] = value;
        }
    }
}

impl<const R: usize, const NP: usize> Estimator for HammersteinEstimator<R, NP> {
    type Parameters = HammersteinParameters<R>;

    fn update(&mut self, sample: &ContactSample) -> SampleUpdate {
        let s = self.config.scaling;
        let (d, v, f) = s.to_internal(sample);
        if !sample.is_finite() {
            return SampleUpdate {
                predicted_force_n: 0.0,
                status: Status::NON_FINITE_INPUT,
            };
        }
        let phi2 = Self::regressor(&self.past_force, &self.past_elastic);
        let predicted =
            self.elastic_force(d) + self.nominal.dot(&phi2) + self.filter.predict(&phi2);
        let abs_error_n = (f - predicted).abs() * s.force_n;
        let mut status = Status::empty();

        // Γ1, only during fast loading (F ≈ F_e), eqs. (40)-(42).
        if v > self.min_rate {
            if d <= self.min_depth {
                status |= Status::GUARD_DEPTH;
            } else if f <= self.min_force {
                status |= Status::GUARD_FORCE;
            } else {
                let beta = self.config.elastic_stage.forgetting.beta(abs_error_n);
                let phi1 = Vector2::new(1.0, libm::logf(d));
                let weight = match self.config.elastic_weighting {
                    crate::hunt_crossley::LogWeighting::Uniform => 1.0,
                    crate::hunt_crossley::LogWeighting::Force => f,
                    crate::hunt_crossley::LogWeighting::ForceSquared => f * f,
                };
                status |= self
                    .elastic
                    .update_weighted(&phi1, libm::logf(f), beta, weight)
                    .status;
                status |= Status::ELASTIC_STAGE_ACTIVE;
            }
        }

        // Γ2, every in-contact sample, with F̂_e from the updated γ̂ (footnote 4), on the
        // prefiltered signals.
        let fe = self.elastic_force(d);
        let k = self.prefilter_gain;
        self.force_lp += k * (f - self.force_lp);
        self.elastic_lp += k * (fe - self.elastic_lp);
        let phi2_lp = Self::regressor(&self.past_force_lp, &self.past_elastic_lp);
        let y2 = self.force_lp - self.elastic_lp - self.nominal.dot(&phi2_lp);
        let beta = self.config.filter_stage.forgetting.beta(abs_error_n);
        status |= self.filter.update_inline(&phi2_lp, y2, beta).status;
        Self::push(&mut self.past_force, f);
        Self::push(&mut self.past_elastic, fe);
        Self::push(&mut self.past_force_lp, self.force_lp);
        Self::push(&mut self.past_elastic_lp, self.elastic_lp);
        // The estimator stays unconstrained (projecting it distorted the relaxation
        // estimate: the filter starts on the stability boundary, A = B = 1 − z⁻¹). But a
        // relaxing material has its poles inside the unit circle, so an unstable filter
        // estimate (creep under constant force drives the ARX towards an integrator) is
        // never reported: the last stable a_i, b_i are held, γ1, γ2 still follow.
        match self.parameters_si() {
            Some(p) if self.filter_is_stable() => self.held = p,
            Some(p) => {
                self.held.gamma1 = p.gamma1;
                self.held.gamma2 = p.gamma2;
                status |= Status::NONPHYSICAL;
            }
            None => status |= Status::NONPHYSICAL,
        }

        SampleUpdate {
            predicted_force_n: finite_or(predicted * s.force_n, 0.0),
            status,
        }
    }

    fn parameters(&self) -> HammersteinParameters<R> {
        self.held
    }

    fn onset_exponent(&self) -> Option<f32> {
        Some(self.held.gamma2)
    }

    fn standard_errors(&self) -> HammersteinParameters<R> {
        let p = self.parameters();
        let se1 = self.elastic.standard_errors();
        let se2 = self.filter.standard_errors();
        let mut e = HammersteinParameters {
            gamma1: p.gamma1 * se1[0],
            gamma2: se1[1],
            ..HammersteinParameters::default()
        };
        for i in 0..R {
            e.a[i] = se2[i];
            e.b[i] = se2[R + i];
        }
        e
    }

    fn start_contact(&mut self) {
        self.past_force = [0.0; R];
        self.past_elastic = [0.0; R];
        self.past_force_lp = [0.0; R];
        self.past_elastic_lp = [0.0; R];
        self.force_lp = 0.0;
        self.elastic_lp = 0.0;
    }

    /// Starts the elastic stage Γ1 from γ1, γ2 (the filter stage keeps G_L = 1).
    fn start_from(&mut self, p: &HammersteinParameters<R>) {
        if !(p.gamma1 > 0.0 && p.gamma1.is_finite() && p.gamma2 > 0.0 && p.gamma2 <= 10.0) {
            return;
        }
        let s = self.config.scaling;
        let ln_gamma1 =
            libm::logf(p.gamma1) + p.gamma2 * libm::logf(s.length_m) - libm::logf(s.force_n);
        self.elastic.restart_from(Vector2::new(ln_gamma1, p.gamma2));
        self.held = self.parameters_si().unwrap_or(self.held);
    }

    fn reset(&mut self) {
        self.elastic.reset();
        self.filter.reset();
        self.start_contact();
        self.held = self.parameters_si().unwrap_or_default();
    }
}
