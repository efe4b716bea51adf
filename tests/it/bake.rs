//! Baking (issue 3): voxel centres, every file format read back and compared with `eval_point`
//! at the same voxel centres, `bake_volume`, thread-count independence, interrupted and failed
//! bakes, overwrite refusal, the size limit, non-finite reporting, and the `texgraph bake`
//! command.
//!
//! The small test grid is 12×10×8 over a non-unit box with negative coordinates, so that an x/y/z
//! mix-up or a wrong centre formula shows.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use exr::prelude::f16;
use texgraph::bake::{
    bake_files, bake_volume, encode_u16, encode_u8, BakeError, BakeFileOptions, BakeOptions,
    BakeReport, ChannelStats, Format, Grid, OutputStats, RawSampleType, Region, Transfer,
    DEFAULT_MAX_BAKE_BYTES,
};
use texgraph::{CheckOptions, CompileOptions, SourceFile, Tape, Type, Workspace};

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");
/// Outputs `colour` (vec3) and `vein` (scalar).
const MARBLE: &str = "graphs/seed003_marble.ron";
/// Outputs `colour` (vec3) and `jump` (scalar).
const STRIPES: &str = "graphs/seed004_stripes.ron";
/// Every kind of non-finite value, over x: `s` is NaN where x > 0.5; `d` is +inf, `m` -inf and
/// `n` (0/0) NaN everywhere; `f` is finite.
const NON_FINITE: &str = r#"Graph(nodes: { "p": Position }, outputs: {
    "s": Sqrt(Sub(0.5, "p.x")),
    "d": Div(1.0, Sub("p.x", "p.x")),
    "m": Neg(Div(1.0, Sub("p.x", "p.x"))),
    "n": Div(Sub("p.x", "p.x"), Sub("p.x", "p.x")),
    "f": "p.y",
})"#;

// ---------------------------------------------------------------------------------------------
// Graphs and grids

use common::{crate_root as root, load_graph_file as load_with, Png};

fn load(path: &str) -> Tape {
    load_with(path, &[]).0
}

/// The marble with fewer octaves, for big grids (debug builds are slow).
fn cheap_marble(octaves: f64) -> Tape {
    load_with(MARBLE, &[("octaves", octaves)]).0
}

fn load_text(text: &str) -> Tape {
    let graph = texgraph::check(
        SourceFile::new("inline.ron", text),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render(false)));
    texgraph::compile(&graph, &CompileOptions::default()).expect("compile")
}

fn grid_over(size: [usize; 3], min: [f64; 3], max: [f64; 3]) -> Grid {
    Grid {
        size,
        region: Region { min, max },
    }
}

/// 12×10×8 voxels over [-0.5, 1.5] × [-1, 0.25] × [-0.75, 0.5].
fn small_grid() -> Grid {
    grid_over([12, 10, 8], [-0.5, -1.0, -0.75], [1.5, 0.25, 0.5])
}

/// The documented voxel centre, computed here independently of `Grid::centre`.
fn centre(grid: &Grid, axis: usize, index: usize) -> f64 {
    let (lo, hi) = (grid.region.min[axis], grid.region.max[axis]);
    lo + (index as f64 + 0.5) * (hi - lo) / grid.size[axis] as f64
}

/// Every voxel (i, j, k), x fastest, then y, then z: the order of `linear`.
fn voxels(size: [usize; 3]) -> impl Iterator<Item = [usize; 3]> {
    let [nx, ny, nz] = size;
    (0..nz).flat_map(move |k| (0..ny).flat_map(move |j| (0..nx).map(move |i| [i, j, k])))
}

fn linear(size: [usize; 3], [i, j, k]: [usize; 3]) -> usize {
    (k * size[1] + j) * size[0] + i
}

fn voxel_count(grid: &Grid) -> usize {
    grid.size.iter().product()
}

/// Bitwise equality, any NaN equal to any NaN.
fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

// ---------------------------------------------------------------------------------------------
// The reference: eval_point at every voxel centre

/// One output evaluated with `eval_point` (f32) at every voxel centre: channels interleaved,
/// x fastest, then y, then z.
struct Expected {
    name: String,
    ty: Type,
    size: [usize; 3],
    values: Vec<f32>,
}

impl Expected {
    fn at(&self, voxel: [usize; 3], c: usize) -> f32 {
        self.values[linear(self.size, voxel) * self.ty.channels() + c]
    }
}

fn expected(tape: &Tape, grid: &Grid) -> Vec<Expected> {
    let mut workspace = Workspace::<f32>::new();
    let mut out = vec![0f32; tape.channels()];
    let mut outputs: Vec<Expected> = tape
        .outputs()
        .iter()
        .map(|o| Expected {
            name: o.name.clone(),
            ty: o.ty,
            size: grid.size,
            values: Vec::new(),
        })
        .collect();
    for [i, j, k] in voxels(grid.size) {
        tape.eval_point(
            &mut workspace,
            [centre(grid, 0, i), centre(grid, 1, j), centre(grid, 2, k)],
            &mut out,
        );
        for (expected, o) in outputs.iter_mut().zip(tape.outputs()) {
            expected
                .values
                .extend_from_slice(&out[o.first_channel..o.first_channel + o.ty.channels()]);
        }
    }
    outputs
}

/// What an 8- or 16-bit file holds for `v`: sRGB for colours unless linear, always linear for
/// scalars.
fn encoded(v: f32, ty: Type, transfer: Transfer, bits: u8) -> u16 {
    let srgb = ty == Type::Vec3 && transfer == Transfer::Srgb;
    if bits == 16 {
        encode_u16(v, srgb)
    } else {
        u16::from(encode_u8(v, srgb))
    }
}

// ---------------------------------------------------------------------------------------------
// Baking to a folder

/// Marble-named file options: the given grid and format, 2 threads, everything else default.
fn options(dir: &Path, grid: Grid, format: Format) -> BakeFileOptions {
    let mut options = BakeFileOptions::new("marble", dir);
    options.bake.grid = grid;
    options.bake.threads = 2;
    options.format = format;
    options.graph_path = MARBLE.to_string();
    options
}

/// Bakes, expecting success, and checks that no temporary is left in the folder.
fn bake_ok(tape: &Tape, options: &BakeFileOptions) -> BakeReport {
    let report =
        bake_files(tape, options, &mut |_| {}).unwrap_or_else(|e| panic!("bake failed: {e}"));
    assert_no_hidden_entries(&options.out_dir);
    report
}

fn bake_err(tape: &Tape, options: &BakeFileOptions) -> BakeError {
    match bake_files(tape, options, &mut |_| {}) {
        Ok(report) => panic!("the bake should fail, but wrote {:?}", report.files),
        Err(e) => e,
    }
}

/// Names in a folder, sorted; empty if it does not exist.
fn entries(dir: &Path) -> Vec<String> {
    let Ok(read) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = read
        .map(|e| {
            e.expect("dir entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    names
}

/// No `.NAME.*.partial` temporary and no `.replaced.*` folder.
fn assert_no_hidden_entries(dir: &Path) {
    let hidden: Vec<String> = entries(dir)
        .into_iter()
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(
        hidden.is_empty(),
        "leftovers in {}: {hidden:?}",
        dir.display()
    );
}

/// Every file under `dir` (recursively) with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(path) = stack.pop() {
        if path.is_dir() {
            stack.extend(
                std::fs::read_dir(&path)
                    .expect("read dir")
                    .map(|e| e.expect("entry").path()),
            );
        } else {
            files.insert(path.clone(), std::fs::read(&path).expect("read file"));
        }
    }
    files
}

/// Small changes to file options, chained.
trait Tweak {
    fn with_grid(self, grid: Grid) -> Self;
    fn in_dir(self, dir: &Path) -> Self;
}

impl Tweak for BakeFileOptions {
    fn with_grid(mut self, grid: Grid) -> Self {
        self.bake.grid = grid;
        self
    }

    fn in_dir(mut self, dir: &Path) -> Self {
        self.out_dir = dir.to_path_buf();
        self
    }
}

fn sorted(names: &[&str]) -> Vec<String> {
    let mut names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    names.sort();
    names
}

// ---------------------------------------------------------------------------------------------
// Reading files back

/// The first layer of an EXR file: size, channels by name (sorted, as EXR stores them).
struct ExrImage {
    width: usize,
    height: usize,
    channels: Vec<(String, exr::prelude::FlatSamples)>,
    attributes: BTreeMap<String, String>,
}

fn read_exr(path: &Path) -> ExrImage {
    use exr::prelude::*;
    let image =
        read_first_flat_layer_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let layer = image.layer_data;
    let attributes = layer
        .attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    ExrImage {
        width: layer.size.width(),
        height: layer.size.height(),
        channels: layer
            .channel_data
            .list
            .into_iter()
            .map(|c| (c.name.to_string(), c.sample_data))
            .collect(),
        attributes,
    }
}

/// A PNG of gray or RGB samples, 8 or 16 bits (what `bake` writes).
fn read_png(path: &Path) -> Png {
    let png = Png::open(path).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        matches!(png.channels, 1 | 3),
        "{}: unexpected PNG of {} channels",
        path.display(),
        png.channels
    );
    png
}

