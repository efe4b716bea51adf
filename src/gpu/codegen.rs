//! WGSL generated from a tape: one straight-line function per tape (`fn tape(p, h) -> Channels`:
//! the point and its sample spacing, for level of detail per point; 0 for none),
//! every slot a local variable, every constant a literal, every fractal's octave loop unrolled
//! with its frequencies, amplitudes and periods written in, so the shader compiler sees exactly
//! the arithmetic of this graph. The per-lane operations and the noise bases are the WGSL
//! library in `wgsl/` (one definition each, mirroring `ops.rs` and `noise/`); the entry points
//! `bake` (positions from the grid, written in the bake's window layout) and `points`
//! (positions from a buffer, written channel-planar as `Tape::eval_batch`) wrap the function.
//!
//! Precision: scalar slots are f32 (the CPU's fast path), vec3 slots and promoted ("wide")
//! scalars f64, as on the CPU, so positions and lattice cells are exact; see `wgsl/math.wgsl`
//! for the transcendentals.

use super::error::GpuError;
use crate::graph::TableKey;
use crate::noise::{Basis, CellularValue, Interpolation, Metric, Octaves, Style};
use crate::ops::{BinaryOp, Spline, SplineInterpolation, TernaryOp, UnaryOp};
use crate::tape::{Instr, Prec, Tape};
use std::fmt::Write;

/// The WGSL library, in the order the generated shader concatenates it.
pub const LIBRARY: [(&str, &str); 7] = [
    ("common.wgsl", include_str!("wgsl/common.wgsl")),
    ("math.wgsl", include_str!("wgsl/math.wgsl")),
    ("cell.wgsl", include_str!("wgsl/cell.wgsl")),
    ("lattice.wgsl", include_str!("wgsl/lattice.wgsl")),
    ("lattice_grad.wgsl", include_str!("wgsl/lattice_grad.wgsl")),
    ("simplex.wgsl", include_str!("wgsl/simplex.wgsl")),
    ("cellular.wgsl", include_str!("wgsl/cellular.wgsl")),
];

/// The bindings every generated shader's entry points share (`wgsl/bindings.wgsl`).
pub(crate) const BINDINGS: &str = include_str!("wgsl/bindings.wgsl");

/// The entry points every generated point shader ends with (`wgsl/entry.wgsl`).
pub(crate) const ENTRY_POINTS: &str = include_str!("wgsl/entry.wgsl");

/// Words of one noise table in the tables buffer (`T_WORDS` in common.wgsl).
pub const TABLE_WORDS: usize = 1544;

/// A tape's shader: its WGSL source and the channels each point produces.
#[derive(Clone, Debug)]
pub struct Shader {
    pub source: String,
    pub channels: usize,
    /// The filtered form's data (`fdata`, binding 4: its chain shapes and samplers); empty
    /// for the point form, which has no such binding.
    pub data: Vec<f64>,
}

/// The WGSL of `tape`: the library (with the bases' f64 forms when the tape has promoted
/// noise), the tape's function and the entry points. Never refused today; `Result` for the
/// tapes a later instruction cannot express.
pub fn generate(tape: &Tape) -> Result<Shader, GpuError> {
    let mut source = String::new();
    for (_, text) in LIBRARY {
        source.push_str(text);
        source.push('\n');
    }
    if tape.instrs.iter().any(|i| {
        i.prec() == Prec::Wide
            && matches!(
                i,
                Instr::Noise { .. }
                    | Instr::Fractal { .. }
                    | Instr::NoiseGradient { .. }
                    | Instr::FractalGradient { .. }
            )
    }) {
        source.push_str(super::widen::declarations());
        source.push('\n');
    }
    source.push_str(&tape_part(tape, &ConstantExprs::default(), "dispatch.one"));
    source.push_str(BINDINGS);
    source.push_str(ENTRY_POINTS);
    Ok(Shader {
        source,
        channels: tape.channels(),
        data: Vec::new(),
    })
}

/// The tape's own part of its shader, without the library, bindings or entry points: its
/// spline functions, `CHANNELS`, `struct Channels` and `fn tape(p, h)`, reading the noise
/// tables through `tables` and its constants times `one`, the WGSL of a 1.0 (the GPU path's
/// `dispatch.one`, which the driver cannot fold; the shader export's literal). The shader
/// export (`shader/`) builds its source on this.
pub(crate) fn tape_part(tape: &Tape, constants: &ConstantExprs, one: &str) -> String {
    let mut source = String::new();
    for (k, ramp) in tape.ramps.iter().enumerate() {
        spline_function(&mut source, &format!("ramp{k}"), ramp);
    }
    for (k, curve) in tape.curves.iter().enumerate() {
        spline_function(&mut source, &format!("curve{k}"), curve);
    }
    let channels = tape.channels();
    let _ = writeln!(source, "const CHANNELS: u32 = {}u;", channels.max(1));
    let _ = writeln!(
        source,
        "struct Channels {{\n    c: array<f32, {}>,\n}}\n",
        channels.max(1)
    );
    source.push_str(&tape_function(tape, constants, one));
    source
}

