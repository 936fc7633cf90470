//! Recursive least squares with a forgetting factor.
//!
//! Implements eqs. (20)-(23) of Biagiotti & Melchiorri, the adaptive forgetting factor of
//! eq. (24), and the weighted variant of eqs. (41)-(42):
//!
//! ```text
//! Q(h) = P(h-1)·φ(h) / (β/w(h) + φᵀ(h)·P(h-1)·φ(h))
//! θ̂(h) = θ̂(h-1) + Q(h)·(y(h) − φᵀ(h)·θ̂(h-1))
//! P(h) = (1/β)·(I − Q(h)·φᵀ(h))·P(h-1)
//! ```
//!
//! with w(h) = 1 for the ordinary cost (20)-(22) and w(h) = e^{y(h)} for (41).
//!
//! Numerical safety, beyond the paper:
//! - P is kept exactly symmetric (only the upper triangle is computed, then mirrored).
//! - Anti-windup: when excitation vanishes, dividing by β makes P grow without bound
//!   ("covariance windup"). Here the effective factor for one sample is raised towards 1
//!   just enough that trace(P) never exceeds `max_covariance_trace`
//!   ([`Status::COVARIANCE_BOUNDED`]).
//! - A non-finite φ, y or weight skips the update ([`Status::NON_FINITE_INPUT`]); a
//!   covariance that turns non-finite or loses a positive diagonal is reset to c·I
//!   ([`Status::COVARIANCE_RESET`]). θ̂ is never overwritten with a non-finite value.

use nalgebra::{SMatrix, SVector};

use crate::error::{check, positive, ConfigError};
use crate::fmath::{max_finite, min_finite};
use crate::Status;

/// Forgetting-factor policy for an RLS estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Forgetting {
    /// Constant forgetting factor β ∈ (0, 1] (eq. 22). β = 1 is ordinary least squares.
    Fixed {
        /// Forgetting factor β, dimensionless, in (0, 1].
        beta: f32,
    },
    /// β computed each sample from the force prediction error (eq. 24).
    Adaptive(AdaptiveForgetting),
}

impl Forgetting {
    /// Validates the policy.
    ///
    /// # Errors
    /// [`ConfigError`] naming `beta` or `alpha1`/`alpha2`/`alpha3` when out of range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match self {
            Forgetting::Fixed { beta } => {
                check("beta", *beta, |b| b > 0.0 && b <= 1.0, "(0, 1]")?;
                Ok(())
            }
            Forgetting::Adaptive(a) => a.validate(),
        }
    }

    /// The forgetting factor for a sample whose a-priori force prediction error is
    /// `abs_force_error_n` \[N\] (≥ 0). For [`Forgetting::Fixed`] the error is ignored.
    #[inline]
    pub fn beta(&self, abs_force_error_n: f32) -> f32 {
        match self {
            Forgetting::Fixed { beta } => *beta,
            Forgetting::Adaptive(a) => a.beta(abs_force_error_n),
        }
    }
}

impl Default for Forgetting {
    fn default() -> Self {
        Forgetting::Fixed { beta: 0.999 }
    }
}

/// Adaptive forgetting factor of eq. (24):
/// β = 1 − α1·((1/π)·arctan(α2·|F − F̂| − α3) + 1/2).
///
/// For small errors β → 1 − α1·(1/2 − arctan(α3)/π) ≈ 1 (when α3 ≫ 1); for large errors
/// β → 1 − α1. The transition sits at |F − F̂| ≈ α3/α2 and its width is ≈ 1/α2.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct AdaptiveForgetting {
    /// α1 ∈ [0, 1): 1 − α1 is β for large errors. Dimensionless.
    pub alpha1: f32,
    /// α2 > 0 \[1/N\]: steepness of the transition.
    pub alpha2: f32,
    /// α3 \[dimensionless\]: threshold between small and large errors, in units of 1/α2.
    pub alpha3: f32,
}

