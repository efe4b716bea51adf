//! The alternative to `codegen.rs` (issue 19, "generate or interpret?"), measured against it
//! and not chosen (docs/performance.md, "GPU": on lavapipe 140-175× slower kernels and 10-100×
//! slower pipeline creation; `examples/gpu_strategies.rs`): one fixed WGSL
//! interpreter of the tape, compiled once, reading the tape as data. The shader is the same
//! library (`codegen::LIBRARY`), then `const CHANNELS` / `struct Channels` exactly as codegen
//! writes them, then the interpreter's `fn tape(p: vec3<f64>, h: f64) -> Channels` (`wgsl/interpreter.wgsl`;
//! it has no level of detail per point, `h` is not read), then codegen's entry
//! points (`wgsl/entry.wgsl`). What the tape is lives in two extra storage buffers:
//!
//! - `@group(0) @binding(4) var<storage, read> program: array<u32>` — the encoded instructions;
//! - `@group(0) @binding(5) var<storage, read> constants: array<f64>` — every number of the
//!   tape (slot constants, matrices, axes, hermite coefficients, spline knots and values,
//!   octave frequencies, amplitudes and periods, fractal bias, ridged offset and sharpness,
//!   cellular jitter).
//!
//! Only `CHANNELS` and the slot files' array sizes depend on the tape (the sizes are the tape's
//! slot counts rounded up to a power of two, at least 8, so similar tapes share one source).
//!
//! # Program layout (32-bit words)
//!
//! ```text
//! word 0        instruction count N (slot constants and outputs included: see below)
//! words 1..4    scalar, vec3 and wide slot counts of the tape (informative)
//! word 4 + 8i   instruction i, 8 words:
//!   w0  opcode (bits 0-7) | sub (bits 8-15) | basis (bits 16-23) | flags (bits 24-31)
//!   w1  dst slot (for OUT_*: the first channel)
//!   w2  a: first operand slot (src)
//!   w3  b: second operand slot
//!   w4  c: third operand slot; for noise instructions the cellular metric | value << 8
//!   w5  k: index of the instruction's first constant in `constants`
//!   w6  n: octaves (fractals) or knots (splines)
//!   w7  t: the noise table's first word in the tables buffer (table · TABLE_WORDS)
//! ```
//!
//! `sub` is the `UnaryOp` / `BinaryOp` / `TernaryOp` code (the order of their `ALL` arrays),
//! the component's axis, the fractal style (0 fbm, 1 turbulence, 2 billow, 3 ridged) or the
//! spline interpolation (0 linear, 1 smooth, 2 constant). `basis`: 0 perlin, 1 gradient,
//! 2 value (linear), 3 value (smooth), 4 simplex, 5 white, 6 cellular. `flags`: bit 0 tiled
//! (periods given), bit 1 the fractal adds its bias, bit 2 the spline is a slope.
//!
//! The program starts with the slot constants (`CONST_S`, `CONST_V`, `CONST_D`), then the
//! tape's instructions in order, then one `OUT_S` / `OUT_V` per output.
//!
//! Constant blocks (`k`): an f32 value of the f32 path is stored already rounded to f32 (as
//! the f64 that is that f32), so `f32(constants[k])` is exact and equals codegen's literal.
//!
//! ```text
//! CONST_S / CONST_D      [value]            (CONST_S: rounded to f32)
//! CONST_V                [x, y, z]
//! ROTATE_CONST           [m00, m01, m02, m10, …, m22]   (row-major)
//! ROTATE_VARYING, WIDE_ROTATE   [axis x, y, z]
//! HERMITE                [p0, p1, m0, m1]   (rounded to f32)
//! NOISE, NOISE_GRADIENT  [jitter (f32), period x, y, z]  (period 0: none on that axis)
//! FRACTAL, FRACTAL_GRAD  [jitter (f32), bias (f32), offset (f32), sharpness (f32)], then per
//!                        octave [frequency, amplitude (FRACTAL: rounded to f32), period x, y, z
//!                        (tiled only)]
//! RAMP / CURVE           per knot [knot, value (3 / 1 channels), 1 / (next knot - knot) or 0]
//! ```

