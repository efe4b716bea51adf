//! The filtered form of a tape in WGSL (issue 33): `fn ftape(p) -> Channels`, every output's
//! estimated mean over the invocation's footprint, the rules of `filter/` run on the GPU in f64
//! (`wgsl/filter.wgsl`). Each instruction becomes the call of its rule, as `filter::Filtered`
//! runs it per lane; the noise samplers, per-table statistics (`filter::noise::cached_stats`,
//! measured on the CPU and written in as literals) and piecewise shapes (`rules::spline_shape`,
//! `rules::hermite_shape`) are the CPU's, so both sides run the same model.
//! For the shader export, one `fn ftape_oK(p)` per output instead, each with only the
//! instructions its output reads (`needed`, from the tape's `Instr::reads`).
//!
//! Covered: every instruction kind, the fused pairs and the periodic chains (`filter/fusions.rs`,
//! `filter/chains.rs`; `filtered_periodic.rs`), white noise's mixture of cells and cellular
//! noise's sub-footprints, but the noise gradients, which [`unsupported`] names (and ramps or
//! curves of more than 24 knots). A tape with one of those is refused with its name
//! (`--device auto` then filters on the CPU).

use super::codegen::{self, f64_literal, Kernel, Shader};
use super::error::GpuError;
use crate::filter::fusions::{Fusion, Fusions};
use crate::filter::moments::Piecewise;
use crate::filter::operands::Source;
use crate::filter::ranges::Restricted;
use crate::noise::{Basis, Style};
use crate::ops::{BinaryOp, TernaryOp, UnaryOp};
use crate::tape::{Instr, Operand, Prec, Tape};
use smallvec::{smallvec, SmallVec};
use std::collections::{HashMap, HashSet};
use std::fmt::Write;

const FILTER: &str = include_str!("wgsl/filter.wgsl");
const OCTAVE: &str = include_str!("wgsl/filter_octave.wgsl");
const PERIODIC: &str = include_str!("wgsl/filter_periodic.wgsl");
const ENTRY: &str = include_str!("wgsl/entry_filtered.wgsl");

/// The most knots a piecewise shape may have on the GPU (its arrays are private memory).
const MAX_KNOTS: usize = 24;

/// Why the GPU's filtered form does not cover `tape` (the first instruction it cannot run),
/// or `None` where it does.
pub fn unsupported(tape: &Tape) -> Option<String> {
    let too_long = |f: &Piecewise| f.knots().len() > MAX_KNOTS;
    for ramp in &tape.ramps {
        if (0..3).any(|c| too_long(&crate::filter::rules::spline_shape(ramp.as_ref(), c))) {
            return Some(format!(
                "a colour ramp with more than {MAX_KNOTS} stops (the GPU's filtered form)"
            ));
        }
    }
    for curve in &tape.curves {
        if too_long(&crate::filter::rules::spline_shape(curve.as_ref(), 0)) {
            return Some(format!(
                "a curve with more than {MAX_KNOTS} points (the GPU's filtered form)"
            ));
        }
    }
    None
}

/// The filtered WGSL of `tape`: the point library (the tape's point function too, for the
/// channels whose filtered mean is not finite, as `Filtered::point_fallback`), the bases' f64
/// forms, `filtered_part` and the filtered entry points.
pub fn generate(tape: &Tape) -> Result<Shader, GpuError> {
    let (filtered, data) = filtered_part(tape, false, None)?;
    let point = codegen::generate(tape)?;
    // The point shader without its entry points (the filtered ones replace them; its
    // bindings stay).
    let Some(library) = point.source.strip_suffix(codegen::ENTRY_POINTS) else {
        return Err(GpuError::Shader(
            "internal: the point shader's entry points".into(),
        ));
    };
    let mut source = String::from(library);
    if !source.contains(super::widen::declarations()) {
        source.push_str(super::widen::declarations());
        source.push('\n');
    }
    source.push_str(&filtered);
    source.push_str(ENTRY);
    Ok(Shader {
        source,
        channels: point.channels,
        data,
    })
}

/// What the filtered form adds to the point library, the bases' f64 forms and the tape's point
/// function: the rules, one octave function per sampler, the shapes and `fn ftape(p) ->
/// Channels` (reading the footprint `fp_set` stored), without bindings or entry points. The
/// shader export (`shader/`) builds its `_filtered` functions on this. With `data_decl` the
/// form's data `fdata` is a module-scope array so declared (`var<private>`, or `const` for MSL:
/// `shader::array_decl`), else a storage binding; returned either way.
pub(crate) fn filtered_part(
    tape: &Tape,
    per_output: bool,
    data_decl: Option<&str>,
) -> Result<(String, Vec<f64>), GpuError> {
    if let Some(why) = unsupported(tape) {
        return Err(GpuError::Unsupported(why));
    }
    let integer = crate::filter::integers::integer_operands(tape);
    let mut data = Vec::new();
    let mut g = Gen {
        tape,
        samplers: Vec::new(),
        kernels: Vec::new(),
        functions: String::new(),
        rules: HashSet::new(),
        fusions: crate::filter::fusions::fusions(tape, &integer),
        knots: 2,
        integer,
        periodic: super::filtered_periodic::Shapes::new(&mut data),
        data,
        names: Gen::constant_names(tape),
        in_range: crate::filter::ranges::restricted_shapes(tape),
    };
    let body = g.function(per_output);
    let mut source = FILTER
        .replace("PW_KNOTS", &g.knots.to_string())
        .replace("PW_PIECES", &(g.knots + 1).to_string())
        .replace("PW_BREAKS", &(g.knots + 8).to_string());
    for (name, wrapper) in &g.kernels {
        source.push_str(wrapper);
        source.push_str(&OCTAVE.replace("SAMPLE", name));
        source.push('\n');
    }
    source.push_str(&g.functions);
    match data_decl {
        Some(decl) => super::filtered_periodic::write_array(&mut source, decl, &g.data),
        None => {
            let n = g.data.len().max(1);
            let _ = writeln!(source, "{DATA_BINDING}{n}>;");
        }
    }
    source.push_str(PERIODIC);
    source.push_str(&body);
    Ok((source, g.data))
}

