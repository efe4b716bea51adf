//! Helpers shared by the test modules (`use crate::common;`).

use std::collections::BTreeSet;
use texgraph::nodes::CATALOGUE;
use texgraph::{Real, Tape, Workspace};

/// Whether this run re-blesses goldens: `TEXGRAPH_BLESS=1` (the one documented variable for every
/// golden of the project: values, pictures, tapes, diagnostics).
pub fn blessing() -> bool {
    std::env::var_os("TEXGRAPH_BLESS").is_some_and(|v| v == "1")
}

/// Whether the slow sets run whole: `TEXGRAPH_FULL=1` (`bash .ci/run --full`, run before each
/// closing note), the one switch for all of them. Without it, the tests that compile a
/// pipeline per graph on lavapipe or a source per graph with glslang take [`covering`]'s
/// graphs or their listed sets, and the GPU property test fewer cases, so that `cargo test`
/// runs in minutes.
pub fn full() -> bool {
    std::env::var_os("TEXGRAPH_FULL").is_some_and(|v| v == "1")
}

/// What one instruction asks of an evaluator, from its disassembly line
/// (`0004  v0 = ramp s0 Smooth [...]`) and its precision: its operation, the words that select
/// a variant of it (a basis, a style, a metric, `key=word` settings; not numbers, slot names
/// or tables), and `wide` for a promoted (f64) instruction.
fn instruction_forms(line: &str, wide: bool) -> Vec<String> {
    let Some((_, rest)) = line.split_once(" = ") else {
        return Vec::new();
    };
    let body = rest.split(" ; ").next().unwrap_or(rest);
    let mut words = body.split('[').next().unwrap_or(body).split_whitespace();
    let Some(op) = words.next() else {
        return Vec::new();
    };
    // A slot, or a component of one (`v10.x`).
    let slot = |w: &str| {
        let w = w.split('.').next().unwrap_or(w);
        w.len() > 1
            && w[1..].chars().all(|c| c.is_ascii_digit())
            && w.starts_with(['s', 'v', 'd', 'w'])
    };
    // A component of a vec3 slot (`s4 = v1.x`): one form whatever the slot.
    let op = match op.split_once('.') {
        Some((_, c)) if slot(op) => format!("component {c}"),
        _ => op.to_string(),
    };
    let op = op.as_str();
    let mut forms = vec![op.to_string()];
    if wide {
        forms.push(format!("{op} wide"));
    }
    for word in words.map(|w| w.trim_end_matches(',')).filter(|w| !slot(w)) {
        let variant = match word.split_once('=') {
            // A setting's number or tuple is not a variant; a varying setting (any slot) is one.
            Some((key, value)) if slot(value) => &format!("{key}=slot"),
            Some((key, value)) if value.parse::<f64>().is_ok() || value.starts_with('(') => key,
            Some(_) => word,
            None if word.chars().all(|c| c.is_ascii_alphabetic()) => word,
            None => continue,
        };
        forms.push(format!("{op} {variant}"));
    }
    forms
}

/// The instruction forms ([`instruction_forms`]) of the graph at `path`, compiled by default,
/// and its instruction count.
fn tape_forms(path: &std::path::Path) -> (usize, BTreeSet<String>) {
    let options = texgraph::CompileOptions::default();
    let (_, tape) = texgraph::load_tape(path, &texgraph::CheckOptions::default(), &options)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let text = tape.to_string();
    // The numbered lines are the instructions, in order (the others: constants, outputs).
    let lines = text.lines().filter(|l| {
        l.split_whitespace()
            .next()
            .is_some_and(|w| w.chars().all(|c| c.is_ascii_digit()))
    });
    let forms = lines
        .zip(tape.instructions())
        .flat_map(|(line, i)| instruction_forms(line, i.prec() == texgraph::tape::Prec::Wide))
        .collect();
    (tape.instructions().len(), forms)
}

