//! Precision chosen per instruction: a range analysis over the region a tape will be evaluated
//! on (the extent), a bound on the error f32 arithmetic puts on each output, and the
//! instructions that must run in f64 on the fast path to keep every output within
//! `max_error` of the f64 reference.
//!
//! The model (first order, every bound an upper bound):
//! - each node's value lies in an interval computed forward from the extent (`rules::range`);
//! - each node's partial derivatives are bounded over those intervals (`rules::partials`), and a
//!   backward pass gives each node's *sensitivity*: how much an error in its value can move the
//!   outputs (the sum over paths of the products of partial bounds);
//! - an f32 scalar node adds `k · |value| · 2^-24` of its own (k from `rules::f32_roundings`:
//!   0 for exact operations, 1 for one rounding, more for transcendentals and noise interiors),
//!   which reaches the outputs times its sensitivity. A node run in f64 computes what the
//!   reference computes (the same operations on the same inputs), so it adds nothing — except
//!   where its value is handed to an f32 consumer (or a constant is rounded to f32), which
//!   rounds `|value|` once there.
//!
//! Choosing: with nothing promoted the bound is evaluated first, and when it is within
//! `max_error` nothing changes (the tape is the plain one, bit for bit). Otherwise a forward pass
//! promotes each node whose own f32 rounding, or whose rounding of an f64 argument, would add
//! more than a threshold τ (starting at `max_error`, divided by 8 until the bound holds or every
//! node that can be promoted is). Positions, lattice cells and noise interiors stay as they are.
//!
//! For the report, each output also gets the bound of the plain f32 tape and the bound of the
//! f64 reference's own error against exact arithmetic: where even that exceeds `max_error`
//! (`Sin(Mul(1e12, "v.x"))` at |p| = 1e6), f64 is meaningless there and the report names the node.

pub mod interval;
mod rules;

use crate::graph::{CheckedGraph, NodeId, Op, Type};
pub use interval::Interval;
use rules::{Partials, Range};
use std::fmt;

/// The default target: every output within this of the f64 reference (absolute).
pub const DEFAULT_MAX_ERROR: f64 = 1e-4;

/// One f32 rounding, relative: half an ulp.
const F32_UNIT: f64 = 1.0 / 16_777_216.0;
/// One f64 rounding, relative.
const F64_UNIT: f64 = 1.0 / 9_007_199_254_740_992.0;

/// The region a tape will be evaluated over, in the graph's coordinates (what `Position` gives):
/// a box, possibly unbounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Extent {
    pub fn new(min: [f64; 3], max: [f64; 3]) -> Extent {
        Extent { min, max }
    }

    /// Every point: precision for any coordinate.
    pub fn unbounded() -> Extent {
        Extent::new([f64::NEG_INFINITY; 3], [f64::INFINITY; 3])
    }

    /// `X0,Y0,Z0:X1,Y1,Z1` (the `--extent` syntax); `inf`/`-inf` allowed.
    pub fn parse(text: &str) -> Result<Extent, String> {
        let corner = |part: &str| -> Result<[f64; 3], String> {
            let values: Vec<&str> = part.split(',').map(str::trim).collect();
            if values.len() != 3 {
                return Err(format!("\"{part}\" is not three numbers X,Y,Z"));
            }
            let mut out = [0.0; 3];
            for (o, v) in out.iter_mut().zip(&values) {
                *o = v
                    .parse::<f64>()
                    .ok()
                    .filter(|x| !x.is_nan())
                    .ok_or_else(|| format!("\"{v}\" is not a number"))?;
            }
            Ok(out)
        };
        let (lo, hi) = text
            .split_once(':')
            .ok_or_else(|| format!("\"{text}\" is not X0,Y0,Z0:X1,Y1,Z1"))?;
        let (min, max) = (corner(lo)?, corner(hi)?);
        if (0..3).any(|c| min[c] > max[c]) {
            return Err(format!(
                "\"{text}\": each minimum must be at most its maximum"
            ));
        }
        Ok(Extent::new(min, max))
    }

    /// The smallest box holding every finite point of three coordinate planes; `None` when
    /// there is none. A non-finite coordinate makes that axis unbounded.
    pub fn around(x: &[f64], y: &[f64], z: &[f64]) -> Option<Extent> {
        let mut e = Extent::new([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (c, plane) in [x, y, z].into_iter().enumerate() {
            for &v in plane {
                if v.is_finite() {
                    e.min[c] = e.min[c].min(v);
                    e.max[c] = e.max[c].max(v);
                } else {
                    e.min[c] = f64::NEG_INFINITY;
                    e.max[c] = f64::INFINITY;
                }
            }
        }
        (0..3).all(|c| e.min[c] <= e.max[c]).then_some(e)
    }

    /// The largest coordinate magnitude.
    pub fn magnitude(&self) -> f64 {
        (0..3).fold(0.0f64, |m, c| {
            m.max(self.min[c].abs()).max(self.max[c].abs())
        })
    }

    fn range(&self) -> Range {
        [0, 1, 2].map(|c| Interval::new(self.min[c], self.max[c]))
    }
}

impl fmt::Display for Extent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [a, b, c] = self.min;
        let [d, e, g] = self.max;
        write!(f, "{a},{b},{c}:{d},{e},{g}")
    }
}