/// The filtered form's data on the GPU path: a storage buffer (`GpuEvaluator` binds
/// `Shader::data`). A module-scope array instead made lavapipe's compile of the library's wood
/// 7× slower (169 s against 24 s): its dynamically indexed private arrays are lowered to code.
const DATA_BINDING: &str = "@group(0) @binding(4) var<storage, read> fdata: array<f64, ";

/// An instruction's WGSL: the value it writes (bound by `let`), or statements that assign it
/// to its name, declared by a `var` before them.
enum Stmt {
    Let(String),
    Block(String),
}

/// What a sampler samples: a table, tiled by a period or not.
type SamplerKey = (u32, Option<[u64; 3]>);

/// A noise sampler of the filtered form: the kernel it calls (its copy of
/// `filter_octave.wgsl` is `n_octave_KERNEL`, ...) and its record's offset in the data.
#[derive(Clone, Debug)]
struct Sampler {
    kernel: String,
    at: u32,
}

/// A value of the filtered body: a tape slot, or a saved operand `f{k}` (`filter/fusions.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Var {
    Slot(Operand),
    Saved(u32),
}

/// One instruction's statements, and per statement, in order, what it reads and writes.
#[derive(Default)]
struct Line {
    text: String,
    effects: Vec<(SmallVec<[Var; 3]>, Var)>,
}

/// Per line, whether the value `output` needs it: a backward pass from the end of the body
/// in which a statement that writes a live value makes its reads live and its write dead
/// (every statement writes a whole slot); a line is kept when one of its statements is. The
/// reads are the tape's (`Instr::reads`) and the fusions' saved operands, so the pass keeps
/// exactly what the output depends on.
fn needed(lines: &[Line], output: Var) -> Vec<bool> {
    let mut live: HashSet<Var> = HashSet::from([output]);
    let mut keep = vec![false; lines.len()];
    for (line, keep) in lines.iter().zip(&mut keep).rev() {
        *keep = line.effects.iter().any(|(_, write)| live.contains(write));
        if *keep {
            for (reads, write) in line.effects.iter().rev() {
                live.remove(write);
                live.extend(reads.iter().copied());
            }
        }
    }
    keep
}

struct Gen<'t> {
    tape: &'t Tape,
    /// Per (table, period) sampled, its sampler: its kernel's name and the offset of its record
    /// in `data` (the table's offset, the period, a cellular basis' codes and jitter, the
    /// table's statistics: `smp_stats` in filter.wgsl).
    samplers: Vec<(SamplerKey, Sampler)>,
    /// Per noise kernel sampled, its name and its wrapper `smp_NAME(s, x)`, which calls it with
    /// sampler `s`'s record: each gets one copy of `filter_octave.wgsl`.
    kernels: Vec<(String, String)>,
    /// The functions the body calls that depend on the tape: the piecewise shapes' (`pwh`,
    /// `pwr`, `pwc`, `pwf`) and the rules' (`u_`, `b_`, `t_` and the operation's name).
    functions: String,
    /// The names of the rule functions written.
    rules: HashSet<String>,
    /// The pairs computed together (`filter/fusions.rs`): their side slots `f{k}`.
    fusions: Fusions,
    /// The most knots of a shape written so far (the built-in shapes have 2).
    knots: usize,
    /// Per instruction: whether its operand `a` is integer-valued (`filter/integers.rs`).
    integer: Vec<[bool; 3]>,
    /// The periodic chains' shapes (`filtered_periodic.rs`), blocks of `data`.
    periodic: super::filtered_periodic::Shapes,
    /// The filtered form's data, `fdata` in the WGSL.
    data: Vec<f64>,
    /// Per slot, the name of the value it holds at the point of the body being written: every
    /// value is named once (`i{index}` for instruction `index`'s, the constants' by their
    /// slots), so the body is `let`s, not stores and loads of slot variables.
    names: HashMap<Operand, String>,
    /// Per instruction, a piecewise instruction's shapes over its input's interval
    /// (`filter/ranges.rs`), as the CPU's filtered form takes them.
    in_range: Vec<Option<Restricted>>,
}

