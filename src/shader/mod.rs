//! Shader export (issue 35, docs/shaders.md): a tape as one self-contained shader source that
//! an engine's own shader calls: per output `texgraph_NAME(p)`, `texgraph_NAME_lod(p,
//! spacing)` (the octave fade of level of detail per point, as `eval --spacing`) and
//! `texgraph_NAME_filtered(p, footprint)` (the mean over a footprint, as `eval --footprint`),
//! in WGSL, GLSL 4.50 (or `--version`), GLSL ES 3.00, HLSL (shader model 5.1) or MSL (2.1).
//!
//! How: the GPU path's WGSL for the tape (`gpu::codegen`: the library in `gpu/wgsl/` and the
//! tape's straight-line function; `gpu::filtered`: the filtered form's rules and one
//! `ftape_oK` per output, with only the instructions that output reads) as the GPU path has it,
//! with the noise tables as module-scope arrays instead of a storage buffer, the functions the
//! export writes for itself (`NAME__export`), the exported functions and one stub entry point
//! that calls them all ([`export_source`]). naga parses that once; on its IR (`translate.rs`)
//! the module is made all-f32 (`narrow.rs`; naga's MSL and GLSL ES have no f64), each
//! `NAME__export` takes `NAME`'s place (`functions.rs`), only what the entry point reaches
//! stays (compaction: the library functions the requested outputs use), every other name gets
//! the `tg_` prefix, the validator proves without the f64 capability that nothing of f64 is
//! left, and naga writes the language; the stub entry point is removed from the module (WGSL,
//! HLSL, MSL) or cut from the text (GLSL, whose writer needs one).

#[cfg(feature = "shader")]
mod functions;
#[cfg(feature = "shader")]
mod narrow;
mod options;
pub mod uniforms;
mod words;

pub use options::{
    function_name, identifier, Exported, ExportedFunction, Lang, ShaderError, ShaderOptions,
};
use options::{KEEP, PREFIX};

use crate::tape::Tape;
use std::fmt::Write;
pub use uniforms::UniformPlan;

/// The exported functions of `tape`'s outputs, in the tape's output order; with `_filtered`
/// forms when `filtered` and the filtered form covers the tape (`gpu::filtered::unsupported`).
pub fn functions(tape: &Tape, filtered: bool) -> Result<Vec<ExportedFunction>, ShaderError> {
    let filtered = filtered && crate::gpu::filtered::unsupported(tape).is_none();
    let mut seen = std::collections::HashSet::new();
    let mut all = Vec::new();
    for o in &tape.outputs {
        let name = function_name(&o.name);
        if !seen.insert(name.clone()) {
            return Err(ShaderError::SameName(name));
        }
        all.push(ExportedFunction {
            output: o.name.to_string(),
            lod: format!("{name}_lod"),
            filtered: filtered.then(|| format!("{name}_filtered")),
            name,
            channels: o.ty.channels(),
        });
    }
    Ok(all)
}

