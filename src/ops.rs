//! The semantics of every per-lane operation, written once and generic over the lane type.
//!
//! The interpreter's lane loops, constant folding and the conformance tests all call these
//! functions, so a folded constant, a point evaluation and a batch evaluation compute the same
//! thing by construction. Edge cases (NaN, infinities, zero divisors) are defined here and
//! documented in docs/format.md.

use crate::real::Real;
use std::fmt;

/// The dot product of two vec3 values, in f64 (vec3 values are f64 on both paths). Folding and
/// the interpreter both call this.
#[inline(always)]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The cross product `a × b` (right-handed), in f64.
#[inline(always)]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `v / |v|`, with the vector first divided by its largest component so that no finite `v`
/// overflows or underflows on the way (`(1e200, 0, 0)` and `(1e-320, 0, 0)` both give
/// `(1, 0, 0)`); the zero vector stays `(0, 0, 0)`; an infinite or NaN component gives NaN.
#[inline(always)]
pub fn normalize(v: [f64; 3]) -> [f64; 3] {
    // NaN first: `f64::max` skips a NaN, so `(0, 0, NaN)` would otherwise pass as the zero
    // vector (the GPU's `max` need not skip it; found by the random-graph GPU test).
    if v.iter().any(|c| c.is_nan()) {
        return [f64::NAN; 3];
    }
    let largest = v[0].abs().max(v[1].abs()).max(v[2].abs());
    if largest == 0.0 {
        return [0.0; 3];
    }
    if !largest.is_finite() {
        return [f64::NAN; 3];
    }
    let scaled = v.map(|c| c / largest);
    let length = length(scaled);
    scaled.map(|c| c / length)
}