/// What the analysis found for one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OutputBound {
    pub output: String,
    /// Bound on |fast path − f64 reference| with every scalar in f32 (the plain tape).
    pub plain_f32: f64,
    /// The same with the chosen instructions in f64.
    pub promoted: f64,
    /// Bound on the f64 reference's own error against exact arithmetic.
    pub f64_floor: f64,
    /// Where `promoted` or `f64_floor` exceeds the target: the node that contributes most, and
    /// why it cannot do better.
    pub shortfall: Option<String>,
}

/// The precision plan of one compile: which graph nodes run in f64 and why.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub extent: Extent,
    pub max_error: f64,
    /// Where the bound asked for promotions but by less than [`CONFIRM_FACTOR`]: the largest
    /// f32 error of the plain tape measured on [`SAMPLES`] points of the extent. Below
    /// `max_error / 4` the plain tape was kept (the bound is a worst case that
    /// multiplies the steepest slope of every node on a path; measured errors run far below).
    pub sampled: Option<f64>,
    /// Per graph node id: runs in f64 on the fast path.
    pub(crate) wide: Vec<bool>,
    /// Per graph node id: its magnitude bound over the extent.
    pub(crate) magnitude: Vec<f64>,
    /// Per graph node id: what its f32 evaluation would add to the outputs (the reason for a
    /// promotion).
    pub(crate) f32_cost: Vec<f64>,
    pub outputs: Vec<OutputBound>,
}

impl Plan {
    /// Promoted nodes.
    pub fn promoted_count(&self) -> usize {
        self.wide.iter().filter(|&&w| w).count()
    }

    /// Why node `id` runs in f64, for the disassembly.
    pub(crate) fn reason(&self, id: NodeId) -> String {
        let i = id as usize;
        format!(
            "f64: |value| <= {:.3e}, f32 would add <= {:.2e}",
            self.magnitude[i], self.f32_cost[i]
        )
    }
}

/// A bound at most this many times the target is checked by measurement before anything is
/// promoted.
pub const CONFIRM_FACTOR: f64 = 10.0;

/// Points of the extent the plain tape is measured on when a promotion is to be confirmed.
pub const SAMPLES: usize = 4096;

impl Plan {
    /// Whether the promotions should be checked by measurement: the extent is bounded and
    /// every output's plain bound is within [`CONFIRM_FACTOR`] of the target.
    pub(crate) fn needs_confirming(&self) -> bool {
        self.promoted_count() > 0
            && self.extent.magnitude().is_finite()
            && self
                .outputs
                .iter()
                .all(|o| o.plain_f32 <= CONFIRM_FACTOR * self.max_error)
    }

    /// Keeps the plain tape: the measured error `sampled` was well within the target.
    pub(crate) fn keep_plain(&mut self, sampled: f64) {
        self.sampled = Some(sampled);
        if sampled <= self.max_error / 4.0 {
            self.wide.iter_mut().for_each(|w| *w = false);
            for o in &mut self.outputs {
                o.promoted = o.plain_f32;
                if o.shortfall.is_some() && o.f64_floor <= self.max_error {
                    o.shortfall = None;
                }
            }
        }
    }
}