impl AdaptiveForgetting {
    /// Validates α1 ∈ [0, 1), α2 > 0, α3 finite, and that small errors give β ≥ 0.9
    /// (otherwise the estimator forgets even when it predicts well).
    ///
    /// # Errors
    /// [`ConfigError`] naming `alpha1`, `alpha2` or `alpha3`.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check("alpha1", self.alpha1, |a| (0.0..1.0).contains(&a), "[0, 1)")?;
        positive("alpha2", self.alpha2)?;
        check("alpha3", self.alpha3, |_| true, "finite")?;
        if self.beta(0.0) < 0.9 {
            return Err(ConfigError::Inconsistent {
                field: "alpha3",
                reason: "beta at zero error is below 0.9: raise alpha3 or lower alpha1",
            });
        }
        Ok(())
    }

    /// β for an a-priori force error `abs_force_error_n` \[N\] (eq. 24).
    #[inline]
    pub fn beta(&self, abs_force_error_n: f32) -> f32 {
        let s = libm::atanf(self.alpha2 * abs_force_error_n - self.alpha3)
            * core::f32::consts::FRAC_1_PI
            + 0.5;
        1.0 - self.alpha1 * s
    }
}

/// Configuration shared by every RLS stage.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RlsConfig {
    /// c in P(0) = c·I, in the estimator's internal (scaled) units. > 0.
    pub initial_covariance: f32,
    /// Upper bound on trace(P) (anti-windup), same units. ≥ N·c, i.e. P may never
    /// exceed its own start in total.
    pub max_covariance_trace_factor: f32,
    /// Forgetting factor policy (eq. 22 or eq. 24).
    pub forgetting: Forgetting,
    /// Start-up forgetting: the factor actually used is min(β, β_s(h)) with
    /// 1 − β_s(h) = (1 − `startup_forgetting`)·ρ^h, ρ = 1 − 1/`startup_samples`
    /// (Ljung & Söderström's forgetting that tends to one, the paper's ref. \[23\]). Early
    /// data, taken while coupled estimators (Hunt-Crossley Γ1/Γ2) still feed each other
    /// wrong values, is forgotten quickly; later the policy's β alone applies. 1.0
    /// disables it.
    pub startup_forgetting: f32,
    /// Time constant of the start-up forgetting, in updates (> 0).
    pub startup_samples: f32,
}

impl Default for RlsConfig {
    fn default() -> Self {
        RlsConfig {
            initial_covariance: 1.0e3,
            max_covariance_trace_factor: 1.0,
            forgetting: Forgetting::default(),
            startup_forgetting: 1.0,
            startup_samples: 1000.0,
        }
    }
}

impl RlsConfig {
    /// Validates the config.
    ///
    /// # Errors
    /// [`ConfigError`] naming `initial_covariance`, `max_covariance_trace_factor` (must be
    /// ≥ 1: the bound is this factor times trace(P(0))) or a forgetting field.
    pub fn validate(&self) -> Result<(), ConfigError> {
        positive("initial_covariance", self.initial_covariance)?;
        check(
            "max_covariance_trace_factor",
            self.max_covariance_trace_factor,
            |v| v >= 1.0,
            ">= 1",
        )?;
        check(
            "startup_forgetting",
            self.startup_forgetting,
            |b| b > 0.0 && b <= 1.0,
            "(0, 1]",
        )?;
        positive("startup_samples", self.startup_samples)?;
        self.forgetting.validate()
    }
}

/// Result of one RLS update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlsUpdate {
    /// A-priori error y − φᵀθ̂(h−1), in the units of y. NaN when the input was non-finite.
    pub prior_error: f32,
    /// Conditions met during the update.
    pub status: Status,
}

/// Recursive least-squares estimator of `N` parameters (eq. 23), f32, fixed size.
///
/// Memory: θ̂ (N floats), P (N² floats) and four scalars; no heap.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rls<const N: usize> {
    theta: SVector<f32, N>,
    theta0: SVector<f32, N>,
    p: SMatrix<f32, N, N>,
    initial_covariance: f32,
    max_trace: f32,
    /// Exponentially weighted mean of the weighted a-posteriori squared residual, for
    /// parameter standard errors.
    residual_variance: f32,
    /// 1 − β_s(h) of the start-up forgetting, and its decay ρ per update.
    startup_gap: f32,
    startup_gap0: f32,
    startup_decay: f32,
    /// Parameters held at their value (see [`Rls::hold`]).
    held: [bool; N],
}

