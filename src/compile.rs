//! Stage 3, compile: checked graph → tape.
//!
//! Keeps only the nodes the requested outputs need, lowers each to one instruction (fbm,
//! turbulence, ramps and splines are single coarse instructions), and assigns slots: constants
//! get pinned slots filled once per workspace, every other value gets the lowest free slot of its
//! type and gives it back after its last use. Deduplication and constant folding already happened
//! while the graph was built (graph.rs), so this pass is linear in the live nodes and never
//! recurses.

use crate::diagnostic::{Diagnostic, DiagnosticClass, Diagnostics};
use crate::eval::Workspace;
use crate::graph::{CheckedGraph, NodeId, Op, TableKey, Type};
use crate::ops;
use crate::precision::{Extent, SAMPLES};
use crate::tape::{Instr, Prec, Slot, Tape, TapeOutput, TapeStats};
use smallvec::SmallVec;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::atomic::{AtomicU64, Ordering};

/// What to compile.
#[derive(Clone, Debug, Default)]
pub struct CompileOptions {
    /// Outputs to compile, by name, in this order; empty means all, in file order.
    pub outputs: Vec<String>,
    /// Footprint level of detail: the sample spacing in world units (a bake's voxel size, a
    /// render's pixel footprint). Fbm/turbulence octaves above the Nyquist limit of this spacing
    /// are left out (see `lod.rs`). `None`: every octave is kept.
    pub spacing: Option<f64>,
    /// The region the tape will be evaluated over (`Position`'s values). With one, precision is
    /// chosen per instruction (`precision.rs`): scalars whose f32 error would push an output
    /// past `max_error` run in f64. `None`: every scalar in the lane type (the plain tape).
    pub extent: Option<Extent>,
    /// The error target of that choice, absolute; `None` is
    /// [`crate::precision::DEFAULT_MAX_ERROR`] (1e-4).
    pub max_error: Option<f64>,
}

static NEXT_TAPE_ID: AtomicU64 = AtomicU64::new(1);

