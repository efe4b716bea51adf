//! Preview rendering: objects carved out of solid textures (seeds 000, 001, 003, 004).
//!
//! A small ray caster (primary rays, shadow rays, Blinn–Phong shading, jittered samples per
//! pixel) renders a [`Scene`]: a camera, lights, and objects (sphere, box, plane, OBJ mesh, the
//! Newell teapot), each with a transform and a material whose channels (ambient, diffuse,
//! specular colour, shininess) are constants or outputs of graph files — seed 003's material
//! model, in which "a channel is a constant or a texture procedure".
//!
//! Textures are evaluated only at ray hits, in batches: a tile's primary rays are traced first,
//! then each material binding's compiled tape runs once over all of the tile's hit points
//! ([`Tape::eval_batch`](crate::tape::Tape::eval_batch), f32), then the hits are shaded. Only the
//! outputs a scene binds are compiled, and a graph file used with the same overrides by several
//! materials or objects is checked and compiled once. Tiles are rendered in parallel (rayon);
//! the image does not depend on the thread count.
//!
//! - [`load_scene`] reads a scene file (format in [`scene`]); [`Scene::from_graph_default`]
//!   builds the default preview scene of a graph file (the object, a ground plane, a key light
//!   with shadows, a fill light); [`load_input`] tells the two apart.
//! - [`render`] renders; [`RenderedImage::write_png`] writes atomically (temporary + rename).
//! - [`Previewer`] and [`watch`] are `texgraph watch`: re-render on save, keep the last good
//!   image when an edit breaks something.
//! - [`timing_table`] times seed 003's marble sphere at 500×500 pixels for 1, 2, 4 and 8
//!   octaves, next to the document's figures.
//!
//! # Scene files
//!
//! ```ron
//! Scene(
//!     camera: Camera(position: (0, 0.4, 3.6), look_at: (0, 0, 0), up: (0, 1, 0), fov: 40),
//!     lights: [
//!         Point(position: (-4, 6, 5), colour: (1, 1, 1), intensity: 0.9, shadows: true),
//!         Directional(direction: (-1, -0.4, -0.8), intensity: 0.3, shadows: false),
//!     ],
//!     materials: {
//!         "marble": Material(
//!             diffuse: Texture(graph: "../seed003_marble.ron", output: "colour",
//!                              set: { "octaves": 8 }, space: Object),
//!             specular: Texture(graph: "../seed003_marble.ron", output: "vein", multiply: 0.5),
//!             shininess: Value(40),
//!         ),
//!         "floor": Material(diffuse: Colour(0.6, 0.6, 0.6), specular: Value(0)),
//!     },
//!     objects: [
//!         Object(shape: Sphere(radius: 1), material: "marble",
//!                transform: [Rotate(axis: (0, 1, 0), degrees: 30), Translate(0, 0.2, 0)]),
//!         Object(shape: Plane(), material: "floor", transform: [Translate(0, -0.8, 0)]),
//!     ],
//!     background: (0.18, 0.19, 0.21),   // optional
//!     ambient_light: (0.12, 0.12, 0.12), // optional
//!     size: (500, 500),                  // optional: the command line's --size wins
//!     samples: 4,                        // optional: the command line's --samples wins
//! )
//! ```
//!
//! - Lights: `Point(position, colour, intensity, shadows)` (no fall-off) and
//!   `Directional(direction, colour, intensity, shadows)`, `direction` being where the light
//!   shines; colour (1, 1, 1), intensity 1 and shadows true by default.
//! - Bump: `bump: (height: "FILE.OUTPUT", strength: 1)` or `bump: (height: Texture(...),
//!   strength: 1)`: the shading normal n becomes normalize(n − strength · g⊥), g⊥ the part
//!   tangent to the surface of the height's world-space gradient (Blinn 1978); the gradient is
//!   compiled into the graph's tape next to its other bound outputs.
//! - Channels: `Colour(r, g, b)`, `Value(v)` (a grey for colour channels), or
//!   `Texture(graph, output, set, space, transform, multiply)`: `graph` relative to the scene
//!   file; `output` by default `colour` (colour channels) or the first scalar output
//!   (shininess); a scalar output in a colour channel is a grey; `set` overrides params like
//!   `--set`; `space: Object` (default: hit points moved back by the object's inverse transform,
//!   the texture moves with the object) or `World` (the object moves through the texture);
//!   `transform` is applied to the point before evaluation. Defaults: diffuse 0.8, specular
//!   0.25, shininess 32, ambient = the diffuse channel.
//! - Shapes: `Sphere(radius: 1)`, `Box(size: (1, 1, 1))` (alias `Cube`, centred), `Plane()`
//!   (y = 0, or `Plane(size: (x, z))` for a rectangle), `Mesh(path: "x.obj", fit: false)`,
//!   `Teapot(resolution: 10, fit: false)`.
//! - Transforms: a list of `Translate(x, y, z)`, `Rotate(axis: (x, y, z), degrees: d)`,
//!   `Scale(s)` or `Scale((x, y, z))`, applied in order (the first one first).