/// What the analysis knows about each live node.
struct Facts<'g> {
    graph: &'g CheckedGraph,
    live: &'g [bool],
    magnitude: Vec<f64>,
    partials: Vec<Partials>,
    edges: Vec<Partials>,
    /// Per node: a bound ρ on its f32 error relative to its own value, pointwise, where its
    /// whole chain keeps errors relative (products, sums of like-signed terms, square roots of
    /// components of exact vec3 values); infinite elsewhere.
    relative: Vec<f64>,
    max_error: f64,
}

/// Sensitivities, and the error square roots pass on from inputs whose relative error they
/// keep relative (`Facts::relative`): near 0 a square root's slope is unbounded, but an input
/// off by ρ·x gives an output off by ρ/2·√x.
struct Sens {
    s: Vec<f64>,
    inherited: Vec<f64>,
}

impl std::ops::Deref for Sens {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.s
    }
}

/// Plans the precision of compiling `outputs` (name, node) of `graph` for `extent`.
pub(crate) fn plan(
    graph: &CheckedGraph,
    live: &[bool],
    outputs: &[(String, NodeId)],
    extent: Extent,
    max_error: f64,
) -> Plan {
    let facts = Facts::new(graph, live, extent, max_error);
    let all = facts.sensitivities(outputs.iter().map(|o| o.1));
    let narrow = vec![false; graph.nodes.len()];
    let mut wide = narrow.clone();
    if facts.bound(&narrow, &all, outputs).total > max_error {
        let mut tau = max_error;
        for _ in 0..64 {
            let next = facts.choose(&all, tau);
            let done = facts.bound(&next, &all, outputs).total <= max_error;
            let settled = next == wide;
            wide = next;
            if done || (settled && tau < max_error * 1e-30) {
                break;
            }
            tau /= 8.0;
        }
    }
    let f32_cost = (0..graph.nodes.len())
        .map(|n| {
            let node = &graph.nodes[n];
            let boundary: f64 = (0..node.args.len())
                .filter(|&i| {
                    let p = node.args[i] as usize;
                    wide[p] || facts.is_const(p)
                })
                .map(|i| facts.narrowing_cost(n, i, &all))
                .sum();
            facts.own_cost(n, &all).max(boundary)
        })
        .collect();
    let bounds = outputs
        .iter()
        .map(|(name, node)| facts.output_bound(name, *node, &wide, max_error))
        .collect();
    Plan {
        extent,
        max_error,
        sampled: None,
        magnitude: facts.magnitude.clone(),
        wide,
        f32_cost,
        outputs: bounds,
    }
}

/// Per graph node, a bound on what its own f32 roundings add to the outputs over `extent`,
/// every other node exact (`∞` for a node the outputs do not read or cannot bound): what the
/// filtered form reads to choose which noise instructions may sample in f32 for an f32 result
/// (`Tape::narrow_samples`). The filtered form's means move with a sample by at most the point
/// tape's slopes (a mean of `f(X)` moves by at most `sup |f'|` times a move of `X`), so the
/// point tape's sensitivities bound them.
pub(crate) fn f32_costs(
    graph: &CheckedGraph,
    live: &[bool],
    outputs: &[NodeId],
    extent: Extent,
    max_error: f64,
) -> Vec<f64> {
    let facts = Facts::new(graph, live, extent, max_error);
    let all = facts.sensitivities(outputs.iter().copied());
    (0..graph.nodes.len())
        .map(|n| {
            let cost = facts.own_cost(n, &all);
            if live[n] && !cost.is_nan() {
                cost
            } else {
                f64::INFINITY
            }
        })
        .collect()
}

/// A bound and its largest term.
#[derive(Default)]
struct Bound {
    total: f64,
    top: f64,
    why: Option<String>,
}

impl Bound {
    fn add(&mut self, term: f64, why: impl FnOnce() -> String) {
        if term > 0.0 {
            self.total += term;
            if term > self.top {
                self.top = term;
                self.why = Some(why());
            }
        }
    }
}

