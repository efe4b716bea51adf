//! The per-operation rules of filtered evaluation: how a value's distribution over the
//! footprint ([`Dist`]) passes through each operation of the tape.
//!
//! A value `V(p)` over the footprint is described by its mean `mean`, its linear part `grad`
//! (the best linear fit's slope in the sample position: `V(p) ≈ mean + grad · (p − p₀)`) and a
//! residual variance `var` (the part not linear in the position, taken as independent of
//! everything else). The footprint ([`Footprint`]) is a parallelepiped of edge vectors `e_k`
//! around the point `p₀` (a box: the axes times its sides), so the linear part alone spreads the
//! value as `Σ_k (grad · e_k) U_k`, `U_k` uniform on [−1/2, 1/2] (exact for affine values), and
//! its variance is `Σ_k (grad · e_k)² / 12`.
//!
//! Rules (docs/filtering.md has the derivations):
//! - affine operations, rotations, `Mix` with a constant weight: exact;
//! - `Sin`, `Cos`: the exact box mean of the linear part, `sin μ · Π_k sinc(a_k / 2)`, times
//!   `e^(−σ²/2)` for the residual (the Gaussian rule);
//! - `Fract`, `Floor`, `Round`, `Trunc`, `Mod` (constant divisor), `Step`, `Sign`, `Abs`,
//!   `Clamp`, `Min`, `Max`, `Smoothstep`, `Select`, `Hermite`, ramps and curves: the exact mean,
//!   variance and slope of the piecewise function over the linear part's box (`moments.rs`),
//!   with the residual taken as one more uniform of the same variance;
//! - products: the moments of a product of correlated values (exact means; the variance as for
//!   Gaussians); `Div`, `Pow`, `Exp`, `Log`, `Sqrt`, trigonometric inverses: second-order
//!   (delta-method) moments, with Jensen's bounds where the function is concave;
//! - every rule's output linear part is `E[f'(V)] · grad` (Stein's lemma: the covariance of
//!   `f(V)` with the position), and its residual is the rest of its variance.

use super::moments::{self, Moments, Piecewise, Spread};
use super::trig;
use crate::ops::{self, BinaryOp, TernaryOp, UnaryOp};

/// A value over the footprint: mean, linear part (per unit of sample position) and residual
/// variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dist {
    pub mean: f64,
    pub grad: [f64; 3],
    pub var: f64,
}

impl Dist {
    /// A constant.
    pub const fn constant(v: f64) -> Dist {
        Dist {
            mean: v,
            grad: [0.0; 3],
            var: 0.0,
        }
    }

    /// Coordinate `axis` of the sample position `p`.
    pub fn position(p: [f64; 3], axis: usize) -> Dist {
        let mut grad = [0.0; 3];
        grad[axis] = 1.0;
        Dist {
            mean: p[axis],
            grad,
            var: 0.0,
        }
    }

    pub fn is_constant(&self) -> bool {
        self.var == 0.0 && self.grad == [0.0; 3]
    }

    /// Whether `self` and `other` are taken for the same value (a copy carried through
    /// `min`, `max` or a select, so that `max(r, g) − r` is exactly 0 where `r` wins): equal
    /// distributions with a linear part. Equal distributions without one are as often two
    /// different values (the two axes' distances to a tile's edge over a box of whole tiles,
    /// two fully faded octaves of one noise): those stay independent (`floor_tiles`' grout,
    /// `min` of its three axes, was half its mean when they were taken for one value).
    pub fn same_value(&self, other: &Dist) -> bool {
        self == other && self.grad != [0.0; 3]
    }

    /// `c · V`: exact.
    pub fn scale(self, c: f64) -> Dist {
        Dist {
            mean: c * self.mean,
            grad: self.grad.map(|g| c * g),
            var: c * c * self.var,
        }
    }
}

/// The region a pixel or voxel covers around the sample point: a parallelepiped given by its
/// three edge vectors in the graph's input space (a box: the axes times its sides; a pixel:
/// its two ray-differential vectors and a zero one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    edges: [[f64; 3]; 3],
    /// `Σ_k e_k e_kᵀ / 12`: the covariance of linear parts over the footprint as one quadratic
    /// form (made once per footprint; `covariance` runs per rule and per noise octave).
    quad: [[f64; 3]; 3],
    /// How many edges are non-zero (0: a point).
    live: usize,
    /// [`Footprint::slope_with`] as a matrix, `E M⁻¹` over the non-zero edges `E` with Gram
    /// matrix `M`, made once per footprint (the slope fit and the slope damping apply it per
    /// octave); `None`: nearly parallel edges.
    fit: Option<[[f64; 3]; 3]>,
}

/// The number of non-zero edges and [`Footprint`]'s `fit` matrix.
fn slope_fit(edges: &[[f64; 3]; 3]) -> (usize, Option<[[f64; 3]; 3]>) {
    let mut live = [0usize; 3];
    let mut n = 0;
    for (k, e) in edges.iter().enumerate() {
        if dot(e, e) > 0.0 {
            live[n] = k;
            n += 1;
        }
    }
    let gram: [[f64; 3]; 3] = std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            if i < n && j < n {
                dot(&edges[live[i]], &edges[live[j]])
            } else {
                0.0
            }
        })
    });
    let inverse = if n == 0 {
        Some([[0.0; 3]; 3])
    } else {
        invert(&gram, n)
    };
    // g = Σ_a y_a e_live[a], y = M⁻¹ du over the live edges: g_i = Σ_k F[i][k] du[k].
    let fit = inverse.map(|inverse| {
        let mut f = [[0.0; 3]; 3];
        for a in 0..n {
            for b in 0..n {
                for (i, row) in f.iter_mut().enumerate() {
                    row[live[b]] += edges[live[a]][i] * inverse[a][b];
                }
            }
        }
        f
    });
    (n, fit)
}

/// Why a footprint was refused.
#[derive(Clone, Debug, PartialEq)]
pub struct FootprintError(pub String);

impl std::fmt::Display for FootprintError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FootprintError {}

impl Footprint {
    /// No footprint: filtered evaluation is then point evaluation.
    pub const POINT: Footprint = Footprint {
        edges: [[0.0; 3]; 3],
        quad: [[0.0; 3]; 3],
        live: 0,
        fit: Some([[0.0; 3]; 3]),
    };

    fn new(edges: [[f64; 3]; 3]) -> Footprint {
        let quad = std::array::from_fn(|i| {
            std::array::from_fn(|j| edges.iter().map(|e| e[i] * e[j]).sum::<f64>() / 12.0)
        });
        let (live, fit) = slope_fit(&edges);
        Footprint {
            edges,
            quad,
            live,
            fit,
        }
    }

