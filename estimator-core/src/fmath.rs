//! `f32::min`, `f32::max`, `libm::logf` and `libm::expf` inline, with the same results
//! (`exp`: but for |x| ≤ 2⁻¹³).
//!
//! On the Cortex-M4F (Armv7E-M, no VMINNM/VMAXNM) `f32::min` and `f32::max` are calls to
//! `fminf`/`fmaxf`, about 15 instructions each with the call; the 1 kHz path makes a dozen.
//! [`min`] and [`max`] are the bodies of those functions (libm's `generic::fmin`/`fmax`,
//! NaN payloads aside): a NaN argument yields the other one.
//!
//! [`ln`] and [`exp`] are libm's `logf` and `expf` (FreeBSD's `e_logf.c`/`e_expf.c`, the
//! same constants and the same operations in the same order) for the arguments the 1 kHz
//! path meets: a positive normal ln argument, |x| < 87.3 for exp (no overflow, no subnormal
//! result; e^x·2^k then needs no `scalbnf`, a call of its own). Other arguments go to
//! libm itself. Inline, they save the calls, the special-case tests and `scalbnf`:
//! ≈ 54 → 40 instructions for `logf` and ≈ 57 → 40 for `expf` under QEMU. [`ln`] is
//! bit-identical to `logf`; [`exp`] also reduces its argument in one step instead of
//! libm's four cases (≈ 18 instructions fewer again: the Hunt-Crossley SI conversion, one
//! `exp`, went from 86 to 68), and differs from `expf` only where libm returns 1 + x (the
//! tests compare both on every 61st f32 bit pattern).
//!
//! The approximations are Sun Microsystems' (copyright 1993, "Permission to use, copy,
//! modify, and distribute this software is freely granted, provided that this notice is
//! preserved"), converted to float by Ian Lance Taylor, Cygnus Support.

/// The smaller of `x` and `y`; `y` when they are equal, the non-NaN one if one is NaN.
#[inline(always)]
pub(crate) fn min(x: f32, y: f32) -> f32 {
    if y.is_nan() || x < y {
        x
    } else {
        y
    }
}

/// [`min`] for arguments known to be finite (no NaN test): the same result.
#[inline(always)]
pub(crate) fn min_finite(x: f32, y: f32) -> f32 {
    if x < y {
        x
    } else {
        y
    }
}

/// The larger of `x` and `y`; `x` when they are equal, the non-NaN one if one is NaN.
#[inline(always)]
pub(crate) fn max(x: f32, y: f32) -> f32 {
    if x.is_nan() || x < y {
        y
    } else {
        x
    }
}

/// [`max`] for arguments known not to be NaN (no NaN test): the same result.
#[inline(always)]
pub(crate) fn max_finite(x: f32, y: f32) -> f32 {
    if x < y {
        y
    } else {
        x
    }
}

/// The natural logarithm of `x`: bit-identical to `libm::logf(x)` for every x.
#[inline(always)]
pub(crate) fn ln(x: f32) -> f32 {
    const LN2_HI: f32 = f32::from_bits(0x3f31_7180); // 6.9313812256e-1
    const LN2_LO: f32 = f32::from_bits(0x3717_f7d1); // 9.0580006145e-6
    const LG1: f32 = f32::from_bits(0x3f2a_aaaa); // 0.66666662693
    const LG2: f32 = f32::from_bits(0x3ecc_ce13); // 0.40000972152
    const LG3: f32 = f32::from_bits(0x3e91_e9ee); // 0.28498786688
    const LG4: f32 = f32::from_bits(0x3e78_9e26); // 0.24279078841
    let ix = x.to_bits();
    // Positive normal and finite; zero, subnormal, negative, infinite and NaN to libm.
    if ix.wrapping_sub(0x0080_0000) >= 0x7f80_0000 - 0x0080_0000 {
        return libm::logf(x);
    }
    // x = 2^k·(1 + f), 1 + f in [√2/2, √2).
    let ix = ix + (0x3f80_0000 - 0x3f35_04f3);
    let k = ((ix >> 23) as i32) - 0x7f;
    let f = f32::from_bits((ix & 0x007f_ffff) + 0x3f35_04f3) - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * LG4);
    let t2 = z * (LG1 + w * LG3);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    let dk = k as f32;
    s * (hfsq + r) + dk * LN2_LO - hfsq + f + dk * LN2_HI
}

