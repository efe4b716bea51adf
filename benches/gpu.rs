//! GPU benchmarks (issue 19): `gpu/marble_512` (the seed 003 marble with 8 octaves over a 512³
//! grid, results kept on the GPU, read back as floats, and read back as a bake of 8-bit files
//! does, `read_back_u8`), `gpu/marble_filtered_256` (its filtered
//! form, issue 33, over a 256³ grid), `gpu/bake_1024` (the command-line
//! bake of a 1024³ raw file, end to end) and `bake_vs_write` (issue 49: a `--device gpu` bake
//! of 8-bit files end to end, `*/gpu`, against writing the same files from the same voxels in
//! memory, `*/write`: the bake's floor; their ratio is the cost of evaluating on the device,
//! packing and reading back, which the double-buffered read-back hides behind the writing). Without an adapter they print why and measure
//! nothing. `TEXGRAPH_GPU_BENCH_SIZE=N` shrinks both grids to N³ (for a software adapter such
//! as lavapipe, where 512³ takes minutes per sample); the benchmark names keep the full sizes
//! only when the sizes are the full ones.

use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use texgraph::bake::Grid;

fn size(full: usize) -> usize {
    std::env::var("TEXGRAPH_GPU_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(full)
}

fn marble() -> texgraph::Tape {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let check = texgraph::CheckOptions {
        overrides: vec![("octaves".into(), 8.0)],
    };
    texgraph::load_tape(
        &root.join("graphs/seed003_marble.ron"),
        &check,
        &texgraph::CompileOptions::default(),
    )
    .expect("the seed 003 marble")
    .1
}

fn bench_gpu(c: &mut Criterion) {
    let adapter = match texgraph::gpu::usable() {
        Ok(name) => name,
        Err(e) => {
            eprintln!("SKIPPED gpu benches: {e}");
            return;
        }
    };
    eprintln!("gpu benches on {adapter}");
    let tape = marble();
    let gpu = texgraph::gpu::evaluator_for(&tape).expect("the marble compiles on the GPU");
    let n = size(512);
    let grid = Grid::cube(n);
    let mut group = c.benchmark_group("gpu");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20));
    group.bench_function(format!("marble_{n}/kernel"), |b| {
        b.iter(|| gpu.eval_grid(&grid, true).expect("evaluates"))
    });
    // From here on each iteration takes tenths of a second to seconds (a read-back of 512 MiB
    // on a card, of 32 MiB through llvmpipe): flat sampling runs each of the 10 samples about
    // equally often instead of criterion's linear 1 + 2 + … + 10 (55 iterations at least),
    // which made `read_back` alone take 90 s of a lent card's time.
    group.sampling_mode(criterion::SamplingMode::Flat);
    group.bench_function(format!("marble_{n}/read_back"), |b| {
        b.iter(|| gpu.eval_grid(&grid, false).expect("evaluates"))
    });
    // What a bake of 8-bit files reads back (issue 49): the same kernel, each value packed to
    // 8 bits on the device with its statistics, windows of 4 Mi voxels double-buffered.
    let layout = texgraph::bake::Layout::new(&grid, gpu.channels(), 32).expect("a layout");
    group.bench_function(format!("marble_{n}/read_back_u8"), |b| {
        b.iter(|| read_back_packed(&gpu, &grid, &layout))
    });
    // The filtered form (`--filter box`): each voxel the estimate of its cell's mean, on a
    // 256³ grid (the rules run in f64), results kept on the GPU.
    let filtered =
        texgraph::gpu::filtered_evaluator_for(&tape).expect("the marble's filtered form compiles");
    let n = size(256);
    let small = Grid::cube(n);
    group.bench_function(format!("marble_filtered_{n}/kernel"), |b| {
        b.iter(|| filtered.eval_grid(&small, true).expect("evaluates"))
    });
    // A 1024³ bake takes seconds: with flat sampling (above) each of the 10 samples runs once.
    let n = size(1024);
    let out = std::env::temp_dir().join(format!("texgraph-gpu-bench-{}", std::process::id()));
    let exe = env!("CARGO_BIN_EXE_texgraph");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let graph = root.join("graphs/seed003_marble.ron");
    group.bench_function(format!("bake_{n}"), |b| {
        b.iter(|| {
            let status = std::process::Command::new(exe)
                .args([
                    "bake",
                    "--device",
                    "gpu",
                    "--format",
                    "raw",
                    "--raw-type",
                    "f32",
                ])
                .arg("--size")
                .arg(n.to_string())
                .args(["--set", "octaves=8", "--force", "-q", "--out"])
                .arg(&out)
                .arg(&graph)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .status()
                .expect("runs texgraph");
            assert!(status.success());
        })
    });
    group.finish();
    let _ = std::fs::remove_dir_all(&out);
}