/// Expressions that replace constant slots' literals in `fn tape` (the shader export's
/// uniforms: a param's slot reads its uniform field); an f32 expression per scalar slot, per
/// vec3 slot one per component (`None`: the constant's own literal).
#[derive(Clone, Debug, Default)]
pub(crate) struct ConstantExprs {
    pub scalar: std::collections::HashMap<u32, String>,
    pub vec3: std::collections::HashMap<u32, [Option<String>; 3]>,
}

/// `fn tape(p: vec3<f64>) -> Channels`: the instructions in order over local slot variables.
fn tape_function(tape: &Tape, constants: &ConstantExprs, one: &str) -> String {
    let mut body = String::new();
    let w = &mut body;
    let _ = writeln!(w, "fn tape(p: vec3<f64>, h: f64) -> Channels {{");
    for k in 0..tape.scalar_slots {
        let _ = writeln!(w, "    var s{k}: f32 = 0.0;");
    }
    for k in 0..tape.vec3_slots {
        let _ = writeln!(w, "    var v{k}: vec3<f64> = vec3<f64>(0.0lf);");
    }
    for k in 0..tape.wide_slots {
        let _ = writeln!(w, "    var d{k}: f64 = 0.0lf;");
    }
    // Constants times `one` (the GPU path's `dispatch.one`, 1.0 at run time, see `entry.wgsl`):
    // exactly the constant (NaN, infinities and signed zeros included), and opaque to the
    // driver's folding.
    let _ = writeln!(w, "    let one = {one};");
    let _ = writeln!(w, "    let one_d = f64(one);");
    for &(slot, value) in &tape.scalar_constants {
        match constants.scalar.get(&slot) {
            Some(expr) => writeln!(w, "    s{slot} = {expr};"),
            None => writeln!(w, "    s{slot} = {} * one;", f32_literal(value as f32)),
        }
        .ok();
    }
    for &(slot, value) in &tape.vec3_constants {
        match constants.vec3.get(&slot) {
            Some(exprs) => {
                let c: [String; 3] = std::array::from_fn(|a| match &exprs[a] {
                    Some(expr) => format!("f64({expr})"),
                    None => format!("{} * one_d", f64_literal(value[a])),
                });
                writeln!(w, "    v{slot} = vec3<f64>({}, {}, {});", c[0], c[1], c[2])
            }
            None => writeln!(w, "    v{slot} = {} * one_d;", vec3_literal(value)),
        }
        .ok();
    }
    for &(slot, value) in &tape.wide_constants {
        let _ = writeln!(w, "    d{slot} = {} * one_d;", f64_literal(value));
    }
    for instr in &tape.instrs {
        let line = instruction(tape, instr);
        let _ = writeln!(w, "    {line}");
    }
    let _ = writeln!(w, "    var r: Channels;");
    for o in &tape.outputs {
        let c = o.first_channel;
        if o.ty.channels() == 1 {
            let _ = writeln!(w, "    r.c[{c}] = s{};", o.slot);
        } else {
            for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                let _ = writeln!(w, "    r.c[{}] = f32(v{}.{axis});", c + i, o.slot);
            }
        }
    }
    let _ = writeln!(w, "    return r;\n}}\n");
    body
}

/// How an instruction's scalars are written in WGSL for its precision: `s` slots in f32 (the
/// `s_` functions), or `d` slots in f64 (the `d_` functions) for a promoted instruction.
#[derive(Clone, Copy)]
struct Scalars(Prec);

impl Scalars {
    /// Scalar slot `slot`.
    fn slot(self, slot: u32) -> String {
        format!("{}{slot}", self.0.file().prefix())
    }

    /// Scalar slot `slot` as an f64 expression.
    fn as_f64(self, slot: u32) -> String {
        match self.0 {
            Prec::Lane => format!("f64(s{slot})"),
            Prec::Wide => format!("d{slot}"),
        }
    }

    /// An f64 expression as a scalar of this precision.
    fn of_f64(self, expr: &str) -> String {
        match self.0 {
            Prec::Lane => format!("f32({expr})"),
            Prec::Wide => expr.to_string(),
        }
    }

    /// The prefix of the library's scalar functions.
    fn functions(self) -> &'static str {
        match self.0 {
            Prec::Lane => "s_",
            Prec::Wide => "d_",
        }
    }

    fn unary(self, op: UnaryOp, x: &str) -> String {
        match self.0 {
            Prec::Lane => unary_f32(op, x),
            Prec::Wide => unary_f64(op, x),
        }
    }
}

