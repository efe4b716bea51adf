//! `texgraph render` and `texgraph watch`.

use super::*;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct RenderArgs {
    /// A graph file or a scene file.
    #[arg(value_name = "FILE", required_unless_present = "timing_table")]
    file: Option<PathBuf>,
    /// The PNG written (default: FILE's name with .png, in the current folder). It must end in
    /// .png, its folder must exist, and an existing destination must be a regular file (a
    /// device, FIFO, socket, link or folder is refused).
    #[arg(short = 'o', long = "out", value_name = "PNG")]
    out: Option<PathBuf>,
    /// Image size W,H in pixels.
    #[arg(long, value_name = "W,H", value_parser = parse_image_size)]
    size: Option<(u32, u32)>,
    /// Graph files only: the object carved out of the texture (sphere, cube, plane, teapot or a
    /// path to an .obj) [default: sphere].
    #[arg(long, value_name = "OBJECT")]
    object: Option<crate::render::PreviewObject>,
    /// Graph files only: object space (the texture moves with the object) or world space
    /// [default: object].
    #[arg(long, value_enum, value_name = "SPACE")]
    space: Option<crate::render::Space>,
    /// Samples per pixel (anti-aliasing).
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Graph files only: the output shown as the diffuse colour (default: `colour`).
    #[arg(long = "output", value_name = "NAME")]
    output: Option<String>,
    /// Graph files only: bump the object's surface with this scalar output of the graph as the
    /// height (evaluated where the colour is: same --set, --space and mapping).
    #[arg(long = "bump", value_name = "OUTPUT")]
    bump: Option<String>,
    /// Graph files only, with --bump: a factor on the height's gradient, any finite number
    /// (negative inverts the bumps) [default: 1].
    #[arg(long = "bump-strength", value_name = "S", requires = "bump", value_parser = parse_strength)]
    bump_strength: Option<f64>,
    /// Graph files only: override a param (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// What each texture sample shows: point (its value at the hit, with level of detail) or
    /// box (its mean over the sample's footprint, the pixel's share carried into texture space
    /// by ray differentials) [default: point: at equal texture time more point samples per
    /// pixel beat one box-filtered sample, docs/filtering.md, "Renders"].
    #[arg(long, value_enum, value_name = "FILTER")]
    filter: Option<FilterArg>,
    /// Point samples with every octave at every pixel (no level of detail per pixel): the
    /// image then aliases where a pixel covers more than the finest octave (toward the
    /// horizon). Implies --filter point.
    #[arg(long = "no-lod")]
    no_lod: bool,
    /// Shift the footprints by B octaves (level of detail, or the box filter's size): positive
    /// blurs sooner (softer, faster), negative keeps finer detail (sharper, may alias); within
    /// ±16 [default: 0].
    #[arg(long = "lod-bias", value_name = "B", conflicts_with = "no_lod", value_parser = parse_lod_bias)]
    lod_bias: Option<f64>,
    /// Where the textures are evaluated: cpu, gpu (each texture's tape as a compute shader,
    /// level of detail per pixel included; an error when no GPU is usable), or auto (the GPU
    /// when one is usable, else the CPU, saying which on stderr). The timing table always
    /// runs on the CPU.
    #[arg(long, value_enum, default_value_t)]
    device: crate::gpu::Device,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Print seed 003's timing table (500×500, octaves 1/2/4/8) for FILE (default: the seed 003
    /// marble) instead of rendering.
    #[arg(long = "timing-table")]
    timing_table: bool,
}

/// `render --filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FilterArg {
    Point,
    Box,
}

/// The render filter the flags ask for: point (with level of detail unless `--no-lod`) unless
/// box is named (on the CPU or the GPU: each texture the GPU's filtered form does not cover is
/// filtered on the CPU). A usage error where they disagree.
pub fn render_filter(
    filter: Option<FilterArg>,
    no_lod: bool,
) -> Result<crate::render::RenderFilter, String> {
    use crate::render::RenderFilter;
    match filter {
        Some(FilterArg::Box) if no_lod => Err(
            "--no-lod turns off point sampling's level of detail; with --filter box the footprint is the filter (give --filter point, or leave out --no-lod)".into(),
        ),
        Some(FilterArg::Box) => Ok(RenderFilter::Box),
        Some(FilterArg::Point) => Ok(RenderFilter::Point),
        None => Ok(RenderFilter::default()),
    }
}

pub fn parse_image_size(text: &str) -> Result<(u32, u32), String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    match parts.as_slice() {
        [w, h] => match (w.parse::<u32>(), h.parse::<u32>()) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => Ok((w, h)),
            _ => Err(format!(
                "expected W,H with positive integers, found `{text}`"
            )),
        },
        _ => Err(format!("expected W,H, found `{text}`")),
    }
}

/// A bump strength: any finite number.
pub fn parse_strength(text: &str) -> Result<f64, String> {
    match text.replace(MINUS, "-").trim().parse::<f64>() {
        Ok(s) if s.is_finite() => Ok(s),
        _ => Err(format!("the strength is a finite number, found `{text}`")),
    }
}

