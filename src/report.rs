//! Error against run time: every evaluation strategy texgraph offers, measured on one sample
//! set against the f64 reference; and the stability survey of extreme coordinates.
//!
//! The sample set is a seeded random scatter of points in the region plus a regular grid, the
//! same for every strategy. Each strategy is timed as the median of several runs; its error is
//! measured channel by channel against the f64 reference over the points where both are finite
//! (non-finite values are counted, never averaged in).

use crate::bake::{bake_volume, BakeOptions, Grid, Region, Volume};
use crate::compile::{compile, CompileOptions};
use crate::eval::Workspace;
use crate::graph::CheckedGraph;
use crate::real::Real;
use crate::tape::Tape;
use std::time::Instant;

/// Most random sample points (`--points`): the report keeps every strategy's values for every
/// point (about 100 bytes per point and channel) and times each strategy on all of them, so
/// 2 000 000 points of a 4-channel graph take about 1 GiB and a few minutes.
pub const MAX_POINTS: usize = 2_000_000;
/// Most timed runs per strategy (`--runs`).
pub const MAX_RUNS: usize = 100;

/// What to measure.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Random points in the region (plus a 16³ grid).
    pub points: usize,
    pub region: Region,
    /// Runs per strategy; the median time is reported.
    pub runs: usize,
    /// Baked-volume strategies at these resolutions (cube sides).
    pub bake_sizes: Vec<usize>,
    /// Level-of-detail strategies at these sample spacings.
    pub lod_spacings: Vec<f64>,
    /// Worker threads for the bakes (timings of the strategies themselves are single-threaded).
    pub threads: usize,
}

impl Default for ReportOptions {
    fn default() -> Self {
        ReportOptions {
            points: 50_000,
            region: Region::default(),
            runs: 5,
            bake_sizes: vec![64, 128, 256],
            lod_spacings: vec![1.0 / 64.0, 1.0 / 128.0, 1.0 / 256.0],
            threads: 0,
        }
    }
}

/// One strategy's cost and error, for one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Row {
    pub output: String,
    pub strategy: String,
    pub ns_per_point: f64,
    /// Reference time / this time.
    pub speedup: f64,
    pub max_abs_error: f64,
    pub rms_error: f64,
    /// 20·log10(peak / rms), peak = the reference's range over the sample set (1 if flat);
    /// `null` in JSON when the error is zero (infinite PSNR).
    pub psnr_db: Option<f64>,
    pub non_finite: u64,
    /// Memory the strategy holds beyond the tape (baked volumes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory_bytes: Option<u64>,
    /// Instructions of the tape the strategy runs (tape strategies).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tape_length: Option<usize>,
}

/// The deterministic sample set: `n` SplitMix64 points in the region, then a 16³ grid of cell
/// centres.
pub fn sample_points(n: usize, region: &Region) -> Vec<[f64; 3]> {
    let mut rng = crate::noise::SplitMix64::new(0x7E57_5EED);
    let mut next = || rng.next_f64();
    let lerp = |a: usize, t: f64| region.min[a] + t * (region.max[a] - region.min[a]);
    let mut points: Vec<[f64; 3]> = (0..n)
        .map(|_| [lerp(0, next()), lerp(1, next()), lerp(2, next())])
        .collect();
    let g = 16;
    for k in 0..g {
        for j in 0..g {
            for i in 0..g {
                let c = |x: usize| (x as f64 + 0.5) / g as f64;
                points.push([lerp(0, c(i)), lerp(1, c(j)), lerp(2, c(k))]);
            }
        }
    }
    points
}

struct Planes {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
}

impl Planes {
    fn new(points: &[[f64; 3]]) -> Planes {
        Planes {
            x: points.iter().map(|p| p[0]).collect(),
            y: points.iter().map(|p| p[1]).collect(),
            z: points.iter().map(|p| p[2]).collect(),
        }
    }
}

