//! `Gradient`: exact derivatives by forward-mode differentiation, done as a graph transform.
//!
//! Every node the differentiated node depends on carries, beside its value, its tangent: the
//! three partial derivatives with respect to the sample point (a scalar node's tangent is three
//! scalar nodes, a vec3 node's the three columns of its Jacobian, each a vec3 node). A node's
//! tangent is built from its arguments' tangents by its operation's chain rule, as graph nodes
//! (`Mul`, `Add`, the operation's partial derivatives written with the math nodes, and for noise
//! the basis' analytic gradient, `Op::NoiseGradient` / `Op::FractalGradient`). So the tangents
//! go through the same hash-consing, folding, slot allocation and interpreter as the values:
//! point = batch bit for bit, f32 and f64 from one tape, and only what feeds a `Gradient` is
//! differentiated (the rest of the tape is unchanged). Zero tangents are structural (`None`):
//! a constant's derivative costs nothing, and a partial derivative is never multiplied by a
//! zero tangent (which would turn an infinite or NaN partial into NaN).
//!
//! Where a function is not differentiable the rule gives the one-sided or almost-everywhere
//! value (docs/format.md, "Gradient", lists each): jumps (Floor, Round, Trunc, Sign, Step, the
//! switch of Select) are flat; Fract and Mod have the slope of their ramps; Abs at 0, Min/Max at
//! ties, Clamp at its bounds and the splines at their knots take the side their value takes.

use crate::graph::{GraphBuilder, NodeId, Op, Origin, Type};
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use rustc_hash::FxHashMap;
use smallvec::smallvec;

/// A node's derivative with respect to the sample point: three partials (scalar nodes) or the
/// three Jacobian columns ∂v/∂x, ∂v/∂y, ∂v/∂z (vec3 nodes); `None` is exactly zero.
#[derive(Clone, Copy, Debug)]
enum Tangent {
    Scalar([Option<NodeId>; 3]),
    /// The sample point itself: the identity Jacobian, kept symbolic so that `Noise(Position)`
    /// reads its gradient's components directly.
    Identity,
    Vector([Option<NodeId>; 3]),
}

const ZERO_SCALAR: Tangent = Tangent::Scalar([None; 3]);
const ZERO_VECTOR: Tangent = Tangent::Vector([None; 3]);

/// A node that cannot be differentiated (a noise gradient: texgraph has no second derivatives of noise).
#[derive(Debug)]
pub(crate) struct NotDifferentiable;

/// The gradient (a vec3 node) of scalar node `of` with respect to the sample point.
pub(crate) fn gradient(
    builder: &mut GraphBuilder,
    of: NodeId,
    origin: &Origin,
) -> Result<NodeId, NotDifferentiable> {
    let mut d = Deriver {
        b: builder,
        origin,
        tangents: FxHashMap::default(),
    };
    for id in d.reachable(of) {
        let t = d.tangent(id)?;
        d.tangents.insert(id, t);
    }
    let partials = match d.tangents[&of] {
        Tangent::Scalar(p) => p,
        _ => return Err(NotDifferentiable),
    };
    Ok(d.assemble(partials))
}

struct Deriver<'a> {
    b: &'a mut GraphBuilder,
    origin: &'a Origin,
    tangents: FxHashMap<NodeId, Tangent>,
}

