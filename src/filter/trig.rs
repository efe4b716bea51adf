//! Sine and cosine for the filtered rules: one argument reduction for both, the kernel
//! polynomials inlined. The `Sin` and `|sin|` rules take up to four of these a lane (the mean's
//! angle, the footprint widths' for the series' steps), and libm's `sin`, `cos` and `sincos`,
//! each a call with its own range checks and reduction, were about a seventh of a filtered
//! marble's time (`perf`, `eval/filtered/seed003_marble` at side 1/8). Hand-written because the
//! crates that vectorise these (`sleef`, `libm`) either need nightly SIMD or are libm's same
//! per-call algorithm; this is fdlibm's reduction and kernels, kept to the arguments the rules
//! meet, libm for the rest.

use std::f64::consts::FRAC_2_PI;

/// 1.5 · 2⁵²: `(y + ROUNDER) − ROUNDER` is `y` rounded to an integer for `|y| < 2⁵¹`.
pub(crate) const ROUNDER: f64 = 6_755_399_441_055_744.0;

/// Past this magnitude the three-part reduction below loses bits: libm reduces instead.
/// (`n · PIO2_1` is exact while `n < 2²⁰`, fdlibm's bound for its medium-size reduction.)
const REDUCE_LIMIT: f64 = 1.0e6;

/// π/2 in three parts of 33 significant bits each (fdlibm's `pio2_1`, `pio2_2`, `pio2_3`), so
/// that `n · PIO2_k` is exact for `|n| < 2²⁰`, and the tail `PIO2_3T`.
const PIO2_1: f64 = 1.570_796_326_734_125_6;
const PIO2_2: f64 = 6.077_100_506_303_966e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_5e-21;
const PIO2_3T: f64 = 8.478_427_660_368_9e-32;

/// fdlibm's `__kernel_sin` coefficients (|error| < 2⁻⁵⁸ on [−π/4, π/4]).
const S: [f64; 6] = [
    -1.666_666_666_666_663_2e-1,
    8.333_333_333_322_49e-3,
    -1.984_126_982_985_795e-4,
    2.755_731_370_707_006_8e-6,
    -2.505_076_025_340_686_3e-8,
    1.589_690_995_211_55e-10,
];

/// fdlibm's `__kernel_cos` coefficients.
const C: [f64; 6] = [
    4.166_666_666_666_66e-2,
    -1.388_888_888_887_411e-3,
    2.480_158_728_947_673e-5,
    -2.755_731_435_139_066_3e-7,
    2.087_572_321_298_175e-9,
    -1.135_964_755_778_819_5e-11,
];

/// `(sin x, cos x)`, within one unit in the last place of 1 of libm's for `|x| < 10⁶` (tested:
/// half a unit at most); libm's own beyond, and for NaN and infinities.
#[inline]
pub(crate) fn sin_cos(x: f64) -> (f64, f64) {
    if x.is_nan() || x.abs() >= REDUCE_LIMIT {
        return x.sin_cos();
    }
    // n = x · 2/π rounded to the nearest integer (ties to even) by adding and taking away
    // 1.5 · 2⁵²: exact for |x · 2/π| < 2⁵¹, no libm `round` call.
    let n = (x * FRAC_2_PI + ROUNDER) - ROUNDER;
    // r = x − n π/2: the products n · PIO2_1 and n · PIO2_2 are exact (|n| < 2²⁰), so r is
    // off by a few units of its own last place, not of x's.
    let r = ((x - n * PIO2_1) - n * PIO2_2) - n * (PIO2_3 + PIO2_3T);
    let (s, c) = (kernel_sin(r).to_bits(), kernel_cos(r).to_bits());
    // The quadrant n mod 4 without branches (the angles a rule meets fall in any quadrant, so
    // a branch on it cannot be predicted): odd quadrants swap the two, quadrants 2 and 3
    // negate the sine, 1 and 2 the cosine.
    let q = n as i64 as u64;
    let swap = 0u64.wrapping_sub(q & 1);
    let (a, b) = ((s & !swap) | (c & swap), (c & !swap) | (s & swap));
    let sign = |quadrant: u64| (quadrant & 2) << 62;
    (
        f64::from_bits(a ^ sign(q)),
        f64::from_bits(b ^ sign(q.wrapping_add(1))),
    )
}

/// `sin x` ([`sin_cos`]'s first value).
#[inline]
pub(crate) fn sin(x: f64) -> f64 {
    sin_cos(x).0
}

/// `sin r` for `|r| ≤ π/4` (fdlibm's `__kernel_sin` without a tail).
#[inline]
fn kernel_sin(r: f64) -> f64 {
    let z = r * r;
    let tail = S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])));
    r + (z * r) * (S[0] + z * tail)
}

/// `cos r` for `|r| ≤ π/4` (fdlibm's `__kernel_cos` without a tail): `1 − r²/2` is summed as
/// `(1 − q) − (r²/2 − q)` with `q` of few bits (`|r|/4` with its low 32 bits cleared), so that
/// `1 − q` is exact and no bit of the leading term is lost. fdlibm takes `1 − (r²/2 −
/// r² p)` below 0.3 and `q = 0.28125` past 0.78125; the one form serves the whole range
/// without its branches (within half a unit of libm, the test below).
#[inline]
fn kernel_cos(r: f64) -> f64 {
    let z = r * r;
    let p = z * (C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5])))));
    let q = f64::from_bits((r.abs() / 4.0).to_bits() & 0xffff_ffff_0000_0000);
    (1.0 - q) - ((0.5 * z - q) - z * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against libm's `sin` and `cos` (correctly rounded or within one unit on glibc): at most
    /// one unit in the last place of 1 apart for every argument, over the whole reduced range
    /// and past it, at quadrant boundaries, and the special values.
    #[test]
    fn sin_cos_is_libms_to_one_unit() {
        let ulp = f64::EPSILON;
        let mut worst: f64 = 0.0;
        let mut check = |x: f64| {
            let (s, c) = sin_cos(x);
            let (ls, lc) = x.sin_cos();
            if ls.is_nan() {
                assert!(s.is_nan() && c.is_nan(), "{x}");
                return;
            }
            let err = (s - ls).abs().max((c - lc).abs()) / ulp;
            worst = worst.max(err);
            assert!(err <= 1.0, "x = {x:e}: ({s}, {c}) against ({ls}, {lc})");
            assert_eq!(sin(x), s);
        };
        // A log-spaced sweep of both signs, 1e-9 to 2e6 (past the reduction's limit).
        let mut x = 1e-9;
        while x < 2e6 {
            check(x);
            check(-x);
            x *= 1.000_37;
        }
        // A dense linear sweep over a few periods, and the multiples of π/4 (quadrant and
        // kernel boundaries) with their neighbours.
        for i in -20_000..=20_000 {
            check(f64::from(i) * 1.3e-3);
        }
        for k in -4000..=4000 {
            let x = f64::from(k) * std::f64::consts::FRAC_PI_4;
            for d in [-2i64, -1, 0, 1, 2] {
                check(f64::from_bits((x.to_bits() as i64 + d) as u64));
            }
        }
        for x in [
            0.0,
            -0.0,
            0.3,
            0.781_25,
            0.785,
            1e6 - 1.0,
            1e6,
            f64::MAX,
            f64::MIN_POSITIVE,
        ] {
            check(x);
        }
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "{x}");
        }
        assert!(worst > 0.0, "the sweep compared something");
    }
}
