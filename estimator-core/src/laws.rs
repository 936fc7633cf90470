//! The contact laws, defined once and generic over the float type: f32 for the 1 kHz
//! loop and the firmware, f64 for the host's batch fits. The models of [`crate::models`],
//! the plant, the online estimators' regressors and the host's whole-record fits all call
//! these functions, so a law cannot differ between simulation, online estimation and the
//! batch diagnosis.
//!
//! Conventions: δ \[m\] is the penetration (≤ 0 out of contact), δ̇ \[m/s\] its rate, forces
//! in N. Every law is 0 for δ ≤ 0.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// The float operations the laws need (implemented with libm for f32 and f64, as in a
/// `no_std` build).
pub trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// From an f64 constant.
    fn of(value: f64) -> Self;
    /// eˣ.
    fn exp(self) -> Self;
    /// eˣ − 1, accurate near 0.
    fn exp_m1(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// The larger of the two.
    fn max(self, other: Self) -> Self {
        if self > other {
            self
        } else {
            other
        }
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    fn of(value: f64) -> Self {
        value as f32
    }
    fn exp(self) -> Self {
        libm::expf(self)
    }
    fn exp_m1(self) -> Self {
        libm::expm1f(self)
    }
    fn ln(self) -> Self {
        libm::logf(self)
    }
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    fn of(value: f64) -> Self {
        value
    }
    // f64 is the host's batch arithmetic (the firmware computes in f32): with the `std`
    // feature it uses the platform's libm, several times faster than the `libm` crate's
    // portable one on the front end's many power laws; results agree to an ulp or so.
    fn exp(self) -> Self {
        #[cfg(feature = "std")]
        return f64::exp(self);
        #[cfg(not(feature = "std"))]
        return libm::exp(self);
    }
    fn exp_m1(self) -> Self {
        #[cfg(feature = "std")]
        return f64::exp_m1(self);
        #[cfg(not(feature = "std"))]
        return libm::expm1(self);
    }
    fn ln(self) -> Self {
        #[cfg(feature = "std")]
        return f64::ln(self);
        #[cfg(not(feature = "std"))]
        return libm::log(self);
    }
}

/// δⁿ for δ > 0, 0 otherwise: the power law of Hunt-Crossley (eq. 3) and of the QLV
/// elastic response (eqs. 12/14, with n = q + 1). Computed as e^{n·ln δ}.
#[inline]
pub fn power_law<T: Real>(depth_m: T, exponent: T) -> T {
    if depth_m > T::ZERO {
        (exponent * depth_m.ln()).exp()
    } else {
        T::ZERO
    }
}

/// [`power_law`] given ln δ instead of δ (`None` for δ ≤ 0): e^{n·ln δ}, for a caller that
/// evaluates many exponents at the same depths (the batch fits' exponent searches).
#[inline]
pub fn power_law_of_ln<T: Real>(ln_depth: Option<T>, exponent: T) -> T {
    match ln_depth {
        Some(l) => (exponent * l).exp(),
        None => T::ZERO,
    }
}

/// ln δ for δ > 0, `None` otherwise: the argument [`power_law_of_ln`] takes.
#[inline]
pub fn ln_depth<T: Real>(depth_m: T) -> Option<T> {
    (depth_m > T::ZERO).then(|| depth_m.ln())
}

/// (e^{bδ} − 1)/b \[m\] for δ > 0, 0 otherwise: the QLV exponential elastic response
/// (eqs. 11/13) per unit m, i.e. F_e = m·exponential_law(δ, b). Tends to δ as b → 0.
#[inline]
pub fn exponential_law<T: Real>(depth_m: T, rate_per_m: T) -> T {
    if depth_m <= T::ZERO {
        return T::ZERO;
    }
    let x = rate_per_m * depth_m;
    if x * x < T::of(1e-12) {
        depth_m * (T::ONE + T::of(0.5) * x)
    } else {
        x.exp_m1() / rate_per_m
    }
}

/// Kelvin-Voigt, eq. (1): κ·δ + λ·δ̇ for δ > 0 \[N\], unclamped (see [`unilateral`]).
#[inline]
pub fn kelvin_voigt<T: Real>(depth_m: T, rate_m_per_s: T, kappa: T, lambda: T) -> T {
    if depth_m > T::ZERO {
        kappa * depth_m + lambda * rate_m_per_s
    } else {
        T::ZERO
    }
}

/// Hunt-Crossley, eq. (3): k·δⁿ + λ·δ^q·δ̇ for δ > 0 \[N\], unclamped (see [`unilateral`]).
/// With q = n one power serves both terms: δⁿ·(k + λ·δ̇).
#[inline]
pub fn hunt_crossley<T: Real>(depth_m: T, rate_m_per_s: T, k: T, lambda: T, n: T, q: T) -> T {
    if depth_m <= T::ZERO {
        return T::ZERO;
    }
    let ln_d = depth_m.ln();
    let elastic = (n * ln_d).exp();
    let damping = if q == n { elastic } else { (q * ln_d).exp() };
    k * elastic + lambda * damping * rate_m_per_s
}

/// The unilateral contact: a material can push but not pull, F ≥ 0.
#[inline]
pub fn unilateral<T: Real>(force_n: T) -> T {
    force_n.max(T::ZERO)
}

/// Exact first-order-hold discretisation of ẋ = −a·x + b·u over one sample T with u
/// linear from u0 to u1, written in deviation form so that the fixed point x = (b/a)·u is
/// exact in f32 (no 1 − e^{−aT} cancellation):
///
/// x1 = x0 + (1 − e^{−aT})·((b/a)·u0 − x0) + b·(G1/T)·(u1 − u0),
/// G1/T = 1/a − (1 − e^{−aT})/(a²T).
///
/// Returns (e^{−aT}, 1 − e^{−aT}, G1/T \[s\]) for a \[1/s\] > 0 and T \[s\] > 0. Used by the
/// Zener and QLV models (the relaxation modes of eq. 10/15).
pub fn first_order_hold<T: Real>(a: T, t: T) -> (T, T, T) {
    let at = a * t;
    let one_minus_e = -(-at).exp_m1();
    let g1_over_t = if at < T::of(1.0e-3) {
        // Series: G1/T = T·(1/2 − aT/6 + (aT)²/24).
        t * (T::of(0.5) - at / T::of(6.0) + at * at / T::of(24.0))
    } else {
        (T::ONE - one_minus_e / at) / a
    };
    (T::ONE - one_minus_e, one_minus_e, g1_over_t)
}

/// Coefficients of [`relaxing_step`] for a mode of rate ν \[1/s\] ≥ 0 over a sample
/// T \[s\] > 0: (1 − e^{−νT}, (1 − e^{−νT})/(νT)), from [`first_order_hold`]; (0, 1), the
/// limit, at ν = 0.
pub fn relaxation_coefficients<T: Real>(rate_per_s: T, sample_time_s: T) -> (T, T) {
    let (_, one_minus_e, _) = first_order_hold(rate_per_s, sample_time_s);
    // ν = 0 (no relaxation): the limit of the gain is 1 (z follows F_e), not 0/0.
    let gain = if one_minus_e != T::ZERO {
        one_minus_e / (rate_per_s * sample_time_s)
    } else {
        T::ONE
    };
    (one_minus_e, gain)
}

/// One sample of a relaxing state z' = −ν·z + dF_e/dt (one mode of the reduced relaxation
/// function, QLV eqs. 9-10; the relaxing force is c·z), exact for F_e linear over the
/// sample: z1 = z0 + ((1 − e^{−νT})/(νT)·ΔF_e − (1 − e^{−νT})·z0), with
/// (`one_minus_decay`, `gain`) from [`relaxation_coefficients`] and ΔF_e \[N\] the change
/// of the elastic force over the sample. Storing 1 − e^{−νT} (not e^{−νT}) keeps a slow
/// pole exact in f32. The QLV model, the hidden-effect plant and the host's batch fits
/// all step their relaxation modes here.
#[inline]
pub fn relaxing_step<T: Real>(z: T, delta_elastic_n: T, one_minus_decay: T, gain: T) -> T {
    z + (gain * delta_elastic_n - one_minus_decay * z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f32_and_f64_agree() {
        for &(d, v) in &[(1e-3f64, 0.01f64), (4e-3, -0.02), (0.0, 1.0), (-1e-3, 0.5)] {
            let hc64 = hunt_crossley(d, v, 4.6e4, 2.8e5, 1.2, 1.2);
            let hc32 = hunt_crossley(d as f32, v as f32, 4.6e4, 2.8e5, 1.2, 1.2);
            assert!((f64::from(hc32) - hc64).abs() <= 1e-5 * hc64.abs().max(1.0));
            assert!((power_law(d, 1.0) - d.max(0.0)).abs() < 1e-15);
        }
        assert!((exponential_law(1e-3f64, 1e-9) - 1e-3).abs() < 1e-15);
        assert!((exponential_law(2e-3f64, 500.0) - (1.0f64.exp() - 1.0) / 500.0).abs() < 1e-15);
        assert_eq!(unilateral(-2.0f64), 0.0);
    }

    #[test]
    fn a_mode_of_rate_zero_holds_its_state_and_follows_the_elastic_force() {
        assert_eq!(relaxation_coefficients(0.0f64, 1e-3), (0.0, 1.0));
        assert_eq!(relaxation_coefficients(0.0f32, 1e-3), (0.0, 1.0));
        let (omd, gain) = relaxation_coefficients(2.0f64, 1e-3);
        assert!((gain - omd / 2e-3).abs() < 1e-15 && gain < 1.0);
        assert_eq!(relaxing_step(0.5f64, 0.25, 0.0, 1.0), 0.75);
    }
}
