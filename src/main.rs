//! The `texgraph` command line: parse arguments, call the library, print, set the exit code.
//! Exit codes: 0 success; 1 a graph or input is invalid; 2 usage or I/O error; 130 a bake interrupted by Ctrl-C.

#![forbid(unsafe_code)]

use clap::{Args, Parser, Subcommand};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use texgraph::{CheckOptions, CompileOptions, LoadError, Real, Tape, Workspace};

#[derive(Parser)]
#[command(
    name = "texgraph",
    version,
    about = "Procedural solid textures from RON node graphs",
    long_about = "Procedural solid textures from RON node graphs.\n\nA graph file describes a texture as nodes (noise, fbm, turbulence, math, splines, colour ramps, domain transforms). texgraph checks it, compiles the outputs you ask for to a flat instruction tape, and evaluates that tape per point or per batch. docs/format.md describes the format; `texgraph nodes` lists every node kind.\n\nExit codes: 0 success, 1 invalid graph or input, 2 usage or I/O error (130: a bake interrupted by Ctrl-C)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Parse and check graph files; print a summary of each (nodes, pruning, tape, outputs).
    ///
    /// Every problem in a file is reported with its file, line, column and node. Exit code 1 if
    /// any graph is invalid.
    Check(CheckArgs),
    /// Evaluate a graph at one point (X Y Z) or at every point of a file (--points).
    ///
    /// Prints one line per output: `NAME v` for scalars, `NAME r g b` for vec3, each number
    /// printed so that it round-trips. With --points, the lines of each point follow in order.
    Eval(EvalArgs),
    /// List every node kind: its arguments with types and defaults, its output, its meaning.
    Nodes(NodesArgs),
    /// Bake graphs to voxel volumes: EXR files, PNG slices (or an atlas), raw volumes.
    ///
    /// Voxel (i, j, k) samples the centre of its cell: region_min + (index + 0.5) ·
    /// (region_max − region_min) / size. Each output of each graph goes to its own file(s) in
    /// --out, named GRAPH.OUTPUT.*; files appear only when complete, and existing ones are kept
    /// unless --force. Prints min, max, mean and non-finite counts per output. Exit code 1 if a
    /// graph is invalid, 2 if a bake was refused or failed to write (the other graphs still
    /// bake), 130 if interrupted by Ctrl-C (nothing of the interrupted graph is written).
    Bake(BakeArgs),
    /// Measure error against run time: every evaluation strategy against the f64 reference.
    ///
    /// For each output: the f64 reference, f32 per point and per batch, f32 with footprint level
    /// of detail at spacings 1/64, 1/128, 1/256, and baked volumes at 64³, 128³, 256³ sampled back
    /// trilinearly — time per million points (median of --runs), speed-up, max abs and RMS error,
    /// PSNR, non-finite count, memory. --stability instead surveys every node at coordinates
    /// ±1 … ±2^31 (f32 error, continuity, non-finite values).
    Report(ReportArgs),
    /// Render a graph on an object (or a scene file) to a PNG: a ray-cast preview.
    ///
    /// A graph file alone gets the default preview scene: the object, a ground plane, a key light
    /// with shadows and a fill light. A scene file (RON: camera, lights, objects, materials whose
    /// channels are constants or graph outputs) renders as written. --timing-table prints seed
    /// 003's table (500×500 pixels, octaves 1/2/4/8) for the marble sphere.
    Render(RenderArgs),
    /// Re-render whenever the graph or scene file (or any file it uses) is saved; a broken edit
    /// prints its diagnostic and keeps the last good image.
    Watch(RenderArgs),
}

#[derive(Args)]
struct RenderArgs {
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
    object: Option<texgraph::render::PreviewObject>,
    /// Graph files only: object space (the texture moves with the object) or world space
    /// [default: object].
    #[arg(long, value_enum, value_name = "SPACE")]
    space: Option<texgraph::render::Space>,
    /// Samples per pixel (anti-aliasing).
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,
    /// Graph files only: the output shown as the diffuse colour (default: `colour`).
    #[arg(long = "output", value_name = "NAME")]
    output: Option<String>,
    /// Graph files only: override a param (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Print seed 003's timing table (500×500, octaves 1/2/4/8) for FILE (default: the seed 003
    /// marble) instead of rendering.
    #[arg(long = "timing-table")]
    timing_table: bool,
}

