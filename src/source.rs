//! Reading a graph or scene file into a [`SourceFile`]: the size limit checked before the
//! file is read whole, UTF-8 checked with the first bad byte located. The checker reads
//! imported files through it and the loader (`load.rs`) the file it is given, so both stand on
//! this module and neither on the other.

use crate::diagnostic::{Diagnostic, DiagnosticClass, Diagnostics, SourceFile, Span};
use crate::limits;
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

impl LoadError {
    /// The CLI exit code: 2 for a file that cannot be read, 1 for an invalid graph.
    pub fn exit_code(&self) -> u8 {
        match self {
            LoadError::Io { .. } => 2,
            LoadError::Invalid(_) => 1,
        }
    }
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
        let diagnostic = Diagnostic::new(
            DiagnosticClass::Limit,
            format!(
                "the file is larger than {} bytes, the limit for graph and scene files",
                limits::MAX_FILE_BYTES
            ),
        );
        return Err(LoadError::Invalid(Diagnostics {
            file,
            list: vec![diagnostic],
        }));
    }
    match String::from_utf8(bytes) {
        Ok(text) => Ok(SourceFile::new(path.display().to_string(), text)),
        Err(e) => Err(LoadError::Invalid(not_utf8(path, e))),
    }
}

/// A file that is not UTF-8 is invalid input (exit code 1), located at its first bad byte: the
/// text shown is the file with invalid sequences replaced, which keeps every byte before the
/// first one where it was.
fn not_utf8(path: &Path, error: std::string::FromUtf8Error) -> Diagnostics {
    let at = error.utf8_error().valid_up_to();
    let bytes = error.as_bytes();
    let bad: Vec<String> = bytes[at..]
        .iter()
        .take(error.utf8_error().error_len().unwrap_or(1).max(1))
        .map(|b| format!("0x{b:02X}"))
        .collect();
    let text = String::from_utf8_lossy(bytes).into_owned();
    let end = text[at..]
        .char_indices()
        .nth(1)
        .map_or(text.len(), |(i, _)| at + i);
    let file = SourceFile::new(path.display().to_string(), text);
    let diagnostic = Diagnostic::new(
        DiagnosticClass::Syntax,
        format!(
            "the file is not UTF-8 text: invalid byte {} after {at} valid bytes",
            bad.join(" ")
        ),
    )
    .at(Span::new(at, end))
    .label("not UTF-8")
    .help("texgraph reads graph and scene files as UTF-8 text; save the file as UTF-8");
    Diagnostics {
        file,
        list: vec![diagnostic],
    }
}
