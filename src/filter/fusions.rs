//! Which instructions the filtered form computes together with the instruction that produced
//! their operand, from that instruction's own argument (docs/filtering.md): an `Abs` of a `Sin`
//! or `Cos` (a Fourier series of the sine's argument), and a `Smoothstep` or `Step` with
//! constant edges `0 ≤ e0 ≤ e1` of an `Abs` (one piecewise function of the `Abs`'s argument).
//! Applying the rules one after the other would treat the intermediate value's spread as
//! unimodal, where it is arcsine-shaped or folded.
//!
//! One forward walk over the tape, as `integers.rs`: each scalar slot remembers which
//! instruction last wrote it. A pair's first instruction saves its argument in a side slot
//! when it runs (the argument's own slot may be reused before the second runs), and the second
//! reads it from there.

use super::moments::Piecewise;
use super::operands::Source;
use super::periodic::Periodic;
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Operand, Prec, Slot, SlotMap, Tape};

/// An instruction computed from its operand's producer's argument, saved in side slot `saved`.
#[derive(Clone, Debug, PartialEq)]
pub enum Fusion {
    /// `|sin arg|`, or `|cos arg|` with `cos`.
    AbsSin { saved: Slot, cos: bool },
    /// `shape(arg)`: `smoothstep(e0, e1, |arg|)` or `step(e, |arg|)` as one piecewise function.
    Folded { saved: Slot, shape: Piecewise },
    /// A periodic chain (`chains.rs`): per component of the result (one for a scalar, three
    /// for a vec3), `shape(fract(scale · arg))`.
    Periodic { parts: Vec<Part> },
}

/// One component of a periodic chain's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub saved: Slot,
    pub scale: f64,
    pub shape: Periodic,
}

/// The fusions of a tape.
#[derive(Clone, Debug, Default)]
pub struct Fusions {
    /// Per instruction: the operands saved before it runs, each with its side slot.
    pub save: Vec<Vec<(Source, Slot)>>,
    /// Per instruction: its fusion, if any.
    pub fused: Vec<Option<Fusion>>,
    /// Side slots.
    pub saved: usize,
    /// Per instruction: not run, its only reader being a fused `|sin|` that computes from its
    /// argument (and falls back to the plain rules on that argument itself).
    pub skip: Vec<bool>,
}

/// What produced a scalar slot's value: the `Sin`/`Cos` or the `Abs` at instruction `at`.
#[derive(Clone, Copy)]
enum Origin {
    Other,
    Sin { at: usize, cos: bool },
    Abs { at: usize },
}

/// The side slot of operand `source` of the instruction at `at`, made on first use.
pub(super) fn side_slot(f: &mut Fusions, at: usize, source: Source) -> Slot {
    if let Some(&(_, slot)) = f.save[at].iter().find(|(s, _)| *s == source) {
        return slot;
    }
    f.saved += 1;
    let slot = (f.saved - 1) as Slot;
    f.save[at].push((source, slot));
    slot
}