fn parse_image_size(text: &str) -> Result<(u32, u32), String> {
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

#[derive(Args)]
struct ReportArgs {
    /// Graph files.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Random sample points in the region (a 16³ grid is added); at most 10 000 000.
    #[arg(long, value_name = "N", default_value_t = 50_000, value_parser = clap::value_parser!(u64).range(1..=texgraph::report::MAX_POINTS as u64))]
    points: u64,
    /// Timed runs per strategy (the median is reported); 1 to 1 000.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=texgraph::report::MAX_RUNS as u64))]
    runs: u64,
    /// The region sampled (default the unit cube).
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_region, allow_hyphen_values = true)]
    region: Option<texgraph::bake::Region>,
    /// Print JSON (an array of rows) instead of a table.
    #[arg(long)]
    json: bool,
    /// Print the Markdown document docs/accuracy.md: the explanation, then per graph the
    /// table and the stability survey.
    #[arg(long, conflicts_with_all = ["json", "stability"])]
    markdown: bool,
    /// Also draw error (log) against time per point, Pareto front marked, to this PNG.
    #[arg(long, value_name = "PNG", conflicts_with_all = ["stability", "markdown"])]
    plot: Option<PathBuf>,
    /// Survey stability instead: every node at |p| = 1 … 2^31, both signs, lattice points and
    /// cell boundaries (--points, --runs, --region and --output do not apply).
    #[arg(long, conflicts_with_all = ["points", "runs", "region", "outputs"])]
    stability: bool,
    /// Report only this output (repeatable).
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
    /// Override a param of the graph (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
}

#[derive(Args)]
struct BakeArgs {
    /// Graph files to bake.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Voxels per axis: N (a cube) or NX,NY,NZ.
    #[arg(long, value_name = "N|NX,NY,NZ", default_value = "64", value_parser = parse_size)]
    size: [usize; 3],
    /// The box baked, X0,Y0,Z0:X1,Y1,Z1 (default: the unit cube 0,0,0:1,1,1).
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_region, allow_hyphen_values = true)]
    region: Option<texgraph::bake::Region>,
    /// File format.
    #[arg(long, value_enum, default_value_t)]
    format: texgraph::bake::Format,
    /// Folder the files go to (created if missing).
    #[arg(long, value_name = "DIR", default_value = "baked")]
    out: PathBuf,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Overwrite existing outputs.
    #[arg(long)]
    force: bool,
    /// EXR: 16-bit half floats instead of 32-bit.
    #[arg(long)]
    half: bool,
    /// EXR: lossless compression [default: zip].
    #[arg(long = "exr-compression", value_enum, value_name = "METHOD")]
    exr_compression: Option<texgraph::bake::ExrCompression>,
    /// PNG: bits per sample, 8 or 16 [default: 8].
    #[arg(long, value_name = "BITS", value_parser = parse_depth)]
    depth: Option<u8>,
    /// PNG: one tiled atlas image per output instead of a folder of slices.
    #[arg(long)]
    atlas: bool,
    /// Raw: sample type [default: u8].
    #[arg(long = "raw-type", value_enum, value_name = "TYPE")]
    raw_type: Option<texgraph::bake::RawSampleType>,
    /// Raw: add an opaque alpha channel (RGBA).
    #[arg(long)]
    alpha: bool,
    /// PNG and raw u8: how colours are encoded in 8/16-bit files (scalars are always linear)
    /// [default: srgb].
    #[arg(long, value_enum, value_name = "TRANSFER")]
    transfer: Option<texgraph::bake::Transfer>,
    /// Evaluate with the f64 reference path (values still stored as f32 or less).
    #[arg(long = "f64")]
    double: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Level of detail from the voxel size: leave out fbm octaves finer than the grid resolves
    /// (the spacing is the smallest voxel side; --spacing overrides it).
    #[arg(long)]
    lod: bool,
    /// Bake even if the files would exceed the 16 GiB size limit, or the format would hold more
    /// than 2 GiB in memory (EXR: the whole volume; PNG atlas: a row of tiles).
    #[arg(long = "allow-large")]
    allow_large: bool,
    #[command(flatten)]
    graph: GraphOptions,
}

fn parse_spacing(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(h) if h > 0.0 && h.is_finite() => Ok(h),
        _ => Err(format!("the spacing is a positive number, found `{text}`")),
    }
}

fn parse_depth(text: &str) -> Result<u8, String> {
    match text.trim() {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("PNG depth is 8 or 16, found `{text}`")),
    }
}

fn parse_size(text: &str) -> Result<[usize; 3], String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Result<Vec<usize>, _> = parts.iter().map(|p| p.parse::<usize>()).collect();
    match numbers.as_deref() {
        Ok([n]) if *n > 0 => Ok([*n; 3]),
        Ok([x, y, z]) if *x > 0 && *y > 0 && *z > 0 => Ok([*x, *y, *z]),
        _ => Err(format!(
            "expected N or NX,NY,NZ with positive integers, found `{text}`"
        )),
    }
}