/// Of `graphs`, a few that together use every instruction form (operation, variant words,
/// width; see [`instruction_forms`]) that any of them uses in its tape compiled by default:
/// picked greedily, the graph adding most new forms per instruction first (what a driver
/// compiles grows with the tape), then without each graph whose forms the others hold, the
/// longest first. A graph with a new instruction, basis or style joins the set by itself.
/// (Issue 46: 14 graphs of 520 instructions, against 14 of 706 when the most forms went
/// first and a vec3 slot's component or a setting's slot counted as a form of its own.)
pub fn covering(graphs: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
    let forms: Vec<(usize, BTreeSet<String>)> = graphs.iter().map(|p| tape_forms(p)).collect();
    let mut missing: BTreeSet<String> = forms.iter().flat_map(|(_, f)| f.clone()).collect();
    let mut chosen: Vec<usize> = Vec::new();
    while !missing.is_empty() {
        // The most new forms per instruction (a graph's instructions: what a driver compiles).
        let (best, _) = forms
            .iter()
            .enumerate()
            .map(|(i, (len, f))| {
                (
                    i,
                    f.intersection(&missing).count() as f64 / (*len).max(1) as f64,
                )
            })
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .expect("a graph");
        missing.retain(|form| !forms[best].1.contains(form));
        chosen.push(best);
    }
    // Then without the graphs the others cover, the longest first.
    chosen.sort_by_key(|&i| std::cmp::Reverse(forms[i].0));
    let mut k = 0;
    while k < chosen.len() {
        let others: BTreeSet<&String> = chosen
            .iter()
            .filter(|&&j| j != chosen[k])
            .flat_map(|&j| &forms[j].1)
            .collect();
        if forms[chosen[k]].1.iter().all(|f| others.contains(f)) {
            chosen.remove(k);
        } else {
            k += 1;
        }
    }
    let mut chosen: Vec<std::path::PathBuf> =
        chosen.into_iter().map(|i| graphs[i].clone()).collect();
    chosen.sort();
    chosen
}

/// The covering set uses every form some graph uses, and each of its graphs adds a form the
/// others lack.
#[test]
fn the_covering_set_has_every_form_and_no_spare_graph() {
    let graphs = graph_files();
    let all: BTreeSet<String> = graphs.iter().flat_map(|p| tape_forms(p).1).collect();
    let set = covering(&graphs);
    let forms: Vec<BTreeSet<String>> = set.iter().map(|p| tape_forms(p).1).collect();
    let union: BTreeSet<String> = forms.iter().flatten().cloned().collect();
    assert_eq!(union, all, "the covering set misses forms");
    for (k, path) in set.iter().enumerate() {
        let others: BTreeSet<&String> = forms
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != k)
            .flat_map(|(_, f)| f)
            .collect();
        let own: Vec<&String> = forms[k].iter().filter(|f| !others.contains(f)).collect();
        assert!(!own.is_empty(), "{} adds no form", path.display());
        eprintln!("{}: {own:?}", path.display());
    }
}

/// Every graph of `graphs/` and `graphs/library/` with [`full`], else [`covering`] them.
pub fn slow_set() -> Vec<std::path::PathBuf> {
    let graphs = graph_files();
    if full() {
        graphs
    } else {
        covering(&graphs)
    }
}

/// The node kinds a graph text uses: every identifier outside string literals that names a
/// catalogue kind (`Position` bare, the others before their parentheses).
pub fn kinds_used(text: &str) -> BTreeSet<&'static str> {
    let mut found = BTreeSet::new();
    let mut word = String::new();
    let mut in_string = false;
    let mut escaped = false;
    for c in text.chars().chain(std::iter::once(' ')) {
        if in_string {
            match (escaped, c) {
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => escaped = false,
            }
            continue;
        }
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
            continue;
        }
        if let Some(def) = CATALOGUE.iter().find(|d| d.name == word) {
            found.insert(def.name);
        }
        word.clear();
        in_string = c == '"';
    }
    found
}