/// The Euclidean length of a vec3 value, in f64. Folding and the interpreter both call this.
#[inline(always)]
pub fn length(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Abs,
    Neg,
    Sin,
    Cos,
    Sqrt,
    Floor,
    Fract,
    Exp,
    Log,
    Log2,
    Tan,
    Asin,
    Acos,
    Sign,
    Round,
    Trunc,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Min,
    Max,
    Pow,
    Atan2,
    Mod,
    Step,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TernaryOp {
    Clamp,
    Mix,
    Smoothstep,
    Select,
}

impl UnaryOp {
    pub const ALL: [UnaryOp; 16] = [
        UnaryOp::Abs,
        UnaryOp::Neg,
        UnaryOp::Sin,
        UnaryOp::Cos,
        UnaryOp::Sqrt,
        UnaryOp::Floor,
        UnaryOp::Fract,
        UnaryOp::Exp,
        UnaryOp::Log,
        UnaryOp::Log2,
        UnaryOp::Tan,
        UnaryOp::Asin,
        UnaryOp::Acos,
        UnaryOp::Sign,
        UnaryOp::Round,
        UnaryOp::Trunc,
    ];

    #[inline(always)]
    pub fn apply<S: Real>(self, x: S) -> S {
        match self {
            UnaryOp::Abs => x.abs(),
            UnaryOp::Neg => -x,
            UnaryOp::Sin => x.sin(),
            UnaryOp::Cos => x.cos(),
            UnaryOp::Sqrt => x.sqrt(),
            UnaryOp::Floor => x.floor(),
            UnaryOp::Fract => fract(x),
            UnaryOp::Exp => x.exp(),
            UnaryOp::Log => x.ln(),
            UnaryOp::Log2 => x.log2(),
            UnaryOp::Tan => x.tan(),
            UnaryOp::Asin => x.asin(),
            UnaryOp::Acos => x.acos(),
            UnaryOp::Sign => sign_of(x),
            UnaryOp::Round => x.round(),
            UnaryOp::Trunc => x.trunc(),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            UnaryOp::Abs => "abs",
            UnaryOp::Neg => "neg",
            UnaryOp::Sin => "sin",
            UnaryOp::Cos => "cos",
            UnaryOp::Sqrt => "sqrt",
            UnaryOp::Floor => "floor",
            UnaryOp::Fract => "fract",
            UnaryOp::Exp => "exp",
            UnaryOp::Log => "log",
            UnaryOp::Log2 => "log2",
            UnaryOp::Tan => "tan",
            UnaryOp::Asin => "asin",
            UnaryOp::Acos => "acos",
            UnaryOp::Sign => "sign",
            UnaryOp::Round => "round",
            UnaryOp::Trunc => "trunc",
        }
    }
}

impl BinaryOp {
    pub const ALL: [BinaryOp; 10] = [
        BinaryOp::Add,
        BinaryOp::Sub,
        BinaryOp::Mul,
        BinaryOp::Div,
        BinaryOp::Min,
        BinaryOp::Max,
        BinaryOp::Pow,
        BinaryOp::Atan2,
        BinaryOp::Mod,
        BinaryOp::Step,
    ];

    #[inline(always)]
    pub fn apply<S: Real>(self, a: S, b: S) -> S {
        match self {
            BinaryOp::Add => a + b,
            BinaryOp::Sub => a - b,
            BinaryOp::Mul => a * b,
            BinaryOp::Div => a / b,
            BinaryOp::Min => a.min_nan(b),
            BinaryOp::Max => a.max_nan(b),
            BinaryOp::Pow => a.powf(b),
            BinaryOp::Atan2 => a.atan2(b),
            BinaryOp::Mod => floored_mod(a, b),
            BinaryOp::Step => step(a, b),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            BinaryOp::Add => "add",
            BinaryOp::Sub => "sub",
            BinaryOp::Mul => "mul",
            BinaryOp::Div => "div",
            BinaryOp::Min => "min",
            BinaryOp::Max => "max",
            BinaryOp::Pow => "pow",
            BinaryOp::Atan2 => "atan2",
            BinaryOp::Mod => "mod",
            BinaryOp::Step => "step",
        }
    }
}

impl TernaryOp {
    pub const ALL: [TernaryOp; 4] = [
        TernaryOp::Clamp,
        TernaryOp::Mix,
        TernaryOp::Smoothstep,
        TernaryOp::Select,
    ];

    /// NaN results are made the canonical NaN: which operand's NaN an operation returns
    /// depends on the operand order the compiler picks, which differed between the per-point
    /// and the vectorised code in release builds (`Mix(NaN, inf, NaN)`).
    #[inline(always)]
    pub fn apply<S: Real>(self, a: S, b: S, c: S) -> S {
        let r = match self {
            TernaryOp::Clamp => clamp(a, b, c),
            TernaryOp::Mix => a + c * (b - a),
            TernaryOp::Smoothstep => smoothstep(a, b, c),
            TernaryOp::Select => select(a, b, c),
        };
        if r.is_nan() {
            S::NAN
        } else {
            r
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            TernaryOp::Clamp => "clamp",
            TernaryOp::Mix => "mix",
            TernaryOp::Smoothstep => "smoothstep",
            TernaryOp::Select => "select",
        }
    }
}

impl fmt::Display for UnaryOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
impl fmt::Display for BinaryOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
impl fmt::Display for TernaryOp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// x - floor(x), kept in [0, 1): a tiny negative x would otherwise round up to exactly 1.
#[inline(always)]
pub fn fract<S: Real>(x: S) -> S {
    let r = x - x.floor();
    if r >= S::ONE {
        S::ONE_BELOW
    } else {
        r
    }
}

/// Floored modulo (the sign of b): the exact IEEE remainder, moved into b's half-line.
/// b = 0 or an infinite a give NaN (from the remainder).
#[inline(always)]
pub fn floored_mod<S: Real>(a: S, b: S) -> S {
    let r = a.rem(b);
    if r != S::ZERO && ((r < S::ZERO) != (b < S::ZERO)) {
        let moved = r + b;
        // A tiny remainder of the other sign rounds to b itself: keep the result inside
        // [0, b) (or (b, 0]), as Fract keeps inside [0, 1).
        if moved == b {
            b * S::ONE_BELOW
        } else {
            moved
        }
    } else {
        r
    }
}

/// min(max(x, lo), hi) with NaN propagation; when lo > hi the result is hi.
#[inline(always)]
pub fn clamp<S: Real>(x: S, lo: S, hi: S) -> S {
    x.max_nan(lo).min_nan(hi)
}

/// GLSL smoothstep; equal edges make a hard step (0 below the edge, 1 at and above it).
#[inline(always)]
pub fn smoothstep<S: Real>(edge0: S, edge1: S, x: S) -> S {
    if edge0 == edge1 {
        step(edge0, x)
    } else {
        let t = clamp((x - edge0) / (edge1 - edge0), S::ZERO, S::ONE);
        t * t * (S::from_f64(3.0) - S::from_f64(2.0) * t)
    }
}

/// The cubic Hermite spline of seed 000 with constant end values and slopes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hermite {
    pub p0: f64,
    pub p1: f64,
    pub m0: f64,
    pub m1: f64,
}

