//! Bake a seed graph to a raw volume from Rust, the way a renderer fills a 3D texture
//! (`glTexImage3D(GL_TEXTURE_3D, 0, GL_RGB8, 64, 64, 64, 0, GL_RGB, GL_UNSIGNED_BYTE, data)`).
//!
//! Run: `cargo run --release --example bake_raw` (writes baked/example/seed003_marble.colour.raw
//! and its .json sidecar), or keep the volume in memory with `bake_volume`.

use texgraph::bake::{bake_files, bake_volume, BakeFileOptions, BakeOptions, Format, Grid};
use texgraph::{load_tape, CheckOptions, CompileOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let compile = CompileOptions {
        outputs: vec!["colour".into()],
        ..Default::default()
    };
    let (_graph, tape) = load_tape(
        "graphs/seed003_marble.ron".as_ref(),
        &CheckOptions::default(),
        &compile,
    )?;

    // In memory: interleaved RGB f32, x fastest, then y, then z.
    let bake = BakeOptions {
        grid: Grid::cube(64),
        ..BakeOptions::default()
    };
    let volume = bake_volume(&tape, &bake)?;
    let colour = &volume.outputs[0];
    println!(
        "voxel (10, 20, 30) = {:?}",
        (0..3)
            .map(|c| colour.get(&volume.grid, 10, 20, 30, c))
            .collect::<Vec<_>>()
    );

    // To a file: u8 RGB with an sRGB transfer, plus a JSON sidecar describing the layout.
    let mut options = BakeFileOptions::new("seed003_marble", "baked/example");
    options.bake = bake;
    options.format = Format::Raw;
    options.force = true;
    let report = bake_files(&tape, &options, &mut |_| {})?;
    for file in &report.files {
        println!(
            "{} -> {} ({})",
            file.output,
            file.path.display(),
            file.description
        );
    }
    println!("{} voxels in {:.3} s", report.voxels, report.seconds);
    Ok(())
}
