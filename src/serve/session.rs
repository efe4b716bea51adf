//! What the page shows, computed by the library's own stages (check, compile, the interpreter,
//! the renderer), so the page can never disagree with `bake` and `render`: the checked graph
//! and its diagnostics, the slice, the node thumbnails with their measured cost, the preview,
//! hover values and the accuracy report. Everything here is blocking; the server runs it off
//! its async threads.

use super::protocol::{Settings, SliceWindow};
use super::writeback::{self, WrittenParam};
use crate::check::CheckOptions;
use crate::compile::{compile, CompileOptions};
use crate::diagnostic::Diagnostics;
use crate::eval::Workspace;
use crate::graph::{CheckedGraph, Type};
use crate::output::RgbImage;
use crate::render::{self, Cancel, PreviewDefaults, RenderError, RenderOptions};
use crate::tape::Tape;
use base64::Engine as _;
use rustc_hash::FxHashMap as HashMap;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// At most this many named nodes get a thumbnail and a cost (the rest are listed without):
/// bounds the memory of one thumbnail pass whatever the graph's size.
pub const MAX_PROBED_NODES: usize = 256;

/// Most values (f32) one thumbnail pass holds: nodes × channels × side²; a larger request is
/// served at a smaller side (64 MiB, whatever the graph and the requested size).
pub const MAX_THUMB_VALUES: usize = 1 << 24;

/// Points evaluated per block of a slice or thumbnail pass (cancellation is checked between
/// blocks).
const BLOCK: usize = 4096;

/// A graph that checked: what hover, the slice and the thumbnails evaluate.
pub struct Loaded {
    pub path: PathBuf,
    pub graph: CheckedGraph,
    /// The params as written in the file (name, number's span, value).
    pub written: Vec<WrittenParam>,
    /// Named nodes' kinds as written, in file order.
    pub kinds: Vec<(String, String)>,
    /// Every output, for hover.
    pub outputs: Tape,
    /// The overrides that applied (those naming a param the file still has).
    pub overrides: Vec<(String, f64)>,
}

/// Why a graph could not be loaded: the `graph` message's diagnostics, and the files it read.
pub struct LoadFailure {
    pub diagnostics: Vec<Value>,
    pub text: String,
}

/// Reads and checks the graph file `path` with the settings' overrides (those naming a param
/// the file no longer has are dropped, not errors). `files` receives every file read.
pub fn load(
    path: &Path,
    settings: &Settings,
    files: &mut Vec<PathBuf>,
) -> Result<Loaded, LoadFailure> {
    files.push(path.to_path_buf());
    let source = crate::source::read_source(path).map_err(load_failure)?;
    let written = writeback::written_params(&source.text).unwrap_or_default();
    let overrides: Vec<(String, f64)> = settings
        .params
        .iter()
        .filter(|(name, _)| written.iter().any(|w| w.name == **name))
        .map(|(name, v)| (name.clone(), *v))
        .collect();
    let kinds = writeback::node_kinds(&source.text);
    let checked = crate::check::check(
        source,
        &CheckOptions {
            overrides: overrides.clone(),
        },
    );
    let graph = match checked {
        Ok(graph) => graph,
        Err(d) => {
            for f in d.list.iter().filter_map(|d| d.file.as_ref()) {
                files.push(PathBuf::from(&f.name));
            }
            return Err(load_failure(crate::source::LoadError::Invalid(d)));
        }
    };
    files.extend(graph.imports().iter().cloned());
    let outputs = compile(&graph, &CompileOptions::default())
        .map_err(|d| load_failure(crate::source::LoadError::Invalid(d)))?;
    Ok(Loaded {
        path: path.to_path_buf(),
        graph,
        written,
        kinds,
        outputs,
        overrides,
    })
}

fn load_failure(e: crate::source::LoadError) -> LoadFailure {
    match e {
        crate::source::LoadError::Io { path, source } => LoadFailure {
            diagnostics: vec![json!({
                "file": path.display().to_string(), "line": null, "column": null,
                "class": "io", "node": null,
                "message": format!("cannot read the file: {source}"),
                "label": null, "help": "the page recovers when the file is back",
                "source_line": null, "caret": null, "chain": [],
            })],
            text: format!("error: {}: {source}\n", path.display()),
        },
        crate::source::LoadError::Invalid(d) => LoadFailure {
            diagnostics: diagnostics_json(&d),
            text: d.render_plain(),
        },
    }
}