fn parse_region(text: &str) -> Result<texgraph::bake::Region, String> {
    let text = text.replace(MINUS, "-");
    let corner = |part: &str| -> Option<[f64; 3]> {
        let v: Vec<f64> = part
            .split(',')
            .map(|p| p.trim().parse::<f64>().ok())
            .collect::<Option<_>>()?;
        (v.len() == 3 && v.iter().all(|c| c.is_finite())).then(|| [v[0], v[1], v[2]])
    };
    let (lo, hi) = text
        .split_once(':')
        .ok_or_else(|| format!("expected X0,Y0,Z0:X1,Y1,Z1, found `{text}`"))?;
    match (corner(lo), corner(hi)) {
        (Some(min), Some(max)) if (0..3).all(|a| min[a] <= max[a]) => {
            Ok(texgraph::bake::Region { min, max })
        }
        (Some(_), Some(_)) => Err(format!(
            "each minimum must be at most its maximum in `{text}`"
        )),
        _ => Err(format!(
            "expected X0,Y0,Z0:X1,Y1,Z1 with finite numbers, found `{text}`"
        )),
    }
}

#[derive(Args)]
struct GraphOptions {
    /// Compile only this output (repeatable); default: all outputs, in file order.
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
    /// Level of detail: leave out the fbm/turbulence octaves finer than samples this far apart
    /// can resolve (Nyquist), fading the last one kept. Default: keep every octave.
    #[arg(long, value_name = "H", value_parser = parse_spacing)]
    spacing: Option<f64>,
    /// Override a param of the graph (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
}

#[derive(Args)]
struct CheckArgs {
    /// Graph files to check.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Also print the tape disassembly.
    #[arg(long)]
    tape: bool,
    #[command(flatten)]
    graph: GraphOptions,
}

#[derive(Args)]
struct EvalArgs {
    /// The graph file.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// The point: X Y Z.
    /// (Negative numbers are fine: `eval g.ron -4.2 10 -1e-3`.)
    #[arg(value_name = "X Y Z", num_args = 0..=3, allow_negative_numbers = true, value_parser = parse_coordinate)]
    coordinates: Vec<f64>,
    /// Read points from a file (`-` for standard input): one `x y z` per line.
    #[arg(long, value_name = "FILE", conflicts_with = "coordinates")]
    points: Option<PathBuf>,
    /// Evaluate in double precision (the reference path) instead of f32.
    #[arg(long = "f64")]
    double: bool,
    #[command(flatten)]
    graph: GraphOptions,
}

#[derive(Args)]
struct NodesArgs {
    /// Print the catalogue as a Markdown table (as in docs/format.md).
    #[arg(long)]
    markdown: bool,
}

/// Marks a negative number that clap would mistake for a flag (see `protect_negative_numbers`).
const MINUS: char = '\u{2212}';

fn parse_coordinate(text: &str) -> Result<f64, String> {
    let text = text.replacen(MINUS, "-", 1);
    text.trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))
}

/// clap takes `-1e-3`, `-.5` and `-inf` for flags (its negative-number test knows only plain
/// decimals), and letting the coordinates accept any hyphen value would swallow the flags that
/// follow them. So numeric arguments that start with `-` (and are not an option's value) get a
/// Unicode minus sign, which `parse_coordinate` turns back.
fn protect_negative_numbers(
    args: impl Iterator<Item = std::ffi::OsString>,
) -> Vec<std::ffi::OsString> {
    // Every option that takes a value, from the clap definitions: its value is left alone (so
    // `--spacing -1` reaches its parser, and its message, as written).
    let mut takes_value: Vec<String> = Vec::new();
    let command = <Cli as clap::CommandFactory>::command();
    for sub in command.get_subcommands() {
        for arg in sub.get_arguments() {
            if arg.get_action().takes_values() && !arg.is_positional() {
                takes_value.extend(arg.get_long().map(|l| format!("--{l}")));
                takes_value.extend(arg.get_short().map(|c| format!("-{c}")));
            }
        }
    }
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    for arg in args {
        let previous_takes_value = out
            .last()
            .and_then(|p| p.to_str())
            .is_some_and(|p| takes_value.iter().any(|t| t == p));
        match arg.to_str() {
            Some(t) if t.len() > 1 && t.starts_with('-') && t.parse::<f64>().is_ok() => {
                if previous_takes_value {
                    // `--spacing -1` → `--spacing=-1`: clap takes the value as written, and
                    // its parser's message quotes it as written.
                    let option = out.pop().unwrap_or_default();
                    let mut joined = option;
                    joined.push("=");
                    joined.push(t);
                    out.push(joined);
                } else {
                    out.push(format!("{MINUS}{}", &t[1..]).into());
                }
            }
            _ => out.push(arg),
        }
    }
    out
}

fn parse_set(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, found `{text}`"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`{value}` is not a number"))?;
    Ok((name.trim().to_string(), value))
}

/// How a command ended; mapped to the exit code in one place.
enum Failure {
    Invalid,
    Usage,
    Interrupted,
}