/// Median wall time of `runs` calls, in seconds.
fn median_time(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..runs.max(1))
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn batch<S: Real>(tape: &Tape, planes: &Planes) -> Vec<f64> {
    let mut out = vec![S::ZERO; tape.channels() * planes.x.len()];
    tape.eval_batch(
        &mut Workspace::<S>::new(),
        &planes.x,
        &planes.y,
        &planes.z,
        &mut out,
    );
    out.iter().map(|v| v.to_f64()).collect()
}

fn per_point<S: Real>(tape: &Tape, points: &[[f64; 3]]) -> Vec<f64> {
    let n = points.len();
    let channels = tape.channels();
    let mut out = vec![0.0; channels * n];
    let mut one = vec![S::ZERO; channels];
    let mut workspace = Workspace::<S>::new();
    for (i, p) in points.iter().enumerate() {
        tape.eval_point(&mut workspace, *p, &mut one);
        for c in 0..channels {
            out[c * n + i] = one[c].to_f64();
        }
    }
    out
}

/// Error statistics of `values` against `reference` (planar, same layout).
struct Errors {
    max_abs: f64,
    rms: f64,
    psnr: Option<f64>,
    non_finite: u64,
}

fn errors(reference: &[f64], values: &[f64]) -> Errors {
    let (mut max_abs, mut sum_sq, mut count, mut non_finite) = (0.0f64, 0.0f64, 0u64, 0u64);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (r, v) in reference.iter().zip(values) {
        if !v.is_finite() {
            non_finite += 1;
        }
        if r.is_finite() {
            lo = lo.min(*r);
            hi = hi.max(*r);
        }
        if r.is_finite() && v.is_finite() {
            let e = (r - v).abs();
            max_abs = max_abs.max(e);
            sum_sq += e * e;
            count += 1;
        }
    }
    let rms = if count > 0 {
        (sum_sq / count as f64).sqrt()
    } else {
        0.0
    };
    let peak = if hi > lo { hi - lo } else { 1.0 };
    let psnr = (rms > 0.0).then(|| 20.0 * (peak / rms).log10());
    Errors {
        max_abs,
        rms,
        psnr,
        non_finite,
    }
}

/// Trilinear sampling of a baked volume at a point, voxel centres at the cell centres, clamped
/// to the edge (the usual GL_LINEAR + CLAMP_TO_EDGE lookup).
fn sample_trilinear(volume: &Volume, output: usize, point: [f64; 3], out: &mut [f64]) {
    let grid = &volume.grid;
    let data = &volume.outputs[output];
    let channels = data.ty.channels();
    let mut index = [0usize; 3];
    let mut t = [0.0f64; 3];
    let mut next = [0usize; 3];
    for a in 0..3 {
        let n = grid.size[a];
        let (lo, hi) = (grid.region.min[a], grid.region.max[a]);
        let u = if hi > lo {
            (point[a] - lo) / (hi - lo) * n as f64 - 0.5
        } else {
            0.0
        };
        let u = u.clamp(0.0, (n - 1) as f64);
        let i = (u.floor() as usize).min(n - 1);
        index[a] = i;
        next[a] = (i + 1).min(n - 1);
        t[a] = u - i as f64;
    }
    for (c, o) in out.iter_mut().enumerate().take(channels) {
        let at = |i: usize, j: usize, k: usize| data.get(grid, i, j, k, c) as f64;
        let lerp = |a: f64, b: f64, t: f64| a + t * (b - a);
        let (i0, j0, k0, i1, j1, k1) = (index[0], index[1], index[2], next[0], next[1], next[2]);
        let x00 = lerp(at(i0, j0, k0), at(i1, j0, k0), t[0]);
        let x10 = lerp(at(i0, j1, k0), at(i1, j1, k0), t[0]);
        let x01 = lerp(at(i0, j0, k1), at(i1, j0, k1), t[0]);
        let x11 = lerp(at(i0, j1, k1), at(i1, j1, k1), t[0]);
        *o = lerp(lerp(x00, x10, t[1]), lerp(x01, x11, t[1]), t[2]);
    }
}

