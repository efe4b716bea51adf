//! `texgraph report --mips`: how close each mip level of a bake is to what a texture of that
//! resolution should hold, the graph's value averaged over each voxel (a box filter).
//!
//! For every level L of an N³ grid's chain (`max(1, N >> L)` voxels per axis over the region):
//! - the reference: the f64 evaluation averaged over a (`SUBSAMPLES` · 2^L)³ lattice of points
//!   spread evenly through each voxel's box (cell-centred), i.e. the same `SUBSAMPLES`³ points per
//!   level-0 voxel at every level: a heavily supersampled box filter of the exact field;
//! - (a) graph-prefiltered: the f32 tape compiled with footprint level of detail for L's voxel
//!   size, evaluated at L's voxel centres (what `bake --mips --filter point` writes);
//! - (f) box-filtered: the filtered form of the tape (`crate::filter`) at L's voxel centres,
//!   each voxel's footprint its own box (what `bake --mips` writes by default);
//! - (b) box-downsampled: level 0 baked without level of detail (f32, at the voxel centres),
//!   then each level the mean of the 2×2×2 voxels below it (what every engine and baking tool's
//!   mip generator does).
//!
//! Errors are over every voxel and channel of the output: RMS and largest absolute difference.

use crate::bake::{mip_grid, mip_level_count, mip_spacing, Grid, Region};
use crate::compile::compile;
use crate::compile::CompileOptions;
use crate::eval::Workspace;
use crate::graph::CheckedGraph;
use crate::tape::Tape;
use rayon::prelude::*;

/// Points per axis per level-0 voxel in the reference's box filter.
pub const SUBSAMPLES: usize = 4;

/// One level of one output.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MipRow {
    pub output: String,
    pub level: u32,
    pub size: [usize; 3],
    /// Octaves kept by level of detail at this level's spacing (the first fractal of the
    /// output; `None` when it has none).
    pub octaves: Option<f64>,
    pub prefiltered_rms: f64,
    pub prefiltered_max: f64,
    pub filtered_rms: f64,
    pub filtered_max: f64,
    pub downsampled_rms: f64,
    pub downsampled_max: f64,
}

/// Values of every voxel of `grid` (channels interleaved, x fastest): `tape`'s outputs at the
/// voxel centres (f32), in parallel over z slices.
fn at_centres(tape: &Tape, grid: &Grid) -> Vec<f64> {
    let channels = tape.channels();
    let [nx, ny, nz] = grid.size;
    let xs: Vec<f64> = (0..nx).map(|i| grid.centre(0, i)).collect();
    let slices: Vec<Vec<f64>> = (0..nz)
        .into_par_iter()
        .map_init(Workspace::<f32>::new, |workspace, k| {
            let mut out = vec![0f32; channels * nx];
            let mut slice = Vec::with_capacity(nx * ny * channels);
            for j in 0..ny {
                let ys = vec![grid.centre(1, j); nx];
                let zs = vec![grid.centre(2, k); nx];
                tape.eval_batch(workspace, &xs, &ys, &zs, &mut out);
                for i in 0..nx {
                    slice.extend((0..channels).map(|c| f64::from(out[c * nx + i])));
                }
            }
            slice
        })
        .collect();
    slices.concat()
}

/// Values of every voxel of `grid` (channels interleaved, x fastest): the filtered form's
/// estimate of each voxel's box mean (f32), the footprint the voxel.
fn box_filtered(filtered: &crate::filter::Filtered, grid: &Grid) -> Vec<f64> {
    let tape = filtered.tape();
    let channels = tape.channels();
    let [nx, ny, nz] = grid.size;
    let side = |a: usize| (grid.region.max[a] - grid.region.min[a]) / grid.size[a] as f64;
    let footprint = crate::filter::Footprint::from_sides([side(0), side(1), side(2)])
        .unwrap_or(crate::filter::Footprint::POINT);
    let xs: Vec<f64> = (0..nx).map(|i| grid.centre(0, i)).collect();
    let mut out = vec![0f32; channels * nx];
    let mut values = Vec::with_capacity(nx * ny * nz * channels);
    let mut ws = crate::filter::FilterWorkspace::default();
    for k in 0..nz {
        for j in 0..ny {
            let ys = vec![grid.centre(1, j); nx];
            let zs = vec![grid.centre(2, k); nx];
            filtered.eval_batch_with(&mut ws, [&xs, &ys, &zs], &[footprint], &mut out);
            for i in 0..nx {
                values.extend((0..channels).map(|c| f64::from(out[c * nx + i])));
            }
        }
    }
    values
}

