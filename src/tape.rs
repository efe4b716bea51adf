//! Stage 3's output: the flat instruction tape.
//!
//! The tape is addressed like a stack frame with fixed offsets (the way Blender Cycles' SVM
//! "stack" is addressed): every instruction names the slots it reads and the slot it writes, and
//! the slot of each value is decided at compile time. Two slot files exist, scalar slots (one lane
//! array of the evaluation's `Real` type) and vec3 slots (three f64 lane planes). Why slots and
//! not push/pop: a batch interpreter pays one dispatch per instruction per batch, so what matters
//! is the lane loops; with fixed slots a value is written once and read in place by every user
//! (a DAG, not a tree: fbm results feed several nodes), where a push/pop machine would have to copy
//! lane arrays to duplicate them. Slots are reused once their value is dead, so the working set
//! of a 256-lane batch stays in L1/L2 (ARCHITECTURE.md, "Tape").
//!
//! A tape is immutable, `Send + Sync`, and shared by reference across threads; all mutable state
//! lives in a per-thread `Workspace`.

use crate::graph::{TableKey, Type};
use crate::noise::{Basis, Interpolation, NoiseTable, Octaves, Style};
use crate::ops::{BinaryOp, Curve, Hermite, Ramp, TernaryOp, UnaryOp};
use std::fmt;
use std::sync::Arc;

/// A slot index in the scalar, wide or vec3 file (which one follows from the instruction).
pub type Slot = u32;

/// Which scalar slot file an instruction's scalar operands live in: the evaluation's lane type
/// (`s` slots in the disassembly) or f64 whatever the lane type (`d` slots: the instructions the
/// precision plan promoted, `precision/`). Vec3 operands are always the f64 vec3 slots (`v`).
/// On the f64 path a promoted instruction computes exactly what the plain one would.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Prec {
    #[default]
    Lane,
    Wide,
}

impl Prec {
    /// The slot file of this precision's scalars.
    pub fn file(self) -> File {
        match self {
            Prec::Lane => File::Scalar,
            Prec::Wide => File::Wide,
        }
    }
}

/// A slot file of a tape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum File {
    /// Lane-type scalars (`s`).
    Scalar,
    /// f64 scalars of promoted instructions (`d`).
    Wide,
    /// f64 points and colours (`v`).
    Vec3,
}

impl File {
    /// The precision of a scalar file's slots; `None` for the vec3 file.
    pub fn prec(self) -> Option<Prec> {
        match self {
            File::Scalar => Some(Prec::Lane),
            File::Wide => Some(Prec::Wide),
            File::Vec3 => None,
        }
    }

    /// The disassembly's (and the generated shaders') prefix of a slot of this file.
    pub fn prefix(self) -> char {
        match self {
            File::Scalar => 's',
            File::Wide => 'd',
            File::Vec3 => 'v',
        }
    }
}

/// A slot with its file: what an instruction reads or writes ([`Instr::reads`],
/// [`Instr::writes`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Operand {
    pub file: File,
    pub slot: Slot,
}

impl Operand {
    pub fn scalar(prec: Prec, slot: Slot) -> Operand {
        Operand {
            file: prec.file(),
            slot,
        }
    }

    pub fn vec3(slot: Slot) -> Operand {
        Operand {
            file: File::Vec3,
            slot,
        }
    }
}

impl fmt::Display for Operand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.file.prefix(), self.slot)
    }
}

/// The slots an instruction reads: at most three, in operand order, without allocating.
pub type Reads = smallvec::SmallVec<[Operand; 3]>;

