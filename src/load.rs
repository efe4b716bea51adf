//! Convenience entry points: read a graph file from disk, check it and compile it.

use crate::check::{check, CheckOptions};
use crate::compile::{compile, CompileOptions};
use crate::diagnostic::{Diagnostics, SourceFile};
use crate::graph::CheckedGraph;
use crate::limits;
use crate::tape::Tape;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why a graph file could not be turned into a tape.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read (exit code 2).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The graph is invalid (exit code 1); every problem found is listed.
    #[error("{0}")]
    Invalid(Diagnostics),
}

/// Reads a graph file as UTF-8, refusing files over [`limits::MAX_FILE_BYTES`] before reading
/// them whole.
pub fn read_source(path: &Path) -> Result<Arc<SourceFile>, LoadError> {
    let io = |source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    file.take(limits::MAX_FILE_BYTES as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() > limits::MAX_FILE_BYTES {
        // An oversized graph is invalid input (exit 1), like any other limit.
        let file = SourceFile::new(path.display().to_string(), String::new());
        let diagnostic = crate::diagnostic::Diagnostic::new(
            crate::diagnostic::DiagnosticClass::Limit,
            format!(
                "the file is larger than {} bytes, the limit for graph files",
                limits::MAX_FILE_BYTES
            ),
        );
        return Err(LoadError::Invalid(Diagnostics {
            file,
            list: vec![diagnostic],
        }));
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text: {e}"),
        ))
    })?;
    Ok(SourceFile::new(path.display().to_string(), text))
}

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