/// Diagnostics as the `graph` message lists them: file, 1-based line and column, the source
/// line and a caret line under the span.
pub fn diagnostics_json(d: &Diagnostics) -> Vec<Value> {
    d.list
        .iter()
        .map(|diag| {
            let file = diag.file.as_ref().unwrap_or(&d.file);
            let located = diag.span.map(|span| {
                let (line, column) = file.line_col(span.start);
                let text = file.text.lines().nth(line - 1).unwrap_or("");
                let (_, end_column) = file.line_col(span.end.max(span.start));
                let end_line = file.line_col(span.end).0;
                let width = if end_line == line {
                    end_column.saturating_sub(column).max(1)
                } else {
                    text.chars().count().saturating_sub(column - 1).max(1)
                };
                let caret = format!("{}{}", " ".repeat(column - 1), "^".repeat(width));
                (line, column, text.to_string(), caret)
            });
            json!({
                "file": file.name,
                "line": located.as_ref().map(|l| l.0),
                "column": located.as_ref().map(|l| l.1),
                "class": diag.class.code(),
                "node": diag.node,
                "message": diag.message,
                "label": diag.label,
                "help": diag.help,
                "source_line": located.as_ref().map(|l| l.2.clone()),
                "caret": located.as_ref().map(|l| l.3.clone()),
                "chain": diag.chain,
            })
        })
        .collect()
}

fn type_name(ty: Type) -> &'static str {
    match ty {
        Type::Scalar => "scalar",
        Type::Vec3 => "vec3",
    }
}

/// The `graph` message's `params`, `outputs`, `nodes` and `imports` for a loaded graph.
pub fn graph_parts(loaded: &Loaded) -> Value {
    let graph = &loaded.graph;
    let params: Vec<Value> = graph
        .params()
        .iter()
        .map(|(name, value)| {
            let file = loaded
                .written
                .iter()
                .find(|w| w.name == *name)
                .map_or(*value, |w| w.value);
            let annotated = graph.param_ranges().iter().find(|(p, _, _)| p == name);
            let (min, max) = annotated.map_or(writeback::default_range(file), |r| (r.1, r.2));
            json!({
                "name": name, "file": file, "value": value, "min": min, "max": max,
                "step": (max - min) / 1000.0, "annotated": annotated.is_some(),
            })
        })
        .collect();
    let outputs: Vec<Value> = graph
        .outputs()
        .iter()
        .map(|o| json!({"name": o.name, "type": type_name(graph.nodes()[o.node as usize].ty)}))
        .collect();
    // Each node's instructions and kind, grouped once (a graph may have thousands of nodes).
    let probes = graph.with_node_probes();
    let tape = compile(&probes, &CompileOptions::default()).ok();
    let mut lines: HashMap<&str, Vec<String>> = HashMap::default();
    for (origin, line) in tape.iter().flat_map(|t| t.instruction_lines()) {
        lines.entry(origin).or_default().push(line);
    }
    let kinds: HashMap<&str, &str> = loaded
        .kinds
        .iter()
        .map(|(n, k)| (n.as_str(), k.as_str()))
        .collect();
    let nodes: Vec<Value> = graph
        .named_nodes()
        .map(|(name, id)| {
            json!({
                "name": name, "kind": kinds.get(name).copied().unwrap_or(""),
                "type": type_name(graph.nodes()[id as usize].ty),
                "instructions": lines.get(name).map_or(&[][..], Vec::as_slice),
            })
        })
        .collect();
    let imports: Vec<String> = graph
        .imports()
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    json!({"params": params, "outputs": outputs, "nodes": nodes, "imports": imports})
}

/// The point (u, v) of the slice plane `w`, as (x, y, z).
pub fn slice_point(w: &SliceWindow, u: f64, v: f64) -> [f64; 3] {
    match w.axis.as_str() {
        "xz" => [u, w.depth, v],
        "yz" => [w.depth, u, v],
        _ => [u, v, w.depth],
    }
}

/// The sample points of an `n`×`n` image of the slice window, row by row from the top, as
/// three coordinate planes.
fn slice_points(w: &SliceWindow, n: u32) -> [Vec<f64>; 3] {
    let count = n as usize * n as usize;
    let mut planes = [
        Vec::with_capacity(count),
        Vec::with_capacity(count),
        Vec::with_capacity(count),
    ];
    let step = w.width / f64::from(n);
    for j in 0..n {
        let v = w.center[1] + w.width / 2.0 - (f64::from(j) + 0.5) * step;
        for i in 0..n {
            let u = w.center[0] - w.width / 2.0 + (f64::from(i) + 0.5) * step;
            let p = slice_point(w, u, v);
            for (plane, c) in planes.iter_mut().zip(p) {
                plane.push(c);
            }
        }
    }
    planes
}