/// One instruction as WGSL statements.
fn instruction(tape: &Tape, instr: &Instr) -> String {
    let sc = Scalars(instr.prec());
    let s = |slot: u32| sc.slot(slot);
    match *instr {
        Instr::Position { dst } => format!("v{dst} = p;"),
        Instr::Splat { dst, src, .. } => format!("v{dst} = vec3<f64>({});", sc.as_f64(src)),
        Instr::Combine { dst, x, y, z, .. } => {
            let [x, y, z] = [x, y, z].map(|c| sc.as_f64(c));
            format!("v{dst} = vec3<f64>({x}, {y}, {z});")
        }
        Instr::Component { dst, src, axis, .. } => {
            let c = format!("v{src}.{}", axis_name(axis));
            format!("{} = {};", s(dst), sc.of_f64(&c))
        }
        Instr::UnaryScalar { op, dst, src, .. } => {
            format!("{} = {};", s(dst), sc.unary(op, &s(src)))
        }
        Instr::UnaryVec3 { op, dst, src } => {
            format!(
                "v{dst} = {};",
                per_component(|c| unary_f64(op, &format!("v{src}.{c}")))
            )
        }
        Instr::BinaryScalar { op, dst, a, b, .. } => {
            let value = binary(sc.functions(), op, &s(a), &s(b));
            format!("{} = {value};", s(dst))
        }
        Instr::BinaryVec3 { op, dst, a, b } => format!(
            "v{dst} = {};",
            per_component(|c| binary("d_", op, &format!("v{a}.{c}"), &format!("v{b}.{c}")))
        ),
        Instr::TernaryScalar {
            op, dst, a, b, c, ..
        } => {
            let f = format!("{}{}", sc.functions(), ternary_name(op));
            format!("{} = {f}({}, {}, {});", s(dst), s(a), s(b), s(c))
        }
        Instr::TernaryVec3 { op, dst, a, b, c } => format!(
            "v{dst} = {};",
            per_component(|k| format!("d_{}(v{a}.{k}, v{b}.{k}, v{c}.{k})", ternary_name(op)))
        ),
        Instr::Dot { dst, a, b, .. } => {
            format!("{} = {};", s(dst), sc.of_f64(&format!("v_dot(v{a}, v{b})")))
        }
        Instr::Length { dst, src, .. } => {
            format!("{} = {};", s(dst), sc.of_f64(&format!("v_length(v{src})")))
        }
        Instr::Cross { dst, a, b } => format!("v{dst} = v_cross(v{a}, v{b});"),
        Instr::Normalize { dst, src } => format!("v{dst} = v_normalize(v{src});"),
        Instr::RotateConst { dst, src, matrix } => {
            let m = tape.matrices[matrix as usize];
            format!(
                "v{dst} = v_matrix({}, {}, {}, v{src});",
                vec3_literal(m[0]),
                vec3_literal(m[1]),
                vec3_literal(m[2])
            )
        }
        Instr::RotateVarying {
            dst,
            src,
            degrees,
            axis,
            ..
        } => format!(
            "v{dst} = v_rotate({}, {}, v{src});",
            vec3_literal(tape.axes[axis as usize]),
            sc.as_f64(degrees)
        ),
        // Promoted noise: the bases' f64 forms (`widen.rs`), as the CPU runs its f64 kernels.
        Instr::Noise {
            prec,
            dst,
            src,
            table,
        } => {
            let key = &tape.tables[table as usize].0;
            let kernel = Kernel::value(prec);
            let call = sample_call(table, key, key.period, &format!("v{src}"), kernel);
            format!("{} = {call};", s(dst))
        }
        Instr::NoiseGradient {
            prec,
            dst,
            src,
            table,
        } => {
            let key = &tape.tables[table as usize].0;
            let kernel = Kernel::gradient(prec);
            let call = sample_call(table, key, key.period, &format!("v{src}"), kernel);
            match prec {
                Prec::Lane => format!("v{dst} = vec3<f64>(({call}).xyz);"),
                Prec::Wide => format!("v{dst} = ({call}).xyz;"),
            }
        }
        Instr::Fractal {
            prec,
            dst,
            src,
            table,
            octaves,
            style,
            bias,
        } => fractal(
            tape,
            (prec, dst),
            src,
            FractalInstr {
                table,
                octaves,
                style,
                bias,
            },
        ),
        Instr::FractalGradient {
            prec,
            dst,
            src,
            table,
            octaves,
            style,
        } => fractal_gradient(tape, dst, src, table, octaves, style, prec),
        Instr::Hermite { dst, src, spline } => {
            let h = tape.hermites[spline as usize];
            format!(
                "s{dst} = s_hermite(s{src}, {}, {}, {}, {});",
                f32_literal(h.p0 as f32),
                f32_literal(h.p1 as f32),
                f32_literal(h.m0 as f32),
                f32_literal(h.m1 as f32)
            )
        }
        Instr::Ramp { dst, src, ramp } => format!("v{dst} = ramp{ramp}(f64(s{src}));"),
        Instr::Curve { dst, src, curve } => format!("s{dst} = f32(curve{curve}(f64(s{src})));"),
        Instr::Widen { dst, src } => format!("d{dst} = f64(s{src});"),
        Instr::Narrow { dst, src } => format!("s{dst} = f32(d{src});"),
    }
}