impl Gen<'_> {
    /// `fn ftape(p) -> Channels`, every output's means; with `per_output` instead one
    /// `fn ftape_oK(p)` per output K, with only the lines that output needs ([`needed`]) and
    /// only its channels set.
    fn function(&mut self, per_output: bool) -> String {
        let t = self.tape;
        for (k, h) in t.hermites.iter().enumerate() {
            let f = crate::filter::rules::hermite_shape(h);
            self.shape(&format!("pwh{k}"), &f);
        }
        for (k, ramp) in t.ramps.iter().enumerate() {
            for c in 0..3 {
                let f = crate::filter::rules::spline_shape(ramp.as_ref(), c);
                self.shape(&format!("pwr{k}_{c}"), &f);
            }
        }
        for (k, curve) in t.curves.iter().enumerate() {
            let f = crate::filter::rules::spline_shape(curve.as_ref(), 0);
            self.shape(&format!("pwc{k}"), &f);
        }
        let lines: Vec<Line> = (t.instrs.iter().enumerate())
            .map(|(index, instr)| self.fused(index, instr))
            .collect();
        let mut w = String::new();
        let out = |o: &crate::tape::TapeOutput| match o.ty.channels() {
            1 => Operand::scalar(Prec::Lane, o.slot),
            _ => Operand::vec3(o.slot),
        };
        // Each output channel's mean, from its slot's value after the last line.
        let means = |g: &Self, outputs: &[usize]| -> Vec<(usize, String)> {
            let mut means = Vec::new();
            for o in outputs.iter().map(|&k| &t.outputs[k]) {
                let value = g.read(out(o));
                for c in 0..o.ty.channels() {
                    let mean = match o.ty.channels() {
                        1 => format!("{value}.m"),
                        _ => format!("{value}[{c}].m"),
                    };
                    means.push((o.first_channel + c, mean));
                }
            }
            means
        };
        if !per_output {
            let all: Vec<usize> = (0..t.outputs.len()).collect();
            let texts = lines.iter().map(|l| &l.text);
            let means = means(self, &all);
            ftape(&mut w, "ftape", &self.prelude(None), texts, t, &means);
            return w;
        }
        for (k, o) in t.outputs.iter().enumerate() {
            let out = out(o);
            let keep = needed(&lines, Var::Slot(out));
            let kept: Vec<&Line> = (lines.iter().zip(keep))
                .filter(|(_, k)| *k)
                .map(|(l, _)| l)
                .collect();
            let mut used = HashSet::from([Var::Slot(out)]);
            for (reads, write) in kept.iter().flat_map(|l| &l.effects) {
                used.extend(reads.iter().copied());
                used.insert(*write);
            }
            let prelude = self.prelude(Some(&used));
            let texts = kept.iter().map(|l| &l.text);
            let means = means(self, &[k]);
            ftape(&mut w, &format!("ftape_o{k}"), &prelude, texts, t, &means);
        }
        w
    }

    /// The tape's constants, one `let` each (`s`, `d` or `v` and the slot: their names until
    /// an instruction writes the slot); with `used`, only those its lines read (an output's own
    /// function: most of the tape's constants belong to other outputs).
    fn prelude(&self, used: Option<&HashSet<Var>>) -> String {
        let t = self.tape;
        let wanted = |o: Operand| used.is_none_or(|u| u.contains(&Var::Slot(o)));
        let mut w = String::new();
        for &(slot, v) in &t.scalar_constants {
            if wanted(Operand::scalar(Prec::Lane, slot)) {
                let _ = writeln!(w, "    let s{slot} = dc({});", f64_literal(v));
            }
        }
        for &(slot, v) in &t.wide_constants {
            if wanted(Operand::scalar(Prec::Wide, slot)) {
                let _ = writeln!(w, "    let d{slot} = dc({});", f64_literal(v));
            }
        }
        for &(slot, v) in &t.vec3_constants {
            if wanted(Operand::vec3(slot)) {
                let [x, y, z] = v.map(f64_literal);
                let _ = writeln!(
                    w,
                    "    let v{slot} = array<D, 3>(dc({x}), dc({y}), dc({z}));"
                );
            }
        }
        w
    }

    /// The names of the constants' slots before any instruction writes them.
    fn constant_names(t: &Tape) -> HashMap<Operand, String> {
        let scalars = t
            .scalar_constants
            .iter()
            .map(|&(slot, _)| (Operand::scalar(Prec::Lane, slot), format!("s{slot}")));
        let wides = t
            .wide_constants
            .iter()
            .map(|&(slot, _)| (Operand::scalar(Prec::Wide, slot), format!("d{slot}")));
        let vec3s =
            (t.vec3_constants.iter()).map(|&(slot, _)| (Operand::vec3(slot), format!("v{slot}")));
        scalars.chain(wides).chain(vec3s).collect()
    }

    /// The name of the value slot `o` holds at this point of the body (a slot nothing wrote
    /// holds zero, as the CPU's workspace does).
    fn read(&self, o: Operand) -> String {
        match (self.names.get(&o), o.file.prec()) {
            (Some(name), _) => name.clone(),
            (None, Some(_)) => "dc(0.0lf)".to_string(),
            (None, None) => "array<D, 3>(dc(0.0lf), dc(0.0lf), dc(0.0lf))".to_string(),
        }
    }

    /// A scalar operand's value in precision `prec`, and a vec3 operand's.
    fn s(&self, prec: Prec, slot: u32) -> String {
        self.read(Operand::scalar(prec, slot))
    }

    fn v(&self, slot: u32) -> String {
        self.read(Operand::vec3(slot))
    }

    /// Instruction `index` as `Filtered::run` takes it: its operands saved for a later fused
    /// instruction first; nothing where it is skipped (its only reader computes from its
    /// argument); a fused instruction's rule on its saved argument; else its own rule. With
    /// the line, what each of its statements reads and writes, in order.
    fn fused(&mut self, index: usize, instr: &Instr) -> Line {
        let mut line = Line::default();
        for &(source, k) in &self.fusions.save[index] {
            let (from, read) = match source {
                Source::Scalar(prec, s) => (self.s(prec, s), Operand::scalar(prec, s)),
                Source::Vec3(s, c) => (format!("{}[{c}]", self.v(s)), Operand::vec3(s)),
            };
            let _ = write!(line.text, "let f{k} = {from}; ");
            line.effects
                .push((smallvec![Var::Slot(read)], Var::Saved(k)));
        }
        if self.fusions.skip[index] {
            return line;
        }
        let written = instr.writes();
        let scalar = written.file.prec().is_some();
        // The value's name: one per instruction, so every name is bound once (a `let`).
        let name = format!("i{index}");
        let saved =
            |k: &[u32]| -> SmallVec<[Var; 3]> { k.iter().map(|&k| Var::Saved(k)).collect() };
        let (stmt, reads) = match (self.fusions.fused[index].clone(), scalar) {
            (Some(Fusion::AbsSin { saved: k, cos }), true) => {
                (Stmt::Let(format!("r_abs_sin(f{k}, {cos})")), saved(&[k]))
            }
            (Some(Fusion::Folded { saved: k, shape }), true) => {
                self.shape(&format!("pwf{index}"), &shape);
                (
                    Stmt::Let(format!("r_piecewise(pwf{index}(), f{k})")),
                    saved(&[k]),
                )
            }
            (Some(Fusion::Periodic { parts }), _) => {
                let calls: Vec<String> = parts
                    .iter()
                    .map(|p| {
                        let at = self.periodic.offset(&p.shape, &mut self.data);
                        let scale = f64_literal(p.scale);
                        format!("r_periodic({at}u, d_scale(f{}, {scale}))", p.saved)
                    })
                    .collect();
                let ks: Vec<u32> = parts.iter().map(|p| p.saved).collect();
                match (calls.as_slice(), scalar) {
                    ([one], true) => (Stmt::Let(one.clone()), saved(&ks)),
                    ([x, y, z], false) => {
                        (Stmt::Let(format!("array<D, 3>({x}, {y}, {z})")), saved(&ks))
                    }
                    _ => self.plain(index, instr, &name),
                }
            }
            _ => self.plain(index, instr, &name),
        };
        match stmt {
            Stmt::Let(value) => {
                let _ = write!(line.text, "let {name} = {value};");
            }
            Stmt::Block(block) => {
                let ty = if scalar { "D" } else { "array<D, 3>" };
                let _ = write!(line.text, "var {name}: {ty};\n    {block}");
            }
        }
        self.names.insert(written, name);
        line.effects.push((reads, Var::Slot(written)));
        line
    }

    /// An instruction's own rule, and the slots it reads.
    fn plain(&mut self, index: usize, instr: &Instr, name: &str) -> (Stmt, SmallVec<[Var; 3]>) {
        let reads = instr.reads().into_iter().map(Var::Slot).collect();
        (self.instruction(index, instr, name), reads)
    }

    /// A rule function (`unary`, `binary`, `ternary`), written once; its name.
    fn rule(&mut self, (name, function): (String, String)) -> String {
        if self.rules.insert(name.clone()) {
            self.functions.push_str(&function);
        }
        name
    }

    fn shape(&mut self, name: &str, f: &Piecewise) {
        let knots = shape_function(&mut self.functions, name, f);
        self.knots = self.knots.max(knots);
    }

    /// The shape functions `pwq{index}_{c}` of instruction `index`'s shapes over its input's
    /// interval (`filter/ranges.rs`); their common prefix.
    fn in_range_shapes(&mut self, index: usize) -> String {
        let name = format!("pwq{index}_");
        match self.in_range[index].clone() {
            Some(Restricted::One(f)) => self.shape(&format!("{name}0"), &f),
            Some(Restricted::Three(fs)) => {
                for (c, f) in fs.iter().enumerate() {
                    self.shape(&format!("{name}{c}"), f);
                }
            }
            None => {}
        }
        name
    }

    /// The sampler of `table` tiled by `period`: its record appended to the data and its
    /// kernel's wrapper written on first use.
    fn sampler(&mut self, table: u32, period: Option<[u64; 3]>) -> Sampler {
        if let Some((_, s)) = self.samplers.iter().find(|(k, _)| *k == (table, period)) {
            return s.clone();
        }
        let key = &self.tape.tables[table as usize].0;
        let name = codegen::sample_function(key, period.is_some(), Kernel::WideGradient);
        let at = self.data.len() as u32;
        let axes = period.unwrap_or_default().map(codegen::period_axis);
        let (metric, value, jitter) = match key.basis {
            Basis::Cellular(c) => {
                let (metric, value) = codegen::cellular_codes(&c);
                (metric, value, c.jitter())
            }
            _ => (0, 0, 0.0),
        };
        let offset = (table as usize * codegen::TABLE_WORDS) as f64;
        self.data.extend([offset, axes[0], axes[1], axes[2]]);
        self.data.extend([metric as f64, value as f64, jitter]);
        let st = crate::filter::noise::cached_stats(*key, &self.tape.tables[table as usize].1);
        let faces = if st.faces { 1.0 } else { 0.0 };
        self.data
            .extend([st.mean, st.var, st.kappa2, st.grad_sq, faces]);
        if !self.kernels.iter().any(|(n, _)| *n == name) {
            let mut args = String::from("u32(fdata[s]), x");
            if period.is_some() {
                args.push_str(", vec3<f64>(fdata[s + 1u], fdata[s + 2u], fdata[s + 3u])");
            }
            if matches!(key.basis, Basis::Cellular(_)) {
                args.push_str(", u32(fdata[s + 4u]), u32(fdata[s + 5u]), fdata[s + 6u]");
            }
            let wrapper = format!(
                "fn smp_{name}(s: u32, x: vec3<f64>) -> vec4<f64> {{\n    return {name}({args});\n}}\n"
            );
            self.kernels.push((name.clone(), wrapper));
        }
        let sampler = Sampler { kernel: name, at };
        self.samplers.push(((table, period), sampler.clone()));
        sampler
    }

    /// Instruction `index`'s own rule: the value it writes, or statements that assign it to
    /// `dst` (declared before them).
    fn instruction(&mut self, index: usize, instr: &Instr, dst: &str) -> Stmt {
        let integer = self.integer[index];
        // A scalar operand in the instruction's precision (both D here, every filtered value
        // being f64).
        let prec = instr.prec();
        let arr = |[x, y, z]: [String; 3]| Stmt::Let(format!("array<D, 3>({x}, {y}, {z})"));
        match *instr {
            Instr::Position { .. } => Stmt::Let(
                "array<D, 3>(d_position(p, 0u), d_position(p, 1u), d_position(p, 2u))".into(),
            ),
            Instr::Splat { src, .. } => arr([0, 1, 2].map(|_| self.s(prec, src))),
            Instr::Combine { x, y, z, .. } => arr([x, y, z].map(|c| self.s(prec, c))),
            Instr::Component { src, axis, .. } => {
                Stmt::Let(format!("{}[{}]", self.v(src), axis % 3))
            }
            Instr::UnaryScalar { op, src, .. } => {
                let x = self.s(prec, src);
                let f = self.rule(unary(op));
                Stmt::Let(format!("{f}({x})"))
            }
            Instr::UnaryVec3 { op, src, .. } => {
                let x = self.v(src);
                let f = self.rule(unary(op));
                arr([0, 1, 2].map(|i| format!("{f}({x}[{i}])")))
            }
            Instr::BinaryScalar { op, a, b, .. } => {
                let (a, b) = (self.s(prec, a), self.s(prec, b));
                let f = self.rule(binary(op, integer[0]));
                Stmt::Let(format!("{f}({a}, {b})"))
            }
            Instr::BinaryVec3 { op, a, b, .. } => {
                let (a, b) = (self.v(a), self.v(b));
                arr([0, 1, 2].map(|i| {
                    let f = self.rule(binary(op, integer[i]));
                    format!("{f}({a}[{i}], {b}[{i}])")
                }))
            }
            Instr::TernaryScalar { op, a, b, c, .. } => {
                let [a, b, c] = [a, b, c].map(|x| self.s(prec, x));
                let f = self.rule(ternary(op));
                Stmt::Let(format!("{f}({a}, {b}, {c})"))
            }
            Instr::TernaryVec3 { op, a, b, c, .. } => {
                let [a, b, c] = [a, b, c].map(|x| self.v(x));
                let f = self.rule(ternary(op));
                arr([0, 1, 2].map(|i| format!("{f}({a}[{i}], {b}[{i}], {c}[{i}])")))
            }
            Instr::Dot { a, b, .. } => Stmt::Let(format!("r_dot({}, {})", self.v(a), self.v(b))),
            Instr::Length { src, .. } => Stmt::Let(format!("r_length({})", self.v(src))),
            Instr::Cross { a, b, .. } => {
                Stmt::Let(format!("r_cross({}, {})", self.v(a), self.v(b)))
            }
            Instr::Normalize { src, .. } => Stmt::Let(format!("r_normalize({})", self.v(src))),
            Instr::RotateConst { src, matrix, .. } => {
                let m = self.tape.matrices[matrix as usize];
                let [r0, r1, r2] = m.map(vec3_literal);
                Stmt::Let(format!("r_rotate({r0}, {r1}, {r2}, {})", self.v(src)))
            }
            Instr::RotateVarying {
                src, degrees, axis, ..
            } => Stmt::Let(format!(
                "r_rotate_varying({}, {}, {})",
                vec3_literal(self.tape.axes[axis as usize]),
                self.v(src),
                self.s(prec, degrees)
            )),
            Instr::Noise { src, table, .. } => Stmt::Let(self.noise(src, table, integer)),
            Instr::Fractal {
                src,
                table,
                octaves,
                style,
                bias,
                ..
            } => Stmt::Let(self.fractal(src, table, octaves, style, bias)),
            // A point (no spread) takes the function itself, as on the CPU.
            Instr::Hermite { src, spline, .. } if self.in_range[index].is_some() => {
                let name = self.in_range_shapes(index);
                let x = self.s(Prec::Lane, src);
                Stmt::Block(format!(
                    "if (fp_n == 0u || !(f_total({x}) > 0.0lf)) {{ {dst} = r_piecewise(pwh{spline}(), {x}); }} \
                     else {{ {dst} = r_piecewise({name}0(), {x}); }}"
                ))
            }
            Instr::Curve { src, curve, .. } if self.in_range[index].is_some() => {
                let name = self.in_range_shapes(index);
                let x = self.s(Prec::Lane, src);
                Stmt::Block(format!(
                    "if (fp_n == 0u || !(f_total({x}) > 0.0lf)) {{ {dst} = r_piecewise(pwc{curve}(), {x}); }} \
                     else {{ {dst} = r_piecewise({name}0(), {x}); }}"
                ))
            }
            Instr::Ramp { src, ramp, .. } if self.in_range[index].is_some() => {
                let name = self.in_range_shapes(index);
                let x = self.s(Prec::Lane, src);
                let channels = |f: &dyn Fn(usize) -> String| {
                    let [a, b, c] = [0, 1, 2].map(|c| format!("r_piecewise({}(), {x})", f(c)));
                    format!("array<D, 3>({a}, {b}, {c})")
                };
                Stmt::Block(format!(
                    "if (fp_n == 0u || !(f_total({x}) > 0.0lf)) {{ {dst} = {}; }} else {{ {dst} = {}; }}",
                    channels(&|c| format!("pwr{ramp}_{c}")),
                    channels(&|c| format!("{name}{c}"))
                ))
            }
            Instr::Hermite { src, spline, .. } => Stmt::Let(format!(
                "r_piecewise(pwh{spline}(), {})",
                self.s(Prec::Lane, src)
            )),
            Instr::Ramp { src, ramp, .. } => {
                let x = self.s(Prec::Lane, src);
                arr([0, 1, 2].map(|c| format!("r_piecewise(pwr{ramp}_{c}(), {x})")))
            }
            Instr::Curve { src, curve, .. } => Stmt::Let(format!(
                "r_piecewise(pwc{curve}(), {})",
                self.s(Prec::Lane, src)
            )),
            Instr::Widen { src, .. } => Stmt::Let(self.s(Prec::Lane, src)),
            Instr::Narrow { src, .. } => Stmt::Let(self.s(Prec::Wide, src)),
            Instr::NoiseGradient { src, table, .. } => Stmt::Let(self.noise_gradient(src, table)),
            Instr::FractalGradient {
                src,
                table,
                octaves,
                style,
                ..
            } => Stmt::Block(self.fractal_gradient(dst, src, table, octaves, style)),
        }
    }

    /// A noise sample (tape.rs `noise_chunk`): white and cellular noise by their own rules
    /// (`integer`: which input components are integer-valued, for white noise's lattice),
    /// every other basis by the fade.
    fn noise(&mut self, src: u32, table: u32, integer: [bool; 3]) -> String {
        let period = self.tape.tables[table as usize].0.period;
        let Sampler { kernel: k, at } = self.sampler(table, period);
        let p = self.v(src);
        match self.tape.tables[table as usize].1.basis() {
            Basis::White => {
                let [x, y, z] = integer;
                format!("n_white_{k}({p}, vec3<bool>({x}, {y}, {z}), {at}u)")
            }
            Basis::Cellular(_) => format!("n_cellular_{k}({p}, {at}u)"),
            _ => format!("n_octave_{k}({p}, {at}u)"),
        }
    }

    /// noise.rs `noise_gradient`: the gradient at the centre faded like the value.
    fn noise_gradient(&mut self, src: u32, table: u32) -> String {
        let period = self.tape.tables[table as usize].0.period;
        let Sampler { kernel: k, at } = self.sampler(table, period);
        format!("n_gradient_{k}({}, 1.0lf, {at}u)", self.v(src))
    }

    /// Each octave's sampler of a fractal sum over `table` (its own period when tiled).
    fn octave_samplers(&mut self, table: u32, octaves: u32) -> Vec<Sampler> {
        let schedule = &self.tape.octaves[octaves as usize];
        let base = self.tape.tables[table as usize].0.period;
        let periods: Vec<Option<[u64; 3]>> = (0..schedule.frequencies.len())
            .map(|k| schedule.periods.as_ref().map(|p| p[k]).or(base))
            .collect();
        periods
            .into_iter()
            .map(|p| self.sampler(table, p))
            .collect()
    }

    /// tape.rs `fractal_gradient` and noise.rs `fractal_gradient`: an Fbm's octaves' faded
    /// gradients summed; a shaped style's point gradient (`gshaper_*_d`, the point form's
    /// shaper in f64) faded by its coarsest octave's fade.
    fn fractal_gradient(
        &mut self,
        dst: &str,
        src: u32,
        table: u32,
        octaves: u32,
        style: Style,
    ) -> String {
        let samplers = self.octave_samplers(table, octaves);
        let schedule = &self.tape.octaves[octaves as usize];
        let p = self.v(src);
        let mut w = String::from("{\n");
        if style == Style::Fbm {
            w.push_str("        var sum = array<D, 3>(dc(0.0lf), dc(0.0lf), dc(0.0lf));\n");
            octave_loop(&mut w, &samplers, schedule, |k, s, f, a| {
                format!(
                    "        let g = n_gradient_{k}(d3_scale({p}, {f}), {a} * {f}, {s});\n        \
                     for (var i = 0u; i < 3u; i += 1u) {{ sum[i] = r_add(sum[i], g[i]); }}\n"
                )
            });
            let _ = write!(w, "        {dst} = sum;\n    }}");
            return w;
        }
        let (code, offset, sharpness) = codegen::style_code(style);
        let (offset, sharpness) = (f64_literal(offset), f64_literal(sharpness));
        let _ = writeln!(
            w,
            "        var g = gshaper_start_d();\n        \
             let c = vec3<f64>({p}[0].m, {p}[1].m, {p}[2].m);"
        );
        octave_loop(&mut w, &samplers, schedule, |k, s, f, a| {
            format!(
                "        let n = smp_{k}({s}, c * {f});\n        \
                 g = gshaper_add_f64_d(g, {code}u, n.w, n.xyz, {a}, {f}, {offset}, {sharpness});\n"
            )
        });
        // The table's statistics from the coarsest octave's sampler record.
        let alpha = match (schedule.frequencies.first(), samplers.first()) {
            (Some(&f), Some(first)) => format!(
                "n_fade(smp_stats({}u), d3_scale({p}, {})).x",
                first.at,
                f64_literal(f)
            ),
            _ => "1.0lf".to_string(),
        };
        let _ = write!(
            w,
            "        let point = gshaper_gradient_d(g);\n        \
             let alpha = {alpha};\n        \
             {dst} = array<D, 3>(dc(alpha * point.x), dc(alpha * point.y), dc(alpha * point.z));\n    \
             }}"
        );
        w
    }

    /// noise.rs `fractal_lanes` and `shape` for one lane: every octave on the scaled input,
    /// shaped by the style's rules, summed; then the bias. A call of the fractal function of
    /// its kernel and style kind (written once: `n_fractal_KERNEL_STYLE`), which runs the
    /// octaves of its schedule's record in the data: the octave count, a ridged style's offset
    /// and sharpness, the bias, then per octave its frequency, amplitude and sampler.
    fn fractal(&mut self, src: u32, table: u32, octaves: u32, style: Style, bias: f64) -> String {
        let samplers = self.octave_samplers(table, octaves);
        let Some(kernel) = samplers.first().map(|s| s.kernel.clone()) else {
            return format!("dc({})", f64_literal(bias));
        };
        debug_assert!(samplers.iter().all(|s| s.kernel == kernel));
        let schedule = &self.tape.octaves[octaves as usize];
        let at = self.data.len() as u32;
        let (offset, sharpness, kind) = match style {
            Style::Fbm => (0.0, 0.0, "fbm"),
            Style::Turbulence => (0.0, 0.0, "turbulence"),
            Style::Billow => (0.0, 0.0, "billow"),
            Style::Ridged { offset, sharpness } => (offset, sharpness, "ridged"),
        };
        self.data
            .extend([samplers.len() as f64, offset, sharpness, bias]);
        for (k, s) in samplers.iter().enumerate() {
            let (f, a) = (schedule.frequencies[k], schedule.amplitudes[k]);
            self.data.extend([f, a, s.at as f64]);
        }
        let name = format!("n_fractal_{kernel}_{kind}");
        let mut body = String::new();
        let shaped = shaped(&mut body, style);
        let function = format!(
            "fn {name}(p: array<D, 3>, at: u32) -> D {{
    var sum = dc(0.0lf);
    var weight = dc(1.0lf);
    let offset = fdata[at + 1u];
    let sharpness = fdata[at + 2u];
    for (var k = 0u; k < u32(fdata[at]); k += 1u) {{
        let o = at + 4u + 3u * k;
        let n = n_octave_{kernel}(d3_scale(p, fdata[o]), u32(fdata[o + 2u]));
{body}        sum = r_add(sum, d_scale({shaped}, fdata[o + 1u]));
    }}
    let bias = fdata[at + 3u];
    if (bias != 0.0lf) {{
        sum = r_add(sum, dc(bias));
    }}
    _ = weight;
    _ = offset;
    _ = sharpness;
    return sum;
}}
"
        );
        self.rule((name.clone(), function));
        format!("{name}({}, {at}u)", self.v(src))
    }
}

