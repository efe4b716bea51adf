//! Per operation: the range of its value over its arguments' ranges, bounds on its partial
//! derivatives there, and how much one f32 evaluation of it rounds. One match per question over
//! the graph's operations (as `derive.rs` has one chain rule per operation), so a new operation
//! is a compile error here until it says all three.
//!
//! Discontinuous operations (Floor, Fract, Step, Mod, Select, comparisons, cell values) use the
//! *edge rule*: their slope is taken as 1, so an input error `e` moves an edge by at most `e` in
//! the input's units instead of counting as an infinite error. docs/accuracy.md states the
//! contract this gives.

use super::interval::Interval;
use crate::graph::{Op, Type};
use crate::noise::{Basis, Style};
use crate::ops::{BinaryOp, SplineInterpolation, TernaryOp, UnaryOp};
use smallvec::{smallvec, SmallVec};
use std::f64::consts::PI;

/// A node's value range: one interval for a scalar, three for a vec3 (per component).
pub type Range = [Interval; 3];

/// Partial derivative bounds, one per argument.
pub type Partials = SmallVec<[f64; 3]>;

fn scalar(i: Interval) -> Range {
    [i; 3]
}

fn magnitude(r: &Range) -> f64 {
    r.iter().fold(0.0f64, |m, i| m.max(i.magnitude()))
}

/// The range of `op`'s value given its arguments' ranges (`position`: the extent).
pub fn range(op: &Op, ty: Type, args: &[Range], position: Range) -> Range {
    let a = |i: usize| args[i][0];
    match op {
        Op::Position => position,
        Op::ConstScalar(v) => scalar(Interval::point(*v)),
        Op::ConstVec3(v) => v.map(Interval::point),
        Op::Splat => scalar(a(0)),
        Op::Combine => [args[0][0], args[1][0], args[2][0]],
        Op::Component(axis) => scalar(args[0][*axis as usize % 3]),
        Op::Unary(u) => componentwise(ty, args, |x| unary(*u, x[0])),
        Op::Binary(b) => componentwise(ty, args, |x| binary(*b, x[0], x[1])),
        Op::Ternary(t) => componentwise(ty, args, |x| ternary(*t, x[0], x[1], x[2])),
        Op::Dot => {
            let sum = (args[0].iter().zip(&args[1]))
                .fold(Interval::point(0.0), |sum, (p, q)| sum.add(p.mul(*q)));
            scalar(sum)
        }
        Op::Length => scalar(Interval::new(0.0, norm(&args[0]))),
        Op::Cross => {
            let (p, q) = (&args[0], &args[1]);
            let term = |i: usize, j: usize| p[i].mul(q[j]).sub(p[j].mul(q[i]));
            [term(1, 2), term(2, 0), term(0, 1)]
        }
        Op::Normalize => scalar(Interval::symmetric(1.0)),
        Op::Rotate { axis } => rotate_range(*axis, &args[0], args[1][0]),
        Op::Noise(key) => {
            let (lo, hi) = key.basis.range();
            scalar(Interval::new(lo, hi))
        }
        Op::Fractal(key, params) => {
            let schedule = params.schedule();
            let sum: f64 = schedule.amplitudes.iter().map(|a| a.abs()).sum();
            let term = style_term(key.basis, params.style);
            scalar(Interval::symmetric(sum * term))
        }
        Op::NoiseGradient(key) => scalar(Interval::symmetric(key.basis.lipschitz())),
        Op::FractalGradient(key, params) => {
            let schedule = params.schedule();
            let sum: f64 = (schedule.frequencies.iter())
                .zip(&schedule.amplitudes)
                .map(|(f, a)| (f * a).abs())
                .sum();
            scalar(Interval::symmetric(sum * key.basis.lipschitz()))
        }
        Op::Hermite(h) => scalar(Interval::symmetric(
            h.p0.abs() + h.p1.abs() + h.m0.abs() + h.m1.abs(),
        )),
        Op::Ramp(r) => spline_range(r.values()),
        Op::Curve(c) => scalar(spline_range(c.values())[0]),
    }
}

