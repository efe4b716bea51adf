//! Reading sample points (`x y z` per line) for `texgraph eval --points`.

use std::io::{BufRead, Read};

/// A problem in a points file: the line number (1-based) and what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    #[error("{source_name}:{line}: expected three numbers `x y z`, found `{text}`")]
    Malformed {
        source_name: String,
        line: usize,
        text: String,
    },
    #[error("{source_name}: {error}")]
    Io {
        source_name: String,
        error: std::io::Error,
    },
    /// Writing the results failed (the callback's error): not the points file's fault.
    #[error("writing the results: {error}")]
    Output { error: std::io::Error },
}

impl PointsError {
    /// The CLI exit code: 1 for a malformed points file, 2 for I/O errors.
    pub fn exit_code(&self) -> u8 {
        match self {
            PointsError::Malformed { .. } => 1,
            PointsError::Io { .. } | PointsError::Output { .. } => 2,
        }
    }
}

/// Longest line of a points file, in bytes: a file without line breaks is refused at this
/// length instead of being read whole.
pub const MAX_LINE: usize = 4096;

/// Reads points in chunks of up to `chunk` points, calling `f` with x, y and z planes.
/// Blank lines and lines starting with `#` are skipped; numbers are separated by whitespace or
/// commas; `nan`, `inf` and `-inf` are accepted (the stability cases).
pub fn for_each_chunk(
    mut reader: impl BufRead,
    source_name: &str,
    chunk: usize,
    mut f: impl FnMut(&[f64], &[f64], &[f64]) -> std::io::Result<()>,
) -> Result<(), PointsError> {
    let io = |error| PointsError::Io {
        source_name: source_name.to_string(),
        error,
    };
    let (mut xs, mut ys, mut zs) = (
        Vec::with_capacity(chunk),
        Vec::with_capacity(chunk),
        Vec::with_capacity(chunk),
    );
    let output = |error| PointsError::Output { error };
    let mut bytes = Vec::new();
    let mut index = 0usize;
    loop {
        bytes.clear();
        let read = std::io::Read::by_ref(&mut reader)
            .take(MAX_LINE as u64 + 1)
            .read_until(b'\n', &mut bytes)
            .map_err(io)?;
        if read == 0 {
            break;
        }
        index += 1;
        if bytes.len() > MAX_LINE && bytes.last() != Some(&b'\n') {
            if !xs.is_empty() {
                f(&xs, &ys, &zs).map_err(output)?;
            }
            return Err(PointsError::Malformed {
                source_name: source_name.to_string(),
                line: index,
                text: format!("a line longer than {MAX_LINE} bytes"),
            });
        }
        let line = String::from_utf8_lossy(&bytes);
        let text = line.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        let numbers: Vec<&str> = text
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|s| !s.is_empty())
            .collect();
        let parsed: Option<Vec<f64>> = numbers.iter().map(|s| s.parse::<f64>().ok()).collect();
        match parsed {
            Some(p) if p.len() == 3 => {
                xs.push(p[0]);
                ys.push(p[1]);
                zs.push(p[2]);
            }
            _ => {
                // Points before the bad line are still evaluated and printed, whatever the
                // chunking: the output does not depend on where a chunk happens to end.
                if !xs.is_empty() {
                    f(&xs, &ys, &zs).map_err(output)?;
                }
                return Err(PointsError::Malformed {
                    source_name: source_name.to_string(),
                    line: index,
                    text: text.chars().take(80).collect(),
                });
            }
        }
        if xs.len() == chunk {
            f(&xs, &ys, &zs).map_err(output)?;
            xs.clear();
            ys.clear();
            zs.clear();
        }
    }
    if !xs.is_empty() {
        f(&xs, &ys, &zs).map_err(output)?;
    }
    Ok(())
}
