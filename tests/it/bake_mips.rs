//! `bake --mips`: prefiltered mip levels baked from the graph. Every level L must hold the graph
//! compiled with footprint level of detail for L's voxel size, evaluated at L's own voxel
//! centres (max(1, n >> L) voxels per axis over the same region) — checked texel by texel
//! against `eval_point` of an independently compiled tape, in KTX2 files (read by the `ktx2`
//! crate), OME-Zarr multiscale groups (read by `zarrs`) and level folders.

use crate::common;
use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use texgraph::bake::{bake_mipmapped, BakeFileOptions, Format, Grid, Ktx2SampleType, Region};
use texgraph::{CheckOptions, CompileOptions, SourceFile, Tape};

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");

/// Fine detail (12 octaves), so coarse levels must leave octaves out.
const GRAPH: &str = r#"Graph(nodes: { "p": Position }, outputs: {
    "height": Fbm(input: Mul("p", 4.0), basis: Perlin, octaves: 12, seed: 3),
    "tint": Combine(Fbm(input: Mul("p", 2.0), basis: Perlin, octaves: 10, seed: 5), "p.y", 0.5),
})"#;

fn graph() -> texgraph::CheckedGraph {
    texgraph::check(SourceFile::new("mips.ron", GRAPH), &CheckOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render(false)))
}

/// 20×9×6 over a box with negative corners: levels 20×9×6, 10×4×3, 5×2×1, 2×1×1, 1×1×1.
fn grid() -> Grid {
    Grid {
        size: [20, 9, 6],
        region: Region {
            min: [-1.0, -0.5, 0.25],
            max: [1.5, 0.75, 1.0],
        },
    }
}

/// Level `level`'s grid and its footprint, computed here from the documented rule.
fn level(grid: &Grid, level: u32) -> (Grid, f64) {
    let size = grid.size.map(|n| (n >> level).max(1));
    let spacing = (0..3)
        .map(|a| (grid.region.max[a] - grid.region.min[a]) / size[a] as f64)
        .fold(f64::INFINITY, f64::min);
    (
        Grid {
            size,
            region: grid.region,
        },
        spacing,
    )
}

fn tapes(grid: &Grid) -> Vec<Tape> {
    let graph = graph();
    (0..texgraph::bake::mip_level_count(grid))
        .map(|l| {
            let options = CompileOptions {
                spacing: Some(level(grid, l).1),
                ..CompileOptions::default()
            };
            texgraph::compile(&graph, &options).unwrap()
        })
        .collect()
}

use common::expected_volume as expected;

fn options(out: &Path, format: Format) -> BakeFileOptions {
    let mut options = BakeFileOptions::new("mips", out);
    options.bake.grid = grid();
    options.bake.threads = 2;
    options.format = format;
    options.ktx2_type = Ktx2SampleType::F32;
    options
}

#[test]
fn the_level_rule_and_level_of_detail_apply() {
    let g = grid();
    assert_eq!(texgraph::bake::mip_level_count(&g), 5);
    for l in 0..5 {
        let (want, spacing) = level(&g, l);
        assert_eq!(texgraph::bake::mip_grid(&g, l), want);
        assert_eq!(texgraph::bake::mip_spacing(&g, l), Some(spacing));
    }
    // Coarser levels keep fewer octaves: the prefiltering is the graph's own (one octave less
    // per level while any is left).
    let kept: Vec<f64> = tapes(&Grid::cube(256))
        .iter()
        .map(|t| t.fractal_octaves()[0].2)
        .collect();
    assert_eq!(kept.len(), 9);
    assert!(
        kept.windows(2).all(|w| w[1] < w[0] || w[0] == 0.0),
        "{kept:?}"
    );
    assert!(
        kept[0] < 12.0,
        "level 0 is prefiltered for its own voxels: {kept:?}"
    );
}

#[test]
fn ktx2_holds_every_level_smallest_last_in_the_index() {
    let g = grid();
    let tapes = tapes(&g);
    let dir = tempfile::tempdir().unwrap();
    let reports = bake_mipmapped(&tapes, &options(dir.path(), Format::Ktx2), &mut |_| {}).unwrap();
    assert_eq!(reports.len(), 1);
    for (o, output) in tapes[0].outputs().iter().enumerate() {
        let bytes = std::fs::read(dir.path().join(format!("mips.{}.ktx2", output.name))).unwrap();
        let reader = ktx2::Reader::new(&bytes[..]).unwrap();
        let header = reader.header();
        assert_eq!(header.level_count, 5);
        assert_eq!(
            [header.pixel_width, header.pixel_height, header.pixel_depth],
            [20, 9, 6]
        );
        let levels: Vec<ktx2::Level> = reader.levels().collect();
        // Level data is stored smallest first (spec "levelImages").
        let offsets: Vec<u64> = (0..5)
            .map(|l| {
                let at = 80 + 24 * l;
                u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
            })
            .collect();
        assert!(offsets.windows(2).all(|w| w[1] < w[0]), "{offsets:?}");
        let channels = if output.ty == texgraph::Type::Vec3 {
            4
        } else {
            1
        };
        for (l, (data, tape)) in levels.iter().zip(&tapes).enumerate() {
            let (lg, _) = level(&g, l as u32);
            let want = &expected(tape, &lg)[o];
            let got: Vec<f32> = data
                .data
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
                .collect();
            let width = output.ty.channels();
            assert_eq!(
                got.len(),
                lg.voxels().unwrap() as usize * channels,
                "level {l}"
            );
            for (v, (texel, want)) in got.chunks(channels).zip(want.chunks(width)).enumerate() {
                assert_eq!(&texel[..width], want, "{} level {l} voxel {v}", output.name);
            }
        }
    }
}

