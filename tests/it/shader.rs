//! `texgraph shader` (issue 35): every graph exported in every language compiles with the
//! languages' own compilers (naga for WGSL, glslang for GLSL 4.50, GLSL ES 3.00 and HLSL), and
//! the exported functions compute the CPU's numbers on a Vulkan adapter (lavapipe in CI).

use crate::common;
use crate::shader_run::{self, Call, Source};
use std::path::{Path, PathBuf};
use std::process::Command;
use texgraph::filter::{Filtered, Footprint};
use texgraph::shader::{export, ExportedFunction, Lang, ShaderOptions};
use texgraph::{CheckOptions, CompileOptions, Tape, Workspace};

/// glslangValidator, or why not: a SKIPPED line without it, a failure with
/// `TEXGRAPH_REQUIRE_GLSLANG=1` (set by .ci/run once Debian's glslang-tools is installed).
fn glslang(test: &str) -> bool {
    let found = Command::new("glslangValidator")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        if std::env::var_os("TEXGRAPH_REQUIRE_GLSLANG").is_some_and(|v| v == "1") {
            panic!("{test}: TEXGRAPH_REQUIRE_GLSLANG=1 but glslangValidator is not found");
        }
        eprintln!("SKIPPED {test}: glslangValidator not found (Debian: glslang-tools)");
    }
    found
}

/// The adapter the numbers run on, or a SKIPPED line (a failure under
/// `TEXGRAPH_REQUIRE_GPU_ADAPTER=1`).
fn runner(test: &str) -> Option<&'static shader_run::Runner> {
    match shader_run::runner() {
        Ok(r) => Some(r),
        Err(e) => {
            if std::env::var_os("TEXGRAPH_REQUIRE_GPU_ADAPTER").is_some_and(|v| v == "1") {
                panic!("{test}: TEXGRAPH_REQUIRE_GPU_ADAPTER=1 but {e}");
            }
            eprintln!("SKIPPED {test}: {e}");
            None
        }
    }
}

pub(crate) fn tape_of(path: &Path, sets: &[(String, f64)]) -> Tape {
    let check = CheckOptions {
        overrides: sets.to_vec(),
    };
    texgraph::load_tape(path, &check, &CompileOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .1
}

pub(crate) fn exported(tape: &Tape, lang: Lang) -> texgraph::shader::Exported {
    export(
        tape,
        &ShaderOptions {
            lang,
            version: None,
            filtered: true,
        },
        None,
    )
    .unwrap_or_else(|e| panic!("{}: {e}", lang.name()))
}

/// A fragment shader (or HLSL pixel shader) that calls every exported function and its `_lod`
/// form, as an engine's shader would.
fn stub(lang: Lang, source: &str, functions: &[ExportedFunction]) -> String {
    let mut sum = Vec::new();
    for f in functions {
        let pick = if f.channels == 1 { "" } else { ".x" };
        sum.push(format!("{}(p){pick} + {}(p, 0.01){pick}", f.name, f.lod));
        if let Some(filtered) = &f.filtered {
            let footprint = match lang {
                Lang::Hlsl => "float3x3(p, p.yzx, float3(0.0, 0.0, 0.0))",
                _ => "mat3(p, p.yzx, vec3(0.0))",
            };
            sum.push(format!("{filtered}(p, {footprint}){pick}"));
        }
    }
    let sum = if sum.is_empty() {
        "0.0".to_string()
    } else {
        sum.join(" + ")
    };
    match lang {
        Lang::Glsl => format!(
            "#version 450\n{source}\nlayout(location = 0) out vec4 o;\n\
             void main() {{ vec3 p = gl_FragCoord.xyz; o = vec4({sum}); }}\n"
        ),
        Lang::GlslEs => format!(
            "#version 300 es\n{source}\nlayout(location = 0) out highp vec4 o;\n\
             void main() {{ vec3 p = gl_FragCoord.xyz; o = vec4({sum}); }}\n"
        ),
        Lang::Hlsl => format!(
            "{source}\nfloat4 main(float4 at : SV_Position) : SV_Target {{ float3 p = at.xyz; return float4(({sum}).xxxx); }}\n"
        ),
        _ => unreachable!(),
    }
}

/// glslangValidator on `text` (a file named for its stage): Ok, or its messages.
fn glslang_compile(dir: &Path, name: &str, text: &str, hlsl: bool) -> Result<(), String> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let mut command = Command::new("glslangValidator");
    if hlsl {
        // `-Od`: without spirv-opt's legalization passes (seconds per graph); the front end
        // and the SPIR-V generation still run.
        command.args(["-V", "-D", "-Od", "-S", "frag", "-e", "main", "-o"]);
        command.arg(dir.join(format!("{name}.spv")));
    }
    let out = command.arg(&path).output().expect("glslangValidator runs");
    if out.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&out.stdout)
            .chars()
            .take(2000)
            .collect())
    }
}