/// The catalogue kinds missing from `found`, for a coverage test's message.
pub fn kinds_missing(found: &BTreeSet<&'static str>) -> Vec<&'static str> {
    CATALOGUE
        .iter()
        .map(|d| d.name)
        .filter(|name| !found.contains(name))
        .collect()
}

/// A fenced code block of a document: its info string (`ron`, `ron invalid`, `text`), its text
/// (fence indentation removed) and the 1-based line of its opening fence.
pub struct Block {
    pub info: String,
    pub text: String,
    pub line: usize,
}

/// The fenced code blocks of the document `name` (its text `doc`). A line opens a block when it
/// starts with three backticks and its info string has none (inline code such as
/// ```` ```ron ```` does not); a block never closed fails the test.
pub fn code_blocks(name: &str, doc: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<(Block, usize)> = None;
    for (i, line) in doc.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        match open.take() {
            None => {
                if let Some(info) = trimmed.strip_prefix("```").filter(|i| !i.contains('`')) {
                    let block = Block {
                        info: info.trim().to_string(),
                        text: String::new(),
                        line: i + 1,
                    };
                    open = Some((block, indent));
                }
            }
            Some((block, _)) if trimmed == "```" => blocks.push(block),
            Some((mut block, fence_indent)) => {
                let strip = indent.min(fence_indent);
                block.text.push_str(&line[strip..]);
                block.text.push('\n');
                open = Some((block, fence_indent));
            }
        }
    }
    assert!(open.is_none(), "{name}: a code block is never closed");
    blocks
}

/// How per-point and batch results must agree.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Agree {
    /// Bit for bit, NaN included (the interpreter's promise where NaN is made canonical).
    Bits,
    /// Bit for bit, except that any NaN equals any NaN.
    BitsOrNan,
}

/// The one point = batch harness: evaluates `tape` at `points` per batch (planar: channel `c`
/// of point `i` at `c · n + i`) and per point, both in precision `S`, with fresh workspaces.
/// Returns the batch values, or a message naming the first point and channel that differ.
pub fn point_and_batch<S: Real>(
    tape: &Tape,
    points: &[[f64; 3]],
    agree: Agree,
) -> Result<Vec<S>, String> {
    let n = points.len();
    let x: Vec<f64> = points.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let channels = tape.channels();
    let mut batch = vec![S::ZERO; channels * n];
    tape.eval_batch(&mut Workspace::<S>::new(), &x, &y, &z, &mut batch);
    let mut workspace = Workspace::<S>::new();
    let mut one = vec![S::ZERO; channels];
    for (i, p) in points.iter().enumerate() {
        tape.eval_point(&mut workspace, *p, &mut one);
        for (c, &u) in one.iter().enumerate() {
            let v = batch[c * n + i];
            let (a, b) = (u.to_f64(), v.to_f64());
            let same = a.to_bits() == b.to_bits()
                || (agree == Agree::BitsOrNan && a.is_nan() && b.is_nan());
            if !same {
                return Err(format!(
                    "point {a} vs batch {b} at {p:?}, channel {c} ({})",
                    std::any::type_name::<S>()
                ));
            }
        }
    }
    Ok(batch)
}

