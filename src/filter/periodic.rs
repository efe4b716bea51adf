//! Periodic piecewise-cubic functions of a value over a footprint: `g(fract X)` where `g` is
//! piecewise cubic on `[0, 1)`, exactly (docs/filtering.md, "Periodic chains").
//!
//! A `Fract` (or `Mod` by a constant) followed by affine maps, `Abs`, `Min`/`Max`/`Clamp`/`Step`
//! with constants (all keeping `g` piecewise linear), then at most one piecewise-cubic shape (a
//! `Smoothstep` with constant edges, a `ColorRamp`, a `Curve`) and affine maps, is one such `g`
//! of the `Fract`'s argument (`chains.rs` finds the chains). Applying the rules one after the
//! other would model the `fract`'s spread as unimodal, where across a jump it is two clusters
//! near 0 and near 1: a tent `1 − |2 fract(x) − 1|` over a small box on a jump is near 0, the
//! unimodal model gives about 0.2.
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
//! (`J_{jk}` the jump of the `k`-th derivative of `g` at knot `c_j`, wrapping at 0;
//! `Φ_n(x) = E[P_n(x + S)]/n!`, `moments::PeriodicMeans`). The second moment is the same formula
//! for `g²` (degree 6), the slope the formula differentiated (`Φ_{n+1}' = Φ_n`, and `Φ_1'` by
//! one step of the box formula). A support of at most two periods instead unrolls `g` over the
//! periods it covers and takes the exact piecewise-polynomial rule (`moments::Piecewise`):
//! centred, so the variance keeps its relative accuracy for small boxes.

use super::moments::{
    piecewise_moments, taylor_at, Moments, PeriodicMeans, Piecewise, Spread, LOCAL_SPAN,
};
use smallvec::SmallVec;

/// At most this many pieces per period: a longer chain is left to the plain rules.
const MAX_PIECES: usize = 64;

/// The shapes a chain applies, as piecewise polynomials of their input.
pub struct Shape;

