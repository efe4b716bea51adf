//! `texgraph shader`: a graph exported as a shader function per output (docs/shaders.md).

use super::*;
use crate::shader::{Lang, ShaderOptions};
use clap::{Args, ValueEnum};
use std::path::PathBuf;

#[derive(Args)]
pub struct ShaderArgs {
    /// The graph file.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// The shading language.
    #[arg(long, value_enum, default_value = "wgsl")]
    lang: LangArg,
    /// GLSL and GLSL ES: start with `#version N` (desktop 330 to 460, ES 300, 310 or 320).
    /// Default: no `#version` line (the calling shader has one); the source is GLSL 4.50 or
    /// GLSL ES 3.00.
    #[arg(long, value_name = "N")]
    version: Option<u16>,
    /// Params as fields of a `TexgraphParams` uniform (group 0, binding 0; one f32 per param in
    /// the graph's order) that the functions read, so an engine can change them at run time.
    /// Params that shape the graph (octaves, seeds, ramp stops...) stay constants: said on
    /// stderr.
    #[arg(long)]
    uniforms: bool,
    /// Leave out the `texgraph_NAME_filtered(p, footprint)` functions: their rules are most of
    /// the source (the seed 003 marble: 110 kB of WGSL with them, 18.6 kB without).
    #[arg(long)]
    no_filtered: bool,
    /// Warn where f32 is not enough over this region (`X0,Y0,Z0:X1,Y1,Z1`): the node and the
    /// error bound its precision plan gives f32.
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_extent, allow_hyphen_values = true)]
    extent: Option<crate::precision::Extent>,
    /// Write the shader to this file (replaced atomically) instead of standard output.
    #[arg(short = 'o', value_name = "PATH")]
    out: Option<PathBuf>,
    #[command(flatten)]
    graph: GraphOptions,
}

#[derive(Clone, Copy, ValueEnum)]
enum LangArg {
    Wgsl,
    Glsl,
    GlslEs,
    Hlsl,
    Msl,
}

impl From<LangArg> for Lang {
    fn from(l: LangArg) -> Lang {
        match l {
            LangArg::Wgsl => Lang::Wgsl,
            LangArg::Glsl => Lang::Glsl,
            LangArg::GlslEs => Lang::GlslEs,
            LangArg::Hlsl => Lang::Hlsl,
            LangArg::Msl => Lang::Msl,
        }
    }
}

pub fn shader(args: ShaderArgs) -> Result<(), Failure> {
    let (check_options, compile_options) = options(&args.graph);
    let (graph, tape) = crate::load::load_tape(&args.file, &check_options, &compile_options)
        .map_err(print_load_error)?;
    let fail = |e: crate::shader::ShaderError| {
        eprintln!("error: {}: {e}", args.file.display());
        Failure::from_exit_code(e.exit_code())
    };
    let mut tape = tape;
    let plan = if args.uniforms {
        let (plan, general) = crate::shader::uniforms::plan(
            &args.file,
            graph.params(),
            &check_options,
            &compile_options,
        )
        .map_err(fail)?;
        if let Some(general) = general {
            tape = general;
        }
        for p in &plan.params {
            if let Some(why) = &p.constant {
                eprintln!(
                    "texgraph: param `{}` stays the constant {} (its uniform field `{}` is not read): {why}",
                    p.name, p.value, p.field
                );
            }
        }
        Some(plan)
    } else {
        None
    };
    if let Some(extent) = args.extent {
        precision_warnings(&args, extent, &check_options, &compile_options)?;
    }
    let options = ShaderOptions {
        lang: args.lang.into(),
        version: args.version,
        filtered: !args.no_filtered,
    };
    let exported = crate::shader::export(&tape, &options, plan.as_ref()).map_err(fail)?;
    if options.filtered && exported.functions.iter().any(|f| f.filtered.is_none()) {
        let why = match crate::gpu::filtered::unsupported(&tape) {
            Some(why) => format!("the filtered form does not cover {why}"),
            None => "the filtered form's rules are built for the params' values, which \
                     --uniforms lets the engine change"
                .to_string(),
        };
        eprintln!("texgraph: no `_filtered` functions: {why}");
    }
    match &args.out {
        Some(path) => {
            crate::output::write_atomic(path, |w| w.write_all(exported.source.as_bytes())).map_err(
                |e| {
                    eprintln!("error: {e}");
                    Failure::Usage
                },
            )
        }
        None => write_stdout(|out| out.write_all(exported.source.as_bytes())),
    }
}

/// `--extent`: the precision plan over the region; every output whose f32 bound misses the
/// target gets a warning naming the node that needs f64 and the error the shader will have.
fn precision_warnings(
    args: &ShaderArgs,
    extent: crate::precision::Extent,
    check_options: &crate::check::CheckOptions,
    compile_options: &crate::compile::CompileOptions,
) -> Result<(), Failure> {
    let mut options = compile_options.clone();
    options.extent = Some(extent);
    let (_, planned) =
        crate::load::load_tape(&args.file, check_options, &options).map_err(print_load_error)?;
    for warning in crate::shader::precision_warnings(&planned) {
        eprintln!("warning: {}: {warning}", args.file.display());
    }
    Ok(())
}