mod error;
pub mod geometry;
pub mod lod_figures;
pub mod scene;
pub mod shade;
pub mod teapot;

pub use error::{RenderError, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE};
pub use scene::{
    load_scene, BumpDesc, ChannelDesc, CompiledTexture, HeightDesc, HeightTexture, LightDesc,
    MaterialDesc, ObjectDesc, PreviewBump, PreviewDefaults, PreviewObject, Scene, SceneDesc,
    ShapeDesc, Space, TransformDesc,
};
pub use shade::Counters;

use crate::output::RgbImage;
use error::check_samples;
use error::check_size;
use glam::Vec3;
use rayon::prelude::*;
use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Image size when neither the command line nor the scene gives one.
pub const DEFAULT_SIZE: (u32, u32) = (480, 360);
/// Samples per pixel when neither the command line nor the scene gives a number.
pub const DEFAULT_SAMPLES: u32 = 4;
/// How to render.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// (width, height) in pixels; else the scene's, else [`DEFAULT_SIZE`].
    pub size: Option<(u32, u32)>,
    /// Samples per pixel; else the scene's, else [`DEFAULT_SAMPLES`]. One sample is the pixel
    /// centre; more are jittered with a fixed seed (stratified for a square number).
    pub samples: Option<u32>,
    /// Worker threads; `None`: rayon's default (one per core).
    pub threads: Option<usize>,
    /// Show a progress bar (only when stderr is a terminal).
    pub progress: bool,
    /// Stop early (at the next tile) when this says so: the render then fails with
    /// [`RenderError::Cancelled`] (`texgraph serve` drops work a newer edit made stale).
    pub cancel: Option<Cancel>,
    /// Level of detail per pixel (on by default; `render --no-lod` turns it off). With
    /// [`RenderFilter::Box`] its bias scales the footprints, and `Off` is refused.
    pub lod: RenderLod,
    /// Point samples or each sample's texture mean over its footprint (`render --filter`;
    /// box by default).
    pub filter: RenderFilter,
    /// Where the textures are evaluated (`render --device`): `Gpu` runs each texture's tape
    /// on the GPU (one batch per tile, level of detail per point included); a texture the GPU
    /// cannot run stays on the CPU, said on stderr. `Auto` is the CPU here (the command line
    /// resolves it).
    pub device: crate::gpu::Device,
}

/// What a render's texture sample stands for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RenderFilter {
    /// The texture's value at the hit, with the octaves the footprint resolves
    /// ([`RenderLod`]).
    Point,
    /// The estimate of the texture's mean over the sample's footprint (its pixel's share,
    /// carried into texture space by the ray differentials as an anisotropic parallelogram):
    /// the filtered form of each tape (`crate::filter`), on the CPU, or on the GPU's filtered
    /// form with `--device gpu` (or `auto` finding one) where that covers the tape.
    #[default]
    Box,
}

/// Level of detail per pixel: each texture point keeps only the fractal octaves its own
/// footprint resolves ([`Tape::eval_batch_lod`](crate::tape::Tape::eval_batch_lod)). The footprint
/// of a sample is its pixel's cone at the hit (ray differentials: distance and incidence)
/// carried into texture space through the object's and the texture's transforms, divided by
/// the square root of the samples per pixel (each sample covers that share of its pixel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RenderLod {
    /// Every octave at every pixel.
    Off,
    /// Footprints scaled by `2^bias`: a positive bias blurs (drops octaves sooner), a negative
    /// one keeps finer detail (`render --lod-bias`).
    On { bias: f64 },
}

impl Default for RenderLod {
    fn default() -> RenderLod {
        RenderLod::On { bias: 0.0 }
    }
}

impl RenderLod {
    /// The most `--lod-bias` may shift footprints, in octaves either way.
    pub const MAX_BIAS: f64 = 16.0;

    /// The factor from a pixel's footprint to one sample's spacing, `None` when off.
    fn spacing_factor(self, samples: u32) -> Option<f64> {
        match self {
            RenderLod::Off => None,
            RenderLod::On { bias } => Some(bias.exp2() / f64::from(samples).sqrt()),
        }
    }
}

/// A cancellation check: cancelled once a shared counter has moved past the value it had when
/// the work began (a generation number that every newer edit bumps).
#[derive(Clone, Debug)]
pub struct Cancel {
    counter: std::sync::Arc<std::sync::atomic::AtomicU64>,
    at: u64,
}