// ---------------------------------------------------------------------------------------------
// Checking each format against the reference

fn check_exr(dir: &Path, grid: &Grid, expected: &[Expected], half: bool) {
    let [nx, ny, nz] = grid.size;
    for output in expected {
        let path = dir.join(format!("marble.{}.exr", output.name));
        let image = read_exr(&path);
        assert_eq!(
            (image.width, image.height),
            (nx, ny * nz),
            "{}: slices stacked vertically",
            path.display()
        );
        let names: Vec<&str> = image.channels.iter().map(|(n, _)| n.as_str()).collect();
        let wanted: &[&str] = if output.ty == Type::Vec3 {
            &["B", "G", "R"]
        } else {
            &["Y"]
        };
        assert_eq!(names, wanted, "{}", path.display());
        assert_eq!(
            image.attributes.get("texgraph:size").map(String::as_str),
            Some(format!("{nx} {ny} {nz}").as_str())
        );
        assert_eq!(image.attributes.get("texgraph:output"), Some(&output.name));
        for (name, samples) in &image.channels {
            // R, G, B are channels 0, 1, 2 of a colour; Y the only one of a scalar.
            let c = match name.as_str() {
                "R" | "Y" => 0,
                "G" => 1,
                _ => 2,
            };
            for voxel @ [i, j, k] in voxels(grid.size) {
                let at = (k * ny + j) * nx + i;
                let want = output.at(voxel, c);
                match (samples, half) {
                    (exr::prelude::FlatSamples::F32(v), false) => {
                        assert!(
                            same(v[at], want),
                            "{} {name} at {voxel:?}: {} != eval {want}",
                            path.display(),
                            v[at]
                        );
                    }
                    (exr::prelude::FlatSamples::F16(v), true) => {
                        let got = v[at];
                        assert_eq!(
                            got.to_bits(),
                            f16::from_f32(want).to_bits(),
                            "{} {name} at {voxel:?}: {got} is not eval {want} rounded to f16",
                            path.display()
                        );
                        let got = got.to_f32();
                        assert!(
                            (got - want).abs() <= want.abs() * 2f32.powi(-11) + 2f32.powi(-24),
                            "{} {name} at {voxel:?}: {got} vs {want}",
                            path.display()
                        );
                    }
                    _ => panic!(
                        "{}: channel {name} has the wrong sample type (half: {half})",
                        path.display()
                    ),
                }
            }
        }
    }
}

fn check_png_slices(dir: &Path, grid: &Grid, expected: &[Expected], bits: u8, transfer: Transfer) {
    let [nx, ny, nz] = grid.size;
    for output in expected {
        let folder = dir.join(format!("marble.{}", output.name));
        let names: Vec<String> = (0..nz).map(|k| format!("z{k:04}.png")).collect();
        assert_eq!(entries(&folder), names, "{}", folder.display());
        for (k, name) in names.iter().enumerate() {
            let png = read_png(&folder.join(name));
            assert_eq!(
                (png.width, png.height, png.channels, png.bits),
                (nx, ny, output.ty.channels(), bits),
                "{}/{name}",
                folder.display()
            );
            for j in 0..ny {
                for i in 0..nx {
                    let want: Vec<u16> = (0..output.ty.channels())
                        .map(|c| encoded(output.at([i, j, k], c), output.ty, transfer, bits))
                        .collect();
                    assert_eq!(
                        png.pixel(i, j),
                        want,
                        "{}/{name} pixel ({i}, {j})",
                        folder.display()
                    );
                }
            }
        }
    }
}

fn check_png_atlas(dir: &Path, grid: &Grid, expected: &[Expected], bits: u8) {
    let [nx, ny, nz] = grid.size;
    let columns = (nz as f64).sqrt().ceil() as usize;
    let rows = nz.div_ceil(columns);
    for output in expected {
        let path = dir.join(format!("marble.{}.png", output.name));
        let png = read_png(&path);
        assert_eq!(
            (png.width, png.height, png.channels, png.bits),
            (columns * nx, rows * ny, output.ty.channels(), bits),
            "{}",
            path.display()
        );
        let mut unused_tiles = 0;
        for (tx, ty) in (0..rows).flat_map(|ty| (0..columns).map(move |tx| (tx, ty))) {
            let k = ty * columns + tx;
            unused_tiles += usize::from(k >= nz);
            for j in 0..ny {
                for i in 0..nx {
                    let want: Vec<u16> = if k < nz {
                        (0..output.ty.channels())
                            .map(|c| {
                                encoded(output.at([i, j, k], c), output.ty, Transfer::Srgb, bits)
                            })
                            .collect()
                    } else {
                        vec![0; output.ty.channels()]
                    };
                    assert_eq!(
                        png.pixel(tx * nx + i, ty * ny + j),
                        want,
                        "{} tile ({tx}, {ty}) = slice {k}, voxel ({i}, {j})",
                        path.display()
                    );
                }
            }
        }
        assert_eq!(unused_tiles, columns * rows - nz);
    }
}

fn raw_channels(ty: Type, alpha: bool) -> usize {
    ty.channels() + usize::from(alpha)
}

/// Checks the raw volumes and returns their sidecars.
fn check_raw(
    dir: &Path,
    grid: &Grid,
    expected: &[Expected],
    raw_type: RawSampleType,
    alpha: bool,
    transfer: Transfer,
) -> Vec<serde_json::Value> {
    let bytes_per_sample = if raw_type == RawSampleType::F32 { 4 } else { 1 };
    let mut sidecars = Vec::new();
    for output in expected {
        let path = dir.join(format!("marble.{}.raw", output.name));
        let bytes = std::fs::read(&path).expect("read raw");
        let channels = raw_channels(output.ty, alpha);
        assert_eq!(
            bytes.len(),
            voxel_count(grid) * channels * bytes_per_sample,
            "{}: tightly packed",
            path.display()
        );
        for voxel in voxels(grid.size) {
            let sample = |c: usize| {
                &bytes[(linear(grid.size, voxel) * channels + c) * bytes_per_sample..]
                    [..bytes_per_sample]
            };
            for c in 0..channels {
                let is_alpha = c == output.ty.channels();
                match raw_type {
                    RawSampleType::U8 => {
                        let want = if is_alpha {
                            255
                        } else {
                            encoded(output.at(voxel, c), output.ty, transfer, 8) as u8
                        };
                        assert_eq!(
                            sample(c)[0],
                            want,
                            "{} voxel {voxel:?} channel {c}",
                            path.display()
                        );
                    }
                    RawSampleType::F32 => {
                        let got = f32::from_le_bytes(sample(c).try_into().expect("4 bytes"));
                        let want = if is_alpha { 1.0 } else { output.at(voxel, c) };
                        assert!(
                            same(got, want),
                            "{} voxel {voxel:?} channel {c}: {got} != eval {want}",
                            path.display()
                        );
                    }
                }
            }
        }
        let sidecar = dir.join(format!("marble.{}.json", output.name));
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&sidecar).expect("read sidecar"))
                .expect("sidecar is JSON");
        assert_eq!(
            json["bytes"],
            serde_json::json!(bytes.len()),
            "{}",
            sidecar.display()
        );
        sidecars.push(json);
    }
    sidecars
}