impl Hermite {
    /// t = clamp(x, 0, 1); h00 p0 + h10 m0 + h01 p1 + h11 m1. NaN in, NaN out.
    #[inline(always)]
    pub fn apply<S: Real>(&self, x: S) -> S {
        let t = clamp(x, S::ZERO, S::ONE);
        let t2 = t * t;
        let t3 = t2 * t;
        let two = S::from_f64(2.0);
        let three = S::from_f64(3.0);
        let h00 = two * t3 - three * t2 + S::ONE;
        let h10 = t3 - two * t2 + t;
        let h01 = three * t2 - two * t3;
        let h11 = t3 - t2;
        h00 * S::from_f64(self.p0)
            + h10 * S::from_f64(self.m0)
            + h01 * S::from_f64(self.p1)
            + h11 * S::from_f64(self.m1)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SplineInterpolation {
    Linear,
    /// Each segment eased with smoothstep: zero slope at every stop.
    Smooth,
    /// Each stop's value held until the next stop.
    Constant,
}

/// A piecewise spline through sorted knots with `N` channels: a ColorRamp (N = 3) or a Curve
/// (N = 1). Segment coefficients are precomputed at compile time; evaluation is in f64.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline<const N: usize> {
    knots: Vec<f64>,
    values: Vec<[f64; N]>,
    /// 1 / (knots[i+1] - knots[i]); 0 for a zero-width segment (never used for lookup).
    inverse_widths: Vec<f64>,
    interpolation: SplineInterpolation,
    /// This spline stands for the derivative of the one it was made from (`slope`): `eval`
    /// gives d/dt.
    slope: bool,
}

impl<const N: usize> Spline<N> {
    /// `knots` sorted non-decreasing, finite, at least one; the checker guarantees it.
    pub fn new(
        knots: Vec<f64>,
        values: Vec<[f64; N]>,
        interpolation: SplineInterpolation,
    ) -> Spline<N> {
        let inverse_widths = knots
            .windows(2)
            .map(|w| {
                if w[1] > w[0] {
                    1.0 / (w[1] - w[0])
                } else {
                    0.0
                }
            })
            .collect();
        Spline {
            knots,
            values,
            inverse_widths,
            interpolation,
            slope: false,
        }
    }

    /// The spline whose `eval` is this one's derivative d/dt (for `Gradient`): 0 outside the
    /// knots, where the input is clamped, and on Constant segments; at a knot, the slope of the
    /// segment the value takes (the one starting there).
    pub fn slope(&self) -> Spline<N> {
        Spline {
            slope: true,
            ..self.clone()
        }
    }

    pub fn is_slope(&self) -> bool {
        self.slope
    }

    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    pub fn values(&self) -> &[[f64; N]] {
        &self.values
    }

    pub fn interpolation(&self) -> SplineInterpolation {
        self.interpolation
    }

