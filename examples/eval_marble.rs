//! Evaluate the seed 003 marble from Rust: load, check and compile a graph file once, then
//! evaluate it per point (a ray hit) and per batch (a row of voxels).
//!
//! Run: `cargo run --release --example eval_marble`

use texgraph::{load_tape, CheckOptions, CompileOptions, Workspace};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (graph, tape) = load_tape(
        "graphs/seed003_marble.ron".as_ref(),
        &CheckOptions {
            overrides: vec![("octaves".into(), 8.0)],
        },
        &CompileOptions::default(),
    )?;
    println!(
        "{} compiled to {} instructions",
        graph.file().name,
        tape.instructions().len()
    );

    // Per point: the outputs' channels in order (colour r g b, then vein).
    let mut workspace = Workspace::<f32>::new();
    let mut out = vec![0.0f32; tape.channels()];
    tape.eval_point(&mut workspace, [0.25, 0.5, 0.75], &mut out);
    println!("at (0.25, 0.5, 0.75): {out:?}");

    // Per batch: one row of 16 voxel centres along x; the output is planar (channel-major).
    let n = 16;
    let x: Vec<f64> = (0..n).map(|i| (i as f64 + 0.5) / n as f64).collect();
    let (y, z) = (vec![0.5; n], vec![0.5; n]);
    let mut row = vec![0.0f32; tape.channels() * n];
    tape.eval_batch(&mut workspace, &x, &y, &z, &mut row);
    let vein = tape
        .output("vein")
        .expect("the marble has a vein output")
        .first_channel;
    println!("vein along x: {:?}", &row[vein * n..(vein + 1) * n]);
    Ok(())
}