/// `fn NAME(p) -> Channels`: `prelude`, `lines`, then the means of `outputs` (indices into
/// the tape's outputs); a channel whose mean is not finite takes the point value where that is
/// finite (`Filtered::point_fallback`). The point tape is called at one site (drivers inline
/// every call: one copy of it, not one per channel).
fn ftape<'a>(
    w: &mut String,
    name: &str,
    prelude: &str,
    lines: impl Iterator<Item = &'a String>,
    t: &Tape,
    means: &[(usize, String)],
) {
    let _ = writeln!(w, "fn {name}(p: vec3<f64>) -> Channels {{\n{prelude}");
    for line in lines {
        let _ = writeln!(w, "    {line}");
    }
    let channels = t
        .outputs
        .iter()
        .map(|o| o.first_channel + o.ty.channels())
        .max();
    let channels = channels.unwrap_or(0).max(1);
    let _ = writeln!(
        w,
        "    var r: Channels;\n    var m: f64;\n    var bad: array<bool, {channels}>;\n    \
         var any_bad = false;"
    );
    for (ch, mean) in means {
        let _ = writeln!(
            w,
            "    m = {mean};\n    r.c[{ch}] = f32(m);\n    bad[{ch}] = !is_finite_d(m);\n    \
             any_bad = any_bad || bad[{ch}];"
        );
    }
    let _ = writeln!(
        w,
        "    if (any_bad) {{\n        let pt = tape(p, 0.0lf);\n        \
         for (var c = 0u; c < {channels}u; c++) {{\n            \
         if (bad[c] && !is_nan(pt.c[c]) && !is_inf(pt.c[c])) {{ r.c[c] = pt.c[c]; }}\n        \
         }}\n    }}\n    return r;\n}}\n"
    );
}

