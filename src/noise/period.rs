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

/// `x` reduced into `[0, P)`, and its cell index there (`c mod P`); a non-finite `x` is kept
/// as it is (the noise is NaN), and so is every `x` when `P` is beyond 2^52.
#[inline(always)]
pub(super) fn reduce(x: f64, period: u64) -> (f64, u64) {
    if period == 0 || period > LIMIT {
        return (x, u64::MAX);
    }
    if x.abs() < TWO52 {
        let t = x as i64;
        let c = t - ((t as f64) > x) as i64;
        let f = x - (c as f64).copysign(x);
        let m = c.rem_euclid(period as i64);
        (m as f64 + f, m as u64)
    } else if x.is_finite() {
        // An integer already; `%` (fmod) is exact.
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