/// Below this the start-up gap is over: 1 − gap rounds to exactly 1 in f32 (it does below
/// 2⁻²⁵), so zeroing the gap changes no β. Left alone, the gap ends stuck on a subnormal
/// (ρ·m·2⁻¹⁴⁹ rounds back to m·2⁻¹⁴⁹ for m below 1/(2(1 − ρ))) and every later update
/// multiplies it: on x86 about a hundred cycles each (a microcode assist), which was a
/// third of the Hunt-Crossley update's time on a long record. Hosted targets only: the
/// Cortex-M4F's FPU handles subnormals in hardware at the usual cost, and there the test
/// would cost 9 instructions of the double stage's step (`cargo qemu`); β and every
/// result are the same either way.
#[cfg(not(target_os = "none"))]
const STARTUP_GAP_OVER: f32 = f32::EPSILON / 8.0;

/// Mixing rate of the residual-variance average (≈ 1000-sample memory).
const RESIDUAL_VARIANCE_RATE: f32 = 1.0e-3;

impl<const N: usize> Rls<N> {
    /// New estimator with θ̂(0) = 0 and P(0) = c·I.
    ///
    /// # Errors
    /// [`ConfigError`] if `config` is invalid ([`RlsConfig::validate`]).
    pub fn try_new(config: &RlsConfig) -> Result<Self, ConfigError> {
        Self::try_with_initial(config, SVector::zeros())
    }

    /// New estimator with a given θ̂(0) (internal units) and P(0) = c·I.
    ///
    /// # Errors
    /// [`ConfigError`] if `config` is invalid or θ̂(0) is not finite (`theta0`).
    pub fn try_with_initial(
        config: &RlsConfig,
        theta0: SVector<f32, N>,
    ) -> Result<Self, ConfigError> {
        config.validate()?;
        if theta0.iter().any(|v| !v.is_finite()) {
            return Err(ConfigError::NonFinite { field: "theta0" });
        }
        let c = config.initial_covariance;
        Ok(Rls {
            theta: theta0,
            theta0,
            p: SMatrix::identity() * c,
            initial_covariance: c,
            max_trace: config.max_covariance_trace_factor * c * N as f32,
            residual_variance: 0.0,
            startup_gap: 1.0 - config.startup_forgetting,
            startup_gap0: 1.0 - config.startup_forgetting,
            startup_decay: 1.0 - 1.0 / config.startup_samples.max(1.0),
            held: [false; N],
        })
    }

    /// Holds parameter `i` at `value` (internal units): its regressor no longer updates
    /// anything, its covariance row and column stay 0 (its diagonal at c, so P stays
    /// positive definite and its trace bounded), and predictions use `value`. For a
    /// parameter the data cannot determine (e.g. damping on a constant-speed ramp, where
    /// δⁿ·δ̇ = v·δⁿ is collinear with δⁿ), which would otherwise absorb part of the others.
    /// Out-of-range `i` and non-finite `value` are ignored; the hold survives
    /// [`Rls::reset`].
    pub fn hold(&mut self, i: usize, value: f32) {
        if i >= N || !value.is_finite() {
            return;
        }
        self.held[i] = true;
        self.theta[i] = value;
        self.theta0[i] = value;
        self.decouple_held();
    }

    /// Starts from `theta` (internal units) instead of θ̂(0): θ̂ and the value
    /// [`Rls::reset`] returns to become `theta`, except held entries; P is reset to c·I.
    /// Non-finite values are ignored.
    pub fn restart_from(&mut self, theta: SVector<f32, N>) {
        if theta.iter().any(|v| !v.is_finite()) {
            return;
        }
        for i in 0..N {
            if !self.held[i] {
                self.theta[i] = theta[i];
                self.theta0[i] = theta[i];
            }
        }
        self.reset_covariance();
    }

    /// `true` if parameter `i` is held ([`Rls::hold`]).
    pub fn is_held(&self, i: usize) -> bool {
        self.held.get(i).copied().unwrap_or(false)
    }

    fn decouple_held(&mut self) {
        for i in 0..N {
            if self.held[i] {
                for j in 0..N {
                    self.p[(i, j)] = 0.0;
                    self.p[(j, i)] = 0.0;
                }
                self.p[(i, i)] = self.initial_covariance;
            }
        }
    }

    /// Current estimate θ̂ (internal units).
    #[inline]
    pub fn theta(&self) -> &SVector<f32, N> {
        &self.theta
    }

