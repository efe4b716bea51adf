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
//! - [`watch`] is `texgraph watch` ([`watch::Previewer`], [`watch::watch`]): re-render on
//!   save, keep the last good image when an edit breaks something.
//! - [`timing`] has seed 003's scenes; [`timing::timing_table`] times its marble sphere at
//!   500×500 pixels for 1, 2, 4 and 8 octaves, next to the document's figures.
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
pub mod timing;
pub mod watch;

pub use error::{RenderError, MAX_PIXELS, MAX_SAMPLES, MAX_SIDE};
#[cfg(feature = "serve")]
pub(crate) use scene::Checked;
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
    /// ([`RenderLod`]). The default (issue 47): at equal texture time, point samples per
    /// pixel beat one box-filtered sample (docs/filtering.md, "Renders").
    #[default]
    Point,
    /// The estimate of the texture's mean over the sample's footprint (its pixel's share,
    /// carried into texture space by the ray differentials as an anisotropic parallelogram):
    /// the filtered form of each tape (`crate::filter`), on the CPU, or on the GPU's filtered
    /// form with `--device gpu` (or `auto` finding one) where that covers the tape.
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
    /// [`watch::Previewer::reload`] only (else 0): reading, checking and compiling the scene and its
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
    fn srgb_encoding() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(2.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
        assert_eq!(srgb8(0.18), 118);
    }
}
