//! The Rust batch API's time on a file of points, for `python/bench.py`: the graph's tape
//! evaluated by one `Tape::eval_batch` call over all the points (x, y and z slices in, a planar
//! output of every point out) on one thread, median of `RUNS` runs.
//!
//! Run: `cargo run --release --example batch_time -- GRAPH POINTS.f64 [RUNS]` where the points
//! file holds N × 3 little-endian f64 (x, y, z per point). Prints `median_s N`.

use std::time::Instant;
use texgraph::{load_tape, CheckOptions, CompileOptions, Workspace};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let [_, graph, points, rest @ ..] = &args[..] else {
        return Err("usage: batch_time GRAPH POINTS.f64 [RUNS]".into());
    };
    let runs: usize = rest.first().map_or(Ok(15), |r| r.parse())?;
    let (_, tape) = load_tape(
        graph.as_ref(),
        &CheckOptions::default(),
        &CompileOptions::default(),
    )?;
    let bytes = std::fs::read(points)?;
    let coords: Vec<f64> = bytes
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
        .collect();
    let n = coords.len() / 3;
    let axis = |a: usize| -> Vec<f64> { coords.iter().skip(a).step_by(3).copied().collect() };
    let (x, y, z) = (axis(0), axis(1), axis(2));
    let mut workspace = Workspace::<f32>::new();
    // The whole batch in one call, into a planar output of every point (preallocated and
    // written once before timing, as `Graph.eval(..., out=...)` is given arrays).
    let mut out = vec![0f32; tape.channels() * n];
    tape.eval_batch(&mut workspace, &x, &y, &z, &mut out);
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let started = Instant::now();
        tape.eval_batch(&mut workspace, &x, &y, &z, &mut out);
        times.push(started.elapsed().as_secs_f64());
        std::hint::black_box(&out);
    }
    times.sort_by(f64::total_cmp);
    println!("{} {n}", times[runs / 2]);
    Ok(())
}