    /// Overwrites θ̂ (internal units), e.g. to clamp a parameter to its physical range.
    /// Non-finite values are ignored.
    #[inline]
    pub fn set_theta(&mut self, theta: SVector<f32, N>) {
        if theta.iter().all(|v| v.is_finite()) {
            self.theta = theta;
        }
    }

    /// Current covariance P (internal units), symmetric positive definite.
    #[inline]
    pub fn covariance(&self) -> &SMatrix<f32, N, N> {
        &self.p
    }

    /// Model output φᵀθ̂ for a regressor φ.
    #[inline]
    pub fn predict(&self, phi: &SVector<f32, N>) -> f32 {
        phi.dot(&self.theta)
    }

    /// Standard error of each parameter, σ̂·sqrt(P_ii), where σ̂² is the running mean of
    /// the (weighted) a-posteriori squared residual. Under forgetting this overstates
    /// the true spread by up to √2 (P/(1+β) is the asymptotic covariance); it is meant
    /// as an honest upper bound, not an exact interval.
    pub fn standard_errors(&self) -> SVector<f32, N> {
        let s2 = self.residual_variance;
        SVector::from_fn(|i, _| {
            if self.held[i] {
                0.0
            } else {
                libm::sqrtf((s2 * self.p[(i, i)]).max(0.0))
            }
        })
    }

    /// Resets P to c·I, keeping θ̂ (used after an abrupt change or a numerical fault).
    pub fn reset_covariance(&mut self) {
        self.p = SMatrix::identity() * self.initial_covariance;
        self.decouple_held();
    }

    /// Resets θ̂ to θ̂(0), P to c·I and restarts the start-up forgetting.
    pub fn reset(&mut self) {
        self.theta = self.theta0;
        self.reset_covariance();
        self.residual_variance = 0.0;
        self.startup_gap = self.startup_gap0;
    }

    /// One update of eq. (23) with forgetting factor `beta` ∈ (0, 1].
    #[inline]
    pub fn update(&mut self, phi: &SVector<f32, N>, y: f32, beta: f32) -> RlsUpdate {
        self.update_weighted(phi, y, beta, 1.0)
    }

    /// [`Rls::update`] compiled into its caller, with the same results: the weight's
    /// arithmetic folds away and there is no call (≈ 30 instructions fewer a call on the
    /// Cortex-M4F, ≈ 0.8 KiB of flash a call site). For the 1 kHz path's hottest call
    /// sites: the Hunt-Crossley double stage's two stages and the Hammerstein filter stage.
    #[inline(always)]
    pub(crate) fn update_inline(&mut self, phi: &SVector<f32, N>, y: f32, beta: f32) -> RlsUpdate {
        self.update_inner(phi, y, beta, 1.0)
    }

    /// One weighted update (eqs. 41-42): the sample's weight in the cost is `weight` > 0
    /// (the paper's e^{y1(h)}), older samples decay by `beta`. One call (not inlined: one
    /// copy per N in the firmware's 64 KiB of flash).
    #[inline(never)]
    pub fn update_weighted(
        &mut self,
        phi: &SVector<f32, N>,
        y: f32,
        beta: f32,
        weight: f32,
    ) -> RlsUpdate {
        self.update_inner(phi, y, beta, weight)
    }

