//! Periodic piecewise-linear functions of a value over a footprint: `g(fract X)` where `g` is
//! piecewise linear on `[0, 1)`, exactly (docs/filtering.md, "Periodic chains").
//!
//! A `Fract` (or `Mod` by a constant) followed by affine maps, `Abs`, `Min`/`Max`/`Clamp`/`Step`
//! with constants and linear or constant ramps is one such `g` of the `Fract`'s argument
//! (`fusions.rs` finds the chains). Applying the rules one after the other would model the
//! `fract`'s spread as unimodal, where across a jump it is two clusters near 0 and near 1: a
//! tent `1 − |2 fract(x) − 1|` over a small box on a jump is near 0, the unimodal model gives
//! about 0.2.
//!
//! # The rule
//!
//! With `P_n(x) = B_n(fract x)` (Bernoulli; `moments.rs`, "fract"), `P_1` drops by 1 at each
//! integer and `P_{n+1}/(n+1)!` is an antiderivative of `P_n/n!`, so `−J P_{k+1}(x − c)/(k+1)!`
//! has a jump `J` in its `k`-th derivative at `c` and is smooth elsewhere. A 1-periodic piecewise
//! polynomial `g` minus such a term for every jump of every derivative is smooth and periodic,
//! hence its mean `ḡ`:
//!
//! ```text
//! g(fract x) = ḡ − Σ_j Σ_k J_{jk} P_{k+1}(x − c_j) / (k+1)!
//! E[g(fract X)] = ḡ − Σ_j Σ_k J_{jk} Φ_{k+1}(t − c_j)
//! ```
//!
//! (`J_{jk}` the jump of `g^(k)` at knot `c_j`, wrapping at 0; `Φ_n(x) = E[P_n(x + S)]/n!`,
//! `moments::PeriodicMeans`). The second moment is the same formula for `g²` (degree 2, jumps of
//! `g²`, `2gg'`, `2g'²`), the slope the formula differentiated (`Φ_{n+1}' = Φ_n`, and `Φ_1'` by
//! one step of the box formula). Where the support holds no knot the linear piece is exact on
//! its own (mean `g(t)`, variance `b² Var S`, slope `b`), with no cancellation.

use super::moments::{Moments, PeriodicMeans, Piecewise, Spread};

/// At most this many pieces per period: a longer chain is left to the plain rules.
const MAX_PIECES: usize = 64;

/// A piecewise-linear function of `u` on the real line: `pieces[0]` on `(−∞, knots[0])`,
/// `pieces[i]` on `[knots[i−1], knots[i])`, the last on `[knots[n−1], ∞)`, each `a + b u`.
#[derive(Clone, Debug, PartialEq)]
pub struct Linear {
    knots: Vec<f64>,
    pieces: Vec<[f64; 2]>,
}

impl Linear {
    /// `|u|`.
    pub fn abs() -> Linear {
        Linear {
            knots: vec![0.0],
            pieces: vec![[0.0, -1.0], [0.0, 1.0]],
        }
    }

    /// `min(u, c)` or (`max`) `max(u, c)`.
    pub fn min_max(c: f64, max: bool) -> Option<Linear> {
        let pieces = if max {
            vec![[c, 0.0], [0.0, 1.0]]
        } else {
            vec![[0.0, 1.0], [c, 0.0]]
        };
        c.is_finite().then(|| Linear {
            knots: vec![c],
            pieces,
        })
    }

    /// `clamp(u, lo, hi)` (as the interpreter: `min(max(u, lo), hi)`).
    pub fn clamp(lo: f64, hi: f64) -> Option<Linear> {
        (lo.is_finite() && hi.is_finite() && lo <= hi).then(|| Linear {
            knots: vec![lo, hi],
            pieces: vec![[lo, 0.0], [0.0, 1.0], [hi, 0.0]],
        })
    }

    /// `step(edge, u)`: 1 for `u >= edge`, else 0.
    pub fn step(edge: f64) -> Option<Linear> {
        edge.is_finite().then(|| Linear {
            knots: vec![edge],
            pieces: vec![[0.0, 0.0], [1.0, 0.0]],
        })
    }

