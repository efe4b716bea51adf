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

/// A slot index in the scalar or vec3 file (which one follows from the instruction).
pub type Slot = u32;

#[derive(Clone, Debug, PartialEq)]
pub enum Instr {
    /// dst(vec3) = the sample point.
    Position {
        dst: Slot,
    },
    /// dst(vec3) = (src, src, src).
    Splat {
        dst: Slot,
        src: Slot,
    },
    /// dst(vec3) = (x, y, z) from three scalar slots.
    Combine {
        dst: Slot,
        x: Slot,
        y: Slot,
        z: Slot,
    },
    /// dst(scalar) = src(vec3)`[axis]`.
    Component {
        dst: Slot,
        src: Slot,
        axis: u8,
    },
    UnaryScalar {
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
    Dot {
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    Length {
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
        dst: Slot,
        src: Slot,
        degrees: Slot,
        axis: u32,
    },
    Noise {
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// Fbm (or turbulence) with the octave loop inside one instruction, plus `bias` (the
    /// average of the octaves level of detail left out; 0 without).
    Fractal {
        dst: Slot,
        src: Slot,
        table: u32,
        octaves: u32,
        style: Style,
        bias: f64,
    },
    /// dst(vec3) = the analytic gradient of the noise at src (`Gradient`).
    NoiseGradient {
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// dst(vec3) = the analytic gradient of a fractal sum (octaves after level of detail).
    FractalGradient {
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
    /// An instruction on the f64 ("wide") scalar slots: the scalars precision analysis promoted
    /// (`precision.rs`). On the f64 path it computes exactly what the plain instruction would.
    Wide(Wide),
}

/// Instructions whose scalar operands live in the wide slots (`d` in the disassembly): f64 lanes
/// whatever the evaluation's lane type. Vec3 operands are the usual vec3 slots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Wide {
    /// d = v.axis, unrounded.
    Component {
        dst: Slot,
        src: Slot,
        axis: u8,
    },
    Unary {
        op: UnaryOp,
        dst: Slot,
        src: Slot,
    },
    Binary {
        op: BinaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    Ternary {
        op: TernaryOp,
        dst: Slot,
        a: Slot,
        b: Slot,
        c: Slot,
    },
    Dot {
        dst: Slot,
        a: Slot,
        b: Slot,
    },
    Length {
        dst: Slot,
        src: Slot,
    },
    /// v = (d, d, d).
    Splat {
        dst: Slot,
        src: Slot,
    },
    /// v = (dx, dy, dz).
    Combine {
        dst: Slot,
        x: Slot,
        y: Slot,
        z: Slot,
    },
    /// v = rotation of v(src) about `axes[axis]` by d(degrees), per lane.
    Rotate {
        dst: Slot,
        src: Slot,
        degrees: Slot,
        axis: u32,
    },
    /// d = a noise sample of v(src), computed in f64 (a promoted `Noise`: every basis has its
    /// f64 form, the reference path's).
    Noise {
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// d = a fractal sum of v(src), computed in f64 (a promoted `Fractal`), plus `bias`.
    Fractal {
        dst: Slot,
        src: Slot,
        table: u32,
        octaves: u32,
        style: Style,
        bias: f64,
    },
    /// v = the analytic gradient of the noise at v(src), its kernel in f64 (a promoted
    /// `NoiseGradient`; the vec3 slot is f64 on both paths).
    NoiseGradient {
        dst: Slot,
        src: Slot,
        table: u32,
    },
    /// v = the gradient of a fractal sum, its kernels in f64 (a promoted `FractalGradient`).
    FractalGradient {
        dst: Slot,
        src: Slot,
        table: u32,
        octaves: u32,
        style: Style,
    },
    /// d = a lane-type scalar, exactly.
    Widen {
        dst: Slot,
        src: Slot,
    },
    /// A lane-type scalar = d, rounded (a no-op copy on the f64 path).
    Narrow {
        dst: Slot,
        src: Slot,
    },
}

impl Wide {
    /// A promoted noise sample, fractal sum or gradient as its plain instruction (the same
    /// fields; the inverse of the compiler's promotion); `None` for every other instruction.
    pub(crate) fn plain_noise(self) -> Option<Instr> {
        Some(match self {
            Wide::Noise { dst, src, table } => Instr::Noise { dst, src, table },
            Wide::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            } => Instr::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            },
            Wide::NoiseGradient { dst, src, table } => Instr::NoiseGradient { dst, src, table },
            Wide::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
            } => Instr::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
            },
            _ => return None,
        })
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

    /// Instructions that run in f64 on the fast path (promoted ones and their conversions).
    pub fn wide_instructions(&self) -> usize {
        self.instrs
            .iter()
            .filter(|i| matches!(i, Instr::Wide(_)))
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
        match instr {
            Instr::Position { dst } => format!("v{dst} = position"),
            Instr::Splat { dst, src } => format!("v{dst} = splat s{src}"),
            Instr::Combine { dst, x, y, z } => format!("v{dst} = combine s{x}, s{y}, s{z}"),
            Instr::Component { dst, src, axis } => {
                format!("s{dst} = v{src}.{}", ["x", "y", "z"][*axis as usize % 3])
            }
            Instr::UnaryScalar { op, dst, src } => format!("s{dst} = {op} s{src}"),
            Instr::UnaryVec3 { op, dst, src } => format!("v{dst} = {op} v{src}"),
            Instr::BinaryScalar { op, dst, a, b } => format!("s{dst} = {op} s{a}, s{b}"),
            Instr::BinaryVec3 { op, dst, a, b } => format!("v{dst} = {op} v{a}, v{b}"),
            Instr::TernaryScalar { op, dst, a, b, c } => {
                format!("s{dst} = {op} s{a}, s{b}, s{c}")
            }
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                format!("v{dst} = {op} v{a}, v{b}, v{c}")
            }
            Instr::Dot { dst, a, b } => format!("s{dst} = dot v{a}, v{b}"),
            Instr::Length { dst, src } => format!("s{dst} = length v{src}"),
            Instr::Cross { dst, a, b } => format!("v{dst} = cross v{a}, v{b}"),
            Instr::Normalize { dst, src } => format!("v{dst} = normalize v{src}"),
            Instr::RotateConst { dst, src, matrix } => {
                let m = &self.matrices[*matrix as usize];
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
            } => {
                format!(
                    "v{dst} = rotate v{src} axis={} degrees=s{degrees}",
                    vec3_text(&self.axes[*axis as usize])
                )
            }
            Instr::Noise { dst, src, table } => {
                format!("s{dst} = {}", self.noise_text(*src, *table))
            }
            Instr::NoiseGradient { dst, src, table } => {
                format!("v{dst} = {}", self.gradient_text(*src, *table, None))
            }
            Instr::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
            } => format!(
                "v{dst} = {}",
                self.gradient_text(*src, *table, Some((*octaves, *style)))
            ),
            Instr::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            } => format!(
                "s{dst} = {}",
                self.fractal_text(*src, *table, *octaves, *style, *bias)
            ),
            Instr::Hermite { dst, src, spline } => {
                let h = &self.hermites[*spline as usize];
                format!(
                    "s{dst} = hermite s{src} p0={} p1={} m0={} m1={}",
                    h.p0, h.p1, h.m0, h.m1
                )
            }
            Instr::Ramp { dst, src, ramp } => {
                let r = &self.ramps[*ramp as usize];
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
                let c = &self.curves[*curve as usize];
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
            Instr::Wide(w) => self.wide_text(w),
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

    fn wide_text(&self, w: &Wide) -> String {
        match *w {
            Wide::NoiseGradient { dst, src, table } => {
                format!("v{dst} = {} f64", self.gradient_text(src, table, None))
            }
            Wide::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
            } => format!(
                "v{dst} = {} f64",
                self.gradient_text(src, table, Some((octaves, style)))
            ),
            Wide::Noise { dst, src, table } => {
                format!("d{dst} = {}", self.noise_text(src, table))
            }
            Wide::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            } => format!(
                "d{dst} = {}",
                self.fractal_text(src, table, octaves, style, bias)
            ),
            Wide::Component { dst, src, axis } => {
                format!("d{dst} = v{src}.{}", ["x", "y", "z"][axis as usize % 3])
            }
            Wide::Unary { op, dst, src } => format!("d{dst} = {op} d{src}"),
            Wide::Binary { op, dst, a, b } => format!("d{dst} = {op} d{a}, d{b}"),
            Wide::Ternary { op, dst, a, b, c } => format!("d{dst} = {op} d{a}, d{b}, d{c}"),
            Wide::Dot { dst, a, b } => format!("d{dst} = dot v{a}, v{b}"),
            Wide::Length { dst, src } => format!("d{dst} = length v{src}"),
            Wide::Splat { dst, src } => format!("v{dst} = splat d{src}"),
            Wide::Combine { dst, x, y, z } => format!("v{dst} = combine d{x}, d{y}, d{z}"),
            Wide::Rotate {
                dst,
                src,
                degrees,
                axis,
            } => format!("v{dst} = rotate v{src} axis=#{axis} degrees=d{degrees}"),
            Wide::Widen { dst, src } => format!("d{dst} = widen s{src}"),
            Wide::Narrow { dst, src } => format!("s{dst} = narrow d{src}"),
        }
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