#[test]
fn zarr_writes_ome_multiscales_of_graph_prefiltered_levels() {
    let g = grid();
    let tapes = tapes(&g);
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("m.zarr");
    let mut options = options(&store, Format::Zarr);
    options.zarr.chunk = 4;
    options.zarr.shard = 8;
    bake_mipmapped(&tapes, &options, &mut |_| {}).unwrap();
    let storage = Arc::new(zarrs::filesystem::FilesystemStore::new(&store).unwrap());
    for (o, output) in tapes[0].outputs().iter().enumerate() {
        let group: serde_json::Value = serde_json::from_slice(
            &std::fs::read(store.join(&output.name).join("zarr.json")).unwrap(),
        )
        .unwrap();
        let ms = &group["attributes"]["ome"]["multiscales"][0];
        assert_eq!(group["attributes"]["ome"]["version"], "0.5");
        for l in 0..5 {
            let (lg, _) = level(&g, l);
            let dataset = &ms["datasets"][l as usize];
            assert_eq!(dataset["path"], l.to_string());
            let scale = &dataset["coordinateTransformations"][0]["scale"];
            let spacing_x = (g.region.max[0] - g.region.min[0]) / lg.size[0] as f64;
            assert_eq!(scale[2].as_f64().unwrap(), spacing_x);
            let array =
                zarrs::array::Array::open(storage.clone(), &format!("/{}/{l}", output.name))
                    .unwrap();
            let ranges: Vec<std::ops::Range<u64>> = array.shape().iter().map(|&n| 0..n).collect();
            let got: Vec<f32> = array.retrieve_array_subset(&ranges).unwrap();
            let want = &expected(&tapes[l as usize], &lg)[o];
            assert_eq!(&got, want, "{} level {l}", output.name);
        }
    }
    let checks = texgraph::bake::zarr::verify_store(&store).unwrap();
    assert_eq!(checks.len(), 10);
    assert!(checks.iter().all(|c| c.problems.is_empty()));
}

#[test]
fn cli_level_folders_and_misuse() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.ron");
    std::fs::write(&path, GRAPH).unwrap();
    let out = dir.path().join("out");
    let run = |extra: &[&str]| {
        let mut args = vec!["bake", path.to_str().unwrap(), "--size", "20,9,6", "-q"];
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        Command::new(BIN).args(&args).output().unwrap()
    };
    let done = run(&["--mips", "--format", "exr"]);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    for l in 0..5 {
        assert!(
            out.join(format!("mip{l}/g.height.exr")).is_file(),
            "level {l}"
        );
    }
    let done = run(&["--mips", "--format", "png"]);
    assert!(done.status.success());
    let slices = std::fs::read_dir(out.join("mip1/g.tint")).unwrap().count();
    assert_eq!(slices, 3, "level 1 has 6 >> 1 = 3 slices");
    // Existing levels are refused without --force, before any level is written.
    let again = run(&["--mips", "--format", "exr"]);
    assert_eq!(again.status.code(), Some(2));
    for extra in [["--mips", "--lod"], ["--mips", "--spacing=0.1"]] {
        let bad = run(&extra);
        assert_eq!(bad.status.code(), Some(2), "{extra:?}");
        assert!(String::from_utf8_lossy(&bad.stderr).contains("--mips bakes every level"));
    }
}

/// `bake --mips` box-filters every level by default (each voxel the filtered estimate of its
/// cell's mean: `Filtered` at the voxel centre, the footprint the voxel), says so in the KTX2
/// key, and `--filter point` gives the level-of-detail levels instead.
#[test]
fn cli_mips_are_box_filtered_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.ron");
    std::fs::write(&path, GRAPH).unwrap();
    let out = dir.path().join("out");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "bake",
            path.to_str().unwrap(),
            "--size",
            "20,9,6",
            "--region=-1,-0.5,0.25:1.5,0.75,1",
            "-q",
            "--force",
            "--mips",
            "--format",
            "raw",
            "--raw-type",
            "f32",
            "--output",
            "height",
        ];
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        args.extend_from_slice(extra);
        let done = Command::new(BIN).args(&args).output().unwrap();
        assert!(
            done.status.success(),
            "{}",
            String::from_utf8_lossy(&done.stderr)
        );
        let bytes = std::fs::read(out.join("mip1/g.height.raw")).unwrap();
        bytes
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect::<Vec<f32>>()
    };
    let boxed = run(&[]);
    let (g1, _) = level(&grid(), 1);
    let tape = texgraph::compile(&graph(), &CompileOptions::default()).unwrap();
    let filtered = texgraph::filter::Filtered::new(&tape);
    let side = |a: usize| (g1.region.max[a] - g1.region.min[a]) / g1.size[a] as f64;
    let footprint = texgraph::filter::Footprint::from_sides([side(0), side(1), side(2)]).unwrap();
    let centre = |a: usize, i: usize| g1.region.min[a] + (i as f64 + 0.5) * side(a);
    let height = tape
        .outputs()
        .iter()
        .position(|o| o.name == "height")
        .unwrap();
    let first = tape.outputs()[height].first_channel;
    let [nx, ny, nz] = g1.size;
    assert_eq!(boxed.len(), nx * ny * nz);
    let mut out = vec![0f32; tape.channels()];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                filtered.eval_point(
                    [centre(0, i), centre(1, j), centre(2, k)],
                    &footprint,
                    &mut out,
                );
                assert_eq!(
                    boxed[(k * ny + j) * nx + i],
                    out[first],
                    "voxel {i} {j} {k}"
                );
            }
        }
    }
    assert_ne!(boxed, run(&["--filter", "point"]));
}