/// The export's WGSL module before naga: the GPU path's library and the tape's parts (the noise
/// tables as module-scope arrays read by `TABLE_READERS`, the constants times a literal 1.0,
/// the filtered form's loops bounded by `FILTER_ONE`), the f32 forms of `narrow.rs` (every
/// target is f32 today), the uniform block, the exported `functions` ([`functions`]) and the
/// stub entry point. Functions written for the export are named `NAME__export`
/// (`options::EXPORT_FORM`) and take `NAME`'s place on naga's IR (`translate`), which also
/// narrows the module to f32 and prefixes its names: no pass rewrites this text.
pub fn export_source(
    tape: &Tape,
    functions: &[ExportedFunction],
    uniforms: Option<&UniformPlan>,
    lang: Lang,
) -> String {
    let mut source = String::new();
    for (_, text) in crate::gpu::codegen::LIBRARY {
        source.push_str(text);
        source.push('\n');
    }
    source.push_str(TABLE_READERS);
    source.push_str(&table_arrays(tape, lang));
    let exprs = uniforms.map(|u| u.exprs.clone()).unwrap_or_default();
    // The GPU path's constants are multiplied by `dispatch.one`, a 1.0 the driver cannot fold
    // into them; the point forms take the literal.
    source.push_str(&crate::gpu::codegen::tape_part(tape, &exprs, "1.0"));
    if functions.iter().any(|f| f.filtered.is_some()) {
        source.push_str(crate::gpu::widen::declarations());
        match crate::gpu::filtered::filtered_part(tape, true, Some(array_decl(lang))) {
            Ok((part, _)) => source.push_str(&part),
            Err(e) => debug_assert!(false, "functions() checked the tape: {e}"),
        }
        let _ = writeln!(
            source,
            "var<private> {FILTER_ONE}: f32 = 1.0;\nfn filter_one() -> f32 {{\n    return {FILTER_ONE};\n}}"
        );
    }
    #[cfg(feature = "shader")]
    source.push_str(narrow::F32_FORMS);
    if let Some(plan) = uniforms {
        // Every param a field, in the graph's order (those that stay constants too, so the
        // layout follows from the graph file alone): std140-compatible, field i at byte 4 i.
        let _ = writeln!(source, "struct {} {{", uniforms::STRUCT);
        for p in &plan.params {
            let _ = writeln!(source, "    {}: f32,", p.field);
        }
        if plan.params.is_empty() {
            let _ = writeln!(source, "    unused: f32,");
        }
        let _ = writeln!(
            source,
            "}}\n@group(0) @binding(0) var<uniform> {}: {};\n",
            uniforms::INSTANCE,
            uniforms::STRUCT
        );
    }
    for (k, (f, o)) in functions.iter().zip(&tape.outputs).enumerate() {
        let c = o.first_channel;
        let (ty, value) = if f.channels == 1 {
            ("f32".to_string(), format!("r.c[{c}]"))
        } else {
            (
                "vec3<f32>".to_string(),
                format!("vec3<f32>(r.c[{c}], r.c[{}], r.c[{}])", c + 1, c + 2),
            )
        };
        // Written in the GPU path's f64 like the tape they call: narrowed, the parameters are
        // the contract's f32 (`p: vec3<f32>`, `spacing: f32`, `footprint: mat3x3<f32>`).
        let _ = writeln!(
            source,
            "fn {}(p: vec3<f64>) -> {ty} {{\n    let r = tape(p, 0.0);\n    return {value};\n}}\n",
            f.name
        );
        let _ = writeln!(
            source,
            "fn {}(p: vec3<f64>, spacing: f64) -> {ty} {{\n    let r = tape(p, spacing);\n    return {value};\n}}\n",
            f.lod
        );
        if let Some(filtered) = &f.filtered {
            let _ = writeln!(
                source,
                "fn {filtered}(p: vec3<f64>, footprint: mat3x3<f64>) -> {ty} {{\n    \
                 {FILTER_ONE} = select(1.0, f32(bitcast<u32>(f32(p.y)) & 255u), bitcast<u32>(f32(p.x)) == 0x7fc0bad1u);\n    \
                 fp_set(footprint[0], footprint[1], footprint[2]);\n    \
                 let r = ftape_o{k}(p);\n    return {value};\n}}\n"
            );
        }
    }
    let _ = writeln!(
        source,
        "@fragment\nfn {KEEP}(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {{\n    \
         let p = vec3<f64>(at.xyz);\n    let w = vec3<f64>(at.www);\n    var a = 0.0;"
    );
    for f in functions {
        let pick = if f.channels == 1 { "" } else { ".x" };
        let _ = writeln!(
            source,
            "    a = a + {}(p){pick} + {}(p, f64(at.w)){pick};",
            f.name, f.lod
        );
        if let Some(filtered) = &f.filtered {
            let _ = writeln!(
                source,
                "    a = a + {filtered}(p, mat3x3<f64>(w, p, p.zyx)){pick};"
            );
        }
    }
    let _ = writeln!(source, "    return vec4<f32>(a);\n}}");
    source
}

