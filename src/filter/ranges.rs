//! The interval each value of a tape surely lies in, for the piecewise rules: a ramp, curve or
//! Hermite spline that is one line over the interval its input cannot leave (`|sin|`, `fract`,
//! a clamp, a noise) is exactly that line of its input (`Piecewise::restricted`): its mean is
//! the line at the input's mean, its variance the slope squared times the input's. The rules
//! model a value's spread as a sum of uniforms, which leaks past the ends of such an interval,
//! where the ramp's clamped ends then made the mean too bright; seed 003 marble's colour over
//! `vein` in [0, 1] was half of its box bake's time in that rule.
//!
//! One forward walk over the tape, each slot's interval as instructions write it (slots are
//! reused). The intervals hold for every non-NaN value (infinities included); an operation
//! without a rule here gives the whole line.

use super::moments::Piecewise;
use super::rules::{hermite_shape, spline_shape};
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Prec, SlotMap, Tape};

/// A closed interval `[lo, hi]`, `lo <= hi` (or the whole line).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    pub lo: f64,
    pub hi: f64,
}

const ALL: Interval = Interval {
    lo: f64::NEG_INFINITY,
    hi: f64::INFINITY,
};

impl Interval {
    /// `[lo, hi]`, or the whole line where either end is NaN or they are out of order.
    fn new(lo: f64, hi: f64) -> Interval {
        if lo <= hi {
            Interval { lo, hi }
        } else {
            ALL
        }
    }

    fn point(v: f64) -> Interval {
        Interval::new(v, v)
    }

    fn is_bounded(&self) -> bool {
        self.lo.is_finite() || self.hi.is_finite()
    }
}

/// Per instruction: the interval of a `Hermite`, `Ramp` or `Curve` instruction's input where it
/// is bounded on at least one side; `None` for every other instruction.
pub fn piecewise_inputs(tape: &Tape) -> Vec<Option<Interval>> {
    let mut w = Walk(SlotMap::new(tape, ALL));
    for &(slot, v) in &tape.scalar_constants {
        *w.0.s_mut(Prec::Lane, slot) = Interval::point(v);
    }
    for &(slot, v) in &tape.wide_constants {
        *w.0.s_mut(Prec::Wide, slot) = Interval::point(v);
    }
    for &(slot, v) in &tape.vec3_constants {
        *w.0.v_mut(slot) = v.map(Interval::point);
    }
    tape.instrs
        .iter()
        .map(|instr| {
            let input = match *instr {
                Instr::Hermite { src, .. } | Instr::Ramp { src, .. } | Instr::Curve { src, .. } => {
                    Some(*w.0.s(Prec::Lane, src)).filter(Interval::is_bounded)
                }
                _ => None,
            };
            w.step(tape, instr);
            input
        })
        .collect()
}

/// A piecewise instruction's shapes over its input's interval.
#[derive(Clone, Debug)]
pub enum Restricted {
    /// A `Hermite`'s or a `Curve`'s shape.
    One(Piecewise),
    /// A `Ramp`'s three channels.
    Three([Piecewise; 3]),
}

/// Per instruction: a `Hermite`'s or `Curve`'s shape or a `Ramp`'s channels restricted to the
/// interval of the instruction's input (`Piecewise::restricted`), where that leaves a knot
/// out; `None` elsewhere. The CPU's and the GPU's filtered forms both take their shapes from
/// here.
pub fn restricted_shapes(tape: &Tape) -> Vec<Option<Restricted>> {
    piecewise_inputs(tape)
        .into_iter()
        .zip(&tape.instrs)
        .map(|(input, instr)| {
            let Interval { lo, hi } = input?;
            let shapes: Vec<Piecewise> = match *instr {
                Instr::Hermite { spline, .. } => {
                    vec![hermite_shape(&tape.hermites[spline as usize])]
                }
                Instr::Curve { curve, .. } => {
                    vec![spline_shape(tape.curves[curve as usize].as_ref(), 0)]
                }
                Instr::Ramp { ramp, .. } => {
                    let ramp = tape.ramps[ramp as usize].as_ref();
                    (0..3).map(|c| spline_shape(ramp, c)).collect()
                }
                _ => return None,
            };
            let restricted: Vec<Option<Piecewise>> =
                shapes.iter().map(|f| f.restricted(lo, hi)).collect();
            if restricted.iter().all(Option::is_none) {
                return None;
            }
            let mut fs = restricted
                .into_iter()
                .zip(shapes)
                .map(|(r, f)| r.unwrap_or(f));
            match (fs.next(), fs.next(), fs.next()) {
                (Some(r), Some(g), Some(b)) => Some(Restricted::Three([r, g, b])),
                (Some(f), None, None) => Some(Restricted::One(f)),
                _ => None,
            }
        })
        .collect()
}

