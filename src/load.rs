//! Convenience entry points: read a graph file from disk, check it and compile it.

use crate::check::{check, CheckOptions};
use crate::compile::{compile, CompileOptions};
use crate::graph::CheckedGraph;
pub use crate::source::{read_source, LoadError};
use crate::tape::Tape;
use std::path::Path;

/// Reads and checks a graph file.
pub fn load_graph(path: &Path, options: &CheckOptions) -> Result<CheckedGraph, LoadError> {
    let file = read_source(path)?;
    check(file, options).map_err(LoadError::Invalid)
}

/// Reads, checks and compiles a graph file.
pub fn load_tape(
    path: &Path,
    check_options: &CheckOptions,
    compile_options: &CompileOptions,
) -> Result<(CheckedGraph, Tape), LoadError> {
    let graph = load_graph(path, check_options)?;
    let tape = compile(&graph, compile_options).map_err(LoadError::Invalid)?;
    Ok((graph, tape))
}