/// The names [`export_source`] gives that keep their name in the export (the rest get the
/// `tg_` prefix): the exported functions, the stub entry point's and the uniform block's.
fn kept_names(functions: &[ExportedFunction]) -> std::collections::HashSet<String> {
    let mut keep: std::collections::HashSet<String> = functions
        .iter()
        .flat_map(ExportedFunction::names)
        .cloned()
        .collect();
    keep.insert(KEEP.to_string());
    keep.insert(uniforms::STRUCT.to_string());
    keep.insert(uniforms::INSTANCE.to_string());
    keep
}

/// The filtered form's loops (a noise octave's samples, the Gauss–Legendre nodes, a periodic
/// chain's three levels) run `n · one` times, where the GPU path's `one` is a uniform that is
/// 1.0 at run time: a bound the driver cannot know, so it keeps one copy of each loop's body
/// (the inlined noise kernel) instead of unrolling it (lavapipe unrolled the literal 1.0 and
/// ran out of 24 GB on the first graph). An exported shader has no binding of its own, so each
/// `_filtered` function sets this private variable from its point: 1.0, unless `p.x` is one
/// particular NaN (then up to 255: wasted work on a NaN result), and `fn filter_one()`, which
/// the loops call (the GPU path's reads `dispatch.one`), returns it. No compiler can fold that.
const FILTER_ONE: &str = "filter_one_value";

/// The noise tables as constant arrays, one per section, holding only what each table's basis
/// reads (the GPU path's buffer gives every table all 1544 words): the permutations packed four
/// bytes to a word (64 words a table; the library's perm is doubled, `perm[i & 511] =
/// perm[i & 255]`), the Gradient basis' vectors and the Value basis' values as f32 bits, the
/// cell hash keys; and `tables_base`, per table its offsets into them. The library's four
/// accessors (`perm_at`, `grad_at`, `value_at`, `hash_key`, whose `t` is the table's index
/// times `T_WORDS`) are replaced by readers of these ([`TABLE_READERS`]).
fn table_arrays(tape: &Tape, lang: Lang) -> String {
    use crate::noise::Basis;
    let (mut perm, mut grads, mut values, mut keys) = (vec![], vec![], vec![], vec![]);
    let mut bases = Vec::new();
    for (key, table) in &tape.tables {
        let words = table.gpu_words();
        bases.push([perm.len(), grads.len(), values.len(), keys.len()]);
        let lattice = !matches!(key.basis, Basis::White | Basis::Cellular(_));
        if lattice {
            perm.extend(
                words[..256]
                    .chunks(4)
                    .map(|b| b[0] | b[1] << 8 | b[2] << 16 | b[3] << 24),
            );
        }
        if matches!(key.basis, Basis::Gradient) {
            grads.extend_from_slice(&words[512..1280]);
        }
        if matches!(key.basis, Basis::Value(_)) {
            values.extend_from_slice(&words[1280..1536]);
        }
        if !lattice {
            keys.extend_from_slice(&words[1536..1538]);
        }
    }
    let decl = array_decl(lang);
    let mut s = String::new();
    for (name, words) in [
        ("perm", &perm),
        ("grads", &grads),
        ("values", &values),
        ("keys", &keys),
    ] {
        let _ = write!(
            s,
            "{decl} tables_{name}: array<u32, {n}> = array<u32, {n}>(",
            n = words.len().max(1)
        );
        for (i, w) in words.iter().enumerate() {
            if i % 12 == 0 {
                s.push_str("\n    ");
            }
            let _ = write!(s, "{w}u,");
        }
        if words.is_empty() {
            s.push_str("0u");
        }
        s.push_str("\n);\n");
    }
    let _ = write!(
        s,
        "{decl} tables_base: array<vec4<u32>, {n}> = array<vec4<u32>, {n}>(",
        n = bases.len().max(1)
    );
    for b in &bases {
        let _ = write!(
            s,
            "\n    vec4<u32>({}u, {}u, {}u, {}u),",
            b[0], b[1], b[2], b[3]
        );
    }
    if bases.is_empty() {
        s.push_str("vec4<u32>(0u)");
    }
    s.push_str("\n);\n");
    s
}