/// The octaves of a fractal sum: a loop the driver cannot unroll (`filter_one()`) over arrays
/// of the octaves' frequencies, amplitudes and samplers, its body the statements `body(kernel,
/// sampler, frequency, amplitude)` makes from their expressions: one copy of the octave rule
/// and its noise kernel per fractal, not per octave. Every octave of a sum samples one table
/// with one kernel (a tiled sum's octaves differ only in their periods, run-time values).
fn octave_loop(
    w: &mut String,
    samplers: &[Sampler],
    schedule: &crate::noise::Octaves,
    body: impl Fn(&str, &str, &str, &str) -> String,
) {
    let Some(first) = samplers.first() else {
        return;
    };
    debug_assert!(samplers.iter().all(|s| s.kernel == first.kernel));
    let list = |v: &[f64]| v.iter().map(|&x| f64_literal(x)).collect::<Vec<_>>();
    let at: Vec<String> = samplers.iter().map(|s| format!("{}u", s.at)).collect();
    let n = samplers.len();
    let _ = writeln!(
        w,
        "        var freqs = array<f64, {n}>({});\n        \
         var amps = array<f64, {n}>({});\n        \
         var smps = array<u32, {n}>({});\n        \
         for (var k = 0u; k < {n}u * u32(filter_one()); k += 1u) {{",
        list(&schedule.frequencies).join(", "),
        list(&schedule.amplitudes).join(", "),
        at.join(", ")
    );
    w.push_str(&body(&first.kernel, "smps[k]", "freqs[k]", "amps[k]"));
    w.push_str("        }\n");
}

