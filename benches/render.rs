//! `render/horizon/{lod,no_lod}`: `graphs/scenes/horizon.ron` (a turbulent floor to the
//! horizon) at 480×270, 1 sample per pixel, one thread, with and without level of detail per
//! pixel — the whole render (tracing, texture evaluation, shading). The texture time alone and
//! the error against a many-sample reference: `cargo run --release --example horizon_lod`.
//!
//! Run: `cargo bench --bench render`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;
use texgraph::render::{load_scene, render, RenderLod, RenderOptions};

fn horizon(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/scenes/horizon.ron");
    let scene = load_scene(&path).expect("the horizon scene loads");
    let mut group = c.benchmark_group("render/horizon");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(5))
        .warm_up_time(Duration::from_secs(1));
    for (name, lod) in [("lod", RenderLod::default()), ("no_lod", RenderLod::Off)] {
        let options = RenderOptions {
            size: Some((480, 270)),
            samples: Some(1),
            threads: Some(1),
            lod,
            ..Default::default()
        };
        group.bench_function(name, |b| {
            b.iter(|| black_box(render(&scene, &options).expect("renders")))
        });
    }
    group.finish();
}

criterion_group!(benches, horizon);
criterion_main!(benches);
