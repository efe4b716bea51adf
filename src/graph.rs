//! Stage 2's output: the checked graph, a typed DAG of operations.
//!
//! Nodes are created through `GraphBuilder` (crate-private), which deduplicates identical subgraphs
//! (hash-consing: an operation with the same inputs is the same node) and folds constants as it
//! goes (an operation whose inputs are all constant becomes one constant). Scalar operands of
//! vec3 operations are broadcast with explicit `Splat` nodes, so every later stage sees operands
//! of exactly the types it expects.

use crate::diagnostic::{SourceFile, Span};
use crate::noise::{self, Basis, NoiseTable, Octaves, Period, Style};
use crate::ops::{self, BinaryOp, Curve, Hermite, Ramp, TernaryOp, UnaryOp};
use rustc_hash::FxHashMap;
use smallvec::SmallVec;
use std::fmt;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Type {
    Scalar,
    Vec3,
}

impl Type {
    pub fn channels(self) -> usize {
        match self {
            Type::Scalar => 1,
            Type::Vec3 => 3,
        }
    }
}

impl fmt::Display for Type {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Type::Scalar => "scalar",
            Type::Vec3 => "vec3",
        })
    }
}

/// Index of a node in [`CheckedGraph::nodes`]. Arguments always have smaller ids than their
/// users (the node list is in topological order).
pub type NodeId = u32;

/// Which lattice tables a noise instruction reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TableKey {
    pub basis: Basis,
    pub seed: u64,
    /// A `Noise`'s tiling period (fractal sums keep theirs in [`FractalParams`]).
    pub period: Option<Period>,
}

/// The parameters of an Fbm or Turbulence, as written (before level of detail).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FractalParams {
    pub octaves: f64,
    pub lacunarity: f64,
    pub gain: f64,
    pub first_octave: u32,
    /// How each octave enters the sum (Fbm, Turbulence, Billow, Ridged).
    pub style: Style,
    /// Tiling period of the first octave written (octave i: times lacunarity^i).
    pub period: Option<Period>,
}

