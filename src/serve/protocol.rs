//! The page's JSON messages (docs/serve.md): the shared view settings and the requests a
//! client sends, each checked against the limits before anything changes.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Largest preview side (pixels).
pub const MAX_PREVIEW: u32 = 2048;
/// Largest slice side (pixels).
pub const MAX_SLICE: u32 = 2048;
/// Largest node thumbnail side (pixels).
pub const MAX_THUMB: u32 = 512;
/// Largest slice window width (texture units).
pub const MAX_WIDTH: f64 = 1e12;
/// The draft preview's side: the first pixels after an edit.
pub const DRAFT_SIZE: u32 = 128;

/// A slice of the texture: the plane (`xy`: z = depth; `xz`: y = depth; `yz`: x = depth) and
/// the square window on it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SliceWindow {
    pub axis: String,
    pub depth: f64,
    pub center: [f64; 2],
    pub width: f64,
}

impl Default for SliceWindow {
    fn default() -> Self {
        SliceWindow {
            axis: "xy".into(),
            depth: 0.5,
            center: [0.5, 0.5],
            width: 1.0,
        }
    }
}

/// What every tab sees: one set of settings, the server's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Settings {
    /// The graph shown (folder mode: chosen from the list).
    pub graph: Option<String>,
    /// The output or node previewed; `None`: the default output.
    pub output: Option<String>,
    pub object: String,
    pub space: String,
    /// Overrides of the file's params.
    pub params: BTreeMap<String, f64>,
    pub slice: SliceWindow,
    pub preview_size: u32,
    pub slice_size: u32,
    pub thumb_size: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            graph: None,
            output: None,
            object: "sphere".into(),
            space: "object".into(),
            params: BTreeMap::new(),
            slice: SliceWindow::default(),
            preview_size: 512,
            slice_size: 256,
            thumb_size: 96,
        }
    }
}

/// A slice window change: any subset of its fields.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlicePatch {
    pub axis: Option<String>,
    pub depth: Option<f64>,
    pub center: Option<[f64; 2]>,
    pub width: Option<f64>,
}

/// A request from a client.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Request {
    /// Override params (`null` drops one); `reset` drops all first.
    Set {
        #[serde(default)]
        params: BTreeMap<String, Option<f64>>,
        #[serde(default)]
        reset: bool,
    },
    /// Change the view; absent fields stay. `output: null` is the default output.
    View {
        #[serde(default, deserialize_with = "present")]
        output: Option<Option<String>>,
        object: Option<String>,
        space: Option<String>,
        slice: Option<SlicePatch>,
        preview_size: Option<u32>,
        slice_size: Option<u32>,
        thumb_size: Option<u32>,
    },
    /// Folder mode: show another graph of the folder.
    Open { graph: String },
    /// The values of every output at (u, v) of the slice plane.
    Hover {
        #[serde(default)]
        id: u64,
        u: f64,
        v: f64,
    },
    /// The accuracy report.
    Report {},
    /// Write the overrides into the file.
    Write {},
}

/// A field that may be given as `null` (`Some(None)`) or left out (`None`).
fn present<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Option<String>>, D::Error> {
    Option::<String>::deserialize(d).map(Some)
}

fn size(what: &str, v: u32, max: u32) -> Result<u32, String> {
    if v == 0 || v > max {
        return Err(format!(
            "{what} {v} is refused: it must be 1 to {max} pixels"
        ));
    }
    Ok(v)
}

/// `settings` with a view request applied, or why it is refused (nothing changes then).
pub fn apply_view(
    settings: &Settings,
    output: Option<Option<String>>,
    object: Option<String>,
    space: Option<String>,
    slice: Option<SlicePatch>,
    sizes: [Option<u32>; 3],
) -> Result<Settings, String> {
    let mut s = settings.clone();
    if let Some(output) = output {
        s.output = output;
    }
    if let Some(object) = object {
        if !["sphere", "cube", "teapot", "plane"].contains(&object.as_str()) {
            return Err(format!(
                "object `{object}`: expected sphere, cube, teapot or plane"
            ));
        }
        s.object = object;
    }
    if let Some(space) = space {
        if space != "object" && space != "world" {
            return Err(format!("space `{space}`: expected object or world"));
        }
        s.space = space;
    }
    if let Some(p) = slice {
        if let Some(axis) = p.axis {
            if !["xy", "xz", "yz"].contains(&axis.as_str()) {
                return Err(format!("slice axis `{axis}`: expected xy, xz or yz"));
            }
            s.slice.axis = axis;
        }
        if let Some(depth) = p.depth {
            s.slice.depth = depth;
        }
        if let Some(center) = p.center {
            s.slice.center = center;
        }
        if let Some(width) = p.width {
            s.slice.width = width;
        }
        let w = &s.slice;
        if !(w.depth.is_finite() && w.center.iter().all(|c| c.is_finite())) {
            return Err("the slice's depth and centre must be finite numbers".into());
        }
        if !(w.width > 0.0 && w.width <= MAX_WIDTH) {
            return Err(format!(
                "slice width {} is refused: it must be in (0, {MAX_WIDTH:e}]",
                w.width
            ));
        }
    }
    let [preview, slice_size, thumb] = sizes;
    if let Some(v) = preview {
        s.preview_size = size("preview size", v, MAX_PREVIEW)?;
    }
    if let Some(v) = slice_size {
        s.slice_size = size("slice size", v, MAX_SLICE)?;
    }
    if let Some(v) = thumb {
        s.thumb_size = size("thumbnail size", v, MAX_THUMB)?;
    }
    Ok(s)
}

/// `settings` with params set (a `null` drops the override), or why not (a non-finite value).
pub fn apply_set(
    settings: &Settings,
    params: BTreeMap<String, Option<f64>>,
    reset: bool,
) -> Result<Settings, String> {
    let mut s = settings.clone();
    if reset {
        s.params.clear();
    }
    for (name, value) in params {
        match value {
            Some(v) if v.is_finite() => {
                s.params.insert(name, v);
            }
            Some(v) => return Err(format!("param \"{name}\": {v} is not a finite number")),
            None => {
                s.params.remove(&name);
            }
        }
    }
    Ok(s)
}