    /// An axis-aligned box of sides `(wx, wy, wz)` (a voxel). Each side must be finite and
    /// ≥ 0 (an infinite box has no mean for most graphs: |x| over all x).
    pub fn from_sides(sides: [f64; 3]) -> Result<Footprint, FootprintError> {
        for (axis, &w) in ["x", "y", "z"].iter().zip(&sides) {
            if !(w.is_finite() && w >= 0.0) {
                return Err(FootprintError(format!(
                    "footprint side {axis} is {w}: a side must be a finite number >= 0"
                )));
            }
        }
        let [x, y, z] = sides;
        Ok(Footprint::new([
            [x, 0.0, 0.0],
            [0.0, y, 0.0],
            [0.0, 0.0, z],
        ]))
    }

    /// A cube of side `w`.
    pub fn cube(w: f64) -> Result<Footprint, FootprintError> {
        Footprint::from_sides([w; 3])
    }

    /// A parallelepiped of three edge vectors (any may be zero): an anisotropic pixel footprint
    /// from its ray differentials. Every component must be finite.
    pub fn from_edges(edges: [[f64; 3]; 3]) -> Result<Footprint, FootprintError> {
        if edges.iter().flatten().any(|c| !c.is_finite()) {
            return Err(FootprintError(format!(
                "footprint edges {edges:?}: every component must be finite"
            )));
        }
        Ok(Footprint::new(edges))
    }

    pub fn edges(&self) -> [[f64; 3]; 3] {
        self.edges
    }

    /// `Σ_k e_k e_kᵀ / 12`, the covariance of linear parts as a quadratic form.
    pub(super) fn quad(&self) -> &[[f64; 3]; 3] {
        &self.quad
    }

    /// The slope fit's matrix ([`Footprint::slope_with`]); `None` for nearly parallel edges.
    pub(super) fn fit(&self) -> Option<&[[f64; 3]; 3]> {
        self.fit.as_ref()
    }

    /// Whether every edge is zero: filtered evaluation is then point evaluation.
    pub fn is_point(&self) -> bool {
        self.live == 0
    }

    /// The widths of a linear part over the footprint: `|grad · e_k|`. An infinite side with a
    /// zero slope along it is no width (0 · ∞ taken as 0).
    pub(crate) fn widths(&self, grad: [f64; 3]) -> [f64; 3] {
        self.edges.map(|e| proj(grad, &e).abs())
    }

    /// The covariance over the footprint of two linear parts: `Σ_k (a · e_k)(b · e_k) / 12`.
    fn covariance(&self, a: [f64; 3], b: [f64; 3]) -> f64 {
        if a.iter().chain(&b).all(|c| c.is_finite()) {
            let q = &self.quad;
            return (0..3)
                .map(|i| a[i] * (0..3).map(|j| q[i][j] * b[j]).sum::<f64>())
                .sum();
        }
        // 0 · ∞ as 0 along each edge.
        let mut c = 0.0;
        for e in &self.edges {
            let (x, y) = (proj(a, e), proj(b, e));
            if x != 0.0 && y != 0.0 {
                c += x * y / 12.0;
            }
        }
        c
    }

    pub(super) fn linear_var(&self, grad: [f64; 3]) -> f64 {
        self.covariance(grad, grad).max(0.0)
    }

    /// The smallest slope `g` with `g · e_k = du[k]` along each non-zero edge (`g = Σ y_a e_a`,
    /// `y = M⁻¹ du` with the Gram matrix `M` inverted once per footprint); `None` where the
    /// edges are (nearly) parallel.
    pub(super) fn slope_with(&self, du: [f64; 3]) -> Option<[f64; 3]> {
        let f = self.fit.as_ref()?;
        let g: [f64; 3] = std::array::from_fn(|i| dot(&f[i], &du));
        g.iter().all(|c| c.is_finite()).then_some(g)
    }

    /// `grad` with its increment along each edge `e_k` scaled by `beta[k]`: the smallest change
    /// `g' = g + Σ_k y_k e_k` with `g' · e_k = beta[k] (g · e_k)` (a Gram system over the
    /// non-zero edges). Where the edges are (nearly) parallel the system is singular and
    /// `grad` is scaled by the smallest `beta` instead. ([`Footprint::damp_matrix`] applied.)
    #[cfg(test)]
    pub(super) fn damp(&self, grad: [f64; 3], beta: [f64; 3]) -> [f64; 3] {
        apply(&self.damp_matrix(beta), grad)
    }

    /// [`Footprint::damp`] as a matrix (it is linear in `grad`): `D = I + E M⁻¹ diag(β − 1) Eᵀ`
    /// over the non-zero edges `E` with Gram matrix `M`; `None` where it leaves every slope as
    /// it is (every factor within 1e-9 of 1: a footprint far inside a cell). Made once per
    /// fade, applied per lane by [`apply`].
    pub(super) fn damp_matrix(&self, beta: [f64; 3]) -> Option<[[f64; 3]; 3]> {
        if beta.iter().all(|&b| (1.0 - b).abs() < 1e-9) {
            return None;
        }
        if self.live == 0 {
            return None;
        }
        let Some(fit) = &self.fit else {
            let least = beta.iter().copied().fold(1.0, f64::min);
            return Some(std::array::from_fn(|i| {
                std::array::from_fn(|j| if i == j { least } else { 0.0 })
            }));
        };
        // D = I + F diag(β − 1) Eᵀ with F = E M⁻¹ (the slope fit's matrix; its columns of
        // zero edges are zero).
        let d: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let change: f64 = (0..3)
                    .map(|k| fit[i][k] * (beta[k] - 1.0) * self.edges[k][j])
                    .sum();
                if i == j {
                    1.0 + change
                } else {
                    change
                }
            })
        });
        d.iter().flatten().all(|c| c.is_finite()).then_some(d)
    }
}

/// `m g`, or `g` where that is not finite (as `damp` keeps a slope it cannot damp).
pub(super) fn apply(m: &Option<[[f64; 3]; 3]>, g: [f64; 3]) -> [f64; 3] {
    let Some(m) = m else { return g };
    let out: [f64; 3] = std::array::from_fn(|i| dot(&m[i], &g));
    if out.iter().all(|c| c.is_finite()) {
        out
    } else {
        g
    }
}