/// A scalar operation applied per component (vec3) or once (scalar).
fn componentwise(ty: Type, args: &[Range], f: impl Fn(&[Interval]) -> Interval) -> Range {
    let lanes = if ty == Type::Vec3 { 3 } else { 1 };
    let mut out = [Interval::TOP; 3];
    for (c, o) in out.iter_mut().enumerate().take(lanes) {
        let column: SmallVec<[Interval; 3]> = args.iter().map(|r| r[c]).collect();
        *o = f(&column);
    }
    if lanes == 1 {
        out = [out[0]; 3];
    }
    out
}

/// Rodrigues' formula over intervals (`ops::rotation_matrix`): the sum of v cos θ,
/// (a × v) sin θ and a (a · v)(1 − cos θ), each component also within the norm bound |v| that
/// any rotation keeps. Per component, so a point far along one axis and turned by a known angle keeps its
/// other components' ranges (and a square root of their squares stays away from 0).
fn rotate_range(axis: [f64; 3], v: &Range, degrees: Interval) -> Range {
    let n = Interval::symmetric(norm(v));
    let Some(a) = crate::ops::normalise_axis(axis) else {
        return [n; 3];
    };
    let theta = degrees.mul(Interval::point(PI / 180.0));
    let (c, s) = (theta.cos(), theta.sin());
    let k = a.map(Interval::point);
    let cross = [
        k[1].mul(v[2]).sub(k[2].mul(v[1])),
        k[2].mul(v[0]).sub(k[0].mul(v[2])),
        k[0].mul(v[1]).sub(k[1].mul(v[0])),
    ];
    let along = (0..3).fold(Interval::point(0.0), |d, i| d.add(k[i].mul(v[i])));
    let t = Interval::point(1.0).sub(c);
    std::array::from_fn(|i| {
        let r = v[i].mul(c).add(cross[i].mul(s)).add(k[i].mul(along).mul(t));
        r.intersect(n)
    })
}

fn norm(r: &Range) -> f64 {
    r.iter().map(|i| i.magnitude().powi(2)).sum::<f64>().sqrt()
}

/// The largest magnitude of one octave's term of a fractal style.
fn style_term(basis: Basis, style: Style) -> f64 {
    let (lo, hi) = basis.range();
    let r = lo.abs().max(hi.abs());
    match style {
        Style::Fbm | Style::Turbulence => r,
        Style::Billow => 2.0 * r + 1.0,
        Style::Ridged { offset, sharpness } => offset.abs().max(r).powf(sharpness).max(1.0),
    }
}

fn spline_range<const N: usize>(values: &[[f64; N]]) -> Range {
    let mut out = [Interval::point(0.0); 3];
    for (c, o) in out.iter_mut().enumerate().take(N) {
        let lo = values.iter().map(|v| v[c]).fold(f64::INFINITY, f64::min);
        let hi = values
            .iter()
            .map(|v| v[c])
            .fold(f64::NEG_INFINITY, f64::max);
        *o = Interval::new(lo, hi);
    }
    out
}

fn unary(op: UnaryOp, x: Interval) -> Interval {
    match op {
        UnaryOp::Abs => x.abs(),
        UnaryOp::Neg => x.neg(),
        UnaryOp::Sin | UnaryOp::Cos => Interval::symmetric(1.0),
        UnaryOp::Sqrt => Interval::new(0.0, x.hi.max(0.0).sqrt()),
        UnaryOp::Floor => x.increasing(f64::floor),
        UnaryOp::Round => x.increasing(f64::round),
        UnaryOp::Trunc => x
            .abs()
            .increasing(f64::trunc)
            .hull(x.increasing(f64::trunc)),
        UnaryOp::Fract => Interval::new(0.0, 1.0),
        UnaryOp::Exp => x.increasing(f64::exp),
        UnaryOp::Log => x.increasing(|v| v.max(0.0).ln()),
        UnaryOp::Log2 => x.increasing(|v| v.max(0.0).log2()),
        UnaryOp::Tan => Interval::TOP,
        UnaryOp::Asin => Interval::symmetric(PI / 2.0),
        UnaryOp::Acos => Interval::new(0.0, PI),
        UnaryOp::Sign => Interval::symmetric(1.0),
    }
}

