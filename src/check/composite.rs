//! The composite kinds: lowered into operations that exist (component-wise math, `Select`,
//! `Length`, `Dot`), so the tape, the interpreter, folding, level of detail and `Gradient` need
//! nothing new for them. Each formula here is the one docs/format.md gives.

use super::*;
use crate::ops::{TernaryOp, UnaryOp};

/// Rec. 709 / sRGB relative luminance weights (ITU-R BT.709-6, item 3.3).
pub(crate) const REC709: [f64; 3] = [0.2126, 0.7152, 0.0722];

impl Checker {
    /// The operation (and arguments) a composite kind ends in; the nodes before it are added
    /// here. `operands` are the kind's inputs in catalogue order.
    pub(super) fn composite(
        &mut self,
        lowering: Lowering,
        operands: &[NodeId],
        clamp: bool,
        mode: &str,
        here: &Origin,
    ) -> Option<(Op, Args)> {
        let mut b = Build {
            checker: self,
            here,
        };
        Some(match lowering {
            Lowering::MapRange => {
                let v = b.widest(operands);
                let (x, from_min, from_max, to_min, to_max) = (v[0], v[1], v[2], v[3], v[4]);
                let t = b.binary(BinaryOp::Sub, x, from_min);
                let width = b.binary(BinaryOp::Sub, from_max, from_min);
                let mut t = b.binary(BinaryOp::Div, t, width);
                if clamp {
                    let ty = b.checker.builder.ty(t);
                    let (zero, one) = (b.scalar(0.0), b.scalar(1.0));
                    let (zero, one) = (b.like(zero, ty), b.like(one, ty));
                    t = b.ternary(TernaryOp::Clamp, t, zero, one);
                }
                (Op::Ternary(TernaryOp::Mix), smallvec![to_min, to_max, t])
            }
            Lowering::Distance => {
                let d = b.binary(BinaryOp::Sub, operands[0], operands[1]);
                (Op::Length, smallvec![d])
            }
            Lowering::Luminance => {
                let weights = b.vec3(REC709);
                (Op::Dot, smallvec![operands[0], weights])
            }
            Lowering::HsvToRgb => b.hsv_to_rgb(operands[0]),
            Lowering::RgbToHsv => b.rgb_to_hsv(operands[0]),
            Lowering::Blend => {
                let v = b.widest(operands);
                let blended = b.blend(mode, v[0], v[1]);
                (Op::Ternary(TernaryOp::Mix), smallvec![v[0], blended, v[2]])
            }
            _ => return None,
        })
    }
}

impl Checker {
    /// `Gradient(of)`: the derivative subgraph of `derive.rs`; a noise gradient inside `of`
    /// (a second derivative of noise) is reported at the Gradient node.
    pub(super) fn gradient(&mut self, of: NodeId, here: &Origin) -> Option<NodeId> {
        match crate::derive::gradient(&mut self.builder, of, here) {
            Ok(id) => Some(id),
            Err(_) => {
                self.error(
                    Diagnostic::new(
                        Class::NotDifferentiable,
                        "this Gradient would need the second derivative of a noise, which texgraph does not compute",
                    )
                    .in_node(&*here.node)
                    .at(here.span)
                    .label("the gradient of a noise gradient")
                    .help("differentiate the noise once: take the Gradient of the scalar the noise feeds"),
                );
                None
            }
        }
    }
}

/// Node creation at one origin.
struct Build<'c> {
    checker: &'c mut Checker,
    here: &'c Origin,
}