#[inline]
pub(super) fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The inverse of the leading `n × n` block (`n <= 3`) of a symmetric positive semi-definite
/// Gram matrix, by cofactors; `None` where it is (nearly) singular (determinant below 1e-9 of
/// the product of the diagonal: nearly parallel edges).
fn invert(m: &[[f64; 3]; 3], n: usize) -> Option<[[f64; 3]; 3]> {
    let mut out = [[0.0; 3]; 3];
    let diagonal: f64 = (0..n).map(|i| m[i][i]).product();
    let det = match n {
        1 => m[0][0],
        2 => m[0][0] * m[1][1] - m[0][1] * m[1][0],
        _ => {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        }
    };
    if det.is_nan() || det <= 1e-9 * diagonal || det <= 0.0 {
        return None;
    }
    match n {
        1 => out[0][0] = 1.0 / det,
        2 => {
            out[0][0] = m[1][1] / det;
            out[1][1] = m[0][0] / det;
            out[0][1] = -m[0][1] / det;
            out[1][0] = -m[1][0] / det;
        }
        _ => {
            for (i, row) in out.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    // The cofactor of m[j][i] (the adjugate's entry).
                    let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
                    let (c0, c1) = ((i + 1) % 3, (i + 2) % 3);
                    *x = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
                }
            }
        }
    }
    Some(out)
}

/// `a · e` with `0 · ∞` taken as 0.
fn proj(a: [f64; 3], e: &[f64; 3]) -> f64 {
    let mut s = 0.0;
    for (x, y) in a.iter().zip(e) {
        if *x != 0.0 && *y != 0.0 {
            s += x * y;
        }
    }
    s
}

/// The rules over one footprint.
#[derive(Clone, Copy, Debug)]
pub struct Rules<'a> {
    pub footprint: &'a Footprint,
}

/// Piecewise functions the rules use, built once.
pub struct Shapes {
    abs: Piecewise,
    sign: Piecewise,
    step: Piecewise,
    ramp: Piecewise,
    unit_clamp: Piecewise,
    unit_smoothstep: Piecewise,
}

