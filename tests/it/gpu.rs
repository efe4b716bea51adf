//! The GPU path (issue 19) against the f64 reference: every graph of `graphs/` at points near
//! the origin, at |p| up to 1e4 and at |p| near 2^31, within the contract of
//! `common::gpu_contract`; bakes on the GPU against bakes on the CPU; every generated shader
//! validated by naga (that test needs no GPU). On a machine without any adapter the GPU tests
//! print `SKIPPED` (CI installs Mesa's lavapipe and requires one).

use crate::common;

use texgraph::bake::{bake_volume, BakeOptions, Grid, Region};
use texgraph::gpu::{Device, GpuEvaluator};
use texgraph::{CheckOptions, CompileOptions, Extent};

/// Per channel "GPU error / CPU f32 error", for the test's log.
fn figures_text(figures: &[(f64, f64)]) -> String {
    figures
        .iter()
        .map(|(g, c)| format!("{g:.1e}/{c:.1e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `n` points, each coordinate `centre + uniform(-r, r)` (a fixed LCG: reproducible).
fn points(n: usize, centre: f64, r: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut lcg = common::lcg(seed);
    let mut next = move || (lcg() >> 11) as f64 / (1u64 << 53) as f64;
    (0..n)
        .map(|_| [0; 3].map(|_| centre + r * (2.0 * next() - 1.0)))
        .collect()
}

fn compile_for(path: &std::path::Path, points: &[[f64; 3]]) -> texgraph::Tape {
    let [x, y, z] = [0, 1, 2].map(|c| points.iter().map(|p| p[c]).collect::<Vec<f64>>());
    let options = CompileOptions {
        extent: Extent::around(&x, &y, &z),
        ..Default::default()
    };
    texgraph::load_tape(path, &CheckOptions::default(), &options)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .1
}

/// Every graph (with `TEXGRAPH_FULL=1`; else [`common::covering`]'s, which together use every
/// instruction form of every graph: lavapipe compiles a pipeline per graph): 1500 points in
/// [-10, 10]³ and 500 in [-1e4, 1e4]³, the tape compiled for their extent (as a bake compiles
/// for its region).
#[test]
fn every_graph_meets_the_gpu_contract() {
    if !common::gpu_available("every_graph_meets_the_gpu_contract") {
        return;
    }
    let mut set = points(1500, 0.0, 10.0, 1);
    set.extend(points(500, 0.0, 1e4, 2));
    let mut failures = Vec::new();
    for path in common::slow_set() {
        let tape = compile_for(&path, &set);
        let gpu = GpuEvaluator::new(&tape).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        match common::gpu_contract(&tape, &gpu, &set) {
            Ok(figures) => eprintln!("{}: {}", path.display(), figures_text(&figures)),
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Huge coordinates: the lattice cells stay exact on the GPU (positions and vec3 values are
/// f64), so noise near |p| = 2^31 is as accurate as near the origin.
#[test]
fn huge_coordinates_keep_their_lattice_cells() {
    if !common::gpu_available("huge_coordinates_keep_their_lattice_cells") {
        return;
    }
    let huge = 2f64.powi(31);
    for name in [
        "graphs/seed002_noise.ron",
        "graphs/seed003_marble.ron",
        "graphs/cells.ron",
        "graphs/tiling_marble.ron",
        "graphs/library/clouds.ron",
    ] {
        for centre in [huge, -huge] {
            let set = points(400, centre, 64.0, 3);
            let tape = compile_for(&common::crate_root().join(name), &set);
            let gpu = GpuEvaluator::new(&tape).expect("compiles on the GPU");
            let figures = common::gpu_contract(&tape, &gpu, &set)
                .unwrap_or_else(|e| panic!("{name} near {centre}: {e}"));
            eprintln!("{name} near {centre}: {}", figures_text(&figures));
        }
    }
}

/// Remainders of huge quotients are exact on the GPU as on the CPU (`d_rem` in math.wgsl, Rust's
/// `%`): `Mod` of coordinates near 1e9 by small divisors gives the CPU's bits, and a rotation by
/// `p · p` degrees (about 1e17 at the first point, which the random-graph test found: the old
/// `a - b trunc(a / b)` turned it by a wrong angle) the CPU's value. Compared with the CPU
/// directly: the contract's allowance for what f64 cannot resolve would hide both.
#[test]
fn huge_remainders_are_exact() {
    if !common::gpu_available("huge_remainders_are_exact") {
        return;
    }
    let text = r#"Graph(nodes: { "p": Position }, outputs: {
        "m": Mod("p.y", 0.7),
        "n": Mod(Mul("p.x", 1e7), -3.3),
        "r": Fract(Rotate(input: Fract(Position), axis: (0.7662260375145, 0.9074880978852755, 0.3), degrees: Dot("p", "p"))),
    })"#;
    let graph = texgraph::check(
        texgraph::SourceFile::new("rem.ron", text),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render_plain()));
    let mut set = vec![[6.988227852850647, 319832753.1311973, 7.073275865146616]];
    set.extend(points(300, 0.0, 1e9, 5));
    let n = set.len();
    let [x, y, z] = [0, 1, 2].map(|c| set.iter().map(|p| p[c]).collect::<Vec<f64>>());
    let options = CompileOptions {
        extent: Extent::around(&x, &y, &z),
        ..Default::default()
    };
    let tape = texgraph::compile(&graph, &options).expect("compiles");
    let gpu = GpuEvaluator::new(&tape).expect("compiles on the GPU");
    let mut cpu = vec![0f32; 5 * n];
    let mut on_gpu = vec![0f32; 5 * n];
    tape.eval_batch(&mut texgraph::Workspace::new(), &x, &y, &z, &mut cpu);
    gpu.eval_batch(&x, &y, &z, &mut on_gpu).expect("runs");
    for (i, p) in set.iter().enumerate() {
        for c in 0..2 {
            let k = c * n + i;
            assert_eq!(
                on_gpu[k].to_bits(),
                cpu[k].to_bits(),
                "Mod channel {c} at {p:?}: GPU {} CPU {}",
                on_gpu[k],
                cpu[k]
            );
        }
        for c in 2..5 {
            let k = c * n + i;
            assert!(
                (on_gpu[k] - cpu[k]).abs() <= 1e-5,
                "rotation channel {c} at {p:?}: GPU {} CPU {}",
                on_gpu[k],
                cpu[k]
            );
        }
    }
}

/// A bake on the GPU writes what a bake on the CPU writes, within the contract, whatever the
/// grid's shape (rows split into several segments, a region away from the origin).
#[test]
fn gpu_bakes_match_cpu_bakes() {
    if !common::gpu_available("gpu_bakes_match_cpu_bakes") {
        return;
    }
    for (name, size, region) in [
        ("graphs/seed003_marble.ron", [33, 17, 9], Region::default()),
        (
            "graphs/library/granite.ron",
            [70_001, 2, 1],
            Region::default(),
        ),
        (
            "graphs/cells.ron",
            [16, 16, 16],
            Region {
                min: [-300.0, 12.5, 1e4],
                max: [-200.0, 40.0, 1.00001e4],
            },
        ),
    ] {
        let grid = Grid { size, region };
        let path = common::crate_root().join(name);
        let options = CompileOptions {
            extent: Some(Extent::new(region.min, region.max)),
            ..Default::default()
        };
        let (_, tape) = texgraph::load_tape(&path, &CheckOptions::default(), &options).unwrap();
        let bake = |device| {
            bake_volume(
                &tape,
                &BakeOptions {
                    grid,
                    device,
                    ..Default::default()
                },
            )
            .expect("bakes")
        };
        let (cpu, gpu) = (bake(Device::Cpu), bake(Device::Gpu));
        for (a, b) in cpu.outputs.iter().zip(&gpu.outputs) {
            assert_eq!(a.data.len(), b.data.len());
            let worst = a
                .data
                .iter()
                .zip(&b.data)
                .map(|(x, y)| (x - y).abs())
                .fold(0f32, f32::max);
            assert!(
                worst <= 2e-5,
                "{name} {}: GPU and CPU bakes differ by {worst}",
                a.name
            );
        }
        // The statistics the GPU reduces (`pack.wgsl`) are the CPU's over values this close
        // (the clamp counts may differ where a value lies within 2e-5 of 0 or 1).
        for (a, b) in cpu.stats.iter().zip(&gpu.stats) {
            for (x, y) in a.channels.iter().zip(&b.channels) {
                assert_eq!(
                    (x.finite(), x.non_finite()),
                    (y.finite(), y.non_finite()),
                    "{name} {}: counts",
                    a.name
                );
                for (p, q) in [(x.min, y.min), (x.max, y.max), (x.mean, y.mean)] {
                    assert!((p - q).abs() <= 2e-5, "{name} {}: {p} against {q}", a.name);
                }
            }
        }
    }
}

/// Every shader the GPU path makes validates with naga (no GPU needed): the WGSL library and
/// the generated shader of every graph, and of every graph's gradient outputs.
#[test]
fn every_generated_shader_validates() {
    for path in common::graph_files() {
        let (_, tape) =
            texgraph::load_tape(&path, &CheckOptions::default(), &CompileOptions::default())
                .unwrap();
        let shader = texgraph::gpu::codegen::generate(&tape).expect("a plain tape");
        if let Err(e) = texgraph::gpu::validate(&shader.source) {
            panic!("{}: {e}", path.display());
        }
    }
}

/// Level of detail per point on the GPU: at spacings from fine to coarse, fractals keep the
/// octaves the CPU's `eval_batch_lod` keeps (its f64 reference within the contract).
#[test]
fn level_of_detail_per_point_matches_the_cpu() {
    if !common::gpu_available("level_of_detail_per_point_matches_the_cpu") {
        return;
    }
    for name in [
        "graphs/seed000_turbulence.ron",
        "graphs/seed003_marble.ron",
        "graphs/ridged_rock.ron",
        "graphs/library/clouds.ron",
    ] {
        let set = points(600, 0.5, 0.5, 4);
        let tape = compile_for(&common::crate_root().join(name), &set);
        // Spacings 1/4096 … 1/2, and a few without a footprint (0: every octave).
        let spacing: Vec<f64> = (0..set.len())
            .map(|i| {
                if i % 50 == 0 {
                    0.0
                } else {
                    2f64.powf(-1.0 - 11.0 * (i as f64 / set.len() as f64))
                }
            })
            .collect();
        let gpu = GpuEvaluator::new(&tape).expect("compiles on the GPU");
        let figures = common::gpu_contract_lod(&tape, &gpu, &set, Some(&spacing))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        eprintln!("{name} with level of detail: {}", figures_text(&figures));
    }
}

/// `render --device gpu --filter point` draws what the CPU draws (a scene with level of detail
/// per pixel and a bump-mapped one): every byte of the 8-bit image within 1. (Box-filtered
/// renders on the GPU's filtered form: `gpu_filtered.rs`; there each bump height's gradient
/// tape would be one more filtered shader for lavapipe to compile, minutes of CI.)
#[test]
fn gpu_renders_match_cpu_renders() {
    if !common::gpu_available("gpu_renders_match_cpu_renders") {
        return;
    }
    use texgraph::render::{load_scene, render, RenderOptions};
    for name in [
        "graphs/scenes/horizon.ron",
        "graphs/scenes/bump_gallery.ron",
    ] {
        let scene = load_scene(&common::crate_root().join(name)).expect("scene");
        let image = |device| {
            let options = RenderOptions {
                size: Some((64, 36)),
                samples: Some(1),
                device,
                filter: texgraph::render::RenderFilter::Point,
                ..Default::default()
            };
            render(&scene, &options).expect("renders").0.to_rgb8()
        };
        let (cpu, gpu) = (image(Device::Cpu), image(Device::Gpu));
        let worst = cpu
            .as_raw()
            .iter()
            .zip(gpu.as_raw())
            .map(|(a, b)| a.abs_diff(*b))
            .max();
        assert!(worst <= Some(1), "{name}: images differ by {worst:?}");
    }
}

/// The command line: `bake --device gpu` writes the files `--device cpu` writes (raw f32
/// within the contract, the sidecar the same), `--device auto` says which device it chose,
/// `--device gpu` with `--f64` is a usage error, `report` has a gpu row.
#[test]
fn the_command_line_runs_on_the_gpu() {
    if !common::gpu_available("the_command_line_runs_on_the_gpu") {
        return;
    }
    let dir = tempfile::tempdir().expect("temporary folder");
    let bake = |device: &str, out: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
            .current_dir(common::crate_root())
            .args([
                "bake",
                "graphs/seed004_marble.ron",
                "--size",
                "19,7,5",
                "--format",
                "raw",
            ])
            .args(["--raw-type", "f32", "--device", device, "--out"])
            .arg(out)
            .output()
            .expect("runs")
    };
    let (cpu_dir, gpu_dir, auto_dir) = (
        dir.path().join("c"),
        dir.path().join("g"),
        dir.path().join("a"),
    );
    for d in [&cpu_dir, &gpu_dir, &auto_dir] {
        std::fs::create_dir(d).unwrap();
    }
    assert!(bake("cpu", &cpu_dir).status.success());
    let gpu = bake("gpu", &gpu_dir);
    assert!(
        gpu.status.success(),
        "{}",
        String::from_utf8_lossy(&gpu.stderr)
    );
    assert!(String::from_utf8_lossy(&gpu.stderr).contains("evaluating on the GPU"));
    let auto = bake("auto", &auto_dir);
    let said = String::from_utf8_lossy(&auto.stderr);
    assert!(
        auto.status.success() && said.contains("--device auto: evaluating on the GPU"),
        "{said}"
    );
    for entry in std::fs::read_dir(&cpu_dir).unwrap() {
        let name = entry.unwrap().file_name();
        let (a, b) = (
            std::fs::read(cpu_dir.join(&name)).unwrap(),
            std::fs::read(gpu_dir.join(&name)).unwrap(),
        );
        if name.to_string_lossy().ends_with(".raw") {
            let floats = |v: &[u8]| {
                v.chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                    .collect::<Vec<f32>>()
            };
            let worst = floats(&a)
                .iter()
                .zip(floats(&b))
                .map(|(x, y)| (x - y).abs())
                .fold(0f32, f32::max);
            assert!(a.len() == b.len() && worst <= 2e-5, "{name:?}: {worst}");
        }
    }
    let double = std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
        .current_dir(common::crate_root())
        .args([
            "bake",
            "graphs/seed004_marble.ron",
            "--f64",
            "--device",
            "gpu",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(double.status.code(), Some(2));
    // `report`'s gpu row (the library call: the command line adds baked volumes up to 256³,
    // minutes in a debug build), its error as the f32 path's.
    let graph = texgraph::load_graph(
        &common::crate_root().join("graphs/seed002_noise.ron"),
        &CheckOptions::default(),
    )
    .unwrap();
    let options = texgraph::report::ReportOptions {
        points: 2000,
        runs: 1,
        bake_sizes: vec![],
        lod_spacings: vec![],
        ..Default::default()
    };
    let rows = texgraph::report::accuracy_report(&graph, &[], &options).unwrap();
    let row = rows
        .iter()
        .find(|r| r.strategy.starts_with("gpu ("))
        .expect("a gpu row");
    assert!(row.max_abs_error <= 2e-5, "{}", row.max_abs_error);
}

/// The stability survey covers the GPU (`report --stability`): at every magnitude up to 2^31,
/// each output's tape compiled for that magnitude runs on the GPU within the contract of the
/// promoted f32 tape's own error.
#[test]
fn the_stability_survey_covers_the_gpu() {
    if !common::gpu_available("the_stability_survey_covers_the_gpu") {
        return;
    }
    for name in ["graphs/seed003_marble.ron", "graphs/cells.ron"] {
        let graph =
            texgraph::load_graph(&common::crate_root().join(name), &CheckOptions::default())
                .unwrap();
        let rows = texgraph::stability::stability_report_with_gpu(&graph, 1e-4).unwrap();
        for row in rows.iter().filter(|r| r.output) {
            let gpu = row.max_gpu_error.expect("a GPU column");
            let tolerance = 2e-5 * row.max_abs_value.max(1.0) + 4.0 * row.max_promoted_error;
            assert!(
                gpu <= tolerance,
                "{name} {} at {:e}: GPU {gpu:e}, promoted f32 {:e}",
                row.node,
                row.magnitude,
                row.max_promoted_error
            );
        }
        eprintln!("{}", texgraph::stability::stability_text(&rows));
    }
}

/// White noise and the cellular values are the same bits on the GPU as on the CPU's f32 path
/// (issue 32): the cell hash is 32-bit integer arithmetic and every feature point is exact in
/// f32 (the jitter a multiple of 1/256), and the distances follow the CPU's order of operations
/// with correctly rounded roots; untiled and tiled, near the origin, at |p| ~ 1e6, beyond
/// 2^32 cells (where the cell index needs its high word) and, untiled, at 2^54 (the GPU reduces
/// a tiled coordinate exactly below 2^51, docs/gpu.md).
#[test]
fn white_and_cellular_values_are_the_cpu_bits() {
    if !common::gpu_available("white_and_cellular_values_are_the_cpu_bits") {
        return;
    }
    let source = r#"Graph(nodes: { "p": Position }, outputs: {
        "white": WhiteNoise(input: "p", seed: 5),
        "white_tiled": WhiteNoise(input: "p", seed: 6, period: (3, 7, 1000)),
        "cell": Cellular(input: "p", seed: 9, jitter: 0.9, value: CellValue),
        "f1": Cellular(input: "p", seed: 3, value: F1),
        "f2": Cellular(input: "p", seed: 4, jitter: 0.75, metric: Manhattan, value: F2),
        "edge": Cellular(input: "p", seed: 2, jitter: 0.5, metric: Chebyshev, value: Edge),
        "tiled": Cellular(input: "p", seed: 7, value: F2MinusF1, period: (4, 5, 6)),
    })"#;
    let graph = texgraph::check(
        texgraph::SourceFile::new("cells.ron", source),
        &CheckOptions::default(),
    )
    .expect("checks");
    let tape = texgraph::compile(&graph, &CompileOptions::default()).expect("compiles");
    let gpu = GpuEvaluator::new(&tape).expect("compiles on the GPU");
    let mut set = points(1000, 0.0, 50.0, 11);
    set.extend(points(300, 1e6, 100.0, 12));
    set.extend(points(300, -6e10, 100.0, 13));
    set.extend(points(100, 2f64.powi(54), 0.0, 14));
    let [x, y, z] = [0, 1, 2].map(|c| set.iter().map(|p| p[c]).collect::<Vec<f64>>());
    let n = set.len();
    let mut cpu = vec![0f32; tape.channels() * n];
    tape.eval_batch(&mut texgraph::Workspace::<f32>::new(), &x, &y, &z, &mut cpu);
    let mut gpu_out = vec![0f32; tape.channels() * n];
    gpu.eval_batch(&x, &y, &z, &mut gpu_out).expect("evaluates");
    let names: Vec<&str> = tape.outputs().iter().map(|o| o.name.as_str()).collect();
    for (c, name) in names.iter().enumerate() {
        let tiled = name.contains("tiled");
        let differ: Vec<String> = (0..n)
            .filter(|&i| !tiled || set[i].iter().all(|v| v.abs() < 2f64.powi(51)))
            .filter(|&i| cpu[c * n + i].to_bits() != gpu_out[c * n + i].to_bits())
            .take(3)
            .map(|i| {
                format!(
                    "{:?}: CPU {} GPU {}",
                    set[i],
                    cpu[c * n + i],
                    gpu_out[c * n + i]
                )
            })
            .collect();
        assert!(differ.is_empty(), "{name}: {}", differ.join("; "));
    }
}

/// A graph whose outputs cross every edge the encodings have: below 0 and above 1, NaN, ±∞,
/// past half's largest finite value and into its subnormals, colours for the sRGB transfer.
const EDGES: &str = r#"Graph(
    nodes: {
        "p": Position,
    },
    outputs: {
        "linear": "p.x",
        "nan": Sqrt("p.x"),
        "inf": Div(a: 1.0, b: Floor("p.x")),
        "neg_inf": Log(Abs(Floor("p.y"))),
        "huge": Mul(a: "p.x", b: 70000.0),
        "tiny": Mul(a: "p.z", b: 0.00003),
        "colour": Combine(x: "p.x", y: "p.y", z: "p.z"),
    },
)"#;

/// The GPU packs each channel into the type its file stores (`pack.wgsl`) exactly as the CPU
/// encodes the GPU's own 32-bit results (`texgraph::encoding`): bit for bit, but for the sRGB
/// transfer (its `pow` may round otherwise on a GPU: at most one step of 255 or 65535) and
/// NaN's payload; each channel's statistics are the CPU's over the same values. Over several
/// windows (the double-buffered queue) of short segments (a row split in three, the last one
/// short: padded words).
#[test]
fn gpu_packs_what_the_files_store() {
    use texgraph::encoding::{Encoding, Packing};
    if !common::gpu_available("gpu_packs_what_the_files_store") {
        return;
    }
    let source = texgraph::diagnostic::SourceFile::new("edges.ron", EDGES);
    let graph = texgraph::check::check(source, &CheckOptions::default()).expect("checks");
    let tape = texgraph::compile::compile(&graph, &CompileOptions::default()).expect("compiles");
    let gpu = texgraph::gpu::evaluator_for(&tape).expect("compiles on the GPU");
    let grid = Grid {
        size: [257, 3, 4],
        region: Region {
            min: [-1.5, -1.5, -1.5],
            max: [1.5, 2.5, 1.5],
        },
    };
    let layout = texgraph::bake::Layout {
        segment_len: 100,
        per_row: 3,
        total: 3 * 3 * 4,
        per_window: 7,
    };
    let channels = tape.channels();
    let mut reference = vec![0f32; layout.total as usize * channels * 100];
    gpu.bake_window(&grid, &layout, 0, &mut reference)
        .expect("evaluates");
    let all = [
        Encoding::F32,
        Encoding::U8 { srgb: false },
        Encoding::U8 { srgb: true },
        Encoding::U16 { srgb: false },
        Encoding::U16 { srgb: true },
        Encoding::F16,
    ];
    // Every encoding for every channel, and one packing that mixes them.
    let mut packings: Vec<Vec<Encoding>> = all.iter().map(|&e| vec![e; channels]).collect();
    packings.push((0..channels).map(|c| all[c % all.len()]).collect());
    for encodings in packings {
        let packing = Packing::new(encodings.clone(), layout.segment_len);
        let mut bake = texgraph::gpu::GpuBake::new(gpu.clone(), &grid, &layout, packing.clone())
            .expect("a GPU bake");
        let mut bytes = Vec::new();
        let mut first = 0u64;
        let mut windows = Vec::new();
        bake.submit(0, layout.per_window).expect("submits");
        while first < layout.total {
            let count = (layout.total - first).min(layout.per_window as u64) as usize;
            let next = first + count as u64;
            if next < layout.total {
                let n = (layout.total - next).min(layout.per_window as u64) as usize;
                bake.submit(next, n).expect("submits");
            }
            let stats = bake.collect(&mut bytes).expect("collects");
            windows.push((first, count, bytes.clone(), stats));
            first = next;
        }
        for (c, &encoding) in encodings.iter().enumerate() {
            let size = encoding.bytes();
            let mut values = Vec::new();
            for (first, count, bytes, stats) in &windows {
                let mut counts = [0u64; 6];
                let (mut lo, mut hi, mut sum) = (f32::MAX, -f32::MAX, 0f64);
                for s in 0..*count {
                    let segment = layout.segment(&grid, first + s as u64);
                    let at = ((*first as usize + s) * channels + c) * 100;
                    let got = packing.channel(bytes, s, c, segment.len);
                    for (i, &v) in reference[at..at + segment.len].iter().enumerate() {
                        values.push(v);
                        let mut want = [0u8; 4];
                        encoding.encode(v, &mut want[..size]);
                        let got = &got[i * size..(i + 1) * size];
                        let same = match encoding {
                            Encoding::U8 { srgb: true } => got[0].abs_diff(want[0]) <= 1,
                            Encoding::U16 { srgb: true } => {
                                let g = u16::from_le_bytes([got[0], got[1]]);
                                g.abs_diff(u16::from_le_bytes([want[0], want[1]])) <= 1
                            }
                            Encoding::F16 if v.is_nan() => {
                                half::f16::from_le_bytes([got[0], got[1]]).is_nan()
                            }
                            Encoding::F32 if v.is_nan() => {
                                f32::from_le_bytes([got[0], got[1], got[2], got[3]]).is_nan()
                            }
                            _ => got == &want[..size],
                        };
                        assert!(same, "{encoding:?} of {v:e}: {got:?}, not {want:?}");
                        if v.is_nan() {
                            counts[0] += 1;
                        } else if v.is_infinite() {
                            counts[if v > 0.0 { 1 } else { 2 }] += 1;
                        } else {
                            counts[3] += 1;
                            (lo, hi, sum) = (lo.min(v), hi.max(v), sum + v as f64);
                        }
                        counts[4] += u64::from(v < 0.0);
                        counts[5] += u64::from(v > 1.0);
                    }
                }
                let w = &stats[c];
                let got = [w.nan, w.pos_inf, w.neg_inf, w.finite, w.below, w.above];
                assert_eq!(got, counts, "channel {c}'s counts");
                if counts[3] > 0 {
                    assert_eq!((w.min, w.max), (lo, hi), "channel {c}'s min and max");
                    assert!((w.sum - sum).abs() <= 1e-9 * sum.abs().max(1.0));
                }
            }
            assert_eq!(values.len(), 257 * 3 * 4);
        }
    }
}

/// `bake --device gpu` writes the files `--device cpu` writes in every format whose samples
/// the GPU packs (`pack.wgsl`): raw 8-bit with alpha, PNG slices of 8 bits and a 16-bit atlas,
/// 8-bit and half-float KTX2, half-float EXR; each sample within the GPU contract's 2e-5
/// after its encoding (one step of 8 bits, two of 16 bits, half's rounding).
#[test]
fn gpu_files_are_the_cpu_files() {
    if !common::gpu_available("gpu_files_are_the_cpu_files") {
        return;
    }
    let dir = tempfile::tempdir().expect("temporary folder");
    let cases: [&[&str]; 6] = [
        &["--format", "raw", "--raw-type", "u8", "--alpha"],
        &["--format", "png"],
        &["--format", "png", "--depth", "16", "--atlas"],
        &["--format", "ktx2"],
        &["--format", "ktx2", "--half"],
        &["--format", "exr", "--half"],
    ];
    for (n, flags) in cases.iter().enumerate() {
        let bake = |device: &str| {
            let out = dir.path().join(format!("{n}-{device}"));
            std::fs::create_dir(&out).unwrap();
            let run = std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
                .current_dir(common::crate_root())
                .args(["bake", "graphs/seed004_marble.ron", "--size", "19,7,5"])
                .args(*flags)
                .args(["--device", device, "-q", "--out"])
                .arg(&out)
                .output()
                .expect("runs");
            let said = String::from_utf8_lossy(&run.stderr);
            assert!(run.status.success(), "{flags:?} on the {device}: {said}");
            out
        };
        let (cpu, gpu) = (bake("cpu"), bake("gpu"));
        let files = files_under(&cpu);
        assert_eq!(files, files_under(&gpu), "{flags:?}: the same files");
        for file in files {
            let name = file.to_string_lossy().to_string();
            let (a, b) = (
                std::fs::read(cpu.join(&file)).unwrap(),
                std::fs::read(gpu.join(&file)).unwrap(),
            );
            // Each file's samples, and how far apart two may be (one step of 8 bits, two of
            // 16, half's rounding of 2e-5 relative).
            let (a, b, step): (Vec<f64>, Vec<f64>, f64) = if name.ends_with(".png") {
                let (a, b) = (
                    common::Png::decode(&a).unwrap(),
                    common::Png::decode(&b).unwrap(),
                );
                let values = |p: &common::Png| p.samples.iter().map(|&v| f64::from(v)).collect();
                (values(&a), values(&b), if a.bits == 16 { 2.0 } else { 1.0 })
            } else if name.ends_with(".ktx2") {
                // Uncompressed: the header and index alike, the texels at the end.
                assert_eq!(a.len(), b.len(), "{name}");
                let texels = 19 * 7 * 5 * if name.contains("colour") { 4 } else { 1 };
                if flags.contains(&"--half") {
                    let at = a.len() - 2 * texels;
                    assert_eq!(a[..at], b[..at], "{name}: the header");
                    let values = |v: &[u8]| {
                        v.chunks(2)
                            .map(|h| half::f16::from_le_bytes([h[0], h[1]]).to_f64())
                            .collect()
                    };
                    (values(&a[at..]), values(&b[at..]), 1e-3)
                } else {
                    let at = a.len() - texels;
                    assert_eq!(a[..at], b[..at], "{name}: the header");
                    let values = |v: &[u8]| v.iter().map(|&x| f64::from(x)).collect();
                    (values(&a[at..]), values(&b[at..]), 1.0)
                }
            } else if name.ends_with(".exr") {
                // The channels' halves as the exr crate reads them (the header's attributes
                // come in a hash map's order, which differs from run to run).
                let halves = |path: &std::path::Path| -> Vec<f64> {
                    let image = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
                    let mut values = Vec::new();
                    for channel in image.layer_data.channel_data.list {
                        match channel.sample_data {
                            exr::prelude::FlatSamples::F16(v) => {
                                values.extend(v.iter().map(|h| h.to_f64()))
                            }
                            other => panic!("{name}: {other:?}, not halves"),
                        }
                    }
                    values
                };
                (halves(&cpu.join(&file)), halves(&gpu.join(&file)), 1e-3)
            } else if name.ends_with(".raw") {
                let values = |v: &[u8]| v.iter().map(|&x| f64::from(x)).collect();
                (values(&a), values(&b), 1.0)
            } else {
                continue;
            };
            assert_eq!(a.len(), b.len(), "{name}");
            // Half floats relative to the value (beyond 1), integers in steps.
            let relative = step < 1.0;
            let worst = a
                .iter()
                .zip(&b)
                .map(|(x, y)| {
                    let steps = (x - y).abs() / step;
                    if relative {
                        steps / x.abs().max(1.0)
                    } else {
                        steps
                    }
                })
                .fold(0.0, f64::max);
            assert!(
                worst <= 1.0,
                "{flags:?} {name}: samples differ by {worst} steps"
            );
        }
    }
}

/// The files under `dir`, as paths relative to it, sorted.
fn files_under(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                found.push(path.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    found.sort();
    found
}

/// `--format zarr --device gpu`: each shard baked on the device as a grid of its own (its box)
/// and packed there into the array's sample type, then scattered into the shard: the store the
/// CPU writes, sample for sample (one step of 8 bits, half's rounding), edge shards clipped
/// (19 × 7 × 11 voxels in shards of 8), and the same statistics' counts.
#[test]
fn gpu_zarr_stores_are_the_cpu_stores() {
    use texgraph::bake::{bake_files, BakeFileOptions, Format, Ktx2SampleType};
    if !common::gpu_available("gpu_zarr_stores_are_the_cpu_stores") {
        return;
    }
    let path = common::crate_root().join("graphs/seed004_marble.ron");
    let tape = texgraph::load_tape(&path, &CheckOptions::default(), &CompileOptions::default())
        .expect("loads")
        .1;
    let grid = Grid {
        size: [19, 7, 11],
        region: Region {
            min: [-0.5, -1.0, -0.75],
            max: [1.5, 0.25, 0.5],
        },
    };
    for sample in [Ktx2SampleType::U8, Ktx2SampleType::F16] {
        let dir = tempfile::tempdir().unwrap();
        let bake = |device: Device| {
            let store = dir.path().join(format!("{device:?}.zarr"));
            let mut options = BakeFileOptions::new("marble", &store);
            options.bake.grid = grid;
            options.bake.device = device;
            options.format = Format::Zarr;
            options.ktx2_type = sample;
            options.zarr.chunk = 4;
            options.zarr.shard = 8;
            let report = bake_files(&tape, &options, &mut |_| {}).expect("bakes");
            (store, report)
        };
        let ((cpu, cpu_report), (gpu, gpu_report)) = (bake(Device::Cpu), bake(Device::Gpu));
        for (a, b) in cpu_report.stats.iter().zip(&gpu_report.stats) {
            for (x, y) in a.channels.iter().zip(&b.channels) {
                assert_eq!((x.finite(), x.non_finite()), (y.finite(), y.non_finite()));
                assert!((x.mean - y.mean).abs() <= 2e-5, "{sample:?} {}", a.name);
            }
        }
        for output in tape.outputs() {
            let read = |store: &std::path::Path| {
                let storage = std::sync::Arc::new(
                    zarrs::filesystem::FilesystemStore::new(store).expect("a store"),
                );
                let array = zarrs::array::Array::open(storage, &format!("/{}", output.name))
                    .expect("an array");
                let ranges: Vec<std::ops::Range<u64>> =
                    array.shape().iter().map(|&n| 0..n).collect();
                match sample {
                    Ktx2SampleType::U8 => array
                        .retrieve_array_subset::<Vec<u8>>(&ranges)
                        .expect("reads")
                        .into_iter()
                        .map(f64::from)
                        .collect::<Vec<f64>>(),
                    _ => array
                        .retrieve_array_subset::<Vec<half::f16>>(&ranges)
                        .expect("reads")
                        .into_iter()
                        .map(|h| h.to_f64())
                        .collect(),
                }
            };
            let (a, b) = (read(&cpu), read(&gpu));
            let voxels = 19 * 7 * 11 * output.ty.channels();
            assert!(a.len() == voxels && b.len() == voxels, "{}", output.name);
            for (x, y) in a.iter().zip(&b) {
                let close = match sample {
                    Ktx2SampleType::U8 => (x - y).abs() <= 1.0,
                    _ => (x - y).abs() <= 1e-3 * x.abs().max(1.0),
                };
                assert!(close, "{sample:?} {}: {x} against {y}", output.name);
            }
        }
    }
}
