//! Generated WGSL per tape against the WGSL tape interpreter (issue 19: "measure both on a
//! small graph and a large one and choose"): for the seed 003 marble (8 octaves, 10
//! instructions) and library/lava (the largest graph of the library), the time to make the
//! pipelines and the median time of the kernel over an N³ grid, results kept on the GPU.
//!
//! ```sh
//! cargo run --release --example gpu_strategies [-- N RUNS]   # defaults: 64, 5
//! ```

use std::time::{Duration, Instant};
use texgraph::bake::Grid;
use texgraph::gpu::GpuEvaluator;

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn main() {
    let args: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (n, runs) = (
        args.first().copied().unwrap_or(64),
        args.get(1).copied().unwrap_or(5),
    );
    let name = match texgraph::gpu::usable() {
        Ok(name) => name,
        Err(e) => {
            eprintln!("SKIPPED: {e}");
            return;
        }
    };
    println!("adapter: {name}; grid {n}³, median of {runs} runs\n");
    println!("| graph | instructions | strategy | pipelines made in | kernel | Mvoxels/s |");
    println!("|---|---:|---|---:|---:|---:|");
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    for (file, overrides) in [
        (
            "graphs/seed003_marble.ron",
            vec![("octaves".to_string(), 8.0)],
        ),
        ("graphs/library/lava.ron", vec![]),
    ] {
        let check = texgraph::CheckOptions { overrides };
        let (_, tape) = texgraph::load_tape(
            &root.join(file),
            &check,
            &texgraph::CompileOptions::default(),
        )
        .expect("graph");
        let grid = Grid::cube(n);
        type Make = fn(&texgraph::Tape) -> Result<GpuEvaluator, texgraph::gpu::GpuError>;
        let strategies: [(&str, Make); 2] = [
            ("generated", GpuEvaluator::new),
            ("interpreter", GpuEvaluator::new_interpreted),
        ];
        for (strategy, make) in strategies {
            let started = Instant::now();
            let gpu = make(&tape).expect("compiles");
            let made = started.elapsed();
            gpu.eval_grid(&grid, true).expect("runs");
            let times: Vec<Duration> = (0..runs)
                .map(|_| {
                    let t = Instant::now();
                    gpu.eval_grid(&grid, true).expect("runs");
                    t.elapsed()
                })
                .collect();
            let kernel = median(times);
            println!(
                "| {file} | {} | {strategy} | {:.2} s | {:.1} ms | {:.2} |",
                tape.instructions().len(),
                made.as_secs_f64(),
                kernel.as_secs_f64() * 1e3,
                (n * n * n) as f64 / kernel.as_secs_f64() / 1e6
            );
        }
    }
}