    #[inline(always)]
    fn update_inner(&mut self, phi: &SVector<f32, N>, y: f32, beta: f32, weight: f32) -> RlsUpdate {
        let inputs = y * 0.0 + weight * 0.0 + beta * 0.0;
        if !(phi.iter().fold(inputs, |z, v| z + v * 0.0) == 0.0 && weight > 0.0) {
            return RlsUpdate {
                prior_error: f32::NAN,
                status: Status::NON_FINITE_INPUT,
            };
        }
        // 1 − gap ∈ (0, 1] (the gap starts in [0, 1) and decays), so only the lower
        // bound needs a test; a NaN β gives 1 − gap.
        let beta = max_finite(min_finite(beta, 1.0 - self.startup_gap), f32::MIN_POSITIVE);
        self.startup_gap *= self.startup_decay;
        #[cfg(not(target_os = "none"))]
        if self.startup_gap < STARTUP_GAP_OVER {
            self.startup_gap = 0.0;
        }
        let mut status = Status::empty();
        let prior_error = y - phi.dot(&self.theta);
        // Held parameters take no part in the update (their P rows are 0). With none held
        // (the usual case) φ as it is, and one test instead of one per parameter.
        let any_held = self.held.iter().any(|&h| h);
        let free_phi = if any_held {
            SVector::from_fn(|i, _| if self.held[i] { 0.0 } else { phi[i] })
        } else {
            *phi
        };
        let pphi = self.p * free_phi;
        let denom = beta / weight + free_phi.dot(&pphi);
        // Finite and positive (a plain `< INFINITY` becomes integer bit tests on the M4F).
        if !(denom > 0.0 && denom * 0.0 == 0.0) {
            self.reset_covariance();
            return RlsUpdate {
                prior_error,
                status: Status::COVARIANCE_RESET,
            };
        }
        let q = pphi / denom;
        let new_theta = self.theta + q * prior_error;

        // P − Q·(Pφ)ᵀ, upper triangle then mirrored: exactly symmetric.
        let mut p = self.p;
        let mut trace = 0.0;
        for j in 0..N {
            for i in 0..=j {
                let v = self.p[(i, j)] - q[i] * pphi[j];
                p[(i, j)] = v;
                p[(j, i)] = v;
            }
            trace += p[(j, j)];
        }
        // Anti-windup: effective β in [β, 1] so that trace(P) ≤ max_trace.
        let mut beta_eff = beta;
        if trace > self.max_trace * beta {
            beta_eff = min_finite(trace / self.max_trace, 1.0);
            status |= Status::COVARIANCE_BOUNDED;
        }
        for j in 0..N {
            for i in 0..=j {
                let v = p[(i, j)] / beta_eff;
                p[(i, j)] = v;
                p[(j, i)] = v;
            }
        }
        if any_held {
            for i in 0..N {
                if self.held[i] {
                    p[(i, i)] = self.initial_covariance;
                }
            }
        }

        // Stored before the test: a failing P is replaced by c·I, never kept.
        self.p = p;
        if !is_positive_definite(&p) {
            self.reset_covariance();
            status |= Status::COVARIANCE_RESET;
        }
        if all_finite(new_theta.as_slice()) {
            self.theta = new_theta;
            let post = y - phi.dot(&self.theta);
            let r = weight * post * post;
            // r ≥ 0 or NaN: finite exactly when at most f32::MAX (one unordered test).
            if r <= f32::MAX {
                self.residual_variance += RESIDUAL_VARIANCE_RATE * (r - self.residual_variance);
            }
        } else {
            status |= Status::COVARIANCE_RESET;
            self.reset_covariance();
        }
        RlsUpdate {
            prior_error,
            status,
        }
    }
}

/// `true` when every value is finite: v·0 is ±0 for a finite v and NaN otherwise, so one
/// comparison of the sum replaces a bit test per value (the RLS update runs at 1 kHz on
/// the Cortex-M4F, where this is a fifth of its instructions).
#[inline(always)]
fn all_finite(values: &[f32]) -> bool {
    values.iter().fold(0.0f32, |z, v| z + v * 0.0) == 0.0
}