/// The octave loop of a fractal sum, unrolled: each octave's point `p · f` in f64, its sample
/// (at its own period when tiled), the style's accumulation in f32, or f64 for a promoted sum
/// (`noise/fractal.rs` `Shaper::add`), NaN made canonical, then the level-of-detail bias. Where the tape has a
/// `LaneLod` for the schedule, the octaves and bias follow the point's spacing `h`
/// ([`lane_lod`]); without a spacing they are the schedule's.
fn fractal(tape: &Tape, (prec, dst): (Prec, u32), src: u32, instr: FractalInstr) -> String {
    let FractalInstr {
        table,
        octaves,
        style,
        bias,
    } = instr;
    // A promoted sum (a `d` slot) runs in f64 throughout, as `fractal_into::<f64>` does.
    let wide = prec == Prec::Wide;
    let dst = Scalars(prec).slot(dst);
    let (ty, p, real) = if wide {
        ("f64", "d", f64_literal as fn(f64) -> String)
    } else {
        (
            "f32",
            "s",
            (|v: f64| f32_literal(v as f32)) as fn(f64) -> String,
        )
    };
    let kernel = if wide { Kernel::Wide } else { Kernel::Value };
    let key = &tape.tables[table as usize].0;
    let schedule = &tape.octaves[octaves as usize];
    let mut w = format!("{{\n        var sum: {ty} = 0.0;\n        var weight: {ty} = 1.0;\n");
    let lod = lane_lod(tape, octaves, &mut w);
    for k in 0..schedule.frequencies.len() {
        let (point, period) = octave_point(schedule, k, src);
        let n = sample_call(table, key, period, &point, kernel);
        // The amplitude in the sum's type (`S::from_f64`): a literal, or per point.
        let a = match lod {
            Some(_) => format!("{ty}({})", octave_amplitude(schedule, k, lod.as_ref())),
            None => real(schedule.amplitudes[k]),
        };
        let _ = writeln!(w, "        if ({} < kept) {{", f64_literal(k as f64));
        let _ = writeln!(w, "        let a{k} = {a};\n        let n{k} = {n};");
        let _ = match style {
            Style::Fbm => writeln!(w, "        sum = sum + a{k} * n{k};"),
            Style::Turbulence => writeln!(w, "        sum = sum + a{k} * abs(n{k});"),
            Style::Billow => writeln!(w, "        sum = sum + a{k} * (2.0 * abs(n{k}) - 1.0);"),
            Style::Ridged { offset, sharpness } => writeln!(
                w,
                "        let r{k} = {p}_pow({p}_max({} - abs(n{k}), 0.0), {}) * weight;\n        \
                 sum = sum + a{k} * r{k};\n        weight = {p}_min({p}_max(2.0 * r{k}, 0.0), 1.0);",
                real(offset),
                real(sharpness)
            ),
        };
        let _ = writeln!(w, "        }}");
    }
    if wide {
        let _ = writeln!(w, "        if (is_nan_d(sum)) {{ sum = nan_d(); }}");
    } else {
        let _ = writeln!(w, "        if (is_nan(sum)) {{ sum = nan_f32(); }}");
    }
    match lod {
        Some(terms) => {
            // lod.rs `LaneLod::biases`: the dropped octaves' mean where the point drops one,
            // else the schedule's own bias.
            let _ = writeln!(w, "        var bias = {};", f64_literal(bias));
            let _ = writeln!(
                w,
                "        if (kept < {}) {{\n            bias = 0.0lf;",
                f64_literal(terms.kept)
            );
            for (n, &gain) in terms.gains.iter().enumerate() {
                let _ = writeln!(
                    w,
                    "            bias = bias + lod_share({}, {}, kept, {}, {});",
                    f64_literal(terms.octaves),
                    f64_literal(n as f64),
                    f64_literal(gain),
                    f64_literal(terms.expected)
                );
            }
            let _ = writeln!(w, "        }}");
            let _ = writeln!(
                w,
                "        if (bias != 0.0lf) {{ sum = sum + {ty}(bias); }}"
            );
        }
        None if bias != 0.0 => {
            let _ = writeln!(w, "        sum = sum + {};", real(bias));
        }
        None => {}
    }
    let _ = write!(w, "        {dst} = sum;\n        _ = weight;\n    }}");
    w
}

/// A fractal sum's operands (`Instr::Fractal` without its slots).
#[derive(Clone, Copy)]
struct FractalInstr {
    table: u32,
    octaves: u32,
    style: Style,
    bias: f64,
}

/// Declares `kept` (f64): the octaves the point keeps. With the schedule's `LaneLod`, from the
/// spacing `h` (`lod_kept`, the formulas of lod.rs); else all of the schedule's.
fn lane_lod<'t>(
    tape: &'t Tape,
    octaves: u32,
    w: &mut String,
) -> Option<crate::lod::LaneLodTerms<'t>> {
    let schedule = &tape.octaves[octaves as usize];
    match &tape.lane_lods[octaves as usize] {
        Some(lod) => {
            let terms = lod.terms();
            let _ = writeln!(
                w,
                "        let kept = lod_kept(h, {}, {}, {}, {}, {}, {});",
                f64_literal(terms.fine),
                f64_literal(terms.kept),
                f64_literal(terms.octaves),
                f64_literal(terms.first_octave as f64),
                f64_literal(terms.stretch),
                f64_literal(terms.ln_lacunarity)
            );
            Some(terms)
        }
        None => {
            let _ = writeln!(
                w,
                "        let kept = {};",
                f64_literal(schedule.len() as f64)
            );
            None
        }
    }
}

