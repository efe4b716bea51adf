//! Seed 003's scenes and the timing table (`texgraph render --timing-table`): its marble sphere
//! at 500×500 pixels for 1, 2, 4 and 8 octaves, timed next to the document's figures.

use super::*;

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