impl FractalParams {
    pub fn schedule(&self) -> Octaves {
        Octaves::new(self.octaves, self.lacunarity, self.gain, self.first_octave)
            .with_period(self.period)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    Position,
    ConstScalar(f64),
    ConstVec3([f64; 3]),
    /// scalar → vec3 (x, x, x).
    Splat,
    /// three scalars → vec3.
    Combine,
    /// vec3 → one component.
    Component(u8),
    Unary(UnaryOp),
    Binary(BinaryOp),
    Ternary(TernaryOp),
    Dot,
    Length,
    /// vec3 × vec3 → vec3.
    Cross,
    /// vec3 → unit vec3 (zero stays zero).
    Normalize,
    /// args: point, degrees. The axis is unit length.
    Rotate {
        axis: [f64; 3],
    },
    Noise(TableKey),
    Fractal(TableKey, FractalParams),
    /// The analytic gradient (a vec3) of `Noise(key)` at the point argument (`Gradient`).
    NoiseGradient(TableKey),
    /// The analytic gradient of `Fractal(key, params)` at the point argument.
    FractalGradient(TableKey, FractalParams),
    Hermite(Hermite),
    Ramp(Arc<Ramp>),
    Curve(Arc<Curve>),
}

impl Op {
    /// Encodes the operation (not its arguments) for hash-consing; floats by their bits so that
    /// NaN payloads and -0.0 are kept apart.
    fn key(&self, out: &mut OpKey) {
        fn basis_code(basis: Basis) -> [u64; 2] {
            let jitter = match basis {
                Basis::Cellular(c) => c.jitter().to_bits(),
                _ => 0,
            };
            let tag = match basis {
                Basis::Perlin => 0,
                Basis::Gradient => 1,
                Basis::Value(noise::Interpolation::Linear) => 2,
                Basis::Value(noise::Interpolation::Smooth) => 3,
                Basis::Simplex => 4,
                Basis::White => 5,
                Basis::Cellular(c) => {
                    let metric = c.metric as u64;
                    let value = c.value as u64;
                    // The jitter's bits do not fit beside the tags: its own word follows.
                    6 | metric << 8 | value << 16
                }
            };
            [tag, jitter]
        }
        fn style_code(style: Style) -> [u64; 3] {
            match style {
                Style::Fbm => [0, 0, 0],
                Style::Turbulence => [1, 0, 0],
                Style::Billow => [2, 0, 0],
                Style::Ridged { offset, sharpness } => [3, offset.to_bits(), sharpness.to_bits()],
            }
        }
        match self {
            Op::Position => out.push(0),
            Op::ConstScalar(v) => out.extend([1, v.to_bits()]),
            Op::ConstVec3(v) => out.extend([2, v[0].to_bits(), v[1].to_bits(), v[2].to_bits()]),
            Op::Splat => out.push(3),
            Op::Combine => out.push(4),
            Op::Component(c) => out.extend([5, *c as u64]),
            Op::Unary(op) => out.extend([6, *op as u64]),
            Op::Binary(op) => out.extend([7, *op as u64]),
            Op::Ternary(op) => out.extend([8, *op as u64]),
            Op::Dot => out.push(9),
            Op::Length => out.push(10),
            Op::Rotate { axis } => {
                out.extend([11, axis[0].to_bits(), axis[1].to_bits(), axis[2].to_bits()])
            }
            Op::NoiseGradient(t) => {
                out.push(19);
                out.extend(basis_code(t.basis));
                out.push(t.seed);
                out.extend(t.period.unwrap_or([0; 3]));
            }
            Op::Noise(t) => {
                out.push(12);
                out.extend(basis_code(t.basis));
                out.push(t.seed);
                out.extend(t.period.unwrap_or([0; 3]));
            }
            Op::Fractal(t, p) | Op::FractalGradient(t, p) => {
                out.push(if matches!(self, Op::Fractal(..)) {
                    13
                } else {
                    20
                });
                out.extend(basis_code(t.basis));
                out.extend([
                    t.seed,
                    p.octaves.to_bits(),
                    p.lacunarity.to_bits(),
                    p.gain.to_bits(),
                    p.first_octave as u64,
                ]);
                out.extend(style_code(p.style));
                out.extend(p.period.unwrap_or([0; 3]));
            }
            Op::Hermite(h) => out.extend([
                14,
                h.p0.to_bits(),
                h.p1.to_bits(),
                h.m0.to_bits(),
                h.m1.to_bits(),
            ]),
            Op::Ramp(r) => {
                out.extend([15, r.interpolation() as u64, r.is_slope() as u64]);
                for (k, v) in r.knots().iter().zip(r.values()) {
                    out.extend([k.to_bits(), v[0].to_bits(), v[1].to_bits(), v[2].to_bits()]);
                }
            }
            Op::Curve(c) => {
                out.extend([16, c.interpolation() as u64, c.is_slope() as u64]);
                for (k, v) in c.knots().iter().zip(c.values()) {
                    out.extend([k.to_bits(), v[0].to_bits()]);
                }
            }
            Op::Cross => out.push(17),
            Op::Normalize => out.push(18),
        }
    }
}

/// An operation's identity for hash-consing, inline for all but long ramps.
type OpKey = SmallVec<[u64; 8]>;

/// A node's arguments: at most three for every kind, so they live inline in the node.
pub type Args = SmallVec<[NodeId; 4]>;

/// Where a node came from: the id of the graph node it was written in, and its span.
#[derive(Clone, Debug, PartialEq)]
pub struct Origin {
    /// Shared: every node created while lowering one graph node carries the same id.
    pub node: Arc<str>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    pub op: Op,
    pub args: Args,
    pub ty: Type,
    pub origin: Origin,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    pub name: String,
    pub node: NodeId,
    pub span: Span,
}

/// Counts reported by `texgraph check`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GraphStats {
    /// Entries in the file's `nodes` map.
    pub declared: usize,
    /// Node expressions written in the file, inline ones included.
    pub written: usize,
    /// Creations answered by an existing identical node.
    pub deduplicated: usize,
    /// Operations replaced by a constant.
    pub folded: usize,
}

/// A graph that passed checking: typed, acyclic, deduplicated and constant-folded. Compiling it
/// cannot fail except for a request naming an output it does not have.
#[derive(Clone, Debug)]
pub struct CheckedGraph {
    pub(crate) file: Arc<SourceFile>,
    pub(crate) nodes: Vec<Node>,
    pub(crate) outputs: Vec<Output>,
    /// The file's node ids and what each became (a folded node points at its constant).
    pub(crate) named: Vec<(crate::syntax::Text, NodeId)>,
    /// Params after `--set` overrides, in file order.
    pub(crate) params: Vec<(String, f64)>,
    /// The file's `ranges`: a slider range (min, max) per param, for `texgraph serve`.
    pub(crate) ranges: Vec<(String, f64, f64)>,
    pub(crate) stats: GraphStats,
    /// Every file imported, directly or through other imports, as the paths were resolved.
    pub(crate) imports: Vec<std::path::PathBuf>,
}