/// Octave `k`'s amplitude (f64 WGSL): the schedule's, or with level of detail per point its
/// unfaded power faded by the point's `kept` (`lod_amplitude`, `LaneOctaves::lane`: the
/// schedule's own amplitude where `kept` is the schedule's).
fn octave_amplitude(
    schedule: &Octaves,
    k: usize,
    lod: Option<&crate::lod::LaneLodTerms>,
) -> String {
    match lod {
        Some(terms) => format!(
            "lod_amplitude(kept, {}, {})",
            f64_literal(terms.powers[k]),
            f64_literal(k as f64)
        ),
        None => f64_literal(schedule.amplitudes[k]),
    }
}

/// The gradient of a fractal sum, unrolled as [`fractal`] (`wgsl/lattice_grad.wgsl`'s
/// `GradShaper`, mirroring `noise/derivative.rs`); the dropped octaves' mean adds no slope.
#[allow(clippy::too_many_arguments)]
fn fractal_gradient(
    tape: &Tape,
    dst: u32,
    src: u32,
    table: u32,
    octaves: u32,
    style: Style,
    prec: Prec,
) -> String {
    let wide = prec == Prec::Wide;
    let key = &tape.tables[table as usize].0;
    let schedule = &tape.octaves[octaves as usize];
    let (code, offset, sharpness) = style_code(style);
    // A promoted gradient: the `_d` forms, offset and sharpness in f64.
    let (d, kernel, real) = if wide {
        ("_d", Kernel::WideGradient, f64_literal as fn(f64) -> String)
    } else {
        (
            "",
            Kernel::Gradient,
            (|v: f64| f32_literal(v as f32)) as fn(f64) -> String,
        )
    };
    let mut w = format!("{{\n        var g = gshaper_start{d}();\n");
    let lod = lane_lod(tape, octaves, &mut w);
    for k in 0..schedule.frequencies.len() {
        let (point, period) = octave_point(schedule, k, src);
        let call = sample_call(table, key, period, &point, kernel);
        let _ = writeln!(
            w,
            "        if ({} < kept) {{\n        let n{k} = {call};\n        g = gshaper_add_f64{d}(g, {code}u, n{k}.w, n{k}.xyz, {}, {}, {}, {});\n        }}",
            f64_literal(k as f64),
            octave_amplitude(schedule, k, lod.as_ref()),
            f64_literal(schedule.frequencies[k]),
            real(offset),
            real(sharpness)
        );
    }
    let _ = write!(
        w,
        "        v{dst} = vec3<f64>(gshaper_gradient{d}(g));\n    }}"
    );
    w
}

/// A fractal style's code in the WGSL library (`gshaper_add`'s `style`)
/// and, for Ridged, its offset and sharpness (0 otherwise).
pub(crate) fn style_code(style: Style) -> (u32, f64, f64) {
    match style {
        Style::Fbm => (0, 0.0, 0.0),
        Style::Turbulence => (1, 0.0, 0.0),
        Style::Billow => (2, 0.0, 0.0),
        Style::Ridged { offset, sharpness } => (3, offset, sharpness),
    }
}

/// A cellular basis' metric and value codes (`CELL_METRIC_*`, `CELL_VALUE_*` in
/// `wgsl/cellular.wgsl`).
pub(crate) fn cellular_codes(c: &crate::noise::Cellular) -> (u32, u32) {
    let metric = match c.metric {
        Metric::Euclidean => 0,
        Metric::Manhattan => 1,
        Metric::Chebyshev => 2,
    };
    let value = match c.value {
        CellularValue::F1 => 0,
        CellularValue::F2 => 1,
        CellularValue::F2MinusF1 => 2,
        CellularValue::CellValue => 3,
        CellularValue::Edge => 4,
    };
    (metric, value)
}

/// Octave `k`'s point (`v{src} * f` in f64) and period.
fn octave_point(schedule: &Octaves, k: usize, src: u32) -> (String, Option<[u64; 3]>) {
    let f = schedule.frequencies[k];
    let period = schedule.periods.as_ref().map(|p| p[k]);
    (format!("v{src} * {}", f64_literal(f)), period)
}