    /// A piecewise polynomial whose pieces are all of degree <= 1 (a linear or constant ramp
    /// channel), else `None`.
    pub fn from_piecewise(f: &Piecewise) -> Option<Linear> {
        let (knots, polys) = f.parts();
        let mut pieces = Vec::with_capacity(polys.len());
        for (i, p) in polys.iter().enumerate() {
            if p[2] != 0.0 || p[3] != 0.0 {
                return None;
            }
            // Local `a0 + a1 (u − anchor)` to `a + b u`.
            let anchor = match i {
                0 => knots.first().copied().unwrap_or(0.0),
                _ => knots[i - 1],
            };
            pieces.push([p[0] - p[1] * anchor, p[1]]);
        }
        Some(Linear {
            knots: knots.to_vec(),
            pieces,
        })
    }

    fn piece_at(&self, u: f64) -> [f64; 2] {
        self.pieces[self.knots.partition_point(|&c| c <= u)]
    }
}

/// `g(fract x)` for `g` piecewise linear on `[0, 1)`, with what its moments need.
#[derive(Clone, Debug, PartialEq)]
pub struct Periodic {
    /// Piece starts in `[0, 1)`, increasing, the first 0.
    starts: Vec<f64>,
    /// `a + b u` per piece.
    pieces: Vec<[f64; 2]>,
    /// `∫₀¹ g` and `∫₀¹ g²`.
    mean: f64,
    mean_sq: f64,
    /// Per knot `c`: the jumps of `g`, `g'` there.
    jumps: Vec<(f64, [f64; 2])>,
    /// Per knot: the jumps of `g²`, `(g²)'`, `(g²)''`.
    jumps_sq: Vec<(f64, [f64; 3])>,
}

impl Periodic {
    /// `fract x` itself.
    pub fn sawtooth() -> Periodic {
        Periodic::finish(vec![0.0], vec![[0.0, 1.0]])
    }

    /// `a + b g`.
    pub fn affine(&self, a: f64, b: f64) -> Option<Periodic> {
        let pieces = self.pieces.iter().map(|p| [a + b * p[0], b * p[1]]);
        Periodic::checked(self.starts.clone(), pieces.collect())
    }

    /// `h(g)` for a piecewise-linear `h`: each piece of `g` split where it crosses a knot of `h`.
    pub fn then(&self, h: &Linear) -> Option<Periodic> {
        let mut starts = Vec::new();
        let mut pieces = Vec::new();
        for (j, &[a, b]) in self.pieces.iter().enumerate() {
            let (u0, u1) = (self.starts[j], self.end(j));
            let mut cuts = vec![u0];
            if b != 0.0 {
                let mut inside: Vec<f64> = (h.knots.iter())
                    .map(|&k| (k - a) / b)
                    .filter(|&u| u > u0 && u < u1)
                    .collect();
                inside.sort_by(f64::total_cmp);
                cuts.extend(inside);
            }
            for (i, &c) in cuts.iter().enumerate() {
                let next = cuts.get(i + 1).copied().unwrap_or(u1);
                let [p, q] = h.piece_at(a + b * (c + next) / 2.0);
                starts.push(c);
                pieces.push([p + q * a, q * b]);
            }
        }
        Periodic::checked(starts, pieces)
    }

    /// The value at `x` (a point spread).
    pub fn eval(&self, x: f64) -> (f64, f64) {
        let u = x - x.floor();
        let [a, b] = self.pieces[self.starts.partition_point(|&c| c <= u).max(1) - 1];
        (a + b * u, b)
    }

    fn end(&self, j: usize) -> f64 {
        self.starts.get(j + 1).copied().unwrap_or(1.0)
    }

    fn checked(starts: Vec<f64>, pieces: Vec<[f64; 2]>) -> Option<Periodic> {
        let finite = pieces.iter().flatten().all(|c| c.is_finite());
        (finite && pieces.len() <= MAX_PIECES).then(|| Periodic::finish(starts, pieces))
    }