/// A checked graph is built only by [`crate::check::check()`]; its fields are private to the crate and
/// read through these accessors.
impl CheckedGraph {
    /// The file it was read from (name and text, for diagnostics).
    pub fn file(&self) -> &Arc<SourceFile> {
        &self.file
    }

    /// The outputs, in file order.
    pub fn outputs(&self) -> &[Output] {
        &self.outputs
    }

    /// The params after `--set` overrides, in file order.
    pub fn params(&self) -> &[(String, f64)] {
        &self.params
    }

    /// The slider ranges the file gives its params (`ranges`), as (name, min, max).
    pub fn param_ranges(&self) -> &[(String, f64, f64)] {
        &self.ranges
    }

    /// The file's node ids in file order, each with the node it became (a folded node: its
    /// constant).
    pub fn named_nodes(&self) -> impl Iterator<Item = (&str, NodeId)> {
        self.named.iter().map(|(name, id)| (name.as_str(), *id))
    }

    /// The files this graph imports, directly or through other imports (to watch them, to
    /// report them), in the order first met.
    pub fn imports(&self) -> &[std::path::PathBuf] {
        &self.imports
    }

    /// Nodes declared, written, deduplicated and folded.
    pub fn stats(&self) -> &GraphStats {
        &self.stats
    }

    /// The nodes of the typed DAG (arguments before their users).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The output named `name`.
    pub fn output(&self, name: &str) -> Option<&Output> {
        self.outputs.iter().find(|o| o.name == name)
    }

    /// The same graph with every named node (not folded to a constant) as an output, in file
    /// order: for probing each node, as the stability report does.
    pub fn with_node_outputs(&self) -> CheckedGraph {
        let mut graph = self.clone();
        graph.outputs = self
            .named
            .iter()
            .filter(|(_, id)| {
                !matches!(
                    self.nodes[*id as usize].op,
                    Op::ConstScalar(_) | Op::ConstVec3(_)
                )
            })
            .map(|(name, id)| Output {
                name: name.to_string(),
                node: *id,
                span: self.nodes[*id as usize].origin.span,
            })
            .collect();
        graph
    }

    /// The same graph with every named node (not folded to a constant) as an output too, after
    /// the file's outputs: a node can be evaluated, previewed and timed by its id (`texgraph
    /// serve`). Nodes and outputs share one namespace, so no name is taken twice.
    pub fn with_node_probes(&self) -> CheckedGraph {
        let mut graph = self.with_node_outputs();
        let probes = std::mem::take(&mut graph.outputs);
        graph.outputs = self.outputs.clone();
        for probe in probes {
            if graph.output(&probe.name).is_none() {
                graph.outputs.push(probe);
            }
        }
        graph
    }
}

/// Creates nodes with deduplication and constant folding (the checker's; not public API).
pub(crate) struct GraphBuilder {
    pub nodes: Vec<Node>,
    /// Interning: an operation and its arguments → the node. Inline keys and a fast hash:
    /// checking creates a node per expression, so this map is the checker's hot path.
    interned: FxHashMap<(OpKey, Args), NodeId>,
    tables: FxHashMap<TableKey, Arc<NoiseTable>>,
    pub stats: GraphStats,
}

impl Default for GraphBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl GraphBuilder {
    /// A builder with room for about `nodes` nodes, so that building a large graph does not
    /// regrow (and copy) its tables again and again.
    pub fn with_capacity(nodes: usize) -> GraphBuilder {
        let mut builder = GraphBuilder::new();
        builder.nodes.reserve(nodes);
        builder.interned.reserve(nodes);
        builder
    }

    /// A builder holding a checked graph's nodes (same ids), to add more to it.
    pub fn from_nodes(nodes: &[Node]) -> GraphBuilder {
        let mut builder = GraphBuilder::with_capacity(nodes.len() * 2);
        for (id, node) in nodes.iter().enumerate() {
            let mut key = OpKey::new();
            node.op.key(&mut key);
            builder
                .interned
                .insert((key, node.args.clone()), id as NodeId);
            builder.nodes.push(node.clone());
        }
        builder
    }