/// An octave `n` shaped by the fractal's style (noise.rs `shape`; ridged updates `weight` and
/// reads its `offset` and `sharpness`): the statements before, and the shaped value's
/// expression.
fn shaped(w: &mut String, style: Style) -> String {
    match style {
        Style::Fbm => "n".to_string(),
        Style::Turbulence => "ru_abs(n)".to_string(),
        Style::Billow => "r_sub(d_scale(ru_abs(n), 2.0lf), dc(1.0lf))".to_string(),
        Style::Ridged { .. } => {
            let _ = writeln!(
                w,
                "        var ridge = r_sub(dc(offset), ru_abs(n));\n        \
                 ridge = rb_pow(rb_max(ridge, dc(0.0lf)), dc(sharpness));\n        \
                 let signal = r_mul(ridge, weight);\n        \
                 weight = rb_min(rb_max(d_scale(signal, 2.0lf), dc(0.0lf)), dc(1.0lf));"
            );
            "signal".to_string()
        }
    }
}

fn vec3_literal(v: [f64; 3]) -> String {
    let [x, y, z] = v.map(f64_literal);
    format!("vec3<f64>({x}, {y}, {z})")
}

/// `fn NAME() -> Pw`: a piecewise cubic's knots and pieces.
fn shape_function(w: &mut String, name: &str, f: &Piecewise) -> usize {
    let _ = writeln!(w, "fn {name}() -> Pw {{\n    var f: Pw;");
    let _ = writeln!(w, "    f.n = {}u;", f.knots().len());
    for (i, k) in f.knots().iter().enumerate() {
        let _ = writeln!(w, "    f.k[{i}] = {};", f64_literal(*k));
    }
    for (i, p) in f.polys().iter().enumerate() {
        let [a, b, c, d] = p.map(f64_literal);
        let _ = writeln!(w, "    f.p[{i}] = vec4<f64>({a}, {b}, {c}, {d});");
    }
    let _ = writeln!(w, "    return f;\n}}");
    f.knots().len()
}