    /// Merges equal neighbours and computes the integrals and jumps.
    fn finish(starts: Vec<f64>, pieces: Vec<[f64; 2]>) -> Periodic {
        let (mut s, mut p): (Vec<f64>, Vec<[f64; 2]>) = (Vec::new(), Vec::new());
        for (c, piece) in starts.into_iter().zip(pieces) {
            if p.last() != Some(&piece) {
                s.push(c);
                p.push(piece);
            }
        }
        let mut g = Periodic {
            starts: s,
            pieces: p,
            mean: 0.0,
            mean_sq: 0.0,
            jumps: Vec::new(),
            jumps_sq: Vec::new(),
        };
        let n = g.pieces.len();
        for j in 0..n {
            let [a, b] = g.pieces[j];
            let (u0, u1) = (g.starts[j], g.end(j));
            let (g0, g1) = (a + b * u0, a + b * u1);
            g.mean += (u1 - u0) * (g0 + g1) / 2.0;
            g.mean_sq += (u1 - u0) * (g0 * g0 + g0 * g1 + g1 * g1) / 3.0;
            // The jump at this piece's start, from the previous piece (the last one at u = 1).
            let [pa, pb] = g.pieces[(j + n - 1) % n];
            let before = pa + pb * if j == 0 { 1.0 } else { u0 };
            let jump = [g0 - before, b - pb];
            let jump_sq = [
                g0 * g0 - before * before,
                2.0 * (g0 * b - before * pb),
                2.0 * (b * b - pb * pb),
            ];
            if jump.iter().any(|&c| c != 0.0) {
                g.jumps.push((u0, jump));
            }
            if jump_sq.iter().any(|&c| c != 0.0) {
                g.jumps_sq.push((u0, jump_sq));
            }
        }
        g
    }

    /// Mean, variance and slope of `g(fract X)`, `X = t + S`, exact (module docs). A NaN or
    /// infinite `t` gives NaN; an unbounded spread the period's mean and variance.
    pub fn moments(&self, t: f64, s: &Spread) -> Moments {
        if !t.is_finite() {
            return Moments {
                mean: f64::NAN,
                variance: f64::NAN,
                slope: f64::NAN,
            };
        }
        if s.is_unbounded() {
            return Moments {
                mean: self.mean,
                variance: (self.mean_sq - self.mean * self.mean).max(0.0),
                slope: 0.0,
            };
        }
        let x = t - t.floor();
        let Some(phi) = PeriodicMeans::new(s) else {
            let (value, slope) = self.eval(x);
            return Moments {
                mean: value,
                variance: 0.0,
                slope,
            };
        };
        // The support inside one piece: that piece alone, exactly.
        let j = self.starts.partition_point(|&c| c <= x).max(1) - 1;
        let half = phi.half();
        if x - half >= self.starts[j] && x + half < self.end(j) {
            let [a, b] = self.pieces[j];
            return Moments {
                mean: a + b * x,
                variance: b * b * s.variance(),
                slope: b,
            };
        }
        let mut mean = self.mean;
        let mut slope = 0.0;
        for &(c, [j0, j1]) in &self.jumps {
            let (p1, p2) = (phi.phi(x - c, 1), phi.phi(x - c, 2));
            mean -= j0 * p1 + j1 * p2;
            slope -= j0 * phi.phi1_slope(x - c) + j1 * p1;
        }
        let mut square = self.mean_sq;
        for &(c, [k0, k1, k2]) in &self.jumps_sq {
            square -= k0 * phi.phi(x - c, 1) + k1 * phi.phi(x - c, 2) + k2 * phi.phi(x - c, 3);
        }
        Moments {
            mean,
            variance: (square - mean * mean).max(0.0),
            slope,
        }
    }
}

#[cfg(test)]
mod tests {
    //! Against an independent reference: the box mean of `g(fract(t + w1 u1 + w2 u2))` by
    //! exact integration of the piecewise-linear integrand along `u1` (split at every point
    //! where `fract` wraps or `g` has a knot, trapezoids exact on each linear piece) and
    //! composite Simpson along `u2`.

    use super::*;

    /// `∫ g(fract x) dx` over `[lo, hi]`, piece by piece.
    fn integral(g: &Periodic, lo: f64, hi: f64) -> (f64, f64) {
        let mut cuts = vec![lo, hi];
        let mut m = lo.floor();
        while m <= hi {
            cuts.extend(
                g.starts
                    .iter()
                    .map(|&c| m + c)
                    .filter(|&c| c > lo && c < hi),
            );
            m += 1.0;
        }
        cuts.sort_by(f64::total_cmp);
        let (mut s1, mut s2) = (0.0, 0.0);
        for w in cuts.windows(2) {
            let mid = (w[0] + w[1]) / 2.0;
            let u = mid - mid.floor();
            let [a, b] = g.pieces[g.starts.partition_point(|&c| c <= u).max(1) - 1];
            // Linear on the cut: the value at the ends from the piece at the middle.
            let at = |x: f64| a + b * (x - mid.floor());
            let (f0, f1) = (at(w[0]), at(w[1]));
            s1 += (w[1] - w[0]) * (f0 + f1) / 2.0;
            s2 += (w[1] - w[0]) * (f0 * f0 + f0 * f1 + f1 * f1) / 3.0;
        }
        (s1, s2)
    }