/// The sidecar states size, region, channels, type, graph, params, version and statistics.
fn check_sidecar(
    json: &serde_json::Value,
    grid: &Grid,
    output: &Expected,
    raw_type: RawSampleType,
    alpha: bool,
    params: &[(String, f64)],
    stats: &OutputStats,
) {
    use serde_json::json;
    assert_eq!(json["size"], json!(grid.size));
    assert_eq!(
        json["region"],
        json!({ "min": grid.region.min, "max": grid.region.max })
    );
    let mut channels: Vec<&str> = if output.ty == Type::Vec3 {
        vec!["r", "g", "b"]
    } else {
        vec!["value"]
    };
    if alpha {
        channels.push("a");
    }
    assert_eq!(json["channels"], json!(channels));
    assert_eq!(
        json["type"],
        json!(if raw_type == RawSampleType::F32 {
            "f32"
        } else {
            "u8"
        })
    );
    assert_eq!(json["graph"], json!(MARBLE));
    assert_eq!(json["output"], json!(output.name));
    assert_eq!(json["texgraph_version"], json!(env!("CARGO_PKG_VERSION")));
    let params: serde_json::Map<String, serde_json::Value> =
        params.iter().map(|(k, v)| (k.clone(), json!(v))).collect();
    assert_eq!(json["params"], serde_json::Value::Object(params));
    let stated = json["stats"]["channels"]
        .as_array()
        .expect("stats.channels");
    assert_eq!(json["stats"]["name"], json!(output.name));
    assert_eq!(stated.len(), stats.channels.len());
    // serde_json (without its float_roundtrip feature) may read a number back one ulp off.
    let close = |stated: &serde_json::Value, value: f64| {
        let stated = stated
            .as_f64()
            .unwrap_or_else(|| panic!("{stated} is not a number"));
        assert!(
            (stated - value).abs() <= 4.0 * f64::EPSILON * value.abs(),
            "{stated} vs {value}"
        );
    };
    for (stated, stats) in stated.iter().zip(&stats.channels) {
        close(&stated["min"], stats.min);
        close(&stated["max"], stats.max);
        close(&stated["mean"], stats.mean);
        assert_eq!(stated["nan"], json!(stats.nan));
        assert_eq!(stated["pos_inf"], json!(stats.pos_inf));
        assert_eq!(stated["neg_inf"], json!(stats.neg_inf));
    }
}

