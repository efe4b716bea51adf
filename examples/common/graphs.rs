//! The graph files the examples measure: every `.ron` of `graphs/` and `graphs/library/`
//! under `root`, sorted (shared by the examples through `#[path]`; not an example itself).

use std::path::{Path, PathBuf};

pub fn graph_files(root: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in ["graphs", "graphs/library"] {
        let entries = std::fs::read_dir(root.join(dir)).expect("the graphs folder");
        for entry in entries {
            let path = entry.expect("entry").path();
            if path.extension().is_some_and(|e| e == "ron") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}