impl Shape {
    /// `|u|`.
    pub fn abs() -> Piecewise {
        Piecewise::new(vec![0.0], vec![[0.0, -1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    }

    /// `min(u, c)` or (`max`) `max(u, c)`.
    pub fn min_max(c: f64, max: bool) -> Option<Piecewise> {
        let (line, flat) = ([c, 1.0, 0.0, 0.0], [c, 0.0, 0.0, 0.0]);
        let polys = if max {
            vec![flat, line]
        } else {
            vec![line, flat]
        };
        c.is_finite().then(|| Piecewise::new(vec![c], polys))
    }

    /// `clamp(u, lo, hi)` (as the interpreter: `min(max(u, lo), hi)`).
    pub fn clamp(lo: f64, hi: f64) -> Option<Piecewise> {
        (lo.is_finite() && hi.is_finite() && lo <= hi).then(|| {
            Piecewise::new(
                vec![lo, hi],
                vec![
                    [lo, 0.0, 0.0, 0.0],
                    [lo, 1.0, 0.0, 0.0],
                    [hi, 0.0, 0.0, 0.0],
                ],
            )
        })
    }

    /// `smoothstep(e0, e1, u)` with constant edges `e0 <= e1` (a step at `e0 = e1`).
    pub fn smoothstep(e0: f64, e1: f64) -> Option<Piecewise> {
        if !(e0.is_finite() && e1.is_finite() && e0 <= e1) {
            return None;
        }
        let w = e1 - e0;
        if w == 0.0 {
            return Shape::step(e0);
        }
        let rise = [0.0, 0.0, 3.0 / (w * w), -2.0 / (w * w * w)];
        Some(Piecewise::new(
            vec![e0, e1],
            vec![[0.0; 4], rise, [1.0, 0.0, 0.0, 0.0]],
        ))
    }

    /// `step(edge, u)`: 1 for `u >= edge`, else 0.
    pub fn step(edge: f64) -> Option<Piecewise> {
        edge.is_finite()
            .then(|| Piecewise::new(vec![edge], vec![[0.0; 4], [1.0, 0.0, 0.0, 0.0]]))
    }
}

/// `Σ c_i u^i` and its derivative.
fn poly(c: &[f64; 4], u: f64) -> (f64, f64) {
    (
        c[0] + u * (c[1] + u * (c[2] + u * c[3])),
        c[1] + u * (2.0 * c[2] + u * 3.0 * c[3]),
    )
}

fn degree(c: &[f64]) -> usize {
    c.iter().rposition(|&a| a != 0.0).unwrap_or(0)
}

/// The `k`-th derivative at `u` of the polynomial `c` (ascending coefficients).
fn derivative(c: &[f64], k: usize, u: f64) -> f64 {
    let mut acc = 0.0;
    for i in (k..c.len()).rev() {
        let falling: f64 = (i - k + 1..=i).map(|f| f as f64).product();
        acc = acc * u + c[i] * falling;
    }
    acc
}

/// `∫_{u0}^{u1}` of the polynomial `c`.
fn integral(c: &[f64], u0: f64, u1: f64) -> f64 {
    let antiderivative = |u: f64| {
        let mut acc = 0.0;
        for (i, &a) in c.iter().enumerate().rev() {
            acc = acc * u + a / (i + 1) as f64;
        }
        acc * u
    };
    antiderivative(u1) - antiderivative(u0)
}

fn square(c: &[f64; 4]) -> [f64; 7] {
    let mut out = [0.0; 7];
    for i in 0..4 {
        for j in 0..4 {
            out[i + j] += c[i] * c[j];
        }
    }
    out
}

/// `q(α + b u)` for a cubic `q`: the binomial expansion, ascending in `u`.
fn compose(q: &[f64; 4], alpha: f64, b: f64) -> [f64; 4] {
    const BINOMIAL: [[f64; 4]; 4] = [
        [1.0, 0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0, 0.0],
        [1.0, 2.0, 1.0, 0.0],
        [1.0, 3.0, 3.0, 1.0],
    ];
    let mut r = [0.0; 4];
    for (k, &qk) in q.iter().enumerate() {
        for (m, rm) in r.iter_mut().enumerate().take(k + 1) {
            *rm += qk * BINOMIAL[k][m] * alpha.powi((k - m) as i32) * b.powi(m as i32);
        }
    }
    r
}

/// `g(fract x)` for `g` piecewise cubic on `[0, 1)`, with what its moments need.
#[derive(Clone, Debug, PartialEq)]
pub struct Periodic {
    /// Piece starts in `[0, 1)`, increasing, the first 0.
    starts: Vec<f64>,
    /// Per piece, `Σ c_i u^i` in the period's own `u`.
    pieces: Vec<[f64; 4]>,
    /// `∫₀¹ g` and `∫₀¹ g²`.
    mean: f64,
    mean_sq: f64,
    /// Per knot `c`: the jumps of `g` and of its first three derivatives there.
    jumps: Vec<(f64, [f64; 4])>,
    /// Per knot: the jumps of `g²` and of its derivatives up to the sixth.
    jumps_sq: Vec<(f64, [f64; 7])>,
}

impl Periodic {
    /// `fract x` itself.
    pub fn sawtooth() -> Periodic {
        Periodic::finish(vec![0.0], vec![[0.0, 1.0, 0.0, 0.0]])
    }

    /// `a + b g`.
    pub fn affine(&self, a: f64, b: f64) -> Option<Periodic> {
        let pieces = (self.pieces.iter())
            .map(|p| [a + b * p[0], b * p[1], b * p[2], b * p[3]])
            .collect();
        Periodic::checked(self.starts.clone(), pieces)
    }

    /// `h(g)` for a piecewise polynomial `h`, where `g` is piecewise linear (else `None`): each
    /// piece of `g` split where it crosses a knot of `h`, `h`'s piece there composed with it.
    pub fn then(&self, h: &Piecewise) -> Option<Periodic> {
        if self.pieces.iter().any(|p| degree(p) > 1) {
            return None;
        }
        let mut starts = Vec::new();
        let mut pieces = Vec::new();
        for (j, p) in self.pieces.iter().enumerate() {
            let (a, b) = (p[0], p[1]);
            let (u0, u1) = (self.starts[j], self.end(j));
            let mut cuts = vec![u0];
            if b != 0.0 {
                let mut inside: Vec<f64> = (h.knots().iter())
                    .map(|&k| (k - a) / b)
                    .filter(|&u| u > u0 && u < u1)
                    .collect();
                inside.sort_by(f64::total_cmp);
                cuts.extend(inside);
            }
            for (i, &c) in cuts.iter().enumerate() {
                let next = cuts.get(i + 1).copied().unwrap_or(u1);
                let (anchor, q) = h.piece(a + b * (c + next) / 2.0);
                starts.push(c);
                pieces.push(compose(&q, a - anchor, b));
            }
        }
        Periodic::checked(starts, pieces)
    }

    /// The pieces' starts in `[0, 1)`, increasing, the first 0.
    pub fn starts(&self) -> &[f64] {
        &self.starts
    }

    /// Per piece, its coefficients `Σ c_i u^i` in the period's own `u`.
    pub fn pieces(&self) -> &[[f64; 4]] {
        &self.pieces
    }

    /// The value and slope at `x` (a point spread).
    pub fn eval(&self, x: f64) -> (f64, f64) {
        let u = x - x.floor();
        poly(&self.pieces[self.piece_at(u)], u)
    }

    fn piece_at(&self, u: f64) -> usize {
        self.starts.partition_point(|&c| c <= u).max(1) - 1
    }

    fn end(&self, j: usize) -> f64 {
        self.starts.get(j + 1).copied().unwrap_or(1.0)
    }

    fn checked(starts: Vec<f64>, pieces: Vec<[f64; 4]>) -> Option<Periodic> {
        let finite = pieces.iter().flatten().all(|c| c.is_finite());
        (finite && pieces.len() <= MAX_PIECES).then(|| Periodic::finish(starts, pieces))
    }

    /// Merges equal neighbours and computes the integrals and jumps.
    fn finish(starts: Vec<f64>, pieces: Vec<[f64; 4]>) -> Periodic {
        let (mut s, mut p): (Vec<f64>, Vec<[f64; 4]>) = (Vec::new(), Vec::new());
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
            let (piece, sq) = (g.pieces[j], square(&g.pieces[j]));
            let (u0, u1) = (g.starts[j], g.end(j));
            g.mean += integral(&piece, u0, u1);
            g.mean_sq += integral(&sq, u0, u1);
            // The jumps at this piece's start, from the previous piece (the last one at u = 1).
            let prev = g.pieces[(j + n - 1) % n];
            let (prev_sq, at) = (square(&prev), if j == 0 { 1.0 } else { u0 });
            let jump: [f64; 4] =
                std::array::from_fn(|k| derivative(&piece, k, u0) - derivative(&prev, k, at));
            let jump_sq: [f64; 7] =
                std::array::from_fn(|k| derivative(&sq, k, u0) - derivative(&prev_sq, k, at));
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
        let phi = match PeriodicMeans::new(s) {
            Some(phi) if 2.0 * s.half_support() > LOCAL_SPAN => phi,
            _ => return self.local(x, s),
        };
        let mut mean = self.mean;
        let mut slope = 0.0;
        for &(c, j) in &self.jumps {
            let p: [f64; 5] = std::array::from_fn(|n| match n {
                0 => phi.phi1_slope(x - c),
                _ => phi.phi(x - c, n),
            });
            mean -= (0..4).map(|k| j[k] * p[k + 1]).sum::<f64>();
            slope -= (0..4).map(|k| j[k] * p[k]).sum::<f64>();
        }
        let mut second = self.mean_sq;
        for &(c, j) in &self.jumps_sq {
            second -= (0..7)
                .filter(|&k| j[k] != 0.0)
                .map(|k| j[k] * phi.phi(x - c, k + 1))
                .sum::<f64>();
        }
        Moments {
            mean,
            variance: (second - mean * mean).max(0.0),
            slope,
        }
    }

    /// A short support: `g` unrolled over the periods it covers (`x` in `[0, 1)`), the exact
    /// piecewise-polynomial rule. Its knots and pieces on the stack up to [`LOCAL_STACK`] (a
    /// longer unrolling spills to the heap), so a lane of a short chain allocates nothing.
    fn local(&self, x: f64, s: &Spread) -> Moments {
        let half = s.half_support();
        let (first, last) = ((x - half).floor() as i64, (x + half).floor() as i64);
        let mut knots = SmallVec::<[f64; LOCAL_STACK]>::new();
        // Before the first knot: the previous period's last piece, anchored at that knot.
        let last_piece = self.pieces[self.pieces.len() - 1];
        let mut polys = SmallVec::<[[f64; 4]; LOCAL_STACK]>::new();
        polys.push(taylor_at(last_piece, 1.0));
        for m in first..=last {
            for (c, p) in self.starts.iter().zip(&self.pieces) {
                knots.push(m as f64 + c);
                polys.push(taylor_at(*p, *c));
            }
        }
        piecewise_moments(&knots, &polys, x, s)
    }
}

/// How many knots and pieces [`Periodic::local`] keeps on the stack.
const LOCAL_STACK: usize = 32;

#[cfg(test)]
mod tests {
    //! Against an independent reference: the box mean of `g(fract(t + w1 u1 + w2 u2))` by
    //! exact integration of the piecewise-linear integrand along `u1` (split at every point
    //! where `fract` wraps or `g` has a knot, trapezoids exact on each linear piece) and
    //! composite Simpson along `u2`.

    use super::*;

    const GL4: [(f64, f64); 4] = [
        (-0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
        (-0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.339_981_043_584_856_3, 0.652_145_154_862_546_1),
        (0.861_136_311_594_052_6, 0.347_854_845_137_453_9),
    ];

    /// `∫ g(fract x) dx` and `∫ g(fract x)² dx` over `[lo, hi]`, piece by piece.
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
            let c = g.pieces[g.starts.partition_point(|&c| c <= u).max(1) - 1];
            // Gauss–Legendre with 4 nodes on the cut: exact for g²'s degree, at most 6.
            let (h, centre) = ((w[1] - w[0]) / 2.0, mid - mid.floor());
            for (node, weight) in GL4 {
                let v = poly(&c, centre + h * node).0;
                s1 += h * weight * v;
                s2 += h * weight * v * v;
            }
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
            .and_then(|g| g.then(&Shape::abs()))
            .and_then(|g| g.affine(1.0, -1.0))
            .unwrap();
        let clipped = tent
            .affine(-0.3, 1.7)
            .and_then(|g| g.then(&Shape::clamp(0.0, 1.0).unwrap()))
            .unwrap();
        let stripes = saw.then(&Shape::step(0.65).unwrap()).unwrap();
        // A line of laminae, 1 − smoothstep(0, 0.2, |fract − 0.5|): cubic pieces.
        let line = saw
            .affine(-0.5, 1.0)
            .and_then(|g| g.then(&Shape::abs()))
            .and_then(|g| g.then(&Shape::smoothstep(0.0, 0.2).unwrap()))
            .and_then(|g| g.affine(1.0, -1.0))
            .unwrap();
        vec![saw, tent, clipped, stripes, line]
    }

    #[test]
    fn tent_is_composed_exactly() {
        let tent = &shapes()[1];
        assert_eq!(tent.starts, [0.0, 0.5]);
        assert_eq!(tent.pieces, [[0.0, 2.0, 0.0, 0.0], [2.0, -2.0, 0.0, 0.0]]);
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