/// The signature each language gives an exported function.
fn signature(lang: Lang, f: &ExportedFunction) -> String {
    let scalar = f.channels == 1;
    match lang {
        Lang::Wgsl => format!(
            "fn {}(p: vec3<f32>) -> {}",
            f.name,
            if scalar { "f32" } else { "vec3<f32>" }
        ),
        Lang::Glsl | Lang::GlslEs => {
            format!("{} {}(vec3 ", if scalar { "float" } else { "vec3" }, f.name)
        }
        Lang::Hlsl => format!(
            "{} {}(float3 ",
            if scalar { "float" } else { "float3" },
            f.name
        ),
        Lang::Msl => format!(
            "{} {}(\n    metal::float3 ",
            if scalar { "float" } else { "metal::float3" },
            f.name
        ),
    }
}

/// The signature each language gives an exported `_filtered` function, in full.
fn filtered_signature(lang: Lang, f: &ExportedFunction, filtered: &str) -> String {
    let scalar = f.channels == 1;
    match lang {
        Lang::Wgsl => format!(
            "fn {filtered}(p: vec3<f32>, footprint: mat3x3<f32>) -> {}",
            if scalar { "f32" } else { "vec3<f32>" }
        ),
        Lang::Glsl | Lang::GlslEs => format!(
            "{} {filtered}(vec3 p, mat3x3 footprint)",
            if scalar { "float" } else { "vec3" }
        ),
        Lang::Hlsl => format!(
            "{} {filtered}(float3 p, float3x3 footprint)",
            if scalar { "float" } else { "float3" }
        ),
        Lang::Msl => format!(
            "{} {filtered}(\n    metal::float3 p,\n    metal::float3x3 footprint\n)",
            if scalar { "float" } else { "metal::float3" }
        ),
    }
}

