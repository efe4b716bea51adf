//! The `texgraph` command line: parse arguments, call the library, print, set the exit code.
//! Exit codes: 0 success; 1 a graph or input is invalid; 2 usage or I/O error.

use clap::{Args, Parser, Subcommand};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use texgraph::{CheckOptions, CompileOptions, LoadError, Real, Tape, Workspace};

#[derive(Parser)]
#[command(
    name = "texgraph",
    version,
    about = "Procedural solid textures from RON node graphs",
    long_about = "Procedural solid textures from RON node graphs.\n\nA graph file describes a texture as nodes (noise, fbm, turbulence, math, splines, colour ramps, domain transforms). texgraph checks it, compiles the outputs you ask for to a flat instruction tape, and evaluates that tape per point or per batch. docs/format.md describes the format; `texgraph nodes` lists every node kind.\n\nExit codes: 0 success, 1 invalid graph or input, 2 usage or I/O error."
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
}

#[derive(Args)]
struct GraphOptions {
    /// Compile only this output (repeatable); default: all outputs, in file order.
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
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
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    for arg in args {
        let previous_takes_value = out
            .last()
            .and_then(|p| p.to_str())
            .is_some_and(|p| matches!(p, "--output" | "--set" | "--points"));
        match arg.to_str() {
            Some(t)
                if !previous_takes_value
                    && t.len() > 1
                    && t.starts_with('-')
                    && t.parse::<f64>().is_ok() =>
            {
                out.push(format!("{MINUS}{}", &t[1..]).into());
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
}

fn main() -> ExitCode {
    let cli = Cli::parse_from(protect_negative_numbers(std::env::args_os()));
    let result = match cli.command {
        Command::Check(args) => check(args),
        Command::Eval(args) => eval(args),
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
    }
}

fn colour() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
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
        Err(texgraph::points::PointsError::Io { error, .. })
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
