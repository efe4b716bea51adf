//! Seamless tiling: noise that repeats exactly with a period of whole cells along each axis.
//!
//! A coordinate is first reduced into its period, `x' = (c mod P) + f` with `c = floor(x)` and
//! `f = x - c` split exactly as the lattice step splits them, so `x + P` (when exact) reduces to
//! the same `x'` bit for bit, and inside `[0, P)` nothing changes (`x' = x`). The noise is then
//! evaluated at `x'`, except that in a period's last cell (`c mod P = P - 1`) the upper corner
//! is cell 0 of the next period, so it takes cell 0's hash, not cell P's: the noise is
//! continuous across the seam. Cellular noise wraps the neighbour cells it searches the same
//! way; white noise needs only the reduction.

use super::lattice::TWO52;

/// A tiling period per axis, in cells (the checker allows 1 to 2^20; fractal octaves multiply
/// it by `lacunarity^i`).
pub type Period = [u64; 3];

/// Periods beyond this are no periods at all for f64 coordinates (every representable
/// coordinate beyond 2^52 is an integer, and the reduction would be the identity anyway).
const LIMIT: u64 = 1 << 52;

/// 2^51: below it, [`reduce_fast`] applies.
pub(super) const FAST: f64 = 2_251_799_813_685_248.0;

/// `x` reduced into `[0, P)`, and its cell index there (`c mod P`); a non-finite `x` is kept
/// as it is (the noise is NaN), and so is every `x` when `P` is beyond 2^52.
#[inline(always)]
pub(super) fn reduce(x: f64, period: u64) -> (f64, u64) {
    if period == 0 || period > LIMIT {
        return (x, u64::MAX);
    }
    if x.abs() < FAST {
        let (q, m) = reduce_fast(x, period as f64, 1.0 / period as f64);
        (q, m as u64)
    } else {
        reduce_cold(x, period)
    }
}

/// [`reduce`] for |x| < 2^51, branch-free (the batch kernels run it over lanes), `inverse`
/// being `1 / P` rounded: with `c = floor(x)`, `c · inverse` is within 2^-52 |c / P| < 1/2 of
/// `c / P`, so `k = floor(c · inverse)` is `floor(c / P)` or one off, and `m = c - P k`, exact
/// (every product and difference is an integer below 2^52), is `c mod P` after at most one
/// correction by P either way; then
/// `x' = m + (x - c)`, which inside `[0, P)` is `x` itself.
#[inline(always)]
pub(super) fn reduce_fast(x: f64, period: f64, inverse: f64) -> (f64, f64) {
    let c = x.floor();
    let m = c - period * (c * inverse).floor();
    let m = if m < 0.0 { m + period } else { m };
    let m = if m >= period { m - period } else { m };
    (m + (x - c), m)
}

/// [`reduce`] for |x| >= 2^51 and non-finite x: the same numbers through integer or `fmod`
/// arithmetic (an |x| >= 2^52 is an integer already).
#[cold]
#[inline(never)]
fn reduce_cold(x: f64, period: u64) -> (f64, u64) {
    if x.abs() < TWO52 {
        let c = x.floor();
        let m = (c as i64).rem_euclid(period as i64);
        (m as f64 + (x - c), m as u64)
    } else if x.is_finite() {
        // `%` (fmod) is exact.
        let m = x % period as f64;
        let m = if m < 0.0 { m + period as f64 } else { m };
        (m, m as u64)
    } else {
        (x, u64::MAX)
    }
}

/// The point reduced into its period on every axis, and which axes sit in their period's last
/// cell (where the upper corner wraps).
#[inline(always)]
pub(super) fn reduce3(p: [f64; 3], period: Period) -> ([f64; 3], [bool; 3]) {
    let mut q = [0.0; 3];
    let mut wrap = [false; 3];
    for a in 0..3 {
        let (x, c) = reduce(p[a], period[a]);
        q[a] = x;
        wrap[a] = c != u64::MAX && c + 1 == period[a];
    }
    (q, wrap)
}