/// `bake_vs_write/{graph}_{format}_{n}/{gpu,write}`: the bake on the GPU, and the same files
/// written from the volume it bakes (`BakeOptions::replay`), all cores both; 256³ (PNG slices
/// and raw 8-bit; `TEXGRAPH_GPU_BENCH_SIZE` shrinks it), the marble and a single-octave noise.
fn bench_bake_vs_write(c: &mut Criterion) {
    if let Err(e) = texgraph::gpu::usable() {
        eprintln!("SKIPPED bake_vs_write: {e}");
        return;
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let n = size(256);
    let grid = Grid::cube(n);
    let mut group = c.benchmark_group("bake_vs_write");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    let out = std::env::temp_dir().join(format!("texgraph-bake-vs-write-{}", std::process::id()));
    for (name, graph) in [
        ("marble", "graphs/seed003_marble.ron"),
        ("noise", "graphs/seed002_noise.ron"),
    ] {
        let tape = texgraph::load_tape(
            &root.join(graph),
            &texgraph::CheckOptions::default(),
            &texgraph::CompileOptions::default(),
        )
        .expect("loads")
        .1;
        let gpu = texgraph::bake::BakeOptions {
            grid,
            device: texgraph::gpu::Device::Gpu,
            ..Default::default()
        };
        let volume = std::sync::Arc::new(texgraph::bake::bake_volume(&tape, &gpu).expect("bakes"));
        let write = texgraph::bake::BakeOptions {
            replay: Some(volume),
            ..Default::default()
        };
        for format in [texgraph::bake::Format::Png, texgraph::bake::Format::Raw] {
            let label = format!("{name}_{format:?}_{n}").to_lowercase();
            for (side, bake) in [("gpu", &gpu), ("write", &write)] {
                let mut options = texgraph::bake::BakeFileOptions::new(name, &out);
                options.bake = texgraph::bake::BakeOptions {
                    grid,
                    ..bake.clone()
                };
                options.format = format;
                options.force = true;
                group.bench_function(format!("{label}/{side}"), |b| {
                    b.iter(|| {
                        texgraph::bake::bake_files(&tape, &options, &mut |_| {}).expect("bakes")
                    })
                });
            }
        }
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&out);
}

/// The whole grid through [`texgraph::gpu::GpuBake`] as 8-bit samples: one window queued
/// ahead of the one copied out, as `bake_into` runs it.
fn read_back_packed(
    gpu: &std::sync::Arc<texgraph::gpu::GpuEvaluator>,
    grid: &Grid,
    layout: &texgraph::bake::Layout,
) {
    use texgraph::encoding::{Encoding, Packing};
    let packing = Packing::new(
        vec![Encoding::U8 { srgb: false }; gpu.channels()],
        layout.segment_len,
    );
    let mut bake =
        texgraph::gpu::GpuBake::new(gpu.clone(), grid, layout, packing).expect("a GPU bake");
    bake.for_each_window(|_, _, _, _| {}).expect("reads back");
}

criterion_group!(benches, bench_gpu, bench_bake_vs_write);
criterion_main!(benches);