impl Cancel {
    /// Work of generation `at`, cancelled when `counter` no longer reads `at`.
    pub fn new(counter: std::sync::Arc<std::sync::atomic::AtomicU64>, at: u64) -> Cancel {
        Cancel { counter, at }
    }

    pub fn is_cancelled(&self) -> bool {
        self.counter.load(std::sync::atomic::Ordering::Acquire) != self.at
    }
}

/// A rendered image: linear RGB, row by row from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedImage {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

/// Linear → sRGB-encoded byte, clamped (the encoding bake uses for colours).
fn srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

impl RenderedImage {
    /// The image as 8-bit sRGB.
    pub fn to_rgb8(&self) -> RgbImage {
        let bytes: Vec<u8> = self.pixels.iter().flat_map(|p| p.map(srgb8)).collect();
        RgbImage::from_raw(self.width, self.height, bytes).expect("width × height pixels")
    }

    /// The linear value of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 3] {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Writes an 8-bit sRGB PNG atomically: into a hidden temporary file in the target folder,
    /// renamed into place when complete, so a viewer never sees half an image.
    pub fn write_png(&self, path: &Path) -> Result<(), RenderError> {
        write_png(&self.to_rgb8(), path)
    }
}

/// Writes an image as PNG atomically (temporary file in the same folder + rename), refusing a
/// destination that is not a regular file (`output::write_atomic`).
pub fn write_png(image: &RgbImage, path: &Path) -> Result<(), RenderError> {
    crate::output::write_png(path, image).map_err(|e| match e {
        crate::output::OutputError::Io { path, source } => RenderError::Io { path, source },
        other => RenderError::Options(other.to_string()),
    })
}

/// Refuses options that apply to graph files only (`given`: the flags the user gave, such as
/// `--set`) when `path` is a scene file, where they would be ignored. A file that cannot be read
/// is left to the render to report.
pub fn refuse_graph_only_options(path: &Path, given: &[&str]) -> Result<(), RenderError> {
    if given.is_empty() {
        return Ok(());
    }
    let Ok(source) = crate::source::read_source(path) else {
        return Ok(());
    };
    if input_kind(&source.text) == InputKind::Scene {
        return Err(RenderError::Options(format!(
            "{}: {} {} to graph files only; this is a scene file, which sets its objects, spaces, outputs, params and bumps itself",
            path.display(),
            given.join(", "),
            if given.len() == 1 { "applies" } else { "apply" }
        )));
    }
    Ok(())
}

/// What one render did.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderStats {
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    pub threads: usize,
    /// Wall time of the render (not of loading the scene).
    pub seconds: f64,
    /// Time spent evaluating textures, summed over threads (CPU seconds).
    pub texture_seconds: f64,
    /// [`Previewer::reload`] only (else 0): reading, checking and compiling the scene and its
    /// graphs, and the whole refresh (load, render, write).
    pub load_seconds: f64,
    pub total_seconds: f64,
    pub counters: Counters,
    /// Outputs the precision plan could not bring within its target at the textures' extents
    /// (`GRAPH: output …`), to print as warnings: the image is right, but not to that error.
    pub shortfalls: Vec<String>,
}

impl std::fmt::Display for RenderStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let c = &self.counters;
        write!(
            f,
            "{}×{} pixels, {} sample{} per pixel, {} thread{}: {:.3} s; {} texture points in {:.3} s of CPU time, {} shadow rays",
            self.width,
            self.height,
            self.samples,
            if self.samples == 1 { "" } else { "s" },
            self.threads,
            if self.threads == 1 { "" } else { "s" },
            self.seconds,
            c.texture_points,
            self.texture_seconds,
            c.shadow_rays
        )?;
        if c.non_finite > 0 {
            write!(
                f,
                "; {} non-finite texture values shaded as 0",
                c.non_finite
            )?;
        }
        if self.total_seconds > 0.0 {
            write!(
                f,
                "; refreshed in {:.3} s (loading and compiling {:.3} s)",
                self.total_seconds, self.load_seconds
            )?;
        }
        Ok(())
    }
}