/// How the export declares its module-scope data arrays (the noise tables, the periodic chains'
/// shapes). A `const` array indexed at run time is copied into a local at every read by naga's
/// SPIR-V writer (wgpu, Bevy), which LLVM-based drivers then inline by the hundred (lavapipe ran
/// out of 24 GB); a private variable that nothing writes is read in place. HLSL gets `const`
/// back after naga (`hlsl_table_initializer`); MSL keeps `const` (its private globals would
/// become every function's parameters).
fn array_decl(lang: Lang) -> &'static str {
    if lang == Lang::Msl {
        "const"
    } else {
        "var<private>"
    }
}

/// The library's table accessors, in place, over [`table_arrays`]' arrays (`t / T_WORDS`: the
/// table's index).
const TABLE_READERS: &str = "
fn perm_at__export(t: u32, i: u32) -> u32 {
    let k = tables_base[t / T_WORDS].x * 4u + (i & 255u);
    return (tables_perm[k >> 2u] >> (8u * (k & 3u))) & 255u;
}
fn grad_at__export(t: u32, h: u32) -> vec3<f32> {
    let b = tables_base[t / T_WORDS].y + 3u * (h & 255u);
    return vec3<f32>(bitcast<f32>(tables_grads[b]), bitcast<f32>(tables_grads[b + 1u]), bitcast<f32>(tables_grads[b + 2u]));
}
fn value_at__export(t: u32, h: u32) -> f32 {
    return bitcast<f32>(tables_values[tables_base[t / T_WORDS].z + (h & 255u)]);
}
fn hash_key__export(t: u32) -> vec2<u32> {
    let b = tables_base[t / T_WORDS].w;
    return vec2<u32>(tables_keys[b], tables_keys[b + 1u]);
}
";

/// `tape` as a shader in `options.lang` (see the module comment).
pub fn export(
    tape: &Tape,
    options: &ShaderOptions,
    uniforms: Option<&UniformPlan>,
) -> Result<Exported, ShaderError> {
    check_version(options)?;
    let functions = functions(tape, options.filtered && !filtered_ignores(uniforms))?;
    let wgsl = export_source(tape, &functions, uniforms, options.lang);
    let written = translate(&wgsl, options, &kept_names(&functions))?;
    let mut source = tidy(&written, options.lang, &functions);
    source = plain_parameters(&source, &functions);
    if options.lang == Lang::Hlsl {
        source = hlsl_table_initializer(&source);
    }
    if options.lang == Lang::Msl {
        source = msl_private_locals(&source, &functions);
    }
    Ok(Exported { source, functions })
}

/// Whether `uniforms` has a param read from the uniform block: the filtered form's rules are
/// built for the params' values (a ramp's shapes over its input's range, the periodic chains'
/// shapes, which operands are integers), so with such a param its `_filtered` functions are
/// left out rather than filter for values the block no longer holds.
fn filtered_ignores(uniforms: Option<&UniformPlan>) -> bool {
    uniforms.is_some_and(|u| u.params.iter().any(|p| p.constant.is_none()))
}

/// The names naga chose, made the contract's: an exported name ending in a digit got a `_`
/// from naga's namer (taken off); GLSL's uniform block and instance (`TexgraphParamsBlock`,
/// `texgraph_params`); MSL's array wrapper types (`type_N`) prefixed like the library.
fn tidy(text: &str, lang: Lang, functions: &[ExportedFunction]) -> String {
    let exported: std::collections::HashMap<String, String> = functions
        .iter()
        .flat_map(ExportedFunction::names)
        .filter(|n| n.ends_with(|c: char| c.is_ascii_digit()))
        .map(|n| (format!("{n}_"), n.clone()))
        .collect();
    words::rename_words(text, |word| {
        if let Some(name) = exported.get(word) {
            return Some(name.clone());
        }
        match lang {
            Lang::Glsl | Lang::GlslEs if word == "TexgraphParams_block_0Fragment" => {
                Some("TexgraphParamsBlock".into())
            }
            Lang::Glsl | Lang::GlslEs if word == "_group_0_binding_0_fs" => {
                Some(uniforms::INSTANCE.into())
            }
            Lang::Msl
                if word
                    .strip_prefix("type_")
                    .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit())) =>
            {
                Some(format!("{PREFIX}{word}"))
            }
            _ => None,
        }
    })
}