impl Shapes {
    pub fn new() -> Shapes {
        Shapes {
            abs: Piecewise::new(vec![0.0], vec![[0.0, -1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]),
            sign: Piecewise::new(vec![0.0], vec![[-1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]),
            step: Piecewise::new(vec![0.0], vec![[0.0; 4], [1.0, 0.0, 0.0, 0.0]]),
            ramp: Piecewise::new(vec![0.0], vec![[0.0; 4], [0.0, 1.0, 0.0, 0.0]]),
            unit_clamp: Piecewise::new(
                vec![0.0, 1.0],
                vec![[0.0; 4], [0.0, 1.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]],
            ),
            // 3t² − 2t³ on [0, 1).
            unit_smoothstep: Piecewise::new(
                vec![0.0, 1.0],
                vec![[0.0; 4], [0.0, 0.0, 3.0, -2.0], [1.0, 0.0, 0.0, 0.0]],
            ),
        }
    }
}

impl Default for Shapes {
    fn default() -> Self {
        Shapes::new()
    }
}

/// Seed 000's Hermite spline `h(clamp(x, 0, 1))` as a piecewise cubic.
pub fn hermite_shape(h: &ops::Hermite) -> Piecewise {
    let (p0, p1, m0, m1) = (h.p0, h.p1, h.m0, h.m1);
    Piecewise::new(
        vec![0.0, 1.0],
        vec![
            [p0, 0.0, 0.0, 0.0],
            [
                p0,
                m0,
                -3.0 * p0 - 2.0 * m0 + 3.0 * p1 - m1,
                2.0 * p0 + m0 - 2.0 * p1 + m1,
            ],
            [p1, 0.0, 0.0, 0.0],
        ],
    )
}

/// One channel of a ramp or curve (`ops::Spline`) as a piecewise cubic: clamped to the end
/// values outside the knots; each segment linear, smoothstep-eased or constant; a slope spline
/// (for `Gradient`) as the derivative of those.
pub fn spline_shape<const N: usize>(spline: &ops::Spline<N>, channel: usize) -> Piecewise {
    use ops::SplineInterpolation as I;
    let (knots, values) = (spline.knots(), spline.values());
    let slope = spline.is_slope();
    let value = |i: usize| values[i][channel];
    let end = |v: f64| if slope { [0.0; 4] } else { [v, 0.0, 0.0, 0.0] };
    let mut polys = vec![end(value(0))];
    for i in 0..knots.len() {
        if i + 1 == knots.len() {
            polys.push(end(value(i)));
            break;
        }
        let (a, b, w) = (value(i), value(i + 1), knots[i + 1] - knots[i]);
        if w <= 0.0 {
            // A hard edge: the segment is empty.
            polys.push(end(b));
            continue;
        }
        let d = b - a;
        polys.push(match (spline.interpolation(), slope) {
            (I::Constant, false) => [a, 0.0, 0.0, 0.0],
            (I::Constant, true) => [0.0; 4],
            (I::Linear, false) => [a, d / w, 0.0, 0.0],
            (I::Linear, true) => [d / w, 0.0, 0.0, 0.0],
            (I::Smooth, false) => [a, 0.0, 3.0 * d / (w * w), -2.0 * d / (w * w * w)],
            (I::Smooth, true) => [0.0, 6.0 * d / (w * w), -6.0 * d / (w * w * w), 0.0],
        });
    }
    Piecewise::new(knots.to_vec(), polys).simplified()
}

impl Rules<'_> {
    fn spread(&self, d: &Dist) -> Spread {
        Spread::new(self.footprint.widths(d.grad), d.var)
    }

    /// The linear part's plus the residual variance.
    pub fn total_var(&self, d: &Dist) -> f64 {
        self.footprint.linear_var(d.grad) + d.var
    }

    /// A rule's output from its moments over `d`: linear part `slope · grad` (Stein), the rest
    /// of the variance as residual.
    fn out_of_moments(&self, d: &Dist, m: Moments) -> Dist {
        let grad = if m.slope == 0.0 {
            [0.0; 3]
        } else {
            d.grad.map(|g| m.slope * g)
        };
        Dist {
            mean: m.mean,
            grad,
            var: residual(m.variance, self.footprint.linear_var(grad)),
        }
    }

    /// `f(d)` for a piecewise polynomial `f`.
    pub fn piecewise(&self, f: &Piecewise, d: &Dist) -> Dist {
        if d.is_constant() {
            return Dist::constant(f.eval(d.mean));
        }
        let widths = self.footprint.widths(d.grad);
        if let Some(line) = line_only(f, d, &widths) {
            return line;
        }
        let m = f.moments(d.mean, &Spread::new(widths, d.var));
        self.out_of_moments(d, m)
    }

    /// `f_c(d)` for several piecewise polynomials (a ramp's channels), sharing the work.
    pub fn piecewise3(&self, fs: &[Piecewise; 3], d: &Dist) -> [Dist; 3] {
        if d.is_constant() {
            return fs.each_ref().map(|f| Dist::constant(f.eval(d.mean)));
        }
        let widths = self.footprint.widths(d.grad);
        if let [Some(a), Some(b), Some(c)] = fs.each_ref().map(|f| line_only(f, d, &widths)) {
            return [a, b, c];
        }
        let spread = Spread::new(widths, d.var);
        Piecewise::moments_of(fs.each_ref(), d.mean, &spread).map(|m| self.out_of_moments(d, m))
    }

    /// `g(fract d)` for a periodic piecewise-cubic `g` (`periodic.rs`), exact.
    pub fn periodic(&self, g: &super::periodic::Periodic, d: &Dist) -> Dist {
        if d.is_constant() {
            return Dist::constant(g.eval(d.mean).0);
        }
        let m = g.moments(d.mean, &self.spread(d));
        self.out_of_moments(d, m)
    }

    /// A smooth function by its value and first two derivatives at the mean (the delta method):
    /// mean `f + f''σ²/2`, variance `f'²σ² + f''²σ⁴/2`; `bound` caps the mean (Jensen's
    /// inequality for a concave f: `E f(V) ≤ f(E V)`).
    fn smooth(&self, d: &Dist, (f, f1, f2): (f64, f64, f64), concave: bool) -> Dist {
        if d.is_constant() {
            return Dist::constant(f);
        }
        let t = self.total_var(d);
        let mut mean = f + 0.5 * f2 * t;
        if concave && mean > f {
            mean = f;
        }
        if !mean.is_finite() {
            mean = f;
        }
        let grad = d.grad.map(|g| f1 * g);
        let total = f1 * f1 * t + 0.5 * f2 * f2 * t * t;
        Dist {
            mean,
            grad,
            var: residual(total, self.footprint.linear_var(grad)),
        }
    }

    fn sin_cos(&self, d: &Dist, cos: bool) -> Dist {
        if d.is_constant() {
            let (s, c) = d.mean.sin_cos();
            return Dist::constant(if cos { c } else { s });
        }
        self.sin_cos_over(d, self.footprint.widths(d.grad), cos)
    }

    /// [`Rules::sin_cos`] of a non-constant `d` whose footprint widths (`Footprint::widths`
    /// of its linear part) the caller has made already.
    pub(super) fn sin_cos_over(&self, d: &Dist, widths: [f64; 3], cos: bool) -> Dist {
        // A point (a zero footprint, no residual) takes libm's own sine, as the point tape
        // does, so that a zero footprint gives the point value to the bit; a spread takes
        // `trig`'s (within half a unit of it, and cheaper).
        let (s, c) = if d.var == 0.0 && widths == [0.0; 3] {
            d.mean.sin_cos()
        } else {
            trig::sin_cos(d.mean)
        };
        let (value, slope) = if cos { (c, -s) } else { (s, c) };
        // E[sin(μ + Σ a_k U_k)] = sin μ · Π sinc(a_k / 2); a Gaussian residual: e^(−σ²/2),
        // and e^(−2σ²) its fourth power (one `exp`, none without a residual).
        let gauss = if d.var == 0.0 {
            1.0
        } else {
            (-d.var / 2.0).exp()
        };
        let gauss2 = gauss * gauss;
        let attenuation: f64 = widths.iter().map(|&a| sinc(a / 2.0)).product::<f64>() * gauss;
        let double: f64 = widths.iter().map(|&a| sinc(a)).product::<f64>() * (gauss2 * gauss2);
        // cos 2μ from μ's sine and cosine.
        let c2 = (c - s) * (c + s);
        // sin² = (1 − cos 2x) / 2, cos² = (1 + cos 2x) / 2.
        let square = if cos {
            0.5 * (1.0 + c2 * double)
        } else {
            0.5 * (1.0 - c2 * double)
        };
        let mean = value * attenuation;
        let m = Moments {
            mean,
            variance: (square - mean * mean).max(0.0),
            slope: slope * attenuation,
        };
        self.out_of_moments(d, m)
    }

    /// `|sin X|`'s (`|cos X|`'s) distribution from its mean, slope and `Re φ(2) =
    /// E[cos 2X]`: `E[sin² X] = (1 − Re φ(2)) / 2`, `E[cos² X] = (1 + Re φ(2)) / 2`.
    pub(super) fn abs_sin_out(&self, x: &Dist, mean: f64, slope: f64, re2: f64, cos: bool) -> Dist {
        let square = if cos {
            0.5 * (1.0 + re2)
        } else {
            0.5 * (1.0 - re2)
        };
        let m = Moments {
            mean,
            variance: (square - mean * mean).max(0.0),
            slope,
        };
        self.out_of_moments(x, m)
    }

    /// `|sin X|` (`|cos X|`) for `X = μ + a U`, `U` uniform on [−1/2, 1/2]: the mean by the
    /// antiderivative `G(x) = ∫₀ˣ |sin| = 2k + 1 − cos(x − kπ)`, `k = ⌊x/π⌋`, as
    /// `(G(μ + a/2) − G(μ − a/2)) / a`; the slope `(|sin(μ + a/2)| − |sin(μ − a/2)|) / a`; the
    /// square's mean as for `Sin` (exact). `X`'s residual, if any, is left out (it is below what
    /// the Fourier series resolves in 64 terms).
    pub(super) fn abs_sin_line(&self, x: &Dist, a: f64, cos: bool) -> Dist {
        let pi = std::f64::consts::PI;
        let x0 = x.mean + if cos { pi / 2.0 } else { 0.0 };
        let (lo, hi) = (x0 - a / 2.0, x0 + a / 2.0);
        let (klo, khi) = ((lo / pi).floor(), (hi / pi).floor());
        let (rlo, rhi) = (lo - klo * pi, hi - khi * pi);
        let mean = (2.0 * (khi - klo) + trig::sin_cos(rlo).1 - trig::sin_cos(rhi).1) / a;
        let slope = (trig::sin(hi).abs() - trig::sin(lo).abs()) / a;
        let re2 = trig::sin_cos(2.0 * x.mean).1 * sinc(a);
        self.abs_sin_out(x, mean, slope, re2, cos)
    }

    pub fn add(&self, a: &Dist, b: &Dist) -> Dist {
        Dist {
            mean: a.mean + b.mean,
            grad: std::array::from_fn(|i| a.grad[i] + b.grad[i]),
            var: a.var + b.var,
        }
    }

    pub fn sub(&self, a: &Dist, b: &Dist) -> Dist {
        if a.same_value(b) {
            // The same value (residuals are independent only between different values).
            return Dist::constant(0.0);
        }
        Dist {
            mean: a.mean - b.mean,
            grad: std::array::from_fn(|i| a.grad[i] - b.grad[i]),
            var: a.var + b.var,
        }
    }

    /// A product of two values whose linear parts are correlated over the footprint: the mean
    /// exactly `μa μb + cov`, the variance as for Gaussians
    /// (`σa²σb² + σa²μb² + σb²μa² + cov² + 2 μa μb cov`).
    pub fn mul(&self, a: &Dist, b: &Dist) -> Dist {
        if b.is_constant() {
            return a.scale(b.mean);
        }
        if a.is_constant() {
            return b.scale(a.mean);
        }
        let cov = self.footprint.covariance(a.grad, b.grad);
        let (ta, tb) = (self.total_var(a), self.total_var(b));
        let grad = std::array::from_fn(|i| a.mean * b.grad[i] + b.mean * a.grad[i]);
        let total = ta * tb
            + ta * b.mean * b.mean
            + tb * a.mean * a.mean
            + cov * cov
            + 2.0 * a.mean * b.mean * cov;
        Dist {
            mean: a.mean * b.mean + cov,
            grad,
            var: residual(total, self.footprint.linear_var(grad)),
        }
    }

    /// `1 / b` by the delta method (`1/μ + σ²/μ³`).
    fn reciprocal(&self, b: &Dist) -> Dist {
        let m = b.mean;
        self.smooth(b, (1.0 / m, -1.0 / (m * m), 2.0 / (m * m * m)), false)
    }

    /// `min(a, b) = a − (a − b)₊`, `max(a, b) = b + (a − b)₊`: the ramp's exact moments over
    /// the difference.
    fn min_max(&self, shapes: &Shapes, a: &Dist, b: &Dist, max: bool) -> Dist {
        if a.is_constant() && b.is_constant() {
            let v = if max {
                a.mean.max(b.mean)
            } else {
                a.mean.min(b.mean)
            };
            return Dist::constant(v);
        }
        let d = self.sub(a, b);
        let r = shapes.ramp.moments(d.mean, &self.spread(&d));
        // One side wins over the whole footprint: the result is that operand itself (so that
        // `max(r, g) - r` is exactly 0 where r wins, residual included).
        if r.slope == 0.0 && r.mean == 0.0 {
            return if max { *b } else { *a };
        }
        if r.slope == 1.0 && r.mean == d.mean {
            return if max { *a } else { *b };
        }
        let (base, sign) = if max { (b, 1.0) } else { (a, -1.0) };
        let mean = base.mean + sign * r.mean;
        let grad = std::array::from_fn(|i| base.grad[i] + sign * r.slope * d.grad[i]);
        // Var(base ± r) with Cov(base, r) ≈ slope · Cov(base, d) (Stein).
        let base_var = base.var * if max { -1.0 } else { 1.0 };
        let cov_base_d = self.footprint.covariance(base.grad, d.grad) + base_var;
        let total = self.total_var(base) + r.variance + 2.0 * sign * r.slope * cov_base_d;
        Dist {
            mean,
            grad,
            var: residual(total, self.footprint.linear_var(grad)),
        }
    }

    /// `fract(d)`; `floor(d) = d − fract(d)` (variance by `Cov(d, fract d) ≈ slope · Var d`).
    fn fract_floor(&self, d: &Dist, floor: bool) -> Dist {
        if d.is_constant() {
            let f = ops::fract(d.mean);
            return Dist::constant(if floor { d.mean.floor() } else { f });
        }
        let m = moments::fract_moments(d.mean, &self.spread(d));
        if !floor {
            return self.out_of_moments(d, m);
        }
        let t = self.total_var(d);
        let floor = Moments {
            mean: d.mean - m.mean,
            variance: (t + m.variance - 2.0 * m.slope * t).max(0.0),
            slope: 1.0 - m.slope,
        };
        self.out_of_moments(d, floor)
    }

    pub fn unary(&self, shapes: &Shapes, op: UnaryOp, d: &Dist) -> Dist {
        if d.is_constant() || d.mean.is_nan() {
            return Dist::constant(op.apply(d.mean));
        }
        let m = d.mean;
        match op {
            UnaryOp::Neg => d.scale(-1.0),
            // One spread for both the corner sum and the piecewise rule (it was made twice
            // where the corner sum declines: most lanes, whose support misses 0).
            UnaryOp::Abs => {
                // A support wholly on one side of 0: `±X` (`line_only`), most lanes of a sharp
                // octave or a small footprint.
                let widths = self.footprint.widths(d.grad);
                if let Some(line) = line_only(&shapes.abs, d, &widths) {
                    return line;
                }
                let spread = Spread::new(widths, d.var);
                let m = moments::abs_moments(d.mean, &spread)
                    .unwrap_or_else(|| shapes.abs.moments(d.mean, &spread));
                self.out_of_moments(d, m)
            }
            UnaryOp::Sign => self.piecewise(&shapes.sign, d),
            UnaryOp::Sin => self.sin_cos(d, false),
            UnaryOp::Cos => self.sin_cos(d, true),
            UnaryOp::Fract => self.fract_floor(d, false),
            UnaryOp::Floor => self.fract_floor(d, true),
            UnaryOp::Round => {
                let shifted = self.add(d, &Dist::constant(0.5));
                self.fract_floor(&shifted, true)
            }
            UnaryOp::Trunc => {
                // trunc x = floor x + [x < 0] (almost everywhere).
                let floor = self.fract_floor(d, true);
                let below = self.piecewise(&shapes.step, &d.scale(-1.0));
                self.add(&floor, &below)
            }
            UnaryOp::Exp => {
                // Exact for a Gaussian: E e^V = e^(μ + σ²/2).
                let t = self.total_var(d);
                let mean = (m + t / 2.0).exp();
                let grad = d.grad.map(|g| mean * g);
                let total = (t.exp() - 1.0) * mean * mean;
                Dist {
                    mean,
                    grad,
                    var: residual(total, self.footprint.linear_var(grad)),
                }
            }
            UnaryOp::Sqrt => self.sqrt(d),
            UnaryOp::Log => self.smooth(d, (m.ln(), 1.0 / m, -1.0 / (m * m)), true),
            UnaryOp::Log2 => {
                let k = std::f64::consts::LN_2;
                self.smooth(d, (m.log2(), 1.0 / (m * k), -1.0 / (m * m * k)), true)
            }
            UnaryOp::Tan => {
                let t = m.tan();
                let s = 1.0 + t * t;
                self.smooth(d, (t, s, 2.0 * t * s), false)
            }
            UnaryOp::Asin | UnaryOp::Acos => {
                let r = 1.0 / (1.0 - m * m).sqrt();
                let (f1, f2) = (r, m * r * r * r);
                let sign = if op == UnaryOp::Acos { -1.0 } else { 1.0 };
                self.smooth(d, (op.apply(m), sign * f1, sign * f2), false)
            }
        }
    }

    /// `√X` of a non-constant `X ≥ 0` (mean `m`, total variance `t`), exact where `X` is
    /// Gamma-distributed (shape `k = m²/t`, scale `t/m`): `E√X = √m · g(k)` with
    /// `g(k) = Γ(k + ½) / (Γ(k) √k)` ([`half_gamma_ratio`]), which is the delta method's
    /// `√m − t / 8m^{3/2}` while the spread is small against the mean and falls to 0 as it
    /// grows past it; the variance `m − (E√X)²` (exact for any `X ≥ 0`, as `E[(√X)²] = E X`);
    /// the slope `E√X / 2m` (`Cov(√X, X) / Var X` under the same model, `1 / 2√m` for a small
    /// spread). The delta method alone diverged near 0: the `Length` of a gradient that
    /// vanishes over most of a box (mean 4e-14, spread beyond it) had a variance of 1e19, and a
    /// `Smoothstep` of it read 0.5 where the box's mean is 0 (library/slate's pale edges).
    /// A mean ≤ 0: `X = 0` almost surely at 0, and below 0 the point tape's NaN.
    fn sqrt(&self, d: &Dist) -> Dist {
        let m = d.mean;
        let t = self.total_var(d);
        if m.is_nan() || m <= 0.0 {
            return Dist::constant(m.sqrt());
        }
        if t == 0.0 {
            // A point: the point tape's value to the bit.
            let s = m.sqrt();
            return Dist {
                mean: s,
                grad: d.grad.map(|g| 0.5 / s * g),
                var: 0.0,
            };
        }
        let (g, one_less) = half_gamma_ratio(m * m / t);
        let mean = m.sqrt() * g;
        let moments = Moments {
            mean,
            variance: m * one_less * (1.0 + g),
            slope: mean / (2.0 * m),
        };
        self.out_of_moments(d, moments)
    }

    /// `mod(K, P)` of an integer-valued `K` by a whole `P` ≥ 1 (a checker's parity, a cell
    /// index's residue). Where `K`'s variance is at most that of the two integers around its
    /// mean (the box straddles one cell face), `K` takes `n` and `n + 1` with probabilities
    /// `1 − p` and `p` (`n = floor μ`, `p = μ − n`): exact. Otherwise `K = round(Y)` for a
    /// continuous `Y` with `K`'s linear part and its residual less the rounding's 1/12
    /// (Sheppard's correction), and with `u = Y + 1/2`,
    /// `mod(K, P) = floor u − P floor(u/P)`, so `E = P·E[fract(u/P)] − E[fract u]` by the exact
    /// `fract` rule.
    pub fn lattice_mod(&self, k: &Dist, p: f64) -> Dist {
        let g = |v: f64| v - p * (v / p).floor();
        let (mu, t) = (k.mean, self.total_var(k));
        let n = mu.floor();
        let q = mu - n;
        if !mu.is_finite() {
            return Dist::constant(f64::NAN);
        }
        let (mean, var, slope) = if t <= q * (1.0 - q) + 1e-12 {
            let (g0, g1) = (g(n), g(n + 1.0));
            let mean = (1.0 - q) * g0 + q * g1;
            let square = (1.0 - q) * g0 * g0 + q * g1 * g1;
            (mean, (square - mean * mean).max(0.0), g1 - g0)
        } else {
            let widths = self.footprint.widths(k.grad);
            let u = Spread::new(widths, (k.var - 1.0 / 12.0).max(0.0));
            let scaled = Spread::new(
                widths.map(|w| w / p),
                (k.var - 1.0 / 12.0).max(0.0) / (p * p),
            );
            let whole = moments::fract_moments((mu + 0.5) / p, &scaled);
            let unit = moments::fract_moments(mu + 0.5, &u);
            let mean = p * whole.mean - unit.mean;
            // The residues' variance once the box spans several periods, less the mean's share.
            let square = (p - 1.0) * (2.0 * p - 1.0) / 6.0;
            (
                mean,
                (square - mean * mean).max(0.0),
                whole.slope - unit.slope,
            )
        };
        let grad = k.grad.map(|c| slope * c);
        Dist {
            mean,
            grad,
            var: residual(var, self.footprint.linear_var(grad)),
        }
    }

    pub fn binary(&self, shapes: &Shapes, op: BinaryOp, a: &Dist, b: &Dist) -> Dist {
        if (a.is_constant() && b.is_constant()) || a.mean.is_nan() || b.mean.is_nan() {
            return Dist::constant(op.apply(a.mean, b.mean));
        }
        match op {
            BinaryOp::Add => self.add(a, b),
            BinaryOp::Sub => self.sub(a, b),
            BinaryOp::Mul => self.mul(a, b),
            BinaryOp::Div => {
                if b.is_constant() {
                    return a.scale(1.0 / b.mean);
                }
                self.mul(a, &self.reciprocal(b))
            }
            BinaryOp::Min => self.min_max(shapes, a, b, false),
            BinaryOp::Max => self.min_max(shapes, a, b, true),
            BinaryOp::Step => self.piecewise(&shapes.step, &self.sub(b, a)),
            BinaryOp::Mod => {
                // b · fract(a / b) with b at its mean (a varying divisor is taken as its mean).
                let c = b.mean;
                if c == 0.0 || !c.is_finite() {
                    return Dist::constant(op.apply(a.mean, c));
                }
                let f = self.fract_floor(&a.scale(1.0 / c), false);
                f.scale(c)
            }
            BinaryOp::Pow => self.pow(a, b),
            BinaryOp::Atan2 => self.atan2(a, b),
        }
    }

    /// A smooth function of two values by the two-variable delta method: value, gradient
    /// `(fa, fb)` and Hessian `(faa, fbb, fab)` at the means.
    fn smooth2(&self, a: &Dist, b: &Dist, f: f64, g: (f64, f64), h: (f64, f64, f64)) -> Dist {
        let (ta, tb) = (self.total_var(a), self.total_var(b));
        let cov = self.footprint.covariance(a.grad, b.grad);
        let (fa, fb) = g;
        let (faa, fbb, fab) = h;
        let mut mean = f + 0.5 * (faa * ta + fbb * tb) + fab * cov;
        if !mean.is_finite() {
            mean = f;
        }
        let grad = std::array::from_fn(|i| fa * a.grad[i] + fb * b.grad[i]);
        let total = fa * fa * ta + fb * fb * tb + 2.0 * fa * fb * cov;
        Dist {
            mean,
            grad,
            var: residual(total, self.footprint.linear_var(grad)),
        }
    }

    fn pow(&self, a: &Dist, b: &Dist) -> Dist {
        let (x, y) = (a.mean, b.mean);
        let f = x.powf(y);
        if b.is_constant() {
            if x <= 0.0 && y.fract() != 0.0 {
                return Dist::constant(f);
            }
            let f1 = y * x.powf(y - 1.0);
            let f2 = y * (y - 1.0) * x.powf(y - 2.0);
            let concave = y > 0.0 && y < 1.0;
            return self.smooth(a, (f, f1, f2), concave);
        }
        if x <= 0.0 {
            return Dist::constant(f);
        }
        let l = x.ln();
        let fa = y * x.powf(y - 1.0);
        let fb = f * l;
        let faa = y * (y - 1.0) * x.powf(y - 2.0);
        let fbb = f * l * l;
        let fab = x.powf(y - 1.0) * (1.0 + y * l);
        self.smooth2(a, b, f, (fa, fb), (faa, fbb, fab))
    }

    fn atan2(&self, a: &Dist, b: &Dist) -> Dist {
        let (y, x) = (a.mean, b.mean);
        let r2 = x * x + y * y;
        let f = y.atan2(x);
        if r2 == 0.0 {
            return Dist::constant(f);
        }
        let r4 = r2 * r2;
        self.smooth2(
            a,
            b,
            f,
            (x / r2, -y / r2),
            (-2.0 * x * y / r4, 2.0 * x * y / r4, (y * y - x * x) / r4),
        )
    }

    pub fn ternary(&self, shapes: &Shapes, op: TernaryOp, a: &Dist, b: &Dist, c: &Dist) -> Dist {
        let all_constant = a.is_constant() && b.is_constant() && c.is_constant();
        if all_constant || a.mean.is_nan() || b.mean.is_nan() || c.mean.is_nan() {
            return Dist::constant(op.apply(a.mean, b.mean, c.mean));
        }
        match op {
            TernaryOp::Clamp => {
                if b.is_constant() && c.is_constant() && b.mean <= c.mean {
                    // lo + (hi − lo) clamp((x − lo) / (hi − lo), 0, 1): affine maps of one
                    // shape, exact.
                    let (lo, hi) = (b.mean, c.mean);
                    if lo == hi {
                        return Dist::constant(lo);
                    }
                    let t = self.sub(a, b).scale(1.0 / (hi - lo));
                    let unit = self.piecewise(&shapes.unit_clamp, &t);
                    return self.add(b, &unit.scale(hi - lo));
                }
                // clamp(x, lo, hi) = min(max(x, lo), hi).
                let lower = self.min_max(shapes, a, b, true);
                self.min_max(shapes, &lower, c, false)
            }
            TernaryOp::Mix => self.add(a, &self.mul(c, &self.sub(b, a))),
            TernaryOp::Smoothstep => {
                // t = (x − e0) / (e1 − e0), then the unit smoothstep (constant edges: an exact
                // affine map, `Div` by a constant being a scale); equal edges make a step.
                let span = self.sub(b, a);
                if span.mean == 0.0 {
                    return self.piecewise(&shapes.step, &self.sub(c, a));
                }
                let t = self.binary(shapes, BinaryOp::Div, &self.sub(c, a), &span);
                self.piecewise(&shapes.unit_smoothstep, &t)
            }
            TernaryOp::Select => self.select(a, b, c),
        }
    }

    /// `a` where `cond > 0`, else `b`: `p = P(cond > 0)` from the step's exact moments.
    fn select(&self, cond: &Dist, a: &Dist, b: &Dist) -> Dist {
        let s = self.spread(cond);
        let p = if s.widths() == [0.0; 3] {
            // A point: `cond > 0` strictly, as the point function (the ramp is 1 at 0).
            f64::from(u8::from(cond.mean > 0.0))
        } else {
            moments::ramp_mean(cond.mean, &s, 0)
        };
        let density = if cond.is_constant() {
            0.0
        } else {
            moments::density(cond.mean, &s)
        };
        let jump = a.mean - b.mean;
        let mean = p * a.mean + (1.0 - p) * b.mean;
        let grad = std::array::from_fn(|i| {
            let w = if density.is_finite() && density != 0.0 {
                jump * density * cond.grad[i]
            } else {
                0.0
            };
            p * a.grad[i] + (1.0 - p) * b.grad[i] + w
        });
        let total =
            p * self.total_var(a) + (1.0 - p) * self.total_var(b) + p * (1.0 - p) * jump * jump;
        Dist {
            mean,
            grad,
            var: residual(total, self.footprint.linear_var(grad)),
        }
    }
}

/// `f(d)` where `f` is one line over `d`'s whole support: that line applied to `d` exactly
/// (mean, linear part and residual scaled by its slope), without making `d`'s spread. The
/// support is bounded on the footprint's widths and the residual's two uniforms before
/// `Spread::new` merges them (a merge only shrinks it), so wherever this applies the piecewise
/// rule would find the same line (`moments.rs` `piecewise_early`). `None` otherwise.
fn line_only(f: &Piecewise, d: &Dist, widths: &[f64; 3]) -> Option<Dist> {
    let residual = (6.0 * d.var.max(0.0)).sqrt();
    let half = (widths.iter().map(|w| w.abs()).sum::<f64>() + 2.0 * residual) / 2.0;
    if !half.is_finite() || !d.mean.is_finite() {
        return None;
    }
    let (value, slope) = f.line_around(d.mean, half)?;
    Some(Dist {
        mean: value,
        grad: d.grad.map(|g| slope * g),
        var: slope * slope * d.var,
    })
}

/// The residual variance left when a linear part of variance `linear` is taken out of a total
/// variance `total`: 0 where the difference is rounding (below 1e-9 of the total), and where
/// either overflowed (an overflowing variance is dropped, not propagated as ∞ or NaN).
#[inline]
/// `g(k) = Γ(k + ½) / (Γ(k) √k)` for `k ≥ 0` and `1 − g(k)` (without cancellation for a
/// large `k`): the asymptotic series `1 − 1/8k + 1/128k² + 5/1024k³ − 21/32768k⁴ −
/// 399/262144k⁵ + 869/4194304k⁶` from `k = 8` on, below it shifted there by
/// `Γ(k + ½)/Γ(k) = Γ(k + 8½)/Γ(k + 8) · Π_{j<8} (k + j)/(k + j + ½)`; within 6e-10 of
/// the log-gamma ratio at every `k` (the test holds it to 1e-9 of the Gamma integrals:
/// `sqrt_rule_is_the_gamma_models_moments`). No crate of the
/// dependency tree has a log-gamma, and the GPU's rule (`filter.wgsl` `half_gamma_tail`, `r_sqrt`)
/// needs the same arithmetic.
pub(crate) fn half_gamma_ratio(k: f64) -> (f64, f64) {
    // 1 − g at k ≥ 8.
    let tail = |k: f64| {
        let u = 1.0 / k;
        u * (1.0 / 8.0
            - u * (1.0 / 128.0
                + u * (5.0 / 1024.0
                    + u * (-21.0 / 32768.0 + u * (-399.0 / 262144.0 + u * 869.0 / 4194304.0)))))
    };
    if k >= 8.0 {
        let h = tail(k);
        return (1.0 - h, h);
    }
    if k.is_nan() || k <= 0.0 {
        return (0.0, 1.0);
    }
    let mut p = ((k + 8.0) / k).sqrt();
    for j in 0..8 {
        let x = k + j as f64;
        p *= x / (x + 0.5);
    }
    let g = (1.0 - tail(k + 8.0)) * p;
    (g, 1.0 - g)
}

pub(super) fn residual(total: f64, linear: f64) -> f64 {
    let r = total - linear;
    if r.is_finite() && r > 1e-9 * total.abs() {
        r
    } else {
        0.0
    }
}

/// `(−1)^k / (2k + 1)!`, `k = 0..10`: sinc's Taylor coefficients in `x²`.
const SINC_TAYLOR: [f64; 10] = {
    let mut c = [0.0; 10];
    let mut f = 1.0;
    let mut k = 0;
    while k < 10 {
        if k > 0 {
            f *= ((2 * k) * (2 * k + 1)) as f64;
        }
        c[k] = if k % 2 == 0 { 1.0 / f } else { -1.0 / f };
        k += 1;
    }
    c
};

/// sin(x) / x, 1 at 0; 0 for an infinite x. Below 1 in magnitude by its Taylor series through
/// `x¹⁸` (the first term left out is below `1/21! ≈ 2e-20`): the rules take six of these per
/// `Sin` (two per footprint edge), and libm's `sin` and a division cost several times the
/// nine multiply-adds.
fn sinc(x: f64) -> f64 {
    if x.abs() < 1.0 {
        let y = x * x;
        SINC_TAYLOR.iter().rev().fold(0.0, |acc, &c| acc * y + c)
    } else if x.is_infinite() {
        0.0
    } else {
        trig::sin(x) / x
    }
}

#[cfg(test)]
mod tests {
    use super::Footprint;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a.iter().zip(&b).map(|(x, y)| x * y).sum()
    }