use super::codegen::{self, TABLE_WORDS};
use crate::noise::{Basis, Interpolation, Style};
use crate::ops::{BinaryOp, Spline, SplineInterpolation, TernaryOp, UnaryOp};
use crate::tape::{Instr, Tape, Wide};
use std::fmt::Write;

/// The interpreter's shader and the tape encoded for it.
#[derive(Clone, Debug)]
pub struct Interpreted {
    /// The WGSL: library, `CHANNELS` / `Channels`, the interpreter, the entry points.
    pub source: String,
    /// Output channels per point (as `Tape::channels`).
    pub channels: usize,
    /// The `program` buffer (binding 4).
    pub program: Vec<u32>,
    /// The `constants` buffer (binding 5; at least one value, a binding cannot be empty).
    pub constants: Vec<f64>,
}

/// Words before the first instruction.
pub const HEADER_WORDS: usize = 4;
/// Words per instruction.
pub const INSTR_WORDS: usize = 8;

/// Opcodes (`w0 & 0xff`), as the WGSL's `I_*` constants.
mod opcode {
    pub const CONST_S: u32 = 0;
    pub const CONST_V: u32 = 1;
    pub const CONST_D: u32 = 2;
    pub const POSITION: u32 = 3;
    pub const SPLAT: u32 = 4;
    pub const COMBINE: u32 = 5;
    pub const COMPONENT: u32 = 6;
    pub const UNARY_S: u32 = 7;
    pub const UNARY_V: u32 = 8;
    pub const BINARY_S: u32 = 9;
    pub const BINARY_V: u32 = 10;
    pub const TERNARY_S: u32 = 11;
    pub const TERNARY_V: u32 = 12;
    pub const DOT: u32 = 13;
    pub const LENGTH: u32 = 14;
    pub const CROSS: u32 = 15;
    pub const NORMALIZE: u32 = 16;
    pub const ROTATE_CONST: u32 = 17;
    pub const ROTATE_VARYING: u32 = 18;
    pub const NOISE: u32 = 19;
    pub const FRACTAL: u32 = 20;
    pub const NOISE_GRADIENT: u32 = 21;
    pub const FRACTAL_GRADIENT: u32 = 22;
    pub const HERMITE: u32 = 23;
    pub const RAMP: u32 = 24;
    pub const CURVE: u32 = 25;
    pub const WIDE_COMPONENT: u32 = 26;
    pub const WIDE_UNARY: u32 = 27;
    pub const WIDE_BINARY: u32 = 28;
    pub const WIDE_TERNARY: u32 = 29;
    pub const WIDE_DOT: u32 = 30;
    pub const WIDE_LENGTH: u32 = 31;
    pub const WIDE_SPLAT: u32 = 32;
    pub const WIDE_COMBINE: u32 = 33;
    pub const WIDE_ROTATE: u32 = 34;
    pub const WIDEN: u32 = 35;
    pub const NARROW: u32 = 36;
    pub const OUT_S: u32 = 37;
    pub const OUT_V: u32 = 38;
}

const FLAG_TILED: u32 = 1;
const FLAG_BIAS: u32 = 2;
const FLAG_SLOPE: u32 = 4;

/// The interpreter of `tape`: its shader (slot files sized from the tape, rounded up to a power
/// of two, at least 8) and the tape encoded.
pub fn generate(tape: &Tape) -> Interpreted {
    let size = |n: usize| n.max(8).next_power_of_two();
    generate_sized(
        tape,
        size(tape.scalar_slots),
        size(tape.vec3_slots),
        size(tape.wide_slots),
    )
}