/// Compiles the requested outputs. Fails only if a requested output does not exist.
///
/// Four phases: output selection, one reachability sweep (liveness and last uses), lowering of
/// each live node to one instruction with slot allocation, and the tape with its constant pool.
pub fn compile(graph: &CheckedGraph, options: &CompileOptions) -> Result<Tape, Diagnostics> {
    let selected = select_outputs(graph, options)?;
    let live = reachable(graph, selected.iter().map(|o| o.node));
    let live_nodes = live.iter().filter(|&&l| l).count();
    let mut plan = options.extent.map(|extent| {
        let outputs: Vec<(String, NodeId)> =
            selected.iter().map(|o| (o.name.clone(), o.node)).collect();
        let max_error = options
            .max_error
            .unwrap_or(crate::precision::DEFAULT_MAX_ERROR);
        crate::precision::plan(graph, &live, &outputs, extent, max_error)
    });
    if let Some(plan) = plan.as_mut().filter(|p| p.needs_confirming()) {
        let plain = compile(
            graph,
            &CompileOptions {
                extent: None,
                ..options.clone()
            },
        )?;
        plan.keep_plain(sampled_error(&plain, &plan.extent));
    }
    let narrow = narrow_samples(graph, &live, &selected, options);
    let mut narrow_instrs = Vec::new();
    let no_wide = vec![false; graph.nodes.len()];
    let wide = plan.as_ref().map_or(&no_wide, |p| &p.wide);
    let uses = Uses::new(graph, &live, &selected, wide);
    let mut emitter = Emitter {
        instrs: Vec::with_capacity(live_nodes),
        origins: Vec::with_capacity(live_nodes),
        ..Emitter::default()
    };
    let mut stretches: Option<Vec<Option<f64>>> = None;
    // The slots of each live node, indexed by node id (only live ones are ever read): its
    // lane-type scalar or vec3 slot, and its f64 slot where it has one.
    let mut slots = Slots {
        narrow: vec![0; graph.nodes.len()],
        wide: vec![0; graph.nodes.len()],
    };
    for (id, node) in graph.nodes.iter().enumerate() {
        if !live[id] {
            continue;
        }
        if emitter.constant(node, id, &uses, &mut slots) {
            continue;
        }
        // Allocate the destination before freeing dead arguments, so an instruction never
        // writes a slot it reads (the interpreter relies on it). A promoted scalar gets a wide
        // slot; Splat and Combine read f64 scalars but write a vec3 slot.
        let prec = if wide[id] { Prec::Wide } else { Prec::Lane };
        let dst = match (node.ty, prec) {
            (Type::Vec3, _) => {
                slots.narrow[id] = emitter.vec3s.alloc();
                slots.narrow[id]
            }
            (Type::Scalar, Prec::Lane) => {
                slots.narrow[id] = emitter.scalars.alloc();
                slots.narrow[id]
            }
            (Type::Scalar, Prec::Wide) => {
                slots.wide[id] = emitter.wides.alloc();
                slots.wide[id]
            }
        };
        if let Some(plan) = plan.as_ref().filter(|_| prec == Prec::Wide) {
            emitter
                .reasons
                .push((emitter.instrs.len(), plan.reason(id as NodeId)));
        }
        let instr = emitter.lower(
            graph,
            id,
            Dst { slot: dst, prec },
            &slots,
            options,
            &mut stretches,
        );
        if narrow[id] > 0.0 {
            narrow_instrs.push((emitter.instrs.len(), narrow[id]));
        }
        emitter.instrs.push(instr);
        emitter.origins.push(node.origin.node.clone());
        emitter.convert(node, id, &uses, &mut slots);
        emitter.free_dead(graph, id, &uses, &slots);
    }
    let mut outputs = Vec::with_capacity(selected.len());
    let mut first_channel = 0;
    for output in selected {
        let ty = graph.nodes[output.node as usize].ty;
        outputs.push(TapeOutput {
            name: output.name.clone(),
            ty,
            slot: slots.narrow[output.node as usize],
            first_channel,
        });
        first_channel += ty.channels();
    }
    // Pruned: nodes of the written graph (reachable from a named node or any output) that the
    // requested outputs do not need. Intermediate constants left behind by folding don't count.
    let written = reachable(
        graph,
        graph
            .named
            .iter()
            .map(|&(_, id)| id)
            .chain(graph.outputs.iter().map(|o| o.node)),
    );
    let graph_nodes = written.iter().filter(|&&w| w).count();
    let stats = TapeStats {
        graph_nodes,
        live_nodes,
        pruned_nodes: graph_nodes.saturating_sub(live_nodes),
    };
    let mut tape = emitter.finish(outputs, stats);
    tape.precision = plan.map(std::sync::Arc::new);
    tape.narrow_samples = vec![0.0; tape.instrs.len()];
    for (i, share) in narrow_instrs {
        tape.narrow_samples[i] = share;
    }
    debug_assert_eq!(tape.check_slots(), Ok(()), "{tape}");
    Ok(tape)
}

/// What the f32 noise samples of the filtered form may add to an f32 result, at most (issue
/// 47's contract: an f32 filtered value within 1e-5 of the f64 one; half of it for the
/// first-order bound, the rest for the filtered rules' own f32 rounding of the result).
pub const NARROW_SAMPLE_ERROR: f64 = 5e-6;

/// Per graph node: the share of a lattice noise's or an Fbm or turbulence fractal's
/// amplitude whose value-only samples the filtered form may take in f32 for an f32 result
/// (`Tape::narrow_samples`; 0 elsewhere). The precision analysis bounds what the node's own
/// f32 roundings add to the outputs (over the extent, or all of space without one); each of
/// the `n` such nodes gets `NARROW_SAMPLE_ERROR / n` of it, and a fractal's octaves from
/// octave `k` up may sample in f32 where their share of its summed amplitude keeps its bound
/// within that (the fine octaves: `filter/noise.rs`' `FractalSamplers`), a noise where its
/// whole bound does (a share of at least 1).
fn narrow_samples(
    graph: &CheckedGraph,
    live: &[bool],
    selected: &[&crate::graph::Output],
    options: &CompileOptions,
) -> Vec<f64> {
    use crate::noise::{Basis, Style};
    let mut share = vec![0.0; graph.nodes.len()];
    let sampled = |op: &Op| match op {
        Op::Noise(key) => !matches!(key.basis, Basis::White | Basis::Cellular(_)),
        Op::Fractal(key, params) => {
            !matches!(key.basis, Basis::White | Basis::Cellular(_))
                && matches!(params.style, Style::Fbm | Style::Turbulence)
        }
        _ => false,
    };
    let candidates: Vec<usize> = (0..graph.nodes.len())
        .filter(|&n| live[n] && sampled(&graph.nodes[n].op))
        .collect();
    if candidates.is_empty() {
        return share;
    }
    let outputs: Vec<NodeId> = selected.iter().map(|o| o.node).collect();
    let extent = options.extent.unwrap_or_else(Extent::unbounded);
    let costs = crate::precision::f32_costs(graph, live, &outputs, extent, NARROW_SAMPLE_ERROR);
    let each = NARROW_SAMPLE_ERROR / candidates.len() as f64;
    for n in candidates {
        share[n] = if costs[n] == 0.0 {
            f64::INFINITY
        } else {
            each / costs[n]
        };
    }
    share
}