/// Statistics agree with the reference: min and max exactly, the mean to rounding.
fn check_stats(stats: &[OutputStats], expected: &[Expected]) {
    assert_eq!(stats.len(), expected.len());
    for (stats, output) in stats.iter().zip(expected) {
        assert_eq!(stats.name, output.name);
        assert_eq!(stats.channels.len(), output.ty.channels());
        for (c, channel) in stats.channels.iter().enumerate() {
            let values: Vec<f64> = output
                .values
                .iter()
                .skip(c)
                .step_by(output.ty.channels())
                .map(|&v| v as f64)
                .collect();
            let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
            let min = finite.iter().copied().fold(f64::INFINITY, f64::min);
            let max = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert_eq!(
                (channel.min, channel.max),
                (min, max),
                "{} channel {c}",
                output.name
            );
            assert_eq!(
                channel.nan,
                values.iter().filter(|v| v.is_nan()).count() as u64
            );
            assert_eq!(
                channel.pos_inf,
                values.iter().filter(|&&v| v == f64::INFINITY).count() as u64
            );
            assert_eq!(
                channel.neg_inf,
                values.iter().filter(|&&v| v == f64::NEG_INFINITY).count() as u64
            );
            if finite.is_empty() {
                assert!(
                    channel.mean.is_nan(),
                    "{} channel {c}: mean of no finite values",
                    output.name
                );
            } else {
                let mean = finite.iter().sum::<f64>() / finite.len() as f64;
                assert!(
                    (channel.mean - mean).abs() <= 1e-12 * mean.abs().max(1.0),
                    "{} channel {c}: mean {} vs {mean}",
                    output.name,
                    channel.mean
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Voxel centres

#[test]
fn voxel_centres_follow_the_documented_formula() {
    // Spacings 0.5, 1 and 0.5: the centres are exact in binary.
    let g = grid_over([3, 5, 2], [-1.5, -2.0, -0.25], [0.0, 3.0, 0.75]);
    let along = |axis: usize| {
        (0..g.size[axis])
            .map(|i| g.centre(axis, i))
            .collect::<Vec<f64>>()
    };
    assert_eq!(along(0), [-1.25, -0.75, -0.25]);
    assert_eq!(along(1), [-1.5, -0.5, 0.5, 1.5, 2.5]);
    assert_eq!(along(2), [0.0, 0.5]);
    assert_eq!(g.spacing(), [0.5, 1.0, 0.5]);
    assert_eq!(g.voxels(), Some(30));

    // A box whose spacings are not exact: the same expression, bit for bit.
    let g = grid_over([3, 5, 2], [-0.3, -7.1, 2.2], [0.7, -1.9, 9.9]);
    for axis in 0..3 {
        for index in 0..g.size[axis] {
            assert_eq!(
                g.centre(axis, index).to_bits(),
                centre(&g, axis, index).to_bits(),
                "axis {axis} index {index}"
            );
        }
    }
    // The default region is the unit cube.
    assert_eq!(
        Region::default(),
        Region {
            min: [0.0; 3],
            max: [1.0; 3]
        }
    );
    assert_eq!(Grid::cube(4).centre(1, 0), 0.125);
    assert_eq!(
        grid_over([u32::MAX as usize; 3], [0.0; 3], [1.0; 3]).voxels(),
        None,
        "an overflowing count is None"
    );
}

// ---------------------------------------------------------------------------------------------
// 2. Each format read back and compared with eval_point

#[test]
fn exr_f32_holds_exactly_the_evaluated_values() {
    let (tape, dir, grid) = (load(MARBLE), tempfile::tempdir().unwrap(), small_grid());
    bake_ok(&tape, &options(dir.path(), grid, Format::Exr));
    assert_eq!(
        entries(dir.path()),
        ["marble.colour.exr", "marble.vein.exr"]
    );
    check_exr(dir.path(), &grid, &expected(&tape, &grid), false);
}

#[test]
fn exr_half_holds_the_evaluated_values_rounded_to_f16() {
    let (tape, dir, grid) = (load(MARBLE), tempfile::tempdir().unwrap(), small_grid());
    bake_ok(
        &tape,
        &BakeFileOptions {
            half: true,
            ..options(dir.path(), grid, Format::Exr)
        },
    );
    check_exr(dir.path(), &grid, &expected(&tape, &grid), true);
}

#[test]
fn png_slices_8_bit_encode_colours_srgb_and_scalars_linear() {
    let (tape, dir, grid) = (load(MARBLE), tempfile::tempdir().unwrap(), small_grid());
    bake_ok(&tape, &options(dir.path(), grid, Format::Png));
    assert_eq!(entries(dir.path()), ["marble.colour", "marble.vein"]);
    check_png_slices(
        dir.path(),
        &grid,
        &expected(&tape, &grid),
        8,
        Transfer::Srgb,
    );
}

#[test]
fn png_slices_16_bit() {
    let (tape, dir, grid) = (load(MARBLE), tempfile::tempdir().unwrap(), small_grid());
    bake_ok(
        &tape,
        &BakeFileOptions {
            depth16: true,
            ..options(dir.path(), grid, Format::Png)
        },
    );
    check_png_slices(
        dir.path(),
        &grid,
        &expected(&tape, &grid),
        16,
        Transfer::Srgb,
    );
}

#[test]
fn png_slices_with_linear_transfer_write_colours_as_they_are() {
    let (tape, grid) = (load(MARBLE), small_grid());
    let expected = expected(&tape, &grid);
    for bits in [8, 16] {
        let dir = tempfile::tempdir().unwrap();
        bake_ok(
            &tape,
            &BakeFileOptions {
                transfer: Transfer::Linear,
                depth16: bits == 16,
                ..options(dir.path(), grid, Format::Png)
            },
        );
        check_png_slices(dir.path(), &grid, &expected, bits, Transfer::Linear);
    }
    // Not vacuous: the marble's green channel is somewhere encoded differently by the two.
    let green = expected[0].values.iter().skip(1).step_by(3);
    assert!(green
        .clone()
        .any(|&g| encoded(g, Type::Vec3, Transfer::Srgb, 8)
            != encoded(g, Type::Vec3, Transfer::Linear, 8)));
}

#[test]
fn png_atlas_tiles_slices_row_major_and_leaves_unused_tiles_black() {
    let (tape, grid) = (load(MARBLE), small_grid());
    let expected = expected(&tape, &grid);
    // 8 slices: 3 columns, 3 rows, one unused tile.
    for bits in [8, 16] {
        let dir = tempfile::tempdir().unwrap();
        bake_ok(
            &tape,
            &BakeFileOptions {
                atlas: true,
                depth16: bits == 16,
                ..options(dir.path(), grid, Format::Png)
            },
        );
        assert_eq!(
            entries(dir.path()),
            ["marble.colour.png", "marble.vein.png"]
        );
        check_png_atlas(dir.path(), &grid, &expected, bits);
    }
    // A square count fills every tile: 9 slices, 3 × 3.
    let square = grid_over([5, 4, 9], [-1.0; 3], [1.0; 3]);
    let dir = tempfile::tempdir().unwrap();
    bake_ok(
        &tape,
        &BakeFileOptions {
            atlas: true,
            ..options(dir.path(), square, Format::Png)
        },
    );
    check_png_atlas(dir.path(), &square, &self::expected(&tape, &square), 8);
}

#[test]
fn raw_u8_rgb_and_rgba_match_eval() {
    let (tape, params) = load_with(MARBLE, &[]);
    let grid = small_grid();
    let expected = expected(&tape, &grid);
    for alpha in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        let options = BakeFileOptions {
            alpha,
            params: params.clone(),
            ..options(dir.path(), grid, Format::Raw)
        };
        let report = bake_ok(&tape, &options);
        assert_eq!(
            entries(dir.path()),
            [
                "marble.colour.json",
                "marble.colour.raw",
                "marble.vein.json",
                "marble.vein.raw"
            ]
        );
        let sidecars = check_raw(
            dir.path(),
            &grid,
            &expected,
            RawSampleType::U8,
            alpha,
            Transfer::Srgb,
        );
        for ((json, output), stats) in sidecars.iter().zip(&expected).zip(&report.stats) {
            check_sidecar(
                json,
                &grid,
                output,
                RawSampleType::U8,
                alpha,
                &params,
                stats,
            );
        }
    }
    // Linear transfer for colours too.
    let dir = tempfile::tempdir().unwrap();
    bake_ok(
        &tape,
        &BakeFileOptions {
            transfer: Transfer::Linear,
            ..options(dir.path(), grid, Format::Raw)
        },
    );
    check_raw(
        dir.path(),
        &grid,
        &expected,
        RawSampleType::U8,
        false,
        Transfer::Linear,
    );
}

#[test]
fn raw_f32_holds_exactly_the_evaluated_values() {
    let (tape, params) = load_with(MARBLE, &[]);
    let grid = small_grid();
    let expected = expected(&tape, &grid);
    for alpha in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        let options = BakeFileOptions {
            raw_type: RawSampleType::F32,
            alpha,
            params: params.clone(),
            ..options(dir.path(), grid, Format::Raw)
        };
        let report = bake_ok(&tape, &options);
        check_stats(&report.stats, &expected);
        assert_eq!(report.voxels, voxel_count(&grid) as u64);
        let sidecars = check_raw(
            dir.path(),
            &grid,
            &expected,
            RawSampleType::F32,
            alpha,
            Transfer::Srgb,
        );
        for ((json, output), stats) in sidecars.iter().zip(&expected).zip(&report.stats) {
            check_sidecar(
                json,
                &grid,
                output,
                RawSampleType::F32,
                alpha,
                &params,
                stats,
            );
        }
    }
}

#[test]
fn the_report_names_the_files_and_progress_reaches_every_voxel() {
    let (tape, dir, grid) = (load(MARBLE), tempfile::tempdir().unwrap(), small_grid());
    let options = options(dir.path(), grid, Format::Raw);
    let mut progress = Vec::new();
    let report = bake_files(&tape, &options, &mut |done| progress.push(done)).expect("bake");
    let paths: Vec<PathBuf> = report.files.iter().map(|f| f.path.clone()).collect();
    assert_eq!(
        paths,
        [
            dir.path().join("marble.colour.raw"),
            dir.path().join("marble.vein.raw")
        ]
    );
    assert_eq!(
        paths,
        texgraph::bake::planned_outputs(&tape, &options).unwrap()
    );
    assert!(
        progress.windows(2).all(|w| w[0] < w[1]),
        "progress only grows: {progress:?}"
    );
    assert_eq!(progress.last(), Some(&(voxel_count(&grid) as u64)));
}

// ---------------------------------------------------------------------------------------------
// 3. bake_volume

#[test]
fn bake_volume_agrees_with_eval_and_with_the_files() {
    let (tape, grid) = (load(MARBLE), small_grid());
    let expected = expected(&tape, &grid);
    let volume = bake_volume(
        &tape,
        &BakeOptions {
            grid,
            threads: 2,
            ..BakeOptions::default()
        },
    )
    .expect("bake");
    assert_eq!(volume.grid, grid);
    assert_eq!(volume.outputs.len(), 2);
    for (output, want) in volume.outputs.iter().zip(&expected) {
        assert_eq!(
            (output.name.as_str(), output.ty),
            (want.name.as_str(), want.ty)
        );
        assert_eq!(output.data.len(), voxel_count(&grid) * want.ty.channels());
        for voxel @ [i, j, k] in voxels(grid.size) {
            for c in 0..want.ty.channels() {
                let (got, want) = (output.get(&grid, i, j, k, c), want.at(voxel, c));
                assert!(
                    same(got, want),
                    "{} {voxel:?} channel {c}: {got} != eval {want}",
                    output.name
                );
            }
        }
    }
    check_stats(&volume.stats, &expected);

    // The raw f32 files hold the volume's bytes, and the file bake reports the same statistics.
    let dir = tempfile::tempdir().unwrap();
    let report = bake_ok(
        &tape,
        &BakeFileOptions {
            raw_type: RawSampleType::F32,
            ..options(dir.path(), grid, Format::Raw)
        },
    );
    assert_eq!(report.stats, volume.stats);
    for output in &volume.outputs {
        let bytes: Vec<u8> = output.data.iter().flat_map(|v| v.to_le_bytes()).collect();
        assert!(
            std::fs::read(dir.path().join(format!("marble.{}.raw", output.name))).unwrap() == bytes,
            "{}",
            output.name
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Thread-count independence

/// Grids that exercise the windowing: one window; windows of several slices (64×64 slices,
/// 2 × threads × 64 Ki voxels a window, 80 slices: 3, 2 and 1 windows for 1, 2, 3 threads); and
/// slices bigger than a window (400×400, one slice a window on 1 thread).
fn windowing_grids() -> Vec<Grid> {
    vec![
        small_grid(),
        grid_over([64, 64, 80], [-2.0, 0.0, -1.0], [2.0, 1.0, 3.0]),
        grid_over([400, 400, 3], [-1.0, -1.0, 0.0], [1.0, 1.0, 0.1]),
    ]
}

#[test]
fn bake_volume_is_bit_identical_whatever_the_thread_count() {
    let tape = cheap_marble(3.0);
    for grid in windowing_grids() {
        let options = |threads: usize| BakeOptions {
            grid,
            threads,
            ..BakeOptions::default()
        };
        let bake = |threads: usize| bake_volume(&tape, &options(threads)).expect("bake");
        let one = bake(1);
        // The same bake through bake_into, counting windows.
        let mut windows = 0;
        let stats =
            texgraph::bake::bake_into(&tape, &options(1), &mut NullSink, &mut |_| windows += 1)
                .expect("bake");
        assert_eq!(
            one.stats, stats,
            "bake_volume and bake_into report the same statistics"
        );
        if grid.size[0] * grid.size[1] >= 64 * 64 {
            assert!(
                windows > 1,
                "{:?}: the grid should need several windows on one thread",
                grid.size
            );
        }
        for threads in [2, 3, 8] {
            let other = bake(threads);
            assert_eq!(
                other.stats, one.stats,
                "{:?}: statistics on {threads} threads",
                grid.size
            );
            for (a, b) in one.outputs.iter().zip(&other.outputs) {
                let differs = a
                    .data
                    .iter()
                    .zip(&b.data)
                    .position(|(x, y)| x.to_bits() != y.to_bits());
                assert_eq!(a.data.len(), b.data.len());
                assert_eq!(
                    differs, None,
                    "{:?} {}: first difference on {threads} threads at {differs:?}",
                    grid.size, a.name
                );
            }
        }
    }
}

/// A sink that drops every window.
struct NullSink;

impl texgraph::bake::Sink for NullSink {
    fn window(&mut self, _: &texgraph::bake::Window<'_>) -> Result<(), BakeError> {
        Ok(())
    }
}

#[test]
fn raw_files_are_byte_identical_whatever_the_thread_count() {
    let tape = cheap_marble(3.0);
    for grid in windowing_grids() {
        for raw_type in [RawSampleType::U8, RawSampleType::F32] {
            let bake = |threads: usize| {
                let dir = tempfile::tempdir().unwrap();
                let mut options = BakeFileOptions {
                    raw_type,
                    ..options(dir.path(), grid, Format::Raw)
                };
                options.bake.threads = threads;
                bake_ok(&tape, &options);
                // Keyed by file name, so the two folders compare.
                snapshot(dir.path())
                    .into_iter()
                    .map(|(p, bytes)| (p.file_name().unwrap().to_owned(), bytes))
                    .collect::<BTreeMap<_, _>>()
            };
            let one = bake(1);
            assert_eq!(one.len(), 4);
            for threads in [2, 8] {
                assert!(
                    one == bake(threads),
                    "{:?} {raw_type:?}: the files differ between 1 and {threads} threads",
                    grid.size
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Interrupted bakes

/// Every way of writing files (the folder still to be chosen with `in_dir`).
fn every_format(grid: Grid) -> Vec<(&'static str, BakeFileOptions)> {
    let base = || options(Path::new("unset"), grid, Format::Exr);
    vec![
        ("exr", base()),
        (
            "exr half",
            BakeFileOptions {
                half: true,
                ..base()
            },
        ),
        (
            "png slices",
            BakeFileOptions {
                format: Format::Png,
                ..base()
            },
        ),
        (
            "png slices 16-bit",
            BakeFileOptions {
                format: Format::Png,
                depth16: true,
                ..base()
            },
        ),
        (
            "png atlas",
            BakeFileOptions {
                format: Format::Png,
                atlas: true,
                ..base()
            },
        ),
        (
            "raw u8",
            BakeFileOptions {
                format: Format::Raw,
                ..base()
            },
        ),
        (
            "raw f32 rgba",
            BakeFileOptions {
                format: Format::Raw,
                raw_type: RawSampleType::F32,
                alpha: true,
                ..base()
            },
        ),
    ]
}

/// Bakes with a cancel flag raised by the progress callback after the first window; returns the
/// result and how many windows were reported.
fn bake_cancelled_after_first_window(
    tape: &Tape,
    options: &BakeFileOptions,
) -> (Result<BakeReport, BakeError>, usize) {
    let cancel = Arc::new(AtomicBool::new(false));
    let mut options = options.clone();
    options.bake.cancel = Some(cancel.clone());
    let mut windows = 0;
    let result = bake_files(tape, &options, &mut |_| {
        windows += 1;
        cancel.store(true, Ordering::Relaxed);
    });
    (result, windows)
}

/// 128×128×64 on 2 threads: 16 slices a window, 4 windows.
fn big_grid() -> Grid {
    grid_over([128, 128, 64], [0.0; 3], [1.0; 3])
}

#[test]
fn an_interrupted_bake_leaves_no_file_in_any_format() {
    let tape = cheap_marble(1.0);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for (what, options) in every_format(big_grid()) {
        let options = options.in_dir(&out);
        let (result, windows) = bake_cancelled_after_first_window(&tape, &options);
        assert!(
            matches!(result, Err(BakeError::Cancelled)),
            "{what}: {:?}",
            result.map(|r| r.files)
        );
        assert_eq!(
            windows, 1,
            "{what}: the bake goes on after the flag is raised"
        );
        assert_eq!(
            entries(&out),
            Vec::<String>::new(),
            "{what}: something was left behind"
        );
    }
    // The output folder this bake created is removed again: no trace of a bake that did not happen.
    assert_eq!(entries(tmp.path()), Vec::<String>::new());
}

#[test]
fn an_interrupted_forced_bake_keeps_the_previous_files() {
    let tape = cheap_marble(1.0);
    for (what, options) in every_format(big_grid()) {
        let dir = tempfile::tempdir().unwrap();
        let options = options.in_dir(dir.path());
        // The previous bake: a smaller grid, so a replacement would show.
        bake_ok(&tape, &options.clone().with_grid(small_grid()));
        let before = snapshot(dir.path());
        let forced = BakeFileOptions {
            force: true,
            ..options
        };
        let (result, _) = bake_cancelled_after_first_window(&tape, &forced);
        assert!(matches!(result, Err(BakeError::Cancelled)), "{what}");
        assert!(
            snapshot(dir.path()) == before,
            "{what}: an interrupted bake changed the previous files"
        );
        assert_no_hidden_entries(dir.path());
    }
}

// ---------------------------------------------------------------------------------------------
// 6. Failed bakes

#[test]
fn an_out_dir_that_is_a_regular_file_fails_and_creates_nothing() {
    let tape = load(MARBLE);
    let tmp = tempfile::tempdir().unwrap();
    let blocker = tmp.path().join("blocker");
    std::fs::write(&blocker, b"not a folder").unwrap();
    for out in [blocker.clone(), blocker.join("below")] {
        for (what, options) in every_format(small_grid()) {
            let error = bake_err(&tape, &options.in_dir(&out));
            assert!(
                matches!(error, BakeError::Io { .. } | BakeError::Output(_)),
                "{what}: {error:?}"
            );
            assert_eq!(entries(tmp.path()), ["blocker"], "{what}");
            assert_eq!(std::fs::read(&blocker).unwrap(), b"not a folder");
        }
    }
}

#[test]
fn an_invalid_grid_is_refused_before_anything_is_written() {
    let tape = load(MARBLE);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for grid in [
        grid_over([0, 4, 4], [0.0; 3], [1.0; 3]),
        grid_over([4; 3], [0.0, 1.0, 0.0], [1.0, 0.0, 1.0]),
        grid_over([4; 3], [f64::NAN, 0.0, 0.0], [1.0; 3]),
    ] {
        let error = bake_err(&tape, &options(&out, grid, Format::Raw));
        assert!(
            matches!(error, BakeError::Refused(_)),
            "{grid:?}: {error:?}"
        );
        assert!(!out.exists(), "{grid:?}: the out folder was created");
    }
}

// ---------------------------------------------------------------------------------------------
// 7. Overwrite refusal

#[test]
fn existing_outputs_are_refused_without_force_and_kept() {
    let tape = load(MARBLE);
    for (what, options) in every_format(small_grid()) {
        let dir = tempfile::tempdir().unwrap();
        let options = options.in_dir(dir.path());
        bake_ok(&tape, &options);
        let before = snapshot(dir.path());
        let error = bake_err(
            &tape,
            &options
                .clone()
                .with_grid(grid_over([3, 3, 3], [0.0; 3], [1.0; 3])),
        );
        let BakeError::Refused(message) = &error else {
            panic!("{what}: {error:?}")
        };
        let first = texgraph::bake::planned_outputs(&tape, &options).unwrap()[0]
            .display()
            .to_string();
        assert!(
            message.contains(&first) && message.contains("--force"),
            "{what}: {message}"
        );
        assert!(
            snapshot(dir.path()) == before,
            "{what}: a refused bake changed the files"
        );
        assert_no_hidden_entries(dir.path());
    }
}

#[test]
fn one_existing_output_blocks_the_whole_bake() {
    // Only the second output exists: the first must not be written either.
    let tape = load(MARBLE);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("marble.vein.exr"), b"precious").unwrap();
    let error = bake_err(&tape, &options(dir.path(), small_grid(), Format::Exr));
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("marble.vein.exr")),
        "{error:?}"
    );
    assert_eq!(entries(dir.path()), ["marble.vein.exr"]);
}

#[test]
fn a_raw_sidecar_alone_blocks_a_raw_bake() {
    let tape = load(MARBLE);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("marble.colour.json"), b"{}").unwrap();
    let error = bake_err(&tape, &options(dir.path(), small_grid(), Format::Raw));
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("marble.colour.raw")),
        "{error:?}"
    );
    assert_eq!(entries(dir.path()), ["marble.colour.json"]);
    assert_eq!(
        std::fs::read(dir.path().join("marble.colour.json")).unwrap(),
        b"{}"
    );
}

#[test]
fn force_replaces_files_and_png_folders_whole() {
    let tape = load(MARBLE);
    let (old, new) = (grid_over([3, 3, 3], [0.0; 3], [1.0; 3]), small_grid());
    let expected = expected(&tape, &new);
    for (what, options) in every_format(new) {
        let dir = tempfile::tempdir().unwrap();
        let options = options.in_dir(dir.path());
        bake_ok(&tape, &options.clone().with_grid(old));
        let names = entries(dir.path());
        // A stale file in a slice folder must not survive the replacement.
        let slices = dir.path().join("marble.colour");
        if slices.is_dir() {
            std::fs::write(slices.join("z0099.png"), b"stale").unwrap();
            std::fs::write(slices.join("notes.txt"), b"stale").unwrap();
        }
        bake_ok(
            &tape,
            &BakeFileOptions {
                force: true,
                ..options.clone()
            },
        );
        assert_eq!(entries(dir.path()), names, "{what}");
        match (options.format, options.atlas, options.raw_type) {
            (Format::Exr, _, _) => check_exr(dir.path(), &new, &expected, options.half),
            (Format::Png, false, _) => check_png_slices(
                dir.path(),
                &new,
                &expected,
                if options.depth16 { 16 } else { 8 },
                Transfer::Srgb,
            ),
            (Format::Png, true, _) => check_png_atlas(dir.path(), &new, &expected, 8),
            (Format::Raw, _, raw_type) => {
                for json in check_raw(
                    dir.path(),
                    &new,
                    &expected,
                    raw_type,
                    options.alpha,
                    Transfer::Srgb,
                ) {
                    assert_eq!(
                        json["size"],
                        serde_json::json!(new.size),
                        "{what}: the sidecar was not replaced"
                    );
                }
            }
            (Format::Ktx2, _, _) => unreachable!("tests/it/bake_ktx2.rs covers KTX2"),
            (Format::Zarr, _, _) => unreachable!("tests/it/bake_zarr.rs covers zarr"),
            (Format::Vdb, _, _) => unreachable!("tests/it/bake_vdb_reader.rs covers vdb"),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 8. Size limit

#[test]
fn the_size_limit_refuses_before_anything_is_written() {
    assert_eq!(DEFAULT_MAX_BAKE_BYTES, 16 << 30);
    let tape = load(MARBLE);
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let grid = small_grid();
    // Raw u8 RGBA colour + grey-alpha vein: 4 + 2 bytes a voxel.
    let estimate = voxel_count(&grid) as u64 * 6;
    let limited = |max_bytes: u64| BakeFileOptions {
        alpha: true,
        max_bytes,
        ..options(&out, grid, Format::Raw)
    };
    let error = bake_err(&tape, &limited(estimate - 1));
    assert!(matches!(error, BakeError::Refused(_)), "{error:?}");
    assert!(!out.exists(), "a refused bake created its folder");
    // The limit itself is allowed.
    bake_ok(&tape, &limited(estimate));
    // A grid far beyond the default limit is refused at once, without evaluating anything.
    let huge = Grid::cube(4096);
    let started = std::time::Instant::now();
    let error = bake_err(
        &tape,
        &BakeFileOptions {
            out_dir: tmp.path().join("huge"),
            ..options(&out, huge, Format::Exr)
        },
    );
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("limit")),
        "{error:?}"
    );
    assert!(started.elapsed().as_secs() < 5);
    assert!(!tmp.path().join("huge").exists());
}

// ---------------------------------------------------------------------------------------------
// 9. Non-finite values

/// 4×3×2 voxels over the unit cube: x centres 1/8, 3/8, 5/8, 7/8, symmetric around 0.5.
fn non_finite_grid() -> Grid {
    grid_over([4, 3, 2], [0.0; 3], [1.0; 3])
}

#[test]
fn non_finite_values_are_counted_and_kept_out_of_min_max_mean() {
    let tape = load_text(NON_FINITE);
    let grid = non_finite_grid();
    let volume = bake_volume(
        &tape,
        &BakeOptions {
            grid,
            threads: 2,
            ..BakeOptions::default()
        },
    )
    .expect("bake");
    let expected = expected(&tape, &grid);
    check_stats(&volume.stats, &expected);

    let stats = |name: &str| -> ChannelStats {
        volume
            .stats
            .iter()
            .find(|s| s.name == name)
            .expect(name)
            .channels[0]
    };
    let half = (voxel_count(&grid) / 2) as u64;
    let all = voxel_count(&grid) as u64;
    let s = stats("s");
    assert_eq!((s.nan, s.pos_inf, s.neg_inf), (half, 0, 0));
    let (low, high) = (
        (0.5f32 - 0.375).sqrt() as f64,
        (0.5f32 - 0.125).sqrt() as f64,
    );
    assert_eq!((s.min, s.max), (low, high));
    assert!((s.mean - (low + high) / 2.0).abs() < 1e-12, "{}", s.mean);
    for (name, counts) in [("d", (0, all, 0)), ("m", (0, 0, all)), ("n", (all, 0, 0))] {
        let c = stats(name);
        assert_eq!((c.nan, c.pos_inf, c.neg_inf), counts, "{name}");
        assert_eq!(
            (c.min, c.max),
            (f64::INFINITY, f64::NEG_INFINITY),
            "{name}: no finite value"
        );
        assert!(c.mean.is_nan(), "{name}");
        assert_eq!(c.non_finite(), all);
    }
    let f = stats("f");
    assert_eq!(f.non_finite(), 0);
    assert_eq!(
        (f.min, f.max),
        ((1.0f64 / 6.0) as f32 as f64, (5.0f64 / 6.0) as f32 as f64)
    );
    let total: Vec<u64> = volume.stats.iter().map(|s| s.non_finite()).collect();
    assert_eq!(total, [half, all, all, all, 0]);

    // 8-bit files: NaN → 0, +inf → 255, -inf → 0.
    let dir = tempfile::tempdir().unwrap();
    bake_ok(&tape, &options(dir.path(), grid, Format::Raw));
    let raw = |name: &str| std::fs::read(dir.path().join(format!("marble.{name}.raw"))).unwrap();
    assert!(raw("d").iter().all(|&b| b == 255));
    assert!(raw("m").iter().all(|&b| b == 0) && raw("n").iter().all(|&b| b == 0));
    let s = raw("s");
    for voxel @ [i, _, _] in voxels(grid.size) {
        assert_eq!(s[linear(grid.size, voxel)] == 0, i >= 2, "{voxel:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// 10. The command line

fn texgraph(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(root())
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .output()
        .expect("run texgraph")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Asserts the exit code, showing the output when it is not the expected one.
fn assert_exit(output: &Output, code: i32) {
    assert_eq!(
        output.status.code(),
        Some(code),
        "stdout:\n{}\nstderr:\n{}",
        text(&output.stdout),
        text(&output.stderr)
    );
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

/// The statistics line of one output, `  NAME: min … max … mean …; non-finite …` (or
/// `  NAME: no finite values; non-finite …`).
fn stats_line<'a>(stdout: &'a str, name: &str) -> &'a str {
    let prefix = format!("  {name}: ");
    stdout
        .lines()
        .find(|l| l.starts_with(&prefix))
        .unwrap_or_else(|| panic!("no statistics for {name} in:\n{stdout}"))
}

#[test]
fn cli_bakes_a_batch_and_reports_statistics_and_speed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("baked");
    let output = texgraph(&[
        "bake",
        MARBLE,
        STRIPES,
        "--size",
        "8",
        "--format",
        "raw",
        "--out",
        path_str(&out),
    ]);
    assert_exit(&output, 0);
    let stdout = text(&output.stdout);
    assert_eq!(
        entries(&out),
        sorted(&[
            "seed003_marble.colour.json",
            "seed003_marble.colour.raw",
            "seed003_marble.vein.json",
            "seed003_marble.vein.raw",
            "seed004_stripes.colour.json",
            "seed004_stripes.colour.raw",
            "seed004_stripes.jump.json",
            "seed004_stripes.jump.raw",
        ])
    );
    for name in ["colour", "vein", "jump"] {
        let line = stats_line(&stdout, name);
        assert!(
            line.contains(" max ") && line.contains(" mean ") && line.contains("non-finite 0"),
            "{line}"
        );
    }
    assert_eq!(
        stdout.matches("512 voxels in ").count(),
        2,
        "a speed line per graph:\n{stdout}"
    );
    let last = stdout.lines().last().unwrap_or_default();
    assert!(
        last.starts_with("baked 2 of 2 graphs: 1024 voxels in ") && last.ends_with(" Mvoxels/s"),
        "final line: {last}"
    );

    // The statistics printed are the library's, and the files the library's.
    let (tape, params) = load_with(MARBLE, &[]);
    let lib_dir = tempfile::tempdir().unwrap();
    let mut options = BakeFileOptions::new("seed003_marble", lib_dir.path());
    options.format = Format::Raw;
    options.bake.grid = Grid::cube(8);
    let report = bake_ok(&tape, &options);
    let vein = &report.stats[1].channels[0];
    let printed: Vec<&str> = stats_line(&stdout, "vein").split_whitespace().collect();
    let number = |word: &str| {
        word.trim_end_matches(';')
            .parse::<f32>()
            .unwrap_or_else(|_| panic!("{word} in {printed:?}"))
    };
    assert_eq!(
        (printed[1], printed[3], printed[5]),
        ("min", "max", "mean"),
        "{printed:?}"
    );
    assert_eq!(
        [number(printed[2]), number(printed[4]), number(printed[6])],
        [vein.min as f32, vein.max as f32, vein.mean as f32]
    );
    for name in ["seed003_marble.colour.raw", "seed003_marble.vein.raw"] {
        assert!(
            std::fs::read(out.join(name)).unwrap()
                == std::fs::read(lib_dir.path().join(name)).unwrap(),
            "{name}"
        );
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("seed003_marble.vein.json")).unwrap())
            .unwrap();
    assert_eq!(json["graph"], serde_json::json!(MARBLE));
    assert_eq!(
        json["params"],
        serde_json::Value::Object(
            params
                .iter()
                .map(|(k, v)| (k.clone(), serde_json::json!(v)))
                .collect()
        )
    );
    assert_eq!(json["size"], serde_json::json!([8, 8, 8]));
}

#[test]
fn cli_bakes_the_good_graphs_of_a_batch_with_a_bad_one_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("broken.ron");
    std::fs::write(
        &bad,
        r#"Graph(nodes: { "n": Noise(input: "nowhere") }, outputs: { "v": "n" })"#,
    )
    .unwrap();
    let out = dir.path().join("baked");
    let output = texgraph(&[
        "bake",
        MARBLE,
        path_str(&bad),
        STRIPES,
        "--size",
        "4",
        "--format",
        "raw",
        "--out",
        path_str(&out),
        "--quiet",
    ]);
    assert_exit(&output, 1);
    assert!(
        text(&output.stderr).contains("broken.ron"),
        "the diagnostic names the file:\n{}",
        text(&output.stderr)
    );
    assert!(
        out.join("seed003_marble.vein.raw").is_file()
            && out.join("seed004_stripes.jump.raw").is_file(),
        "{:?}",
        entries(&out)
    );
    assert!(!entries(&out).iter().any(|n| n.starts_with("broken")));
    assert!(
        text(&output.stdout).contains("baked 2 of 3 graphs")
            && text(&output.stdout).contains("1 failed"),
        "{}",
        text(&output.stdout)
    );
}

#[test]
fn cli_refuses_to_overwrite_without_force() {
    let dir = tempfile::tempdir().unwrap();
    let out = path_str(dir.path());
    let args = [
        "bake", MARBLE, "--size", "4", "--format", "exr", "--out", out,
    ];
    assert_exit(&texgraph(&args), 0);
    let before = snapshot(dir.path());
    let second = texgraph(&args);
    assert_exit(&second, 2);
    assert!(
        text(&second.stderr).contains("--force")
            && text(&second.stderr).contains("seed003_marble.colour.exr"),
        "{}",
        text(&second.stderr)
    );
    assert!(snapshot(dir.path()) == before);
    let forced = texgraph(&[
        "bake", MARBLE, "--size", "5", "--format", "exr", "--out", out, "--force",
    ]);
    assert_exit(&forced, 0);
    assert_eq!(
        read_exr(&dir.path().join("seed003_marble.vein.exr")).width,
        5,
        "--force replaced the file"
    );
}

#[test]
fn cli_rejects_bad_sizes_and_regions_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("baked");
    for bad in [
        &["--size", "0"][..],
        &["--size", "1,2"],
        &["--size", "4,0,4"],
        &["--size", "-3"],
        &["--region", "1,0,0:0,1,1"],
        &["--region", "0,0,0"],
        &["--region", "0,0,nan:1,1,1"],
    ] {
        let output = texgraph(
            &[
                &["bake", MARBLE, "--format", "raw", "--out", path_str(&out)][..],
                bad,
            ]
            .concat(),
        );
        assert_exit(&output, 2);
        assert!(!out.exists(), "{bad:?} created the out folder");
    }
}

#[test]
fn cli_accepts_negative_regions() {
    for region in [
        &["--region=-1,-1,-1:1,1,1"][..],
        &["--region", "-1,-1,-1:1,1,1"],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let output = texgraph(
            &[
                &[
                    "bake",
                    MARBLE,
                    "--size",
                    "2,3,4",
                    "--format",
                    "raw",
                    "--out",
                    path_str(dir.path()),
                ][..],
                region,
            ]
            .concat(),
        );
        assert_exit(&output, 0);
        assert!(
            text(&output.stdout).contains("2×3×4 voxels over [-1, -1, -1]..[1, 1, 1]"),
            "{}",
            text(&output.stdout)
        );
        let json: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.path().join("seed003_marble.colour.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(
            json["region"],
            serde_json::json!({ "min": [-1.0, -1.0, -1.0], "max": [1.0, 1.0, 1.0] }),
            "{region:?}"
        );
    }
}

#[test]
fn cli_shows_no_progress_bar_when_piped_or_quiet() {
    for quiet in [false, true] {
        let dir = tempfile::tempdir().unwrap();
        let mut args = vec![
            "bake",
            MARBLE,
            "--size",
            "16",
            "--format",
            "png",
            "--out",
            path_str(dir.path()),
        ];
        if quiet {
            args.push("--quiet");
        }
        let output = texgraph(&args);
        assert_exit(&output, 0);
        // stderr is a pipe here: no bar, no carriage returns, no escapes; nothing at all.
        assert_eq!(text(&output.stderr), "", "quiet: {quiet}");
        assert!(
            !text(&output.stdout).contains(['\r', '\u{1b}']),
            "{}",
            text(&output.stdout)
        );
    }
}

#[test]
fn cli_reports_non_finite_counts_and_warns() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("nonfinite.ron");
    std::fs::write(&graph, NON_FINITE).unwrap();
    let out = dir.path().join("baked");
    let output = texgraph(&[
        "bake",
        path_str(&graph),
        "--size",
        "4,3,2",
        "--format",
        "exr",
        "--out",
        path_str(&out),
    ]);
    assert_exit(&output, 0);
    let stdout = text(&output.stdout);
    assert!(
        stats_line(&stdout, "s").ends_with("non-finite 12 (NaN 12, +inf 0, -inf 0)"),
        "{stdout}"
    );
    assert_eq!(
        stats_line(&stdout, "d"),
        "  d: no finite values; non-finite 24 (NaN 0, +inf 24, -inf 0)",
        "{stdout}"
    );
    assert!(
        stats_line(&stdout, "m").ends_with("non-finite 24 (NaN 0, +inf 0, -inf 24)"),
        "{stdout}"
    );
    assert!(
        stats_line(&stdout, "n").ends_with("non-finite 24 (NaN 24, +inf 0, -inf 0)"),
        "{stdout}"
    );
    assert!(
        stats_line(&stdout, "f").ends_with("non-finite 0"),
        "{stdout}"
    );
    let stderr = text(&output.stderr);
    for (name, count) in [("s", 12), ("d", 24), ("m", 24), ("n", 24)] {
        assert!(
            stderr.contains(&format!(
                "warning: {}: output \"{name}\" has {count} non-finite",
                graph.display()
            )),
            "{stderr}"
        );
    }
    assert!(!stderr.contains("output \"f\""), "{stderr}");
}

// ---------------------------------------------------------------------------------------------
// Bugs found while writing these tests

#[test]
fn force_never_replaces_a_folder_where_a_file_goes() {
    // Even with --force, a folder where a raw file goes is refused before anything is baked
    // (a destination that is not a regular file is never replaced), and left as it was.
    let tape = load(MARBLE);
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("marble.vein.raw")).unwrap();
    std::fs::write(dir.path().join("marble.vein.raw").join("keep"), b"x").unwrap();
    let error = bake_files(
        &tape,
        &BakeFileOptions {
            force: true,
            ..options(dir.path(), small_grid(), Format::Raw)
        },
        &mut |_| {},
    )
    .expect_err("refused");
    assert!(error.to_string().contains("is a folder"), "{error}");
    assert_eq!(entries(dir.path()), ["marble.vein.raw"]);
    assert_eq!(
        std::fs::read(dir.path().join("marble.vein.raw").join("keep")).unwrap(),
        b"x"
    );
}

// ---------------------------------------------------------------------------------------------
// Windows smaller than a slice, segments shorter than a row

/// Slices larger than a window (520 × 300 voxels against one thread's window of 131 072) are
/// streamed through one PNG encoder across windows, and rows longer than a segment (70 000
/// voxels against 65 536) are split: every format still holds exactly what `eval` gives.
#[test]
fn slices_larger_than_a_window_and_rows_longer_than_a_segment_bake_exactly() {
    let tape = cheap_marble(2.0);
    for size in [[520, 300, 3], [70_000, 2, 2]] {
        let grid = grid_over(size, [-1.0, 0.0, 0.0], [1.0, 1.0, 0.5]);
        let expected = expected(&tape, &grid);
        let one_thread = |format: Format, dir: &Path| {
            let mut options = options(dir, grid, format);
            options.bake.threads = 1;
            options
        };
        let dir = tempfile::tempdir().unwrap();
        bake_ok(&tape, &one_thread(Format::Png, dir.path()));
        check_png_slices(dir.path(), &grid, &expected, 8, Transfer::Srgb);
        let dir = tempfile::tempdir().unwrap();
        bake_ok(
            &tape,
            &BakeFileOptions {
                atlas: true,
                ..one_thread(Format::Png, dir.path())
            },
        );
        check_png_atlas(dir.path(), &grid, &expected, 8);
        let dir = tempfile::tempdir().unwrap();
        bake_ok(&tape, &one_thread(Format::Exr, dir.path()));
        check_exr(dir.path(), &grid, &expected, false);
        let dir = tempfile::tempdir().unwrap();
        bake_ok(
            &tape,
            &BakeFileOptions {
                raw_type: RawSampleType::F32,
                ..one_thread(Format::Raw, dir.path())
            },
        );
        check_raw(
            dir.path(),
            &grid,
            &expected,
            RawSampleType::F32,
            false,
            Transfer::Srgb,
        );
    }
}

/// graphs/tiling_marble.ron repeats every unit: a 2×2 (×1) tiling of its bake of [0, 1]³ is,
/// voxel for voxel and bit for bit, the bake of the doubled region [0, 2]² × [0, 1] (the voxel
/// centres of the doubled grid are the unit grid's plus whole units: exact for a power-of-two
/// size); and the unit bake's opposite faces match as neighbours would (the seam is continuous).
#[test]
fn the_tiling_marble_tiles() {
    let tape = load_with("graphs/tiling_marble.ron", &[("octaves", 5.0)]).0;
    let n = 16;
    let bake = |grid: Grid| {
        bake_volume(
            &tape,
            &BakeOptions {
                grid,
                threads: 2,
                ..BakeOptions::default()
            },
        )
        .expect("bake")
    };
    let unit = bake(grid_over([n, n, n], [0.0; 3], [1.0; 3]));
    let doubled = bake(grid_over([2 * n, 2 * n, n], [0.0; 3], [2.0, 2.0, 1.0]));
    let mut compared = 0;
    for (u, d) in unit.outputs.iter().zip(&doubled.outputs) {
        let channels = u.ty.channels();
        for [i, j, k] in voxels([2 * n, 2 * n, n]) {
            for c in 0..channels {
                let want = u.get(&unit.grid, i % n, j % n, k, c);
                let got = d.get(&doubled.grid, i, j, k, c);
                assert!(
                    same(got, want),
                    "{} voxel {:?} channel {c}: {got} vs {want}",
                    u.name,
                    [i, j, k]
                );
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 4 * n * n * n * 4);
    // Without the period, the same marble does not tile: the test can fail.
    let plain = load_text(
        &std::fs::read_to_string(root().join("graphs/tiling_marble.ron"))
            .unwrap()
            .replace(", period: 4", ""),
    );
    let plain_value = |p: [f64; 3]| {
        let mut out = [0f32; 4];
        plain.eval_point(&mut Workspace::new(), p, &mut out);
        out[3]
    };
    assert_ne!(plain_value([0.3, 0.4, 0.5]), plain_value([1.3, 0.4, 0.5]));
}

// ---------------------------------------------------------------------------------------------
// Filtered bakes (issue 33)

/// `--filter box` (`BakeOptions::filter`): each voxel holds the graph's mean over its cell.
/// `fract(3x + 0.2)` over x-cells of width 1/4 (a third of a period to a period and a half):
/// every voxel within 1e-5 of the exact mean from fract's antiderivative
/// `F(x) = floor(x)/2 + fract(x)²/2`, where the point bake is off by up to 1/2.
#[test]
fn box_filtered_bake_holds_each_voxels_mean() {
    let tape = load_text(
        r#"Graph(nodes: { "p": Position }, outputs: { "f": Fract(Add(Mul(3.0, "p.x"), 0.2)) })"#,
    );
    let grid = grid_over([8, 2, 2], [-1.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
    let dir = tempfile::tempdir().expect("tempdir");
    let mut options = options(dir.path(), grid, Format::Raw);
    options.stem = "box".into();
    options.raw_type = RawSampleType::F32;
    options.bake.filter = texgraph::filter::Filter::Box;
    bake_ok(&tape, &options);
    let bytes = std::fs::read(dir.path().join("box.f.raw")).expect("read raw");
    let antiderivative = |x: f64| x.floor() / 2.0 + (x - x.floor()).powi(2) / 2.0;
    let mut worst_point = 0.0f64;
    for voxel in voxels(grid.size) {
        let at = linear(grid.size, voxel) * 4;
        let got = f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as f64;
        let (a, b) = (
            -1.0 + 0.25 * voxel[0] as f64,
            -1.0 + 0.25 * (voxel[0] + 1) as f64,
        );
        let (u, v) = (3.0 * a + 0.2, 3.0 * b + 0.2);
        let exact = (antiderivative(v) - antiderivative(u)) / (v - u);
        assert!(
            (got - exact).abs() < 1e-5,
            "voxel {voxel:?}: {got}, exact mean {exact}"
        );
        let centre = 3.0 * (a + b) / 2.0 + 0.2;
        worst_point = worst_point.max((centre - centre.floor() - exact).abs());
    }
    assert!(
        worst_point > 0.1,
        "the grid must be one where point sampling is wrong"
    );
}
