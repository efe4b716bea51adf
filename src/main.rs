//! The `texgraph` command line: clap definitions and dispatch. The commands themselves are
//! library code (`texgraph::cli`), and so is the choice of exit code (`cli::Failure::code`).
//! Exit codes: 0 success; 1 a graph or input is invalid; 2 usage or I/O error; 130 a bake interrupted by Ctrl-C.

#![forbid(unsafe_code)]

use clap::{Args, Parser, Subcommand};
use std::process::ExitCode;
use texgraph::cli::{self, bake::BakeArgs, check::CheckArgs, eval::EvalArgs, render::RenderArgs};
use texgraph::cli::{report::ReportArgs, write_stdout, MINUS};

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
    Eval(Box<EvalArgs>),
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
    Bake(Box<BakeArgs>),
    /// Check a zarr store written by `bake --format zarr` (or by the parts of a split bake):
    /// every shard present, matching its manifest's length and crc32c, baked for the array's
    /// metadata and tape.
    ///
    /// Lists what is missing, corrupt or stale. Exit code 0 when complete, 1 when any shard is
    /// not, 2 when a path is not a texgraph zarr store.
    Verify(cli::verify::VerifyArgs),
    /// Measure error against run time: every evaluation strategy against the f64 reference.
    ///
    /// For each output: the f64 reference, f32 per point and per batch, the GPU (when one is
    /// usable), f32 with footprint level of detail at spacings 1/64, 1/128, 1/256, and baked volumes at 64³, 128³, 256³ sampled back
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
    /// Serve a live authoring page: preview, slice, every node's thumbnail and cost, params as
    /// sliders, errors, hover values and the accuracy report, updated on every save.
    ///
    /// FILE is a graph file, a scene file or a folder of graphs. The page is at
    /// http://127.0.0.1:7878/ by default (localhost only unless --host); its WebSocket protocol is
    /// documented in docs/serve.md.
    Serve(cli::serve::ServeArgs),
    /// List the graphics adapters the GPU path can use (Vulkan, Metal, DX12), one per line.
    ///
    /// A software Vulkan driver (Mesa's lavapipe) is listed as a CPU adapter. Exit code 0, also
    /// when none is found (the line then says why).
    Devices(cli::devices::DevicesArgs),
    /// Export a graph as shader source: a function per output that an engine's own shader
    /// calls (WGSL, GLSL, GLSL ES, HLSL or MSL), with its level-of-detail form.
    ///
    /// `texgraph_NAME(p)` and `texgraph_NAME_lod(p, spacing)` per output, f32 throughout;
    /// documented in docs/shaders.md.
    Shader(cli::shader::ShaderArgs),
}

#[derive(Args)]
struct NodesArgs {
    /// Print the catalogue as a Markdown table (as in docs/format.md).
    #[arg(long)]
    markdown: bool,
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

fn main() -> ExitCode {
    let cli = Cli::parse_from(protect_negative_numbers(std::env::args_os()));
    let result = match cli.command {
        Command::Check(args) => cli::check::check(args),
        Command::Eval(args) => cli::eval::eval(*args),
        Command::Bake(args) => cli::bake::bake(*args),
        Command::Verify(args) => cli::verify::verify(args),
        Command::Report(args) => cli::report::report_command(args),
        Command::Render(args) => cli::render::render_command(args, false),
        Command::Watch(args) => cli::render::render_command(args, true),
        Command::Serve(args) => cli::serve::serve(args),
        Command::Devices(args) => cli::devices::devices(args),
        Command::Shader(args) => cli::shader::shader(args),
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
        Err(failure) => ExitCode::from(failure.code()),
    }
}