/// Every graph of `graphs/` and `graphs/library/` in every language, with and without
/// `--uniforms`: WGSL validates with naga (no f64 capability), GLSL 4.50 and GLSL ES 3.00
/// compile with glslang inside a fragment shader calling every function, HLSL with glslang's
/// HLSL front end (glslang: every graph with `TEXGRAPH_FULL=1`, else [`common::covering`]'s),
/// MSL is written; each function has the contract's name and signature.
#[test]
fn every_graph_compiles_in_every_language() {
    let compile = glslang("every_graph_compiles_in_every_language");
    let dir = tempfile::tempdir().unwrap();
    let graphs = common::graph_files();
    // glslang (a process per source, half the test's time) compiles every graph with
    // `TEXGRAPH_FULL=1`, else the graphs that together use every instruction form.
    let glslang_set = if common::full() {
        graphs.clone()
    } else {
        common::covering(&graphs)
    };
    // Two workers over the graphs.
    let (counts, failures) = std::thread::scope(|scope| {
        let workers: Vec<_> = graphs
            .chunks(graphs.len().div_ceil(2).max(1))
            .map(|chunk| {
                let (glslang_set, dir) = (&glslang_set, dir.path());
                scope.spawn(move || compile_graphs(chunk, compile, glslang_set, dir))
            })
            .collect();
        let mut all = ([0usize; 5], Vec::new());
        for worker in workers {
            let (counts, failures) = worker.join().expect("a compiling worker");
            (0..5).for_each(|l| all.0[l] += counts[l]);
            all.1.extend(failures);
        }
        all
    });
    eprintln!("compiled per language (wgsl, glsl, glsl-es, hlsl, msl): {counts:?}");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// [`every_graph_compiles_in_every_language`] over `graphs`: per language how many compiled,
/// and what failed (glslang only where `compile`, on the graphs of `glslang_set`).
fn compile_graphs(
    graphs: &[PathBuf],
    compile: bool,
    glslang_set: &[PathBuf],
    dir: &Path,
) -> ([usize; 5], Vec<String>) {
    let mut failures = Vec::new();
    let mut counts = [0usize; 5];
    for path in graphs {
        let compile = compile && glslang_set.contains(path);
        let tape = tape_of(path, &[]);
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        for (l, lang) in Lang::ALL.into_iter().enumerate() {
            let e = exported(&tape, lang);
            for f in &e.functions {
                let mut expected = vec![signature(lang, f)];
                match &f.filtered {
                    Some(filtered) => expected.push(filtered_signature(lang, f, filtered)),
                    None => failures.push(format!("{stem} {}: no _filtered form", lang.name())),
                }
                for text in expected.iter().filter(|t| !e.source.contains(t.as_str())) {
                    failures.push(format!("{stem} {}: no `{text}`", lang.name()));
                }
            }
            let result = match lang {
                Lang::Wgsl => validate_wgsl(&e.source),
                Lang::Msl => Ok(()),
                _ if !compile => Ok(()),
                Lang::Hlsl => glslang_compile(
                    dir,
                    &format!("{stem}.hlsl"),
                    &stub(lang, &e.source, &e.functions),
                    true,
                ),
                _ => glslang_compile(
                    dir,
                    &format!("{stem}_{}.frag", lang.name()),
                    &stub(lang, &e.source, &e.functions),
                    false,
                ),
            };
            match result {
                Ok(()) => counts[l] += 1,
                Err(why) => failures.push(format!("{stem} {}: {why}", lang.name())),
            }
        }
    }
    (counts, failures)
}

fn validate_wgsl(source: &str) -> Result<(), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .map(|_| ())
    .map_err(|e| e.emit_to_string(source))
}

/// `n` points in the unit cube (the default bake region), f32-exact, and spacings for the
/// level-of-detail forms: 0 (no level of detail: the point form's value) at every other point,
/// else between 1e-4 and 1e-1.
pub(crate) fn unit_points(n: usize, seed: u64) -> Vec<[f32; 4]> {
    let mut lcg = common::lcg(seed);
    let mut next = move || (lcg() >> 40) as f32 / (1u64 << 24) as f32;
    (0..n)
        .map(|i| {
            let h = if i % 2 == 0 {
                0.0
            } else {
                10f32.powf(-1.0 - 3.0 * next())
            };
            [next(), next(), next(), h]
        })
        .collect()
}