fn generate_sized(tape: &Tape, scalars: usize, vec3s: usize, wides: usize) -> Interpreted {
    let mut source = String::new();
    for (_, text) in codegen::LIBRARY {
        source.push_str(text);
        source.push('\n');
    }
    let channels = tape.channels();
    let _ = writeln!(source, "const CHANNELS: u32 = {}u;", channels.max(1));
    let _ = writeln!(
        source,
        "struct Channels {{\n    c: array<f32, {}>,\n}}\n",
        channels.max(1)
    );
    let _ = writeln!(
        source,
        "const I_SCALARS: u32 = {}u;\nconst I_VEC3S: u32 = {}u;\nconst I_WIDES: u32 = {}u;",
        scalars.max(1),
        vec3s.max(1),
        wides.max(1)
    );
    source.push_str(INTERPRETER);
    source.push_str(ENTRY);
    let (program, constants) = encode(tape);
    Interpreted {
        source,
        channels,
        program,
        constants,
    }
}

/// The entry points every shader ends with (codegen's).
use super::codegen::ENTRY;

/// One instruction's words.
#[derive(Default)]
struct Word {
    opcode: u32,
    sub: u32,
    basis: u32,
    flags: u32,
    dst: u32,
    a: u32,
    b: u32,
    c: u32,
    k: u32,
    n: u32,
    t: u32,
}

struct Encoder {
    program: Vec<u32>,
    constants: Vec<f64>,
    count: u32,
}

impl Encoder {
    fn push(&mut self, w: Word) {
        self.program.extend([
            w.opcode | w.sub << 8 | w.basis << 16 | w.flags << 24,
            w.dst,
            w.a,
            w.b,
            w.c,
            w.k,
            w.n,
            w.t,
        ]);
        self.count += 1;
    }

    /// Appends constants; the index of the first.
    fn constants(&mut self, values: impl IntoIterator<Item = f64>) -> u32 {
        let k = self.constants.len() as u32;
        self.constants.extend(values);
        k
    }
}

/// An f64 holding `v` rounded to f32 (what codegen writes as an f32 literal).
fn f32_value(v: f64) -> f64 {
    f64::from(v as f32)
}

/// A period's axis as codegen writes it: 0 for none or beyond 2^52.
fn period_axis(p: u64) -> f64 {
    if p == 0 || p > 1 << 52 {
        0.0
    } else {
        p as f64
    }
}

fn unary_code(op: UnaryOp) -> u32 {
    match op {
        UnaryOp::Abs => 0,
        UnaryOp::Neg => 1,
        UnaryOp::Sin => 2,
        UnaryOp::Cos => 3,
        UnaryOp::Sqrt => 4,
        UnaryOp::Floor => 5,
        UnaryOp::Fract => 6,
        UnaryOp::Exp => 7,
        UnaryOp::Log => 8,
        UnaryOp::Log2 => 9,
        UnaryOp::Tan => 10,
        UnaryOp::Asin => 11,
        UnaryOp::Acos => 12,
        UnaryOp::Sign => 13,
        UnaryOp::Round => 14,
        UnaryOp::Trunc => 15,
    }
}

fn binary_code(op: BinaryOp) -> u32 {
    match op {
        BinaryOp::Add => 0,
        BinaryOp::Sub => 1,
        BinaryOp::Mul => 2,
        BinaryOp::Div => 3,
        BinaryOp::Min => 4,
        BinaryOp::Max => 5,
        BinaryOp::Pow => 6,
        BinaryOp::Atan2 => 7,
        BinaryOp::Mod => 8,
        BinaryOp::Step => 9,
    }
}

fn ternary_code(op: TernaryOp) -> u32 {
    match op {
        TernaryOp::Clamp => 0,
        TernaryOp::Mix => 1,
        TernaryOp::Smoothstep => 2,
        TernaryOp::Select => 3,
    }
}

/// (basis code, metric | value << 8, jitter rounded to f32) of a table.
fn basis_code(basis: &Basis) -> (u32, u32, f64) {
    match basis {
        Basis::Perlin => (0, 0, 0.0),
        Basis::Gradient => (1, 0, 0.0),
        Basis::Value(Interpolation::Linear) => (2, 0, 0.0),
        Basis::Value(Interpolation::Smooth) => (3, 0, 0.0),
        Basis::Simplex => (4, 0, 0.0),
        Basis::White => (5, 0, 0.0),
        Basis::Cellular(c) => {
            let (metric, value) = codegen::cellular_codes(c);
            (6, metric | value << 8, f32_value(c.jitter()))
        }
    }
}