fn check_version(options: &ShaderOptions) -> Result<(), ShaderError> {
    let Some(version) = options.version else {
        return Ok(());
    };
    let (ok, allowed) = match options.lang {
        Lang::Glsl => (
            matches!(version, 330 | 400 | 410 | 420 | 430 | 440 | 450 | 460),
            "330, 400, 410, 420, 430, 440, 450, 460",
        ),
        Lang::GlslEs => (matches!(version, 300 | 310 | 320), "300, 310, 320"),
        _ => return Err(ShaderError::VersionNotGlsl),
    };
    if ok {
        Ok(())
    } else {
        Err(ShaderError::Version { version, allowed })
    }
}

#[cfg(feature = "shader")]
mod translate;
#[cfg(feature = "shader")]
use translate::translate;

#[cfg(not(feature = "shader"))]
fn translate(
    _: &str,
    _: &ShaderOptions,
    _: &std::collections::HashSet<String>,
) -> Result<String, ShaderError> {
    Err(ShaderError::NotBuilt)
}

/// What `--extent` warns of: per output of `planned` (compiled with an extent) whose f32 bound
/// misses the precision target, the bound and the nodes the plan would run in f64 (each with
/// its reason). The CPU's f32 path keeps positions and vec3 values in f64; the shader cannot,
/// so these bounds are the least it will be off by over the extent.
pub fn precision_warnings(planned: &Tape) -> Vec<String> {
    let Some(plan) = &planned.precision else {
        return Vec::new();
    };
    // One line per node (a node can be several instructions), its first reason.
    let mut seen = std::collections::HashSet::new();
    let nodes: Vec<String> = planned
        .reasons
        .iter()
        .filter(|(i, _)| seen.insert(planned.origins[*i].clone()))
        .map(|(i, why)| format!("node `{}` ({why})", planned.origins[*i]))
        .collect();
    plan.outputs
        .iter()
        .filter(|o| o.plain_f32 > plan.max_error)
        .map(|o| {
            let mut line = format!(
                "output `{}` needs f64 over the extent: in f32 it may be off by up to {:.2e} (target {:.0e})",
                o.output, o.plain_f32, plan.max_error
            );
            if let Some(why) = &o.shortfall {
                let _ = write!(line, "; {why}");
            }
            if !nodes.is_empty() {
                let _ = write!(line, "; f64 where the CPU runs it: {}", nodes.join(", "));
            }
            line
        })
        .collect()
}

/// naga writes HLSL's constant arrays as calls of generated constructors with one parameter
/// per element (`Constructarray64_uint_(uint arg0, …)`), which glslang's HLSL front end
/// refuses ("recursion detected") and compilers parse slowly: each module-scope array (the
/// tables) becomes a `static const` initializer list, and a constructor nothing else calls
/// goes. Zero arrays become lists ([`hlsl_zero_array`]).
fn hlsl_table_initializer(text: &str) -> String {
    let mut constructors = Vec::new();
    let mut lines: Vec<String> = text
        .lines()
        .map(|line| {
            let rewritten = line
                .strip_prefix("static ")
                .and_then(|_| line.split_once(" = Constructarray"))
                .and_then(|(head, call)| {
                    let (name, args) = call.split_once('(')?;
                    let args = args.strip_suffix(");")?;
                    constructors.push(format!("Constructarray{name}"));
                    // Only the data arrays are module-scope arrays: private variables in the
                    // WGSL (see `array_decl`) that nothing writes, `static const` again here.
                    let head = head
                        .strip_prefix("static const ")
                        .unwrap_or(&head["static ".len()..]);
                    Some(format!("static const {head} = {{ {args} }};"))
                });
            rewritten
                .or_else(|| hlsl_zero_array(line))
                .unwrap_or_else(|| line.to_string())
        })
        .collect();
    for constructor in constructors {
        let call = format!("{constructor}(");
        let calls = lines.iter().filter(|l| l.contains(&call)).count();
        // Only its definition's first line names it: drop the typedef and the definition.
        if calls == 1 {
            let typedef = format!("ret_{constructor}[");
            lines.retain(|l| !(l.starts_with("typedef") && l.contains(&typedef)));
            if let Some(start) = lines.iter().position(|l| l.contains(&call)) {
                let end = (start..lines.len())
                    .find(|&i| lines[i].starts_with('}'))
                    .unwrap_or(start);
                lines.drain(start..=end);
            }
        }
    }
    let mut out = lines.join("\n");
    out.push('\n');
    out
}