/// Renders a scene.
pub fn render(
    scene: &Scene,
    options: &RenderOptions,
) -> Result<(RenderedImage, RenderStats), RenderError> {
    let (width, height) = options.size.or(scene.size()).unwrap_or(DEFAULT_SIZE);
    check_size(width, height).map_err(RenderError::Options)?;
    let samples = options
        .samples
        .or(scene.samples())
        .unwrap_or(DEFAULT_SAMPLES);
    check_samples(samples).map_err(RenderError::Options)?;
    if let RenderLod::On { bias } = options.lod {
        if bias.is_nan() || bias.abs() > RenderLod::MAX_BIAS {
            return Err(RenderError::Options(format!(
                "level-of-detail bias {bias}: it must be within ±{}",
                RenderLod::MAX_BIAS
            )));
        }
    }
    let cancel = options.cancel.as_ref();
    let boxed = options.filter == RenderFilter::Box;
    if boxed && options.lod == RenderLod::Off {
        return Err(RenderError::Options(
            "level of detail cannot be off with box filtering (the footprint is the filter): \
             render with point samples to turn it off"
                .into(),
        ));
    }
    let factor = options.lod.spacing_factor(samples);
    let frame = shade::Frame {
        width,
        height,
        samples,
        lod: factor.filter(|_| !boxed),
        filter: factor.filter(|_| boxed),
    };
    let filtered: Vec<crate::filter::Filtered> = if boxed {
        scene
            .textures()
            .iter()
            .map(|t| crate::filter::Filtered::new(&t.tape))
            .collect()
    } else {
        Vec::new()
    };
    let gpus = gpu_textures(scene, options.device, boxed);
    let run = || {
        render_in_pool(scene, frame, options.progress, cancel, &gpus, &filtered)
            .ok_or(RenderError::Cancelled)
    };
    let rendered = match options.threads {
        Some(threads) => {
            if threads == 0 {
                return Err(RenderError::Options("--threads must be at least 1".into()));
            }
            let (threads, _) = crate::bake::capped_threads(threads);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| {
                    RenderError::Options(format!("cannot start {threads} worker threads: {e}"))
                })?;
            pool.install(run)
        }
        None => run(),
    };
    rendered.map(|(image, mut stats)| {
        stats.shortfalls = texture_shortfalls(scene);
        (image, stats)
    })
}

/// Each texture's precision shortfalls, named by graph file.
fn texture_shortfalls(scene: &Scene) -> Vec<String> {
    scene
        .textures()
        .iter()
        .flat_map(|t| {
            t.tape
                .shortfalls()
                .into_iter()
                .map(move |why| format!("{}: {why}", t.graph.display()))
        })
        .collect()
}

/// Per texture, its GPU evaluator with `Device::Gpu` (the start-up check: a texture whose tape
/// the GPU cannot run is evaluated on the CPU, with the reason on stderr); with `boxed`, the
/// filtered form's (a texture it does not cover is filtered on the CPU).
fn gpu_textures(
    scene: &Scene,
    device: crate::gpu::Device,
    boxed: bool,
) -> Vec<Option<std::sync::Arc<crate::gpu::GpuEvaluator>>> {
    scene
        .textures()
        .iter()
        .map(|texture| {
            if device != crate::gpu::Device::Gpu {
                return None;
            }
            let made = if boxed {
                crate::gpu::filtered_evaluator_for(&texture.tape)
            } else {
                crate::gpu::evaluator_for(&texture.tape)
            };
            made.map_err(|e| {
                eprintln!(
                    "warning: {}: {e}; this texture is evaluated on the CPU",
                    texture.graph.display()
                )
            })
            .ok()
        })
        .collect()
}

fn render_in_pool(
    scene: &Scene,
    frame: shade::Frame,
    progress: bool,
    cancel: Option<&Cancel>,
    gpus: &[Option<std::sync::Arc<crate::gpu::GpuEvaluator>>],
    filtered: &[crate::filter::Filtered],
) -> Option<(RenderedImage, RenderStats)> {
    let (width, height, samples) = (frame.width, frame.height, frame.samples);
    let started = Instant::now();
    let tiles = shade::tiles(width, height);
    let bar = (progress && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(tiles.len() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "render [{bar:30}] {percent:>3}% {pos}/{len} tiles, {eta} left",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        bar
    });
    let results: Vec<(Vec<Vec3>, Counters, Duration)> = tiles
        .par_iter()
        .map_init(
            || shade::Scratch::new(scene, gpus, filtered),
            |scratch, tile| {
                let mut pixels = Vec::new();
                if cancel.is_some_and(Cancel::is_cancelled) {
                    return (pixels, Counters::default(), Duration::ZERO);
                }
                let mut texture_time = Duration::ZERO;
                let counters = shade::render_tile(
                    scene,
                    scratch,
                    *tile,
                    frame,
                    &mut pixels,
                    &mut texture_time,
                );
                if let Some(bar) = &bar {
                    bar.inc(1);
                }
                (pixels, counters, texture_time)
            },
        )
        .collect();
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    if cancel.is_some_and(Cancel::is_cancelled) {
        return None;
    }
    let mut pixels = vec![[0.0f32; 3]; width as usize * height as usize];
    let mut counters = Counters::default();
    let mut texture_time = Duration::ZERO;
    for (tile, (tile_pixels, c, t)) in tiles.iter().zip(&results) {
        counters.add(c);
        texture_time += *t;
        for row in 0..tile.h {
            for col in 0..tile.w {
                let p = tile_pixels[(row * tile.w + col) as usize];
                pixels[((tile.y0 + row) * width + tile.x0 + col) as usize] = p.to_array();
            }
        }
    }
    let stats = RenderStats {
        width,
        height,
        samples,
        threads: rayon::current_num_threads(),
        seconds: started.elapsed().as_secs_f64(),
        texture_seconds: texture_time.as_secs_f64(),
        load_seconds: 0.0,
        total_seconds: 0.0,
        counters,
        shortfalls: Vec::new(),
    };
    Some((
        RenderedImage {
            width,
            height,
            pixels,
        },
        stats,
    ))
}