/// (style code, offset, sharpness), the latter two rounded to f32.
fn style_code(style: Style) -> (u32, f64, f64) {
    let (code, offset, sharpness) = codegen::style_code(style);
    (code, f32_value(offset), f32_value(sharpness))
}

/// The program and constants of `tape` (layout: the module's documentation).
fn encode(tape: &Tape) -> (Vec<u32>, Vec<f64>) {
    use opcode::*;
    let mut e = Encoder {
        program: vec![
            0,
            tape.scalar_slots as u32,
            tape.vec3_slots as u32,
            tape.wide_slots as u32,
        ],
        constants: Vec::new(),
        count: 0,
    };
    for &(slot, value) in &tape.scalar_constants {
        let k = e.constants([f32_value(value)]);
        e.push(Word {
            opcode: CONST_S,
            dst: slot,
            k,
            ..Word::default()
        });
    }
    for &(slot, value) in &tape.vec3_constants {
        let k = e.constants(value);
        e.push(Word {
            opcode: CONST_V,
            dst: slot,
            k,
            ..Word::default()
        });
    }
    for &(slot, value) in &tape.wide_constants {
        let k = e.constants([value]);
        e.push(Word {
            opcode: CONST_D,
            dst: slot,
            k,
            ..Word::default()
        });
    }
    for instr in &tape.instrs {
        let w = instruction(tape, &mut e, instr);
        e.push(w);
    }
    for o in &tape.outputs {
        e.push(Word {
            opcode: if o.ty.channels() == 1 { OUT_S } else { OUT_V },
            dst: o.first_channel as u32,
            a: o.slot,
            ..Word::default()
        });
    }
    e.program[0] = e.count;
    if e.constants.is_empty() {
        e.constants.push(0.0);
    }
    (e.program, e.constants)
}