/// A unary rule (rules.rs `unary`) as a function of its operand, `u_{op}`: a constant or NaN
/// operand takes the point operation. Its name and text.
fn unary(op: UnaryOp) -> (String, String) {
    let rule = match op {
        UnaryOp::Neg => "d_scale(a, -1.0lf)".to_string(),
        UnaryOp::Abs => "r_piecewise(shape_abs(), a)".into(),
        UnaryOp::Sign => "r_piecewise(shape_sign(), a)".into(),
        UnaryOp::Sin => "r_sin_cos(a, false)".into(),
        UnaryOp::Cos => "r_sin_cos(a, true)".into(),
        UnaryOp::Exp => "r_exp(a)".into(),
        UnaryOp::Sqrt => "r_sqrt(a)".into(),
        UnaryOp::Log => "r_smooth(a, d_log(a.m), 1.0lf / a.m, -1.0lf / (a.m * a.m), true)".into(),
        UnaryOp::Log2 => {
            "r_smooth(a, d_log2(a.m), 1.0lf / (a.m * LN2), -1.0lf / (a.m * a.m * LN2), true)"
                .replace("LN2", &f64_literal(std::f64::consts::LN_2))
        }
        UnaryOp::Tan => "r_smooth(a, d_tan(a.m), 1.0lf + d_tan(a.m) * d_tan(a.m), \
             2.0lf * d_tan(a.m) * (1.0lf + d_tan(a.m) * d_tan(a.m)), false)"
            .into(),
        UnaryOp::Asin | UnaryOp::Acos => {
            let sign = if op == UnaryOp::Acos { "-" } else { "" };
            let name = op.name();
            format!(
                "r_smooth(a, d_{name}(a.m), {sign}(1.0lf / d_sqrt(1.0lf - a.m * a.m)), \
                 {sign}(a.m / ((1.0lf - a.m * a.m) * d_sqrt(1.0lf - a.m * a.m))), false)"
            )
        }
        UnaryOp::Fract => "r_fract(a)".into(),
        UnaryOp::Floor => "r_floor(a)".into(),
        UnaryOp::Round => "r_round(a)".into(),
        UnaryOp::Trunc => "r_trunc(a)".into(),
    };
    let point = point_unary(op, "a.m");
    let name = format!("u_{}", op.name());
    let function = format!(
        "fn {name}(a: D) -> D {{\n    if (d_is_const(a) || is_nan_d(a.m)) {{\n        return dc({point});\n    }}\n    return {rule};\n}}\n"
    );
    (name, function)
}