/// The crate's folder (graph paths in tests are relative to it).
pub fn crate_root() -> &'static std::path::Path {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Every graph file of `graphs/` and `graphs/library/`, sorted, as paths under
/// [`crate_root`].
pub fn graph_files() -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for dir in ["graphs", "graphs/library"] {
        for entry in std::fs::read_dir(crate_root().join(dir)).expect("graphs folder") {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "ron") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// A graph file of the crate with param overrides: its tape and its params after them.
pub fn load_graph_file(path: &str, overrides: &[(&str, f64)]) -> (Tape, Vec<(String, f64)>) {
    let check = texgraph::CheckOptions {
        overrides: overrides.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
    };
    let (graph, tape) = texgraph::load_tape(
        &crate_root().join(path),
        &check,
        &texgraph::CompileOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{path}: {e}"));
    (tape, graph.params().to_vec())
}

/// The documented voxel centre (docs/baking.md, "The grid"), computed here independently of
/// `Grid::centre`: `region.min + (index + 0.5) · (region.max − region.min) / size`.
pub fn voxel_centre(grid: &texgraph::bake::Grid, axis: usize, index: usize) -> f64 {
    let (lo, hi) = (grid.region.min[axis], grid.region.max[axis]);
    lo + (index as f64 + 0.5) * (hi - lo) / grid.size[axis] as f64
}

/// Each output of `tape` by `eval_point` (f32, a bake's precision) at every voxel centre of
/// `grid`: channels interleaved, x fastest, then y, then z (raw's, KTX2's and zarr's C order).
pub fn expected_volume(tape: &Tape, grid: &texgraph::bake::Grid) -> Vec<Vec<f32>> {
    let mut workspace = Workspace::<f32>::new();
    let mut out = vec![0f32; tape.channels()];
    let mut values = vec![Vec::new(); tape.outputs().len()];
    let [nx, ny, nz] = grid.size;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = [0, 1, 2].map(|a| voxel_centre(grid, a, [i, j, k][a]));
                tape.eval_point(&mut workspace, p, &mut out);
                for (values, o) in values.iter_mut().zip(tape.outputs()) {
                    values.extend_from_slice(&out[o.first_channel..][..o.ty.channels()]);
                }
            }
        }
    }
    values
}

/// `texgraph serve` tests: a server on a free localhost port.
pub fn serve(input: &std::path::Path) -> texgraph::serve::Server {
    serve_sized(input, SMALL_IMAGES)
}

/// Image sizes for the tests that do not check the defaults: a quarter of the default sides
/// (a 128² preview renders 16 times faster than 512² in a debug build, and proves the same).
pub const SMALL_IMAGES: texgraph::serve::Sizes = texgraph::serve::Sizes {
    preview: 128,
    slice: 64,
    thumb: 24,
};

/// [`serve`] with the images' sizes when the page opens.
pub fn serve_sized(
    input: &std::path::Path,
    sizes: texgraph::serve::Sizes,
) -> texgraph::serve::Server {
    texgraph::serve::start(texgraph::serve::ServeOptions {
        input: input.to_path_buf(),
        host: "127.0.0.1".parse().unwrap(),
        port: 0,
        sizes,
    })
    .expect("the server starts")
}

/// The seed 003 marble.
pub const MARBLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/seed003_marble.ron");

/// A copy of the seed 003 marble in a fresh folder.
pub fn marble_copy() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("marble.ron");
    std::fs::copy(MARBLE, &path).unwrap();
    (dir, path)
}

/// Saves `text` the way many editors do: a new file renamed over the old one.
pub fn save_by_rename(path: &std::path::Path, text: &str) {
    let temp = path.with_extension("ron.tmp~");
    std::fs::write(&temp, text).unwrap();
    std::fs::rename(&temp, path).unwrap();
}

/// A fixed 64-bit linear congruential generator (Knuth's MMIX constants): the tests' points,
/// reproducible without a dependency. Each call gives the next state; callers take its high bits.
pub fn lcg(seed: u64) -> impl FnMut() -> u64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        state
    }
}

#[cfg(feature = "gpu")]
/// Whether the GPU tests can run: a usable adapter (lavapipe counts). Without one they say so
/// on stderr with `SKIPPED` and return false, never passing silently; with
/// `TEXGRAPH_REQUIRE_GPU_ADAPTER=1` (set by .ci/run after installing lavapipe) a missing
/// adapter fails the test instead.
pub fn gpu_available(test: &str) -> bool {
    match texgraph::gpu::usable() {
        Ok(_) => true,
        Err(e) => {
            if std::env::var_os("TEXGRAPH_REQUIRE_GPU_ADAPTER").is_some_and(|v| v == "1") {
                panic!("{test}: TEXGRAPH_REQUIRE_GPU_ADAPTER=1 but {e}");
            }
            eprintln!("SKIPPED {test}: {e}");
            false
        }
    }
}

