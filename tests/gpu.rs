//! The GPU path (issue 19) against the f64 reference: every graph of `graphs/` at points near
#![cfg(feature = "gpu")]
//! the origin, at |p| up to 1e4 and at |p| near 2^31, within the contract of
//! `common::gpu_contract`; bakes on the GPU against bakes on the CPU; every generated shader
//! validated by naga (that test needs no GPU). On a machine without any adapter the GPU tests
//! print `SKIPPED` (CI installs Mesa's lavapipe and requires one).

mod common;

use texgraph::bake::{bake_volume, BakeOptions, Grid, Region};
use texgraph::gpu::{Device, GpuEvaluator};
use texgraph::{CheckOptions, CompileOptions, Extent};

/// `n` points, each coordinate `centre + uniform(-r, r)` (a fixed LCG: reproducible).
fn points(n: usize, centre: f64, r: f64, seed: u64) -> Vec<[f64; 3]> {
    let mut state = seed;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
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

/// Every graph: 1500 points in [-10, 10]³ and 500 in [-1e4, 1e4]³, the tape compiled for
/// their extent (as a bake compiles for its region).
#[test]
fn every_graph_meets_the_gpu_contract() {
    if !common::gpu_available("every_graph_meets_the_gpu_contract") {
        return;
    }
    let mut set = points(1500, 0.0, 10.0, 1);
    set.extend(points(500, 0.0, 1e4, 2));
    let mut failures = Vec::new();
    for path in common::graph_files() {
        let tape = compile_for(&path, &set);
        let gpu = GpuEvaluator::new(&tape).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        match common::gpu_contract(&tape, &gpu, &set) {
            Ok(figures) => eprintln!("{}: {figures:.1?}", path.display()),
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
            eprintln!("{name} near {centre}: {figures:.1?}");
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
        let shader = texgraph::gpu::codegen::generate(&tape);
        if let Err(e) = texgraph::gpu::validate(&shader.source) {
            panic!("{}: {e}", path.display());
        }
    }
}