// ---------------------------------------------------------------------------------------------
// Input: a scene file or a graph file
// ---------------------------------------------------------------------------------------------

/// What a `.ron` file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    Scene,
    Graph,
}

/// A file whose first identifier (after comments and `#![...]` attributes) is `Scene` is a
/// scene; anything else is treated as a graph (whose checker then explains what is wrong).
pub fn input_kind(text: &str) -> InputKind {
    let mut rest = text.trim_start_matches('\u{feff}');
    loop {
        rest = rest.trim_start();
        if let Some(r) = rest.strip_prefix("//") {
            rest = r.split_once('\n').map_or("", |(_, after)| after);
        } else if let Some(r) = rest.strip_prefix("/*") {
            rest = r.split_once("*/").map_or("", |(_, after)| after);
        } else if let Some(r) = rest.strip_prefix("#!") {
            rest = r.split_once(']').map_or("", |(_, after)| after);
        } else {
            break;
        }
    }
    let ident: String = rest
        .chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect();
    if ident == "Scene" {
        InputKind::Scene
    } else {
        InputKind::Graph
    }
}

/// Loads a scene file, or builds the default preview scene of a graph file.
pub fn load_input(path: &Path, defaults: &PreviewDefaults) -> Result<Scene, RenderError> {
    load_input_tracking(path, defaults, &mut Vec::new())
}

pub(crate) fn load_input_tracking(
    path: &Path,
    defaults: &PreviewDefaults,
    files: &mut Vec<PathBuf>,
) -> Result<Scene, RenderError> {
    let source = crate::source::read_source(path).map_err(|e| {
        files.push(path.to_path_buf());
        RenderError::from_load(e)
    })?;
    match input_kind(&source.text) {
        InputKind::Scene => scene::load_scene_source(path, &source, files),
        InputKind::Graph => Scene::from_graph_default_tracking(path, defaults, files),
    }
}

// ---------------------------------------------------------------------------------------------
// Watch mode
// ---------------------------------------------------------------------------------------------

/// `texgraph watch`: renders a scene or graph to a PNG, again after each edit, and keeps the
/// last good image when an edit breaks something.
#[derive(Debug)]
pub struct Previewer {
    input: PathBuf,
    defaults: PreviewDefaults,
    options: RenderOptions,
    output: PathBuf,
    last_good: Option<RenderedImage>,
    files: Vec<PathBuf>,
}

impl Previewer {
    /// A previewer of `input` (a scene or graph file) writing `output`. Nothing is read until
    /// [`reload`](Previewer::reload).
    pub fn new(
        input: impl Into<PathBuf>,
        defaults: PreviewDefaults,
        options: RenderOptions,
        output: impl Into<PathBuf>,
    ) -> Previewer {
        let input = input.into();
        Previewer {
            files: vec![input.clone()],
            input,
            defaults,
            options,
            output: output.into(),
            last_good: None,
        }
    }

    /// Re-reads the input (and the graphs and meshes it uses), renders it and writes the output
    /// image. On any error the last good image — in memory and on disk — is kept and the
    /// diagnostic returned (rendered with file:line:column by its `Display`).
    pub fn reload(&mut self) -> Result<RenderStats, RenderError> {
        let mut files = Vec::new();
        let started = Instant::now();
        let result =
            load_input_tracking(&self.input, &self.defaults, &mut files).and_then(|scene| {
                let load_seconds = started.elapsed().as_secs_f64();
                let (image, mut stats) = render(&scene, &self.options)?;
                image.write_png(&self.output)?;
                stats.load_seconds = load_seconds;
                stats.total_seconds = started.elapsed().as_secs_f64();
                Ok((image, stats))
            });
        // Watch what this attempt read as well as what earlier ones did: a scene broken before
        // it names its graphs still depends on them.
        for f in files {
            if !self.files.contains(&f) {
                self.files.push(f);
            }
        }
        let (image, stats) = result?;
        self.last_good = Some(image);
        Ok(stats)
    }

