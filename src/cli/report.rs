//! `texgraph report`: error against run time, the stability survey, the Markdown document.

use super::*;
use crate::check::CheckOptions;
use crate::compile::CompileOptions;
use crate::source::LoadError;
use clap::Args;
use std::path::{Path, PathBuf};

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
    /// hypercubes), the filtered evaluation, and as many samples per box as fit in the
    /// filtered evaluation's time (equal time: which wins), with their times per box; --plot
    /// draws error against time.
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
    let mut report = Report {
        args: &args,
        worst: None,
        json_rows: Vec::new(),
    };
    if args.markdown {
        write_stdout(|out| out.write_all(crate::report::MARKDOWN_HEADER.as_bytes()))?;
    }
    for file in &args.files {
        let graph = match crate::load::load_graph(file, &check_options) {
            Ok(graph) => graph,
            Err(error) => {
                report.failed(print_load_error(error));
                continue;
            }
        };
        let text = if args.filtering {
            report.filtering(file, &graph)
        } else if args.mips {
            report.mips(file, &graph)?
        } else if args.markdown || args.stability {
            report.stability(file, &graph)?
        } else {
            report.accuracy(file, &graph)?
        };
        if let Some(text) = text {
            write_stdout(|out| out.write_all(text.as_bytes()))?;
        }
    }
    if args.json {
        let text = serde_json::to_string_pretty(&report.json_rows).unwrap_or_default() + "\n";
        write_stdout(|out| out.write_all(text.as_bytes()))?;
    }
    report.worst.map_or(Ok(()), Err)
}

/// One `report` run: its arguments, the worst failure of the graphs that failed (the others
/// are still reported), and the rows `--json` prints at the end.
struct Report<'a> {
    args: &'a ReportArgs,
    worst: Option<Failure>,
    json_rows: Vec<serde_json::Value>,
}

impl Report<'_> {
    fn failed(&mut self, failure: Failure) {
        self.worst = Failure::worst(self.worst, failure);
    }

    /// `--plot FILE` of one graph's rows; a failure is reported and the run goes on.
    fn plot(&mut self, made: Result<(), String>) {
        if let (Err(e), Some(path)) = (made, &self.args.plot) {
            eprintln!("error: {}: {e}", path.display());
            self.failed(Failure::Usage);
        }
    }

    /// `--filtering`: the filtered form against point sampling and supersampling; the text
    /// to print (`None` with `--json` or when the graph failed).
    fn filtering(&mut self, file: &Path, graph: &crate::graph::CheckedGraph) -> Option<String> {
        let args = self.args;
        let rows = match filtering_rows(graph, args) {
            Ok(rows) => rows,
            Err(failure) => {
                self.failed(failure);
                return None;
            }
        };
        if let Some(path) = &args.plot {
            let title = file.display().to_string();
            let made = crate::filter_report::filter_plot(&rows, &title, path);
            self.plot(made.map_err(|e| e.to_string()));
        }
        if args.json {
            self.json_rows.extend(graph_rows(file, &rows));
            return None;
        }
        Some(format!(
            "{}: box means over {} random cubes per side in [{}], against {} stratified f64 samples per box; one thread\n{}",
            file.display(),
            args.boxes,
            region_text(&args.region.unwrap_or_default()),
            crate::filter_report::REFERENCE_SAMPLES,
            crate::filter_report::filter_table_markdown(&rows)
        ))
    }

    /// `--mips`: the mip levels against the box-filtered reference.
    fn mips(
        &mut self,
        file: &Path,
        graph: &crate::graph::CheckedGraph,
    ) -> Result<Option<String>, Failure> {
        let args = self.args;
        let region = args.region.unwrap_or_default();
        let rows = crate::mip_report::mip_report(graph, args.mip_size as usize, region)
            .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
        let rows: Vec<_> = rows
            .into_iter()
            .filter(|r| args.outputs.is_empty() || args.outputs.contains(&r.output))
            .collect();
        if args.json {
            self.json_rows.extend(graph_rows(file, &rows));
            return Ok(None);
        }
        Ok(Some(format!(
            "{}: mip levels of a {}³ bake over [{}], error against the f64 reference box-filtered over each voxel\n{}",
            file.display(),
            args.mip_size,
            region_text(&region),
            crate::mip_report::mip_table_markdown(&rows)
        )))
    }

    /// `--stability` (and `--markdown`, which adds the accuracy table): every node from
    /// |p| = 1 to 2^31.
    fn stability(
        &mut self,
        file: &Path,
        graph: &crate::graph::CheckedGraph,
    ) -> Result<Option<String>, Failure> {
        let args = self.args;
        let max_error = args
            .max_error
            .unwrap_or(crate::precision::DEFAULT_MAX_ERROR);
        let stability = crate::stability::stability_report_with_gpu(graph, max_error)
            .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
        if args.markdown {
            let rows = crate::report::accuracy_report(graph, &args.outputs, &self.options())
                .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
            return Ok(Some(format!(
                "\n## `{}`\n\nTape length: {}.\n{}\nStability:\n\n```text\n{}```\n",
                file.display(),
                tape_lengths(graph),
                crate::report::table_markdown(&rows),
                crate::stability::stability_text(&stability)
            )));
        }
        if args.json {
            self.json_rows.extend(
                stability
                    .iter()
                    .map(|r| serde_json::json!({ "graph": file.display().to_string(), "row": r })),
            );
            return Ok(None);
        }
        Ok(Some(format!(
            "{}: stability\n{}",
            file.display(),
            crate::stability::stability_text(&stability)
        )))
    }

    /// The default report: every strategy against the f64 reference, with times.
    fn accuracy(
        &mut self,
        file: &Path,
        graph: &crate::graph::CheckedGraph,
    ) -> Result<Option<String>, Failure> {
        let args = self.args;
        let options = self.options();
        let rows = crate::report::accuracy_report(graph, &args.outputs, &options)
            .map_err(|d| print_load_error(LoadError::Invalid(d)))?;
        if let Some(path) = &args.plot {
            let made = crate::report::plot(&rows, &file.display().to_string(), path);
            self.plot(made.map_err(|e| e.to_string()));
        }
        if args.json {
            self.json_rows.extend(rows.iter().map(|r| {
                let mut value = serde_json::to_value(r).unwrap_or_default();
                if let Some(object) = value.as_object_mut() {
                    object.insert(
                        "graph".into(),
                        serde_json::json!(file.display().to_string()),
                    );
                }
                value
            }));
            return Ok(None);
        }
        let tapes = tape_lengths(graph);
        Ok(Some(format!(
            "{}: {} points in [{}], median of {} runs, one thread; tape length {tapes}\n{}",
            file.display(),
            args.points as usize + 4096,
            region_text(&options.region),
            args.runs,
            crate::report::table_text(&rows)
        )))
    }

    fn options(&self) -> crate::report::ReportOptions {
        crate::report::ReportOptions {
            points: self.args.points as usize,
            runs: self.args.runs as usize,
            region: self.args.region.unwrap_or_default(),
            ..Default::default()
        }
    }
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