#[cfg(feature = "gpu")]
/// The GPU contract (docs/gpu.md, "Precision"): per output channel, the largest difference of
/// the GPU from the f64 reference over the points is at most 2e-5 (times the channel's largest
/// magnitude, when above 1) plus four times the CPU's f32 path's own largest difference at the
/// same points (the GPU is as exact as the f32 path up to its different rounding, whatever the
/// conditioning of the graph), plus, per point, four times what f64 itself cannot resolve there:
/// how far the reference moves when the point moves up to 4 ulps (the GPU's f64 rounds differently,
/// drivers fuse multiply-adds, so where one ulp flips a cell the GPU may land in the other).
/// Where the reference is NaN the GPU's value is left open: Vulkan drivers may fold
/// NaN-making operations such as `inf · 0` away (Mesa does), so the GPU promises NaN
/// propagation only where it computes the NaN itself. Returns each channel's (GPU error, CPU f32
/// error), or what broke the contract.
pub fn gpu_contract(
    tape: &Tape,
    gpu: &texgraph::gpu::GpuEvaluator,
    points: &[[f64; 3]],
) -> Result<Vec<(f64, f64)>, String> {
    gpu_contract_lod(tape, gpu, points, None)
}

#[cfg(feature = "gpu")]
/// [`gpu_contract`] with level of detail per point (`Tape::eval_batch_lod` on the CPU,
/// `GpuEvaluator::eval_batch_lod` on the GPU) where `spacing` is given.
pub fn gpu_contract_lod(
    tape: &Tape,
    gpu: &texgraph::gpu::GpuEvaluator,
    points: &[[f64; 3]],
    spacing: Option<&[f64]>,
) -> Result<Vec<(f64, f64)>, String> {
    let n = points.len();
    let [x, y, z] = [0, 1, 2].map(|c| points.iter().map(|p| p[c]).collect::<Vec<f64>>());
    let channels = tape.channels();
    let mut reference = vec![0f64; channels * n];
    let mut cpu = vec![0f32; channels * n];
    let mut on_gpu = vec![0f32; channels * n];
    // The reference at the point moved 1 to 4 ulps down and up (every coordinate), and 2 ulps
    // along each axis alone: where a tape is chaotic at f64's resolution (a fine fractal far
    // from the origin) two neighbours alone undersample how far it moves (a random graph at
    // y = 6.9e8 moved 0.06 there and 0.31 on the GPU).
    let moved = |step: fn(f64) -> f64, ulps: usize, axes: [bool; 3]| {
        let shift = |v: f64| (0..ulps).fold(v, |v, _| step(v));
        let [x, y, z] = [(&x, axes[0]), (&y, axes[1]), (&z, axes[2])].map(|(c, on)| {
            c.iter()
                .map(|&v| if on { shift(v) } else { v })
                .collect::<Vec<_>>()
        });
        let mut out = vec![0f64; channels * n];
        match spacing {
            Some(h) => tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], h, &mut out),
            None => tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut out),
        }
        out
    };
    let mut neighbours = Vec::new();
    for step in [f64::next_down as fn(f64) -> f64, f64::next_up] {
        for ulps in 1..=4 {
            neighbours.push(moved(step, ulps, [true; 3]));
        }
        for axis in 0..3 {
            neighbours.push(moved(step, 2, std::array::from_fn(|a| a == axis)));
        }
    }
    match spacing {
        Some(h) => {
            tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], h, &mut reference);
            tape.eval_batch_lod(&mut Workspace::new(), [&x, &y, &z], h, &mut cpu);
            gpu.eval_batch_lod([&x, &y, &z], h, &mut on_gpu)
        }
        None => {
            tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut reference);
            tape.eval_batch(&mut Workspace::new(), &x, &y, &z, &mut cpu);
            gpu.eval_batch(&x, &y, &z, &mut on_gpu)
        }
    }
    .map_err(|e| e.to_string())?;
    let error = |v: f32, r: f64| -> f64 {
        match (v.is_nan(), r.is_nan()) {
            (true, true) => 0.0,
            (false, false) if v as f64 == r => 0.0,
            (false, false) => (v as f64 - r).abs(),
            _ => f64::INFINITY,
        }
    };
    let gpu_error = |v: f32, r: f64| if r.is_nan() { 0.0 } else { error(v, r) };
    // What f64 cannot resolve at point k (infinite where a neighbour is NaN and it is not).
    let unresolved = |k: usize| {
        let r = reference[k];
        neighbours
            .iter()
            .map(|m| m[k])
            .map(|m| match (m.is_nan(), r.is_nan()) {
                (true, true) => 0.0,
                (false, false) => (m - r).abs(),
                _ => f64::INFINITY,
            })
            .fold(0f64, f64::max)
    };
    let mut figures = Vec::with_capacity(channels);
    for c in 0..channels {
        let mut worst_cpu = 0f64;
        for i in 0..n {
            worst_cpu = worst_cpu.max(error(cpu[c * n + i], reference[c * n + i]));
        }
        let scale = (0..n)
            .map(|i| reference[c * n + i].abs())
            .filter(|r| r.is_finite())
            .fold(1f64, f64::max);
        let tolerance = 2e-5 * scale + 4.0 * worst_cpu;
        // The worst point by its excess over its own tolerance.
        let (mut worst_gpu, mut excess, mut at) = (0f64, f64::NEG_INFINITY, 0);
        for (i, point) in points.iter().enumerate() {
            let k = c * n + i;
            // At a point with a non-finite coordinate, `inf − inf` makes NaNs that comparisons,
            // `min` and `max` meet, which WGSL leaves indeterminate (Rust's `max` returns the
            // other operand): the GPU's value there is left open (docs/gpu.md, "NaN").
            let open = point.iter().any(|c| !c.is_finite());
            let e = if open {
                0.0
            } else {
                gpu_error(on_gpu[k], reference[k])
            };
            worst_gpu = worst_gpu.max(e);
            let bound = tolerance + 4.0 * unresolved(k);
            // Within the bound, infinite ones included (an f32 overflow the CPU f32 path has
            // too: inf − inf would be NaN, a false failure the random-graph test found).
            let over = match (e <= bound, bound.is_finite()) {
                (true, false) => f64::MIN, // within an infinite bound
                _ => e - bound,
            };
            if over > excess || over.is_nan() {
                (excess, at) = (over, i);
            }
        }
        if excess.is_nan() || excess > 0.0 {
            let k = c * n + at;
            return Err(format!(
                "channel {c}: GPU {} vs f64 {} at {:?} (error {:e}, tolerance {tolerance:e} + 4 × {:e} that f64 moves within 4 ulps; the CPU f32 path: {})",
                on_gpu[k], reference[k], points[at], gpu_error(on_gpu[k], reference[k]), unresolved(k), cpu[k]
            ));
        }
        figures.push((worst_gpu, worst_cpu));
    }
    Ok(figures)
}