/// A level-of-detail bias: a finite number of octaves within ±16.
pub fn parse_lod_bias(text: &str) -> Result<f64, String> {
    let max = crate::render::RenderLod::MAX_BIAS;
    match text.replace(MINUS, "-").trim().parse::<f64>() {
        Ok(b) if b.abs() <= max => Ok(b),
        _ => Err(format!(
            "the bias is a number of octaves within ±{max}, found `{text}`"
        )),
    }
}

/// The input of render and watch must be a file; watch says so at once instead of waiting for a
/// file that is missing (render reports the read error itself).
pub fn check_render_input(file: &Path, watch: bool) -> Result<(), String> {
    match std::fs::metadata(file) {
        Ok(m) if m.is_dir() => Err(format!(
            "{}: is a folder; give a graph or scene file",
            file.display()
        )),
        Err(e) if watch => Err(format!("{}: {e}", file.display())),
        _ => Ok(()),
    }
}

pub fn render_command(args: RenderArgs, watch: bool) -> Result<(), Failure> {
    use crate::render::watch::Previewer;
    use crate::render::{self, PreviewBump, PreviewDefaults, RenderLod, RenderOptions};
    let failure = |e: &render::RenderError| {
        eprint!("{}", e.render(colour()));
        Failure::from_exit_code(e.exit_code())
    };
    let options = RenderOptions {
        size: args.size,
        samples: args.samples,
        // 0 stays 0: the renderer refuses it.
        threads: args
            .threads
            .map(|t| if t == 0 { 0 } else { threads_or_warn(t) }),
        progress: !args.quiet,
        cancel: None,
        lod: if args.no_lod {
            RenderLod::Off
        } else {
            RenderLod::On {
                bias: args.lod_bias.unwrap_or(0.0),
            }
        },
        filter: crate::render::RenderFilter::Point,
        device: crate::gpu::Device::Cpu,
    };
    if args.timing_table {
        if args.no_lod || args.lod_bias.is_some() || args.filter.is_some() {
            eprintln!("error: --filter, --no-lod and --lod-bias do not apply to --timing-table, which renders every octave as seed 003's renderer did");
            return Err(Failure::Usage);
        }
        if args.bump.is_some() {
            eprintln!("error: --bump does not apply to --timing-table, which renders seed 003's marble sphere as it is");
            return Err(Failure::Usage);
        }
        let graph = args
            .file
            .clone()
            .unwrap_or_else(|| PathBuf::from("graphs/seed003_marble.ron"));
        let timing = render::timing::TimingOptions {
            threads: options.threads,
            ..Default::default()
        };
        let table = render::timing::timing_table(&graph, &timing).map_err(|e| failure(&e))?;
        let text = format!("{table}\n");
        return write_stdout(|out| out.write_all(text.as_bytes()));
    }
    let Some(file) = args.file.clone() else {
        eprintln!("error: give a graph or scene file");
        return Err(Failure::Usage);
    };
    let filter = render_filter(args.filter, args.no_lod).map_err(|e| {
        eprintln!("error: {e}");
        Failure::Usage
    })?;
    let device = super::resolve_device(args.device, false)?;
    let options = RenderOptions {
        filter,
        device,
        ..options
    };
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from(format!(
            "{}.png",
            file.file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("render")
        ))
    });
    if let Err(e) = check_render_input(&file, watch) {
        eprintln!("error: {e}");
        return Err(Failure::Usage);
    }
    if let Err(e) = crate::output::check_file_argument(&out, "png") {
        eprintln!("error: {e}");
        return Err(Failure::Usage);
    }
    let graph_only: Vec<&str> = [
        ("--object", args.object.is_some()),
        ("--space", args.space.is_some()),
        ("--set", !args.sets.is_empty()),
        ("--output", args.output.is_some()),
        ("--bump", args.bump.is_some()),
        ("--bump-strength", args.bump_strength.is_some()),
    ]
    .into_iter()
    .filter_map(|(flag, given)| given.then_some(flag))
    .collect();
    if let Err(e) = render::refuse_graph_only_options(&file, &graph_only) {
        return Err(failure(&e));
    }
    let defaults = PreviewDefaults {
        object: args.object.clone().unwrap_or_default(),
        space: args.space.unwrap_or_default(),
        overrides: args.sets.clone(),
        output: args.output.clone(),
        bump: args.bump.clone().map(|output| PreviewBump {
            output,
            strength: args.bump_strength.unwrap_or(1.0),
        }),
    };
    let mut previewer = Previewer::new(&file, defaults, options, &out);
    if !watch {
        return match previewer.reload() {
            Ok(stats) => {
                warn_render_shortfalls(&stats);
                write_stdout(|w| writeln!(w, "wrote {}: {stats}", out.display()))
            }
            Err(e) => Err(failure(&e)),
        };
    }
    eprintln!("watching {} (Ctrl-C to stop)", file.display());
    let result = render::watch::watch(&mut previewer, |result| {
        match result {
            Ok(stats) => {
                warn_render_shortfalls(stats);
                eprintln!("{}: {stats}", out.display())
            }
            Err(e) => eprint!("{}", e.render(colour())),
        }
        std::ops::ControlFlow::Continue(())
    });
    result.map_err(|e| failure(&e))
}

/// The precision plan's shortfalls, one `warning:` line each on stderr.
fn warn_render_shortfalls(stats: &crate::render::RenderStats) {
    for why in &stats.shortfalls {
        eprintln!("warning: {why}");
    }
}