/// The call of a basis' sample (`*_sample`) or gradient (`*_grad`, a vec4: gradient, value),
/// tiled when there is a period.
pub(super) fn sample_call(
    table: u32,
    key: &TableKey,
    period: Option<[u64; 3]>,
    point: &str,
    kernel: Kernel,
) -> String {
    let offset = table as usize * TABLE_WORDS;
    let mut args = format!("{offset}u, {point}");
    if let Some(period) = period {
        let [x, y, z] = period.map(|p| f64_literal(period_axis(p)));
        let _ = write!(args, ", vec3<f64>({x}, {y}, {z})");
    }
    if let Basis::Cellular(c) = key.basis {
        let (metric, value) = cellular_codes(&c);
        // The jitter is a multiple of 1/256 (`Cellular::new`): the same in f32 and f64.
        let jitter = match kernel {
            Kernel::Wide | Kernel::WideGradient => f64_literal(c.jitter()),
            Kernel::Value | Kernel::Gradient => f32_literal(c.jitter() as f32),
        };
        let _ = write!(args, ", {metric}u, {value}u, {jitter}");
    }
    format!("{}({args})", sample_function(key, period.is_some(), kernel))
}

/// A period's axis as the kernels take it: periods beyond 2^52 are no periods for f64
/// coordinates (noise/period.rs), 0 = none.
pub(super) fn period_axis(p: u64) -> f64 {
    if p == 0 || p > 1 << 52 {
        0.0
    } else {
        p as f64
    }
}

/// The library function [`sample_call`] calls: the basis, `_sample` or `_grad`, `_periodic`
/// when tiled, `_d` in f64. Its arguments: the table's offset, the point, the period when
/// tiled, a cellular basis' metric and value codes and jitter.
pub(super) fn sample_function(key: &TableKey, periodic: bool, kernel: Kernel) -> String {
    let name = match key.basis {
        Basis::Perlin => "perlin",
        Basis::Gradient => "gradient",
        Basis::Value(Interpolation::Linear) => "value_linear",
        Basis::Value(Interpolation::Smooth) => "value_smooth",
        Basis::Simplex => "simplex",
        Basis::White => "white",
        Basis::Cellular(_) => "cellular",
    };
    let kind = match kernel {
        Kernel::Gradient | Kernel::WideGradient => "grad",
        Kernel::Value | Kernel::Wide => "sample",
    };
    let suffix = if periodic { "_periodic" } else { "" };
    let wide = match kernel {
        Kernel::Wide | Kernel::WideGradient => "_d",
        Kernel::Value | Kernel::Gradient => "",
    };
    format!("{name}_{kind}{suffix}{wide}")
}

/// Which form of a basis a call uses.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Kernel {
    /// The value in f32.
    Value,
    /// The value in f64 (`widen.rs`), for promoted noise.
    Wide,
    /// (gradient, value) in f32.
    Gradient,
    /// (gradient, value) in f64, for a promoted gradient.
    WideGradient,
}

impl Kernel {
    /// The value form for an instruction of precision `prec`.
    fn value(prec: Prec) -> Kernel {
        match prec {
            Prec::Lane => Kernel::Value,
            Prec::Wide => Kernel::Wide,
        }
    }

    /// The gradient form for an instruction of precision `prec`.
    fn gradient(prec: Prec) -> Kernel {
        match prec {
            Prec::Lane => Kernel::Gradient,
            Prec::Wide => Kernel::WideGradient,
        }
    }
}

/// A spline (colour ramp: vec3, curve: scalar) as a WGSL function of an f64 input, evaluated
/// in f64 as `ops::Spline::eval`: segments tested from the last knot down, so where knots
/// coincide the later value wins.
fn spline_function<const N: usize>(w: &mut String, name: &str, spline: &Spline<N>) {
    let ty = if N == 3 { "vec3<f64>" } else { "f64" };
    let value = |v: &[f64; N]| {
        if N == 3 {
            vec3_literal([v[0], v[1], v[2]])
        } else {
            f64_literal(v[0])
        }
    };
    let zero = if N == 3 { "vec3<f64>(0.0lf)" } else { "0.0lf" };
    let nan = if N == 3 {
        "vec3<f64>(nan_d())"
    } else {
        "nan_d()"
    };
    let (knots, values) = (spline.knots(), spline.values());
    let _ = writeln!(w, "fn {name}(t: f64) -> {ty} {{");
    let _ = writeln!(w, "    if (is_nan_d(t)) {{ return {nan}; }}");
    let (Some(&first), Some(&last)) = (knots.first(), knots.last()) else {
        let _ = writeln!(w, "    return {nan};\n}}\n");
        return;
    };
    let slope = spline.is_slope();
    if slope {
        let _ = writeln!(
            w,
            "    if (!(t >= {} && t < {})) {{ return {zero}; }}",
            f64_literal(first),
            f64_literal(last)
        );
    }
    let _ = writeln!(
        w,
        "    let c = min(max(t, {}), {});",
        f64_literal(first),
        f64_literal(last)
    );
    let _ = writeln!(
        w,
        "    if (c >= {}) {{ return {}; }}",
        f64_literal(last),
        if slope {
            zero.to_string()
        } else {
            value(&values[values.len() - 1])
        }
    );
    for i in (0..knots.len() - 1).rev() {
        let inverse = if knots[i + 1] > knots[i] {
            1.0 / (knots[i + 1] - knots[i])
        } else {
            0.0
        };
        let a = value(&values[i]);
        // b − a as the literal the GPU's f64 subtraction gives (naga folds no f64 vectors, and
        // the export narrows it: one rounding instead of two).
        let step = value(&std::array::from_fn(|c| values[i + 1][c] - values[i][c]));
        let (k, inv) = (f64_literal(knots[i]), f64_literal(inverse));
        let _ = writeln!(w, "    if (c >= {k}) {{");
        let _ = writeln!(w, "        var u = (c - {k}) * {inv};");
        let interpolation = spline.interpolation();
        let _ = match (slope, interpolation) {
            (_, SplineInterpolation::Constant) if slope => writeln!(w, "        return {zero};"),
            (_, SplineInterpolation::Constant) => writeln!(w, "        return {a};"),
            (true, SplineInterpolation::Linear) => {
                writeln!(w, "        return {step} * {inv};")
            }
            (true, SplineInterpolation::Smooth) => writeln!(
                w,
                "        return 6.0lf * u * (1.0lf - u) * {step} * {inv};"
            ),
            (false, SplineInterpolation::Linear) => {
                writeln!(w, "        return {a} + u * {step};")
            }
            (false, SplineInterpolation::Smooth) => writeln!(
                w,
                "        u = u * u * (3.0lf - 2.0lf * u);\n        return {a} + u * {step};"
            ),
        };
        let _ = writeln!(w, "    }}");
    }
    let _ = writeln!(w, "    return {};\n}}\n", value(&values[0]));
}