/// [`instruction_forms`] reads a disassembly line's variant words, and [`covering`]'s graphs
/// use every form that all graphs use, in fewer graphs.
#[test]
fn the_covering_graphs_use_every_instruction_form() {
    let line = "0002  s0 = noise v2 cellular jitter=0.9 metric=Euclidean seed=3 ; cells";
    assert_eq!(
        instruction_forms(line, false),
        [
            "noise",
            "noise cellular",
            "noise jitter",
            "noise metric=Euclidean",
            "noise seed"
        ]
    );
    assert_eq!(
        instruction_forms("0001  d2 = mul d0, d1", true),
        ["mul", "mul wide"]
    );
    let forms_of = |paths: &[std::path::PathBuf]| -> BTreeSet<String> {
        paths.iter().flat_map(|path| tape_forms(path).1).collect()
    };
    let graphs = graph_files();
    let chosen = covering(&graphs);
    assert_eq!(forms_of(&chosen), forms_of(&graphs));
    assert!(
        chosen.len() * 2 <= graphs.len(),
        "{} of {}",
        chosen.len(),
        graphs.len()
    );
    eprintln!(
        "covering: {}",
        chosen
            .iter()
            .map(|p| p.file_stem().unwrap().to_string_lossy())
            .collect::<Vec<_>>()
            .join(" ")
    );
}

