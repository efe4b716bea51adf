//! Level of detail and box filtering per pixel on a plane to the horizon
//! (`graphs/scenes/horizon.ron`): the scene at one sample per pixel with point samples (with
//! and without level of detail) and box-filtered, and at four point samples per pixel, each
//! against a many-sample reference without level of detail, and at as many point samples per
//! pixel as fit in the box-filtered render's texture time (equal time); prints the RMS errors,
//! the texture times (median of several renders) and their ratios.
//!
//! ```text
//! cargo run --release --example horizon_lod [-- REFERENCE_SAMPLES [RUNS [THREADS]]]
//! ```

use std::path::Path;
use texgraph::render::lod_figures::{compare_lod, LodComparison};

fn main() {
    let arg = |i: usize| {
        std::env::args()
            .nth(i)
            .and_then(|a| a.parse::<usize>().ok())
    };
    let scene_path = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/scenes/horizon.ron");
    let scene = texgraph::render::load_scene(Path::new(scene_path)).unwrap_or_else(|e| {
        eprint!("{}", e.render(false));
        std::process::exit(1)
    });
    let comparison = LodComparison {
        size: scene.size().unwrap_or((480, 270)),
        reference_samples: arg(1).unwrap_or(256) as u32,
        runs: arg(2).unwrap_or(9),
        threads: Some(arg(3).unwrap_or(1)),
        bias: 0.0,
    };
    let f = compare_lod(&scene, &comparison).unwrap_or_else(|e| {
        eprint!("{}", e.render(false));
        std::process::exit(1)
    });
    let (w, h) = comparison.size;
    println!(
        "horizon.ron {w}×{h}, reference {} samples per pixel without LOD ({:.2} s), {} thread(s), median of {} renders",
        comparison.reference_samples,
        f.reference_seconds,
        comparison.threads.unwrap_or(1),
        comparison.runs
    );
    println!("| 1 sample per pixel | RMS error vs reference | texture time |");
    println!("|---|---|---|");
    println!(
        "| without LOD | {:.5} | {:.2} ms |",
        f.rms_plain,
        f.texture_seconds_plain * 1e3
    );
    println!(
        "| with LOD | {:.5} | {:.2} ms |",
        f.rms_lod,
        f.texture_seconds_lod * 1e3
    );
    println!(
        "| box-filtered | {:.5} | {:.2} ms |",
        f.rms_filtered,
        f.texture_seconds_filtered * 1e3
    );
    println!(
        "| 4 samples per pixel, point with LOD | {:.5} | {:.2} ms |",
        f.rms_four,
        f.texture_seconds_four * 1e3
    );
    println!(
        "| {} samples per pixel, point with LOD (equal time: as many as fit in the box-filtered time) | {:.5} | {:.2} ms |",
        f.equal_samples,
        f.rms_equal,
        f.texture_seconds_equal * 1e3
    );
    println!(
        "| ratio (with LOD / without) | {:.3}× | {:.3}× |",
        f.error_ratio(),
        f.time_ratio()
    );
    println!(
        "median of the {} pairwise texture-time ratios: {:.3}×",
        comparison.runs, f.pair_time_ratio
    );
    println!(
        "at equal texture time: {} (box-filtered {:.5} vs {} point samples {:.5})",
        if f.filtered_wins_at_equal_time() {
            "the box filter wins"
        } else {
            "point samples win"
        },
        f.rms_filtered,
        f.equal_samples,
        f.rms_equal
    );
}