impl<'g> Facts<'g> {
    fn new(graph: &'g CheckedGraph, live: &'g [bool], extent: Extent, max_error: f64) -> Facts<'g> {
        let n = graph.nodes.len();
        let mut ranges: Vec<Range> = Vec::with_capacity(n);
        let mut partials: Vec<Partials> = Vec::with_capacity(n);
        let position = extent.range();
        for (id, node) in graph.nodes.iter().enumerate() {
            if !live[id] {
                ranges.push([Interval::TOP; 3]);
                partials.push(Partials::new());
                continue;
            }
            let args: smallvec::SmallVec<[Range; 3]> =
                node.args.iter().map(|&a| ranges[a as usize]).collect();
            let mut range = rules::range(&node.op, node.ty, &args, position);
            if let (Op::Binary(crate::ops::BinaryOp::Mul), [a, b]) = (&node.op, &node.args[..]) {
                if a == b {
                    // x · x: interval arithmetic does not know both factors are one value.
                    range = args[0].map(|i| {
                        let m = i.least_magnitude();
                        Interval::new(m * m, i.magnitude() * i.magnitude())
                    });
                }
            }
            ranges.push(range);
            partials.push(rules::partials(&node.op, &args));
        }
        let relative = relative_errors(graph, live, &ranges);
        let magnitude = ranges.iter().map(rules::range_magnitude).collect();
        let edges = graph.nodes.iter().map(|n| rules::edges(&n.op)).collect();
        Facts {
            graph,
            live,
            magnitude,
            partials,
            edges,
            relative,
            max_error,
        }
    }

    fn is_const(&self, n: usize) -> bool {
        matches!(
            self.graph.nodes[n].op,
            Op::ConstScalar(_) | Op::ConstVec3(_)
        )
    }

    /// How much an error in each node's value can move the given outputs, and the jumps of
    /// the discontinuous nodes they depend on (the edge rule), summed.
    ///
    /// A square root whose inputs keep their error relative, and whose inherited error is then
    /// far below the target, does not pass sensitivity on to its inputs: its inherited error
    /// is counted instead (`Sens::inherited`). Where that error matters (a huge extent), the
    /// inputs are sensitive as usual, so promoting them can help.
    fn sensitivities(&self, seeds: impl Iterator<Item = NodeId>) -> Sens {
        let mut s = vec![0.0; self.graph.nodes.len()];
        let mut inherited = vec![0.0; s.len()];
        let mut reached = vec![false; s.len()];
        for seed in seeds {
            s[seed as usize] += 1.0;
            reached[seed as usize] = true;
        }
        for c in (0..s.len()).rev() {
            if !self.live[c] || !reached[c] {
                continue;
            }
            if matches!(self.graph.nodes[c].op, Op::Unary(crate::ops::UnaryOp::Sqrt)) {
                let small = |t: f64| t.is_finite() && t <= self.max_error / 4.0;
                // √(Σ xᵢ²) is a norm: 1-Lipschitz in each xᵢ; the squares and sums round
                // relatively, one unit each, halved by the root.
                let mut bases = Vec::new();
                let arg = self.graph.nodes[c].args[0] as usize;
                if self.sum_of_squares(arg, &mut bases, 0) {
                    let units = bases.len() as f64 / 2.0 + 1.0;
                    let term = scaled(units * F32_UNIT * self.magnitude[c], s[c]);
                    if small(term) {
                        inherited[c] = term;
                        for x in bases {
                            reached[x] = true;
                            s[x] += s[c];
                        }
                        continue;
                    }
                }
                let passed = (self.relative[c] - F32_UNIT).max(0.0) * self.magnitude[c];
                let term = scaled(passed, s[c]);
                if small(term) {
                    inherited[c] = term;
                    continue;
                }
            }
            // atan2 of two relatively rounded values moves by at most half their relative
            // errors' sum (in radians), however close to the origin.
            if let (Op::Binary(crate::ops::BinaryOp::Atan2), [y, x]) =
                (&self.graph.nodes[c].op, &self.graph.nodes[c].args[..])
            {
                let rho = (self.relative[*y as usize] + self.relative[*x as usize]) / 2.0;
                let term = scaled(rho, s[c]);
                if term.is_finite() && term <= self.max_error / 4.0 {
                    inherited[c] = term;
                    continue;
                }
            }
            for (i, &p) in self.graph.nodes[c].args.iter().enumerate() {
                reached[p as usize] = true;
                let l = self.partials[c].get(i).copied().unwrap_or(f64::INFINITY);
                let edge = self.edges[c].get(i).copied().unwrap_or(0.0);
                s[p as usize] += scaled(l, s[c]) + edge;
            }
        }
        Sens { s, inherited }
    }

    /// Whether node `n` is a sum of squares `x·x + y·y + …` (nested additions, at most 8
    /// deep), collecting the bases.
    fn sum_of_squares(&self, n: usize, bases: &mut Vec<usize>, depth: u32) -> bool {
        use crate::ops::BinaryOp;
        let node = &self.graph.nodes[n];
        match (&node.op, &node.args[..]) {
            (Op::Binary(BinaryOp::Mul), [a, b]) if a == b => {
                bases.push(*a as usize);
                true
            }
            (Op::Binary(BinaryOp::Add), [a, b]) if depth < 8 => {
                self.sum_of_squares(*a as usize, bases, depth + 1)
                    && self.sum_of_squares(*b as usize, bases, depth + 1)
            }
            _ => false,
        }
    }

    /// What node `n` adds to the outputs if it runs in f32 (its own rounding).
    fn own_cost(&self, n: usize, s: &[f64]) -> f64 {
        let node = &self.graph.nodes[n];
        if !self.live[n] || self.is_const(n) {
            return 0.0;
        }
        let k = rules::f32_roundings(&node.op, node.ty);
        scaled(k * self.magnitude[n] * F32_UNIT, s[n])
    }

    /// What handing argument `i` of node `c` (in f64: promoted, or a constant) to `c` in f32 adds.
    fn narrowing_cost(&self, c: usize, i: usize, s: &[f64]) -> f64 {
        let p = self.graph.nodes[c].args[i] as usize;
        if self.graph.nodes[p].ty != Type::Scalar {
            return 0.0;
        }
        let l = self.partials[c].get(i).copied().unwrap_or(f64::INFINITY);
        let edge = self.edges[c].get(i).copied().unwrap_or(0.0);
        scaled(self.magnitude[p] * F32_UNIT, scaled(l, s[c]) + edge)
    }

    /// One forward pass: a node runs in f64 when its own f32 rounding, or its rounding of an
    /// argument that is in f64, would add more than `tau`.
    fn choose(&self, s: &[f64], tau: f64) -> Vec<bool> {
        let mut wide = vec![false; self.graph.nodes.len()];
        for (n, node) in self.graph.nodes.iter().enumerate() {
            if !self.live[n] || !rules::promotable(&node.op, node.ty) {
                continue;
            }
            let mut boundary = 0.0;
            let mut any_wide = false;
            for (i, &p) in node.args.iter().enumerate() {
                if wide[p as usize] || self.is_const(p as usize) {
                    any_wide |= wide[p as usize];
                    boundary += self.narrowing_cost(n, i, s);
                }
            }
            wide[n] = match node.op {
                // Free: their value is f64 either way.
                Op::Splat | Op::Combine => any_wide || boundary > tau,
                // A constant angle is a precomputed matrix already.
                Op::Rotate { .. } if self.is_const(node.args[1] as usize) => false,
                Op::Rotate { .. } => any_wide || boundary > tau,
                _ => self.own_cost(n, s) > tau || boundary > tau,
            };
        }
        wide
    }

    /// The bound on the outputs' error with `wide` promoted, sensitivities `s`.
    fn bound(&self, wide: &[bool], s: &Sens, outputs: &[(String, NodeId)]) -> Bound {
        let mut b = Bound::default();
        for (n, node) in self.graph.nodes.iter().enumerate() {
            if !self.live[n] || s[n] == 0.0 {
                continue;
            }
            b.add(s.inherited[n], || {
                format!(
                    "{} inherits the relative f32 error of its inputs",
                    self.describe(n)
                )
            });
            if !wide[n] {
                b.add(self.own_cost(n, s), || {
                    self.with_slope(self.own_reason(n), n, s)
                });
                for (i, &p) in node.args.iter().enumerate() {
                    if wide[p as usize] || self.is_const(p as usize) {
                        b.add(self.narrowing_cost(n, i, s), || {
                            self.with_slope(self.narrowing_reason(n, i), n, s)
                        });
                    }
                }
            }
        }
        for (name, node) in outputs {
            let n = *node as usize;
            if s[n] > 0.0 && (wide[n] || self.graph.nodes[n].ty == Type::Vec3 || self.is_const(n)) {
                let term = self.magnitude[n] * F32_UNIT;
                b.add(term, || {
                    format!(
                        "output \"{name}\" is written in f32 and reaches |value| {:.3e}, which \
                         f32 resolves only to {:.1e}: evaluate in f64 (`--f64`)",
                        self.magnitude[n], term
                    )
                });
            }
        }
        b
    }

    /// The bound on the f64 reference's own error.
    fn f64_bound(&self, s: &[f64]) -> Bound {
        let mut b = Bound::default();
        for (n, node) in self.graph.nodes.iter().enumerate() {
            if !self.live[n] || s[n] == 0.0 {
                continue;
            }
            let own = rules::f64_roundings(&node.op, node.ty) * self.magnitude[n] * F64_UNIT;
            b.add(scaled(own, s[n]), || {
                let why = format!(
                    "f64 itself cannot: \"{}\" reaches |value| {:.3e} over the extent, which f64 \
                     resolves only to {:.1e}, and the output moves {:.3e} times as much",
                    self.graph.nodes[n].origin.node,
                    self.magnitude[n],
                    self.magnitude[n] * F64_UNIT,
                    s[n]
                );
                self.with_slope(why, n, s)
            });
        }
        b
    }

    fn output_bound(&self, name: &str, node: NodeId, wide: &[bool], max: f64) -> OutputBound {
        let outputs = [(name.to_string(), node)];
        let s = self.sensitivities(std::iter::once(node));
        let narrow = vec![false; wide.len()];
        let promoted = self.bound(wide, &s, &outputs);
        let floor = self.f64_bound(&s);
        // What the fast path still rounds is named first; where everything that matters runs
        // in f64 and the reference itself cannot hold the target, that is the reason.
        let shortfall = if promoted.total > max {
            promoted.why
        } else if floor.total > max {
            floor.why
        } else {
            None
        };
        OutputBound {
            output: name.to_string(),
            plain_f32: self.bound(&narrow, &s, &outputs).total,
            promoted: promoted.total,
            f64_floor: floor.total,
            shortfall,
        }
    }

    /// The first operation with an unbounded slope on the way from node `n` to the outputs
    /// (sensitivities `s`), for the message of an infinite bound.
    fn unbounded_slope(&self, n: usize, s: &[f64]) -> String {
        let culprit = (n..self.graph.nodes.len()).find(|&c| {
            self.live[c]
                && s[c] > 0.0
                && s[c].is_finite()
                && self.partials[c].iter().any(|l| l.is_infinite())
        });
        match culprit {
            Some(c) => format!(
                "; the bound is infinite: {} has no bounded slope over the extent",
                self.describe(c)
            ),
            None => String::new(),
        }
    }

    fn describe(&self, n: usize) -> String {
        let node = &self.graph.nodes[n];
        format!("\"{}\" ({})", node.origin.node, op_name(&node.op))
    }

    fn own_reason(&self, n: usize) -> String {
        let node = &self.graph.nodes[n];
        let what = if rules::promotable(&node.op, node.ty) {
            "rounds in f32"
        } else {
            "has no f64 form on the fast path and rounds in f32"
        };
        format!(
            "{} {what} with |value| up to {:.3e}",
            self.describe(n),
            self.magnitude[n]
        )
    }

    /// A reason, with the cause of an infinite sensitivity where there is one.
    fn with_slope(&self, why: String, n: usize, s: &[f64]) -> String {
        if s[n].is_infinite() {
            why + &self.unbounded_slope(n, s)
        } else {
            why
        }
    }

    fn narrowing_reason(&self, c: usize, i: usize) -> String {
        let p = self.graph.nodes[c].args[i] as usize;
        format!(
            "{} has no f64 form on the fast path and reads {} (|value| up to {:.3e}) in f32",
            self.describe(c),
            self.describe(p),
            self.magnitude[p]
        )
    }
}