    /// Mean and second moment over `t + w1 U1 + w2 U2` (`w1 > 0`).
    fn reference(g: &Periodic, t: f64, w1: f64, w2: f64) -> (f64, f64) {
        let inner = |c: f64| {
            let (a, b) = integral(g, c - w1 / 2.0, c + w1 / 2.0);
            (a / w1, b / w1)
        };
        if w2 == 0.0 {
            return inner(t);
        }
        let n = 4000;
        let h = w2 / n as f64;
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..=n {
            let weight = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let (a, b) = inner(t - w2 / 2.0 + i as f64 * h);
            m1 += weight * a;
            m2 += weight * b;
        }
        (m1 * h / 3.0 / w2, m2 * h / 3.0 / w2)
    }

    /// The slope of the box mean: `d/dt` of the mean over `u1` is the difference of the
    /// integrand at the ends of `u1`'s range over `w1` (the fundamental theorem of calculus),
    /// then averaged over `u2` exactly.
    fn reference_slope(g: &Periodic, t: f64, w1: f64, w2: f64) -> f64 {
        let across = |c: f64| {
            if w2 == 0.0 {
                g.eval(c).0
            } else {
                integral(g, c - w2 / 2.0, c + w2 / 2.0).0 / w2
            }
        };
        (across(t + w1 / 2.0) - across(t - w1 / 2.0)) / w1
    }

    fn shapes() -> Vec<Periodic> {
        let saw = Periodic::sawtooth();
        let tent = saw
            .affine(-1.0, 2.0)
            .and_then(|g| g.then(&Linear::abs()))
            .and_then(|g| g.affine(1.0, -1.0))
            .unwrap();
        let clipped = tent
            .affine(-0.3, 1.7)
            .and_then(|g| g.then(&Linear::clamp(0.0, 1.0).unwrap()))
            .unwrap();
        let stripes = saw.then(&Linear::step(0.65).unwrap()).unwrap();
        vec![saw, tent, clipped, stripes]
    }

    #[test]
    fn tent_is_composed_exactly() {
        let tent = &shapes()[1];
        assert_eq!(tent.starts, [0.0, 0.5]);
        assert_eq!(tent.pieces, [[0.0, 2.0], [2.0, -2.0]]);
        assert!((tent.mean - 0.5).abs() < 1e-15 && (tent.mean_sq - 1.0 / 3.0).abs() < 1e-15);
    }

    /// Random centres (also far from 0 and negative) and one or two widths from 1e-4 to 30
    /// periods: mean and variance within 1e-6 of the reference, and the slope within 1e-4 of
    /// the reference's central difference.
    #[test]
    fn moments_agree_with_quadrature() {
        let mut state = 0x1234_5678_9abc_def1u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for (k, g) in shapes().iter().enumerate() {
            for case in 0..40 {
                let t = (next() - 0.5) * if case % 4 == 0 { 2e4 } else { 8.0 };
                let w1 = 10f64.powf(next() * 5.5 - 4.0);
                let w2 = if case % 2 == 0 { 0.0 } else { w1 * next() };
                let s = Spread::new([w1, w2, 0.0], 0.0);
                let m = g.moments(t, &s);
                let (mean, second) = reference(g, t, w1, w2);
                let var = second - mean * mean;
                let what = format!("shape {k} t {t} widths {w1} {w2}: {m:?} vs {mean} {var}");
                assert!((m.mean - mean).abs() < 1e-6, "mean, {what}");
                assert!((m.variance - var).abs() < 1e-6, "variance, {what}");
                let slope = reference_slope(g, t, w1, w2);
                assert!(
                    (m.slope - slope).abs() < 1e-6 * (1.0 + slope.abs()),
                    "slope, {what} ({slope})"
                );
            }
        }
    }

    #[test]
    fn points_and_unbounded_spreads() {
        let tent = &shapes()[1];
        let point = tent.moments(3.25, &Spread::new([0.0; 3], 0.0));
        assert_eq!((point.mean, point.variance, point.slope), (0.5, 0.0, 2.0));
        let wide = tent.moments(0.1, &Spread::new([f64::INFINITY, 0.0, 0.0], 0.0));
        assert!((wide.mean - 0.5).abs() < 1e-15 && (wide.variance - 1.0 / 12.0).abs() < 1e-15);
        assert!(tent
            .moments(f64::NAN, &Spread::new([1.0, 0.0, 0.0], 0.0))
            .mean
            .is_nan());
    }
}