impl Build<'_> {
    fn add(&mut self, op: Op, args: Args) -> NodeId {
        self.checker.builder.add(op, args, self.here)
    }

    fn scalar(&mut self, v: f64) -> NodeId {
        self.add(Op::ConstScalar(v), Args::new())
    }

    fn vec3(&mut self, v: [f64; 3]) -> NodeId {
        self.add(Op::ConstVec3(v), Args::new())
    }

    /// `id` splatted to `ty` when it is a scalar and `ty` a vec3.
    fn like(&mut self, id: NodeId, ty: Type) -> NodeId {
        self.checker.builder.broadcast(id, ty, self.here)
    }

    /// The operands made one type: vec3 if any is.
    fn widest(&mut self, ids: &[NodeId]) -> Args {
        self.checker.broadcast_all(ids, self.here)
    }

    fn unary(&mut self, op: UnaryOp, a: NodeId) -> NodeId {
        self.add(Op::Unary(op), smallvec![a])
    }

    /// A binary operation, the scalar operand splatted when the other is a vec3.
    fn binary(&mut self, op: BinaryOp, a: NodeId, b: NodeId) -> NodeId {
        let v = self.widest(&[a, b]);
        self.add(Op::Binary(op), v)
    }

    fn ternary(&mut self, op: TernaryOp, a: NodeId, b: NodeId, c: NodeId) -> NodeId {
        let v = self.widest(&[a, b, c]);
        self.add(Op::Ternary(op), v)
    }

    fn component(&mut self, v: NodeId, axis: u8) -> NodeId {
        self.add(Op::Component(axis), smallvec![v])
    }

    /// `mode(base, layer)`, per component (W3C Compositing and Blending Level 1, section 9.1,
    /// separable modes; Add, Subtract as painters use them; nothing clamped):
    /// Mix `l`; Multiply `b l`; Screen `b + l - b l`; Overlay `2 b l` where `b < 0.5`, else
    /// `Screen(l, 2 b - 1)`; Add `b + l`; Subtract `b - l`; Difference `|b - l|`; Darken
    /// `min(b, l)`; Lighten `max(b, l)`.
    fn blend(&mut self, mode: &str, base: NodeId, layer: NodeId) -> NodeId {
        match mode {
            "Multiply" => self.binary(BinaryOp::Mul, base, layer),
            "Screen" => self.screen(base, layer),
            "Overlay" => {
                // W3C: Overlay(b, l) = HardLight(l, b): Multiply(l, 2b) for b <= 0.5, else
                // Screen(l, 2b - 1). The two agree at b = 0.5, so `0.5 - b > 0` may pick.
                let ty = self.checker.builder.ty(base);
                let two = self.scalar(2.0);
                let twice = self.binary(BinaryOp::Mul, two, base);
                let dark = self.binary(BinaryOp::Mul, twice, layer);
                let one = self.scalar(1.0);
                let lifted = self.binary(BinaryOp::Sub, twice, one);
                let light = self.screen(layer, lifted);
                let half = self.scalar(0.5);
                let half = self.like(half, ty);
                let below = self.binary(BinaryOp::Sub, half, base);
                self.ternary(TernaryOp::Select, below, dark, light)
            }
            "Add" => self.binary(BinaryOp::Add, base, layer),
            "Subtract" => self.binary(BinaryOp::Sub, base, layer),
            "Difference" => {
                let d = self.binary(BinaryOp::Sub, base, layer);
                self.unary(UnaryOp::Abs, d)
            }
            "Darken" => self.binary(BinaryOp::Min, base, layer),
            "Lighten" => self.binary(BinaryOp::Max, base, layer),
            _ => layer, // Mix
        }
    }

    /// W3C screen: `b + l - b l`.
    fn screen(&mut self, b: NodeId, l: NodeId) -> NodeId {
        let sum = self.binary(BinaryOp::Add, b, l);
        let product = self.binary(BinaryOp::Mul, b, l);
        self.binary(BinaryOp::Sub, sum, product)
    }

    /// HSV → RGB in the branch-free form of the shader literature (as in Sam Hocevar's
    /// `hsv2rgb`): `rgb = v · mix(1, clamp(|fract(h + (1, 2/3, 1/3)) · 6 − 3| − 1, 0, 1), s)`.
    /// Each channel is the hue's piecewise-linear ramp, so every hue wraps.
    fn hsv_to_rgb(&mut self, hsv: NodeId) -> (Op, Args) {
        let h = self.component(hsv, 0);
        let s = self.component(hsv, 1);
        let v = self.component(hsv, 2);
        let h = self.like(h, Type::Vec3);
        let offsets = self.vec3([1.0, 2.0 / 3.0, 1.0 / 3.0]);
        let shifted = self.binary(BinaryOp::Add, h, offsets);
        let wrapped = self.unary(UnaryOp::Fract, shifted);
        let six = self.scalar(6.0);
        let scaled = self.binary(BinaryOp::Mul, wrapped, six);
        let three = self.scalar(3.0);
        let centred = self.binary(BinaryOp::Sub, scaled, three);
        let folded = self.unary(UnaryOp::Abs, centred);
        let one = self.scalar(1.0);
        let ramp = self.binary(BinaryOp::Sub, folded, one);
        let (zero, one3) = (self.vec3([0.0; 3]), self.vec3([1.0; 3]));
        let pure = self.ternary(TernaryOp::Clamp, ramp, zero, one3);
        let s = self.like(s, Type::Vec3);
        let tinted = self.ternary(TernaryOp::Mix, one3, pure, s);
        let v = self.like(v, Type::Vec3);
        (Op::Binary(BinaryOp::Mul), smallvec![tinted, v])
    }

    /// RGB → HSV: value `max`, saturation `(max − min) / max` (0 where max <= 0), hue in turns
    /// from the sector of the largest channel (r: `(g − b) / c`, g: `(b − r) / c + 2`,
    /// b: `(r − g) / c + 4`, c = max − min), `fract(sector / 6)`, 0 for greys (c = 0). Ties
    /// between largest channels pick r, then g (the sectors agree there).
    fn rgb_to_hsv(&mut self, rgb: NodeId) -> (Op, Args) {
        let [r, g, b] = [0, 1, 2].map(|c| self.component(rgb, c));
        let rg = self.binary(BinaryOp::Max, r, g);
        let max = self.binary(BinaryOp::Max, rg, b);
        let rg = self.binary(BinaryOp::Min, r, g);
        let min = self.binary(BinaryOp::Min, rg, b);
        let chroma = self.binary(BinaryOp::Sub, max, min);
        let sector = |this: &mut Self, x: NodeId, y: NodeId, offset: f64| {
            let d = this.binary(BinaryOp::Sub, x, y);
            let d = this.binary(BinaryOp::Div, d, chroma);
            let offset = this.scalar(offset);
            this.binary(BinaryOp::Add, d, offset)
        };
        let red = sector(self, g, b, 0.0);
        let green = sector(self, b, r, 2.0);
        let blue = sector(self, r, g, 4.0);
        // r is the largest where r >= max(g, b); else g where g >= b. (The same choice as
        // `r >= max` and `g >= max`, but a difference with no point mass at 0: over a
        // footprint `r − max(r, g, b)` is never positive, and the filtered `Step` took it as a
        // continuous spread around its mean, mixing the hue's sectors.)
        let g_max = self.binary(BinaryOp::Step, b, g);
        let green_or_blue = self.ternary(TernaryOp::Select, g_max, green, blue);
        let gb = self.binary(BinaryOp::Max, g, b);
        let r_max = self.binary(BinaryOp::Step, gb, r);
        let sector = self.ternary(TernaryOp::Select, r_max, red, green_or_blue);
        let sixth = self.scalar(1.0 / 6.0);
        let turns = self.binary(BinaryOp::Mul, sector, sixth);
        let turns = self.unary(UnaryOp::Fract, turns);
        let zero = self.scalar(0.0);
        let hue = self.ternary(TernaryOp::Select, chroma, turns, zero);
        let saturation = self.binary(BinaryOp::Div, chroma, max);
        let saturation = self.ternary(TernaryOp::Select, max, saturation, zero);
        (Op::Combine, smallvec![hue, saturation, max])
    }
}