/// The precision plan's confirmation: the largest |f32 − f64| of `tape` (compiled plain) on [`SAMPLES`] points spread over
/// `extent` (one jittered point per cell of a 16³ lattice; fixed, so compiles are
/// reproducible); non-finite disagreements count as infinite.
fn sampled_error(tape: &Tape, extent: &Extent) -> f64 {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut planes: [Vec<f64>; 3] = Default::default();
    for i in 0..SAMPLES {
        let cell = [i % 16, (i / 16) % 16, i / 256];
        for c in 0..3 {
            let t = (cell[c] as f64 + next()) / 16.0;
            planes[c].push(extent.min[c] + t * (extent.max[c] - extent.min[c]));
        }
    }
    let channels = tape.channels();
    let mut a = vec![0f32; channels * SAMPLES];
    let mut b = vec![0f64; channels * SAMPLES];
    let [x, y, z] = &planes;
    tape.eval_batch(&mut Workspace::new(), x, y, z, &mut a);
    tape.eval_batch(&mut Workspace::new(), x, y, z, &mut b);
    a.iter().zip(&b).fold(0.0f64, |m, (s, r)| {
        let d = (*s as f64 - r).abs();
        if d.is_nan() && !(s.is_nan() && r.is_nan()) {
            f64::INFINITY
        } else if d.is_nan() {
            m
        } else {
            m.max(d)
        }
    })
}

/// Where each live node's value is read from, per representation: the lane-type slot
/// (`narrow`: instructions in the lane type, outputs) and the f64 slot (`wide`: promoted
/// instructions), with the last instruction (node id) reading each. A plain tape has no wide
/// uses, and its narrow last uses are the classic last uses.
struct Uses {
    narrow_last: Vec<usize>,
    wide_last: Vec<usize>,
    has_narrow: Vec<bool>,
    has_wide: Vec<bool>,
    wide_node: Vec<bool>,
}

impl Uses {
    fn new(
        graph: &CheckedGraph,
        live: &[bool],
        selected: &[&crate::graph::Output],
        wide: &[bool],
    ) -> Uses {
        let n = graph.nodes.len();
        let mut u = Uses {
            narrow_last: vec![0; n],
            wide_last: vec![0; n],
            has_narrow: vec![false; n],
            has_wide: vec![false; n],
            wide_node: wide.to_vec(),
        };
        for (id, node) in graph.nodes.iter().enumerate() {
            if !live[id] {
                continue;
            }
            for &arg in &node.args {
                let a = arg as usize;
                // Vec3 values have one representation, the vec3 slot ("narrow" here).
                if wide[id] && graph.nodes[a].ty == Type::Scalar {
                    u.has_wide[a] = true;
                    u.wide_last[a] = u.wide_last[a].max(id);
                } else {
                    u.has_narrow[a] = true;
                    u.narrow_last[a] = u.narrow_last[a].max(id);
                }
            }
        }
        for output in selected {
            let o = output.node as usize;
            u.has_narrow[o] = true;
            u.narrow_last[o] = usize::MAX;
        }
        u
    }
}

/// The slots of every node, per representation.
struct Slots {
    narrow: Vec<Slot>,
    wide: Vec<Slot>,
}

/// Where an instruction writes and in which precision its scalars are read and written.
#[derive(Clone, Copy)]
struct Dst {
    slot: Slot,
    prec: Prec,
}

impl Slots {
    /// The slot node `node`'s value is read from in precision `prec` (vec3 values have one
    /// slot, in `narrow`).
    fn of(&self, prec: Prec, node: NodeId) -> Slot {
        match prec {
            Prec::Lane => self.narrow[node as usize],
            Prec::Wide => self.wide[node as usize],
        }
    }
}

