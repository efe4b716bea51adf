//! Bake benchmarks (criterion): `bake/marble_128/threads_N` bakes the seed 003 marble (its
//! defaults: 12 octaves, both outputs) over 128³ voxels into memory-free sinks with 1 and 2
//! worker threads, so the ratio of the two is the parallel scaling; `bake/marble_128_png` writes
//! the PNG slices as `texgraph bake --format png` does.
//!
//! `bake/threads/{raw,png}_256/threads_N` bake the same marble over 256³ voxels to files through
//! `bake_files` (what `texgraph bake --format raw|png --size 256 --threads N` runs), on 1 and 2
//! threads: evaluation overlapped with encoding and writing, end to end, so the ratio of the two
//! is the scaling a user sees (docs/performance.md). Flat sampling, 10 runs each: about a
//! minute for the group.
//!
//! `bake/texture_set/knot_2048` bakes the same marble into the UV layout of
//! `examples/meshes/knot.glb` (10 000 triangles) at 2048² texels, as `texgraph bake --mesh
//! examples/meshes/knot.glb --size 2048` does before encoding (rasterisation, evaluation,
//! padding), on 2 threads; `bake/texture_set/volume_same_points` bakes a volume of as many voxels
//! as the knot covers texels: the ratio is the texture set's overhead (issue 48: ≤ 1.5×).
//!
//! Run: `cargo bench --bench bake`.

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use std::time::Duration;
use texgraph::bake::{
    bake_files, bake_into, BakeError, BakeFileOptions, BakeOptions, Format, Grid, Precision, Sink,
    Window,
};
use texgraph::{CheckOptions, CompileOptions};

/// Receives windows and keeps nothing: measures evaluation and the engine alone.
struct Discard;

impl Sink for Discard {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        std::hint::black_box(window.segments);
        Ok(())
    }
}

fn benches(c: &mut Criterion) {
    let (_, tape) = texgraph::load_tape(
        "graphs/seed003_marble.ron".as_ref(),
        &CheckOptions::default(),
        &CompileOptions::default(),
    )
    .expect("run from the crate root");
    let grid = Grid::cube(128);
    let mut group = c.benchmark_group("bake");
    group.throughput(Throughput::Elements(grid.voxels().unwrap_or(0)));
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(12))
        .warm_up_time(Duration::from_secs(2));
    for threads in [1usize, 2] {
        let options = BakeOptions {
            grid,
            threads,
            precision: Precision::F32,
            cancel: None,
            device: Default::default(),
            filter: Default::default(),
            replay: None,
        };
        group.bench_function(format!("marble_128/threads_{threads}"), |b| {
            b.iter(|| bake_into(&tape, &options, &mut Discard, &mut |_| {}).expect("bakes"))
        });
    }
    let out = tempfile::tempdir().expect("temp dir");
    group.bench_function("marble_128_png/threads_2", |b| {
        b.iter(|| {
            let mut options = BakeFileOptions::new("marble", out.path());
            options.bake = BakeOptions {
                grid,
                threads: 2,
                precision: Precision::F32,
                cancel: None,
                device: Default::default(),
                filter: Default::default(),
                replay: None,
            };
            options.force = true;
            bake_files(&tape, &options, &mut |_| {}).expect("bakes")
        })
    });
    group.finish();
    threads(c, &tape);
    texture_set(c, &tape);
}

/// The marble into the knot's UV layout at 2048², against a volume of as many points.
fn texture_set(c: &mut Criterion, tape: &texgraph::Tape) {
    use texgraph::mesh::{bake_texture_set, load_model, raster::rasterize, MeshBakeOptions, Space};
    let model = load_model("examples/meshes/knot.glb".as_ref(), Space::Object).expect("the knot");
    let size = 2048;
    let covered = rasterize(&model, size, size).hits.len();
    let grid = Grid {
        size: [size, covered.div_ceil(size), 1],
        region: Default::default(),
    };
    let mut group = c.benchmark_group("bake/texture_set");
    group.throughput(Throughput::Elements(covered as u64));
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(1));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("threads");
    let options = MeshBakeOptions {
        width: size,
        height: size,
        ..Default::default()
    };
    group.bench_function("knot_2048", |b| {
        b.iter(|| {
            pool.install(|| bake_texture_set(tape, None, &model, &options, None).expect("bakes"))
        })
    });
    let options = BakeOptions {
        grid,
        threads: 2,
        precision: Precision::F32,
        cancel: None,
        device: Default::default(),
        filter: Default::default(),
        replay: None,
    };
    group.bench_function("volume_same_points", |b| {
        b.iter(|| bake_into(tape, &options, &mut Discard, &mut |_| {}).expect("bakes"))
    });
    group.finish();
}

/// The 256³ marble to raw and PNG files on 1 and 2 threads, end to end.
fn threads(c: &mut Criterion, tape: &texgraph::Tape) {
    let grid = Grid::cube(256);
    let mut group = c.benchmark_group("bake/threads");
    group.throughput(Throughput::Elements(grid.voxels().unwrap_or(0)));
    group
        .sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .warm_up_time(Duration::from_secs(1));
    let out = tempfile::tempdir().expect("temp dir");
    for (name, format) in [("raw", Format::Raw), ("png", Format::Png)] {
        for threads in [1usize, 2] {
            let mut options = BakeFileOptions::new("marble", out.path());
            options.format = format;
            options.force = true;
            options.bake = BakeOptions {
                grid,
                threads,
                precision: Precision::F32,
                cancel: None,
                device: Default::default(),
                filter: Default::default(),
                replay: None,
            };
            group.bench_function(format!("{name}_256/threads_{threads}"), |b| {
                b.iter(|| bake_files(tape, &options, &mut |_| {}).expect("bakes"))
            });
        }
    }
    group.finish();
}

criterion_group!(bake, benches);
criterion_main!(bake);
