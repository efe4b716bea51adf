//! The filtering table of docs/filtering.md: for every graph of `graphs/` and `graphs/library/`
//! and box sides 1/2, 1/8 and 1/32, the RMS error against a 216-sample stratified box mean
//! (f64) of point sampling (the box centre), of 4 and 16 samples per box (Latin hypercubes) and
//! of the filtered evaluation, over 100 random boxes in [−4, 4]³ (fixed seed), all channels —
//! `texgraph report --filtering` (`texgraph::filter_report`) over every graph, with the issue's
//! summary counts, and the rows the filtered form wins at equal time (its RMS at most that of
//! as many samples per box as fit in its measured time).
//!
//! ```sh
//! cargo run --release --example filtering_table [-- BOXES]
//! ```

use texgraph::filter_report::{filter_report, FilterOptions};
use texgraph::grid::Region;
use texgraph::{load_tape, CheckOptions, CompileOptions};

#[path = "common/graphs.rs"]
mod graphs;

fn main() {
    let boxes: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100);
    // Relative to the crate root, where it runs (the table names the files so).
    let files = graphs::graph_files(std::path::Path::new(""));
    let options = FilterOptions {
        boxes,
        region: Region {
            min: [-4.0; 3],
            max: [4.0; 3],
        },
        ..FilterOptions::default()
    };
    println!("| graph | side | point RMS | 4 samples RMS | 16 samples RMS | filtered RMS | filtered vs point | filtered vs 4 samples | filtered µs / point µs | equal-time samples RMS |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let (mut point_us, mut filtered_us, mut sixteen_us) = (0.0, 0.0, 0.0);
    let (mut beats4, mut beats16, mut beats_point, mut rows) = (0, 0, 0, 0);
    let mut wins_at_equal_time = 0;
    let mut losses = Vec::new();
    for path in &files {
        let Ok((_, tape)) = load_tape(path, &CheckOptions::default(), &CompileOptions::default())
        else {
            continue;
        };
        for row in filter_report(&tape, &options) {
            rows += 1;
            point_us += row.point_us;
            sixteen_us += row.samples16_us;
            filtered_us += row.filtered_us;
            beats4 += usize::from(row.filtered_rms <= row.samples4_rms || row.point_rms < 0.02);
            beats16 += usize::from(row.filtered_rms <= row.samples16_rms || row.point_rms < 0.02);
            beats_point += usize::from(row.filtered_rms <= 1.1 * row.point_rms + 0.005);
            wins_at_equal_time += usize::from(row.filtered_wins);
            if !row.filtered_wins {
                losses.push(format!(
                    "{} at 1/{}",
                    path.display(),
                    (1.0 / row.side).round()
                ));
            }
            println!(
                "| {} | 1/{} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2}× | {:.2}× | {:.1} | {:.4}{} |",
                path.display(),
                (1.0 / row.side).round(),
                row.point_rms,
                row.samples4_rms,
                row.samples16_rms,
                row.filtered_rms,
                row.point_rms / row.filtered_rms.max(1e-12),
                row.samples4_rms / row.filtered_rms.max(1e-12),
                row.filtered_us / row.point_us.max(1e-9),
                row.equal_rms,
                if row.filtered_wins {
                    ""
                } else {
                    " (samples win)"
                },
            );
        }
    }
    println!();
    println!(
        "{rows} rows: filtered ≤ 4 samples (where point RMS ≥ 0.02) in {beats4}, ≤ 16 samples in {beats16}; never worse than point (≤ 1.1× + 0.005) in {beats_point}."
    );
    println!(
        "At equal time (as many Latin-hypercube samples per box as fit in the filtered form's time, 1 to 216): the filtered form wins {wins_at_equal_time} of {rows} rows."
    );
    if !losses.is_empty() {
        println!("Samples win at equal time: {}.", losses.join(", "));
    }
    println!(
        "Time per box (this run, one thread, f64, mean over rows): point {:.2} µs, 16 samples {:.2} µs, filtered {:.2} µs ({:.1}× point).",
        point_us / rows as f64,
        sixteen_us / rows as f64,
        filtered_us / rows as f64,
        filtered_us / point_us
    );
}