/// Measures every strategy for every output of `graph` (or the `outputs` given). Rows come
/// grouped by output, the f64 reference first.
pub fn accuracy_report(
    graph: &CheckedGraph,
    outputs: &[String],
    options: &ReportOptions,
) -> Result<Vec<Row>, crate::diagnostic::Diagnostics> {
    // The bounds hold for library callers too: points and runs are clamped to them.
    let options = &ReportOptions {
        points: options.points.min(MAX_POINTS),
        runs: options.runs.clamp(1, MAX_RUNS),
        ..options.clone()
    };
    let points = sample_points(options.points, &options.region);
    let planes = Planes::new(&points);
    let n = points.len() as f64;
    let names: Vec<String> = if outputs.is_empty() {
        graph.outputs.iter().map(|o| o.name.clone()).collect()
    } else {
        outputs.to_vec()
    };
    let all = compile(
        graph,
        &CompileOptions {
            outputs: names.clone(),
            spacing: None,
            ..Default::default()
        },
    )?;
    // Bake once per resolution with every requested output.
    let volumes: Vec<(usize, Volume, f64)> = options
        .bake_sizes
        .iter()
        .filter_map(|&size| {
            let bake = BakeOptions {
                grid: Grid {
                    size: [size; 3],
                    region: options.region,
                },
                threads: options.threads,
                ..BakeOptions::default()
            };
            let start = Instant::now();
            let volume = bake_volume(&all, &bake).ok()?;
            Some((size, volume, start.elapsed().as_secs_f64()))
        })
        .collect();

    let mut rows = Vec::new();
    for name in &names {
        let single = CompileOptions {
            outputs: vec![name.clone()],
            spacing: None,
            ..Default::default()
        };
        let tape = compile(graph, &single)?;
        let reference = batch::<f64>(&tape, &planes);
        let reference_time = median_time(options.runs, || {
            std::hint::black_box(batch::<f64>(&tape, &planes));
        });
        let output_index = all
            .outputs
            .iter()
            .position(|o| &o.name == name)
            .unwrap_or(0);
        let mut measured = direct_strategies(&tape, &points, &planes, options.runs);
        measured.extend(gpu_strategy(&tape, &planes, options.runs));
        measured.extend(lod_strategies(graph, name, &planes, options)?);
        measured.extend(baked_strategies(
            &volumes,
            output_index,
            tape.channels(),
            &points,
            options.runs,
        ));
        let reference_row = Measured {
            strategy: "f64 reference (batch)".into(),
            time: reference_time,
            values: reference.clone(),
            memory: None,
            tape_length: Some(tape.instrs.len()),
        };
        for m in std::iter::once(reference_row).chain(measured) {
            let e = errors(&reference, &m.values);
            rows.push(Row {
                output: name.clone(),
                strategy: m.strategy,
                ns_per_point: m.time / n * 1e9,
                speedup: if m.time > 0.0 {
                    reference_time / m.time
                } else {
                    f64::INFINITY
                },
                max_abs_error: e.max_abs,
                rms_error: e.rms,
                psnr_db: e.psnr,
                non_finite: e.non_finite,
                memory_bytes: m.memory,
                tape_length: m.tape_length,
            });
        }
    }
    Ok(rows)
}

/// One strategy's values and median time for one output, before its errors are measured.
struct Measured {
    strategy: String,
    time: f64,
    values: Vec<f64>,
    memory: Option<u64>,
    tape_length: Option<usize>,
}

/// The tape evaluated directly: f64 per point, f32 per point, f32 batch.
fn direct_strategies(
    tape: &Tape,
    points: &[[f64; 3]],
    planes: &Planes,
    runs: usize,
) -> Vec<Measured> {
    let length = Some(tape.instrs.len());
    let measure = |strategy: &str, run: &dyn Fn() -> Vec<f64>| Measured {
        strategy: strategy.into(),
        time: median_time(runs, || {
            std::hint::black_box(run());
        }),
        values: run(),
        memory: None,
        tape_length: length,
    };
    vec![
        measure("f64 per point", &|| per_point::<f64>(tape, points)),
        measure("f32 per point", &|| per_point::<f32>(tape, points)),
        measure("f32 batch", &|| batch::<f32>(tape, planes)),
    ]
}