fn axis_name(axis: u8) -> &'static str {
    ["x", "y", "z"][axis as usize % 3]
}

fn per_component(f: impl Fn(&str) -> String) -> String {
    format!("vec3<f64>({}, {}, {})", f("x"), f("y"), f("z"))
}

fn unary_f32(op: UnaryOp, x: &str) -> String {
    match op {
        UnaryOp::Abs => format!("abs({x})"),
        UnaryOp::Neg => format!("-({x})"),
        UnaryOp::Floor => format!("floor({x})"),
        UnaryOp::Trunc => format!("trunc({x})"),
        _ => format!("s_{}({x})", op.name()),
    }
}

fn unary_f64(op: UnaryOp, x: &str) -> String {
    match op {
        UnaryOp::Abs => format!("abs({x})"),
        UnaryOp::Neg => format!("-({x})"),
        UnaryOp::Floor => format!("floor({x})"),
        _ => format!("d_{}({x})", op.name()),
    }
}

/// `prefix` is `s_` (f32) or `d_` (f64).
fn binary(prefix: &str, op: BinaryOp, a: &str, b: &str) -> String {
    match op {
        BinaryOp::Add => format!("({a} + {b})"),
        BinaryOp::Sub => format!("({a} - {b})"),
        BinaryOp::Mul => format!("({a} * {b})"),
        // Guarded: drivers may turn x/0 into NaN (`math.wgsl`).
        BinaryOp::Div => format!("{prefix}div({a}, {b})"),
        _ => format!("{prefix}{}({a}, {b})", op.name()),
    }
}

fn ternary_name(op: TernaryOp) -> &'static str {
    op.name()
}

/// An f32 constant, exactly (its bits where a decimal literal cannot be written).
pub(crate) fn f32_literal(v: f32) -> String {
    if v.is_finite() && (v == 0.0 || v.abs() >= f32::MIN_POSITIVE) && v.to_bits() >> 31 == 0 {
        format!("{v:e}f")
    } else {
        format!("bitcast<f32>({:#010x}u)", v.to_bits())
    }
}

/// An f64 constant, exactly: the shortest decimal that reads back to it; non-finite and
/// subnormal values through the f32 NaN / infinity helpers or a product of exact factors.
pub(crate) fn f64_literal(v: f64) -> String {
    if v.is_nan() {
        "nan_d()".into()
    } else if v.is_infinite() {
        if v > 0.0 {
            "f64(inf_f32())".into()
        } else {
            "(-f64(inf_f32()))".into()
        }
    } else if v != 0.0 && v.abs() < f64::MIN_POSITIVE {
        // Subnormal: (v · 2^600) · 2^-600, exact.
        format!("ldexp({:e}lf, -600)", v * 2f64.powi(600))
    } else if v.to_bits() >> 63 == 1 {
        format!("(-{:e}lf)", -v)
    } else {
        format!("{v:e}lf")
    }
}

fn vec3_literal(v: [f64; 3]) -> String {
    format!(
        "vec3<f64>({}, {}, {})",
        f64_literal(v[0]),
        f64_literal(v[1]),
        f64_literal(v[2])
    )
}

/// A generated shader parsed by naga, the bases' f64 twins given their bodies
/// (`widen::graft`) and validated (what wgpu itself runs before compiling) with 64-bit floats
/// allowed: the module wgpu compiles, or the errors located in the source.
#[cfg(feature = "gpu")]
pub fn module(source: &str) -> Result<naga::Module, String> {
    let mut module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    super::widen::graft(&mut module)?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::FLOAT64,
    )
    .validate(&module)
    .map_err(|e| e.emit_to_string(source))?;
    Ok(module)
}