/// MSL has no module-scope private variables: naga passes each (the filtered form's footprint
/// state, `fp_*`, and `filter_one_value`) down as a `thread T&` parameter of every function that
/// uses one, the exported `_filtered` functions included. There they become locals
/// (zero-initialized; the function sets them before any read), so each keeps the contract's
/// signature `(p, footprint)`.
fn msl_private_locals(text: &str, functions: &[ExportedFunction]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        out.push_str(line);
        out.push('\n');
        let exported = functions
            .iter()
            .filter_map(|f| f.filtered.as_ref())
            .any(|n| line.ends_with(&format!(" {n}(")));
        if !exported {
            continue;
        }
        let (mut params, mut locals) = (Vec::new(), Vec::new());
        for line in lines.by_ref() {
            if line.starts_with(')') {
                let kept = params.len();
                for (k, p) in params.into_iter().enumerate() {
                    let p: &str = p;
                    let p = if k + 1 == kept {
                        p.trim_end_matches(',')
                    } else {
                        p
                    };
                    out.push_str(p);
                    out.push('\n');
                }
                out.push_str(line);
                out.push('\n');
                for local in &locals {
                    let _ = writeln!(out, "    {local} = {{}};");
                }
                break;
            }
            match line.trim().strip_prefix("thread ") {
                Some(param) => locals.push(param.trim_end_matches(',').replacen('&', "", 1)),
                None => params.push(line),
            }
        }
    }
    out
}

/// An array's zero value as naga writes it, `float3 e[3] = (float3[3])0;`, which glslang's
/// HLSL front end refuses, as an initializer list of zeros: `{ (float3)0, (float3)0, … }`.
fn hlsl_zero_array(line: &str) -> Option<String> {
    let (head, cast) = line.split_once(" = (")?;
    let (ty, n) = cast.strip_suffix("])0;")?.split_once('[')?;
    let n: usize = n.parse().ok()?;
    let zeros = vec![format!("({ty})0"); n].join(", ");
    Some(format!("{head} = {{ {zeros} }};"))
}

/// naga numbers every parameter apart (`p_3`, `spacing_1`); in the exported functions they are
/// `p`, `spacing` and `footprint` again, as the contract writes them (their bodies name nothing
/// else).
fn plain_parameters(text: &str, functions: &[ExportedFunction]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut inside = false;
    let mut depth = 0usize;
    for line in text.lines() {
        if !inside && depth == 0 {
            inside = functions.iter().any(|f| {
                f.names()
                    .any(|n| line.contains(&format!(" {n}(")) || line.starts_with(&format!("{n}(")))
            });
        }
        depth += line.matches('{').count();
        depth = depth.saturating_sub(line.matches('}').count());
        if inside {
            out.push_str(&words::rename_words(line, |w| {
                let (base, n) = w.rsplit_once('_')?;
                let numbered = !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit());
                let ours = matches!(base, "p" | "spacing" | "footprint");
                (numbered && ours).then(|| base.to_string())
            }));
            if depth == 0 && line.contains('}') {
                inside = false;
            }
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}