/// Each slot's interval as the walk reaches an instruction.
struct Walk(SlotMap<Interval>);

impl Walk {
    fn step(&mut self, tape: &Tape, instr: &Instr) {
        let w = &mut self.0;
        match *instr {
            Instr::UnaryScalar { prec, op, dst, src } => {
                *w.s_mut(prec, dst) = unary(op, *w.s(prec, src))
            }
            Instr::UnaryVec3 { op, dst, src } => *w.v_mut(dst) = w.v(src).map(|x| unary(op, x)),
            Instr::BinaryScalar {
                prec,
                op,
                dst,
                a,
                b,
            } => *w.s_mut(prec, dst) = binary(op, *w.s(prec, a), *w.s(prec, b)),
            Instr::BinaryVec3 { op, dst, a, b } => {
                let (x, y) = (*w.v(a), *w.v(b));
                *w.v_mut(dst) = std::array::from_fn(|i| binary(op, x[i], y[i]));
            }
            Instr::TernaryScalar {
                prec,
                op,
                dst,
                a,
                b,
                c,
            } => {
                let [x, y, z] = [a, b, c].map(|k| *w.s(prec, k));
                *w.s_mut(prec, dst) = ternary(op, x, y, z);
            }
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                let [x, y, z] = [a, b, c].map(|k| *w.v(k));
                *w.v_mut(dst) = std::array::from_fn(|i| ternary(op, x[i], y[i], z[i]));
            }
            Instr::Splat { prec, dst, src } => *w.v_mut(dst) = [*w.s(prec, src); 3],
            Instr::Combine { prec, dst, x, y, z } => {
                *w.v_mut(dst) = [x, y, z].map(|k| *w.s(prec, k))
            }
            Instr::Component {
                prec,
                dst,
                src,
                axis,
            } => *w.s_mut(prec, dst) = w.v(src)[axis as usize % 3],
            Instr::Length { prec, dst, .. } => {
                *w.s_mut(prec, dst) = Interval::new(0.0, f64::INFINITY)
            }
            Instr::Noise {
                prec, dst, table, ..
            } => {
                let (lo, hi) = tape.tables[table as usize].1.range();
                *w.s_mut(prec, dst) = Interval::new(lo, hi);
            }
            Instr::Widen { dst, src } => *w.s_mut(Prec::Wide, dst) = *w.s(Prec::Lane, src),
            Instr::Narrow { dst, src } => *w.s_mut(Prec::Lane, dst) = *w.s(Prec::Wide, src),
            ref other => w.clear(other, ALL),
        }
    }
}

/// The image of an interval under a non-decreasing function.
fn monotone(x: Interval, f: impl Fn(f64) -> f64) -> Interval {
    Interval::new(f(x.lo), f(x.hi))
}