    pub fn new() -> GraphBuilder {
        GraphBuilder {
            nodes: Vec::new(),
            interned: FxHashMap::default(),
            tables: FxHashMap::default(),
            stats: GraphStats::default(),
        }
    }

    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id as usize]
    }

    pub fn ty(&self, id: NodeId) -> Type {
        self.node(id).ty
    }

    pub fn const_scalar(&self, id: NodeId) -> Option<f64> {
        match self.node(id).op {
            Op::ConstScalar(v) => Some(v),
            _ => None,
        }
    }

    pub fn const_vec3(&self, id: NodeId) -> Option<[f64; 3]> {
        match self.node(id).op {
            Op::ConstVec3(v) => Some(v),
            Op::ConstScalar(v) => Some([v; 3]),
            _ => None,
        }
    }

    /// Adds (or finds) a node. `args` must have the types `op` expects: callers insert splats
    /// with [`GraphBuilder::broadcast`]. Folds when every argument is constant.
    pub fn add(&mut self, op: Op, args: Args, origin: &Origin) -> NodeId {
        // x * 1 and x / 1 are x exactly (NaN, infinities and -0 included): drop the operation.
        if let (Op::Binary(BinaryOp::Mul | BinaryOp::Div), [a, b]) = (&op, args.as_slice()) {
            if self.is_one(*b) {
                self.stats.folded += 1;
                return *a;
            }
            if op == Op::Binary(BinaryOp::Mul) && self.is_one(*a) {
                self.stats.folded += 1;
                return *b;
            }
        }
        // Select with a constant condition is the branch it picks; with equal branches, that
        // branch (whatever the condition, NaN included).
        if let (Op::Ternary(TernaryOp::Select), [c, a, b]) = (&op, args.as_slice()) {
            let pick = match self.const_vec3(*c) {
                _ if a == b => Some(*a),
                Some(v) if v.iter().all(|&x| x > 0.0) => Some(*a),
                Some(v) if v.iter().all(|&x| x <= 0.0 || x.is_nan()) => Some(*b),
                _ => None,
            };
            if let Some(id) = pick {
                self.stats.folded += 1;
                return id;
            }
        }
        if let Some(folded) = self.fold(&op, &args) {
            self.stats.folded += 1;
            return self.intern(folded, Args::new(), origin);
        }
        self.intern(op, args, origin)
    }

    fn intern(&mut self, op: Op, args: Args, origin: &Origin) -> NodeId {
        let mut key = OpKey::new();
        op.key(&mut key);
        let map_key = (key, args.clone());
        if let Some(&id) = self.interned.get(&map_key) {
            // Constants are re-created at every use of a param or literal: only operations
            // count as deduplicated subgraphs.
            if !matches!(
                self.nodes[id as usize].op,
                Op::ConstScalar(_) | Op::ConstVec3(_)
            ) {
                self.stats.deduplicated += 1;
            }
            return id;
        }
        let ty = self.result_type(&op, &args);
        let id = self.nodes.len() as NodeId;
        self.nodes.push(Node {
            op,
            args,
            ty,
            origin: origin.clone(),
        });
        self.interned.insert(map_key, id);
        id
    }

    fn result_type(&self, op: &Op, args: &[NodeId]) -> Type {
        match op {
            Op::Position
            | Op::ConstVec3(_)
            | Op::Splat
            | Op::Combine
            | Op::Rotate { .. }
            | Op::Cross
            | Op::Normalize
            | Op::NoiseGradient(_)
            | Op::FractalGradient(..)
            | Op::Ramp(_) => Type::Vec3,
            Op::ConstScalar(_)
            | Op::Component(_)
            | Op::Dot
            | Op::Length
            | Op::Noise(_)
            | Op::Fractal(..)
            | Op::Hermite(_)
            | Op::Curve(_) => Type::Scalar,
            Op::Unary(_) | Op::Binary(_) | Op::Ternary(_) => {
                args.first().map_or(Type::Scalar, |&a| self.ty(a))
            }
        }
    }

    fn is_one(&self, id: NodeId) -> bool {
        matches!(self.node(id).op, Op::ConstScalar(v) if v == 1.0)
            || matches!(self.node(id).op, Op::ConstVec3(v) if v == [1.0; 3])
    }

    /// Makes `id` a vec3 by splatting a scalar (a constant splat folds to a vec3 constant).
    pub fn broadcast(&mut self, id: NodeId, ty: Type, origin: &Origin) -> NodeId {
        if ty == Type::Vec3 && self.ty(id) == Type::Scalar {
            self.add(Op::Splat, smallvec::smallvec![id], origin)
        } else {
            id
        }
    }

    pub fn table(&mut self, key: TableKey) -> Arc<NoiseTable> {
        self.tables
            .entry(key)
            .or_insert_with(|| Arc::new(NoiseTable::periodic(key.basis, key.seed, key.period)))
            .clone()
    }

    /// Evaluates `op` in f64 when every argument is a constant.
    fn fold(&mut self, op: &Op, args: &[NodeId]) -> Option<Op> {
        match op {
            Op::Position | Op::ConstScalar(_) | Op::ConstVec3(_) => return None,
            Op::Rotate { axis } => {
                // Mixed argument types: point (vec3), degrees (scalar).
                let point = match self.node(args[0]).op {
                    Op::ConstVec3(v) => v,
                    _ => return None,
                };
                let degrees = self.const_scalar(args[1])?;
                return Some(Op::ConstVec3(ops::apply_matrix(
                    &ops::rotation_matrix(*axis, degrees),
                    point,
                )));
            }
            _ => {}
        }
        let scalars: Option<Vec<f64>> = args.iter().map(|&a| self.const_scalar(a)).collect();
        let vectors: Option<Vec<[f64; 3]>> = args
            .iter()
            .map(|&a| match self.node(a).op {
                Op::ConstVec3(v) => Some(v),
                _ => None,
            })
            .collect();
        let all_scalar = scalars.is_some();
        let all_vec3 = vectors.is_some();
        if !all_scalar && !all_vec3 {
            return None;
        }
        if args.is_empty() {
            return None;
        }
        let s = scalars.unwrap_or_default();
        let v = vectors.unwrap_or_default();
        let map3 = |f: &dyn Fn(usize) -> f64| Op::ConstVec3([f(0), f(1), f(2)]);
        Some(match op {
            Op::Splat if all_scalar => Op::ConstVec3([s[0]; 3]),
            Op::Combine if all_scalar => Op::ConstVec3([s[0], s[1], s[2]]),
            Op::Component(c) if all_vec3 => Op::ConstScalar(v[0][*c as usize % 3]),
            Op::Unary(u) if all_scalar => Op::ConstScalar(u.apply(s[0])),
            Op::Unary(u) if all_vec3 => map3(&|c| u.apply(v[0][c])),
            Op::Binary(b) if all_scalar => Op::ConstScalar(b.apply(s[0], s[1])),
            Op::Binary(b) if all_vec3 => map3(&|c| b.apply(v[0][c], v[1][c])),
            Op::Ternary(t) if all_scalar => Op::ConstScalar(t.apply(s[0], s[1], s[2])),
            Op::Ternary(t) if all_vec3 => map3(&|c| t.apply(v[0][c], v[1][c], v[2][c])),
            Op::Dot if all_vec3 => Op::ConstScalar(crate::ops::dot(v[0], v[1])),
            Op::Length if all_vec3 => Op::ConstScalar(crate::ops::length(v[0])),
            Op::Cross if all_vec3 => Op::ConstVec3(crate::ops::cross(v[0], v[1])),
            Op::Normalize if all_vec3 => Op::ConstVec3(crate::ops::normalize(v[0])),
            Op::Noise(key) if all_vec3 => {
                let table = self.table(*key);
                Op::ConstScalar(table.sample::<f64>(v[0]))
            }
            Op::NoiseGradient(key) if all_vec3 => {
                let table = self.table(*key);
                Op::ConstVec3(table.sample_grad::<f64>(v[0]))
            }
            Op::FractalGradient(key, params) if all_vec3 => {
                let table = self.table(*key);
                Op::ConstVec3(noise::fractal_styled_grad::<f64>(
                    &table,
                    &params.schedule(),
                    params.style,
                    v[0],
                ))
            }
            Op::Fractal(key, params) if all_vec3 => {
                let table = self.table(*key);
                Op::ConstScalar(noise::fractal_styled::<f64>(
                    &table,
                    &params.schedule(),
                    params.style,
                    v[0],
                ))
            }
            Op::Hermite(h) if all_scalar => Op::ConstScalar(h.apply(s[0])),
            Op::Ramp(r) if all_scalar => Op::ConstVec3(r.eval(s[0])),
            Op::Curve(c) if all_scalar => Op::ConstScalar(c.eval(s[0])[0]),
            _ => return None,
        })
    }
}