fn instruction(tape: &Tape, e: &mut Encoder, instr: &Instr) -> Word {
    use opcode::*;
    let op2 = |opcode, sub, dst, a, b| Word {
        opcode,
        sub,
        dst,
        a,
        b,
        ..Word::default()
    };
    match *instr {
        Instr::Position { dst } => op2(POSITION, 0, dst, 0, 0),
        Instr::Splat { dst, src } => op2(SPLAT, 0, dst, src, 0),
        Instr::Combine { dst, x, y, z } => Word {
            c: z,
            ..op2(COMBINE, 0, dst, x, y)
        },
        Instr::Component { dst, src, axis } => op2(COMPONENT, u32::from(axis % 3), dst, src, 0),
        Instr::UnaryScalar { op, dst, src } => op2(UNARY_S, unary_code(op), dst, src, 0),
        Instr::UnaryVec3 { op, dst, src } => op2(UNARY_V, unary_code(op), dst, src, 0),
        Instr::BinaryScalar { op, dst, a, b } => op2(BINARY_S, binary_code(op), dst, a, b),
        Instr::BinaryVec3 { op, dst, a, b } => op2(BINARY_V, binary_code(op), dst, a, b),
        Instr::TernaryScalar { op, dst, a, b, c } => Word {
            c,
            ..op2(TERNARY_S, ternary_code(op), dst, a, b)
        },
        Instr::TernaryVec3 { op, dst, a, b, c } => Word {
            c,
            ..op2(TERNARY_V, ternary_code(op), dst, a, b)
        },
        Instr::Dot { dst, a, b } => op2(DOT, 0, dst, a, b),
        Instr::Length { dst, src } => op2(LENGTH, 0, dst, src, 0),
        Instr::Cross { dst, a, b } => op2(CROSS, 0, dst, a, b),
        Instr::Normalize { dst, src } => op2(NORMALIZE, 0, dst, src, 0),
        Instr::RotateConst { dst, src, matrix } => {
            let m = tape.matrices[matrix as usize];
            let k = e.constants(m.into_iter().flatten());
            Word {
                k,
                ..op2(ROTATE_CONST, 0, dst, src, 0)
            }
        }
        Instr::RotateVarying {
            dst,
            src,
            degrees,
            axis,
        } => {
            let k = e.constants(tape.axes[axis as usize]);
            Word {
                k,
                ..op2(ROTATE_VARYING, 0, dst, src, degrees)
            }
        }
        Instr::Noise { dst, src, table } => noise(tape, e, NOISE, dst, src, table),
        Instr::NoiseGradient { dst, src, table } => noise(tape, e, NOISE_GRADIENT, dst, src, table),
        Instr::Fractal {
            dst,
            src,
            table,
            octaves,
            style,
            bias,
        } => fractal(tape, e, FRACTAL, dst, src, table, octaves, style, bias),
        Instr::FractalGradient {
            dst,
            src,
            table,
            octaves,
            style,
        } => fractal(
            tape,
            e,
            FRACTAL_GRADIENT,
            dst,
            src,
            table,
            octaves,
            style,
            0.0,
        ),
        Instr::Hermite { dst, src, spline } => {
            let h = tape.hermites[spline as usize];
            let k = e.constants([h.p0, h.p1, h.m0, h.m1].map(f32_value));
            Word {
                k,
                ..op2(HERMITE, 0, dst, src, 0)
            }
        }
        Instr::Ramp { dst, src, ramp } => spline(e, RAMP, dst, src, &tape.ramps[ramp as usize]),
        Instr::Curve { dst, src, curve } => {
            spline(e, CURVE, dst, src, &tape.curves[curve as usize])
        }
        Instr::Wide(w) => match w {
            Wide::Component { dst, src, axis } => {
                op2(WIDE_COMPONENT, u32::from(axis % 3), dst, src, 0)
            }
            Wide::Unary { op, dst, src } => op2(WIDE_UNARY, unary_code(op), dst, src, 0),
            Wide::Binary { op, dst, a, b } => op2(WIDE_BINARY, binary_code(op), dst, a, b),
            Wide::Ternary { op, dst, a, b, c } => Word {
                c,
                ..op2(WIDE_TERNARY, ternary_code(op), dst, a, b)
            },
            Wide::Dot { dst, a, b } => op2(WIDE_DOT, 0, dst, a, b),
            Wide::Length { dst, src } => op2(WIDE_LENGTH, 0, dst, src, 0),
            Wide::Splat { dst, src } => op2(WIDE_SPLAT, 0, dst, src, 0),
            Wide::Combine { dst, x, y, z } => Word {
                c: z,
                ..op2(WIDE_COMBINE, 0, dst, x, y)
            },
            Wide::Rotate {
                dst,
                src,
                degrees,
                axis,
            } => {
                let k = e.constants(tape.axes[axis as usize]);
                Word {
                    k,
                    ..op2(WIDE_ROTATE, 0, dst, src, degrees)
                }
            }
            Wide::Widen { dst, src } => op2(WIDEN, 0, dst, src, 0),
            Wide::Narrow { dst, src } => op2(NARROW, 0, dst, src, 0),
        },
    }
}

/// A noise sample or gradient: the table's basis, its period (codegen's `key.period`).
fn noise(tape: &Tape, e: &mut Encoder, opcode: u32, dst: u32, src: u32, table: u32) -> Word {
    let key = &tape.tables[table as usize].0;
    let (basis, cell, jitter) = basis_code(&key.basis);
    let period = key.period.unwrap_or([0; 3]).map(period_axis);
    let k = e.constants([jitter, period[0], period[1], period[2]]);
    Word {
        opcode,
        basis,
        flags: if key.period.is_some() { FLAG_TILED } else { 0 },
        dst,
        a: src,
        c: cell,
        k,
        t: table * TABLE_WORDS as u32,
        ..Word::default()
    }
}