/// The box-filtered f64 reference of every voxel of `grid`: the mean over `s`³ cell-centred
/// points per voxel.
fn box_reference(tape: &Tape, grid: &Grid, s: usize) -> Vec<f64> {
    let channels = tape.channels();
    let [nx, ny, nz] = grid.size;
    let sub = |a: usize, index: usize, q: usize| {
        let (lo, hi) = (grid.region.min[a], grid.region.max[a]);
        lo + (hi - lo) * ((index * s + q) as f64 + 0.5) / (grid.size[a] * s) as f64
    };
    let xs: Vec<f64> = (0..nx)
        .flat_map(|i| (0..s).map(move |q| (i, q)))
        .map(|(i, q)| sub(0, i, q))
        .collect();
    let n = xs.len();
    let per_voxel = (s * s * s) as f64;
    let slices: Vec<Vec<f64>> = (0..nz)
        .into_par_iter()
        .map_init(Workspace::<f64>::new, |workspace, k| {
            let mut out = vec![0f64; channels * n];
            let mut slice = vec![0f64; nx * ny * channels];
            for j in 0..ny {
                for (qz, qy) in (0..s).flat_map(|a| (0..s).map(move |b| (a, b))) {
                    let ys = vec![sub(1, j, qy); n];
                    let zs = vec![sub(2, k, qz); n];
                    tape.eval_batch(workspace, &xs, &ys, &zs, &mut out);
                    for (p, i) in (0..n).map(|p| (p, p / s)) {
                        for c in 0..channels {
                            slice[(j * nx + i) * channels + c] += out[c * n + p];
                        }
                    }
                }
            }
            slice.iter_mut().for_each(|v| *v /= per_voxel);
            slice
        })
        .collect();
    slices.concat()
}

/// The level below `fine` (of `from` voxels) by box filtering: each voxel the mean of the fine
/// voxels it covers (2 a side; the last voxel of an odd side takes the remainder too).
fn downsample(fine: &[f64], from: [usize; 3], to: [usize; 3], channels: usize) -> Vec<f64> {
    let span = |a: usize, i: usize| {
        let start = (2 * i).min(from[a] - 1);
        let end = if i + 1 == to[a] {
            from[a]
        } else {
            (2 * i + 2).min(from[a])
        };
        start..end.max(start + 1)
    };
    let mut coarse = vec![0f64; to[0] * to[1] * to[2] * channels];
    for k in 0..to[2] {
        for j in 0..to[1] {
            for i in 0..to[0] {
                let mut count = 0.0;
                let at = ((k * to[1] + j) * to[0] + i) * channels;
                for z in span(2, k) {
                    for y in span(1, j) {
                        for x in span(0, i) {
                            let from_at = ((z * from[1] + y) * from[0] + x) * channels;
                            for c in 0..channels {
                                coarse[at + c] += fine[from_at + c];
                            }
                            count += 1.0;
                        }
                    }
                }
                coarse[at..at + channels]
                    .iter_mut()
                    .for_each(|v| *v /= count);
            }
        }
    }
    coarse
}

/// RMS and largest absolute difference of `values` against `reference`, over channels
/// `first .. first + width` of `channels`-wide voxels.
fn error(
    reference: &[f64],
    values: &[f64],
    channels: usize,
    first: usize,
    width: usize,
) -> (f64, f64) {
    let (mut sum, mut max, mut n) = (0.0f64, 0.0f64, 0usize);
    for (r, v) in reference.chunks(channels).zip(values.chunks(channels)) {
        for c in first..first + width {
            let d = (r[c] - v[c]).abs();
            sum += d * d;
            max = max.max(d);
            n += 1;
        }
    }
    ((sum / n.max(1) as f64).sqrt(), max)
}