/// The tape on the GPU (`gpu::GpuEvaluator`: uploads, one dispatch, read-back), when one is
/// usable; the row names the adapter. Without one there is no row (said once on stderr).
fn gpu_strategy(tape: &Tape, planes: &Planes, runs: usize) -> Option<Measured> {
    let gpu = match crate::gpu::evaluator_for(tape) {
        Ok(gpu) => gpu,
        Err(e) => {
            static SAID: std::sync::Once = std::sync::Once::new();
            SAID.call_once(|| eprintln!("texgraph report: no gpu row: {e}"));
            return None;
        }
    };
    let run = || -> Option<Vec<f64>> {
        let mut out = vec![0f32; tape.channels() * planes.x.len()];
        gpu.eval_batch(&planes.x, &planes.y, &planes.z, &mut out)
            .ok()?;
        Some(out.into_iter().map(f64::from).collect())
    };
    let values = run()?;
    Some(Measured {
        strategy: format!("gpu ({})", gpu.adapter()),
        time: median_time(runs, || {
            std::hint::black_box(run());
        }),
        values,
        memory: None,
        tape_length: Some(tape.instrs.len()),
    })
}

/// The output compiled with level of detail at each requested spacing, evaluated as f32 batches.
fn lod_strategies(
    graph: &CheckedGraph,
    name: &str,
    planes: &Planes,
    options: &ReportOptions,
) -> Result<Vec<Measured>, crate::diagnostic::Diagnostics> {
    let mut measured = Vec::new();
    for &spacing in &options.lod_spacings {
        let lod = compile(
            graph,
            &CompileOptions {
                outputs: vec![name.to_string()],
                spacing: Some(spacing),
                ..Default::default()
            },
        )?;
        let kept: Vec<String> = lod
            .fractal_octaves()
            .iter()
            .map(|(_, _, k)| format!("{}", (k * 100.0).round() / 100.0))
            .collect();
        let octaves = if kept.is_empty() {
            String::new()
        } else {
            format!(", octaves {}", kept.join("/"))
        };
        measured.push(Measured {
            strategy: format!(
                "f32 batch, LOD spacing 1/{}{octaves}",
                (1.0 / spacing).round()
            ),
            time: median_time(options.runs, || {
                std::hint::black_box(batch::<f32>(&lod, planes));
            }),
            values: batch::<f32>(&lod, planes),
            memory: None,
            tape_length: Some(lod.instrs.len()),
        });
    }
    Ok(measured)
}

/// Each baked volume sampled trilinearly at the points (the volume's memory reported).
fn baked_strategies(
    volumes: &[(usize, Volume, f64)],
    output_index: usize,
    channels: usize,
    points: &[[f64; 3]],
    runs: usize,
) -> Vec<Measured> {
    let mut measured = Vec::new();
    for (size, volume, bake_seconds) in volumes {
        let sample_all = || {
            let mut values = vec![0.0; channels * points.len()];
            let mut one = [0.0f64; 3];
            for (i, p) in points.iter().enumerate() {
                sample_trilinear(volume, output_index, *p, &mut one);
                for c in 0..channels {
                    values[c * points.len() + i] = one[c];
                }
            }
            values
        };
        let time = median_time(runs, || {
            std::hint::black_box(sample_all());
        });
        let memory = (volume.grid.voxels().unwrap_or(0) as usize * channels * 4) as u64;
        measured.push(Measured {
            strategy: format!("baked {size}³ f32, trilinear (bake {:.2} s)", bake_seconds),
            time,
            values: sample_all(),
            memory: Some(memory),
            tape_length: None,
        });
    }
    measured
}