/// A fractal sum or its gradient: the octave schedule's frequencies, amplitudes (f32 for the
/// sum, f64 for the gradient, as codegen) and periods (the schedule's, as codegen).
#[allow(clippy::too_many_arguments)]
fn fractal(
    tape: &Tape,
    e: &mut Encoder,
    opcode: u32,
    dst: u32,
    src: u32,
    table: u32,
    octaves: u32,
    style: Style,
    bias: f64,
) -> Word {
    let key = &tape.tables[table as usize].0;
    let schedule = &tape.octaves[octaves as usize];
    let (basis, cell, jitter) = basis_code(&key.basis);
    let (sub, offset, sharpness) = style_code(style);
    let k = e.constants([jitter, f32_value(bias), offset, sharpness]);
    let n = schedule.frequencies.len();
    for o in 0..n {
        let amplitude = schedule.amplitudes[o];
        let amplitude = if opcode == opcode::FRACTAL {
            f32_value(amplitude)
        } else {
            amplitude
        };
        e.constants([schedule.frequencies[o], amplitude]);
        if let Some(periods) = &schedule.periods {
            e.constants(periods[o].map(period_axis));
        }
    }
    let mut flags = 0;
    if schedule.periods.is_some() {
        flags |= FLAG_TILED;
    }
    if bias != 0.0 {
        flags |= FLAG_BIAS;
    }
    Word {
        opcode,
        sub,
        basis,
        flags,
        dst,
        a: src,
        c: cell,
        k,
        n: n as u32,
        t: table * TABLE_WORDS as u32,
        ..Word::default()
    }
}

/// A ramp or curve: per knot [knot, value…, inverse width] (codegen's `spline_function`).
fn spline<const N: usize>(
    e: &mut Encoder,
    opcode: u32,
    dst: u32,
    src: u32,
    spline: &Spline<N>,
) -> Word {
    let (knots, values) = (spline.knots(), spline.values());
    let k = e.constants.len() as u32;
    for i in 0..knots.len() {
        let inverse = if i + 1 < knots.len() && knots[i + 1] > knots[i] {
            1.0 / (knots[i + 1] - knots[i])
        } else {
            0.0
        };
        e.constants([knots[i]]);
        e.constants(values[i]);
        e.constants([inverse]);
    }
    let sub = match spline.interpolation() {
        SplineInterpolation::Linear => 0,
        SplineInterpolation::Smooth => 1,
        SplineInterpolation::Constant => 2,
    };
    Word {
        opcode,
        sub,
        flags: if spline.is_slope() { FLAG_SLOPE } else { 0 },
        dst,
        a: src,
        k,
        n: knots.len() as u32,
        ..Word::default()
    }
}

/// The interpreter (after `CHANNELS`, `Channels` and the `I_*` slot file sizes).
const INTERPRETER: &str = include_str!("wgsl/interpreter.wgsl");

#[cfg(all(test, feature = "gpu"))]
mod tests {
    use super::*;
    use crate::{CheckOptions, CompileOptions, Extent, SourceFile};

    fn tape(text: &str, options: &CompileOptions) -> Tape {
        let graph = crate::check(SourceFile::new("test.ron", text), &CheckOptions::default())
            .unwrap_or_else(|e| panic!("{e:?}"));
        crate::compile(&graph, options).unwrap_or_else(|e| panic!("{e:?}"))
    }

    fn wide() -> CompileOptions {
        CompileOptions {
            extent: Some(Extent::new([-1e6; 3], [1e6; 3])),
            ..Default::default()
        }
    }

    /// Validates the interpreter of `tape` with naga; the opcodes it uses.
    fn validated(name: &str, tape: &Tape) -> Vec<u32> {
        let interpreted = generate(tape);
        if let Ok(dir) = std::env::var("TEXGRAPH_INTERPRETER_DUMP") {
            let _ = std::fs::write(format!("{dir}/{name}.wgsl"), &interpreted.source);
        }
        if let Err(e) = crate::gpu::validate(&interpreted.source) {
            panic!("{name}: {e}");
        }
        assert_eq!(interpreted.channels, tape.channels());
        let count = interpreted.program[0] as usize;
        assert_eq!(
            interpreted.program.len(),
            HEADER_WORDS + count * INSTR_WORDS
        );
        (0..count)
            .map(|i| interpreted.program[HEADER_WORDS + i * INSTR_WORDS] & 0xff)
            .collect()
    }