fn main() -> ExitCode {
    let cli = Cli::parse_from(protect_negative_numbers(std::env::args_os()));
    let result = match cli.command {
        Command::Check(args) => check(args),
        Command::Eval(args) => eval(args),
        Command::Bake(args) => bake(args),
        Command::Report(args) => report_command(args),
        Command::Render(args) => render_command(args, false),
        Command::Watch(args) => render_command(args, true),
        Command::Nodes(args) => {
            let text = if args.markdown {
                texgraph::nodes::catalogue_markdown()
            } else {
                texgraph::nodes::catalogue_text()
            };
            write_stdout(|out| out.write_all(text.as_bytes()))
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Invalid) => ExitCode::from(1),
        Err(Failure::Usage) => ExitCode::from(2),
        Err(Failure::Interrupted) => ExitCode::from(130),
    }
}

fn colour() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
}

/// The thread count for `--threads N` (0: one per core), capped at
/// `bake::MAX_THREADS_PER_CORE` × the cores, with a warning when capped.
fn threads_or_warn(requested: usize) -> usize {
    let (threads, capped) = texgraph::bake::capped_threads(requested);
    if capped {
        eprintln!(
            "warning: --threads {requested} is more than {} per core; using {threads}",
            texgraph::bake::MAX_THREADS_PER_CORE
        );
    }
    threads
}

/// Prints a load error to stderr and says which exit code it means.
fn report(error: LoadError) -> Failure {
    match error {
        LoadError::Io { .. } => {
            eprintln!("error: {error}");
            Failure::Usage
        }
        LoadError::Invalid(diagnostics) => {
            eprint!("{}", diagnostics.render(colour()));
            Failure::Invalid
        }
    }
}

/// Runs `f` on a buffered stdout. A closed pipe (`texgraph eval ... | head`) ends quietly.
fn write_stdout(f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), Failure> {
    let stdout = std::io::stdout();
    let mut out = BufWriter::new(stdout.lock());
    match f(&mut out).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => {
            eprintln!("error: writing output: {e}");
            Err(Failure::Usage)
        }
    }
}

fn options(graph: &GraphOptions) -> (CheckOptions, CompileOptions) {
    (
        CheckOptions {
            overrides: graph.sets.clone(),
        },
        CompileOptions {
            outputs: graph.outputs.clone(),
            spacing: graph.spacing,
        },
    )
}

fn check(args: CheckArgs) -> Result<(), Failure> {
    let (check_options, compile_options) = options(&args.graph);
    let mut worst: Option<Failure> = None;
    for file in &args.files {
        match texgraph::load_tape(file, &check_options, &compile_options) {
            Ok((graph, tape)) => {
                let mut text = texgraph::summary::check_summary(&graph, &tape);
                if args.tape {
                    text.push_str(&tape.to_string());
                }
                write_stdout(|out| out.write_all(text.as_bytes()))?;
            }
            Err(error) => {
                let failure = report(error);
                worst = match (worst, failure) {
                    (Some(Failure::Usage), _) | (_, Failure::Usage) => Some(Failure::Usage),
                    _ => Some(Failure::Invalid),
                };
            }
        }
    }
    worst.map_or(Ok(()), Err)
}

fn eval(args: EvalArgs) -> Result<(), Failure> {
    if args.points.is_none() && args.coordinates.len() != 3 {
        eprintln!("error: give a point as three numbers X Y Z, or --points FILE");
        return Err(Failure::Usage);
    }
    let (check_options, compile_options) = options(&args.graph);
    let (_, tape) =
        texgraph::load_tape(&args.file, &check_options, &compile_options).map_err(report)?;
    if args.double {
        eval_with::<f64>(&tape, &args)
    } else {
        eval_with::<f32>(&tape, &args)
    }
}

fn eval_with<S: Real>(tape: &Tape, args: &EvalArgs) -> Result<(), Failure> {
    let mut workspace = Workspace::<S>::new();
    let Some(points) = &args.points else {
        let point = [
            args.coordinates[0],
            args.coordinates[1],
            args.coordinates[2],
        ];
        let mut out = vec![S::ZERO; tape.channels()];
        tape.eval_point(&mut workspace, point, &mut out);
        return write_stdout(|w| write_lines(w, tape, &out, 1));
    };
    let stdout = std::io::stdout();
    let mut writer = BufWriter::new(stdout.lock());
    let mut out = Vec::new();
    let mut evaluate = |x: &[f64], y: &[f64], z: &[f64]| -> std::io::Result<()> {
        out.resize(tape.channels() * x.len(), S::ZERO);
        tape.eval_batch(&mut workspace, x, y, z, &mut out);
        write_lines(&mut writer, tape, &out, x.len())
    };
    let result = if points == Path::new("-") {
        texgraph::points::for_each_chunk(std::io::stdin().lock(), "<stdin>", 4096, &mut evaluate)
    } else {
        match std::fs::File::open(points) {
            Ok(file) => texgraph::points::for_each_chunk(
                std::io::BufReader::new(file),
                &points.display().to_string(),
                4096,
                &mut evaluate,
            ),
            Err(e) => {
                eprintln!("error: {}: {e}", points.display());
                return Err(Failure::Usage);
            }
        }
    };
    let flushed = writer.flush();
    match result {
        Ok(()) => {}
        Err(texgraph::points::PointsError::Output { error })
            if error.kind() == std::io::ErrorKind::BrokenPipe =>
        {
            return Ok(())
        }
        Err(e @ texgraph::points::PointsError::Malformed { .. }) => {
            eprintln!("error: {e}");
            return Err(Failure::Invalid);
        }
        Err(e) => {
            eprintln!("error: {e}");
            return Err(Failure::Usage);
        }
    }
    match flushed {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: writing output: {e}");
            Err(Failure::Usage)
        }
        _ => Ok(()),
    }
}