fn binary(op: BinaryOp, a: Interval, b: Interval) -> Interval {
    match op {
        BinaryOp::Add => a.add(b),
        BinaryOp::Sub => a.sub(b),
        BinaryOp::Mul => a.mul(b),
        BinaryOp::Div => a.div(b),
        BinaryOp::Min => a.min(b),
        BinaryOp::Max => a.max(b),
        BinaryOp::Pow => pow_range(a, b),
        BinaryOp::Atan2 => Interval::symmetric(PI),
        BinaryOp::Mod => Interval::symmetric(b.magnitude()),
        BinaryOp::Step => Interval::new(0.0, 1.0),
    }
}

/// a^b for a >= 0 is monotone in each argument, so its extremes lie at the corners; a negative
/// base (NaN or a sign that depends on b) gives no bound.
fn pow_range(a: Interval, b: Interval) -> Interval {
    if a.lo < 0.0 {
        return Interval::TOP;
    }
    let c = [
        a.lo.powf(b.lo),
        a.lo.powf(b.hi),
        a.hi.powf(b.lo),
        a.hi.powf(b.hi),
    ];
    let mut r = Interval::new(
        c.iter().copied().fold(f64::INFINITY, f64::min),
        c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
    if a.lo <= 1.0 && a.hi >= 1.0 {
        r = r.hull(Interval::point(1.0));
    }
    r
}

fn ternary(op: TernaryOp, a: Interval, b: Interval, c: Interval) -> Interval {
    match op {
        TernaryOp::Clamp => a.max(b).min(c).hull(c.min(b.max(c))),
        TernaryOp::Mix => a.add(c.mul(b.sub(a))),
        TernaryOp::Smoothstep => Interval::new(0.0, 1.0),
        TernaryOp::Select => b.hull(c),
    }
}

/// Bounds on |∂value/∂argument| over the arguments' ranges, each argument's error measured as
/// its largest component error (a vec3's error moves a point by up to √3 times it).
pub fn partials(op: &Op, args: &[Range]) -> Partials {
    let mag = |i: usize| magnitude(&args[i]);
    const SQRT3: f64 = 1.732_050_807_568_877_2;
    match op {
        Op::Position | Op::ConstScalar(_) | Op::ConstVec3(_) => smallvec![],
        Op::Splat | Op::Component(_) => smallvec![1.0],
        Op::Combine => smallvec![1.0, 1.0, 1.0],
        Op::Unary(u) => smallvec![unary_slope(*u, (0..3).map(|c| args[0][c]))],
        Op::Binary(b) => {
            let both = (0..3).map(|c| binary_slopes(*b, args[0][c], args[1][c]));
            let (x, y) = both.fold((0.0f64, 0.0f64), |m, s| (m.0.max(s.0), m.1.max(s.1)));
            smallvec![x, y]
        }
        Op::Ternary(t) => {
            let mut m = [0.0f64; 3];
            for ((a, b), c) in args[0].iter().zip(&args[1]).zip(&args[2]) {
                let s = ternary_slopes(*t, *a, *b, *c);
                for (m, s) in m.iter_mut().zip(s) {
                    *m = m.max(s);
                }
            }
            SmallVec::from_slice(&m)
        }
        Op::Dot => smallvec![3.0 * mag(1), 3.0 * mag(0)],
        Op::Length => smallvec![SQRT3],
        Op::Cross => smallvec![2.0 * mag(1), 2.0 * mag(0)],
        Op::Normalize => {
            let nearest = args[0]
                .iter()
                .map(|i| i.least_magnitude())
                .fold(0.0, f64::max);
            smallvec![if nearest > 0.0 {
                2.0 * SQRT3 / nearest
            } else {
                f64::INFINITY
            }]
        }
        Op::Rotate { .. } => smallvec![SQRT3, PI / 180.0 * norm(&args[0])],
        Op::Noise(key) => smallvec![SQRT3 * edge_rule(key.basis.lipschitz())],
        Op::Fractal(key, params) | Op::FractalGradient(key, params) => {
            let schedule = params.schedule();
            let sum: f64 = (schedule.frequencies.iter())
                .zip(&schedule.amplitudes)
                .map(|(f, a)| (f * a).abs())
                .sum();
            let shaping = match params.style {
                Style::Fbm | Style::Turbulence => 1.0,
                Style::Billow => 2.0,
                Style::Ridged { offset, sharpness } => {
                    2.0 * sharpness.max(1.0) * offset.abs().max(1.0).powf(sharpness)
                }
            };
            let second = if matches!(op, Op::FractalGradient(..)) {
                8.0 * schedule
                    .frequencies
                    .iter()
                    .fold(1.0f64, |m, f| m.max(f.abs()))
            } else {
                1.0
            };
            smallvec![SQRT3 * shaping * second * edge_rule(key.basis.lipschitz()) * sum]
        }
        Op::NoiseGradient(key) => smallvec![SQRT3 * 8.0 * edge_rule(key.basis.lipschitz())],
        Op::Hermite(h) => {
            smallvec![6.0 * (h.p0.abs() + h.p1.abs()) + 4.0 * (h.m0.abs() + h.m1.abs())]
        }
        Op::Ramp(r) => smallvec![spline_slope(r.knots(), r.values(), r.interpolation())],
        Op::Curve(c) => smallvec![spline_slope(c.knots(), c.values(), c.interpolation())],
    }
}

/// A basis or spline that jumps (an infinite Lipschitz bound) is flat between its jumps; the
/// jumps are edges (`edges`).
fn edge_rule(slope: f64) -> f64 {
    if slope.is_finite() {
        slope
    } else {
        0.0
    }
}

/// The edge rule: for each argument of a discontinuous operation, the weight with which an
/// error in it moves one of the operation's jumps (0: continuous in that argument). The
/// analysis keeps every such movement within the target, in the argument's own units, as if
/// each jump were an output of its own.
pub fn edges(op: &Op) -> Partials {
    const SQRT3: f64 = 1.732_050_807_568_877_2;
    match op {
        Op::Unary(
            UnaryOp::Floor | UnaryOp::Fract | UnaryOp::Round | UnaryOp::Trunc | UnaryOp::Sign,
        ) => smallvec![1.0],
        Op::Binary(BinaryOp::Step | BinaryOp::Mod) => smallvec![1.0, 1.0],
        Op::Ternary(TernaryOp::Select) => smallvec![1.0, 0.0, 0.0],
        Op::Ternary(TernaryOp::Smoothstep) => smallvec![1.0, 1.0, 1.0],
        Op::Noise(key) | Op::Fractal(key, _) if key.basis.lipschitz().is_infinite() => {
            smallvec![SQRT3]
        }
        Op::Ramp(r) if jumps(r.knots(), r.values(), r.interpolation()) => smallvec![1.0],
        Op::Curve(c) if jumps(c.knots(), c.values(), c.interpolation()) => smallvec![1.0],
        _ => Partials::new(),
    }
}

/// Whether a spline jumps: constant interpolation, or two stops at one knot.
fn jumps<const N: usize>(knots: &[f64], values: &[[f64; N]], how: SplineInterpolation) -> bool {
    how == SplineInterpolation::Constant
        || knots
            .windows(2)
            .zip(values.windows(2))
            .any(|(k, v)| k[1] <= k[0] && v[1] != v[0])
}

/// The steepest segment of a spline (1.5× for smooth segments' eased middle); a jump (two stops
/// at one knot) follows the edge rule.
fn spline_slope<const N: usize>(
    knots: &[f64],
    values: &[[f64; N]],
    how: SplineInterpolation,
) -> f64 {
    // Coinciding knots and constant interpolation make jumps: edges, not slopes.
    if how == SplineInterpolation::Constant {
        return 0.0;
    }
    let mut steepest = 0.0f64;
    for (k, v) in knots.windows(2).zip(values.windows(2)) {
        let change = (0..N).fold(0.0f64, |m, c| m.max((v[1][c] - v[0][c]).abs()));
        let width = k[1] - k[0];
        if width > 0.0 {
            steepest = steepest.max(1.5 * change / width);
        }
    }
    steepest
}

fn unary_slope(op: UnaryOp, xs: impl Iterator<Item = Interval>) -> f64 {
    xs.map(|x| match op {
        UnaryOp::Abs | UnaryOp::Neg | UnaryOp::Sin | UnaryOp::Cos => 1.0,
        // Flat between their jumps (the jumps are edges, `edges`).
        UnaryOp::Floor | UnaryOp::Round | UnaryOp::Trunc | UnaryOp::Sign => 0.0,
        UnaryOp::Fract => 1.0,
        // Near 0 the slope is unbounded but the change is not: below the input's own f32
        // rounding scale δ = |x|·2^-24, sqrt moves by at most √δ, the slope at δ times δ.
        UnaryOp::Sqrt => 0.5 / x.lo.max(x.magnitude() * 5.960_464_477_539_063e-8).sqrt(),
        UnaryOp::Exp => x.hi.exp(),
        UnaryOp::Log => 1.0 / x.lo.max(0.0),
        UnaryOp::Log2 => 1.0 / (x.lo.max(0.0) * std::f64::consts::LN_2),
        UnaryOp::Tan => {
            if x.lo > -PI / 2.0 && x.hi < PI / 2.0 {
                1.0 + x.magnitude().tan().powi(2)
            } else {
                f64::INFINITY
            }
        }
        UnaryOp::Asin | UnaryOp::Acos => {
            let m = x.magnitude();
            if m < 1.0 {
                1.0 / (1.0 - m * m).sqrt()
            } else {
                f64::INFINITY
            }
        }
    })
    .fold(0.0, f64::max)
}

fn binary_slopes(op: BinaryOp, a: Interval, b: Interval) -> (f64, f64) {
    match op {
        BinaryOp::Add | BinaryOp::Sub | BinaryOp::Min | BinaryOp::Max => (1.0, 1.0),
        BinaryOp::Step => (0.0, 0.0),
        BinaryOp::Mul => (b.magnitude(), a.magnitude()),
        BinaryOp::Div => {
            let least = b.least_magnitude();
            if least > 0.0 {
                (1.0 / least, a.magnitude() / (least * least))
            } else {
                (f64::INFINITY, f64::INFINITY)
            }
        }
        BinaryOp::Pow => {
            if a.lo <= 0.0 {
                return (f64::INFINITY, f64::INFINITY);
            }
            let corners = |f: &dyn Fn(f64, f64) -> f64| {
                [(a.lo, b.lo), (a.lo, b.hi), (a.hi, b.lo), (a.hi, b.hi)]
                    .iter()
                    .map(|&(x, y)| f(x, y).abs())
                    .fold(0.0, f64::max)
            };
            let power = corners(&|x, y| x.powf(y)).max(1.0);
            let da = b.magnitude() * corners(&|x, y| x.powf(y - 1.0)).max(1.0);
            let db = a.lo.ln().abs().max(a.hi.ln().abs()) * power;
            (da, db)
        }
        BinaryOp::Atan2 => {
            let r = a.least_magnitude().hypot(b.least_magnitude());
            if r > 0.0 {
                (1.0 / r, 1.0 / r)
            } else {
                (f64::INFINITY, f64::INFINITY)
            }
        }
        BinaryOp::Mod => {
            let least = b.least_magnitude();
            if least > 0.0 {
                (1.0, a.magnitude() / least + 1.0)
            } else {
                (1.0, f64::INFINITY)
            }
        }
    }
}

fn ternary_slopes(op: TernaryOp, a: Interval, b: Interval, c: Interval) -> [f64; 3] {
    match op {
        TernaryOp::Clamp => [1.0; 3],
        TernaryOp::Select => [0.0, 1.0, 1.0],
        TernaryOp::Mix => {
            let t = c.magnitude();
            [1.0 + t, t, b.sub(a).magnitude()]
        }
        TernaryOp::Smoothstep => {
            let span = b.sub(a);
            let width = span.least_magnitude();
            if width > 0.0 {
                [1.5 / width; 3]
            } else if span == Interval::point(0.0) {
                // Equal edges make a step: flat but for its edge.
                [0.0; 3]
            } else {
                [f64::INFINITY; 3]
            }
        }
    }
}

/// How many units of f32 rounding (2^-24 of the value's magnitude) one evaluation of `op` adds
/// on the fast path, where its value is a scalar in the lane type. Vec3 values are f64 on both
/// paths (nothing added); noise and fractal interiors run in the lane type.
pub fn f32_roundings(op: &Op, ty: Type) -> f64 {
    if ty == Type::Vec3 {
        return match op {
            Op::NoiseGradient(..) | Op::FractalGradient(..) => 8.0,
            _ => 0.0,
        };
    }
    match op {
        Op::Unary(u) => match u {
            UnaryOp::Abs | UnaryOp::Neg | UnaryOp::Floor | UnaryOp::Round => 0.0,
            UnaryOp::Trunc | UnaryOp::Sign => 0.0,
            UnaryOp::Sqrt | UnaryOp::Fract => 1.0,
            _ => 2.0,
        },
        Op::Binary(b) => match b {
            BinaryOp::Min | BinaryOp::Max | BinaryOp::Step => 0.0,
            BinaryOp::Pow | BinaryOp::Atan2 => 2.0,
            _ => 1.0,
        },
        Op::Ternary(TernaryOp::Clamp | TernaryOp::Select) => 0.0,
        Op::Ternary(_) => 4.0,
        // Cellular and simplex interiors are longer (distances, square roots, skews).
        Op::Noise(key) | Op::Fractal(key, _)
            if matches!(key.basis, Basis::Cellular(_) | Basis::Simplex) =>
        {
            32.0
        }
        Op::Noise(_) | Op::Fractal(..) | Op::Hermite(_) => 8.0,
        _ => 1.0,
    }
}

/// Units of f64 rounding (2^-53 of the magnitude) one evaluation adds in the reference itself.
pub fn f64_roundings(op: &Op, ty: Type) -> f64 {
    match op {
        Op::Position | Op::ConstScalar(_) | Op::ConstVec3(_) => 0.0,
        Op::Splat | Op::Combine | Op::Component(_) => 0.0,
        _ => f32_roundings(op, Type::Scalar).max(if ty == Type::Vec3 { 1.0 } else { 0.0 }),
    }
}

/// Operations the fast path can run in f64 on the wide slots (`Instr::Wide`): the math, the
/// vector operations that read or make scalars, and noise samples, fractal sums and their
/// gradients (every basis' f64 form, the reference path's kernels).
pub fn promotable(op: &Op, ty: Type) -> bool {
    match op {
        Op::Component(_) | Op::Dot | Op::Length | Op::Splat | Op::Combine => true,
        Op::Rotate { .. } => true,
        Op::Unary(_) | Op::Binary(_) | Op::Ternary(_) => ty == Type::Scalar,
        Op::Noise(_) | Op::Fractal(..) => ty == Type::Scalar,
        Op::NoiseGradient(_) | Op::FractalGradient(..) => true,
        _ => false,
    }
}

/// The largest magnitude of a range.
pub fn range_magnitude(r: &Range) -> f64 {
    magnitude(r)
}