    /// Input clamped to the first and last knot; where knots coincide the later value wins from
    /// the knot on (a hard edge). NaN gives NaN in every channel.
    #[inline]
    pub fn eval(&self, t: f64) -> [f64; N] {
        let (Some(first), Some(last)) = (self.knots.first(), self.knots.last()) else {
            return [f64::NAN; N];
        };
        if t.is_nan() {
            return [f64::NAN; N];
        }
        if self.slope && !(t >= *first && t < *last) {
            return [0.0; N];
        }
        let t = t.max(*first).min(*last);
        // Number of knots <= t; at least 1 after clamping.
        let after = self.knots.partition_point(|&k| k <= t);
        let i = after.saturating_sub(1);
        if after >= self.knots.len() {
            return self.values[self.values.len() - 1];
        }
        let a = self.values[i];
        let b = self.values[after];
        let mut u = (t - self.knots[i]) * self.inverse_widths[i];
        if self.slope {
            // d/dt of a + e(u) (b - a), u' = 1 / width: e' = 1 (Linear), 6u(1 - u) (Smooth).
            let ease = match self.interpolation {
                SplineInterpolation::Constant => return [0.0; N],
                SplineInterpolation::Linear => 1.0,
                SplineInterpolation::Smooth => 6.0 * u * (1.0 - u),
            };
            let mut out = [0.0; N];
            for c in 0..N {
                out[c] = ease * (b[c] - a[c]) * self.inverse_widths[i];
            }
            return out;
        }
        match self.interpolation {
            SplineInterpolation::Constant => return a,
            SplineInterpolation::Linear => {}
            SplineInterpolation::Smooth => u = u * u * (3.0 - 2.0 * u),
        }
        let mut out = [0.0; N];
        for c in 0..N {
            out[c] = a[c] + u * (b[c] - a[c]);
        }
        out
    }
}

pub type Ramp = Spline<3>;
pub type Curve = Spline<1>;

/// sin and cos of an angle in degrees, exact at multiples of 90° so that quarter turns map
/// lattice points to lattice points.
pub fn sin_cos_degrees(degrees: f64) -> (f64, f64) {
    let r = degrees.rem_euclid(360.0);
    if r == 0.0 {
        (0.0, 1.0)
    } else if r == 90.0 {
        (1.0, 0.0)
    } else if r == 180.0 {
        (0.0, -1.0)
    } else if r == 270.0 {
        (-1.0, 0.0)
    } else {
        r.to_radians().sin_cos()
    }
}

/// The right-handed rotation matrix (rows) about a unit axis (Rodrigues' formula).
pub fn rotation_matrix(axis: [f64; 3], degrees: f64) -> [[f64; 3]; 3] {
    let (s, c) = sin_cos_degrees(degrees);
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
        [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
        [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
    ]
}

#[inline(always)]
pub fn apply_matrix(m: &[[f64; 3]; 3], p: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2],
        m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2],
        m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2],
    ]
}

/// Normalises a rotation axis; `None` for a zero or non-finite axis.
pub fn normalise_axis(axis: [f64; 3]) -> Option<[f64; 3]> {
    // Scale by the largest component first, so tiny (1e-320) and huge (1e300) axes neither
    // underflow nor overflow when squared.
    let largest = axis.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if !(largest.is_finite() && largest > 0.0) {
        return None;
    }
    let scaled = axis.map(|c| c / largest);
    let length = (scaled[0] * scaled[0] + scaled[1] * scaled[1] + scaled[2] * scaled[2]).sqrt();
    Some(scaled.map(|c| c / length))
}

/// GLSL's `sign`: -1 below 0, 1 above, and x itself at ±0 and NaN (so NaN propagates and the
/// zero keeps its sign).
#[inline(always)]
pub fn sign_of<S: Real>(x: S) -> S {
    if x > S::ZERO {
        S::ONE
    } else if x < S::ZERO {
        -S::ONE
    } else {
        x
    }
}

/// GLSL's `step(edge, x)`: 0 where x < edge, 1 where x >= edge; NaN if either is NaN (GLSL
/// leaves that open; NaN propagates here as everywhere else).
#[inline(always)]
pub fn step<S: Real>(edge: S, x: S) -> S {
    if edge.is_nan() || x.is_nan() {
        S::NAN
    } else if x < edge {
        S::ZERO
    } else {
        S::ONE
    }
}

