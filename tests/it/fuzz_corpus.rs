//! Replays the fuzz corpus on stable Rust: every input that cargo-fuzz kept as interesting
//! (`fuzz/corpus/<target>/`) and every input that once crashed (`fuzz/regressions/<target>/`)
//! goes through the same harness as the fuzz targets (`fuzz/src/lib.rs`, compiled here by path),
//! so CI checks the invariants on all of them without nightly or libFuzzer.

use crate::harness;

use std::path::Path;

/// Runs `target` on every file of `fuzz/corpus/<name>` and `fuzz/regressions/<name>`; returns
/// how many there were.
fn replay(name: &str, target: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut count = 0;
    for dir in ["corpus", "regressions"] {
        let dir = root.join(dir).join(name);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut paths: Vec<_> = entries
            .map(|e| e.expect("readable corpus").path())
            .collect();
        paths.sort();
        for path in paths {
            let data = std::fs::read(&path).expect("readable corpus file");
            let outcome = std::panic::catch_unwind(|| target(&data));
            assert!(
                outcome.is_ok(),
                "{name}: {} fails the harness",
                path.display()
            );
            count += 1;
        }
    }
    count
}

#[test]
fn graph_bytes_corpus_replays() {
    let count = replay("graph_bytes", harness::graph_bytes);
    assert!(
        count >= 50,
        "only {count} graph_bytes inputs: is fuzz/corpus missing?"
    );
}

#[test]
fn structured_graph_corpus_replays() {
    let count = replay("structured_graph", harness::structured_graph);
    assert!(
        count >= 50,
        "only {count} structured_graph inputs: is fuzz/corpus missing?"
    );
}

#[test]
fn scene_bytes_corpus_replays() {
    let count = replay("scene_bytes", harness::scene_bytes);
    assert!(
        count >= 20,
        "only {count} scene_bytes inputs: is fuzz/corpus missing?"
    );
}

use crate::common;

/// The fuzz harness's structured generator reaches every node kind of the catalogue: a kind
/// added without a fuzz case fails here.
#[test]
fn the_fuzz_generator_reaches_every_node_kind() {
    let mut found = std::collections::BTreeSet::new();
    let mut state = 0x5EEDu64;
    for _ in 0..3000 {
        let bytes: Vec<u8> = (0..512)
            .map(|_| {
                // SplitMix64, one byte of each output.
                state = state.wrapping_add(0x9E3779B97F4A7C15);
                let mut z = state;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
                (z ^ (z >> 31)) as u8
            })
            .collect();
        let mut u = arbitrary::Unstructured::new(&bytes);
        if let Some(text) = harness::random_graph_text(&mut u) {
            found.extend(common::kinds_used(&text));
        }
    }
    assert_eq!(
        common::kinds_missing(&found),
        Vec::<&str>::new(),
        "node kinds the fuzz harness's generator never produces"
    );
}