    /// The last image rendered without error.
    pub fn image(&self) -> Option<&RenderedImage> {
        self.last_good.as_ref()
    }

    /// The files whose changes trigger a reload.
    pub fn watched_files(&self) -> &[PathBuf] {
        &self.files
    }

    pub fn output(&self) -> &Path {
        &self.output
    }
}

/// Watched files as (canonical folder, file name).
pub(crate) type WatchList = Vec<(PathBuf, std::ffi::OsString)>;

/// Whether a file-system event can change what the previewer renders.
pub(crate) fn relevant(event: &notify::Event, watched: &[(PathBuf, std::ffi::OsString)]) -> bool {
    use notify::event::{AccessKind, AccessMode, EventKind};
    let kind_matters = match event.kind {
        EventKind::Create(_) | EventKind::Modify(_) | EventKind::Remove(_) | EventKind::Any => true,
        EventKind::Access(AccessKind::Close(AccessMode::Write)) => true,
        // Reading the files (as a reload does) must not trigger another reload.
        EventKind::Access(_) | EventKind::Other => false,
    };
    kind_matters
        && event.paths.iter().any(|p| {
            let (Some(dir), Some(name)) = (p.parent(), p.file_name()) else {
                return false;
            };
            let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
            watched.iter().any(|(d, n)| *d == dir && n == name)
        })
}

/// The folders to watch and the (folder, name) pairs that matter. Folders rather than files:
/// editors often save by writing a new file and renaming it over the old one.
pub(crate) fn watch_list(files: &[PathBuf]) -> WatchList {
    files
        .iter()
        .filter_map(|f| {
            let name = f.file_name()?.to_os_string();
            let dir = match f.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            };
            let dir = dir.canonicalize().ok()?;
            Some((dir, name))
        })
        .collect()
}