/// The outputs to compile: all, in file order, or the named ones in the order asked (each
/// once); an unknown name is an `unknown-output` diagnostic listing the graph's outputs.
fn select_outputs<'g>(
    graph: &'g CheckedGraph,
    options: &CompileOptions,
) -> Result<Vec<&'g crate::graph::Output>, Diagnostics> {
    if options.outputs.is_empty() {
        return Ok(graph.outputs.iter().collect());
    }
    let mut selected: Vec<&crate::graph::Output> = Vec::new();
    let mut errors = Vec::new();
    for name in &options.outputs {
        match graph.output(name) {
            Some(o) if !selected.iter().any(|s| s.name == *name) => selected.push(o),
            Some(_) => {}
            None => {
                let names: Vec<&str> = graph.outputs.iter().map(|o| o.name.as_str()).collect();
                errors.push(
                    Diagnostic::new(
                        DiagnosticClass::UnknownOutput,
                        format!("--output {name}: the graph has no output \"{name}\""),
                    )
                    .help(format!("its outputs are: {}", names.join(", "))),
                );
            }
        }
    }
    if !errors.is_empty() {
        return Err(Diagnostics {
            file: graph.file.clone(),
            list: errors,
        });
    }
    Ok(selected)
}

/// The nodes reachable from `roots` through arguments. Arguments have smaller ids than their
/// users, so one reverse sweep suffices (no recursion, no work list).
fn reachable(graph: &CheckedGraph, roots: impl Iterator<Item = NodeId>) -> Vec<bool> {
    let mut reached = vec![false; graph.nodes.len()];
    for root in roots {
        reached[root as usize] = true;
    }
    for id in (0..graph.nodes.len()).rev() {
        if reached[id] {
            for &arg in &graph.nodes[id].args {
                reached[arg as usize] = true;
            }
        }
    }
    reached
}

fn unreachable_const() -> Instr {
    // Constants are handled (and `continue`d) before lowering, and each lowering helper is
    // called for its own operations only; kept panic-free regardless.
    Instr::Position { dst: 0 }
}

/// A slot file: hands out the lowest free slot so allocation is deterministic. A min-heap, not
/// a sorted set: a slot is freed at most once before it is handed out again, so both give the
/// same order, and the heap costs far less per operation (compile/N in benches/eval.rs).
#[derive(Default)]
struct SlotFile {
    count: usize,
    free: BinaryHeap<Reverse<Slot>>,
}

impl SlotFile {
    fn alloc(&mut self) -> Slot {
        if let Some(Reverse(slot)) = self.free.pop() {
            slot
        } else {
            self.count += 1;
            (self.count - 1) as Slot
        }
    }

    /// A slot that is never freed (constants).
    fn pin(&mut self) -> Slot {
        self.count += 1;
        (self.count - 1) as Slot
    }

    fn free(&mut self, slot: Slot) {
        self.free.push(Reverse(slot));
    }
}

#[derive(Default)]
struct Emitter {
    instrs: Vec<Instr>,
    origins: Vec<std::sync::Arc<str>>,
    scalars: SlotFile,
    vec3s: SlotFile,
    wides: SlotFile,
    wide_constants: Vec<(Slot, f64)>,
    reasons: Vec<(usize, String)>,
    scalar_constants: Vec<(Slot, f64)>,
    vec3_constants: Vec<(Slot, [f64; 3])>,
    tables: Vec<(TableKey, std::sync::Arc<crate::noise::NoiseTable>)>,
    octaves: Vec<crate::noise::Octaves>,
    octave_counts: Vec<(f64, f64)>,
    lane_lods: Vec<Option<crate::lod::LaneLod>>,
    matrices: Vec<[[f64; 3]; 3]>,
    axes: Vec<[f64; 3]>,
    hermites: Vec<ops::Hermite>,
    ramps: Vec<std::sync::Arc<ops::Ramp>>,
    curves: Vec<std::sync::Arc<ops::Curve>>,
}