/// One evaluated image: its channels (1 or 3) planar, and its side.
pub struct Plane {
    pub ty: Type,
    pub side: u32,
    pub values: Vec<f32>,
}

impl Plane {
    /// Finite minimum and maximum of a scalar image (`None` for a colour or no finite value).
    pub fn range(&self) -> Option<(f32, f32)> {
        if self.ty != Type::Scalar {
            return None;
        }
        let finite = self.values.iter().filter(|v| v.is_finite());
        let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(*v), hi.max(*v))
        });
        (lo <= hi).then_some((lo, hi))
    }

    /// The image as a PNG `data:` URL: a scalar as grey from its minimum (black) to maximum
    /// (white), non-finite values red; a vec3 as an sRGB-encoded colour, clamped.
    pub fn png(&self) -> String {
        let n = self.side as usize * self.side as usize;
        let mut bytes = Vec::with_capacity(3 * n);
        match self.ty {
            Type::Scalar => {
                let (lo, hi) = self.range().unwrap_or((0.0, 1.0));
                let scale = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
                for v in &self.values {
                    if v.is_finite() {
                        let g = if hi > lo { (v - lo) * scale } else { 0.5 };
                        let g = (g.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
                        bytes.extend([g, g, g]);
                    } else {
                        bytes.extend([255, 0, 0]);
                    }
                }
            }
            Type::Vec3 => {
                for i in 0..n {
                    for c in 0..3 {
                        bytes.push(crate::bake::encode_u8(self.values[c * n + i], true));
                    }
                }
            }
        }
        let image = RgbImage::from_raw(self.side, self.side, bytes).expect("n×n pixels");
        png_data_url(&image)
    }
}

/// A PNG `data:` URL of an 8-bit RGB image.
pub fn png_data_url(image: &RgbImage) -> String {
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(image.encode_png())
    )
}

/// The name the slice and preview show: the settings' output if the graph has it as an output
/// or a named node, else the renderer's default (`colour`, the first colour output, the first
/// output).
pub fn chosen_output(graph: &CheckedGraph, settings: &Settings) -> Option<String> {
    if let Some(name) = &settings.output {
        if graph.output(name).is_some() || graph.named_nodes().any(|(n, _)| n == name) {
            return Some(name.clone());
        }
    }
    let vec3 = |o: &&crate::graph::Output| graph.nodes()[o.node as usize].ty == Type::Vec3;
    graph
        .output("colour")
        .filter(vec3)
        .or_else(|| graph.outputs().iter().find(vec3))
        .or_else(|| graph.outputs().first())
        .map(|o| o.name.clone())
}

/// The loaded graph compiled for `outputs`, each an output or a named node.
fn probe_tape(loaded: &Loaded, outputs: Vec<String>) -> Option<Tape> {
    let options = CompileOptions {
        outputs,
        spacing: None,
        ..Default::default()
    };
    compile(&loaded.graph.with_node_probes(), &options).ok()
}

/// Runs `run` over the points in blocks of `block` (checking `cancel` before each), copying
/// each block's planar result into `values` (planar over all points) when given; `None` when
/// cancelled.
fn in_blocks(
    tape: &Tape,
    points: &[Vec<f64>; 3],
    block: usize,
    cancel: &Cancel,
    mut values: Option<&mut [f32]>,
    mut run: impl FnMut([&[f64]; 3], &mut [f32]),
) -> Option<()> {
    let channels = tape.channels();
    let count = points[0].len();
    let mut out = vec![0.0f32; channels * block];
    let mut start = 0;
    while start < count {
        if cancel.is_cancelled() {
            return None;
        }
        let end = (start + block).min(count);
        let len = end - start;
        let out = &mut out[..channels * len];
        run(
            [
                &points[0][start..end],
                &points[1][start..end],
                &points[2][start..end],
            ],
            out,
        );
        if let Some(values) = values.as_deref_mut() {
            for c in 0..channels {
                values[c * count + start..c * count + end].copy_from_slice(&out[c * len..][..len]);
            }
        }
        start = end;
    }
    Some(())
}

/// Evaluates output or node `name` over an n×n image of the slice window, in blocks; `None`
/// when cancelled.
pub fn slice(
    loaded: &Loaded,
    name: &str,
    w: &SliceWindow,
    n: u32,
    cancel: &Cancel,
) -> Option<Plane> {
    let tape = probe_tape(loaded, vec![name.to_string()])?;
    let ty = tape.outputs()[0].ty;
    let points = slice_points(w, n);
    let mut values = vec![0.0f32; tape.channels() * points[0].len()];
    let mut ws = Workspace::<f32>::new();
    in_blocks(
        &tape,
        &points,
        BLOCK,
        cancel,
        Some(&mut values),
        |[x, y, z], out| tape.eval_batch(&mut ws, x, y, z, out),
    )?;
    Some(Plane {
        ty,
        side: n,
        values,
    })
}