/// The rows as a plain-text table (one block per output).
pub fn table_text(rows: &[Row]) -> String {
    let mut out = String::new();
    let mut current = "";
    for row in rows {
        if row.output != current {
            current = &row.output;
            out.push_str(&format!(
                "output \"{}\"\n  {:<52} {:>12} {:>8} {:>11} {:>11} {:>9} {:>10} {:>10}\n",
                row.output,
                "strategy",
                "ms/Mpoint",
                "speedup",
                "max |err|",
                "rms err",
                "PSNR dB",
                "non-finite",
                "memory"
            ));
        }
        out.push_str(&format!(
            "  {:<52} {:>12.1} {:>8.2} {:>11.3e} {:>11.3e} {:>9} {:>10} {:>10}\n",
            row.strategy,
            row.ns_per_point,
            row.speedup,
            row.max_abs_error,
            row.rms_error,
            row.psnr_db.map_or("inf".to_string(), |p| format!("{p:.1}")),
            row.non_finite,
            row.memory_bytes
                .map_or("-".to_string(), crate::bake::human_bytes),
        ));
    }
    out
}

/// The rows as a Markdown table (docs/accuracy.md).
pub fn table_markdown(rows: &[Row]) -> String {
    let mut out = String::new();
    let mut current = "";
    for row in rows {
        if row.output != current {
            current = &row.output;
            out.push_str(&format!(
                "\nOutput `{}`:\n\n| strategy | ms / Mpoint | speed-up | max abs error | RMS error | PSNR dB | non-finite | memory |\n|---|---:|---:|---:|---:|---:|---:|---:|\n",
                row.output
            ));
        }
        out.push_str(&format!(
            "| {} | {:.1} | {:.2} | {:.2e} | {:.2e} | {} | {} | {} |\n",
            row.strategy,
            row.ns_per_point,
            row.speedup,
            row.max_abs_error,
            row.rms_error,
            row.psnr_db.map_or("∞".to_string(), |p| format!("{p:.1}")),
            row.non_finite,
            row.memory_bytes
                .map_or("—".to_string(), crate::bake::human_bytes),
        ));
    }
    out
}

/// Draws RMS error (log) against time per point (log), one colour per output, each output's
/// Pareto front (no other strategy is both faster and more accurate) joined and ringed.
/// Exact strategies (zero error) sit on the bottom edge.
/// Registers the plots' font once: the bitmap backend needs one for its labels, and DejaVu
/// Sans ships with the crate (assets/, Bitstream Vera licence), so plots work on machines
/// without fonts installed.
pub(crate) fn plot_font() -> Result<(), String> {
    static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    if !*REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, FONT)
            .is_ok()
    }) {
        return Err("the embedded font could not be loaded".into());
    }
    Ok(())
}

/// A log-log chart drawn on a 1000×640 bitmap (`LogLogPlot::draw`).
pub(crate) type LogChart<'a, 'b> = plotters::chart::ChartContext<
    'a,
    plotters::prelude::BitMapBackend<'b>,
    plotters::coord::cartesian::Cartesian2d<
        plotters::coord::combinators::LogCoord<f64>,
        plotters::coord::combinators::LogCoord<f64>,
    >,
>;

/// The frame of an error-against-time plot, shared by `report --plot` and
/// `report --filtering --plot`: title, log ranges, axis names, where the legend goes.
pub(crate) struct LogLogPlot<'s> {
    pub title: String,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub x_desc: &'s str,
    pub y_desc: &'s str,
    /// Decimals of the x labels.
    pub x_decimals: usize,
    pub legend: plotters::chart::SeriesLabelPosition,
}

