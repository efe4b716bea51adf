//! `texgraph report --filtering`: how close each way of showing a footprint gets to the mean
//! over it, and what each costs (issue 33).
//!
//! For each box side `W` (1/2, 1/8, 1/32 by default) and `boxes` random cubes of that side
//! centred in the region (a fixed seed): the reference is the f64 mean of 216 stratified
//! samples per box (6³ jittered cells); against it, over every channel of every box:
//! - point: the f64 value at the box centre;
//! - 4 and 16 samples: the mean of a Latin hypercube of 4 or 16 f64 samples in the box;
//! - filtered: the filtered form's estimate of the box mean ([`crate::filter::Filtered`]);
//! - equal-time samples (issue 47): a Latin hypercube of as many f64 samples per box as fit in
//!   the filtered form's measured time per box (the filtered time over the point time, at
//!   least 1, at most the reference's 216: beyond that the reference cannot judge them), the
//!   same boxes; the filtered form *wins* a row where its RMS is at most theirs.
//!
//! Each strategy's time is per box, one thread, summed over the boxes (a strategy with `k`
//! samples makes `k` point evaluations).

use crate::eval::Workspace;
use crate::filter::{Filtered, Footprint};
use crate::grid::Region;
use crate::tape::Tape;
use std::time::Instant;

/// The box sides of the table.
pub const SIDES: [f64; 3] = [0.5, 0.125, 1.0 / 32.0];
/// Stratified samples per box of the reference (6³).
pub const REFERENCE_SAMPLES: usize = 216;

/// What to measure.
#[derive(Clone, Debug)]
pub struct FilterOptions {
    /// Random boxes per side.
    pub boxes: usize,
    /// Where the box centres are drawn.
    pub region: Region,
    pub sides: Vec<f64>,
}

impl Default for FilterOptions {
    fn default() -> FilterOptions {
        FilterOptions {
            boxes: 100,
            region: Region::default(),
            sides: SIDES.to_vec(),
        }
    }
}

/// One side's figures: RMS errors against the reference and microseconds per box.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FilterRow {
    pub side: f64,
    pub point_rms: f64,
    pub samples4_rms: f64,
    pub samples16_rms: f64,
    pub filtered_rms: f64,
    pub point_us: f64,
    pub samples4_us: f64,
    pub samples16_us: f64,
    pub filtered_us: f64,
    /// Samples per box that fit in the filtered form's time (`filtered_us / point_us`, 1 to
    /// [`REFERENCE_SAMPLES`]).
    pub equal_samples: usize,
    pub equal_rms: f64,
    pub equal_us: f64,
    /// Whether the filtered form's RMS is at most the equal-time samples' (ties within 1e-6).
    pub filtered_wins: bool,
}

impl FilterRow {
    /// The strategies as (name, RMS, µs per box), in the table's order.
    pub fn strategies(&self) -> [(&'static str, f64, f64); 5] {
        [
            ("point", self.point_rms, self.point_us),
            ("4 samples", self.samples4_rms, self.samples4_us),
            ("16 samples", self.samples16_rms, self.samples16_us),
            ("filtered", self.filtered_rms, self.filtered_us),
            ("equal-time samples", self.equal_rms, self.equal_us),
        ]
    }

    /// The supersampling curve: (samples per box, RMS, µs per box) for 1, 4, 16 and the
    /// equal-time count, by count.
    pub fn supersampling(&self) -> Vec<(usize, f64, f64)> {
        let mut curve = vec![
            (1, self.point_rms, self.point_us),
            (4, self.samples4_rms, self.samples4_us),
            (16, self.samples16_rms, self.samples16_us),
            (self.equal_samples, self.equal_rms, self.equal_us),
        ];
        curve.sort_by_key(|c| c.0);
        curve
    }
}

/// The crate's SplitMix64 in [0, 1): the same boxes and jitter on every run and machine.
struct Rng(crate::noise::SplitMix64);

impl Rng {
    fn new(seed: u64) -> Rng {
        Rng(crate::noise::SplitMix64::new(seed))
    }

    fn next(&mut self) -> f64 {
        self.0.next_f64()
    }