/// Per node, the relative error bound ρ of the plain f32 tape where the chain keeps errors
/// relative, infinite elsewhere (see `Facts::relative`).
fn relative_errors(graph: &CheckedGraph, live: &[bool], ranges: &[Range]) -> Vec<f64> {
    use crate::ops::{BinaryOp, UnaryOp};
    let n = graph.nodes.len();
    let mut rho = vec![f64::INFINITY; n];
    // Vec3 values computed in f64 from positions and constants only: exact on both paths.
    let mut exact = vec![false; n];
    let same_sign = |a: &Range, b: &Range| {
        (a[0].lo >= 0.0 && b[0].lo >= 0.0) || (a[0].hi <= 0.0 && b[0].hi <= 0.0)
    };
    for (id, node) in graph.nodes.iter().enumerate() {
        if !live[id] {
            continue;
        }
        let arg = |i: usize| node.args[i] as usize;
        if node.ty == Type::Vec3 {
            exact[id] = match node.op {
                Op::Position | Op::ConstVec3(_) => true,
                Op::Unary(_) | Op::Binary(_) | Op::Ternary(_) | Op::Cross | Op::Normalize => {
                    node.args.iter().all(|&a| exact[a as usize])
                }
                _ => false,
            };
            continue;
        }
        rho[id] = match node.op {
            Op::ConstScalar(_) => F32_UNIT,
            Op::Component(_) if exact[arg(0)] => F32_UNIT,
            Op::Unary(UnaryOp::Neg | UnaryOp::Abs) => rho[arg(0)],
            Op::Unary(UnaryOp::Sqrt) if ranges[arg(0)][0].lo >= 0.0 => rho[arg(0)] / 2.0 + F32_UNIT,
            Op::Binary(BinaryOp::Mul | BinaryOp::Div) => rho[arg(0)] + rho[arg(1)] + F32_UNIT,
            Op::Binary(BinaryOp::Add) if same_sign(&ranges[arg(0)], &ranges[arg(1)]) => {
                rho[arg(0)].max(rho[arg(1)]) + F32_UNIT
            }
            _ => f64::INFINITY,
        };
    }
    rho
}