/// Renders once, then again whenever a watched file changes, calling `on_refresh` after each
/// attempt with its result (print it; return `ControlFlow::Break(())` to stop). A broken edit
/// keeps the last good image. Bursts of events (an editor's save) are coalesced over 100 ms.
pub fn watch(
    previewer: &mut Previewer,
    mut on_refresh: impl FnMut(&Result<RenderStats, RenderError>) -> ControlFlow<()>,
) -> Result<(), RenderError> {
    use notify::{RecursiveMode, Watcher};
    let (tx, rx) = std::sync::mpsc::channel();
    let mut watcher = notify::recommended_watcher(move |event| {
        let _ = tx.send(event);
    })?;
    let mut watched_dirs: Vec<PathBuf> = Vec::new();
    // Watches every folder of `files` not watched yet.
    let mut watch_folders = |watcher: &mut notify::RecommendedWatcher,
                             files: &[PathBuf]|
     -> Result<WatchList, RenderError> {
        let list = watch_list(files);
        for (dir, _) in &list {
            if !watched_dirs.contains(dir) {
                watcher.watch(dir, RecursiveMode::NonRecursive)?;
                watched_dirs.push(dir.clone());
            }
        }
        Ok(list)
    };
    // The input's folder is watched before the first render, and each render's files before
    // its result is reported: a save made meanwhile is not missed.
    watch_folders(&mut watcher, previewer.watched_files())?;
    let mut refresh = |previewer: &mut Previewer,
                       watcher: &mut notify::RecommendedWatcher|
     -> Result<(ControlFlow<()>, WatchList), RenderError> {
        let result = previewer.reload();
        let list = watch_folders(watcher, previewer.watched_files())?;
        Ok((on_refresh(&result), list))
    };
    let (flow, mut list) = refresh(previewer, &mut watcher)?;
    if flow.is_break() {
        return Ok(());
    }
    loop {
        let Ok(event) = rx.recv() else {
            return Ok(());
        };
        match event {
            Ok(event) if relevant(&event, &list) => {}
            Ok(_) => continue,
            Err(e) => return Err(e.into()),
        }
        // Let the save finish: swallow the rest of the burst.
        while rx.recv_timeout(Duration::from_millis(100)).is_ok() {}
        let (flow, new_list) = refresh(previewer, &mut watcher)?;
        list = new_list;
        if flow.is_break() {
            return Ok(());
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Seed 003's scenes and timing table
// ---------------------------------------------------------------------------------------------

/// Seed 003's marble sphere: a unit sphere in object space, the marble's `colour` output as
/// ambient and diffuse channel with the given overrides, a white highlight, a key light with
/// shadows and a fill light. `graph` is used as written (relative to the working directory for
/// [`Scene::from_desc`] with an empty base).
pub fn seed003_sphere(graph: &str, overrides: &[(&str, f64)]) -> SceneDesc {
    let texture = ChannelDesc::Texture {
        graph: graph.to_string(),
        output: Some("colour".into()),
        set: overrides.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        space: Space::Object,
        transform: Vec::new(),
        multiply: 1.0,
    };
    let mut materials = std::collections::BTreeMap::new();
    materials.insert(
        "marble".to_string(),
        MaterialDesc {
            ambient: None,
            diffuse: texture,
            specular: ChannelDesc::Value(0.3),
            shininess: ChannelDesc::Value(30.0),
            bump: None,
        },
    );
    SceneDesc {
        probe_nodes: false,
        camera: scene::CameraDesc {
            position: [0.0, 0.0, 3.6],
            look_at: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov: 36.0,
        },
        lights: vec![
            LightDesc::Point {
                position: [-4.0, 5.0, 6.0],
                colour: [1.0, 1.0, 1.0],
                intensity: 0.9,
                shadows: true,
            },
            LightDesc::Directional {
                direction: [-1.0, 0.2, -0.6],
                colour: [1.0, 1.0, 1.0],
                intensity: 0.25,
                shadows: false,
            },
        ],
        materials,
        objects: vec![ObjectDesc {
            shape: ShapeDesc::Sphere { radius: 1.0 },
            material: "marble".into(),
            transform: Vec::new(),
        }],
        background: [0.0, 0.0, 0.0],
        ambient_light: [0.15, 0.15, 0.15],
        size: Some((500, 500)),
        samples: Some(1),
    }
}

/// Seed 003's render times on its PentiumIII 733 MHz, 500×500 pixels, scale 1, period 1,
/// distortion 1: (octaves, seconds).
pub const SEED003_OCTAVE_SECONDS: [(u32, f64); 4] = [(1, 0.8), (2, 1.0), (4, 1.4), (8, 2.0)];

/// What [`timing_table`] measures.
#[derive(Clone, Debug)]
pub struct TimingOptions {
    pub size: (u32, u32),
    pub samples: u32,
    pub octaves: Vec<u32>,
    pub threads: Option<usize>,
    /// Renders per row; the fastest counts (the first one also warms caches).
    pub repeats: u32,
}

impl Default for TimingOptions {
    fn default() -> TimingOptions {
        TimingOptions {
            size: (500, 500),
            samples: 1,
            octaves: SEED003_OCTAVE_SECONDS.iter().map(|r| r.0).collect(),
            threads: None,
            repeats: 3,
        }
    }
}

/// One row of the timing table.
#[derive(Clone, Debug)]
pub struct TimingRow {
    pub octaves: u32,
    /// Reading, checking and compiling the scene and its graph.
    pub load_seconds: f64,
    /// The fastest render.
    pub render_seconds: f64,
    /// Texture evaluation in the fastest render, CPU seconds summed over threads.
    pub texture_seconds: f64,
    pub texture_points: u64,
    /// Seed 003's time for this octave count, if it has one.
    pub seed003_seconds: Option<f64>,
}

/// Seed 003's octave table, re-timed.
#[derive(Clone, Debug)]
pub struct TimingTable {
    pub graph: PathBuf,
    pub width: u32,
    pub height: u32,
    pub samples: u32,
    pub threads: usize,
    pub repeats: u32,
    pub rows: Vec<TimingRow>,
}

impl std::fmt::Display for TimingTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "seed 003 marble sphere ({}): {}×{} pixels, {} sample{} per pixel, {} thread{}; scale 1, period 1, distortion 1",
            self.graph.display(),
            self.width,
            self.height,
            self.samples,
            if self.samples == 1 { "" } else { "s" },
            self.threads,
            if self.threads == 1 { "" } else { "s" },
        )?;
        writeln!(
            f,
            "{:>7}  {:>9}  {:>10}  {:>14}  {:>16}  {:>15}  {:>14}",
            "octaves",
            "load (ms)",
            "render (s)",
            "texture points",
            "textures (cpu s)",
            "Mpoints/s/core",
            "seed 003 (s)"
        )?;
        for r in &self.rows {
            writeln!(
                f,
                "{:>7}  {:>9.1}  {:>10.3}  {:>14}  {:>16.3}  {:>15.1}  {:>14}",
                r.octaves,
                r.load_seconds * 1e3,
                r.render_seconds,
                r.texture_points,
                r.texture_seconds,
                r.texture_points as f64 / r.texture_seconds.max(1e-9) / 1e6,
                r.seed003_seconds
                    .map_or("-".to_string(), |s| format!("{s:.1}")),
            )?;
        }
        writeln!(
            f,
            "render: wall time of the fastest of {} render{} (primary rays, textures at the hits, shadow rays, shading);",
            self.repeats,
            if self.repeats == 1 { "" } else { "s" }
        )?;
        writeln!(
            f,
            "textures: CPU time in the tape interpreter, summed over threads; seed 003: the document's render times"
        )?;
        write!(
            f,
            "(MM:SS.S) for the same images on a PentiumIII 733 MHz with 384 MB SDRAM, one thread."
        )
    }
}

