//! `texgraph report`: error against run time, the stability survey, the Markdown document.

use super::*;
use crate::check::CheckOptions;
use crate::compile::CompileOptions;
use crate::source::LoadError;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ReportArgs {
    /// Graph files.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Random sample points in the region (a 16³ grid is added); at most 10 000 000.
    #[arg(long, value_name = "N", default_value_t = 50_000, value_parser = clap::value_parser!(u64).range(1..=crate::report::MAX_POINTS as u64))]
    points: u64,
    /// Timed runs per strategy (the median is reported); 1 to 1 000.
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=crate::report::MAX_RUNS as u64))]
    runs: u64,
    /// The region sampled (default the unit cube).
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_region, allow_hyphen_values = true)]
    region: Option<crate::grid::Region>,
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
    /// Compare mip levels instead: for each level of a --mip-size³ grid, the error of
    /// graph-prefiltered levels (what `bake --mips` writes) and of box-downsampled levels
    /// against the f64 reference box-filtered over each voxel (4³ points per level-0 voxel).
    #[arg(long, conflicts_with_all = ["stability", "markdown", "plot", "points", "runs"])]
    mips: bool,
    /// Compare ways of showing a footprint instead (docs/filtering.md): for cubes of side 1/2,
    /// 1/8 and 1/32 centred at --boxes random points of the region, the RMS error against a
    /// 216-sample stratified f64 box mean of point sampling, 4 and 16 samples per box (Latin
    /// hypercubes) and the filtered evaluation, with their times per box; --plot draws error
    /// against time.
    #[arg(long, conflicts_with_all = ["stability", "markdown", "mips", "points", "runs"])]
    filtering: bool,
    /// With --filtering: random boxes per side (1 to 100 000).
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=100_000), requires = "filtering")]
    boxes: u64,
    /// With --mips: voxels per axis of level 0.
    #[arg(long = "mip-size", value_name = "N", default_value_t = 64, value_parser = clap::value_parser!(u64).range(1..=512), requires = "mips")]
    mip_size: u64,
    /// Report only this output (repeatable).
    #[arg(long = "output", value_name = "NAME")]
    outputs: Vec<String>,
    /// Override a param of the graph (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    sets: Vec<(String, f64)>,
    /// The precision target of the tapes compiled for each extent (stability survey); default
    /// 1e-4.
    #[arg(long = "max-error", value_name = "E", value_parser = parse_max_error)]
    max_error: Option<f64>,
}