impl Emitter {
    /// The instruction of live node `id`, writing `dst`; side tables (noise tables, octave
    /// schedules with level of detail, matrices, splines) are filled as needed. Scalar
    /// arguments are read in `dst.prec` (a promoted instruction reads the wide slots).
    fn lower(
        &mut self,
        graph: &CheckedGraph,
        id: usize,
        dst: Dst,
        slots: &Slots,
        options: &CompileOptions,
        stretches: &mut Option<Vec<Option<f64>>>,
    ) -> Instr {
        let node = &graph.nodes[id];
        let Dst { slot: dst, prec } = dst;
        // A scalar argument (in the instruction's precision) and a vec3 one.
        let s = |i: usize| slots.of(prec, node.args[i]);
        let v = |i: usize| slots.narrow[node.args[i] as usize];
        let vec3 = node.ty == Type::Vec3;
        match node.op {
            Op::ConstScalar(_) | Op::ConstVec3(_) => unreachable_const(),
            Op::Position => Instr::Position { dst },
            Op::Splat => Instr::Splat {
                prec,
                dst,
                src: s(0),
            },
            Op::Combine => Instr::Combine {
                prec,
                dst,
                x: s(0),
                y: s(1),
                z: s(2),
            },
            Op::Component(axis) => Instr::Component {
                prec,
                dst,
                src: v(0),
                axis,
            },
            Op::Unary(op) if vec3 => Instr::UnaryVec3 { op, dst, src: v(0) },
            Op::Unary(op) => Instr::UnaryScalar {
                prec,
                op,
                dst,
                src: s(0),
            },
            Op::Binary(op) if vec3 => Instr::BinaryVec3 {
                op,
                dst,
                a: v(0),
                b: v(1),
            },
            Op::Binary(op) => Instr::BinaryScalar {
                prec,
                op,
                dst,
                a: s(0),
                b: s(1),
            },
            Op::Ternary(op) if vec3 => Instr::TernaryVec3 {
                op,
                dst,
                a: v(0),
                b: v(1),
                c: v(2),
            },
            Op::Ternary(op) => Instr::TernaryScalar {
                prec,
                op,
                dst,
                a: s(0),
                b: s(1),
                c: s(2),
            },
            Op::Dot => Instr::Dot {
                prec,
                dst,
                a: v(0),
                b: v(1),
            },
            Op::Length => Instr::Length {
                prec,
                dst,
                src: v(0),
            },
            Op::Cross => Instr::Cross {
                dst,
                a: v(0),
                b: v(1),
            },
            Op::Normalize => Instr::Normalize { dst, src: v(0) },
            Op::Rotate { axis } => match graph.nodes[node.args[1] as usize].op {
                Op::ConstScalar(degrees) => {
                    self.matrices.push(ops::rotation_matrix(axis, degrees));
                    Instr::RotateConst {
                        dst,
                        src: v(0),
                        matrix: (self.matrices.len() - 1) as u32,
                    }
                }
                _ => {
                    self.axes.push(axis);
                    Instr::RotateVarying {
                        prec,
                        dst,
                        src: v(0),
                        degrees: s(1),
                        axis: (self.axes.len() - 1) as u32,
                    }
                }
            },
            Op::Noise(_) | Op::NoiseGradient(_) | Op::Fractal(..) | Op::FractalGradient(..) => {
                let src = v(0);
                self.lower_noise(graph, id, Dst { slot: dst, prec }, src, options, stretches)
            }
            Op::Hermite(_) | Op::Ramp(_) | Op::Curve(_) => self.lower_spline(node, dst, s(0)),
        }
    }

    /// A noise sample, fractal sum or gradient of the point in vec3 slot `src`: its table, and
    /// for a fractal its octave schedule after level of detail (per compile with
    /// `options.spacing`, and per lane, `LaneLod`).
    fn lower_noise(
        &mut self,
        graph: &CheckedGraph,
        id: usize,
        dst: Dst,
        src: Slot,
        options: &CompileOptions,
        stretches: &mut Option<Vec<Option<f64>>>,
    ) -> Instr {
        let node = &graph.nodes[id];
        let Dst { slot: dst, prec } = dst;
        let (key, params) = match &node.op {
            Op::Noise(key) => {
                let table = self.table(*key);
                return Instr::Noise {
                    prec,
                    dst,
                    src,
                    table,
                };
            }
            Op::NoiseGradient(key) => {
                let table = self.table(*key);
                return Instr::NoiseGradient {
                    prec,
                    dst,
                    src,
                    table,
                };
            }
            Op::Fractal(key, params) | Op::FractalGradient(key, params) => (*key, params),
            _ => return unreachable_const(),
        };
        let table = self.table(key);
        let stretch =
            stretches.get_or_insert_with(|| crate::lod::stretches(graph))[node.args[0] as usize];
        let lod = match options.spacing {
            Some(spacing) => crate::lod::fractal_lod(key, params, stretch, spacing),
            None => crate::lod::FractalLod {
                octaves: params.octaves,
                bias: 0.0,
            },
        };
        let kept = crate::graph::FractalParams {
            octaves: lod.octaves,
            ..*params
        };
        self.octaves.push(kept.schedule());
        self.octave_counts.push((params.octaves, lod.octaves));
        self.lane_lods
            .push(crate::lod::LaneLod::new(key, params, stretch, lod));
        let octaves = (self.octaves.len() - 1) as u32;
        if let Op::FractalGradient(..) = node.op {
            // The octaves left out add a constant on average: no slope.
            return Instr::FractalGradient {
                prec,
                dst,
                src,
                table,
                octaves,
                style: params.style,
            };
        }
        Instr::Fractal {
            prec,
            dst,
            src,
            table,
            octaves,
            style: params.style,
            bias: lod.bias,
        }
    }