/// A named node's thumbnail and its measured cost.
pub struct Thumbnail {
    pub name: String,
    pub plane: Plane,
    /// Nanoseconds per point of the node's instructions (the fastest of the timed passes).
    pub ns_per_point: f64,
    pub instructions: usize,
}

/// The cost of reading the clock around one instruction, subtracted from each measurement.
fn clock_overhead() -> Duration {
    let mut samples: Vec<Duration> = (0..64)
        .map(|_| {
            let began = Instant::now();
            std::hint::black_box(Instant::now());
            began.elapsed()
        })
        .collect();
    samples.sort();
    samples[samples.len() / 2]
}

/// Thumbnails (n×n over the slice window, smaller when [`MAX_THUMB_VALUES`] says so) of the
/// first [`MAX_PROBED_NODES`] named nodes, each
/// with the time per point of its own instructions, measured by
/// [`Tape::eval_batch_timed`] over the thumbnail's points (passes repeated until 20 ms or 5
/// passes; each instruction's fastest pass counts). `None` when cancelled.
pub fn thumbnails(
    loaded: &Loaded,
    w: &SliceWindow,
    n: u32,
    cancel: &Cancel,
) -> Option<Vec<Thumbnail>> {
    let graph = &loaded.graph;
    let names: Vec<String> = graph
        .named_nodes()
        .filter(|(_, id)| {
            !matches!(
                graph.nodes()[*id as usize].op,
                crate::graph::Op::ConstScalar(_) | crate::graph::Op::ConstVec3(_)
            )
        })
        .map(|(name, _)| name.to_string())
        .take(MAX_PROBED_NODES)
        .collect();
    if names.is_empty() {
        return Some(Vec::new());
    }
    let tape = probe_tape(loaded, names)?;
    let channels = tape.channels();
    let fits = ((MAX_THUMB_VALUES / channels.max(1)) as f64).sqrt() as u32;
    let n = n.min(fits.max(8));
    let points = slice_points(w, n);
    let count = points[0].len();
    let mut values = vec![0.0f32; channels * count];
    let mut ws = Workspace::<f32>::new();
    let block = (BLOCK / channels.max(1)).clamp(256, BLOCK);
    let overhead = clock_overhead();
    let instrs = tape.instructions().len();
    let mut best = vec![Duration::MAX; instrs];
    let began = Instant::now();
    for pass in 0..5 {
        let mut times = vec![Duration::ZERO; instrs];
        let mut calls = 0u32;
        let keep = (pass == 0).then_some(values.as_mut_slice());
        in_blocks(&tape, &points, block, cancel, keep, |p, out| {
            tape.eval_batch_timed(&mut ws, p, out, &mut times);
            calls += p[0].len().div_ceil(crate::eval::LANES) as u32;
        })?;
        for (b, t) in best.iter_mut().zip(&times) {
            *b = (*b).min(t.saturating_sub(overhead * calls));
        }
        if began.elapsed() > Duration::from_millis(20) {
            break;
        }
    }
    let origins: Vec<&str> = tape.origins().collect();
    let thumbs = tape
        .outputs()
        .iter()
        .map(|o| {
            let mine = origins
                .iter()
                .zip(&best)
                .filter(|(origin, _)| **origin == o.name);
            let (count_mine, total) =
                mine.fold((0, Duration::ZERO), |(k, t), (_, d)| (k + 1, t + *d));
            let c = o.first_channel;
            Thumbnail {
                name: o.name.clone(),
                plane: Plane {
                    ty: o.ty,
                    side: n,
                    values: values[c * count..(c + o.ty.channels()) * count].to_vec(),
                },
                ns_per_point: total.as_secs_f64() * 1e9 / count as f64,
                instructions: count_mine,
            }
        })
        .collect();
    Some(thumbs)
}

/// Values of every output of the loaded graph at `point` (f32, as `bake` evaluates).
pub fn hover(loaded: &Loaded, point: [f64; 3]) -> Vec<Value> {
    let tape = &loaded.outputs;
    let mut ws = Workspace::<f32>::new();
    let mut out = vec![0.0f32; tape.channels()];
    tape.eval_point(&mut ws, point, &mut out);
    tape.outputs()
        .iter()
        .map(|o| {
            let values: Vec<Value> = out[o.first_channel..o.first_channel + o.ty.channels()]
                .iter()
                .map(|v| number_json(f64::from(*v)))
                .collect();
            json!({"name": o.name, "type": type_name(o.ty), "value": values})
        })
        .collect()
}

