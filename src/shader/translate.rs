//! The export's WGSL module (`export_source`) through naga: parse, made all-f32 and given the
//! export's own functions on the IR (`narrow.rs`, `functions.rs`), compacted to what the
//! exported functions reach, prefixed, validated without f64, written in the language, and the
//! stub entry point taken out.

use super::options::{Lang, ShaderError, ShaderOptions, KEEP};
use naga::valid::{Capabilities, ValidationFlags, Validator};
use std::collections::HashSet;

/// `wgsl` (the module `export_source` builds) written in `options.lang`, without its stub entry
/// point; the names in `keep` are not prefixed.
pub(super) fn translate(
    wgsl: &str,
    options: &ShaderOptions,
    keep: &HashSet<String>,
) -> Result<String, ShaderError> {
    let internal = |what: &str, e: String| ShaderError::Internal(format!("{what}: {e}"));
    let mut module = naga::front::wgsl::parse_str(wgsl)
        .map_err(|e| internal("parsing the export's WGSL", e.emit_to_string(wgsl)))?;
    crate::gpu::widen::graft(&mut module).map_err(|e| internal("the bases' f64 twins", e))?;
    let wide = super::narrow::narrow(&mut module).map_err(|e| internal("narrowing to f32", e))?;
    super::functions::replace(&mut module, super::options::EXPORT_FORM)
        .map_err(|e| internal("the export's functions", e))?;
    for (from, to) in super::narrow::SAME_IN_F32 {
        super::functions::redirect(&mut module, from, to)
            .map_err(|e| internal("the export's functions", e))?;
    }
    // Compacted before validation: the f64 forms the export replaced are gone, and then the
    // constants only they read (such as f64's largest finite value), with their literals past
    // f32's range.
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    super::narrow::settle_constants(&mut module, &wide)
        .map_err(|e| internal("narrowing to f32", e))?;
    naga::compact::compact(&mut module, naga::compact::KeepUnused::No);
    super::functions::prefix(&mut module, keep);
    if matches!(options.lang, Lang::Glsl | Lang::GlslEs) {
        let info = validate(&module, wgsl)?;
        return glsl(&module, &info, options);
    }
    // Without an entry point naga keeps every function (compaction is done) and the writers
    // write no stage code.
    module.entry_points.clear();
    let info = validate(&module, wgsl)?;
    let text = match options.lang {
        Lang::Wgsl => {
            naga::back::wgsl::write_string(&module, &info, naga::back::wgsl::WriterFlags::empty())
                .map_err(|e| internal("writing WGSL", e.to_string()))?
        }
        Lang::Hlsl => {
            let hlsl_options = naga::back::hlsl::Options {
                shader_model: naga::back::hlsl::ShaderModel::V5_1,
                ..Default::default()
            };
            let pipeline = naga::back::hlsl::PipelineOptions::default();
            let mut out = String::new();
            naga::back::hlsl::Writer::new(&mut out, &hlsl_options, &pipeline)
                .write(&module, &info, None)
                .map_err(|e| internal("writing HLSL", e.to_string()))?;
            out
        }
        Lang::Msl => {
            let msl_options = naga::back::msl::Options {
                lang_version: (2, 1),
                ..Default::default()
            };
            let pipeline = naga::back::msl::PipelineOptions::default();
            naga::back::msl::write_string(&module, &info, &msl_options, &pipeline)
                .map_err(|e| internal("writing MSL", e.to_string()))?
                .0
        }
        Lang::Glsl | Lang::GlslEs => unreachable!("written above"),
    };
    Ok(text)
}

fn validate(module: &naga::Module, wgsl: &str) -> Result<naga::valid::ModuleInfo, ShaderError> {
    // No FLOAT64 capability: a leftover f64 is an error here.
    Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(module)
        .map_err(|e| {
            ShaderError::Internal(format!(
                "the f32 WGSL does not validate: {}",
                e.emit_to_string(wgsl)
            ))
        })
}

/// GLSL through naga's writer for the stub fragment entry point, then the text without the
/// entry point's parts: the `#version` line (unless asked for), the fragment output and
/// `void main()`.
fn glsl(
    module: &naga::Module,
    info: &naga::valid::ModuleInfo,
    options: &ShaderOptions,
) -> Result<String, ShaderError> {
    use naga::back::glsl;
    let version = match (options.lang, options.version) {
        (Lang::GlslEs, v) => glsl::Version::Embedded {
            version: v.unwrap_or(300),
            is_webgl: false,
        },
        (_, v) => glsl::Version::Desktop(v.unwrap_or(450)),
    };
    let glsl_options = glsl::Options {
        version,
        writer_flags: glsl::WriterFlags::empty(),
        ..Default::default()
    };
    let pipeline = glsl::PipelineOptions {
        shader_stage: naga::ShaderStage::Fragment,
        entry_point: KEEP.to_string(),
        multiview: None,
    };
    let mut text = String::new();
    glsl::Writer::new(
        &mut text,
        module,
        info,
        &glsl_options,
        &pipeline,
        naga::proc::BoundsCheckPolicies::default(),
    )
    .and_then(|mut w| w.write())
    .map_err(|e| ShaderError::Internal(format!("writing GLSL: {e}")))?;
    Ok(strip_glsl_entry(&text, options.version.is_some()))
}

/// [`glsl`]'s text without the stub entry point: `void main()` (always last), the fragment
/// output's declaration, and the `#version` line unless `keep_version`.
fn strip_glsl_entry(text: &str, keep_version: bool) -> String {
    let mut text = text.to_string();
    if let Some(main) = super::words::block_range(&text, "void main(") {
        text.replace_range(main, "");
    }
    text.lines()
        .filter(|line| {
            !(line.contains("_fs2p_") || (line.starts_with("#version") && !keep_version))
        })
        .flat_map(|line| [line, "\n"])
        .collect()
}