impl LogLogPlot<'_> {
    /// Draws the frame, then `series` on it, then the legend, and writes the PNG at `path`.
    pub(crate) fn draw(
        &self,
        path: &std::path::Path,
        series: impl FnOnce(&mut LogChart) -> Result<(), String>,
    ) -> Result<(), String> {
        use plotters::prelude::*;
        plot_font()?;
        let (width, height) = (1000u32, 640u32);
        let mut buffer = vec![0u8; (width * height * 3) as usize];
        let error = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
        {
            let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
            root.fill(&WHITE).map_err(error)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&self.title, ("sans-serif", 20))
                .margin(16)
                .x_label_area_size(44)
                .y_label_area_size(76)
                .build_cartesian_2d(
                    (self.x.0..self.x.1).log_scale(),
                    (self.y.0..self.y.1).log_scale(),
                )
                .map_err(error)?;
            let decimals = self.x_decimals;
            chart
                .configure_mesh()
                .x_desc(self.x_desc)
                .y_desc(self.y_desc)
                .label_style(("sans-serif", 13))
                .x_label_formatter(&|v| format!("{v:.decimals$}"))
                .y_label_formatter(&|v| format!("{v:.0e}"))
                .draw()
                .map_err(error)?;
            series(&mut chart)?;
            chart
                .configure_series_labels()
                .position(self.legend.clone())
                .border_style(BLACK)
                .background_style(WHITE.mix(0.8))
                .label_font(("sans-serif", 13))
                .draw()
                .map_err(error)?;
            root.present().map_err(error)?;
        }
        let image = crate::output::RgbImage::from_raw(width, height, buffer)
            .ok_or("plot buffer has the wrong size")?;
        crate::output::write_png(path, &image).map_err(|e| e.to_string())
    }
}

pub fn plot(rows: &[Row], title: &str, path: &std::path::Path) -> Result<(), String> {
    use plotters::prelude::*;
    let positive: Vec<f64> = rows
        .iter()
        .map(|r| r.rms_error)
        .filter(|e| *e > 0.0)
        .collect();
    let floor = positive
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min)
        .min(1e-3)
        / 10.0;
    let top = positive.iter().cloned().fold(floor * 10.0, f64::max) * 3.0;
    let times: Vec<f64> = rows.iter().map(|r| r.ns_per_point.max(1e-3)).collect();
    let (t_lo, t_hi) = (
        times.iter().cloned().fold(f64::INFINITY, f64::min) / 2.0,
        times.iter().cloned().fold(0.0, f64::max) * 2.0,
    );
    let error = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
    let frame = LogLogPlot {
        title: format!("{title}: error against run time"),
        x: (t_lo, t_hi),
        y: (floor, top),
        x_desc: "ns per point (one thread)",
        y_desc: "RMS error against f64 (exact: bottom edge)",
        x_decimals: 0,
        legend: SeriesLabelPosition::UpperRight,
    };
    frame.draw(path, |chart| {
        let palette = [
            RGBColor(31, 119, 180),
            RGBColor(214, 39, 40),
            RGBColor(44, 160, 44),
            RGBColor(148, 103, 189),
            RGBColor(140, 86, 75),
        ];
        let mut outputs: Vec<&str> = Vec::new();
        for row in rows {
            if !outputs.contains(&row.output.as_str()) {
                outputs.push(&row.output);
            }
        }
        for (o, output) in outputs.iter().enumerate() {
            let colour = palette[o % palette.len()];
            let mine: Vec<&Row> = rows.iter().filter(|r| r.output == *output).collect();
            let at = |r: &Row| (r.ns_per_point.max(1e-3), r.rms_error.max(floor));
            chart
                .draw_series(mine.iter().map(|r| Circle::new(at(r), 4, colour.filled())))
                .map_err(error)?
                .label(format!("output {output}"))
                .legend(move |(x, y)| Circle::new((x, y), 4, colour.filled()));
            for r in &mine {
                let short: String = r
                    .strategy
                    .split(" (")
                    .next()
                    .unwrap_or(&r.strategy)
                    .chars()
                    .take(34)
                    .collect();
                let label = EmptyElement::at(at(r))
                    + Text::new(
                        short,
                        (8, -6),
                        ("sans-serif", 11).into_font().color(&colour),
                    );
                chart.draw_series(std::iter::once(label)).map_err(error)?;
            }
            let mut front: Vec<&Row> = mine
                .iter()
                .copied()
                .filter(|a| {
                    !mine.iter().any(|b| {
                        b.ns_per_point <= a.ns_per_point
                            && b.rms_error <= a.rms_error
                            && (b.ns_per_point < a.ns_per_point || b.rms_error < a.rms_error)
                    })
                })
                .collect();
            front.sort_by(|a, b| a.ns_per_point.total_cmp(&b.ns_per_point));
            chart
                .draw_series(LineSeries::new(
                    front.iter().map(|r| at(r)),
                    colour.stroke_width(2),
                ))
                .map_err(error)?;
            chart
                .draw_series(
                    front
                        .iter()
                        .map(|r| Circle::new(at(r), 8, colour.stroke_width(2))),
                )
                .map_err(error)?;
        }
        Ok(())
    })
}