/// A number for JSON: non-finite values as the strings "NaN", "inf", "-inf" (JSON has none).
pub fn number_json(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        json!(v.to_string())
    }
}

/// The default preview scene of the graph `loaded` (docs/scenes.md) with the page's object,
/// space, params and output; `probe`: the output is a named node, not one of the graph's outputs.
/// The scene takes the graph as `load` read and checked it, not the file again: a save in
/// between would make the preview another text's than the graph the page shows.
pub fn preview_scene(
    loaded: &Loaded,
    settings: &Settings,
    output: Option<&str>,
    probe: bool,
    files: &mut Vec<PathBuf>,
) -> Result<render::Scene, RenderError> {
    let defaults = PreviewDefaults {
        object: settings.object.parse().unwrap_or_default(),
        space: if settings.space == "world" {
            render::Space::World
        } else {
            render::Space::Object
        },
        overrides: settings
            .params
            .iter()
            .map(|(k, v)| (k.clone(), *v))
            .collect(),
        output: output.map(str::to_string),
        bump: None,
    };
    let mut desc = defaults.scene_desc(&loaded.path);
    desc.probe_nodes = probe;
    let checked = render::Checked {
        path: &loaded.path,
        overrides: &loaded.overrides,
        graph: &loaded.graph,
    };
    render::Scene::from_desc_tracking(&desc, Path::new(""), checked, files)
}

/// Renders the preview at `width` pixels across (the scene's aspect kept, square for a graph's
/// default scene) with `samples` per pixel.
pub fn preview(
    scene: &render::Scene,
    width: u32,
    samples: u32,
    cancel: &Cancel,
) -> Result<(RgbImage, Duration), RenderError> {
    let height = match scene.size() {
        Some((w, h)) if w > 0 => ((u64::from(width) * u64::from(h)) / u64::from(w)).max(1) as u32,
        _ => width,
    };
    let options = RenderOptions {
        size: Some((width, height)),
        samples: Some(samples),
        threads: None,
        progress: false,
        cancel: Some(cancel.clone()),
        // As `render` by default: point samples with level of detail per pixel (the octaves
        // each footprint resolves), so the preview does not alias toward its horizon.
        lod: render::RenderLod::default(),
        filter: render::RenderFilter::default(),
        device: crate::gpu::Device::Cpu,
    };
    let began = Instant::now();
    let (image, _) = render::render(scene, &options)?;
    Ok((image.to_rgb8(), began.elapsed()))
}

/// `texgraph report`'s rows for the loaded graph (with its overrides), smaller than the
/// command's default so the page answers in seconds: 20 000 points, 3 runs, one bake size and
/// one LOD spacing.
pub fn report(loaded: &Loaded) -> Result<Value, String> {
    let options = crate::report::ReportOptions {
        points: 20_000,
        runs: 3,
        bake_sizes: vec![64],
        lod_spacings: vec![1.0 / 128.0],
        ..Default::default()
    };
    let rows = crate::report::accuracy_report(&loaded.graph, &[], &options)
        .map_err(|d| d.render_plain())?;
    let text = crate::report::table_text(&rows);
    Ok(json!({"type": "report", "text": text, "rows": rows}))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The preview scene is the graph `load` checked, not the file read again: a save in
    /// between (here one without the output the page chose, as a generation can see when the
    /// next save lands) leaves it the checked graph's; a removed file too.
    #[test]
    fn the_preview_scene_is_the_loaded_graph_not_a_later_save() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("g.ron");
        std::fs::write(
            &path,
            "Graph(nodes: { \"p\": Position }, outputs: { \"v\": Mul(\"p.x\", 2.0) })",
        )
        .unwrap();
        let settings = Settings::default();
        let loaded =
            load(&path, &settings, &mut Vec::new()).unwrap_or_else(|f| panic!("{}", f.text));
        let scene = |loaded: &Loaded| {
            let mut files = Vec::new();
            preview_scene(loaded, &settings, Some("v"), false, &mut files)
                .map(|_| files)
                .map_err(|e| e.to_string())
        };
        let files = scene(&loaded).expect("the scene of the file as read");
        assert!(
            files.contains(&path),
            "the graph file is watched: {files:?}"
        );
        std::fs::write(&path, "Graph(nodes: {}, outputs: { \"w\": 1.0 })").unwrap();
        scene(&loaded).expect("a later save without output v");
        std::fs::remove_file(&path).unwrap();
        scene(&loaded).expect("the file removed");
    }
}