/// Writes `NAME v` / `NAME r g b` lines for `n` points of a planar output buffer.
fn write_lines<S: Real>(
    w: &mut dyn Write,
    tape: &Tape,
    out: &[S],
    n: usize,
) -> std::io::Result<()> {
    for i in 0..n {
        for output in &tape.outputs {
            write!(w, "{}", output.name)?;
            for c in 0..output.ty.channels() {
                write!(w, " {}", out[(output.first_channel + c) * n + i])?;
            }
            writeln!(w)?;
        }
    }
    Ok(())
}

/// Options given that do not apply to the chosen format: each a usage error, not ignored.
fn bake_option_misuse(args: &BakeArgs) -> Vec<String> {
    use texgraph::bake::{Format, RawSampleType};
    let format = args.format;
    let name = match format {
        Format::Exr => "exr",
        Format::Png => "png",
        Format::Raw => "raw",
    };
    let mut problems = Vec::new();
    let mut only = |given: bool, option: &str, applies: bool, to: &str| {
        if given && !applies {
            problems.push(format!(
                "{option} applies to {to} only, not to --format {name}"
            ));
        }
    };
    only(args.half, "--half", format == Format::Exr, "--format exr");
    only(
        args.exr_compression.is_some(),
        "--exr-compression",
        format == Format::Exr,
        "--format exr",
    );
    only(
        args.depth.is_some(),
        "--depth",
        format == Format::Png,
        "--format png",
    );
    only(args.atlas, "--atlas", format == Format::Png, "--format png");
    only(
        args.raw_type.is_some(),
        "--raw-type",
        format == Format::Raw,
        "--format raw",
    );
    only(args.alpha, "--alpha", format == Format::Raw, "--format raw");
    let eight_bit = format == Format::Png
        || (format == Format::Raw && args.raw_type.unwrap_or_default() == RawSampleType::U8);
    only(
        args.transfer.is_some(),
        "--transfer",
        eight_bit,
        "8/16-bit files (--format png, --format raw with --raw-type u8)",
    );
    problems
}