/// The table for an `n`³ grid over `region`, every level, every output of `graph`.
pub fn mip_report(
    graph: &CheckedGraph,
    n: usize,
    region: Region,
) -> Result<Vec<MipRow>, crate::diagnostic::Diagnostics> {
    let grid = Grid {
        size: [n.max(1); 3],
        region,
    };
    let exact = compile(graph, &CompileOptions::default())?;
    let filtered_form = crate::filter::Filtered::new(&exact);
    let channels = exact.channels();
    let mut rows = Vec::new();
    let mut boxed = at_centres(&exact, &grid);
    let mut previous = grid.size;
    for level in 0..mip_level_count(&grid) {
        let lg = mip_grid(&grid, level);
        if level > 0 {
            boxed = downsample(&boxed, previous, lg.size, channels);
        }
        previous = lg.size;
        let options = CompileOptions {
            spacing: mip_spacing(&grid, level),
            ..CompileOptions::default()
        };
        let lod = compile(graph, &options)?;
        let prefiltered = at_centres(&lod, &lg);
        let filtered = box_filtered(&filtered_form, &lg);
        let reference = box_reference(&exact, &lg, SUBSAMPLES << level);
        let octaves = lod.fractal_octaves().first().map(|o| o.2);
        for output in exact.outputs() {
            let (first, width) = (output.first_channel, output.ty.channels());
            let (prefiltered_rms, prefiltered_max) =
                error(&reference, &prefiltered, channels, first, width);
            let (filtered_rms, filtered_max) = error(&reference, &filtered, channels, first, width);
            let (downsampled_rms, downsampled_max) =
                error(&reference, &boxed, channels, first, width);
            rows.push(MipRow {
                output: output.name.clone(),
                level,
                size: lg.size,
                octaves,
                prefiltered_rms,
                prefiltered_max,
                filtered_rms,
                filtered_max,
                downsampled_rms,
                downsampled_max,
            });
        }
    }
    rows.sort_by(|a, b| a.output.cmp(&b.output).then(a.level.cmp(&b.level)));
    Ok(rows)
}

/// The rows as a Markdown table (one per output, levels in order).
pub fn mip_table_markdown(rows: &[MipRow]) -> String {
    let mut text = String::from(
        "| output | level | voxels | octaves kept | graph-prefiltered RMS | max | box-filtered RMS | max | box-downsampled RMS | max |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let octaves = r.octaves.map_or("–".to_string(), |o| format!("{o:.2}"));
        text.push_str(&format!(
            "| {} | {} | {}×{}×{} | {octaves} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |\n",
            r.output,
            r.level,
            r.size[0],
            r.size[1],
            r.size[2],
            r.prefiltered_rms,
            r.prefiltered_max,
            r.filtered_rms,
            r.filtered_max,
            r.downsampled_rms,
            r.downsampled_max
        ));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_the_voxels_below() {
        // 4×2×1 → 2×1×1, two channels.
        let fine: Vec<f64> = (0..8).flat_map(|v| [v as f64, 10.0 * v as f64]).collect();
        let coarse = downsample(&fine, [4, 2, 1], [2, 1, 1], 2);
        // Voxel 0 covers x 0..2, y 0..2: values 0, 1, 4, 5.
        assert_eq!(coarse, vec![2.5, 25.0, 4.5, 45.0]);
        // An odd side: 3 → 1 takes all three.
        let odd = downsample(&[1.0, 2.0, 6.0], [3, 1, 1], [1, 1, 1], 1);
        assert_eq!(odd, vec![3.0]);
    }

    /// A linear field's box average is its value at the box's centre: every strategy is exact
    /// (to f32 rounding) at every level, so the reference, the levels and the downsampling line
    /// up voxel for voxel.
    #[test]
    fn a_linear_field_has_no_mip_error() {
        let source = crate::diagnostic::SourceFile::new(
            "linear.ron",
            r#"Graph(nodes: { "p": Position }, outputs: { "x": Add(Mul("p.x", 2.0), "p.z") })"#,
        );
        let graph = crate::check::check(source, &crate::check::CheckOptions::default()).unwrap();
        let region = Region {
            min: [-1.0, 0.0, 0.5],
            max: [1.0, 2.0, 1.5],
        };
        let rows = mip_report(&graph, 8, region).unwrap();
        assert_eq!(rows.len(), 4);
        for r in &rows {
            assert!(
                r.prefiltered_max < 1e-6 && r.downsampled_max < 1e-6 && r.filtered_max < 1e-6,
                "{r:?}"
            );
        }
    }

    #[test]
    fn errors_are_rms_and_max_over_the_output_channels() {
        let reference = [0.0, 5.0, 0.0, 5.0];
        let values = [3.0, 0.0, 4.0, 0.0];
        let (rms, max) = error(&reference, &values, 2, 0, 1);
        assert_eq!((rms, max), ((12.5f64).sqrt(), 4.0));
    }
}