/// Renders seed 003's marble sphere (scale 1, period 1, distortion 1) at each octave count and
/// times it: the command-line `texgraph render --timing-table`.
pub fn timing_table(graph: &Path, options: &TimingOptions) -> Result<TimingTable, RenderError> {
    let graph_name = graph.to_string_lossy().into_owned();
    let mut rows = Vec::new();
    let mut threads = 0;
    for &octaves in &options.octaves {
        let started = Instant::now();
        let desc = seed003_sphere(
            &graph_name,
            &[
                ("scale", 1.0),
                ("period", 1.0),
                ("distortion", 1.0),
                ("octaves", octaves as f64),
            ],
        );
        let scene = Scene::from_desc(&desc, Path::new(""))?;
        let load_seconds = started.elapsed().as_secs_f64();
        let render_options = RenderOptions {
            size: Some(options.size),
            samples: Some(options.samples),
            threads: options.threads,
            progress: false,
            cancel: None,
            // Seed 003's renderer evaluates every octave at a point: so does its timing table.
            lod: RenderLod::Off,
            filter: RenderFilter::Point,
            device: crate::gpu::Device::Cpu,
        };
        let mut best: Option<RenderStats> = None;
        for _ in 0..options.repeats.max(1) {
            let (_, stats) = render(&scene, &render_options)?;
            threads = stats.threads;
            if best.as_ref().is_none_or(|b| stats.seconds < b.seconds) {
                best = Some(stats);
            }
        }
        let best = best.expect("at least one render");
        rows.push(TimingRow {
            octaves,
            load_seconds,
            render_seconds: best.seconds,
            texture_seconds: best.texture_seconds,
            texture_points: best.counters.texture_points,
            seed003_seconds: SEED003_OCTAVE_SECONDS
                .iter()
                .find(|r| r.0 == octaves)
                .map(|r| r.1),
        });
    }
    Ok(TimingTable {
        graph: graph.to_path_buf(),
        width: options.size.0,
        height: options.size.1,
        samples: options.samples,
        threads,
        repeats: options.repeats.max(1),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_kinds() {
        assert_eq!(
            input_kind("// c\n/* x */ #![enable(implicit_some)]\n Scene(camera: ...)"),
            InputKind::Scene
        );
        assert_eq!(input_kind("\u{feff}Graph(nodes: {})"), InputKind::Graph);
        assert_eq!(input_kind("(nodes: {})"), InputKind::Graph);
        assert_eq!(input_kind(""), InputKind::Graph);
    }

    #[test]
    fn watch_reacts_to_writes_of_watched_files_only() {
        use notify::event::{AccessKind, AccessMode, CreateKind, EventKind, ModifyKind};
        let dir = tempfile::tempdir().unwrap();
        let graph = dir.path().join("g.ron");
        std::fs::write(&graph, "Graph()").unwrap();
        let list = watch_list(&[graph.clone(), dir.path().join("gone/x.ron")]);
        assert_eq!(list.len(), 1, "a file in a missing folder is not watched");
        let canonical = dir.path().canonicalize().unwrap();
        let event = |kind, name: &str| notify::Event::new(kind).add_path(canonical.join(name));
        let modify = EventKind::Modify(ModifyKind::Any);
        assert!(relevant(&event(modify, "g.ron"), &list));
        assert!(relevant(
            &event(EventKind::Create(CreateKind::File), "g.ron"),
            &list
        ));
        assert!(relevant(
            &event(
                EventKind::Access(AccessKind::Close(AccessMode::Write)),
                "g.ron"
            ),
            &list
        ));
        // Reading the graph (as a reload does) or writing the output image next to it does not
        // trigger a reload.
        assert!(!relevant(
            &event(
                EventKind::Access(AccessKind::Open(AccessMode::Read)),
                "g.ron"
            ),
            &list
        ));
        assert!(!relevant(
            &event(
                EventKind::Access(AccessKind::Close(AccessMode::Read)),
                "g.ron"
            ),
            &list
        ));
        assert!(!relevant(&event(modify, "preview.png"), &list));
        assert!(!relevant(
            &event(modify, ".preview.png.x1y2.partial"),
            &list
        ));
    }

    #[test]
    fn srgb_encoding() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(2.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
        assert_eq!(srgb8(0.18), 118);
    }
}
