//! The commands of the `texgraph` binary, as library code: each module holds one command's
//! arguments (clap) and its implementation; `main.rs` only parses and dispatches. Exit codes are
//! decided in one place, `Failure::code`.

pub mod bake;
pub mod check;
pub mod devices;
pub mod eval;
pub mod render;
pub mod report;
pub mod serve;
pub mod shader;
pub mod verify;

use crate::check::CheckOptions;
use crate::compile::CompileOptions;
use crate::source::LoadError;
use crate::tape::Tape;
use clap::Args;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::Path;

pub fn parse_spacing(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(h) if h > 0.0 && h.is_finite() => Ok(h),
        _ => Err(format!("the spacing is a positive number, found `{text}`")),
    }
}

pub fn parse_region(text: &str) -> Result<crate::grid::Region, String> {
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
            Ok(crate::grid::Region { min, max })
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
pub struct GraphOptions {
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
    /// Precision target: scalars whose f32 error could push an output further than this from
    /// the f64 reference run in f64 (absolute; default 1e-4). Chosen per instruction from the
    /// region evaluated over (a bake's region, `--extent`).
    #[arg(long = "max-error", value_name = "E", value_parser = parse_max_error)]
    max_error: Option<f64>,
}

pub fn parse_max_error(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(e) if e > 0.0 && e.is_finite() => Ok(e),
        _ => Err(format!(
            "the error target is a positive number, found `{text}`"
        )),
    }
}

/// `--extent X0,Y0,Z0:X1,Y1,Z1` (or `unbounded`): the region a tape is evaluated over.
pub fn parse_extent(text: &str) -> Result<crate::precision::Extent, String> {
    let text = text.replace(MINUS, "-");
    if text.trim() == "unbounded" {
        return Ok(crate::precision::Extent::unbounded());
    }
    crate::precision::Extent::parse(&text)
}

/// Marks a negative number that clap would mistake for a flag (see `protect_negative_numbers`).
pub const MINUS: char = '\u{2212}';

pub fn parse_set(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, found `{text}`"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("`{value}` is not a number"))?;
    Ok((name.trim().to_string(), value))
}

/// How a command failed; mapped to the exit code in one place.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Failure {
    /// A graph, scene or input file is invalid: exit code 1.
    Invalid,
    /// A usage or I/O error, a refused bake or destination: exit code 2.
    Usage,
    /// A bake interrupted by Ctrl-C: exit code 130.
    Interrupted,
}

impl Failure {
    /// The process exit code.
    pub fn code(self) -> u8 {
        match self {
            Failure::Invalid => 1,
            Failure::Usage => 2,
            Failure::Interrupted => 130,
        }
    }

    /// The failure behind a library error's `exit_code()`.
    pub fn from_exit_code(code: u8) -> Failure {
        match code {
            1 => Failure::Invalid,
            130 => Failure::Interrupted,
            _ => Failure::Usage,
        }
    }

    /// The failure a command reports after several: usage and I/O errors win over invalid
    /// input (a batch with a missing file and a broken graph exits 2).
    pub fn worst(so_far: Option<Failure>, new: Failure) -> Option<Failure> {
        Some(match (so_far, new) {
            (_, Failure::Interrupted) | (Some(Failure::Interrupted), _) => Failure::Interrupted,
            (Some(Failure::Usage), _) | (_, Failure::Usage) => Failure::Usage,
            _ => Failure::Invalid,
        })
    }
}

pub fn colour() -> bool {
    std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none()
}

/// The thread count for `--threads N` (0: one per core), capped at
/// `bake::MAX_THREADS_PER_CORE` × the cores, with a warning when capped.
pub fn threads_or_warn(requested: usize) -> usize {
    let (threads, capped) = crate::bake::capped_threads(requested);
    if capped {
        eprintln!(
            "warning: --threads {requested} is more than {} per core; using {threads}",
            crate::bake::MAX_THREADS_PER_CORE
        );
    }
    threads
}