    const TILING_MARBLE: &str = include_str!("../../graphs/tiling_marble.ron");

    /// A fractal, a ramp, a tiled noise (the fractal's periods) and promoted instructions.
    #[test]
    fn tiling_marble_validates() {
        let tape = tape(TILING_MARBLE, &wide());
        assert!(tape.wide_instructions() > 0, "{tape}");
        let ops = validated("tiling_marble", &tape);
        for op in [opcode::FRACTAL, opcode::RAMP, opcode::OUT_V, opcode::OUT_S] {
            assert!(ops.contains(&op), "{op} in {ops:?}\n{tape}");
        }
        let tape = tape_plain(TILING_MARBLE);
        validated("tiling_marble_plain", &tape);
    }

    fn tape_plain(text: &str) -> Tape {
        tape(text, &CompileOptions::default())
    }

    /// Most other instructions: tiled cellular noise, gradients, curve, hermite, rotations,
    /// ridged, vec3 arithmetic.
    #[test]
    fn many_instructions_validate() {
        let text = r#"Graph(
    nodes: {
        "p":      Position,
        "q":      Rotate(input: "p", axis: (0.0, 1.0, 0.0), degrees: 30.0),
        "twist":  Rotate(input: "q", axis: (0.0, 0.0, 1.0), degrees: Mul(10.0, "p.z")),
        "cells":  Cellular(input: "twist", seed: 3, jitter: 0.8, metric: Manhattan, value: F2MinusF1, period: 8),
        "n":      Noise(input: "p", basis: Simplex, seed: 1, period: 6),
        "r":      Ridged(input: "p", basis: Value, seed: 2, octaves: 4.0),
        "g":      Gradient(of: Fbm(input: "p", basis: Perlin, seed: 5, octaves: 3.0)),
        "gn":     Gradient(of: Noise(input: "p", basis: Gradient, seed: 7)),
        "c":      Cross("g", "gn"),
        "m":      Normalize(Add("c", "p")),
        "h":      Hermite(input: Abs("n"), p0: 0.0, p1: 1.0, m0: 0.5, m1: 2.0),
        "k":      Curve(input: "cells", points: [(0.0, 0.0), (0.3, 0.8), (1.0, 1.0)], interpolation: Smooth),
        "s":      Smoothstep(0.2, 0.8, Add("h", Dot("m", "p"))),
        "w":      Mix(Sin("p"), Floor("q"), 0.25),
    },
    outputs: { "k": "k", "s": "s", "r": "r", "w": "w", "m": "m", "len": Length("twist") },
)"#;
        let plain = tape_plain(text);
        let ops = validated("many", &plain);
        for op in [
            opcode::NOISE,
            opcode::NOISE_GRADIENT,
            opcode::FRACTAL,
            opcode::FRACTAL_GRADIENT,
            opcode::HERMITE,
            opcode::CURVE,
            opcode::ROTATE_CONST,
            opcode::ROTATE_VARYING,
            opcode::CROSS,
            opcode::NORMALIZE,
        ] {
            assert!(ops.contains(&op), "{op} in {ops:?}\n{plain}");
        }
        let promoted = tape(text, &wide());
        assert!(promoted.wide_instructions() > 0, "{promoted}");
        validated("many_wide", &promoted);
    }

    /// Every graph of `graphs/` (and its library), plain and promoted.
    #[test]
    fn every_graph_validates() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs");
        let mut files = Vec::new();
        for dir in [root.clone(), root.join("library")] {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.extension().is_some_and(|e| e == "ron") {
                    files.push(path);
                }
            }
        }
        files.sort();
        let mut sources = std::collections::HashSet::new();
        for path in &files {
            for options in [CompileOptions::default(), wide()] {
                let Ok((_, tape)) = crate::load_tape(path, &CheckOptions::default(), &options)
                else {
                    continue;
                };
                let interpreted = generate(&tape);
                if sources.insert(interpreted.source.clone()) {
                    crate::gpu::validate(&interpreted.source)
                        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                }
            }
        }
        assert!(files.len() > 10);
    }
}