/// Every fusion of `tape` (`integer`: per instruction, whether each operand `a` component is
/// integer-valued, `integers.rs`).
pub fn fusions(tape: &Tape, integer: &[[bool; 3]]) -> Fusions {
    let n = tape.instrs.len();
    let mut chains = super::chains::Chains::new(tape);
    let mut f = Fusions {
        save: vec![Vec::new(); n],
        fused: vec![None; n],
        saved: 0,
        skip: vec![false; n],
    };
    // Per scalar slot (either precision): the instruction that produced its value, and its
    // constant.
    let mut origin = SlotMap::new(tape, Origin::Other);
    let mut constant: SlotMap<Option<f64>> = SlotMap::new(tape, None);
    for &(slot, v) in &tape.scalar_constants {
        *constant.s_mut(Prec::Lane, slot) = Some(v);
    }
    for &(slot, v) in &tape.wide_constants {
        *constant.s_mut(Prec::Wide, slot) = Some(v);
    }
    for (i, instr) in tape.instrs.iter().enumerate() {
        // A step or smoothstep of the `Abs` that produced `x`, with constant edges `e0`, `e1`.
        let folded = |f: &mut Fusions, prec: Prec, [x, e0, e1]: [Slot; 3]| {
            let Origin::Abs { at } = *origin.s(prec, x) else {
                return;
            };
            let (Some(lo), Some(hi)) = (*constant.s(prec, e0), *constant.s(prec, e1)) else {
                return;
            };
            if let Some(shape) = folded_step(lo, hi) {
                let saved = side_slot(f, at, src_of(&tape.instrs[at]));
                f.fused[i] = Some(Fusion::Folded { saved, shape });
            }
        };
        let made = match *instr {
            Instr::UnaryScalar { prec, op, src, .. } => {
                if let (UnaryOp::Abs, Origin::Sin { at, cos }) = (op, *origin.s(prec, src)) {
                    let saved = side_slot(&mut f, at, src_of(&tape.instrs[at]));
                    f.fused[i] = Some(Fusion::AbsSin { saved, cos });
                }
                match op {
                    UnaryOp::Sin | UnaryOp::Cos => Origin::Sin {
                        at: i,
                        cos: op == UnaryOp::Cos,
                    },
                    UnaryOp::Abs => Origin::Abs { at: i },
                    _ => Origin::Other,
                }
            }
            Instr::BinaryScalar {
                prec,
                op: BinaryOp::Step,
                a,
                b,
                ..
            } => {
                folded(&mut f, prec, [b, a, a]);
                Origin::Other
            }
            Instr::TernaryScalar {
                prec,
                op: TernaryOp::Smoothstep,
                a,
                b,
                c,
                ..
            } => {
                folded(&mut f, prec, [c, a, b]);
                Origin::Other
            }
            _ => Origin::Other,
        };
        if let Some(prec) = instr.writes().file.prec() {
            *origin.s_mut(prec, instr.writes().slot) = made;
        }
        if let Some(parts) = chains.visit(tape, i, instr, integer[i]) {
            // A chain's rule is exact: it replaces a plain fusion of the same instruction.
            let parts = parts.into_iter().map(|c| Part {
                saved: side_slot(&mut f, c.at, c.source),
                scale: c.scale,
                shape: c.shape,
            });
            f.fused[i] = Some(Fusion::Periodic {
                parts: parts.collect(),
            });
        }
    }
    skip_sole_producers(tape, &mut f);
    f
}

/// Marks the `Sin`/`Cos` of each fused `|sin|` whose value nothing else reads (before its slot
/// is written again, and not an output) as skipped.
fn skip_sole_producers(tape: &Tape, f: &mut Fusions) {
    for consumer in 0..tape.instrs.len() {
        let (Some(Fusion::AbsSin { .. }), &Instr::UnaryScalar { prec, src, .. }) =
            (&f.fused[consumer], &tape.instrs[consumer])
        else {
            continue;
        };
        let slot = Operand::scalar(prec, src);
        // The producer: the last writer of the slot before the consumer.
        let Some(at) = (0..consumer)
            .rev()
            .find(|&j| tape.instrs[j].writes() == slot)
        else {
            continue;
        };
        let mut sole = true;
        let mut rewritten = false;
        for (j, instr) in tape.instrs.iter().enumerate().skip(at + 1) {
            if j != consumer && instr.reads().contains(&slot) {
                sole = false;
                break;
            }
            if instr.writes() == slot {
                rewritten = true;
                break;
            }
        }
        // Outputs are read from lane-type or vec3 slots.
        let output = prec == Prec::Lane
            && tape
                .outputs
                .iter()
                .any(|o| o.ty == crate::graph::Type::Scalar && o.slot == src);
        if sole && (rewritten || !output) {
            f.skip[at] = true;
        }
    }
}

/// The operand of a unary scalar instruction (the producers of the plain fusions).
fn src_of(instr: &Instr) -> Source {
    match *instr {
        Instr::UnaryScalar { prec, src, .. } => Source::Scalar(prec, src),
        _ => unreachable!("plain fusions start at unary scalar instructions"),
    }
}