/// `a` where `condition > 0`, else `b` (a NaN condition is not > 0: `b`).
#[inline(always)]
pub fn select<S: Real>(condition: S, a: S, b: S) -> S {
    if condition > S::ZERO {
        a
    } else {
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floored_mod_takes_sign_of_divisor() {
        assert_eq!(floored_mod(-0.5f64, 2.0), 1.5);
        assert_eq!(floored_mod(5.0f64, -3.0), -1.0);
        assert_eq!(floored_mod(7.0f32, 2.0), 1.0);
        assert!(floored_mod(1.0f64, 0.0).is_nan());
        assert!(floored_mod(f64::INFINITY, 2.0).is_nan());
        assert!(floored_mod(-1e-20f64, 1.0) < 1.0);
        assert!(floored_mod(1e-20f32, -1.0) > -1.0);
    }

    #[test]
    fn fract_stays_below_one() {
        assert_eq!(fract(-1e-20f64), f64::ONE_BELOW);
        assert_eq!(fract(-1e-20f32), f32::ONE_BELOW);
        assert_eq!(fract(2.25f64), 0.25);
        assert_eq!(fract(-0.25f32), 0.75);
        assert!(fract(f64::INFINITY).is_nan());
    }

    #[test]
    fn smoothstep_matches_glsl_and_handles_equal_edges() {
        assert_eq!(smoothstep(0.0f64, 1.0, 0.5), 0.5);
        assert_eq!(smoothstep(0.0f64, 1.0, -1.0), 0.0);
        assert_eq!(smoothstep(0.0f64, 1.0, 2.0), 1.0);
        assert_eq!(smoothstep(1.0f64, 1.0, 0.5), 0.0);
        assert_eq!(smoothstep(1.0f64, 1.0, 1.0), 1.0);
        assert!(smoothstep(1.0f64, 1.0, f64::NAN).is_nan());
    }

    #[test]
    fn hermite_hits_its_ends_and_slopes() {
        let h = Hermite {
            p0: 0.0,
            p1: 1.0,
            m0: 3.0,
            m1: 0.0,
        };
        assert_eq!(h.apply(0.0f64), 0.0);
        assert_eq!(h.apply(1.0f64), 1.0);
        assert_eq!(h.apply(-5.0f64), 0.0);
        assert_eq!(h.apply(5.0f64), 1.0);
        let eps = 1e-7;
        assert!(((h.apply(eps) - h.apply(0.0f64)) / eps - 3.0).abs() < 1e-5);
        assert!(h.apply(f64::NAN).is_nan());
    }

    #[test]
    fn spline_clamps_and_handles_coinciding_knots() {
        let ramp = Ramp::new(
            vec![0.0, 0.5, 0.5, 1.0],
            vec![[0.0; 3], [1.0; 3], [2.0; 3], [3.0; 3]],
            SplineInterpolation::Linear,
        );
        assert_eq!(ramp.eval(-1.0), [0.0; 3]);
        assert_eq!(ramp.eval(0.25), [0.5; 3]);
        assert_eq!(ramp.eval(0.5), [2.0; 3]);
        assert_eq!(ramp.eval(0.75), [2.5; 3]);
        assert_eq!(ramp.eval(2.0), [3.0; 3]);
        assert!(ramp.eval(f64::NAN)[0].is_nan());
        let constant = Curve::new(
            vec![0.0, 1.0],
            vec![[4.0], [5.0]],
            SplineInterpolation::Constant,
        );
        assert_eq!(constant.eval(0.99), [4.0]);
        assert_eq!(constant.eval(1.0), [5.0]);
        let single = Curve::new(vec![0.3], vec![[7.0]], SplineInterpolation::Smooth);
        assert_eq!(single.eval(-9.0), [7.0]);
        assert_eq!(single.eval(9.0), [7.0]);
    }

    #[test]
    fn quarter_turns_are_exact() {
        let m = rotation_matrix([0.0, 0.0, 1.0], 90.0);
        assert_eq!(apply_matrix(&m, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]);
        let m = rotation_matrix([0.0, 1.0, 0.0], -90.0);
        assert_eq!(apply_matrix(&m, [1.0, 0.0, 0.0]), [0.0, 0.0, 1.0]);
        assert!(normalise_axis([0.0, 0.0, 0.0]).is_none());
        assert_eq!(normalise_axis([1e-320, 0.0, 0.0]), Some([1.0, 0.0, 0.0]));
        assert_eq!(normalise_axis([0.0, 1e300, 0.0]), Some([0.0, 1.0, 0.0]));
    }
}
