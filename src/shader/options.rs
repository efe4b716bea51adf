//! The shader export's vocabulary: the languages, the options, what an export gives and why
//! it can fail (below every other file of `shader/`).

/// The languages `texgraph shader --lang` writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Lang {
    Wgsl,
    Glsl,
    GlslEs,
    Hlsl,
    Msl,
}

impl Lang {
    /// Every language, in `--lang`'s order.
    pub const ALL: [Lang; 5] = [Lang::Wgsl, Lang::Glsl, Lang::GlslEs, Lang::Hlsl, Lang::Msl];

    /// The `--lang` value.
    pub fn name(self) -> &'static str {
        match self {
            Lang::Wgsl => "wgsl",
            Lang::Glsl => "glsl",
            Lang::GlslEs => "glsl-es",
            Lang::Hlsl => "hlsl",
            Lang::Msl => "msl",
        }
    }
}

/// What `export` writes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ShaderOptions {
    pub lang: Lang,
    /// GLSL only: a `#version` line with this version (desktop: 330 to 460; ES: 300, 310, 320)
    /// at the top; `None`: no `#version` line (the calling shader has one), the source written
    /// for GLSL 4.50 or GLSL ES 3.00.
    pub version: Option<u16>,
    /// Also `texgraph_NAME_filtered(p, footprint)`: each output's mean over a footprint
    /// (`eval --footprint`'s filtered form, in f32); `--no-filtered` leaves it out (a source
    /// about a fifth the size).
    pub filtered: bool,
}

/// One exported source and its functions.
#[derive(Clone, Debug)]
pub struct Exported {
    pub source: String,
    pub functions: Vec<ExportedFunction>,
}

/// An exported output: its functions' names and its type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExportedFunction {
    /// The graph's output name.
    pub output: String,
    /// `texgraph_` + the output name (see [`function_name`]).
    pub name: String,
    /// `name` + `_lod`: the level-of-detail form, `(p, spacing)`.
    pub lod: String,
    /// `name` + `_filtered`: the filtered form, `(p, footprint)` (a 3×3 matrix whose columns
    /// are the footprint's edges); `None` where it is not exported (`--no-filtered`, or a tape
    /// the filtered form does not cover).
    pub filtered: Option<String>,
    /// 1 (a scalar, `f32`/`float`) or 3 (`vec3<f32>`/`vec3`/`float3`).
    pub channels: usize,
}

impl ExportedFunction {
    /// The names of its functions: the point form, `_lod` and `_filtered` where exported.
    pub fn names(&self) -> impl Iterator<Item = &String> {
        [Some(&self.name), Some(&self.lod), self.filtered.as_ref()]
            .into_iter()
            .flatten()
    }
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    #[error(
        "this texgraph was built without the `shader` feature (naga's GLSL, HLSL and MSL writers)"
    )]
    NotBuilt,
    #[error("--version {version} is not a GLSL version texgraph writes ({allowed})")]
    Version { version: u16, allowed: &'static str },
    #[error("--version applies to --lang glsl and glsl-es only")]
    VersionNotGlsl,
    #[error("two outputs export as the same function `{0}` (rename one output)")]
    SameName(String),
    #[error("two params become the same uniform field `{0}` (rename one param)")]
    SameField(String),
    /// A texgraph bug: the generated WGSL does not validate, or naga refuses to write it.
    #[error("internal error in the shader export: {0}")]
    Internal(String),
}

impl ShaderError {
    /// The process exit code: 2 for a usage error, 70 (EX_SOFTWARE) for an internal error.
    pub fn exit_code(&self) -> u8 {
        match self {
            ShaderError::Internal(_) => 70,
            _ => 2,
        }
    }
}

/// `texgraph_` + `output` made an identifier (see [`identifier`]).
pub fn function_name(output: &str) -> String {
    format!("texgraph_{}", identifier(output))
}

/// `name` with every character outside `[A-Za-z0-9_]` made `_`.
pub fn identifier(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The name of the stub entry point that keeps the exported functions through compaction.
pub(super) const KEEP: &str = "tg_keep";

/// The suffix of a function the export writes for itself: `fn NAME__export(…)` takes the place
/// of the library's `NAME` on naga's IR (`functions::replace`).
#[cfg_attr(not(feature = "shader"), allow(dead_code))]
pub(super) const EXPORT_FORM: &str = "__export";

/// The prefix of every module-scope name of the library and the tape function in the export.
pub(super) const PREFIX: &str = "tg_";