    /// A Hermite step, colour ramp or curve of the lane-type scalar in slot `src`.
    fn lower_spline(&mut self, node: &crate::graph::Node, dst: Slot, src: Slot) -> Instr {
        match &node.op {
            Op::Hermite(h) => {
                self.hermites.push(*h);
                Instr::Hermite {
                    dst,
                    src,
                    spline: (self.hermites.len() - 1) as u32,
                }
            }
            Op::Ramp(r) => {
                self.ramps.push(r.clone());
                Instr::Ramp {
                    dst,
                    src,
                    ramp: (self.ramps.len() - 1) as u32,
                }
            }
            Op::Curve(c) => {
                self.curves.push(c.clone());
                Instr::Curve {
                    dst,
                    src,
                    curve: (self.curves.len() - 1) as u32,
                }
            }
            _ => unreachable_const(),
        }
    }

    /// Pins the slots of a constant (a lane-type slot where a lane-type instruction or an output
    /// reads it, an f64 slot where a promoted one does); false for any other node.
    fn constant(
        &mut self,
        node: &crate::graph::Node,
        id: usize,
        uses: &Uses,
        slots: &mut Slots,
    ) -> bool {
        match node.op {
            Op::ConstScalar(v) => {
                if uses.has_narrow[id] || !uses.has_wide[id] {
                    slots.narrow[id] = self.scalars.pin();
                    self.scalar_constants.push((slots.narrow[id], v));
                }
                if uses.has_wide[id] {
                    slots.wide[id] = self.wides.pin();
                    self.wide_constants.push((slots.wide[id], v));
                }
                true
            }
            Op::ConstVec3(v) => {
                slots.narrow[id] = self.vec3s.pin();
                self.vec3_constants.push((slots.narrow[id], v));
                true
            }
            _ => false,
        }
    }

    /// After node `id`'s instruction: the other representation of a scalar that has readers of
    /// both kinds (a promoted value read by a lane-type instruction or an output is rounded
    /// once; a lane-type value read by a promoted instruction is widened exactly).
    fn convert(&mut self, node: &crate::graph::Node, id: usize, uses: &Uses, slots: &mut Slots) {
        if node.ty != Type::Scalar {
            return;
        }
        let instr = if uses.wide_node[id] && uses.has_narrow[id] {
            slots.narrow[id] = self.scalars.alloc();
            Instr::Narrow {
                dst: slots.narrow[id],
                src: slots.wide[id],
            }
        } else if !uses.wide_node[id] && uses.has_wide[id] {
            slots.wide[id] = self.wides.alloc();
            Instr::Widen {
                dst: slots.wide[id],
                src: slots.narrow[id],
            }
        } else {
            return;
        };
        self.instrs.push(instr);
        self.origins.push(node.origin.node.clone());
    }