/// [`module`]'s checks alone.
#[cfg(feature = "gpu")]
pub fn validate(source: &str) -> Result<(), String> {
    module(source).map(|_| ())
}

#[cfg(all(test, feature = "gpu"))]
mod tests {
    use super::*;

    /// The f64 twins are planned from the library as the shaders concatenate it: the files
    /// `widen.rs` parses are [`LIBRARY`]'s, in its order.
    #[test]
    fn the_twins_are_planned_from_this_library() {
        let planned: Vec<&str> = (super::super::widen::CONTEXT.iter())
            .chain(&super::super::widen::SOURCES)
            .copied()
            .collect();
        let library: Vec<&str> = LIBRARY.iter().map(|(_, text)| *text).collect();
        assert!(
            planned == library,
            "widen.rs' CONTEXT and SOURCES are not LIBRARY"
        );
    }

    /// The hand-written WGSL validates with naga on its own (the library and the entry points
    /// over the smallest `tape` function), and so does the shader generated for a graph that
    /// reaches every basis, tiling, both gradients, every fractal style, splines, rotations
    /// and promoted (f64) instructions.
    #[test]
    fn the_wgsl_library_and_a_generated_shader_validate() {
        let mut source: String = LIBRARY
            .iter()
            .map(|(_, text)| format!("{text}\n"))
            .collect();
        source.push_str(
            "const CHANNELS: u32 = 1u;\nstruct Channels {\n    c: array<f32, 1>,\n}\n\
             fn tape(p: vec3<f64>, h: f64) -> Channels {\n    var r: Channels;\n    \
             r.c[0] = f32(p.x + h);\n    return r;\n}\n",
        );
        source.push_str(BINDINGS);
        source.push_str(ENTRY_POINTS);
        validate(&source).unwrap_or_else(|e| panic!("{e}"));

        let text = r#"Graph(nodes: {
            "p": Position,
            "q": Rotate(input: Scale(input: "p", by: 3.0), axis: (1, 2, 3), degrees: Mul("p.x", 40.0)),
            "a": Fbm(input: "q", basis: Simplex, octaves: 4.5, period: (4, 5, 6)),
            "b": Turbulence(input: "p", basis: Value(Smooth), octaves: 3),
            "c": Noise(input: "q", basis: Cellular(jitter: 0.8, metric: Manhattan, value: F2MinusF1)),
            "d": Ridged(input: "p", basis: Gradient, octaves: 5, offset: 1.0, sharpness: 2.0),
            "e": Add(Sin(Mul("p.x", 1e5)), WhiteNoise(input: "p")),
            "g": Gradient(of: Add("a", "d")),
            "r": ColorRamp(input: Add("a", "b"), stops: [(0.0, (0, 0, 0)), (0.5, (1, 0.5, 0)), (1.0, (1, 1, 1))]),
        }, outputs: { "a": "a", "b": "b", "c": "c", "d": "d", "e": "e", "g": "g", "r": "r" })"#;
        let graph = crate::check::check(
            crate::diagnostic::SourceFile::new("every.ron", text),
            &crate::check::CheckOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{}", e.render_plain()));
        let compile = |graph: &crate::graph::CheckedGraph, half: Option<f64>| {
            let options = crate::compile::CompileOptions {
                extent: half.map(|h| crate::precision::Extent::new([-h; 3], [h; 3])),
                ..Default::default()
            };
            crate::compile::compile(graph, &options).expect("compiles")
        };
        // Every kind, in f32.
        let shader = generate(&compile(&graph, None)).expect("no promoted noise");
        validate(&shader.source).unwrap_or_else(|e| panic!("{e}"));
        // Arithmetic promoted to f64 (`Sin(p.x·1e5)` over ±1e6): f64 in WGSL.
        let sine = crate::check::check(
            crate::diagnostic::SourceFile::new(
                "sine.ron",
                r#"Graph(nodes: { "p": Position, "s": Sin(Mul("p.x", 1e5)) }, outputs: { "s": "s" })"#,
            ),
            &crate::check::CheckOptions::default(),
        )
        .unwrap_or_else(|e| panic!("{}", e.render_plain()));
        let tape = compile(&sine, Some(1e6));
        assert!(tape.wide_instructions() > 0, "{tape}");
        let shader = generate(&tape).expect("no promoted noise");
        validate(&shader.source).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(shader.channels, tape.channels());
        // Noise and gradients promoted to f64 over ±1e6: the bases' f64 forms.
        let tape = compile(&graph, Some(1e6));
        let has = |f: fn(&Instr) -> bool| {
            tape.instrs
                .iter()
                .any(|i| i.prec() == crate::tape::Prec::Wide && f(i))
        };
        assert!(has(|i| matches!(i, Instr::Noise { .. })), "{tape}");
        assert!(has(|i| matches!(i, Instr::Fractal { .. })), "{tape}");
        assert!(
            has(|i| matches!(i, Instr::FractalGradient { .. })),
            "{tape}"
        );
        let shader = generate(&tape).expect("generated");
        validate(&shader.source).unwrap_or_else(|e| panic!("{e}"));
    }
}