/// The shader contract (docs/shaders.md, "Accuracy"): per channel, |shader − f64 reference| is
/// at most 2e-5 · max(1, |v|) + 4 × the CPU f32 path's own largest error over the points (the
/// GPU path's contract, docs/gpu.md), plus, per point, 4 × what f32 positions cannot resolve
/// there: how far the f64 reference moves when the point moves by 2 f32 ulps (an engine passes
/// f32 positions, and the shader's vec3 arithmetic is f32 where the CPU's is f64). A point
/// whose value is outside that bound passes when it is within the bound of the reference at a
/// point up to 32 f32 ulps away along an axis or a diagonal: where a discontinuity (a step, a
/// floor, a ramp's `Constant` stops, a cell edge) passes that close, f32 arithmetic may land on
/// either side. Returns the largest error at the points that needed no neighbour and the
/// largest ratio of an error to its bound, or what broke the contract.
pub(crate) fn shader_contract(
    tape: &Tape,
    points: &[[f32; 4]],
    lod: bool,
    on_gpu: &[f32],
) -> Result<(f64, f64), String> {
    let n = points.len();
    let plane = |c: usize, step: i32| -> Vec<f64> {
        points
            .iter()
            .map(|p| {
                let mut v = p[c];
                for _ in 0..step.abs() {
                    v = if step > 0 { v.next_up() } else { v.next_down() };
                }
                v as f64
            })
            .collect()
    };
    let h: Vec<f64> = points.iter().map(|p| p[3] as f64).collect();
    // The reference with each coordinate moved by its own number of ulps.
    let eval_at = |steps: [i32; 3]| -> Vec<f64> {
        let (x, y, z) = (plane(0, steps[0]), plane(1, steps[1]), plane(2, steps[2]));
        let mut out = vec![0f64; tape.channels() * n];
        if lod {
            tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &h, &mut out);
        } else {
            tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut out);
        }
        out
    };
    // Evaluated only if a point needs them.
    let neighbours = std::cell::OnceCell::new();
    let neighbours = || {
        neighbours.get_or_init(|| {
            [
                [32, 0, 0],
                [-32, 0, 0],
                [0, 32, 0],
                [0, -32, 0],
                [0, 0, 32],
                [0, 0, -32],
                [32, 32, 32],
                [-32, -32, -32],
            ]
            .into_iter()
            .map(eval_at)
            .collect::<Vec<Vec<f64>>>()
        })
    };
    let reference = eval_at([0; 3]);
    let (down, up) = (eval_at([-2; 3]), eval_at([2; 3]));
    let (x, y, z) = (plane(0, 0), plane(1, 0), plane(2, 0));
    let mut cpu = vec![0f32; tape.channels() * n];
    if lod {
        tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], &h, &mut cpu);
    } else {
        tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut cpu);
    }
    let error = |v: f64, r: f64| match (v.is_nan(), r.is_nan()) {
        (true, true) => 0.0,
        (false, false) if v == r => 0.0,
        (false, false) => (v - r).abs(),
        _ => f64::INFINITY,
    };
    let (mut worst, mut ratio) = (0f64, 0f64);
    for c in 0..tape.channels() {
        let k = |i: usize| c * n + i;
        let cpu_error = (0..n)
            .map(|i| error(cpu[k(i)] as f64, reference[k(i)]))
            .fold(0.0, f64::max);
        let scale = (0..n)
            .map(|i| reference[k(i)].abs())
            .filter(|r| r.is_finite())
            .fold(1f64, f64::max);
        for i in 0..n {
            let r = reference[k(i)];
            let unresolved = error(down[k(i)], r).max(error(up[k(i)], r));
            let bound = 2e-5 * scale + 4.0 * cpu_error + 4.0 * unresolved;
            let v = on_gpu[k(i)] as f64;
            let e = error(v, r);
            // (`e` is never NaN: infinite where exactly one of the two is.)
            let within = e <= bound;
            if !within && neighbours().iter().any(|m| error(v, m[k(i)]) <= bound) {
                continue;
            }
            if !within {
                return Err(format!(
                    "channel {c} at {:?}: shader {} against {r} (error {e:.3e} > bound {bound:.3e}; CPU f32 {cpu_error:.3e}, unresolved {unresolved:.3e})",
                    points[i], on_gpu[k(i)]
                ));
            }
            worst = worst.max(e);
            if e > 0.0 {
                ratio = ratio.max(e / bound);
            }
        }
    }
    Ok((worst, ratio))
}

/// Whether a run takes the graph `stem`: those of `set`, or every graph with
/// `TEXGRAPH_FULL=1`; of those, with `TEXGRAPH_SHADER_ONLY=a,b`, the ones whose name
/// contains `a` or `b` (while debugging, or to time a few).
pub(crate) fn selected(stem: &str, set: &[&str]) -> bool {
    let only = std::env::var("TEXGRAPH_SHADER_ONLY").unwrap_or_default();
    (common::full() || set.contains(&stem)) && only.split(',').any(|o| stem.contains(o))
}

/// The points a run of `call`'s form takes, as the input buffer's floats (`call.stride()` a
/// point), and the contract its values are held to: the `_lod` form at 4096 points of the
/// unit cube, [`shader_contract`]; the `_filtered` form at 4096 points with footprints,
/// [`filtered_contract`].
pub(crate) fn run_of(call: Call) -> (Vec<f32>, Box<Contract>) {
    match call {
        Call::Filtered => {
            let points = filtered_points(4096, 36);
            let input = points
                .iter()
                .flat_map(|(p, e)| p.iter().chain(e.iter().flatten()).copied())
                .collect();
            (
                input,
                Box::new(move |tape, out| filtered_contract(tape, &points, out)),
            )
        }
        Call::Lod | Call::Point => {
            let points = unit_points(4096, 35);
            let input = points.iter().flatten().copied().collect();
            let lod = call == Call::Lod;
            (
                input,
                Box::new(move |tape, out| shader_contract(tape, &points, lod, out)),
            )
        }
    }
}