/// `a · b` where an exact zero stays zero even against an infinite factor.
fn scaled(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        0.0
    } else {
        a * b
    }
}

fn op_name(op: &Op) -> String {
    match op {
        Op::Unary(u) => u.name().to_string(),
        Op::Binary(b) => b.name().to_string(),
        Op::Ternary(t) => t.name().to_string(),
        Op::Component(a) => format!("component {}", ["x", "y", "z"][*a as usize % 3]),
        Op::Noise(_) => "noise".into(),
        Op::Fractal(..) => "fractal".into(),
        Op::Ramp(_) => "ramp".into(),
        Op::Curve(_) => "curve".into(),
        Op::Hermite(_) => "hermite".into(),
        other => format!("{other:?}")
            .split(['(', ' ', '{'])
            .next()
            .unwrap_or("")
            .to_lowercase(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extents_parse_and_print() {
        let e = Extent::parse("-1e6,0,0:1e6,1,inf").unwrap();
        assert_eq!(e.min, [-1e6, 0.0, 0.0]);
        assert_eq!(e.max, [1e6, 1.0, f64::INFINITY]);
        assert_eq!(Extent::parse(&e.to_string()).unwrap(), e);
        assert!(Extent::parse("0,0:1,1,1").is_err());
        assert!(Extent::parse("1,0,0:0,1,1").is_err());
        assert!(Extent::parse("0,0,0").is_err());
        assert!(Extent::parse("nan,0,0:1,1,1").is_err());
        let around = Extent::around(&[1.0, -2.0], &[0.0, 0.0], &[3.0, f64::NAN]).unwrap();
        assert_eq!(around.min, [-2.0, 0.0, f64::NEG_INFINITY]);
        assert_eq!(around.magnitude(), f64::INFINITY);
    }
}