fn unary(op: UnaryOp, x: Interval) -> Interval {
    match op {
        UnaryOp::Sin | UnaryOp::Cos | UnaryOp::Sign => Interval::new(-1.0, 1.0),
        UnaryOp::Fract => Interval::new(0.0, 1.0),
        UnaryOp::Neg => Interval::new(-x.hi, -x.lo),
        UnaryOp::Abs => {
            if x.lo >= 0.0 {
                x
            } else if x.hi <= 0.0 {
                Interval::new(-x.hi, -x.lo)
            } else {
                Interval::new(0.0, x.hi.max(-x.lo))
            }
        }
        UnaryOp::Floor => monotone(x, f64::floor),
        UnaryOp::Round => monotone(x, f64::round),
        UnaryOp::Trunc => monotone(x, f64::trunc),
        UnaryOp::Exp => monotone(x, f64::exp),
        UnaryOp::Sqrt if x.hi >= 0.0 => Interval::new(x.lo.max(0.0).sqrt(), x.hi.sqrt()),
        UnaryOp::Acos => Interval::new(0.0, std::f64::consts::PI),
        UnaryOp::Asin => Interval::new(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
        _ => ALL,
    }
}

fn binary(op: BinaryOp, a: Interval, b: Interval) -> Interval {
    match op {
        BinaryOp::Add => Interval::new(a.lo + b.lo, a.hi + b.hi),
        BinaryOp::Sub => Interval::new(a.lo - b.hi, a.hi - b.lo),
        BinaryOp::Mul => {
            let p = [a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi];
            if p.iter().any(|x| x.is_nan()) {
                return ALL; // 0 · ∞
            }
            Interval::new(
                p.iter().copied().fold(f64::INFINITY, f64::min),
                p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        }
        BinaryOp::Min => Interval::new(a.lo.min(b.lo), a.hi.min(b.hi)),
        BinaryOp::Max => Interval::new(a.lo.max(b.lo), a.hi.max(b.hi)),
        BinaryOp::Step => Interval::new(0.0, 1.0),
        BinaryOp::Atan2 => Interval::new(-std::f64::consts::PI, std::f64::consts::PI),
        _ => ALL,
    }
}

fn ternary(op: TernaryOp, a: Interval, b: Interval, c: Interval) -> Interval {
    match op {
        // `ops::clamp`: min(max(x, lo), hi), non-decreasing in each argument.
        TernaryOp::Clamp => Interval::new(a.lo.max(b.lo).min(c.lo), a.hi.max(b.hi).min(c.hi)),
        TernaryOp::Smoothstep => Interval::new(0.0, 1.0),
        TernaryOp::Select => Interval::new(b.lo.min(c.lo), b.hi.max(c.hi)),
        TernaryOp::Mix => ALL,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each rule's interval holds every value of the operation at points sampled in the
    /// operands' intervals (ends included), for bounded and one-sided operands.
    #[test]
    fn rules_hold_their_values() {
        let intervals = [
            Interval::new(-2.5, 3.0),
            Interval::new(0.25, 0.75),
            Interval::new(-4.0, -1.0),
            Interval::new(0.0, 0.0),
            Interval::new(1.0, f64::INFINITY),
        ];
        let spaced = |x: Interval, n: u32| {
            let (lo, hi) = (x.lo, x.hi.min(x.lo + 50.0));
            (0..=n).map(move |k| lo + (hi - lo) * f64::from(k) / f64::from(n))
        };
        let samples = |x: Interval| spaced(x, 20);
        let inside = |v: f64, i: Interval| v.is_nan() || (v >= i.lo && v <= i.hi);
        for op in UnaryOp::ALL {
            for x in intervals {
                let r = unary(op, x);
                for u in samples(x) {
                    let v = op.apply(u);
                    assert!(inside(v, r), "{op:?} {u} = {v} outside {r:?} ({x:?})");
                }
            }
        }
        let binaries = [
            BinaryOp::Add,
            BinaryOp::Sub,
            BinaryOp::Mul,
            BinaryOp::Min,
            BinaryOp::Max,
            BinaryOp::Step,
            BinaryOp::Atan2,
        ];
        for op in binaries {
            for (a, b) in intervals
                .iter()
                .flat_map(|a| intervals.iter().map(move |b| (*a, *b)))
            {
                let r = binary(op, a, b);
                for u in samples(a) {
                    for w in samples(b) {
                        let v = op.apply(u, w);
                        assert!(inside(v, r), "{op:?}({u}, {w}) = {v} outside {r:?}");
                    }
                }
            }
        }
        for op in [TernaryOp::Clamp, TernaryOp::Smoothstep, TernaryOp::Select] {
            for a in intervals {
                for b in intervals {
                    for c in intervals {
                        let r = ternary(op, a, b, c);
                        for u in spaced(a, 6) {
                            for w in spaced(b, 6) {
                                for z in spaced(c, 6) {
                                    let v = op.apply(u, w, z);
                                    assert!(
                                        inside(v, r),
                                        "{op:?}({u}, {w}, {z}) = {v} not in {r:?}"
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