fn bake(args: BakeArgs) -> Result<(), Failure> {
    use texgraph::bake::{bake_files, BakeError, BakeFileOptions, BakeOptions, Grid, Precision};
    let misuse = bake_option_misuse(&args);
    if !misuse.is_empty() {
        for problem in misuse {
            eprintln!("error: {problem}");
        }
        return Err(Failure::Usage);
    }
    let threads = threads_or_warn(args.threads);
    let cancel = Arc::new(AtomicBool::new(false));
    {
        // Ctrl-C stops between windows; temporary files are removed and nothing is renamed
        // into place. A second Ctrl-C is left to the default (the flag is already set).
        let cancel = cancel.clone();
        let _ = ctrlc::set_handler(move || cancel.store(true, Ordering::Relaxed));
    }
    let (check_options, mut compile_options) = options(&args.graph);
    let grid = Grid {
        size: args.size,
        region: args.region.unwrap_or_default(),
    };
    if args.lod && compile_options.spacing.is_none() {
        let spacing = grid.spacing().into_iter().fold(f64::INFINITY, f64::min);
        compile_options.spacing = (spacing > 0.0 && spacing.is_finite()).then_some(spacing);
    }
    let show_progress = !args.quiet && std::io::stderr().is_terminal();
    let mut worst: Option<Failure> = None;
    let fail = |worst: &mut Option<Failure>, f: Failure| {
        *worst = match (worst.take(), f) {
            (Some(Failure::Usage), _) | (_, Failure::Usage) => Some(Failure::Usage),
            _ => Some(Failure::Invalid),
        };
    };
    let (mut total_voxels, mut total_seconds, mut baked) = (0u64, 0f64, 0usize);
    let mut produced: std::collections::HashSet<PathBuf> = std::collections::HashSet::new();
    for file in &args.files {
        let (graph, tape) = match texgraph::load_tape(file, &check_options, &compile_options) {
            Ok(loaded) => loaded,
            Err(error) => {
                let failure = report(error);
                fail(&mut worst, failure);
                continue;
            }
        };
        let stem = file
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("graph")
            .to_string();
        let mut options = BakeFileOptions::new(stem, &args.out);
        options.bake = BakeOptions {
            grid,
            threads,
            precision: if args.double {
                Precision::F64
            } else {
                Precision::F32
            },
            cancel: Some(cancel.clone()),
        };
        options.format = args.format;
        options.force = args.force;
        options.half = args.half;
        options.exr_compression = args.exr_compression.unwrap_or_default();
        options.depth16 = args.depth == Some(16);
        options.atlas = args.atlas;
        options.raw_type = args.raw_type.unwrap_or_default();
        options.alpha = args.alpha;
        options.transfer = args.transfer.unwrap_or_default();
        options.graph_path = file.display().to_string();
        options.params = graph.params.clone();
        options.overrides = args.graph.sets.clone();
        if args.allow_large {
            options.max_bytes = u64::MAX;
            options.max_held_bytes = u64::MAX;
        }
        // Two graphs with the same file name (a/x.ron, b/x.ron) would write the same files.
        let planned = match texgraph::bake::planned_outputs(&tape, &options) {
            Ok(planned) => planned,
            Err(error) => {
                eprintln!("error: {}: {error}", file.display());
                fail(&mut worst, Failure::Usage);
                continue;
            }
        };
        if let Some(clash) = planned.iter().find(|p| produced.contains(*p)) {
            eprintln!("error: {}: {} was already written by an earlier graph of this batch (same file name); bake them into different --out folders", file.display(), clash.display());
            fail(&mut worst, Failure::Usage);
            continue;
        }
        let voxels = grid.voxels().unwrap_or(u64::MAX);
        let bar = if show_progress {
            let bar = indicatif::ProgressBar::new(voxels);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{msg} [{bar:30}] {percent:>3}% {human_pos}/{human_len} voxels, {eta} left",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar.set_message(file.display().to_string());
            Some(bar)
        } else {
            None
        };
        let result = bake_files(&tape, &options, &mut |done| {
            if let Some(bar) = &bar {
                bar.set_position(done);
            }
        });
        if let Some(bar) = &bar {
            bar.finish_and_clear();
        }
        match result {
            Ok(report) => {
                produced.extend(planned);
                baked += 1;
                total_voxels += report.voxels;
                total_seconds += report.seconds;
                let clamps = options.format == texgraph::bake::Format::Png
                    || (options.format == texgraph::bake::Format::Raw
                        && options.raw_type == texgraph::bake::RawSampleType::U8);
                let text = bake_report(file, &grid, &report, threads, clamps);
                write_stdout(|out| out.write_all(text.as_bytes()))?;
                for stats in &report.stats {
                    if stats.non_finite() > 0 {
                        eprintln!("warning: {}: output \"{}\" has {} non-finite voxel values (see the counts above)", file.display(), stats.name, stats.non_finite());
                    }
                    let (below, above) = stats.clamped();
                    if clamps && below + above > 0 {
                        eprintln!("warning: {}: output \"{}\": {below} values below 0 and {above} above 1 were clamped to [0, 1] in the 8/16-bit file (bake --format exr or --raw-type f32 to keep them)", file.display(), stats.name);
                    }
                }
            }
            Err(BakeError::Cancelled) => {
                eprintln!(
                    "error: {}: interrupted; no output was written",
                    file.display()
                );
                return Err(Failure::Interrupted);
            }
            Err(error) => {
                eprintln!("error: {}: {error}", file.display());
                fail(&mut worst, Failure::Usage);
            }
        }
    }
    if args.files.len() > 1 {
        let failed = args.files.len() - baked;
        let rate = if total_seconds > 0.0 {
            total_voxels as f64 / total_seconds / 1e6
        } else {
            0.0
        };
        let line = format!("baked {baked} of {} graphs: {total_voxels} voxels in {total_seconds:.3} s, {rate:.2} Mvoxels/s{}\n", args.files.len(), if failed > 0 { format!("; {failed} failed") } else { String::new() });
        write_stdout(|out| out.write_all(line.as_bytes()))?;
    }
    worst.map_or(Ok(()), Err)
}

