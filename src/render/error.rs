//! What a render refuses and why it fails: the image limits and [`RenderError`], which every
//! part of `render/` (scene loading, resolving, shading) reports through.

use crate::diagnostic::Diagnostics;
use crate::source::LoadError;
use std::path::PathBuf;

/// Longest image side.
pub const MAX_SIDE: u32 = 16384;
/// Most pixels in an image.
pub const MAX_PIXELS: u64 = 64 << 20;
/// Most samples per pixel.
pub const MAX_SAMPLES: u32 = 1024;

pub(crate) fn check_size(width: u32, height: u32) -> Result<(), String> {
    if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!(
            "the image size is {width}×{height}; each side must be 1 to {MAX_SIDE} pixels"
        ));
    }
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(format!(
            "the image size is {width}×{height}; images are limited to {MAX_PIXELS} pixels"
        ));
    }
    Ok(())
}

pub(crate) fn check_samples(samples: u32) -> Result<(), String> {
    if samples == 0 || samples > MAX_SAMPLES {
        return Err(format!(
            "{samples} samples per pixel; it must be 1 to {MAX_SAMPLES}"
        ));
    }
    Ok(())
}

/// Why a scene could not be loaded or rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// A scene, graph or mesh file is invalid (exit code 1): every problem, per file, with
    /// file:line:column.
    #[error("{}", render_all(.0))]
    Invalid(Vec<Diagnostics>),
    /// A file could not be read or written (exit code 2).
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Bad render options (exit code 2).
    #[error("{0}")]
    Options(String),
    /// The file watcher failed (exit code 2).
    #[error("watching files: {0}")]
    Watch(#[from] notify::Error),
    /// [`RenderOptions::cancel`](crate::render::RenderOptions::cancel) said stop (exit code 2; not an error a user sees).
    #[error("the render was cancelled")]
    Cancelled,
}

fn render_all(list: &[Diagnostics]) -> String {
    list.iter()
        .map(|d| d.render_plain())
        .collect::<Vec<_>>()
        .join("")
}

impl RenderError {
    pub(crate) fn from_load(e: LoadError) -> RenderError {
        match e {
            LoadError::Io { path, source } => RenderError::Io { path, source },
            LoadError::Invalid(d) => RenderError::Invalid(vec![d]),
        }
    }

    /// The message, with colour for a terminal when `colour` is set.
    pub fn render(&self, colour: bool) -> String {
        match self {
            RenderError::Invalid(list) => list.iter().map(|d| d.render(colour)).collect(),
            other => format!("error: {other}\n"),
        }
    }

    /// The CLI exit code: 1 for invalid input, 2 for I/O and usage errors.
    pub fn exit_code(&self) -> u8 {
        match self {
            RenderError::Invalid(_) => 1,
            _ => 2,
        }
    }
}
