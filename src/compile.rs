//! Stage 3, compile: checked graph → tape.
//!
//! Keeps only the nodes the requested outputs need, lowers each to one instruction (fbm,
//! turbulence, ramps and splines are single coarse instructions), and assigns slots: constants
//! get pinned slots filled once per workspace, every other value gets the lowest free slot of its
//! type and gives it back after its last use. Deduplication and constant folding already happened
//! while the graph was built (graph.rs), so this pass is linear in the live nodes and never
//! recurses.

use crate::diagnostic::{Diagnostic, DiagnosticClass, Diagnostics};
use crate::graph::{CheckedGraph, NodeId, Op, TableKey, Type};
use crate::ops;
use crate::tape::{Instr, Slot, Tape, TapeOutput, TapeStats};
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
}

static NEXT_TAPE_ID: AtomicU64 = AtomicU64::new(1);

/// Compiles the requested outputs. Fails only if a requested output does not exist.
///
/// Four phases: output selection, one reachability sweep (liveness and last uses), lowering of
/// each live node to one instruction with slot allocation, and the tape with its constant pool.
pub fn compile(graph: &CheckedGraph, options: &CompileOptions) -> Result<Tape, Diagnostics> {
    let selected = select_outputs(graph, options)?;
    let live = reachable(graph, selected.iter().map(|o| o.node));
    let last_use = last_uses(graph, &live, &selected);
    let live_nodes = live.iter().filter(|&&l| l).count();
    let mut emitter = Emitter {
        instrs: Vec::with_capacity(live_nodes),
        origins: Vec::with_capacity(live_nodes),
        ..Emitter::default()
    };
    let mut stretches: Option<Vec<Option<f64>>> = None;
    // The slot of each live node, indexed by node id (only live ones are ever read).
    let mut slot_of: Vec<Slot> = vec![0; graph.nodes.len()];
    for (id, node) in graph.nodes.iter().enumerate() {
        if !live[id] {
            continue;
        }
        match &node.op {
            Op::ConstScalar(v) => {
                slot_of[id] = emitter.scalars.pin();
                emitter.scalar_constants.push((slot_of[id], *v));
                continue;
            }
            Op::ConstVec3(v) => {
                slot_of[id] = emitter.vec3s.pin();
                emitter.vec3_constants.push((slot_of[id], *v));
                continue;
            }
            _ => {}
        }
        // Allocate the destination before freeing dead arguments, so an instruction never
        // writes a slot it reads (the interpreter relies on it).
        let dst = if node.ty == Type::Vec3 {
            emitter.vec3s.alloc()
        } else {
            emitter.scalars.alloc()
        };
        let instr = emitter.lower(graph, id, dst, &slot_of, options, &mut stretches);
        emitter.instrs.push(instr);
        emitter.origins.push(node.origin.node.clone());
        slot_of[id] = dst;
        emitter.free_dead_arguments(graph, id, &last_use, &slot_of);
    }
    let mut outputs = Vec::with_capacity(selected.len());
    let mut first_channel = 0;
    for output in selected {
        let ty = graph.nodes[output.node as usize].ty;
        outputs.push(TapeOutput {
            name: output.name.clone(),
            ty,
            slot: slot_of[output.node as usize],
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
    Ok(emitter.finish(outputs, stats))
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

/// The last user of each live node (instruction order is node id order); outputs live to the
/// end.
fn last_uses(
    graph: &CheckedGraph,
    live: &[bool],
    selected: &[&crate::graph::Output],
) -> Vec<usize> {
    let mut last_use: Vec<usize> = vec![0; graph.nodes.len()];
    for (id, node) in graph.nodes.iter().enumerate() {
        if live[id] {
            for &arg in &node.args {
                last_use[arg as usize] = last_use[arg as usize].max(id);
            }
        }
    }
    for output in selected {
        last_use[output.node as usize] = usize::MAX;
    }
    last_use
}

fn unreachable_const() -> Instr {
    // Constants are handled (and `continue`d) before this match; kept panic-free regardless.
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
    scalar_constants: Vec<(Slot, f64)>,
    vec3_constants: Vec<(Slot, [f64; 3])>,
    tables: Vec<(TableKey, std::sync::Arc<crate::noise::NoiseTable>)>,
    octaves: Vec<crate::noise::Octaves>,
    octave_counts: Vec<(f64, f64)>,
    matrices: Vec<[[f64; 3]; 3]>,
    axes: Vec<[f64; 3]>,
    hermites: Vec<ops::Hermite>,
    ramps: Vec<std::sync::Arc<ops::Ramp>>,
    curves: Vec<std::sync::Arc<ops::Curve>>,
}

impl Emitter {
    /// The instruction of live node `id`, writing `dst`; side tables (noise tables, octave
    /// schedules with level of detail, matrices, splines) are filled as needed.
    fn lower(
        &mut self,
        graph: &CheckedGraph,
        id: usize,
        dst: Slot,
        slot_of: &[Slot],
        options: &CompileOptions,
        stretches: &mut Option<Vec<Option<f64>>>,
    ) -> Instr {
        let node = &graph.nodes[id];
        let arg = |i: usize| slot_of[node.args[i] as usize];
        let vec3 = node.ty == Type::Vec3;
        match &node.op {
            Op::ConstScalar(_) | Op::ConstVec3(_) => unreachable_const(),
            Op::Position => Instr::Position { dst },
            Op::Splat => Instr::Splat { dst, src: arg(0) },
            Op::Combine => Instr::Combine {
                dst,
                x: arg(0),
                y: arg(1),
                z: arg(2),
            },
            Op::Component(axis) => Instr::Component {
                dst,
                src: arg(0),
                axis: *axis,
            },
            Op::Unary(op) if vec3 => Instr::UnaryVec3 {
                op: *op,
                dst,
                src: arg(0),
            },
            Op::Unary(op) => Instr::UnaryScalar {
                op: *op,
                dst,
                src: arg(0),
            },
            Op::Binary(op) if vec3 => Instr::BinaryVec3 {
                op: *op,
                dst,
                a: arg(0),
                b: arg(1),
            },
            Op::Binary(op) => Instr::BinaryScalar {
                op: *op,
                dst,
                a: arg(0),
                b: arg(1),
            },
            Op::Ternary(op) if vec3 => Instr::TernaryVec3 {
                op: *op,
                dst,
                a: arg(0),
                b: arg(1),
                c: arg(2),
            },
            Op::Ternary(op) => Instr::TernaryScalar {
                op: *op,
                dst,
                a: arg(0),
                b: arg(1),
                c: arg(2),
            },
            Op::Dot => Instr::Dot {
                dst,
                a: arg(0),
                b: arg(1),
            },
            Op::Length => Instr::Length { dst, src: arg(0) },
            Op::Cross => Instr::Cross {
                dst,
                a: arg(0),
                b: arg(1),
            },
            Op::Normalize => Instr::Normalize { dst, src: arg(0) },
            Op::Rotate { axis } => match graph.nodes[node.args[1] as usize].op {
                Op::ConstScalar(degrees) => {
                    self.matrices.push(ops::rotation_matrix(*axis, degrees));
                    Instr::RotateConst {
                        dst,
                        src: arg(0),
                        matrix: (self.matrices.len() - 1) as u32,
                    }
                }
                _ => {
                    self.axes.push(*axis);
                    Instr::RotateVarying {
                        dst,
                        src: arg(0),
                        degrees: arg(1),
                        axis: (self.axes.len() - 1) as u32,
                    }
                }
            },
            Op::Noise(key) => Instr::Noise {
                dst,
                src: arg(0),
                table: self.table(*key),
            },
            Op::NoiseGradient(key) => Instr::NoiseGradient {
                dst,
                src: arg(0),
                table: self.table(*key),
            },
            Op::Fractal(key, params) | Op::FractalGradient(key, params) => {
                let table = self.table(*key);
                let lod = match options.spacing {
                    Some(spacing) => {
                        let stretches =
                            stretches.get_or_insert_with(|| crate::lod::stretches(graph));
                        crate::lod::fractal_lod(
                            *key,
                            params,
                            stretches[node.args[0] as usize],
                            spacing,
                        )
                    }
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
                if let Op::FractalGradient(..) = node.op {
                    // The octaves left out add a constant on average: no slope.
                    return Instr::FractalGradient {
                        dst,
                        src: arg(0),
                        table,
                        octaves: (self.octaves.len() - 1) as u32,
                        style: params.style,
                    };
                }
                Instr::Fractal {
                    dst,
                    src: arg(0),
                    table,
                    octaves: (self.octaves.len() - 1) as u32,
                    style: params.style,
                    bias: lod.bias,
                }
            }
            Op::Hermite(h) => {
                self.hermites.push(*h);
                Instr::Hermite {
                    dst,
                    src: arg(0),
                    spline: (self.hermites.len() - 1) as u32,
                }
            }
            Op::Ramp(r) => {
                self.ramps.push(r.clone());
                Instr::Ramp {
                    dst,
                    src: arg(0),
                    ramp: (self.ramps.len() - 1) as u32,
                }
            }
            Op::Curve(c) => {
                self.curves.push(c.clone());
                Instr::Curve {
                    dst,
                    src: arg(0),
                    curve: (self.curves.len() - 1) as u32,
                }
            }
        }
    }

    /// Gives back the slots of node `id`'s arguments whose last use is `id` (each once, even if
    /// used twice here); constants keep their pinned slots.
    fn free_dead_arguments(
        &mut self,
        graph: &CheckedGraph,
        id: usize,
        last_use: &[usize],
        slot_of: &[Slot],
    ) {
        let mut freed: SmallVec<[NodeId; 3]> = SmallVec::new();
        for &a in &graph.nodes[id].args {
            let node = &graph.nodes[a as usize];
            let pinned = matches!(node.op, Op::ConstScalar(_) | Op::ConstVec3(_));
            if !pinned && last_use[a as usize] == id && !freed.contains(&a) {
                freed.push(a);
                match node.ty {
                    Type::Vec3 => self.vec3s.free(slot_of[a as usize]),
                    Type::Scalar => self.scalars.free(slot_of[a as usize]),
                }
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
            matrices: self.matrices,
            axes: self.axes,
            hermites: self.hermites,
            ramps: self.ramps,
            curves: self.curves,
            origins: self.origins,
            stats,
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