/// A contract over a tape's values read back: the largest error and largest error / bound.
pub(crate) type Contract = dyn Fn(&Tape, &[f32]) -> Result<(f64, f64), String>;

/// What a run over graphs found: the graphs that broke the contract, the largest error and
/// ratio to its bound among those that met it.
#[derive(Default)]
pub(crate) struct Tally {
    failures: Vec<String>,
    worst: f64,
    ratio: f64,
    matched: usize,
}

impl Tally {
    pub(crate) fn record(&mut self, stem: &str, result: Result<(f64, f64), String>) {
        match result {
            Ok((w, r)) => {
                self.worst = self.worst.max(w);
                self.ratio = self.ratio.max(r);
                self.matched += 1;
            }
            Err(why) => self.failures.push(format!("{stem}: {why}")),
        }
    }

    /// Prints the figures and fails the test with every graph that broke the contract (or
    /// when no graph ran, unless `TEXGRAPH_SHADER_ONLY` picked none).
    pub(crate) fn finish(self, test: &str, device: &str) {
        eprintln!(
            "{test} on {device}: {} graphs matched, largest error {:.3e}, largest error / bound {:.3}",
            self.matched, self.worst, self.ratio
        );
        assert!(self.failures.is_empty(), "{}", self.failures.join("\n"));
        assert!(
            self.matched > 0 || std::env::var_os("TEXGRAPH_SHADER_ONLY").is_some(),
            "no graph was run"
        );
    }
}

/// Runs every graph's exported functions in `lang` (WGSL, or GLSL 4.50 through glslang's
/// SPIR-V) on the adapter, `call`'s form at [`run_of`]'s points, against the CPU.
fn every_graph_matches(test: &str, lang: Lang, subset: &[&str], call: Call) {
    let Some(runner) = runner(test) else { return };
    if lang == Lang::Glsl && !glslang(test) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let (input, contract) = run_of(call);
    let n = input.len() / call.stride();
    let mut tally = Tally::default();
    for path in common::graph_files() {
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&stem, subset) {
            continue;
        }
        let tape = tape_of(&path, &[]);
        let e = exported(&tape, lang);
        if call == Call::Filtered && e.functions.iter().any(|f| f.filtered.is_none()) {
            tally.record(&stem, Err("no filtered form exported".into()));
            continue;
        }
        let started = std::time::Instant::now();
        let source = match lang {
            Lang::Wgsl => Ok(Source::Wgsl(format!(
                "{}{}",
                e.source,
                shader_run::wgsl_entry(&e.functions, n, call)
            ))),
            _ => {
                let text = shader_run::glsl_entry(&e.source, &e.functions, n, call);
                spirv(dir.path(), &stem, &text).map(Source::SpirV)
            }
        };
        let result = source
            .and_then(|source| runner.run(source, (&input, call), tape.channels(), None))
            .and_then(|out| contract(&tape, &out));
        let seconds = started.elapsed().as_secs_f64();
        match &result {
            Ok((worst, ratio)) => {
                eprintln!("{stem}: {seconds:.2} s, error {worst:.3e}, error / bound {ratio:.3}")
            }
            Err(_) => eprintln!("{stem}: {seconds:.2} s, FAILED"),
        }
        tally.record(&stem, result);
    }
    tally.finish(test, &runner.name);
}