    /// `damp` scales the increment along each edge by its factor, for three, two (a pixel) and
    /// one non-zero edges, and leaves a slope alone where every factor is 1.
    #[test]
    fn damp_scales_each_edges_increment() {
        let g = [0.7, -1.3, 2.1];
        let cases = [
            [[0.5, 0.1, 0.0], [0.2, 0.4, 0.3], [0.0, -0.1, 0.6]],
            [[0.5, 0.1, 0.0], [0.2, 0.4, 0.3], [0.0; 3]],
            [[0.0; 3], [0.2, 0.4, 0.3], [0.0; 3]],
        ];
        let beta = [0.25, 0.5, 0.9];
        for edges in cases {
            let f = Footprint::from_edges(edges).unwrap();
            let d = f.damp(g, beta);
            for (k, e) in edges.iter().enumerate() {
                let want = if *e == [0.0; 3] {
                    0.0
                } else {
                    beta[k] * dot(g, *e)
                };
                assert!(
                    (dot(d, *e) - want).abs() < 1e-12,
                    "{edges:?} edge {k}: {d:?}"
                );
            }
            assert_eq!(f.damp(g, [1.0; 3]), g);
        }
        // Parallel edges: the Gram system is singular; the smallest factor scales the slope.
        let f = Footprint::from_edges([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0; 3]]).unwrap();
        assert_eq!(f.damp(g, beta), g.map(|c| c * 0.25));
    }

    /// `half_gamma_ratio` against the Gamma integrals themselves (trapezoids in `s = ln x`:
    /// `∫ x^a e^{−x} dx = ∫ e^{(a+1)s − e^s} ds`, smooth and fast-decaying), and
    /// `Rules::sqrt` within what any `X ≥ 0` allows: `0 ≤ E√X ≤ √m` and `E[(√X)²] = m`; the
    /// delta method where the spread is small against the mean.
    #[test]
    fn sqrt_rule_is_the_gamma_models_moments() {
        // ln ∫ x^a e^{−x} dx, the integrand scaled by its peak at s = ln(a + 1).
        let log_integral = |a: f64| {
            let b = a + 1.0;
            let peak = b * (b.ln() - 1.0);
            let (lo, hi, n) = (b.ln() - 40.0 / b - 10.0, b.ln().max(0.0) + 4.0, 400_000);
            let h = (hi - lo) / n as f64;
            let sum: f64 = (0..=n)
                .map(|i| {
                    let s = lo + i as f64 * h;
                    let w = if i == 0 || i == n { 0.5 } else { 1.0 };
                    w * (b * s - s.exp() - peak).exp()
                })
                .sum();
            peak + (sum * h).ln()
        };
        for k in [0.05, 0.3, 1.0, 2.5, 7.9, 8.0, 12.0, 40.0, 300.0] {
            let want = (log_integral(k - 0.5) - log_integral(k - 1.0)).exp() / k.sqrt();
            let (g, h) = super::half_gamma_ratio(k);
            assert!(
                (g - want).abs() < 1e-9 * want,
                "k = {k}: {g} against {want}"
            );
            assert!((g + h - 1.0).abs() < 1e-15, "k = {k}");
        }
        assert_eq!(super::half_gamma_ratio(f64::INFINITY), (1.0, 0.0));
        assert_eq!(super::half_gamma_ratio(0.0), (0.0, 1.0));

        let fp = Footprint::from_sides([0.1, 0.2, 0.3]).unwrap();
        let rules = super::Rules { footprint: &fp };
        for (mean, grad, var) in [
            (4e-14, [1e-6, 0.0, 0.0], 1e-10),
            (0.5, [1.0, -2.0, 0.5], 0.01),
            (2.0, [0.0; 3], 3.0),
            (1e6, [1.0, 1.0, 1.0], 0.0),
        ] {
            let d = super::Dist { mean, grad, var };
            let r = rules.sqrt(&d);
            let total = rules.total_var(&r);
            assert!(r.mean >= 0.0 && r.mean <= mean.sqrt(), "{d:?}: {r:?}");
            assert!(
                r.mean * r.mean + total <= mean * (1.0 + 1e-12),
                "{d:?}: {r:?}"
            );
            let t = rules.total_var(&d);
            if t < 1e-6 * mean * mean {
                let delta = mean.sqrt() - t / (8.0 * mean * mean.sqrt());
                assert!((r.mean - delta).abs() < 1e-12 * mean.sqrt(), "{d:?}: {r:?}");
            }
        }
    }
}