/// Lowered here, beside `Gradient`'s lowering, and not in `graph.rs`: the graph types stand
/// below the derivative transform, which builds on them.
impl CheckedGraph {
    /// The same graph with one more output, `name`: the gradient (a vec3, `Gradient`) of the
    /// scalar output `of`. For callers that need a surface's slope beside its value (the
    /// renderer's bump mapping): the derivative nodes join the graph's own, deduplicated.
    pub fn with_gradient_output(&self, of: &str, name: &str) -> Result<CheckedGraph, String> {
        let output = self
            .output(of)
            .ok_or_else(|| format!("the graph has no output `{of}`"))?;
        if self.nodes[output.node as usize].ty != Type::Scalar {
            return Err(format!(
                "output `{of}` is a vec3: a height must be a scalar"
            ));
        }
        let mut builder = GraphBuilder::from_nodes(&self.nodes);
        let origin = self.nodes[output.node as usize].origin.clone();
        let gradient = crate::derive::gradient(&mut builder, output.node, &origin).map_err(|_| {
            format!("output `{of}` uses a noise gradient: its gradient would need a second derivative of noise")
        })?;
        let mut graph = self.clone();
        graph.nodes = builder.nodes;
        graph.outputs.push(Output {
            name: name.to_string(),
            node: gradient,
            span: output.span,
        });
        Ok(graph)
    }
}