/// GLSL compiled to SPIR-V words by glslang.
fn spirv(dir: &Path, stem: &str, text: &str) -> Result<Vec<u32>, String> {
    let source = dir.join(format!("{stem}.comp"));
    let out = dir.join(format!("{stem}.spv"));
    std::fs::write(&source, text).unwrap();
    let run = Command::new("glslangValidator")
        .args(["-V", "--target-env", "vulkan1.1", "-o"])
        .arg(&out)
        .arg(&source)
        .output()
        .expect("glslangValidator runs");
    if !run.status.success() {
        return Err(String::from_utf8_lossy(&run.stdout)
            .chars()
            .take(2000)
            .collect());
    }
    let bytes = std::fs::read(&out).unwrap();
    Ok(bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

/// What `cargo test` runs on lavapipe (`TEXGRAPH_FULL=1`: every graph): every basis
/// (Perlin, Gradient, Value, Simplex, cellular, white), every fractal style, tiling, warps,
/// ramps and the seeds' math, in graphs lavapipe compiles in seconds. Mesa lowers a table read
/// at a run-time index to a ladder of branches over the array, so a library graph with a dozen
/// noise instructions takes 10 to 30 s to compile there (a GPU driver reads the table in
/// place); the whole set, 260 s cold, is run before each stop and its figures are in
/// docs/shaders.md. (Left out for time: `seed000_fractal_noise`, 10 s, a second Gradient-basis
/// fractal; `stone`, 4 s, a second cellular graph.)
const WGSL_SET: &[&str] = &[
    "cells",
    "ridged_rock",
    "tiling_marble",
    "warped_wood",
    "floor_tiles",
    "seed000_gradient_noise",
    "seed000_wood_rings",
    "seed002_marble",
    "seed002_noise",
    "seed002_smooth_noise",
    "seed002_sine",
    "seed002_turbulence",
    "seed002_wood",
    "seed002_woodgrain",
    "seed003_marble",
    "seed004_checker2d",
    "seed004_checker3d",
    "seed004_colour_cube",
    "seed004_marble",
    "seed004_noise",
    "seed004_rings",
    "seed004_stripes",
    "seed004_turbulence",
    "seed004_wood_grain",
];

/// GLSL's share of [`WGSL_SET`] (lavapipe compiles glslang's SPIR-V about twice as slowly):
/// cellular, simplex, Perlin, Value and white noise, tiling, the seeds' math.
const GLSL_SET: &[&str] = &[
    "cells",
    "floor_tiles",
    "ridged_rock",
    "tiling_marble",
    "seed002_noise",
    "seed003_marble",
    "seed004_checker3d",
    "seed004_wood_grain",
];

#[test]
fn exported_wgsl_matches_the_cpu() {
    // The `_lod` forms only (one pipeline a graph: lavapipe's compile is the cost), with
    // spacing 0 at every other point, which is the point form's value (`texgraph_NAME(p)` is
    // `_lod` at 0; its text is compiled by every_graph_compiles_in_every_language).
    every_graph_matches(
        "exported_wgsl_matches_the_cpu",
        Lang::Wgsl,
        WGSL_SET,
        Call::Lod,
    );
}

#[test]
fn exported_glsl_matches_the_cpu() {
    every_graph_matches(
        "exported_glsl_matches_the_cpu",
        Lang::Glsl,
        GLSL_SET,
        Call::Lod,
    );
}

fn marble() -> PathBuf {
    common::crate_root().join("graphs/seed003_marble.ron")
}

/// `--uniforms` (issue 35): the seed 003 marble's `period` changed through the uniform block at
/// run time gives the CPU's values for that period (compiled with `--set period=…`), while
/// `octaves` (it shapes the octave loop) stays a constant and says so.
#[test]
fn a_uniform_changes_the_period_at_run_time() {
    let Some(runner) = runner("a_uniform_changes_the_period_at_run_time") else {
        return;
    };
    let path = marble();
    let graph = texgraph::load_graph(&path, &CheckOptions::default()).unwrap();
    let (plan, general) = texgraph::shader::uniforms::plan(
        &path,
        graph.params(),
        &CheckOptions::default(),
        &CompileOptions::default(),
    )
    .unwrap();
    let fields: Vec<(&str, bool)> = plan
        .params
        .iter()
        .map(|p| (p.field.as_str(), p.constant.is_none()))
        .collect();
    assert_eq!(
        fields,
        [
            ("scale", true),
            ("period", true),
            ("distortion", true),
            ("octaves", false)
        ]
    );
    let tape = general.expect("a tape with the uniforms' slots");
    let options = ShaderOptions {
        lang: Lang::Wgsl,
        version: None,
        filtered: false,
    };
    let e = export(&tape, &options, Some(&plan)).unwrap();
    let points = unit_points(4096, 7);
    let input: Vec<f32> = points.iter().flatten().copied().collect();
    for period in [1.3f32, 2.5, -0.75] {
        // The block: every param in the graph's order (scale, period, distortion, octaves).
        let block = [1.0, period, 3.0, 12.0];
        let source = Source::Wgsl(format!(
            "{}{}",
            e.source,
            shader_run::wgsl_entry(&e.functions, points.len(), Call::Point)
        ));
        let out = runner
            .run(source, (&input, Call::Point), tape.channels(), Some(&block))
            .unwrap();
        let cpu = tape_of(&path, &[("period".into(), period as f64)]);
        let (worst, ratio) = shader_contract(&cpu, &points, false, &out)
            .unwrap_or_else(|e| panic!("period {period}: {e}"));
        eprintln!("period {period} through the uniform: largest error {worst:.3e} ({ratio:.3} of its bound)");
    }
}

/// The engine templates of `examples/shader/` with the seed 003 marble's `colour` exported
/// into them: the Bevy material's WGSL validates with naga (its `#import` replaced by the
/// `VertexOutput` fields it reads), the WebGL 2 page's fragment shader compiles with glslang as
/// GLSL ES 3.00. (The Godot shader is Godot's own language: no compiler here.)
#[test]
fn engine_templates_compile() {
    let tape = texgraph::load_tape(
        &marble(),
        &CheckOptions::default(),
        &CompileOptions {
            outputs: vec!["colour".into()],
            ..Default::default()
        },
    )
    .unwrap()
    .1;
    let root = common::crate_root().join("examples/shader");
    let bevy = std::fs::read_to_string(root.join("bevy_material.wgsl")).unwrap();
    let wgsl = exported(&tape, Lang::Wgsl).source;
    let module = bevy
        .replace(
            "#import bevy_pbr::forward_io::VertexOutput",
            "struct VertexOutput {\n    @builtin(position) position: vec4<f32>,\n    @location(0) world_position: vec4<f32>,\n}",
        )
        .replace("// TEXGRAPH EXPORT HERE", &wgsl);
    assert!(module.contains("fn texgraph_colour_lod("));
    validate_wgsl(&module).unwrap_or_else(|e| panic!("bevy_material.wgsl: {e}"));
    if !glslang("engine_templates_compile") {
        return;
    }
    let page = std::fs::read_to_string(root.join("webgl2.html")).unwrap();
    let body = &page[page.find("function fragment(exported, scalar) {").unwrap()..];
    let start = body.find("return `").unwrap() + "return `".len();
    let template = &body[start..start + body[start..].find("`;\n}").unwrap()];
    let glsl = exported(&tape, Lang::GlslEs).source;
    let dir = tempfile::tempdir().unwrap();
    // The page's two forms (`form=lod`, `form=filtered`), as its script writes the calls.
    for call in [
        "texgraph_colour_lod(p, spacing)",
        "texgraph_colour_filtered(p, mat3(dFdx(p), dFdy(p), vec3(0.0)))",
    ] {
        assert!(
            page.contains(&call.replace("texgraph_colour", "${fn}")),
            "{call}"
        );
        let fragment = template
            .replace("${exported}", &glsl)
            .replace("${value}", call)
            .replace("${scale.toFixed(6)}", "1.000000");
        assert!(
            !fragment.contains("${"),
            "a placeholder of the page is not filled in"
        );
        glslang_compile(dir.path(), "page.frag", &fragment, false)
            .unwrap_or_else(|e| panic!("webgl2.html's fragment shader with {call}: {e}"));
    }
}

/// Points of the unit cube (f32) each with a footprint (three edges, f32): cubes of sides 1/2,
/// 1/8, 1/32 and 1/256, a voxel box, two anisotropic pixel parallelograms, a point.
pub(crate) fn filtered_points(n: usize, seed: u64) -> Vec<([f32; 3], [[f32; 3]; 3])> {
    let cube = |w: f32| [[w, 0.0, 0.0], [0.0, w, 0.0], [0.0, 0.0, w]];
    unit_points(n, seed)
        .into_iter()
        .enumerate()
        .map(|(i, q)| {
            let edges = match i % 8 {
                0 => cube(0.5),
                1 => cube(0.125),
                2 => cube(1.0 / 32.0),
                3 => cube(1.0 / 256.0),
                4 => [[0.3, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.07]],
                5 => [[0.2, 0.05, 0.0], [0.0, 0.01, 0.003], [0.0; 3]],
                6 => [[0.15, -0.07, 0.02], [0.001, 0.002, -0.003], [0.0; 3]],
                _ => [[0.0; 3]; 3],
            };
            ([q[0], q[1], q[2]], edges)
        })
        .collect()
}

/// The filtered contract (docs/shaders.md, "Accuracy"): per channel, |shader − CPU filtered
/// estimate (f64 rules)| ≤ [`FILTERED_TOLERANCE`] · max(1, |v|). Returns the largest such
/// relative error and its ratio to the tolerance, or the first point that breaks it.
pub(crate) fn filtered_contract(
    tape: &Tape,
    points: &[([f32; 3], [[f32; 3]; 3])],
    on_gpu: &[f32],
) -> Result<(f64, f64), String> {
    let n = points.len();
    let [x, y, z] = [0, 1, 2].map(|c| points.iter().map(|p| p.0[c] as f64).collect::<Vec<f64>>());
    let footprints: Vec<Footprint> = points
        .iter()
        .map(|p| Footprint::from_edges(p.1.map(|e| e.map(f64::from))).expect("a footprint"))
        .collect();
    let mut cpu = vec![0f64; tape.channels() * n];
    Filtered::new(tape).eval_batch([&x, &y, &z], &footprints, &mut cpu);
    let mut worst = 0f64;
    for (k, (&c, &g)) in cpu.iter().zip(on_gpu).enumerate() {
        let g = f64::from(g);
        let err = match (c.is_finite(), g.is_finite()) {
            (true, true) => (c - g).abs() / c.abs().max(1.0),
            (false, false) => 0.0,
            _ => f64::INFINITY,
        };
        if err > FILTERED_TOLERANCE {
            let (i, ch) = (k % n, k / n);
            return Err(format!(
                "channel {ch} at {:?} over {:?}: shader {g} against the CPU's {c} (relative error {err:.2e} > {FILTERED_TOLERANCE:.0e})",
                points[i].0, points[i].1
            ));
        }
        worst = worst.max(err);
    }
    Ok((worst, worst / FILTERED_TOLERANCE))
}

/// How far an exported `_filtered` function may be from the CPU's filtered estimate, relative
/// to max(1, |v|): the same rules, in f32 instead of f64 (the largest seen over every graph is
/// 1.4e-4), a tenth of what the estimates are off from the true means (docs/filtering.md).
pub(crate) const FILTERED_TOLERANCE: f64 = 1e-3;

/// What `cargo test` runs of the filtered forms on lavapipe (`TEXGRAPH_FULL=1`: every
/// graph): plain noise through a ramp, a sine, the lattice `mod` of a checker, a periodic
/// chain. lavapipe inlines every call: a seed graph's filtered shader compiles in 1 to 40 s
/// (the seed 003 marble's 24 s: run before stops), `floor_tiles` took more than 13 minutes and
/// 12 GB (docs/shaders.md).
const FILTERED_SET: &[&str] = &[
    "seed002_noise",
    "seed002_sine",
    "seed004_checker3d",
    "seed004_stripes",
];

/// What `cargo test` runs of the GLSL `_filtered` forms on lavapipe (`TEXGRAPH_FULL=1`:
/// every graph): glslang's SPIR-V of the same functions as [`FILTERED_SET`]'s first graph.
const GLSL_FILTERED_SET: &[&str] = &["seed002_noise"];

/// Every graph's exported WGSL `_filtered` functions on the adapter at 4096 points of the unit
/// cube with footprints from a point to half the cube, against the CPU's filtered estimates.
#[test]
fn exported_filtered_matches_the_cpu() {
    every_graph_matches(
        "exported_filtered_matches_the_cpu",
        Lang::Wgsl,
        FILTERED_SET,
        Call::Filtered,
    );
}

/// [`exported_filtered_matches_the_cpu`] for GLSL 4.50, through glslang's SPIR-V.
#[test]
fn exported_glsl_filtered_matches_the_cpu() {
    every_graph_matches(
        "exported_glsl_filtered_matches_the_cpu",
        Lang::Glsl,
        GLSL_FILTERED_SET,
        Call::Filtered,
    );
}