/// `smoothstep(e0, e1, |y|)` (a step where `e0 = e1`) as one piecewise function of `y`, for
/// edges `0 <= e0 <= e1`: 1 beyond `±e1`, the mirrored smoothstep between `±e0` and `±e1`, 0
/// inside `±e0` (the unit smoothstep `3t² − 2t³` and its mirror `1 − 3s² + 2s³` in local
/// coefficients). `None` for other edges (the plain rules then).
fn folded_step(lo: f64, hi: f64) -> Option<Piecewise> {
    if !(lo >= 0.0 && hi >= lo && hi.is_finite()) {
        return None;
    }
    let w = hi - lo;
    let (rise, fall) = if w > 0.0 {
        let (a2, a3) = (3.0 / (w * w), 2.0 / (w * w * w));
        ([0.0, 0.0, a2, -a3], [1.0, 0.0, -a2, a3])
    } else {
        ([1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0])
    };
    Some(Piecewise::new(
        vec![-hi, -lo, lo, hi],
        vec![
            [1.0, 0.0, 0.0, 0.0],
            fall,
            [0.0; 4],
            rise,
            [1.0, 0.0, 0.0, 0.0],
        ],
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tape(text: &str) -> Tape {
        let source = crate::diagnostic::SourceFile::new("f.ron", text);
        let graph = crate::check::check(source, &crate::check::CheckOptions::default()).unwrap();
        crate::compile::compile(&graph, &Default::default()).unwrap()
    }

    fn kinds(t: &Tape) -> Vec<&'static str> {
        fusions(t, &crate::filter::integers::integer_operands(t))
            .fused
            .iter()
            .flatten()
            .map(|f| match f {
                Fusion::AbsSin { cos: false, .. } => "abs sin",
                Fusion::AbsSin { cos: true, .. } => "abs cos",
                Fusion::Folded { .. } => "folded",
                Fusion::Periodic { .. } => "periodic",
            })
            .collect()
    }

    /// The pairs are found, also when a value feeds several and its argument's slot is reused
    /// in between (the argument is saved once per producer), and not with varying or negative
    /// edges.
    #[test]
    fn pairs_are_found_where_the_argument_holds() {
        let t = tape(
            r#"Graph(nodes: { "p": Position, "a": Abs("p.x") }, outputs: {
                "v": Abs(Sin("p.y")), "w": Abs(Cos("p.z")),
                "s": Smoothstep(0.0, 0.2, "a"), "h": Smoothstep(0.1, 0.5, "a"),
                "t": Step(0.3, "a"), "x": Smoothstep(0.0, "p.y", "a"), "n": Step(-1.0, "a") })"#,
        );
        let mut found = kinds(&t);
        found.sort_unstable();
        assert_eq!(found, ["abs cos", "abs sin", "folded", "folded", "folded"]);
        let integer = crate::filter::integers::integer_operands(&t);
        assert_eq!(fusions(&t, &integer).saved, 3, "one side slot per producer");
        assert_eq!(folded_step(0.5, 0.2), None);
        assert_eq!(folded_step(-0.1, 0.2), None);
    }

    /// Periodic chains: each instruction after a `Fract` or a `Mod` by a constant that is
    /// piecewise linear in it is fused (scalar and per component); a chain ends at anything
    /// else, and a `Mod` of an integer-valued value is left to the lattice rule.
    #[test]
    fn periodic_chains_are_found() {
        let t = tape(
            r#"Graph(nodes: { "p": Position, "f": Fract("p.x"), "v": Fract("p") }, outputs: {
                "tent": Sub(1.0, Abs(Sub(Mul(2.0, "f"), 1.0))),
                "vec": Abs(Sub("v", 0.5)),
                "ramp": ColorRamp(input: "f", stops: [(0.0, (0, 0, 0)), (0.5, (1, 1, 1))],
                                  interpolation: Constant),
                "smooth": Smoothstep(0.0, 0.4, "f"),
                "folded": Abs(Sub(Smoothstep(0.1, 0.3, "f"), 0.5)),
                "moved": Div(Mod("p.y", 0.3), 0.3),
                "parity": Mod(Floor("p.z"), 2.0),
                "ended": Sin(Mul(3.0, "f")) })"#,
        );
        let periodic = kinds(&t).iter().filter(|k| **k == "periodic").count();
        // tent: Mul, Sub, Abs, Sub; vec: Sub, Abs; ramp; smooth; folded: Smoothstep, Sub;
        // moved: Div; ended: the Mul. Not the Abs of a cubic, the sine, or either Mod (a
        // chain's start; an integer's parity).
        assert_eq!(periodic, 12, "{}", t);
    }

    /// A `Sin` read only by its fused `|sin|` is skipped; one that is also an output, or read
    /// by another instruction, is not.
    #[test]
    fn sole_producers_are_skipped() {
        let skipped = |text: &str| {
            let t = tape(text);
            let f = fusions(&t, &crate::filter::integers::integer_operands(&t));
            f.skip.iter().filter(|&&s| s).count()
        };
        let graph = |outputs: &str| {
            format!(
                r#"Graph(nodes: {{ "p": Position, "s": Sin(Mul(3.0, "p.x")) }}, outputs: {{ {outputs} }})"#
            )
        };
        assert_eq!(skipped(&graph(r#""v": Abs("s")"#)), 1);
        assert_eq!(skipped(&graph(r#""v": Abs("s"), "s": "s""#)), 0);
        assert_eq!(skipped(&graph(r#""v": Abs("s"), "w": Mul("s", 2.0)"#)), 0);
    }
}