/// `true` when the symmetric P is finite and positive definite: every pivot of its LDLᵀ
/// factorisation is positive (relative to the diagonal, so that rounding-level pivots count
/// as lost). A non-finite entry fails a pivot test (an infinite or NaN pivot, or one
/// compared with an infinite diagonal), so finiteness needs no test of its own.
/// O(N³/6) flops, no square roots; N ≤ 4 here.
///
/// The test of pivot j, d_j > 10⁻⁶·P_jj, is d_j > 10⁻⁶·|P_jj| and d_j > 0 in one
/// comparison: d_j = P_jj − Σ l²·d_k ≤ P_jj once the earlier pivots passed, so a negative
/// P_jj fails either way, and for P_jj ≥ 0 the first implies the second. Written as a
/// negated `>` so that a NaN pivot fails.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn is_positive_definite<const N: usize>(p: &SMatrix<f32, N, N>) -> bool {
    let mut l = SMatrix::<f32, N, N>::zeros();
    let mut d = [0.0f32; N];
    for j in 0..N {
        let mut dj = p[(j, j)];
        for k in 0..j {
            dj -= l[(j, k)] * l[(j, k)] * d[k];
        }
        if !(dj > 1.0e-6 * p[(j, j)]) {
            return false;
        }
        d[j] = dj;
        for i in j + 1..N {
            let mut v = p[(i, j)];
            for k in 0..j {
                v -= l[(i, k)] * l[(j, k)] * d[k];
            }
            l[(i, j)] = v / dj;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector2;

    fn cfg(beta: f32) -> RlsConfig {
        RlsConfig {
            initial_covariance: 1.0e4,
            forgetting: Forgetting::Fixed { beta },
            ..RlsConfig::default()
        }
    }

    #[test]
    #[cfg(not(target_os = "none"))]
    fn the_start_up_gap_ends_at_zero_not_on_a_subnormal() {
        // ρ = 0.9: the plain product sticks at m·2⁻¹⁴⁹ for m < 5 (ρ·m rounds back to m),
        // a subnormal every later update would multiply.
        let config = RlsConfig {
            startup_forgetting: 0.5,
            startup_samples: 10.0,
            ..cfg(0.999)
        };
        let mut rls = Rls::<2>::try_new(&config).unwrap();
        let (mut over, mut capped) = (None, 0);
        for h in 0..2000 {
            let gap = rls.startup_gap;
            assert!(gap == 0.0 || gap.is_normal(), "update {h}: gap {gap:e}");
            // The cap 1 − gap binds β = 0.999 until the gap is under 10⁻³.
            capped += usize::from(1.0 - gap < 0.999);
            if gap == 0.0 && over.is_none() {
                over = Some(h);
            }
            let u = 0.5 + 0.4 * libm::sinf(h as f32 * 0.01);
            rls.update(&Vector2::new(u, u * u), 3.0 * u, 0.999);
        }
        // 0.5·0.9^h < 2⁻²⁶ from h = 165 on; 0.5·0.9^h ≥ 10⁻³ for h ≤ 58.
        assert_eq!(over, Some(165));
        assert_eq!(capped, 59);
    }

    #[test]
    fn a_held_parameter_stays_put_and_the_rest_converges() {
        // y = 3·u + 0·(2u): the second regressor is collinear with the first (a constant
        // speed times the first), so unheld RLS splits the gain arbitrarily between them.
        let mut free = Rls::<2>::try_new(&cfg(0.999)).unwrap();
        let mut held = Rls::<2>::try_new(&cfg(0.999)).unwrap();
        held.hold(1, 0.0);
        for h in 0..5000 {
            let u = 0.5 + 0.4 * libm::sinf(h as f32 * 0.01);
            let phi = Vector2::new(u, 2.0 * u);
            free.update(&phi, 3.0 * u, 0.999);
            held.update(&phi, 3.0 * u, 0.999);
        }
        assert_eq!(held.theta()[1], 0.0);
        assert!((held.theta()[0] - 3.0).abs() < 1e-4, "{:?}", held.theta());
        assert!(held.is_held(1) && !held.is_held(0));
        assert_eq!(held.covariance()[(0, 1)], 0.0);
        assert_eq!(held.standard_errors()[1], 0.0);
        // Unheld: the sum is right, the split is not.
        assert!((free.theta()[0] + 2.0 * free.theta()[1] - 3.0).abs() < 1e-3);
        assert!(free.theta()[1].abs() > 0.1, "{:?}", free.theta());
        // The hold survives a reset.
        held.reset();
        assert!(held.is_held(1) && held.theta()[1] == 0.0);
    }

    #[test]
    fn converges_to_exact_linear_model() {
        let mut rls = Rls::<2>::try_new(&cfg(1.0)).unwrap();
        for h in 0..200 {
            let x = (h as f32 * 0.1).sin();
            let phi = Vector2::new(1.0, x);
            rls.update(&phi, 3.0 - 2.0 * x, 1.0);
        }
        assert!((rls.theta()[0] - 3.0).abs() < 1e-4, "{:?}", rls.theta());
        assert!((rls.theta()[1] + 2.0).abs() < 1e-4, "{:?}", rls.theta());
    }

    #[test]
    fn forgetting_tracks_a_parameter_jump() {
        let mut rls = Rls::<1>::try_new(&cfg(0.95)).unwrap();
        let phi = SVector::<f32, 1>::new(1.0);
        for _ in 0..200 {
            rls.update(&phi, 1.0, 0.95);
        }
        for _ in 0..200 {
            rls.update(&phi, 5.0, 0.95);
        }
        assert!((rls.theta()[0] - 5.0).abs() < 1e-3);
    }

    #[test]
    fn covariance_does_not_wind_up_without_excitation() {
        let mut rls = Rls::<2>::try_new(&cfg(0.9)).unwrap();
        let zero = Vector2::zeros();
        let mut bounded = false;
        for _ in 0..100_000 {
            let u = rls.update(&zero, 0.0, 0.9);
            bounded |= u.status.contains(Status::COVARIANCE_BOUNDED);
            assert!(rls.covariance().trace() <= 2.0e4 * 1.0001);
        }
        assert!(bounded);
    }

    #[test]
    fn non_finite_input_skips_the_update() {
        let mut rls = Rls::<2>::try_new(&cfg(1.0)).unwrap();
        rls.update(&Vector2::new(1.0, 2.0), 3.0, 1.0);
        let before = rls;
        let u = rls.update(&Vector2::new(f32::NAN, 2.0), 3.0, 1.0);
        assert_eq!(u.status, Status::NON_FINITE_INPUT);
        assert_eq!(rls, before);
        let u = rls.update(&Vector2::new(1.0, 2.0), f32::INFINITY, 1.0);
        assert_eq!(u.status, Status::NON_FINITE_INPUT);
        assert_eq!(rls, before);
    }

    #[test]
    fn weighted_update_matches_batch_weighted_least_squares() {
        // Noisy data: the weighted RLS (β = 1) must equal the batch weighted LS solution.
        let mut rls = Rls::<2>::try_new(&RlsConfig {
            initial_covariance: 1.0e6,
            ..cfg(1.0)
        })
        .unwrap();
        let mut a = nalgebra::Matrix2::<f64>::zeros();
        let mut b = nalgebra::Vector2::<f64>::zeros();
        for h in 0..500 {
            let x = (h as f32 * 0.37).sin() * 2.0;
            let noise = ((h * 7919) % 101) as f32 / 101.0 - 0.5;
            let y = 1.0 + 0.5 * x + noise;
            let w = 1.0 + (h % 5) as f32;
            rls.update_weighted(&Vector2::new(1.0, x), y, 1.0, w);
            let phi = nalgebra::Vector2::new(1.0, x as f64);
            a += phi * phi.transpose() * w as f64;
            b += phi * (y * w) as f64;
        }
        let exact = a.try_inverse().unwrap() * b;
        assert!((rls.theta()[0] as f64 - exact[0]).abs() < 1e-3);
        assert!((rls.theta()[1] as f64 - exact[1]).abs() < 1e-3);
    }

    #[test]
    fn adaptive_forgetting_follows_eq_24() {
        let a = AdaptiveForgetting {
            alpha1: 0.05,
            alpha2: 10.0,
            alpha3: 20.0,
        };
        a.validate().unwrap();
        // Small error: β ≈ 1 − α1·(1/2 − atan(20)/π) ≈ 1 − 0.05·0.0159.
        assert!(
            (a.beta(0.0) - (1.0 - 0.05 * (0.5 - libm::atanf(20.0) / core::f32::consts::PI))).abs()
                < 1e-6
        );
        // Large error: β → 1 − α1.
        assert!((a.beta(1.0e6) - 0.95).abs() < 1e-4);
        // Threshold at α3/α2 = 2 N: β is halfway.
        assert!((a.beta(2.0) - 0.975).abs() < 1e-6);
    }

    #[test]
    fn invalid_configs_name_their_field() {
        let e = RlsConfig {
            initial_covariance: 0.0,
            ..RlsConfig::default()
        }
        .validate()
        .unwrap_err();
        assert!(matches!(
            e,
            ConfigError::OutOfRange {
                field: "initial_covariance",
                ..
            }
        ));
        let e = Forgetting::Fixed { beta: 1.5 }.validate().unwrap_err();
        assert!(matches!(e, ConfigError::OutOfRange { field: "beta", .. }));
        let e = Forgetting::Adaptive(AdaptiveForgetting {
            alpha1: 0.5,
            alpha2: 1.0,
            alpha3: 0.0,
        })
        .validate()
        .unwrap_err();
        assert!(matches!(
            e,
            ConfigError::Inconsistent {
                field: "alpha3",
                ..
            }
        ));
    }
}