fn point_unary(op: UnaryOp, x: &str) -> String {
    match op {
        UnaryOp::Abs => format!("abs({x})"),
        UnaryOp::Neg => format!("-({x})"),
        UnaryOp::Floor => format!("floor({x})"),
        _ => format!("d_{}({x})", op.name()),
    }
}

/// A binary rule (rules.rs `binary`) as a function of its operands, `b_{op}`: constant or NaN
/// operands take the point operation. `Mod` (tape.rs's `binary`) is `b_mod_{integer}`, `r_mod`
/// with `integer` whether `a` is integer-valued (it takes constants and NaN itself). Its name
/// and text.
fn binary(op: BinaryOp, integer: bool) -> (String, String) {
    let rule = match op {
        BinaryOp::Add => "r_add(a, b)",
        BinaryOp::Sub => "r_sub(a, b)",
        BinaryOp::Mul => "r_mul(a, b)",
        BinaryOp::Div => "r_div(a, b)",
        BinaryOp::Min => "r_min_max(a, b, false)",
        BinaryOp::Max => "r_min_max(a, b, true)",
        BinaryOp::Step => "r_piecewise(shape_step(), r_sub(b, a))",
        BinaryOp::Pow => "r_pow(a, b)",
        BinaryOp::Atan2 => "r_atan2(a, b)",
        BinaryOp::Mod => {
            let name = format!("b_mod_{integer}");
            let function =
                format!("fn {name}(a: D, b: D) -> D {{\n    return r_mod(a, b, {integer});\n}}\n");
            return (name, function);
        }
    };
    let point = match op {
        BinaryOp::Add => "(a.m + b.m)".to_string(),
        BinaryOp::Sub => "(a.m - b.m)".to_string(),
        BinaryOp::Mul => "(a.m * b.m)".to_string(),
        _ => format!("d_{}(a.m, b.m)", op.name()),
    };
    let name = format!("b_{}", op.name());
    let function = format!(
        "fn {name}(a: D, b: D) -> D {{\n    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {{\n        return dc({point});\n    }}\n    return {rule};\n}}\n"
    );
    (name, function)
}

/// A ternary rule (rules.rs `ternary`) as a function of its operands, `t_{op}`. Its name and
/// text.
fn ternary(op: TernaryOp) -> (String, String) {
    let rule = match op {
        TernaryOp::Clamp => "r_clamp(a, b, c)",
        TernaryOp::Mix => "r_mix(a, b, c)",
        TernaryOp::Smoothstep => "r_smoothstep(a, b, c)",
        TernaryOp::Select => "r_select(a, b, c)",
    };
    let op = op.name();
    let name = format!("t_{op}");
    let function = format!(
        "fn {name}(a: D, b: D, c: D) -> D {{\n    \
         if ((d_is_const(a) && d_is_const(b) && d_is_const(c)) || is_nan_d(a.m) || is_nan_d(b.m) || is_nan_d(c.m)) {{\n        \
         return dc(d_{op}(a.m, b.m, c.m));\n    }}\n    return {rule};\n}}\n"
    );
    (name, function)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(reads: &[Var], write: Var) -> Line {
        Line {
            text: String::new(),
            effects: vec![(reads.iter().copied().collect(), write)],
        }
    }

    /// Liveness kills a slot at its write: where a slot is reused, only the last writer before
    /// a reader is kept, and a value nothing reads keeps nothing.
    #[test]
    fn needed_follows_slot_reuse() {
        let s = |k| Var::Slot(Operand::scalar(Prec::Lane, k));
        let v = |k| Var::Slot(Operand::vec3(k));
        let lines = [
            line(&[v(0)], s(0)),
            line(&[s(0)], s(1)),
            line(&[s(1)], Var::Saved(0)),
            line(&[v(0)], s(0)),
            line(&[s(0), Var::Saved(0)], s(2)),
        ];
        assert_eq!(needed(&lines, s(1)), [true, true, false, false, false]);
        assert_eq!(needed(&lines, s(2)), [true; 5]);
        assert_eq!(needed(&lines, s(0)), [false, false, false, true, false]);
        assert_eq!(needed(&lines, s(7)), [false; 5]);
    }

    /// An instruction is one call of its rule's function, which is written once per operation
    /// the tape uses (vec3 instructions call it per component).
    #[test]
    fn each_rule_function_is_written_once() {
        let source = crate::diagnostic::SourceFile::new(
            "t.ron",
            r#"Graph(nodes: { "p": Position }, outputs: {
                "a": Mul(Mul("p.x", "p.y"), Sin(Mul("p.z", 3.0))),
                "c": Sin(Mul("p", "p")) })"#,
        );
        let graph = crate::check::check(source, &Default::default()).expect("checks");
        let tape = crate::compile::compile(&graph, &Default::default()).expect("compiles");
        let text = filtered_part(&tape, false, None).expect("covered").0;
        assert_eq!(text.matches("fn b_mul(").count(), 1, "{text}");
        assert_eq!(text.matches("fn u_sin(").count(), 1, "{text}");
        // Its definition and at least the vec3 product's three components' calls.
        assert!(text.matches("b_mul(").count() >= 4, "{text}");
    }

    /// Each output's exported function runs only its own rules.
    #[test]
    fn each_output_keeps_only_its_own_rules() {
        let source = crate::diagnostic::SourceFile::new(
            "t.ron",
            r#"Graph(nodes: { "p": Position }, outputs: {
                "a": Abs(Sin(Mul("p.x", 3.0))),
                "n": Noise(input: "p", basis: Perlin, seed: 0) })"#,
        );
        let graph = crate::check::check(source, &Default::default()).expect("checks");
        let tape = crate::compile::compile(&graph, &Default::default()).expect("compiles");
        let text = filtered_part(&tape, true, None).expect("covered").0;
        let body = |name: &str| {
            let start = text.find(&format!("fn {name}(")).expect("the function");
            let end = text[start..].find("\n}\n").expect("its end");
            text[start..start + end].to_string()
        };
        let (a, n) = (body("ftape_o0"), body("ftape_o1"));
        assert!(a.contains("r_abs_sin") && !a.contains("n_octave_"), "{a}");
        assert!(n.contains("n_octave_") && !n.contains("r_abs_sin"), "{n}");
    }
}