/// The per-graph report: files, statistics per output, and the speed line.
fn bake_report(
    file: &Path,
    grid: &texgraph::bake::Grid,
    report: &texgraph::bake::BakeReport,
    threads: usize,
    clamps: bool,
) -> String {
    let [nx, ny, nz] = grid.size;
    let (lo, hi) = (grid.region.min, grid.region.max);
    let mut text = format!(
        "{}: {nx}×{ny}×{nz} voxels over [{}, {}, {}]..[{}, {}, {}]\n",
        file.display(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2]
    );
    for baked in &report.files {
        text.push_str(&format!(
            "  {} -> {} ({})\n",
            baked.output,
            baked.path.display(),
            baked.description
        ));
    }
    let list = |values: Vec<f64>| -> String {
        // f32 precision is plenty for a report; scientific notation keeps tiny values short.
        let short = |v: f64| {
            let v = v as f32;
            if v != 0.0 && v.is_finite() && !(1e-4..1e7).contains(&v.abs()) {
                format!("{v:e}")
            } else {
                v.to_string()
            }
        };
        let parts: Vec<String> = values.iter().map(|v| short(*v)).collect();
        if parts.len() == 1 {
            parts[0].clone()
        } else {
            format!("({})", parts.join(", "))
        }
    };
    for stats in &report.stats {
        let c = &stats.channels;
        let non_finite = stats.non_finite();
        let detail = if non_finite > 0 {
            let nan: u64 = c.iter().map(|s| s.nan).sum();
            let pos: u64 = c.iter().map(|s| s.pos_inf).sum();
            let neg: u64 = c.iter().map(|s| s.neg_inf).sum();
            format!("{non_finite} (NaN {nan}, +inf {pos}, -inf {neg})")
        } else {
            "0".to_string()
        };
        let (below, above) = stats.clamped();
        let range = if c.iter().all(|s| s.finite() == 0) {
            "no finite values".to_string()
        } else {
            // A channel without finite values shows NaN instead of ±inf.
            let shown = |v: f64| if v.is_infinite() { f64::NAN } else { v };
            format!(
                "min {} max {} mean {}",
                list(c.iter().map(|s| shown(s.min)).collect()),
                list(c.iter().map(|s| shown(s.max)).collect()),
                list(c.iter().map(|s| s.mean).collect()),
            )
        };
        let clamped = if clamps {
            format!("; clamped to [0, 1]: {below} below 0, {above} above 1")
        } else {
            String::new()
        };
        text.push_str(&format!(
            "  {}: {range}; non-finite {detail}{clamped}\n",
            stats.name,
        ));
    }
    let rate = if report.seconds > 0.0 {
        report.voxels as f64 / report.seconds / 1e6
    } else {
        0.0
    };
    let threads = texgraph::bake::capped_threads(threads).0;
    text.push_str(&format!(
        "  {} voxels in {:.3} s: {rate:.2} Mvoxels/s on {threads} thread(s)\n",
        report.voxels, report.seconds
    ));
    text
}

fn report_command(args: ReportArgs) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        if let Err(e) = texgraph::output::check_file_argument(path, "png") {
            eprintln!("error: {e}");
            return Err(Failure::Usage);
        }
    }
    let check_options = CheckOptions {
        overrides: args.sets.clone(),
    };
    let mut worst: Option<Failure> = None;
    let mut json_rows: Vec<serde_json::Value> = Vec::new();
    if args.markdown {
        write_stdout(|out| out.write_all(texgraph::report::MARKDOWN_HEADER.as_bytes()))?;
    }
    for file in &args.files {
        let graph = match texgraph::load_graph(file, &check_options) {
            Ok(graph) => graph,
            Err(error) => {
                let failure = report(error);
                worst = Some(match (worst, failure) {
                    (Some(Failure::Usage), _) | (_, Failure::Usage) => Failure::Usage,
                    _ => Failure::Invalid,
                });
                continue;
            }
        };
        let options = texgraph::report::ReportOptions {
            points: args.points as usize,
            runs: args.runs as usize,
            region: args.region.unwrap_or_default(),
            ..Default::default()
        };
        let text = if args.markdown {
            let rows = texgraph::report::accuracy_report(&graph, &args.outputs, &options)
                .map_err(|d| report(LoadError::Invalid(d)))?;
            let stability = texgraph::stability::stability_report(&graph)
                .map_err(|d| report(LoadError::Invalid(d)))?;
            format!(
                "\n## `{}`\n\nTape length: {}.\n{}\nStability:\n\n```text\n{}```\n",
                file.display(),
                tape_lengths(&graph),
                texgraph::report::table_markdown(&rows),
                texgraph::stability::stability_text(&stability)
            )
        } else if args.stability {
            let rows = texgraph::stability::stability_report(&graph)
                .map_err(|d| report(LoadError::Invalid(d)))?;
            if args.json {
                json_rows.extend(
                    rows.iter().map(
                        |r| serde_json::json!({ "graph": file.display().to_string(), "row": r }),
                    ),
                );
                continue;
            }
            format!(
                "{}: stability\n{}",
                file.display(),
                texgraph::stability::stability_text(&rows)
            )
        } else {
            let rows = texgraph::report::accuracy_report(&graph, &args.outputs, &options)
                .map_err(|d| report(LoadError::Invalid(d)))?;
            if let Some(path) = &args.plot {
                if let Err(e) = texgraph::report::plot(&rows, &file.display().to_string(), path) {
                    eprintln!("error: {}: {e}", path.display());
                    worst = Some(Failure::Usage);
                }
            }
            if args.json {
                json_rows.extend(rows.iter().map(|r| {
                    let mut value = serde_json::to_value(r).unwrap_or_default();
                    if let Some(object) = value.as_object_mut() {
                        object.insert(
                            "graph".into(),
                            serde_json::json!(file.display().to_string()),
                        );
                    }
                    value
                }));
                continue;
            }
            let tapes = tape_lengths(&graph);
            format!(
                "{}: {} points in [{}], median of {} runs, one thread; tape length {tapes}\n{}",
                file.display(),
                args.points as usize + 4096,
                region_text(&options.region),
                args.runs,
                texgraph::report::table_text(&rows)
            )
        };
        write_stdout(|out| out.write_all(text.as_bytes()))?;
    }
    if args.json {
        let text = serde_json::to_string_pretty(&json_rows).unwrap_or_default() + "\n";
        write_stdout(|out| out.write_all(text.as_bytes()))?;
    }
    worst.map_or(Ok(()), Err)
}