    /// A Latin hypercube of `n` points in the cube of side `side` around `c`: `n` strata per
    /// axis, each axis' strata permuted (Fisher–Yates), jittered within the stratum.
    fn latin(&mut self, c: [f64; 3], side: f64, n: usize) -> Vec<[f64; 3]> {
        let mut perms: [Vec<usize>; 3] = std::array::from_fn(|_| (0..n).collect());
        for p in &mut perms {
            for i in (1..n).rev() {
                let j = ((self.next() * (i + 1) as f64) as usize).min(i);
                p.swap(i, j);
            }
        }
        (0..n)
            .map(|s| {
                std::array::from_fn(|a| {
                    c[a] + side * ((perms[a][s] as f64 + self.next()) / n as f64 - 0.5)
                })
            })
            .collect()
    }
}

/// Sums of squared errors and seconds of one strategy.
#[derive(Default)]
struct Tally {
    squares: f64,
    seconds: f64,
}

/// The mean of `tape` over `points` (f64), timed into `tally`.
fn mean_of(
    tape: &Tape,
    ws: &mut Workspace<f64>,
    points: &[[f64; 3]],
    tally: &mut Tally,
) -> Vec<f64> {
    let mut out = vec![0.0; tape.channels()];
    let mut sum = vec![0.0; tape.channels()];
    let started = Instant::now();
    for p in points {
        tape.eval_point(ws, *p, &mut out);
        for (s, v) in sum.iter_mut().zip(&out) {
            *s += v;
        }
    }
    tally.seconds += started.elapsed().as_secs_f64();
    sum.iter().map(|s| s / points.len() as f64).collect()
}

/// The samples per box that fit in `filtered_us` at `point_us` each: at least 1, at most
/// [`REFERENCE_SAMPLES`].
pub fn equal_time_samples(filtered_us: f64, point_us: f64) -> usize {
    if point_us.is_nan() || point_us <= 0.0 || !filtered_us.is_finite() {
        return 1;
    }
    ((filtered_us / point_us).floor() as usize).clamp(1, REFERENCE_SAMPLES)
}

/// One random box: its centre and the reference mean of every channel.
struct RandomBox {
    centre: [f64; 3],
    reference: Vec<f64>,
}

/// Adds each finite reference channel's squared error of `estimate` to `tally`; the number of
/// channels counted.
fn score(reference: &[f64], estimate: &[f64], tally: &mut Tally) -> f64 {
    let mut count = 0.0;
    for (r, e) in reference.iter().zip(estimate) {
        if r.is_finite() {
            tally.squares += (e - r).powi(2);
            count += 1.0;
        }
    }
    count
}

/// The figures of one side.
fn measure(tape: &Tape, filtered: &Filtered, side: f64, options: &FilterOptions) -> FilterRow {
    let channels = tape.channels();
    let footprint = Footprint::cube(side).unwrap_or(Footprint::POINT);
    let mut ws = Workspace::<f64>::new();
    let mut fws = crate::filter::FilterWorkspace::<f64>::default();
    let mut rng = Rng::new(0x5eed ^ side.to_bits());
    let mut tallies: [Tally; 5] = Default::default();
    let mut ignore = Tally::default();
    let mut count = 0.0f64;
    let mut boxes = Vec::with_capacity(options.boxes);
    let Region { min, max } = options.region;
    for _ in 0..options.boxes {
        let c: [f64; 3] = std::array::from_fn(|a| min[a] + (max[a] - min[a]) * rng.next());
        let reference_points: Vec<[f64; 3]> = (0..REFERENCE_SAMPLES)
            .map(|i| {
                let cell = [i % 6, i / 6 % 6, i / 36];
                std::array::from_fn(|a| c[a] + side * ((cell[a] as f64 + rng.next()) / 6.0 - 0.5))
            })
            .collect();
        let reference = mean_of(tape, &mut ws, &reference_points, &mut ignore);
        let four = rng.latin(c, side, 4);
        let sixteen = rng.latin(c, side, 16);
        let estimates = [
            mean_of(tape, &mut ws, &[c], &mut tallies[0]),
            mean_of(tape, &mut ws, &four, &mut tallies[1]),
            mean_of(tape, &mut ws, &sixteen, &mut tallies[2]),
            {
                // Through a kept workspace, as a bake's or render's worker calls it (the
                // point samples reuse theirs too): no allocation in the timed call.
                let mut f = vec![0.0; channels];
                let (x, y, z) = ([c[0]], [c[1]], [c[2]]);
                let fp = std::slice::from_ref(&footprint);
                let started = Instant::now();
                filtered.eval_batch_with(&mut fws, [&x, &y, &z], fp, &mut f);
                tallies[3].seconds += started.elapsed().as_secs_f64();
                f
            },
        ];
        // Every strategy scores the same channels: the box's finite reference means.
        count += score(&reference, &estimates[0], &mut tallies[0]);
        for (tally, estimate) in tallies[1..].iter_mut().zip(&estimates[1..]) {
            score(&reference, estimate, tally);
        }
        boxes.push(RandomBox {
            centre: c,
            reference,
        });
    }
    let per_box = |t: &Tally| t.seconds * 1e6 / options.boxes.max(1) as f64;
    let equal_samples = equal_time_samples(per_box(&tallies[3]), per_box(&tallies[0]));
    // The equal-time samples: the same boxes, their own draws (a second generator, so the
    // columns above do not depend on the count).
    let mut rng = Rng::new(0xe9a1 ^ side.to_bits());
    for b in &boxes {
        let points = rng.latin(b.centre, side, equal_samples);
        let estimate = mean_of(tape, &mut ws, &points, &mut tallies[4]);
        score(&b.reference, &estimate, &mut tallies[4]);
    }
    let rms = |t: &Tally| (t.squares / count.max(1.0)).sqrt();
    let (filtered_rms, equal_rms) = (rms(&tallies[3]), rms(&tallies[4]));
    FilterRow {
        side,
        point_rms: rms(&tallies[0]),
        samples4_rms: rms(&tallies[1]),
        samples16_rms: rms(&tallies[2]),
        filtered_rms,
        point_us: per_box(&tallies[0]),
        samples4_us: per_box(&tallies[1]),
        samples16_us: per_box(&tallies[2]),
        filtered_us: per_box(&tallies[3]),
        equal_samples,
        equal_rms,
        equal_us: per_box(&tallies[4]),
        filtered_wins: filtered_rms <= equal_rms + 1e-6,
    }
}

/// The table's rows for `tape`, one per side.
pub fn filter_report(tape: &Tape, options: &FilterOptions) -> Vec<FilterRow> {
    let filtered = Filtered::new(tape);
    options
        .sides
        .iter()
        .map(|&side| measure(tape, &filtered, side, options))
        .collect()
}

/// `1/8` for 0.125, else the number.
fn side_text(side: f64) -> String {
    let inverse = 1.0 / side;
    if side < 1.0 && (inverse - inverse.round()).abs() < 1e-9 {
        format!("1/{}", inverse.round())
    } else {
        format!("{side}")
    }
}

/// The rows as a Markdown table.
pub fn filter_table_markdown(rows: &[FilterRow]) -> String {
    let mut text = String::from(
        "| side | point RMS | 4 samples RMS | 16 samples RMS | filtered RMS | point µs | 4 samples µs | 16 samples µs | filtered µs | equal-time samples | their RMS | at equal time |\n|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---|\n",
    );
    for r in rows {
        text.push_str(&format!(
            "| {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {:.4} | {} |\n",
            side_text(r.side),
            r.point_rms,
            r.samples4_rms,
            r.samples16_rms,
            r.filtered_rms,
            r.point_us,
            r.samples4_us,
            r.samples16_us,
            r.filtered_us,
            r.equal_samples,
            r.equal_rms,
            if r.filtered_wins { "filtered wins" } else { "samples win" },
        ));
    }
    text
}

/// RMS error (log) against µs per box (log), one colour per strategy, each point labelled by
/// its side, as a PNG. Each side's supersampling curve (1, 4, 16 and the equal-time number of
/// samples per box) is a grey line: the filtered point wins where it lies below the curve at
/// its own time.
pub fn filter_plot(rows: &[FilterRow], title: &str, path: &std::path::Path) -> Result<(), String> {
    use plotters::prelude::*;
    let all: Vec<(f64, f64)> = rows
        .iter()
        .flat_map(|r| r.strategies().map(|(_, e, t)| (t.max(1e-3), e)))
        .collect();
    let floor = all
        .iter()
        .map(|p| p.1)
        .filter(|e| *e > 0.0)
        .fold(1e-3, f64::min)
        / 3.0;
    let top = all.iter().map(|p| p.1).fold(floor * 10.0, f64::max) * 3.0;
    let t_lo = all.iter().map(|p| p.0).fold(f64::INFINITY, f64::min) / 2.0;
    let t_hi = all.iter().map(|p| p.0).fold(0.0, f64::max) * 2.0;
    let error = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
    let frame = crate::report::LogLogPlot {
        title: format!("{title}: box means, error against time"),
        x: (t_lo, t_hi),
        y: (floor, top),
        x_desc: "µs per box (one thread)",
        y_desc: "RMS error against the 216-sample box mean",
        x_decimals: 2,
        legend: SeriesLabelPosition::LowerLeft,
    };
    let palette = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
    ];
    frame.draw(path, |chart| {
        let grey = RGBColor(150, 150, 150);
        for (i, r) in rows.iter().enumerate() {
            let curve = r.supersampling();
            let line = LineSeries::new(
                curve.iter().map(|&(_, e, t)| (t.max(1e-3), e.max(floor))),
                grey.stroke_width(1),
            );
            let drawn = chart.draw_series(line).map_err(error)?;
            if i == 0 {
                drawn
                    .label("supersampling (1, 4, 16, equal-time samples)")
                    .legend(move |(x, y)| PathElement::new([(x - 8, y), (x + 8, y)], grey));
            }
        }
        for (s, colour) in palette.iter().enumerate() {
            let name = rows.first().map_or("", |r| r.strategies()[s].0);
            let at = |r: &FilterRow| {
                let (_, e, t) = r.strategies()[s];
                (t.max(1e-3), e.max(floor))
            };
            let colour = *colour;
            chart
                .draw_series(rows.iter().map(|r| Circle::new(at(r), 5, colour.filled())))
                .map_err(error)?
                .label(name)
                .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
            for r in rows {
                let label = EmptyElement::at(at(r))
                    + Text::new(
                        side_text(r.side),
                        (8, -6),
                        ("sans-serif", 11).into_font().color(&colour),
                    );
                chart.draw_series(std::iter::once(label)).map_err(error)?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An affine field's box mean is its centre value: point and filtered are exact, so their
    /// errors are the reference's own (jittered samples), equal; every error is small.
    #[test]
    fn an_affine_field_has_no_error() {
        let source = crate::diagnostic::SourceFile::new(
            "affine.ron",
            r#"Graph(nodes: { "p": Position }, outputs: { "x": Add(Mul("p.x", 2.0), "p.z") })"#,
        );
        let graph = crate::check::check(source, &crate::check::CheckOptions::default()).unwrap();
        let tape = crate::compile::compile(&graph, &Default::default()).unwrap();
        let options = FilterOptions {
            boxes: 5,
            ..FilterOptions::default()
        };
        let rows = filter_report(&tape, &options);
        assert_eq!(rows.len(), 3);
        for r in &rows {
            assert!((r.point_rms - r.filtered_rms).abs() < 1e-12, "{r:?}");
            assert!(r.point_rms < 0.01, "{r:?}");
            assert!((1..=REFERENCE_SAMPLES).contains(&r.equal_samples), "{r:?}");
            assert!(r.equal_rms.is_finite(), "{r:?}");
            assert_eq!(
                r.filtered_wins,
                r.filtered_rms <= r.equal_rms + 1e-6,
                "{r:?}"
            );
            for (name, rms, us) in r.strategies() {
                assert!(rms.is_finite() && us >= 0.0, "{name}: {rms}, {us}");
            }
        }
        assert_eq!(side_text(0.125), "1/8");
        assert_eq!(side_text(2.0), "2");
    }

    /// As many samples as fit in the filtered time, at least one, at most the reference's.
    #[test]
    fn equal_time_samples_fit_the_filtered_time() {
        assert_eq!(equal_time_samples(10.0, 1.0), 10);
        assert_eq!(equal_time_samples(10.9, 1.0), 10);
        assert_eq!(equal_time_samples(0.5, 1.0), 1);
        assert_eq!(equal_time_samples(1e9, 1.0), REFERENCE_SAMPLES);
        assert_eq!(equal_time_samples(5.0, 0.0), 1);
        assert_eq!(equal_time_samples(f64::NAN, 1.0), 1);
    }

    /// A Latin hypercube puts one sample in each stratum of each axis.
    #[test]
    fn latin_hypercube_fills_every_stratum() {
        let mut rng = Rng::new(7);
        let points = rng.latin([0.0; 3], 1.0, 16);
        for a in 0..3 {
            let mut strata: Vec<usize> = points
                .iter()
                .map(|p| ((p[a] + 0.5) * 16.0).floor() as usize)
                .collect();
            strata.sort_unstable();
            assert_eq!(strata, (0..16).collect::<Vec<_>>());
        }
    }
}
