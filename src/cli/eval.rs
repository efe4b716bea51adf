//! `texgraph eval`: evaluate a graph at one point or at every point of a file.

use super::*;
use crate::eval::Workspace;
use crate::real::Real;
use crate::tape::Tape;
use clap::Args;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

#[derive(Args)]
pub struct EvalArgs {
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
    /// The region the points lie in (`X0,Y0,Z0:X1,Y1,Z1` or `unbounded`): scalars whose f32
    /// error there could exceed --max-error run in f64. Default: the point itself; with
    /// --points, none (every scalar in f32).
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_extent, allow_hyphen_values = true)]
    extent: Option<crate::precision::Extent>,
    /// Filter: print each output's estimated mean over a box of side W (or sides WX,WY,WZ)
    /// centred on the point (one footprint for every point of --points); see docs/filtering.md.
    #[arg(long, value_name = "W|WX,WY,WZ", value_parser = parse_footprint)]
    footprint: Option<crate::filter::Footprint>,
    #[command(flatten)]
    graph: GraphOptions,
}

/// `W` or `WX,WY,WZ`: each side a number >= 0 (`inf` allowed: the mean along the whole axis).
pub fn parse_footprint(text: &str) -> Result<crate::filter::Footprint, String> {
    let sides: Vec<f64> = text
        .split(',')
        .map(|t| parse_coordinate(t).map_err(|e| format!("--footprint: {e}")))
        .collect::<Result<_, _>>()?;
    let sides = match sides[..] {
        [w] => [w; 3],
        [x, y, z] => [x, y, z],
        _ => return Err(format!("--footprint `{text}`: give W or WX,WY,WZ")),
    };
    crate::filter::Footprint::from_sides(sides).map_err(|e| format!("--footprint: {e}"))
}

pub fn parse_coordinate(text: &str) -> Result<f64, String> {
    let text = text.replacen(MINUS, "-", 1);
    text.trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))
}

pub fn eval(args: EvalArgs) -> Result<(), Failure> {
    if args.points.is_none() && args.coordinates.len() != 3 {
        eprintln!("error: give a point as three numbers X Y Z, or --points FILE");
        return Err(Failure::Usage);
    }
    let (check_options, mut compile_options) = options(&args.graph);
    compile_options.extent = args.extent.or_else(|| {
        let c = &args.coordinates;
        (args.points.is_none() && c.len() == 3)
            .then(|| crate::precision::Extent::new([c[0], c[1], c[2]], [c[0], c[1], c[2]]))
    });
    let (_, tape) = crate::load::load_tape(&args.file, &check_options, &compile_options)
        .map_err(print_load_error)?;
    if !args.double {
        warn_shortfalls(&args.file, &tape);
    }
    if args.double {
        eval_with::<f64>(&tape, &args)
    } else {
        eval_with::<f32>(&tape, &args)
    }
}

pub fn eval_with<S: Real>(tape: &Tape, args: &EvalArgs) -> Result<(), Failure> {
    let mut workspace = Workspace::<S>::new();
    let filtered = args
        .footprint
        .map(|f| (crate::filter::Filtered::new(tape), f));
    let Some(points) = &args.points else {
        let point = [
            args.coordinates[0],
            args.coordinates[1],
            args.coordinates[2],
        ];
        let mut out = vec![S::ZERO; tape.channels()];
        match &filtered {
            Some((f, footprint)) => f.eval_point(point, footprint, &mut out),
            None => tape.eval_point(&mut workspace, point, &mut out),
        }
        return write_stdout(|w| write_lines(w, tape, &out, 1));
    };
    let stdout = std::io::stdout();
    let mut writer = BufWriter::new(stdout.lock());
    let mut out = Vec::new();
    let mut evaluate = |x: &[f64], y: &[f64], z: &[f64]| -> std::io::Result<()> {
        out.resize(tape.channels() * x.len(), S::ZERO);
        match &filtered {
            Some((f, footprint)) => {
                f.eval_batch([x, y, z], std::slice::from_ref(footprint), &mut out)
            }
            None => tape.eval_batch(&mut workspace, x, y, z, &mut out),
        }
        write_lines(&mut writer, tape, &out, x.len())
    };
    let result = if points == Path::new("-") {
        crate::points::for_each_chunk(std::io::stdin().lock(), "<stdin>", 4096, &mut evaluate)
    } else {
        match std::fs::File::open(points) {
            Ok(file) => crate::points::for_each_chunk(
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
        Err(crate::points::PointsError::Output { error })
            if error.kind() == std::io::ErrorKind::BrokenPipe =>
        {
            return Ok(())
        }
        Err(e) => {
            eprintln!("error: {e}");
            return Err(Failure::from_exit_code(e.exit_code()));
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
pub fn write_lines<S: Real>(
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