/// e^`x`: `libm::expf(x)` bit for bit except for |x| ≤ 2⁻¹³, where libm returns 1 + x
/// and this the full approximation (one ulp apart at most, both less than an ulp from e^x;
/// `exp_is_libm_but_for_tiny_arguments`).
///
/// libm's `expf` (FreeBSD's `e_expf.c`): x = k·ln2 + r with ln2 split in a high part
/// (k·ln2_hi exact) and a low one, e^r from the same rational approximation and constants
/// in the same order. Only the reduction differs: k rounded to nearest in one step (adding
/// and subtracting 1.5·2²³, which also leaves k in the low bits of the sum, ready for
/// 2^k) instead of libm's four cases (|x| ≤ 2⁻¹³, ≤ ln2/2, ≤ 1.5·ln2, else truncation of
/// x/ln2 ± 1/2).
/// |x| ≥ 87.33655 (overflow, a subnormal result or NaN) goes to libm itself.
#[inline(always)]
pub(crate) fn exp(x: f32) -> f32 {
    const LN2_HI: f32 = f32::from_bits(0x3f31_7200); // 6.9314575195e-1
    const LN2_LO: f32 = f32::from_bits(0x35bf_be8e); // 1.4286067653e-6
    const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b); // 1.4426950216
    const P1: f32 = f32::from_bits(0x3e2a_aa8f); // 1.6666625440e-1
    const P2: f32 = f32::from_bits(0xbb35_5215); // -2.7667332906e-3

    // 1.5·2²³: x/ln2 + this is rounded to an integer, whose low bits are k.
    const ROUND: f32 = 12_582_912.0;
    if x.to_bits() & 0x7fff_ffff >= 0x42ae_ac50 {
        return libm::expf(x);
    }
    let t = x * INV_LN2 + ROUND;
    let kf = t - ROUND;
    let hi = x - kf * LN2_HI; // k·ln2_hi is exact for |k| ≤ 126
    let lo = kf * LN2_LO;
    let r = hi - lo;
    let xx = r * r;
    let c = r - xx * (P1 + xx * P2);
    let y = 1.0 + (r * c / (2.0 - c) - lo + hi);
    // 2^k (normal: |k| ≤ 126 here): k's two's complement sits in the low bits of t's,
    // and ROUND's own low bits are 0, so t's bits shifted to the exponent field are k's.
    y * f32::from_bits((t.to_bits() << 23).wrapping_add(0x3f80_0000))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_results_as_the_std_functions() {
        let values = [
            f32::NAN,
            f32::NEG_INFINITY,
            -1.5,
            -0.0,
            0.0,
            1.0e-40,
            2.0,
            f32::INFINITY,
        ];
        for x in values {
            for y in values {
                let same = |a: f32, b: f32| (a.is_nan() && b.is_nan()) || a == b;
                assert!(same(min(x, y), x.min(y)), "min({x}, {y})");
                assert!(same(max(x, y), x.max(y)), "max({x}, {y})");
                if !x.is_nan() && !y.is_nan() {
                    assert!(same(min_finite(x, y), x.min(y)), "min_finite({x}, {y})");
                    assert!(same(max_finite(x, y), x.max(y)), "max_finite({x}, {y})");
                }
            }
        }
    }

    /// Every 61st bit pattern (70 million of both signs, NaNs and infinities included)
    /// and the edges of the fast paths.
    fn patterns() -> impl Iterator<Item = f32> {
        let edges = [
            0x0000_0000u32,
            0x0000_0001,
            0x007f_ffff,
            0x0080_0000,
            0x3f80_0000,
            0x7f7f_ffff,
            0x7f80_0000,
            0x3900_0000,
            0x3900_0001,
            0x3eb1_7218,
            0x3eb1_7219,
            0x3f85_1592,
            0x3f85_1593,
            0x42ae_ac4f,
            0x42ae_ac50,
        ];
        (0..=u32::MAX)
            .step_by(61)
            .chain(edges.into_iter().flat_map(|b| [b, b | 0x8000_0000]))
            .map(f32::from_bits)
    }

    #[test]
    fn ln_is_libm_bit_for_bit() {
        for x in patterns() {
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            assert!(same(ln(x), libm::logf(x)), "ln({x:e}) = {:e}", ln(x));
        }
    }

    #[test]
    fn exp_is_libm_but_for_tiny_arguments() {
        let mut differ = 0u32;
        for x in patterns() {
            let (a, b) = (exp(x), libm::expf(x));
            if a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()) {
                continue;
            }
            differ += 1;
            // Only where libm returns 1 + x (|x| ≤ 2⁻¹³, 20 059 of the 70 million
            // patterns): one ulp apart at most, and faithfully rounded (less than an ulp
            // from e^x, as 1 + x is).
            assert!(x.abs() <= 1.220_703_1e-4, "exp({x:e}) = {a:e}, libm {b:e}");
            assert!(
                a.to_bits().abs_diff(b.to_bits()) <= 1,
                "exp({x:e}) = {a:e}, libm {b:e}"
            );
            let exact = libm::exp(f64::from(x));
            let ulp = f64::from(f32::EPSILON) * if x < 0.0 { 0.5 } else { 1.0 };
            assert!(
                (f64::from(a) - exact).abs() < ulp,
                "exp({x:e}) = {a:e}, libm {b:e}, e^x {exact:e}"
            );
        }
        assert!(differ > 0, "the tiny-argument case was not reached");
    }
}