pub fn report_command(args: ReportArgs) -> Result<(), Failure> {
    if let Some(path) = &args.plot {
        if let Err(e) = crate::output::check_file_argument(path, "png") {
            eprintln!("error: {e}");
            return Err(Failure::Usage);
        }
    }
    let check_options = CheckOptions {
        overrides: args.sets.clone(),
    };
    let max_error = args
        .max_error
        .unwrap_or(crate::precision::DEFAULT_MAX_ERROR);
    let mut worst: Option<Failure> = None;
    let mut json_rows: Vec<serde_json::Value> = Vec::new();
    if args.markdown {
        write_stdout(|out| out.write_all(crate::report::MARKDOWN_HEADER.as_bytes()))?;
    }
    for file in &args.files {
        let graph = match crate::load::load_graph(file, &check_options) {
            Ok(graph) => graph,
            Err(error) => {
                let failure = print_load_error(error);
                worst = Failure::worst(worst, failure);
                continue;
            }
        };
        let options = crate::report::ReportOptions {
            points: args.points as usize,
            runs: args.runs as usize,
            region: args.region.unwrap_or_default(),
            ..Default::default()
        };
        if args.filtering {
            let rows = match filtering_rows(&graph, &args) {
                Ok(rows) => rows,
                Err(failure) => {
                    worst = Failure::worst(worst, failure);
                    continue;
                }
            };
            if let Some(path) = &args.plot {
                let title = file.display().to_string();
                if let Err(e) = crate::filter_report::filter_plot(&rows, &title, path) {
                    eprintln!("error: {}: {e}", path.display());
                    worst = Some(Failure::Usage);
                }
            }
            if args.json {
                json_rows.extend(graph_rows(file, &rows));
                continue;
            }
            let text = format!(
                "{}: box means over {} random cubes per side in [{}], against {} stratified f64 samples per box; one thread\n{}",
                file.display(),
                args.boxes,
                region_text(&args.region.unwrap_or_default()),
                crate::filter_report::REFERENCE_SAMPLES,
                crate::filter_report::filter_table_markdown(&rows)
            );
            write_stdout(|out| out.write_all(text.as_bytes()))?;
            continue;
        }
        if args.mips {
            let region = args.region.unwrap_or_default();
            let rows = crate::mip_report::mip_report(&graph, args.mip_size as usize, region)
                .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
            let rows: Vec<_> = rows
                .into_iter()
                .filter(|r| args.outputs.is_empty() || args.outputs.contains(&r.output))
                .collect();
            if args.json {
                json_rows.extend(graph_rows(file, &rows));
                continue;
            }
            let text = format!(
                "{}: mip levels of a {}³ bake over [{}], error against the f64 reference box-filtered over each voxel\n{}",
                file.display(),
                args.mip_size,
                region_text(&region),
                crate::mip_report::mip_table_markdown(&rows)
            );
            write_stdout(|out| out.write_all(text.as_bytes()))?;
            continue;
        }
        let text =
            if args.markdown {
                let rows = crate::report::accuracy_report(&graph, &args.outputs, &options)
                    .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
                let stability = crate::stability::stability_report_with_gpu(&graph, max_error)
                    .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
                format!(
                    "\n## `{}`\n\nTape length: {}.\n{}\nStability:\n\n```text\n{}```\n",
                    file.display(),
                    tape_lengths(&graph),
                    crate::report::table_markdown(&rows),
                    crate::stability::stability_text(&stability)
                )
            } else if args.stability {
                let rows = crate::stability::stability_report_with_gpu(&graph, max_error)
                    .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
                if args.json {
                    json_rows.extend(rows.iter().map(
                        |r| serde_json::json!({ "graph": file.display().to_string(), "row": r }),
                    ));
                    continue;
                }
                format!(
                    "{}: stability\n{}",
                    file.display(),
                    crate::stability::stability_text(&rows)
                )
            } else {
                let rows = crate::report::accuracy_report(&graph, &args.outputs, &options)
                    .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
                if let Some(path) = &args.plot {
                    if let Err(e) = crate::report::plot(&rows, &file.display().to_string(), path) {
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
                    crate::report::table_text(&rows)
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

/// `{ "graph": FILE, "row": ROW }` per row, the JSON of `--mips` and `--filtering`.
fn graph_rows<'r, T: serde::Serialize>(
    file: &'r std::path::Path,
    rows: &'r [T],
) -> impl Iterator<Item = serde_json::Value> + 'r {
    rows.iter()
        .map(move |r| serde_json::json!({ "graph": file.display().to_string(), "row": r }))
}

/// The filtering table's rows for `graph` (only the `--output`s asked for).
fn filtering_rows(
    graph: &crate::graph::CheckedGraph,
    args: &ReportArgs,
) -> Result<Vec<crate::filter_report::FilterRow>, Failure> {
    let options = CompileOptions {
        outputs: args.outputs.clone(),
        ..Default::default()
    };
    let tape = crate::compile::compile(graph, &options)
        .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
    let options = crate::filter_report::FilterOptions {
        boxes: args.boxes as usize,
        region: args.region.unwrap_or_default(),
        ..Default::default()
    };
    Ok(crate::filter_report::filter_report(&tape, &options))
}

/// "all outputs 10, colour 10, vein 8": tape length per output set.
pub fn tape_lengths(graph: &crate::graph::CheckedGraph) -> String {
    let mut parts = Vec::new();
    if let Ok(tape) = crate::compile::compile(graph, &CompileOptions::default()) {
        parts.push(format!("all outputs {}", tape.instrs.len()));
    }
    for output in &graph.outputs {
        if let Ok(tape) = crate::compile::compile(
            graph,
            &CompileOptions {
                outputs: vec![output.name.clone()],
                spacing: None,
                ..Default::default()
            },
        ) {
            parts.push(format!("{} {}", output.name, tape.instrs.len()));
        }
    }
    parts.join(", ")
}

pub fn region_text(region: &crate::grid::Region) -> String {
    format!(
        "{}, {}, {} .. {}, {}, {}",
        region.min[0], region.min[1], region.min[2], region.max[0], region.max[1], region.max[2]
    )
}