/// "all outputs 10, colour 10, vein 8": tape length per output set.
fn tape_lengths(graph: &texgraph::CheckedGraph) -> String {
    let mut parts = Vec::new();
    if let Ok(tape) = texgraph::compile(graph, &CompileOptions::default()) {
        parts.push(format!("all outputs {}", tape.instrs.len()));
    }
    for output in &graph.outputs {
        if let Ok(tape) = texgraph::compile(
            graph,
            &CompileOptions {
                outputs: vec![output.name.clone()],
                spacing: None,
            },
        ) {
            parts.push(format!("{} {}", output.name, tape.instrs.len()));
        }
    }
    parts.join(", ")
}

fn region_text(region: &texgraph::bake::Region) -> String {
    format!(
        "{}, {}, {} .. {}, {}, {}",
        region.min[0], region.min[1], region.min[2], region.max[0], region.max[1], region.max[2]
    )
}

/// The input of render and watch must be a file; watch says so at once instead of waiting for a
/// file that is missing (render reports the read error itself).
fn check_render_input(file: &Path, watch: bool) -> Result<(), String> {
    match std::fs::metadata(file) {
        Ok(m) if m.is_dir() => Err(format!(
            "{}: is a folder; give a graph or scene file",
            file.display()
        )),
        Err(e) if watch => Err(format!("{}: {e}", file.display())),
        _ => Ok(()),
    }
}

fn render_command(args: RenderArgs, watch: bool) -> Result<(), Failure> {
    use texgraph::render::{self, PreviewDefaults, Previewer, RenderOptions};
    let failure = |e: &render::RenderError| {
        eprint!("{}", e.render(colour()));
        if e.exit_code() == 1 {
            Failure::Invalid
        } else {
            Failure::Usage
        }
    };
    let options = RenderOptions {
        size: args.size,
        samples: args.samples,
        // 0 stays 0: the renderer refuses it.
        threads: args
            .threads
            .map(|t| if t == 0 { 0 } else { threads_or_warn(t) }),
        progress: !args.quiet,
    };
    if args.timing_table {
        let graph = args
            .file
            .clone()
            .unwrap_or_else(|| PathBuf::from("graphs/seed003_marble.ron"));
        let timing = render::TimingOptions {
            threads: options.threads,
            ..Default::default()
        };
        let table = render::timing_table(&graph, &timing).map_err(|e| failure(&e))?;
        let text = format!("{table}\n");
        return write_stdout(|out| out.write_all(text.as_bytes()));
    }
    let Some(file) = args.file.clone() else {
        eprintln!("error: give a graph or scene file");
        return Err(Failure::Usage);
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
    if let Err(e) = texgraph::output::check_file_argument(&out, "png") {
        eprintln!("error: {e}");
        return Err(Failure::Usage);
    }
    let graph_only: Vec<&str> = [
        ("--object", args.object.is_some()),
        ("--space", args.space.is_some()),
        ("--set", !args.sets.is_empty()),
        ("--output", args.output.is_some()),
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
    };
    let mut previewer = Previewer::new(&file, defaults, options, &out);
    if !watch {
        return match previewer.reload() {
            Ok(stats) => write_stdout(|w| writeln!(w, "wrote {}: {stats}", out.display())),
            Err(e) => Err(failure(&e)),
        };
    }
    eprintln!("watching {} (Ctrl-C to stop)", file.display());
    let result = render::watch(&mut previewer, |result| {
        match result {
            Ok(stats) => eprintln!("{}: {stats}", out.display()),
            Err(e) => eprint!("{}", e.render(colour())),
        }
        std::ops::ControlFlow::Continue(())
    });
    result.map_err(|e| failure(&e))
}