/// One instruction. Those with a scalar operand or result carry the [`Prec`] of their scalars
/// (the slot file they are read from and written to; for a noise kernel also the type it runs
/// in); the others read and write vec3 slots, or lane-type scalars only (the splines).
#[derive(Clone, Debug, PartialEq)]
pub enum Instr {
    /// dst(vec3) = the sample point.
    Position {
        dst: Slot,
    },
    /// dst(vec3) = (src, src, src).
    Splat {
        prec: Prec,
        dst: Slot,
        src: Slot,
    },
    /// dst(vec3) = (x, y, z) from three scalar slots.
    Combine {
        prec: Prec,
        dst: Slot,
        x: Slot,
        y: Slot,
        z: Slot,
    },
    /// dst(scalar) = src(vec3)`[axis]` (rounded once to the lane type, or exact in f64).
    Component {
        prec: Prec,
        dst: Slot,
        src: Slot,
        axis: u8,
    },
    UnaryScalar {
        prec: Prec,
        op: UnaryOp,
        dst: Slot,
        src: Slot,
    },
    UnaryVec3 {
        op: UnaryOp,
        dst: Slot,
        src: Slot,
    },
    BinaryScalar {
        prec: Prec,
        op: BinaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    BinaryVec3 {
        op: BinaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    TernaryScalar {
        prec: Prec,
        op: TernaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
        c: Slot,
    },
    TernaryVec3 {
        op: TernaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
        c: Slot,
    },
    /// dst(scalar) = a · b (in f64, then rounded once to the lane type where `prec` is `Lane`).
    Dot {
        prec: Prec,
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    Length {
        prec: Prec,
        dst: Slot,
        src: Slot,
    },
    /// dst(vec3) = a × b.
    Cross {
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    /// dst(vec3) = src / |src| (`ops::normalize`).
    Normalize {
        dst: Slot,
        src: Slot,
    },
    /// dst(vec3) = `matrices[matrix]` · src: a rotation whose angle is constant.
    RotateConst {
        dst: Slot,
        src: Slot,
        matrix: u32,
    },
    /// dst(vec3) = rotation of src about `axes[axis]` by degrees(scalar slot), per lane.
    RotateVarying {
        prec: Prec,
        dst: Slot,
        src: Slot,
        degrees: Slot,
        axis: u32,
    },
    /// dst(scalar) = a noise sample of src(vec3), computed in the precision's type (every basis
    /// has its f64 form, the reference path's).
    Noise {
        prec: Prec,
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// Fbm (or turbulence) with the octave loop inside one instruction, plus `bias` (the
    /// average of the octaves level of detail left out; 0 without).
    Fractal {
        prec: Prec,
        dst: Slot,
        src: Slot,
        table: u32,
        octaves: u32,
        style: Style,
        bias: f64,
    },
    /// dst(vec3) = the analytic gradient of the noise at src (`Gradient`), its kernels in the
    /// precision's type (the vec3 slot is f64 either way).
    NoiseGradient {
        prec: Prec,
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// dst(vec3) = the analytic gradient of a fractal sum (octaves after level of detail).
    FractalGradient {
        prec: Prec,
        dst: Slot,
        src: Slot,
        table: u32,
        octaves: u32,
        style: Style,
    },
    Hermite {
        dst: Slot,
        src: Slot,
        spline: u32,
    },
    Ramp {
        dst: Slot,
        src: Slot,
        ramp: u32,
    },
    Curve {
        dst: Slot,
        src: Slot,
        curve: u32,
    },
    /// d(dst) = s(src): a lane-type scalar in f64, exactly.
    Widen {
        dst: Slot,
        src: Slot,
    },
    /// s(dst) = d(src), rounded once to the lane type (a copy on the f64 path).
    Narrow {
        dst: Slot,
        src: Slot,
    },
}

impl Instr {
    /// The slot this instruction writes (every instruction writes exactly one).
    pub fn writes(&self) -> Operand {
        use Operand as O;
        match *self {
            Instr::Position { dst }
            | Instr::Splat { dst, .. }
            | Instr::Combine { dst, .. }
            | Instr::UnaryVec3 { dst, .. }
            | Instr::BinaryVec3 { dst, .. }
            | Instr::TernaryVec3 { dst, .. }
            | Instr::Cross { dst, .. }
            | Instr::Normalize { dst, .. }
            | Instr::RotateConst { dst, .. }
            | Instr::RotateVarying { dst, .. }
            | Instr::NoiseGradient { dst, .. }
            | Instr::FractalGradient { dst, .. }
            | Instr::Ramp { dst, .. } => O::vec3(dst),
            Instr::Component { prec, dst, .. }
            | Instr::UnaryScalar { prec, dst, .. }
            | Instr::BinaryScalar { prec, dst, .. }
            | Instr::TernaryScalar { prec, dst, .. }
            | Instr::Dot { prec, dst, .. }
            | Instr::Length { prec, dst, .. }
            | Instr::Noise { prec, dst, .. }
            | Instr::Fractal { prec, dst, .. } => O::scalar(prec, dst),
            Instr::Hermite { dst, .. } | Instr::Curve { dst, .. } | Instr::Narrow { dst, .. } => {
                O::scalar(Prec::Lane, dst)
            }
            Instr::Widen { dst, .. } => O::scalar(Prec::Wide, dst),
        }
    }

    /// The slots this instruction reads, in operand order (a slot read twice is listed twice).
    pub fn reads(&self) -> Reads {
        use Operand as O;
        let v = O::vec3;
        let mut r = Reads::new();
        match *self {
            Instr::Position { .. } => {}
            Instr::Splat { prec, src, .. } | Instr::UnaryScalar { prec, src, .. } => {
                r.push(O::scalar(prec, src))
            }
            Instr::Combine { prec, x, y, z, .. } => r.extend([x, y, z].map(|s| O::scalar(prec, s))),
            Instr::BinaryScalar { prec, a, b, .. } => r.extend([a, b].map(|s| O::scalar(prec, s))),
            Instr::TernaryScalar { prec, a, b, c, .. } => {
                r.extend([a, b, c].map(|s| O::scalar(prec, s)))
            }
            Instr::Component { src, .. }
            | Instr::UnaryVec3 { src, .. }
            | Instr::Length { src, .. }
            | Instr::Normalize { src, .. }
            | Instr::RotateConst { src, .. }
            | Instr::Noise { src, .. }
            | Instr::Fractal { src, .. }
            | Instr::NoiseGradient { src, .. }
            | Instr::FractalGradient { src, .. } => r.push(v(src)),
            Instr::BinaryVec3 { a, b, .. }
            | Instr::Dot { a, b, .. }
            | Instr::Cross { a, b, .. } => r.extend([v(a), v(b)]),
            Instr::TernaryVec3 { a, b, c, .. } => r.extend([v(a), v(b), v(c)]),
            Instr::RotateVarying {
                prec, src, degrees, ..
            } => r.extend([v(src), O::scalar(prec, degrees)]),
            Instr::Hermite { src, .. }
            | Instr::Ramp { src, .. }
            | Instr::Curve { src, .. }
            | Instr::Widen { src, .. } => r.push(O::scalar(Prec::Lane, src)),
            Instr::Narrow { src, .. } => r.push(O::scalar(Prec::Wide, src)),
        }
        r
    }

    /// The precision of the instruction's scalars: `Wide` for a promoted instruction and for
    /// the conversions between the files (`Widen`, `Narrow`), else `Lane`.
    pub fn prec(&self) -> Prec {
        match *self {
            Instr::Splat { prec, .. }
            | Instr::Combine { prec, .. }
            | Instr::Component { prec, .. }
            | Instr::UnaryScalar { prec, .. }
            | Instr::BinaryScalar { prec, .. }
            | Instr::TernaryScalar { prec, .. }
            | Instr::Dot { prec, .. }
            | Instr::Length { prec, .. }
            | Instr::RotateVarying { prec, .. }
            | Instr::Noise { prec, .. }
            | Instr::Fractal { prec, .. }
            | Instr::NoiseGradient { prec, .. }
            | Instr::FractalGradient { prec, .. } => prec,
            Instr::Widen { .. } | Instr::Narrow { .. } => Prec::Wide,
            _ => Prec::Lane,
        }
    }
}

/// One value per slot of every file of a tape: what the walks over a tape track as
/// instructions write slots (integer flags, intervals, chains), addressed by [`Operand`] or by
/// a scalar's precision and slot.
#[derive(Clone, Debug)]
pub(crate) struct SlotMap<T> {
    pub scalars: Vec<T>,
    pub wides: Vec<T>,
    pub vec3s: Vec<[T; 3]>,
}

impl<T: Clone> SlotMap<T> {
    /// Every slot of `tape` holding `init`.
    pub fn new(tape: &Tape, init: T) -> SlotMap<T> {
        SlotMap {
            scalars: vec![init.clone(); tape.scalar_slots],
            wides: vec![init.clone(); tape.wide_slots],
            vec3s: vec![[init.clone(), init.clone(), init]; tape.vec3_slots],
        }
    }

    /// The scalar slot `slot` of precision `prec`.
    pub fn s(&self, prec: Prec, slot: Slot) -> &T {
        match prec {
            Prec::Lane => &self.scalars[slot as usize],
            Prec::Wide => &self.wides[slot as usize],
        }
    }

    pub fn s_mut(&mut self, prec: Prec, slot: Slot) -> &mut T {
        match prec {
            Prec::Lane => &mut self.scalars[slot as usize],
            Prec::Wide => &mut self.wides[slot as usize],
        }
    }

    pub fn v(&self, slot: Slot) -> &[T; 3] {
        &self.vec3s[slot as usize]
    }

    pub fn v_mut(&mut self, slot: Slot) -> &mut [T; 3] {
        &mut self.vec3s[slot as usize]
    }

    /// Sets whatever `instr` writes to `value` (each component of a vec3).
    pub fn clear(&mut self, instr: &Instr, value: T) {
        let w = instr.writes();
        match w.file {
            File::Scalar => self.scalars[w.slot as usize] = value,
            File::Wide => self.wides[w.slot as usize] = value,
            File::Vec3 => self.vec3s[w.slot as usize] = [value.clone(), value.clone(), value],
        }
    }
}

/// Where an output's value lives at the end of the tape.
#[derive(Clone, Debug, PartialEq)]
pub struct TapeOutput {
    pub name: String,
    pub ty: Type,
    pub slot: Slot,
    /// Index of its first channel in an evaluation's output (scalar: 1 channel, vec3: 3).
    pub first_channel: usize,
}

/// Counts reported by `texgraph check`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TapeStats {
    /// Nodes of the checked graph after deduplication and folding.
    pub graph_nodes: usize,
    /// Graph nodes the requested outputs need.
    pub live_nodes: usize,
    /// Graph nodes left out because no requested output needs them.
    pub pruned_nodes: usize,
}

/// A compiled graph: a flat list of instructions over fixed slots.
#[derive(Debug)]
pub struct Tape {
    pub(crate) id: u64,
    pub(crate) instrs: Vec<Instr>,
    pub(crate) scalar_slots: usize,
    pub(crate) vec3_slots: usize,
    /// Constant slots, filled once when a workspace is bound to this tape.
    pub(crate) scalar_constants: Vec<(Slot, f64)>,
    pub(crate) vec3_constants: Vec<(Slot, [f64; 3])>,
    pub(crate) outputs: Vec<TapeOutput>,
    pub(crate) tables: Vec<(TableKey, Arc<NoiseTable>)>,
    pub(crate) octaves: Vec<Octaves>,
    /// For each octave schedule: the octaves written and those kept by level of detail.
    pub(crate) octave_counts: Vec<(f64, f64)>,
    /// For each octave schedule: level of detail per lane (`Tape::eval_batch_lod`), where the
    /// fractal's input stretch is known.
    pub(crate) lane_lods: Vec<Option<crate::lod::LaneLod>>,
    pub(crate) matrices: Vec<[[f64; 3]; 3]>,
    pub(crate) axes: Vec<[f64; 3]>,
    pub(crate) hermites: Vec<Hermite>,
    pub(crate) ramps: Vec<Arc<Ramp>>,
    pub(crate) curves: Vec<Arc<Curve>>,
    /// For each instruction, the graph node id it was written in (disassembly comments).
    pub(crate) origins: Vec<std::sync::Arc<str>>,
    pub(crate) stats: TapeStats,
    /// f64 scalar slots (promoted instructions) and their constants.
    pub(crate) wide_slots: usize,
    pub(crate) wide_constants: Vec<(Slot, f64)>,
    /// The precision plan it was compiled with (an extent was given), and for each promoted
    /// instruction why (instruction index, reason).
    pub(crate) precision: Option<Arc<crate::precision::Plan>>,
    pub(crate) reasons: Vec<(usize, String)>,
    /// Per instruction: the share of a lattice noise's or fractal's summed amplitude whose
    /// value-only samples the filtered form may take in f32 for an f32 result, its finest
    /// octaves first (`compile::narrow_samples`: the precision analysis bounds what that adds
    /// within `compile::NARROW_SAMPLE_ERROR`); 0: none.
    pub(crate) narrow_samples: Vec<f64>,
}

/// A tape is built only by [`crate::compile::compile()`]: its fields are private to the crate, so no caller
/// can assemble one the interpreter would read out of bounds. What a caller needs is read through
/// these accessors.
impl Tape {
    /// The outputs, in the order requested, each with its type and first channel.
    pub fn outputs(&self) -> &[TapeOutput] {
        &self.outputs
    }

    /// The instructions, in execution order (the disassembly is `Display`).
    pub fn instructions(&self) -> &[Instr] {
        &self.instrs
    }

    /// Scalar slots a workspace holds for this tape (constants included).
    pub fn scalar_slots(&self) -> usize {
        self.scalar_slots
    }

    /// Vec3 slots a workspace holds for this tape (constants included).
    pub fn vec3_slots(&self) -> usize {
        self.vec3_slots
    }

    /// Nodes kept and pruned by compiling.
    pub fn stats(&self) -> &TapeStats {
        &self.stats
    }

    /// The precision plan (when compiled for an extent): the error bound of each output and
    /// which instructions run in f64.
    pub fn precision(&self) -> Option<&crate::precision::Plan> {
        self.precision.as_deref()
    }
    /// The outputs that may miss the precision target over the extent the tape was compiled
    /// for, each as `output "grain" may miss 1e-4: WHY` (the plan's shortfalls, which
    /// `check --tape` lists and `eval`, `bake` and `render` print as warnings). Empty without
    /// a plan, or when every output meets the target.
    pub fn shortfalls(&self) -> Vec<String> {
        let Some(plan) = &self.precision else {
            return Vec::new();
        };
        plan.outputs
            .iter()
            .filter_map(|o| {
                let why = o.shortfall.as_ref()?;
                Some(shortfall_text(&o.output, plan.max_error, why))
            })
            .collect()
    }

    /// The slot discipline the interpreter relies on, checked from each instruction's
    /// [`Instr::reads`] and [`Instr::writes`]: every slot within its file, no instruction
    /// writing a slot it reads, every slot read written before (by an instruction, or as a
    /// constant), no constant slot overwritten, and every output's slot written. `compile`
    /// asserts it in debug builds (every test compiles through it); a tape failing it is a
    /// compiler bug, named with the instruction.
    pub(crate) fn check_slots(&self) -> Result<(), String> {
        let mut written = SlotMap::new(self, false);
        let mut constant = SlotMap::new(self, false);
        for &(slot, _) in &self.scalar_constants {
            *constant.s_mut(Prec::Lane, slot) = true;
        }
        for &(slot, _) in &self.wide_constants {
            *constant.s_mut(Prec::Wide, slot) = true;
        }
        for &(slot, _) in &self.vec3_constants {
            *constant.v_mut(slot) = [true; 3];
        }
        let count = |file: File| match file {
            File::Scalar => self.scalar_slots,
            File::Wide => self.wide_slots,
            File::Vec3 => self.vec3_slots,
        };
        let get = |map: &SlotMap<bool>, o: Operand| match o.file.prec() {
            Some(prec) => *map.s(prec, o.slot),
            None => map.v(o.slot)[0],
        };
        for (i, instr) in self.instrs.iter().enumerate() {
            let write = instr.writes();
            let reads = instr.reads();
            let text = || format!("{i:04} {}", self.instruction_text(instr));
            for o in reads.iter().chain([&write]) {
                if o.slot as usize >= count(o.file) {
                    return Err(format!("{}: {o} is out of range", text()));
                }
            }
            if let Some(o) = reads
                .iter()
                .find(|o| !get(&written, **o) && !get(&constant, **o))
            {
                return Err(format!("{}: {o} is read before it is written", text()));
            }
            if reads.contains(&write) {
                return Err(format!("{}: writes {write}, which it reads", text()));
            }
            if get(&constant, write) {
                return Err(format!("{}: overwrites the constant {write}", text()));
            }
            match write.file.prec() {
                Some(prec) => *written.s_mut(prec, write.slot) = true,
                None => *written.v_mut(write.slot) = [true; 3],
            }
        }
        for output in &self.outputs {
            let o = match output.ty {
                Type::Scalar => Operand::scalar(Prec::Lane, output.slot),
                Type::Vec3 => Operand::vec3(output.slot),
            };
            if o.slot as usize >= count(o.file) || !(get(&written, o) || get(&constant, o)) {
                return Err(format!("output \"{}\": {o} is never written", output.name));
            }
        }
        Ok(())
    }

    /// Instructions that run in f64 on the fast path (promoted ones and their conversions).
    pub fn wide_instructions(&self) -> usize {
        self.instrs
            .iter()
            .filter(|i| i.prec() == Prec::Wide)
            .count()
    }

    /// A fingerprint of what the tape computes (FNV-1a 64 over its instructions, constants,
    /// outputs and tables' keys, not over its process-local id): equal tapes compiled in
    /// different processes, or by different runs of one build, have equal fingerprints. A bake
    /// records it (zarr attributes, shard manifests) to tell a resumable store from a stale one.
    pub fn fingerprint(&self) -> u64 {
        let text = format!(
            "{:?}|{}|{}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}|{:?}{}",
            self.instrs,
            self.scalar_slots,
            self.vec3_slots,
            self.scalar_constants,
            self.vec3_constants,
            self.outputs,
            self.tables.iter().map(|(key, _)| key).collect::<Vec<_>>(),
            self.octaves,
            self.octave_counts,
            self.matrices,
            self.axes,
            self.hermites,
            self.ramps,
            self.curves,
            // Only a tape with wide slots hashes them: a plain tape keeps its old fingerprint.
            if self.wide_slots > 0 {
                format!("|{}|{:?}", self.wide_slots, self.wide_constants)
            } else {
                String::new()
            },
        );
        text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    }

    /// Total output channels: 1 per scalar output, 3 per vec3 output.
    pub fn channels(&self) -> usize {
        self.outputs.iter().map(|o| o.ty.channels()).sum()
    }

    pub fn output(&self, name: &str) -> Option<&TapeOutput> {
        self.outputs.iter().find(|o| o.name == name)
    }

    /// Most octaves any fbm/turbulence instruction sums (after level of detail).
    pub fn fractal_octaves(&self) -> Vec<(String, f64, f64)> {
        self.instrs
            .iter()
            .zip(&self.origins)
            .filter_map(|(instr, origin)| match instr {
                Instr::Fractal { octaves, .. } | Instr::FractalGradient { octaves, .. } => {
                    let (written, kept) = self.octave_counts[*octaves as usize];
                    Some((origin.to_string(), written, kept))
                }
                _ => None,
            })
            .collect()
    }
}

/// A fractal style as the disassembly writes it.
fn style_name(style: &Style) -> String {
    match style {
        Style::Fbm => "fbm".into(),
        Style::Turbulence => "turbulence".into(),
        Style::Billow => "billow".into(),
        Style::Ridged { offset, sharpness } => {
            format!("ridged offset={offset} sharpness={sharpness}")
        }
    }
}

fn basis_name(key: &TableKey) -> String {
    let period = key.period.map_or(String::new(), |p| {
        format!(" period=({}, {}, {})", p[0], p[1], p[2])
    });
    let name = match key.basis {
        Basis::Perlin => format!("perlin seed={}", key.seed),
        Basis::Gradient => format!("gradient seed={}", key.seed),
        Basis::Value(Interpolation::Linear) => format!("value seed={}", key.seed),
        Basis::Value(Interpolation::Smooth) => format!("value-smooth seed={}", key.seed),
        Basis::Simplex => format!("simplex seed={}", key.seed),
        Basis::White => format!("white seed={}", key.seed),
        Basis::Cellular(c) => format!(
            "cellular jitter={} metric={:?} value={:?} seed={}",
            c.jitter(),
            c.metric,
            c.value,
            key.seed
        ),
    };
    name + &period
}

/// A tiled schedule's per-octave periods, as the disassembly writes them ("" untiled).
fn periods_text(schedule: &Octaves) -> String {
    match &schedule.periods {
        None => String::new(),
        Some(periods) => {
            let each: Vec<String> = periods
                .iter()
                .map(|p| format!("({}, {}, {})", p[0], p[1], p[2]))
                .collect();
            format!(" periods=[{}]", each.join(", "))
        }
    }
}

fn vec3_text(v: &[f64; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

impl Tape {
    /// Each instruction as the disassembly writes it (without its number), with the graph node
    /// it was written in: `texgraph serve` lists a node's instructions.
    pub fn instruction_lines(&self) -> impl Iterator<Item = (&str, String)> + '_ {
        self.instrs
            .iter()
            .zip(&self.origins)
            .map(|(instr, origin)| (&**origin, self.instruction_text(instr)))
    }

    /// The graph node each instruction was written in, in tape order.
    pub fn origins(&self) -> impl Iterator<Item = &str> + '_ {
        self.origins.iter().map(|o| &**o)
    }

    fn instruction_text(&self, instr: &Instr) -> String {
        // A scalar operand's name: `s` (lane type) or `d` (wide) by the instruction's precision.
        let p = instr.prec().file().prefix();
        match *instr {
            Instr::Position { dst } => format!("v{dst} = position"),
            Instr::Splat { dst, src, .. } => format!("v{dst} = splat {p}{src}"),
            Instr::Combine { dst, x, y, z, .. } => {
                format!("v{dst} = combine {p}{x}, {p}{y}, {p}{z}")
            }
            Instr::Component { dst, src, axis, .. } => {
                format!("{p}{dst} = v{src}.{}", ["x", "y", "z"][axis as usize % 3])
            }
            Instr::UnaryScalar { op, dst, src, .. } => format!("{p}{dst} = {op} {p}{src}"),
            Instr::UnaryVec3 { op, dst, src } => format!("v{dst} = {op} v{src}"),
            Instr::BinaryScalar { op, dst, a, b, .. } => format!("{p}{dst} = {op} {p}{a}, {p}{b}"),
            Instr::BinaryVec3 { op, dst, a, b } => format!("v{dst} = {op} v{a}, v{b}"),
            Instr::TernaryScalar {
                op, dst, a, b, c, ..
            } => {
                format!("{p}{dst} = {op} {p}{a}, {p}{b}, {p}{c}")
            }
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                format!("v{dst} = {op} v{a}, v{b}, v{c}")
            }
            Instr::Dot { dst, a, b, .. } => format!("{p}{dst} = dot v{a}, v{b}"),
            Instr::Length { dst, src, .. } => format!("{p}{dst} = length v{src}"),
            Instr::Cross { dst, a, b } => format!("v{dst} = cross v{a}, v{b}"),
            Instr::Normalize { dst, src } => format!("v{dst} = normalize v{src}"),
            Instr::RotateConst { dst, src, matrix } => {
                let m = &self.matrices[matrix as usize];
                format!(
                    "v{dst} = rotate v{src} matrix [{}, {}, {}]",
                    vec3_text(&m[0]),
                    vec3_text(&m[1]),
                    vec3_text(&m[2])
                )
            }
            Instr::RotateVarying {
                dst,
                src,
                degrees,
                axis,
                ..
            } => {
                format!(
                    "v{dst} = rotate v{src} axis={} degrees={p}{degrees}",
                    vec3_text(&self.axes[axis as usize])
                )
            }
            Instr::Noise {
                dst, src, table, ..
            } => {
                format!("{p}{dst} = {}", self.noise_text(src, table))
            }
            Instr::NoiseGradient {
                prec,
                dst,
                src,
                table,
            } => {
                let text = self.gradient_text(src, table, None);
                format!("v{dst} = {text}{}", f64_suffix(prec))
            }
            Instr::FractalGradient {
                prec,
                dst,
                src,
                table,
                octaves,
                style,
            } => {
                let text = self.gradient_text(src, table, Some((octaves, style)));
                format!("v{dst} = {text}{}", f64_suffix(prec))
            }
            Instr::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
                ..
            } => format!(
                "{p}{dst} = {}",
                self.fractal_text(src, table, octaves, style, bias)
            ),
            Instr::Hermite { dst, src, spline } => {
                let h = &self.hermites[spline as usize];
                format!(
                    "s{dst} = hermite s{src} p0={} p1={} m0={} m1={}",
                    h.p0, h.p1, h.m0, h.m1
                )
            }
            Instr::Ramp { dst, src, ramp } => {
                let r = &self.ramps[ramp as usize];
                let stops: Vec<String> = r
                    .knots()
                    .iter()
                    .zip(r.values())
                    .map(|(t, c)| format!("({t}, {})", vec3_text(c)))
                    .collect();
                format!(
                    "v{dst} = ramp s{src} {:?} [{}]",
                    r.interpolation(),
                    stops.join(", ")
                )
            }
            Instr::Curve { dst, src, curve } => {
                let c = &self.curves[curve as usize];
                let points: Vec<String> = c
                    .knots()
                    .iter()
                    .zip(c.values())
                    .map(|(x, y)| format!("({x}, {})", y[0]))
                    .collect();
                format!(
                    "s{dst} = curve s{src} {:?} [{}]",
                    c.interpolation(),
                    points.join(", ")
                )
            }
            Instr::Widen { dst, src } => format!("d{dst} = widen s{src}"),
            Instr::Narrow { dst, src } => format!("s{dst} = narrow d{src}"),
        }
    }

    /// A noise instruction's text after `dst =`.
    fn noise_text(&self, src: Slot, table: u32) -> String {
        format!(
            "noise v{src} {}",
            basis_name(&self.tables[table as usize].0)
        )
    }

    /// A fractal instruction's text after `dst =`.
    fn fractal_text(&self, src: Slot, table: u32, octaves: u32, style: Style, bias: f64) -> String {
        let schedule = &self.octaves[octaves as usize];
        let bias = if bias != 0.0 {
            format!(" bias={bias}")
        } else {
            String::new()
        };
        let amplitudes: Vec<String> = schedule.amplitudes.iter().map(|a| a.to_string()).collect();
        let frequencies: Vec<String> = schedule.frequencies.iter().map(|a| a.to_string()).collect();
        format!(
            "{} v{src} {} octaves={} frequencies=[{}] amplitudes=[{}]",
            style_name(&style),
            basis_name(&self.tables[table as usize].0),
            schedule.len(),
            frequencies.join(", "),
            amplitudes.join(", "),
        ) + &periods_text(schedule)
            + &bias
    }

    /// A noise gradient (`fractal`: its octave schedule and style) after `v{dst} = `.
    fn gradient_text(&self, src: Slot, table: u32, fractal: Option<(u32, Style)>) -> String {
        let basis = basis_name(&self.tables[table as usize].0);
        match fractal {
            None => format!("gradient noise v{src} {basis}"),
            Some((octaves, style)) => {
                let schedule = &self.octaves[octaves as usize];
                format!(
                    "gradient {} v{src} {basis} octaves={}",
                    style_name(&style),
                    schedule.len(),
                ) + &periods_text(schedule)
            }
        }
    }
}

/// A promoted gradient's mark in the disassembly (its kernels run in f64).
fn f64_suffix(prec: Prec) -> &'static str {
    match prec {
        Prec::Lane => "",
        Prec::Wide => " f64",
    }
}

/// The disassembly: stable, human readable, one instruction per line. It is a golden format.
impl fmt::Display for Tape {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "; {} instructions, {} scalar slots, {} vec3 slots, {} constants",
            self.instrs.len(),
            self.scalar_slots,
            self.vec3_slots,
            self.scalar_constants.len() + self.vec3_constants.len()
        )?;
        for (slot, v) in &self.scalar_constants {
            writeln!(f, "const s{slot} = {v}")?;
        }
        for (slot, v) in &self.vec3_constants {
            writeln!(f, "const v{slot} = {}", vec3_text(v))?;
        }
        if self.wide_slots > 0 {
            if let Some(plan) = &self.precision {
                writeln!(
                    f,
                    "; precision: extent {}, max error {:e}: {} f64 slots",
                    plan.extent, plan.max_error, self.wide_slots
                )?;
            }
            for (slot, v) in &self.wide_constants {
                writeln!(f, "const d{slot} = {v}")?;
            }
        }
        let mut reasons = self.reasons.iter().peekable();
        for (i, (instr, origin)) in self.instrs.iter().zip(&self.origins).enumerate() {
            let text = self.instruction_text(instr);
            write!(f, "{i:04}  {text:<48} ; {origin}")?;
            if let Some((_, why)) = reasons.next_if(|(at, _)| *at == i) {
                write!(f, "  {why}")?;
            }
            writeln!(f)?;
        }
        for output in &self.outputs {
            let prefix = if output.ty == Type::Scalar { "s" } else { "v" };
            writeln!(
                f,
                "output \"{}\": {} = {prefix}{}",
                output.name, output.ty, output.slot
            )?;
        }
        Ok(())
    }
}

/// One output's shortfall, as `check --tape` and the evaluating commands print it.
pub(crate) fn shortfall_text(output: &str, max_error: f64, why: &str) -> String {
    format!("output \"{output}\" may miss {max_error:e}: {why}")
}
