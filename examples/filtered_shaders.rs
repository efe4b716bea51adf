//! The filtered form's shaders per graph (issue 49, docs/shaders.md): the size of the exported
//! WGSL with and without the `_filtered` functions, and with `--compile` the time the GPU takes
//! to compile the filtered form's bake pipeline (the first bake of a 4³ grid, which builds it;
//! the process's adapter, lavapipe on a machine without a GPU).
//!
//! ```sh
//! cargo run --release --example filtered_shaders                  # every graph: sizes
//! cargo run --release --example filtered_shaders -- --compile     # and compile times
//! cargo run --release --example filtered_shaders -- --compile graphs/library/planks.ron
//! ```

use std::path::PathBuf;
use std::time::Instant;
use texgraph::shader::{export, Lang, ShaderOptions};

#[path = "common/graphs.rs"]
mod graphs;

fn graphs(args: &[String]) -> Vec<PathBuf> {
    if args.is_empty() {
        return graphs::graph_files(std::path::Path::new(env!("CARGO_MANIFEST_DIR")));
    }
    args.iter().map(PathBuf::from).collect()
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let compile = args.iter().any(|a| a == "--compile");
    args.retain(|a| a != "--compile");
    if compile {
        match texgraph::gpu::usable() {
            Ok(adapter) => println!("adapter: {adapter}"),
            Err(e) => {
                eprintln!("no GPU adapter: {e}");
                std::process::exit(1);
            }
        }
    }
    println!("| graph | WGSL with `_filtered` | without | filtered pipeline compile |");
    println!("|---|---:|---:|---:|");
    for path in graphs(&args) {
        let name = path
            .file_stem()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string();
        let tape = match texgraph::load_tape(&path, &Default::default(), &Default::default()) {
            Ok((_, tape)) => tape,
            Err(e) => {
                println!("| {name} | {e} | | |");
                continue;
            }
        };
        let size = |filtered| {
            let options = ShaderOptions {
                lang: Lang::Wgsl,
                version: None,
                filtered,
            };
            match export(&tape, &options, None) {
                Ok(e) => format!("{:.1} kB", e.source.len() as f64 / 1000.0),
                Err(e) => e.to_string(),
            }
        };
        let time = if compile {
            let start = Instant::now();
            let grid = texgraph::grid::Grid::cube(4);
            match texgraph::gpu::filtered_evaluator_for(&tape)
                .and_then(|g| g.eval_grid(&grid, true))
            {
                Ok(()) => format!("{:.1} s", start.elapsed().as_secs_f64()),
                Err(e) => e.to_string(),
            }
        } else {
            "-".to_string()
        };
        println!("| {name} | {} | {} | {time} |", size(true), size(false));
    }
}