    /// Gives back every slot whose last reader is node `id`: its arguments' (each once, even
    /// if used twice here; constants keep their pinned slots), and its own representation
    /// that nothing reads but the conversion just emitted.
    fn free_dead(&mut self, graph: &CheckedGraph, id: usize, uses: &Uses, slots: &Slots) {
        let mut freed: SmallVec<[NodeId; 3]> = SmallVec::new();
        for &a in &graph.nodes[id].args {
            let node = &graph.nodes[a as usize];
            let pinned = matches!(node.op, Op::ConstScalar(_) | Op::ConstVec3(_));
            if pinned || freed.contains(&a) {
                continue;
            }
            freed.push(a);
            let a = a as usize;
            if uses.has_narrow[a] && uses.narrow_last[a] == id {
                match node.ty {
                    Type::Vec3 => self.vec3s.free(slots.narrow[a]),
                    Type::Scalar => self.scalars.free(slots.narrow[a]),
                }
            }
            if uses.has_wide[a] && uses.wide_last[a] == id {
                self.wides.free(slots.wide[a]);
            }
        }
        if graph.nodes[id].ty == Type::Scalar {
            if uses.wide_node[id] && !uses.has_wide[id] {
                self.wides.free(slots.wide[id]);
            } else if !uses.wide_node[id] && !uses.has_narrow[id] && uses.has_wide[id] {
                self.scalars.free(slots.narrow[id]);
            }
        }
    }

    /// The tape: instructions, slot counts, the constant pool and the side tables.
    fn finish(self, outputs: Vec<TapeOutput>, stats: TapeStats) -> Tape {
        Tape {
            id: NEXT_TAPE_ID.fetch_add(1, Ordering::Relaxed),
            instrs: self.instrs,
            scalar_slots: self.scalars.count,
            vec3_slots: self.vec3s.count,
            scalar_constants: self.scalar_constants,
            vec3_constants: self.vec3_constants,
            outputs,
            tables: self.tables,
            octaves: self.octaves,
            octave_counts: self.octave_counts,
            lane_lods: self.lane_lods,
            matrices: self.matrices,
            axes: self.axes,
            hermites: self.hermites,
            ramps: self.ramps,
            curves: self.curves,
            origins: self.origins,
            stats,
            wide_slots: self.wides.count,
            wide_constants: self.wide_constants,
            precision: None,
            reasons: self.reasons,
            narrow_samples: Vec::new(),
        }
    }

    fn table(&mut self, key: TableKey) -> u32 {
        if let Some(i) = self.tables.iter().position(|(k, _)| *k == key) {
            return i as u32;
        }
        self.tables.push((
            key,
            std::sync::Arc::new(crate::noise::NoiseTable::periodic(
                key.basis, key.seed, key.period,
            )),
        ));
        (self.tables.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tape(text: &str) -> Tape {
        let source = crate::diagnostic::SourceFile::new("t.ron", text);
        let graph = crate::check::check(source, &Default::default()).expect("checks");
        compile(&graph, &CompileOptions::default()).expect("compiles")
    }

    const GRAPH: &str = r#"Graph(nodes: { "p": Position, "s": Sin(Mul("p.x", 3.0)) },
        outputs: { "a": Abs("s"), "b": Add("s", "p.y") })"#;

    /// The slot check every compile asserts in debug builds finds each way a tape can break
    /// the interpreter's assumptions (so the assertion can fail).
    #[test]
    fn the_slot_check_names_a_broken_tape() {
        assert_eq!(tape(GRAPH).check_slots(), Ok(()));
        let unary = |t: &Tape| {
            t.instrs
                .iter()
                .position(|i| matches!(i, Instr::UnaryScalar { .. }))
                .expect("a unary instruction")
        };
        let broken = |edit: &dyn Fn(&mut Tape)| {
            let mut t = tape(GRAPH);
            edit(&mut t);
            t.check_slots().expect_err("broken")
        };
        let own = broken(&|t| {
            let i = unary(t);
            if let Instr::UnaryScalar { dst, src, .. } = &mut t.instrs[i] {
                *src = *dst;
            }
        });
        assert!(own.contains("which it reads"), "{own}");
        let range = broken(&|t| {
            let i = unary(t);
            if let Instr::UnaryScalar { src, .. } = &mut t.instrs[i] {
                *src = 99;
            }
        });
        assert!(range.contains("s99 is out of range"), "{range}");
        let early = broken(&|t| t.instrs.swap(0, 1));
        assert!(early.contains("before it is written"), "{early}");
        let output = broken(&|t| t.outputs[0].slot = 99);
        assert!(output.contains("output \"a\""), "{output}");
        let constant = broken(&|t| {
            let c = t.scalar_constants[0].0;
            let i = unary(t);
            if let Instr::UnaryScalar { dst, .. } = &mut t.instrs[i] {
                *dst = c;
            }
        });
        assert!(constant.contains("overwrites the constant"), "{constant}");
    }
}