/// Prints a load error to stderr and says which exit code it means.
pub fn print_load_error(error: LoadError) -> Failure {
    match &error {
        LoadError::Io { .. } => eprintln!("error: {error}"),
        LoadError::Invalid(diagnostics) => eprint!("{}", diagnostics.render(colour())),
    }
    Failure::from_exit_code(error.exit_code())
}

/// Runs `f` on a buffered stdout. A closed pipe (`texgraph eval ... | head`) ends quietly.
pub fn write_stdout(f: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), Failure> {
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

pub fn options(graph: &GraphOptions) -> (CheckOptions, CompileOptions) {
    (
        CheckOptions {
            overrides: graph.sets.clone(),
        },
        CompileOptions {
            outputs: graph.outputs.clone(),
            spacing: graph.spacing,
            extent: None,
            max_error: graph.max_error,
        },
    )
}

/// `--device`: `auto` resolved to the GPU or the CPU (said on stderr), `gpu` checked once
/// before the first graph (no usable GPU, or with `--f64`: a usage error).
pub(crate) fn resolve_device(
    requested: crate::gpu::Device,
    double: bool,
) -> Result<crate::gpu::Device, Failure> {
    use crate::gpu::Device;
    match requested {
        Device::Cpu => Ok(Device::Cpu),
        Device::Gpu if double => {
            eprintln!("error: --device gpu evaluates the f32 path; an --f64 bake runs on the CPU (--device cpu)");
            Err(Failure::Usage)
        }
        Device::Gpu => match crate::gpu::usable() {
            Ok(name) => {
                eprintln!("texgraph: evaluating on the GPU ({name})");
                Ok(Device::Gpu)
            }
            Err(e) => {
                eprintln!("error: --device gpu: {e}");
                Err(Failure::Usage)
            }
        },
        Device::Auto if double => {
            eprintln!(
                "texgraph: --device auto: evaluating on the CPU (an --f64 bake runs on the CPU)"
            );
            Ok(Device::Cpu)
        }
        Device::Auto => match crate::gpu::usable() {
            Ok(name) => {
                eprintln!("texgraph: --device auto: evaluating on the GPU ({name})");
                Ok(Device::Gpu)
            }
            Err(e) => {
                eprintln!("texgraph: --device auto: evaluating on the CPU ({e})");
                Ok(Device::Cpu)
            }
        },
    }
}

/// Prints the outputs of `tape` that may miss the precision target over the extent it was
/// compiled for, and why (`Tape::shortfalls`), as warnings on stderr: the evaluating commands
/// say so whenever the fast path cannot meet `--max-error`.
pub(crate) fn warn_shortfalls(file: &Path, tape: &Tape) {
    for shortfall in tape.shortfalls() {
        eprintln!("warning: {}: {shortfall}", file.display());
    }
}

/// `--size`: the numbers given (1, 2 or 3) and the three dimensions they mean (one number: a
/// cube, or a square image; W,H: an image, depth 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SizeArg {
    pub dims: [usize; 3],
    pub given: u8,
}

/// Warnings on stderr for non-finite values and, in 8/16-bit files, clamped ones.
pub(crate) fn warn_about_values(
    file: &Path,
    report: &crate::bake::BakeReport,
    clamps: bool,
    format: crate::bake::Format,
) {
    let keep = if format == crate::bake::Format::Ktx2 {
        "bake with --half or --float to keep them"
    } else {
        "bake --format exr or --raw-type f32 to keep them"
    };
    for stats in &report.stats {
        if stats.non_finite() > 0 {
            eprintln!(
                "warning: {}: output \"{}\" has {} non-finite voxel values (see the counts above)",
                file.display(),
                stats.name,
                stats.non_finite()
            );
        }
        let (below, above) = stats.clamped();
        if clamps && below + above > 0 {
            eprintln!("warning: {}: output \"{}\": {below} values below 0 and {above} above 1 were clamped to [0, 1] in the 8/16-bit file ({keep})", file.display(), stats.name);
        }
    }
}

/// A report's files and the statistics of each output, one line each.
pub(crate) fn report_body(report: &crate::bake::BakeReport, clamps: bool) -> String {
    let mut text = String::new();
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
    text
}