/// A PNG as the `png` crate decodes it (palettes and bit depths under 8 expanded): size,
/// channels per pixel (1 grey, 2 grey and alpha, 3 RGB, 4 RGBA), bits per sample (8 or 16),
/// samples row by row.
pub struct Png {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub bits: u8,
    pub samples: Vec<u16>,
}

impl Png {
    /// The PNG file at `path`.
    pub fn open(path: &std::path::Path) -> Result<Png, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        Png::decode(&bytes).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The PNG in `bytes`.
    pub fn decode(bytes: &[u8]) -> Result<Png, String> {
        let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        decoder.set_transformations(png::Transformations::EXPAND);
        let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
        let mut buffer = vec![0; reader.output_buffer_size().ok_or("a PNG too large")?];
        let info = reader.next_frame(&mut buffer).map_err(|e| e.to_string())?;
        buffer.truncate(info.buffer_size());
        let channels = info.color_type.samples();
        let (bits, samples) = match info.bit_depth {
            png::BitDepth::Sixteen => (
                16,
                buffer
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]]))
                    .collect(),
            ),
            png::BitDepth::Eight => (8, buffer.into_iter().map(u16::from).collect()),
            other => return Err(format!("{other:?} bits per sample after expansion")),
        };
        Ok(Png {
            width: info.width as usize,
            height: info.height as usize,
            channels,
            bits,
            samples,
        })
    }

    /// (width, height) in pixels.
    pub fn dimensions(&self) -> (u32, u32) {
        (self.width as u32, self.height as u32)
    }

    /// The samples of pixel (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> &[u16] {
        let at = (y * self.width + x) * self.channels;
        &self.samples[at..at + self.channels]
    }

    /// The 8-bit pixels as RGB (grey repeated, alpha dropped), row by row.
    pub fn rgb8(&self) -> Vec<u8> {
        self.with_alpha(false)
    }

    /// The 8-bit pixels as RGBA (grey repeated, opaque where the file has no alpha).
    pub fn rgba8(&self) -> Vec<u8> {
        self.with_alpha(true)
    }

    /// The samples of an 8-bit PNG as bytes, as stored.
    pub fn samples8(&self) -> Vec<u8> {
        assert_eq!(self.bits, 8, "an 8-bit PNG");
        self.samples.iter().map(|&s| s as u8).collect()
    }

    fn with_alpha(&self, alpha: bool) -> Vec<u8> {
        let samples = self.samples8();
        let mut out = Vec::with_capacity(self.width * self.height * 4);
        for p in samples.chunks_exact(self.channels) {
            let (rgb, a) = match p.len() {
                1 => ([p[0]; 3], 255),
                2 => ([p[0]; 3], p[1]),
                3 => ([p[0], p[1], p[2]], 255),
                _ => ([p[0], p[1], p[2]], p[3]),
            };
            out.extend_from_slice(&rgb);
            if alpha {
                out.push(a);
            }
        }
        out
    }
}