impl Deriver<'_> {
    /// The nodes `of` depends on (itself included), arguments before their users: a node's
    /// arguments always have smaller ids, so ascending order is a dependency order.
    fn reachable(&self, of: NodeId) -> Vec<NodeId> {
        let mut seen = vec![of];
        let mut stack = vec![of];
        while let Some(id) = stack.pop() {
            for &a in &self.b.node(id).args {
                if !seen.contains(&a) {
                    seen.push(a);
                    stack.push(a);
                }
            }
        }
        seen.sort_unstable();
        seen
    }

    fn add(&mut self, op: Op, args: crate::graph::Args) -> NodeId {
        self.b.add(op, args, self.origin)
    }

    fn scalar(&mut self, v: f64) -> NodeId {
        self.add(Op::ConstScalar(v), smallvec![])
    }

    fn vec3(&mut self, v: [f64; 3]) -> NodeId {
        self.add(Op::ConstVec3(v), smallvec![])
    }

    fn unary(&mut self, op: UnaryOp, a: NodeId) -> NodeId {
        self.add(Op::Unary(op), smallvec![a])
    }

    /// A component-wise binary operation; a scalar operand is splatted to the other's type.
    fn binary(&mut self, op: BinaryOp, a: NodeId, b: NodeId) -> NodeId {
        let ty = self.wider(&[a, b]);
        let a = self.b.broadcast(a, ty, self.origin);
        let b = self.b.broadcast(b, ty, self.origin);
        self.add(Op::Binary(op), smallvec![a, b])
    }

    fn ternary(&mut self, op: TernaryOp, a: NodeId, b: NodeId, c: NodeId) -> NodeId {
        let ty = self.wider(&[a, b, c]);
        let [a, b, c] = [a, b, c].map(|x| self.b.broadcast(x, ty, self.origin));
        self.add(Op::Ternary(op), smallvec![a, b, c])
    }

    fn wider(&self, ids: &[NodeId]) -> Type {
        if ids.iter().any(|&i| self.b.ty(i) == Type::Vec3) {
            Type::Vec3
        } else {
            Type::Scalar
        }
    }

    fn is_zero(&self, id: NodeId) -> bool {
        matches!(self.b.node(id).op, Op::ConstScalar(v) if v == 0.0)
            || matches!(self.b.node(id).op, Op::ConstVec3(v) if v == [0.0; 3])
    }

    /// The tangent of an argument (arguments are differentiated before their users).
    fn of(&self, id: NodeId) -> Tangent {
        self.tangents[&id]
    }

    /// The Jacobian columns of a vec3 argument, the identity made explicit.
    fn columns(&mut self, id: NodeId) -> [Option<NodeId>; 3] {
        match self.of(id) {
            Tangent::Vector(c) => c,
            Tangent::Identity => {
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|e| Some(self.vec3(e)))
            }
            Tangent::Scalar(p) => p.map(|x| x.map(|x| self.add(Op::Splat, smallvec![x]))),
        }
    }

    /// An argument's tangent as three entries of its own type (partials or columns).
    fn entries(&mut self, id: NodeId) -> [Option<NodeId>; 3] {
        match self.of(id) {
            Tangent::Scalar(p) => p,
            _ => self.columns(id),
        }
    }

    /// A tangent of `like`'s type from three entries.
    fn tangent_like(&self, like: NodeId, entries: [Option<NodeId>; 3]) -> Tangent {
        match self.b.ty(like) {
            Type::Scalar => Tangent::Scalar(entries),
            Type::Vec3 => Tangent::Vector(entries),
        }
    }

    /// `Σ_k partial_k · tangent(arg_k)` entry by entry, skipping zero tangents and zero
    /// partials (so an infinite partial times a zero tangent is not NaN).
    fn chain(&mut self, node: NodeId, terms: &[(NodeId, NodeId)]) -> Tangent {
        let mut out: [Option<NodeId>; 3] = [None; 3];
        for &(arg, partial) in terms {
            if self.is_zero(partial) {
                continue;
            }
            let entries = self.entries(arg);
            // A partial that is 0 at a point wins over an infinite tangent there (a clamp or
            // smoothstep saturated by an overflowing input is flat): p · t where p != 0, else p.
            // Constant partials are never 0 here, so they multiply plainly.
            let guard = match self.b.node(partial).op {
                Op::ConstScalar(_) | Op::ConstVec3(_) => None,
                _ => Some(self.unary(UnaryOp::Abs, partial)),
            };
            for (o, e) in out.iter_mut().zip(entries) {
                let Some(e) = e else { continue };
                let mut term = self.binary(BinaryOp::Mul, partial, e);
                if let Some(nonzero) = guard {
                    // And a tangent that is 0 at a point wins over a partial that is not
                    // defined there (atan2(y, 0) with y flat: d = 0, not 0/0 · 0).
                    term = self.ternary(TernaryOp::Select, nonzero, term, partial);
                    let moving = self.unary(UnaryOp::Abs, e);
                    term = self.ternary(TernaryOp::Select, moving, term, e);
                }
                *o = Some(match *o {
                    Some(sum) => self.binary(BinaryOp::Add, sum, term),
                    None => term,
                });
            }
        }
        self.tangent_like(node, out)
    }

    /// The tangent of one node from its arguments' tangents.
    fn tangent(&mut self, id: NodeId) -> Result<Tangent, NotDifferentiable> {
        let node = self.b.node(id).clone();
        let a = |i: usize| node.args[i];
        Ok(match &node.op {
            Op::ConstScalar(_) => ZERO_SCALAR,
            Op::ConstVec3(_) => ZERO_VECTOR,
            Op::Position => Tangent::Identity,
            Op::Splat => Tangent::Vector(self.columns(a(0))),
            Op::Combine => {
                let parts = [0, 1, 2].map(|k| self.entries(a(k)));
                let mut cols = [None; 3];
                for (j, col) in cols.iter_mut().enumerate() {
                    if parts.iter().all(|p| p[j].is_none()) {
                        continue;
                    }
                    let xyz = [0, 1, 2].map(|k| parts[k][j].unwrap_or_else(|| self.scalar(0.0)));
                    *col = Some(self.add(Op::Combine, smallvec![xyz[0], xyz[1], xyz[2]]));
                }
                Tangent::Vector(cols)
            }
            Op::Component(c) => {
                let axis = *c % 3;
                match self.of(a(0)) {
                    Tangent::Identity => {
                        Tangent::Scalar([0, 1, 2].map(|j| (j == axis).then(|| self.scalar(1.0))))
                    }
                    _ => {
                        let cols = self.columns(a(0));
                        Tangent::Scalar(
                            cols.map(|c| c.map(|c| self.add(Op::Component(axis), smallvec![c]))),
                        )
                    }
                }
            }
            Op::Unary(op) => {
                let partial = self.unary_partial(*op, a(0), id);
                self.chain(id, &[(a(0), partial)])
            }
            Op::Binary(op) => {
                let (pa, pb) = self.binary_partials(*op, a(0), a(1), id);
                self.chain(id, &[(a(0), pa), (a(1), pb)])
            }
            Op::Ternary(TernaryOp::Select) => {
                let (x, y) = (self.entries(a(1)), self.entries(a(2)));
                let mut out = [None; 3];
                for (o, (x, y)) in out.iter_mut().zip(x.into_iter().zip(y)) {
                    if x.is_none() && y.is_none() {
                        continue;
                    }
                    let zero = self.scalar(0.0);
                    let (x, y) = (x.unwrap_or(zero), y.unwrap_or(zero));
                    *o = Some(self.ternary(TernaryOp::Select, a(0), x, y));
                }
                self.tangent_like(id, out)
            }
            Op::Ternary(op) => {
                let p = self.ternary_partials(*op, [a(0), a(1), a(2)]);
                self.chain(id, &[(a(0), p[0]), (a(1), p[1]), (a(2), p[2])])
            }
            Op::Dot => {
                let (ca, cb) = (self.columns(a(0)), self.columns(a(1)));
                let mut out = [None; 3];
                for (o, (da, db)) in out.iter_mut().zip(ca.into_iter().zip(cb)) {
                    let left = da.map(|da| self.dot(da, a(1)));
                    let right = db.map(|db| self.dot(a(0), db));
                    *o = self.sum(left, right);
                }
                Tangent::Scalar(out)
            }
            Op::Length => {
                // d|v| = (v · dv) / |v|: the node itself is |v|.
                let cols = self.columns(a(0));
                Tangent::Scalar(cols.map(|c| {
                    c.map(|c| {
                        let along = self.dot(a(0), c);
                        self.binary(BinaryOp::Div, along, id)
                    })
                }))
            }
            Op::Cross => {
                let (ca, cb) = (self.columns(a(0)), self.columns(a(1)));
                let mut out = [None; 3];
                for (o, (da, db)) in out.iter_mut().zip(ca.into_iter().zip(cb)) {
                    let left = da.map(|da| self.add(Op::Cross, smallvec![da, a(1)]));
                    let right = db.map(|db| self.add(Op::Cross, smallvec![a(0), db]));
                    *o = self.sum(left, right);
                }
                Tangent::Vector(out)
            }
            Op::Normalize => self.normalize(id, a(0)),
            Op::Rotate { axis } => self.rotate(id, *axis, a(0), a(1)),
            Op::Noise(key) => {
                let g = self.add(Op::NoiseGradient(*key), smallvec![a(0)]);
                self.through_gradient(g, a(0))
            }
            Op::Fractal(key, params) => {
                let g = self.add(Op::FractalGradient(*key, *params), smallvec![a(0)]);
                self.through_gradient(g, a(0))
            }
            Op::Hermite(h) => {
                let slope = self.hermite_slope(h, a(0));
                self.chain(id, &[(a(0), slope)])
            }
            Op::Ramp(r) => {
                let slope = self.add(Op::Ramp(std::sync::Arc::new(r.slope())), smallvec![a(0)]);
                let dt = self.entries(a(0));
                Tangent::Vector(dt.map(|d| d.map(|d| self.binary(BinaryOp::Mul, slope, d))))
            }
            Op::Curve(c) => {
                let slope = self.add(Op::Curve(std::sync::Arc::new(c.slope())), smallvec![a(0)]);
                self.chain(id, &[(a(0), slope)])
            }
            Op::NoiseGradient(_) | Op::FractalGradient(..) => return Err(NotDifferentiable),
        })
    }

    fn sum(&mut self, a: Option<NodeId>, b: Option<NodeId>) -> Option<NodeId> {
        match (a, b) {
            (Some(a), Some(b)) => Some(self.binary(BinaryOp::Add, a, b)),
            (a, None) => a,
            (None, b) => b,
        }
    }

    /// `a · b` of two vec3 nodes; a constant with one non-zero component reads that component
    /// (a Jacobian column of a scaled or permuted point).
    fn dot(&mut self, a: NodeId, b: NodeId) -> NodeId {
        for (v, c) in [(a, b), (b, a)] {
            if let Op::ConstVec3(k) = self.b.node(c).op {
                let nonzero: Vec<usize> = (0..3).filter(|&i| k[i] != 0.0).collect();
                if let [axis] = nonzero[..] {
                    let component = self.add(Op::Component(axis as u8), smallvec![v]);
                    let factor = self.scalar(k[axis]);
                    return self.binary(BinaryOp::Mul, component, factor);
                }
            }
        }
        self.add(Op::Dot, smallvec![a, b])
    }

    /// A noise node's tangent from its gradient `g` (a vec3 node) and its point's Jacobian:
    /// `∂n/∂x_j = g · ∂p/∂x_j`.
    fn through_gradient(&mut self, g: NodeId, point: NodeId) -> Tangent {
        if let Tangent::Identity = self.of(point) {
            return Tangent::Scalar(
                [0u8, 1, 2].map(|j| Some(self.add(Op::Component(j), smallvec![g]))),
            );
        }
        let cols = self.columns(point);
        // A diagonal constant Jacobian (a point scaled per axis, the usual case): the gradient
        // scaled as one vec3 multiply, which `assemble` then passes through whole.
        let diagonal = cols.iter().enumerate().try_fold([0.0; 3], |mut d, (j, c)| {
            let v = match c {
                Some(c) => match self.b.node(*c).op {
                    Op::ConstVec3(v) => v,
                    _ => return None,
                },
                None => [0.0; 3],
            };
            let off_axis = (0..3).any(|i| i != j && v[i] != 0.0);
            d[j] = v[j];
            (!off_axis).then_some(d)
        });
        if let Some(d) = diagonal {
            let d = self.vec3(d);
            let scaled = self.binary(BinaryOp::Mul, g, d);
            return Tangent::Scalar(
                [0u8, 1, 2].map(|j| Some(self.add(Op::Component(j), smallvec![scaled]))),
            );
        }
        Tangent::Scalar(cols.map(|c| c.map(|c| self.dot(g, c))))
    }

    /// The final vec3 from three partials; `Component(g, 0..3)` of one `g` is `g` itself.
    fn assemble(&mut self, partials: [Option<NodeId>; 3]) -> NodeId {
        let source = |p: Option<NodeId>, j: u8| match p.map(|p| &self.b.node(p).op) {
            Some(Op::Component(c)) if *c == j => Some(self.b.node(p.unwrap_or(0)).args[0]),
            _ => None,
        };
        if let (Some(x), Some(y), Some(z)) = (
            source(partials[0], 0),
            source(partials[1], 1),
            source(partials[2], 2),
        ) {
            if x == y && y == z {
                return x;
            }
        }
        let xyz = partials.map(|p| p.unwrap_or_else(|| self.scalar(0.0)));
        self.add(Op::Combine, smallvec![xyz[0], xyz[1], xyz[2]])
    }

    /// `d/dx op(x)` as a node of x's type (`value` is the node `op(x)` itself).
    fn unary_partial(&mut self, op: UnaryOp, x: NodeId, value: NodeId) -> NodeId {
        match op {
            UnaryOp::Abs => self.unary(UnaryOp::Sign, x),
            UnaryOp::Neg => self.scalar(-1.0),
            UnaryOp::Sin => self.unary(UnaryOp::Cos, x),
            UnaryOp::Cos => {
                let s = self.unary(UnaryOp::Sin, x);
                self.unary(UnaryOp::Neg, s)
            }
            UnaryOp::Sqrt => {
                let half = self.scalar(0.5);
                self.binary(BinaryOp::Div, half, value)
            }
            UnaryOp::Floor | UnaryOp::Sign | UnaryOp::Round | UnaryOp::Trunc => self.scalar(0.0),
            UnaryOp::Fract => self.scalar(1.0),
            UnaryOp::Exp => value,
            UnaryOp::Log | UnaryOp::Log2 => {
                let k = if op == UnaryOp::Log {
                    1.0
                } else {
                    std::f64::consts::LOG2_E
                };
                let k = self.scalar(k);
                self.binary(BinaryOp::Div, k, x)
            }
            UnaryOp::Tan => {
                let one = self.scalar(1.0);
                let sq = self.binary(BinaryOp::Mul, value, value);
                self.binary(BinaryOp::Add, one, sq)
            }
            UnaryOp::Asin | UnaryOp::Acos => {
                let one = self.scalar(1.0);
                let sq = self.binary(BinaryOp::Mul, x, x);
                let rest = self.binary(BinaryOp::Sub, one, sq);
                let root = self.unary(UnaryOp::Sqrt, rest);
                let k = self.scalar(if op == UnaryOp::Asin { 1.0 } else { -1.0 });
                self.binary(BinaryOp::Div, k, root)
            }
        }
    }

    /// `(∂/∂a, ∂/∂b)` of `op(a, b)` (`value` is the node itself).
    fn binary_partials(
        &mut self,
        op: BinaryOp,
        a: NodeId,
        b: NodeId,
        value: NodeId,
    ) -> (NodeId, NodeId) {
        let one = self.scalar(1.0);
        match op {
            BinaryOp::Add => (one, one),
            BinaryOp::Sub => (one, self.scalar(-1.0)),
            BinaryOp::Mul => (b, a),
            BinaryOp::Div => {
                // d(a/b)/db = -a/b² = -(a/b)/b.
                let inverse = self.binary(BinaryOp::Div, one, b);
                let q = self.binary(BinaryOp::Div, value, b);
                (inverse, self.unary(UnaryOp::Neg, q))
            }
            BinaryOp::Min | BinaryOp::Max => {
                // The operand the value takes: a at ties (Min: a <= b; Max: a >= b).
                let takes_a = if op == BinaryOp::Min {
                    self.binary(BinaryOp::Step, a, b)
                } else {
                    self.binary(BinaryOp::Step, b, a)
                };
                (takes_a, self.binary(BinaryOp::Sub, one, takes_a))
            }
            BinaryOp::Pow => {
                let b1 = self.binary(BinaryOp::Sub, b, one);
                let p = self.binary(BinaryOp::Pow, a, b1);
                let da = self.binary(BinaryOp::Mul, b, p);
                let ln = self.unary(UnaryOp::Log, a);
                (da, self.binary(BinaryOp::Mul, value, ln))
            }
            BinaryOp::Atan2 => {
                // atan2(y = a, x = b): (x, -y) / (x² + y²).
                let aa = self.binary(BinaryOp::Mul, a, a);
                let bb = self.binary(BinaryOp::Mul, b, b);
                let r2 = self.binary(BinaryOp::Add, aa, bb);
                let da = self.binary(BinaryOp::Div, b, r2);
                let ya = self.binary(BinaryOp::Div, a, r2);
                (da, self.unary(UnaryOp::Neg, ya))
            }
            BinaryOp::Mod => {
                let q = self.binary(BinaryOp::Div, a, b);
                let f = self.unary(UnaryOp::Floor, q);
                (one, self.unary(UnaryOp::Neg, f))
            }
            BinaryOp::Step => {
                let zero = self.scalar(0.0);
                (zero, zero)
            }
        }
    }

    /// The three partials of Clamp, Mix and Smoothstep (Select is differentiated by branch).
    fn ternary_partials(&mut self, op: TernaryOp, [a, b, c]: [NodeId; 3]) -> [NodeId; 3] {
        let one = self.scalar(1.0);
        match op {
            TernaryOp::Clamp => {
                // min(max(x, lo), hi), each step taking the operand the value takes: x where
                // x >= lo, else lo; then that where it is <= hi, else hi (so with lo > hi the
                // value, hi, moves with hi alone).
                let (x, lo, hi) = (a, b, c);
                let raised = self.binary(BinaryOp::Max, x, lo);
                let takes_x = self.binary(BinaryOp::Step, lo, x);
                let kept = self.binary(BinaryOp::Step, raised, hi);
                let px = self.binary(BinaryOp::Mul, takes_x, kept);
                let takes_lo = self.binary(BinaryOp::Sub, one, takes_x);
                let plo = self.binary(BinaryOp::Mul, takes_lo, kept);
                [px, plo, self.binary(BinaryOp::Sub, one, kept)]
            }
            TernaryOp::Mix => {
                let pa = self.binary(BinaryOp::Sub, one, c);
                [pa, c, self.binary(BinaryOp::Sub, b, a)]
            }
            TernaryOp::Smoothstep => self.smoothstep_partials(a, b, c),
            TernaryOp::Select => unreachable!("Select is differentiated by branch"),
        }
    }

    /// Smoothstep: with w = e1 − e0, t = clamp((x − e0) / w, 0, 1) and k = 6 t (1 − t) / w
    /// (0 outside the ramp, where t is clamped), ∂/∂x = k, ∂/∂e0 = k (t − 1), ∂/∂e1 = −k t;
    /// the hard step of equal edges is flat (k = 0).
    fn smoothstep_partials(&mut self, e0: NodeId, e1: NodeId, x: NodeId) -> [NodeId; 3] {
        let one = self.scalar(1.0);
        let w = self.binary(BinaryOp::Sub, e1, e0);
        let dx = self.binary(BinaryOp::Sub, x, e0);
        let ratio = self.binary(BinaryOp::Div, dx, w);
        let zero = self.scalar(0.0);
        let t = self.ternary(TernaryOp::Clamp, ratio, zero, one);
        let six = self.scalar(6.0);
        let six_t = self.binary(BinaryOp::Mul, six, t);
        let rest = self.binary(BinaryOp::Sub, one, t);
        let bump = self.binary(BinaryOp::Mul, six_t, rest);
        let k = self.binary(BinaryOp::Div, bump, w);
        let width = self.unary(UnaryOp::Abs, w);
        let k = self.ternary(TernaryOp::Select, width, k, zero);
        let t1 = self.binary(BinaryOp::Sub, t, one);
        let pe0 = self.binary(BinaryOp::Mul, k, t1);
        let kt = self.binary(BinaryOp::Mul, k, t);
        [pe0, self.unary(UnaryOp::Neg, kt), k]
    }

    /// Hermite: `H'(t)` on [0, 1] (a quadratic, in Horner form), 0 outside where t is clamped;
    /// at 0 and 1 the inside value.
    fn hermite_slope(&mut self, h: &crate::ops::Hermite, x: NodeId) -> NodeId {
        let (p0, p1, m0, m1) = (h.p0, h.p1, h.m0, h.m1);
        let quadratic = 6.0 * p0 + 3.0 * m0 - 6.0 * p1 + 3.0 * m1;
        let linear = -6.0 * p0 - 4.0 * m0 + 6.0 * p1 - 2.0 * m1;
        let (zero, one) = (self.scalar(0.0), self.scalar(1.0));
        let t = self.ternary(TernaryOp::Clamp, x, zero, one);
        let q = self.scalar(quadratic);
        let l = self.scalar(linear);
        let c = self.scalar(m0);
        let qt = self.binary(BinaryOp::Mul, q, t);
        let inner = self.binary(BinaryOp::Add, qt, l);
        let inner = self.binary(BinaryOp::Mul, inner, t);
        let slope = self.binary(BinaryOp::Add, inner, c);
        let above = self.binary(BinaryOp::Step, zero, x);
        let below = self.binary(BinaryOp::Step, x, one);
        let inside = self.binary(BinaryOp::Mul, above, below);
        self.binary(BinaryOp::Mul, slope, inside)
    }

    /// Normalize: `dn = (dv − n (n · dv)) / |v|` per column (`id` is n).
    fn normalize(&mut self, id: NodeId, v: NodeId) -> Tangent {
        let cols = self.columns(v);
        let length = self.add(Op::Length, smallvec![v]);
        Tangent::Vector(cols.map(|c| {
            c.map(|c| {
                let along = self.dot(id, c);
                let radial = self.binary(BinaryOp::Mul, id, along);
                let tangential = self.binary(BinaryOp::Sub, c, radial);
                self.binary(BinaryOp::Div, tangential, length)
            })
        }))
    }

    /// Rotate (unit `axis`, angle θ in degrees): `d(R p) = R dp + (axis × R p) · (π/180) dθ`
    /// (`id` is R p).
    fn rotate(&mut self, id: NodeId, axis: [f64; 3], p: NodeId, degrees: NodeId) -> Tangent {
        let dp = match self.of(p) {
            Tangent::Vector(c) if c.iter().all(Option::is_none) => [None; 3],
            _ => self.columns(p),
        };
        let rotated = dp.map(|c| c.map(|c| self.add(Op::Rotate { axis }, smallvec![c, degrees])));
        let dtheta = self.entries(degrees);
        let mut out = rotated;
        if dtheta.iter().any(Option::is_some) {
            let k = self.vec3(axis);
            let turn = self.add(Op::Cross, smallvec![k, id]);
            let radians = self.scalar(std::f64::consts::PI / 180.0);
            let turn = self.binary(BinaryOp::Mul, turn, radians);
            for (o, d) in out.iter_mut().zip(dtheta) {
                let term = d.map(|d| self.binary(BinaryOp::Mul, turn, d));
                *o = self.sum(*o, term);
            }
        }
        Tangent::Vector(out)
    }
}