/// The introduction of docs/accuracy.md, printed once by `texgraph report --markdown`.
pub const MARKDOWN_HEADER: &str = r#"# Accuracy and cost

Generated by `cargo run --release -- report graphs/*.ron --markdown > docs/accuracy.md`
(do not edit by hand; re-run after changes). Times depend on the machine (this file: the
project's 2-core x86-64 build machine, portable build); errors do not.

## How to read the tables

For every graph in `graphs/` and each of its outputs, every evaluation strategy runs on the
same sample set — 50 000 seeded random points in the unit cube plus a 16³ grid — and is
compared with the **f64 reference** (the same tape in double precision):

| column | meaning |
|---|---|
| ms / Mpoint | median of 5 runs, one thread (equal to ns per point) |
| speed-up | reference time / this time |
| max abs error, RMS error | over every channel of the output, where both values are finite |
| PSNR dB | 20·log10(peak / RMS), peak = the reference's range over the sample set |
| non-finite | NaN or infinite values the strategy produced |
| memory | what the strategy holds besides the tape (baked volumes, f32) |

Strategies: **f64 per point**, **f32 per point** and **f32 batch** (the fast path; point and batch
are bit-identical); **f32 batch with footprint level of detail** at sample spacings 1/64, 1/128,
1/256 (`CompileOptions::spacing`, `--spacing`, `bake --lod`: fbm/turbulence octaves above the
Nyquist limit of the spacing are left out, the last one faded, their mean added back; the
octaves kept are listed); **baked volumes** at 64³, 128³ and 256³ (f32, voxel centres) sampled
back with trilinear filtering, the way a renderer samples a 3D texture (seed 002: "different
texture cube densities lead to different accuracy"). Level of detail and baking trade error for
time on purpose: their error is what the filtering removes, which is the point at that spacing.

`texgraph report FILE --plot out.png` draws these rows as error against time with the Pareto
front marked; `--json` gives the numbers to scripts.

## Stability

`texgraph report --stability FILE` evaluates every named node at |p| = 1, 1e3, 1e4, 1e6, 1e8 and
2^31, both signs, along each axis, on scattered points, lattice points and both sides of cell
boundaries: the largest |f32 − f64|, and continuity — neighbouring samples δ = 1e-4 apart must
differ by no more than the node's Lipschitz bound allows (ratio ≤ 1: no seam).

Targets for **noise-valued** outputs (Noise, Fbm, Turbulence of a position): within 1e-5 of f64
for |p| ≤ 1e4 and within 1e-4, seam-free, up to |p| = 2^31 — met with a wide margin (below
1e-6 at every magnitude) because positions stay f64 on both paths and the lattice cell is
computed exactly (`tests/it/accuracy.rs` and `tests/it/properties.rs` enforce it). Nodes that carry a
coordinate through **scalar f32 arithmetic** (`Mul("period", "v.x")`) lose what f32 cannot hold:
about |v|·6e-8 absolute; the survey names each such node and the magnitude where its error
passes 1e-4, and why. The survey's second table is the answer: every output and node again,
each magnitude compiled for its own extent with precision chosen per instruction (below);
outputs are marked `*`.

## Precision chosen per instruction

Given the region a tape will be evaluated over — a bake's region, `eval`'s point or
`--extent X0,Y0,Z0:X1,Y1,Z1`, `check --extent`, `CompileOptions::extent` — the compiler
(`src/precision/`) bounds every node's value over it (interval arithmetic from the extent), bounds
each node's partial derivatives there, and from the outputs backwards each node's
*sensitivity*: how far an error in its value can move the outputs. An f32 scalar adds
`k·|value|·2^-24` of its own (k = 0 for exact operations, 1 for one rounding, 2 for libm
functions, 8–32 for noise interiors); a scalar run in f64 computes what the reference computes
and adds nothing, except where its value is handed to an f32 reader, which rounds it once.
Instructions are promoted to f64 (the tape's `d` slots; `check --tape` gives each one's
magnitude and what f32 would have added) until every output's bound is within `--max-error`
(default 1e-4). Noise samples, fractal sums and their gradients are promoted like any other
instruction: a promoted one runs the basis' f64 kernels (the reference's) on its lanes, batched,
so its value is exact to f64 (issue 32). Positions and lattice cells are f64 either way. The fbm
of a far marble stays f32 (its f32 rounding is small next to the target), its
`v.x → phase → sin` chain runs in f64; the wood grain's noise, whose angle turns a radius of
1e6, runs in f64 too. `eval`, `bake` and `render` print each output the compiled tape
still cannot promise as a `warning:` on stderr (the same text as `check`).

- **Nothing changes where nothing needs it.** When the bound with every scalar in f32 is within
  the target, the tape is the plain one, instruction for instruction. The bound is a worst case
  (it multiplies the steepest slope of every node on a path); where it exceeds the target by
  less than 10× on a bounded extent, the plain tape is measured on 4096 points of the extent
  and kept when its error there is below a quarter of the target (`check` prints the
  measurement).
- **The edge rule.** Discontinuous operations (Floor, Fract, Mod, Step, Select, white noise and
  cell values, constant-interpolated ramps) are flat between their jumps; an error in their
  input instead *moves a jump*. The analysis keeps every such movement within the target in the
  input's own units, so the contract for an output is: within `max_error` of f64, or at a point
  within that distance of one of its jumps. The stability survey measures accordingly: the
  promoted error at a point is the smallest difference from the reference at the point and at
  points 1e-6 away along each axis.
- **What cannot be.** `check --extent` and `report --stability` name the node and the reason:
  an output whose own value is too large for f32 (`evaluate in f64`), a node with no f64 form on
  the fast path (splines, ramps) feeding a steep chain, an operation without a bounded
  slope over the extent (a division by a range containing 0, `atan2` at its origin), or f64
  itself (`Sin(Mul(1e12, "v.x"))` at |p| = 1e6: the reference is meaningless there too).
- **Bit-identity.** Point and batch evaluation stay bit-identical with promoted instructions;
  on the f64 path a promoted tape computes exactly what the plain tape computes.

## Defined behaviour in stiff and extreme cases

Each row is asserted by `tests/it/accuracy.rs` (or the conformance suite).

| case | behaviour |
|---|---|
| coordinates up to ±1e300, negative, on lattice points and cell faces | exact lattice cell (mod 256) and fraction in f64: no offset needed, no seam, no overflow or panic |
| NaN or ±inf position | noise gives NaN; the bake statistics count it |
| octaves at the maximum (32), lacunarity near 1 or 1000, gain ≥ 1 | finite, bounded by Σ gain^i · range; octave frequencies or amplitudes above 1e30 are refused at check time |
| Hermite slopes ±1e6 | the cubic, finite, exact at 0 and 1 |
| ramp or curve stops that coincide | a hard edge: the later stop from the knot on |
| Sin/Cos of very large arguments | libm range reduction of the argument as the path holds it (f32 or f64): in [-1, 1] |
| Div by a tiny value | IEEE: huge or ±inf (an f64 constant below f32's range is 0 on the f32 path, so 1/x = inf there), counted as non-finite |
| Pow or Sqrt of a negative | NaN, counted |
| Atan2(0, 0) | 0 |
| Mod(a, 0), Mod(±inf, b) | NaN |
| NaN param or `--set NAME=NaN` | rejected by the checker (`error[bad-parameter]`) |
| ±inf literal or param | allowed; flows through IEEE arithmetic (inf·0 = NaN) and is counted |
"#;
