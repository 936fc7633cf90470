//! `f32::min`, `f32::max`, `libm::logf` and `libm::expf` with the same results, inline.
//!
//! On the Cortex-M4F (Armv7E-M, no VMINNM/VMAXNM) `f32::min` and `f32::max` are calls to
//! `fminf`/`fmaxf`, about 15 instructions each with the call; the 1 kHz path makes a dozen.
//! [`min`] and [`max`] are the bodies of those functions (libm's `generic::fmin`/`fmax`,
//! NaN payloads aside): a NaN argument yields the other one.
//!
//! [`ln`] and [`exp`] are libm's `logf` and `expf` (FreeBSD's `e_logf.c`/`e_expf.c`, the
//! same constants and the same operations in the same order, so bit-identical results:
//! the tests compare them on every 61st f32 bit pattern) for the arguments the 1 kHz path
//! meets: a positive normal ln argument, |x| < 87.3 for exp (no overflow, no subnormal
//! result; e^x·2^k then needs no `scalbnf`, a call of its own). Other arguments go to
//! libm itself. Inline, they save the calls, the special-case tests and `scalbnf`:
//! ≈ 54 → 40 instructions for `logf` and ≈ 57 → 40 for `expf` under QEMU.
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

/// e^`x`: bit-identical to `libm::expf(x)` for every x.
#[inline(always)]
pub(crate) fn exp(x: f32) -> f32 {
    const LN2_HI: f32 = f32::from_bits(0x3f31_7200); // 6.9314575195e-1
    const LN2_LO: f32 = f32::from_bits(0x35bf_be8e); // 1.4286067653e-6
    const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b); // 1.4426950216
    const P1: f32 = f32::from_bits(0x3e2a_aa8f); // 1.6666625440e-1
    const P2: f32 = f32::from_bits(0xbb35_5215); // -2.7667332906e-3
    let hx = x.to_bits() & 0x7fff_ffff;
    let negative = x.to_bits() >> 31 != 0;
    // |x| ≥ 87.33655 (overflow, a subnormal result or NaN) and |x| ≤ 2^-14 to libm.
    if hx >= 0x42ae_ac50 || hx <= 0x3900_0000 {
        return libm::expf(x);
    }
    let (k, hi, lo, r) = if hx > 0x3eb1_7218 {
        // |x| > ln2/2: x = k·ln2 + r, |r| ≤ ln2/2.
        let k = if hx > 0x3f85_1592 {
            (INV_LN2 * x + if negative { -0.5 } else { 0.5 }) as i32
        } else if negative {
            -1
        } else {
            1
        };
        let kf = k as f32;
        let hi = x - kf * LN2_HI; // k·ln2_hi is exact here
        let lo = kf * LN2_LO;
        (k, hi, lo, hi - lo)
    } else {
        (0, x, 0.0, x)
    };
    let xx = r * r;
    let c = r - xx * (P1 + xx * P2);
    let y = 1.0 + (r * c / (2.0 - c) - lo + hi);
    // 2^k is normal: |k| ≤ 126 for |x| < 87.34, where `scalbnf` multiplies by it alone.
    y * f32::from_bits(((0x7f + k) as u32) << 23)
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

    #[test]
    fn ln_and_exp_are_libm_bit_for_bit() {
        // Every 61st bit pattern (70 million of both signs, NaNs and infinities included)
        // and the edges of the fast paths.
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
        let patterns = (0..=u32::MAX)
            .step_by(61)
            .chain(edges.iter().flat_map(|&b| [b, b | 0x8000_0000]));
        for bits in patterns {
            let x = f32::from_bits(bits);
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            assert!(same(ln(x), libm::logf(x)), "ln({x:e}) = {:e}", ln(x));
            assert!(same(exp(x), libm::expf(x)), "exp({x:e}) = {:e}", exp(x));
        }
    }
}
