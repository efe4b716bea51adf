//! `texgraph bake --mesh MODEL`: each graph's outputs baked into the model's UV layout as
//! images (docs/baking.md "Texture sets"), a normal map from `--normal`, a GLB from `--gltf`;
//! and `--normal` on a flat bake (`--size W,H,1`).

use crate::cli::{
    options, print_load_error, report_body, threads_or_warn, warn_about_values, warn_shortfalls,
    write_stdout, Failure, GraphOptions, SizeArg, MINUS,
};
use crate::mesh::{MeshBakeOptions, Model, TextureSet};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The options of `bake` that make or shape a texture set.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MeshArgs {
    /// Bake into this model's UV layout instead of a voxel grid (a texture set): glTF 2.0
    /// (`.gltf` with its buffers, or `.glb`) or Wavefront OBJ. Each output becomes an image
    /// STEM.OUTPUT.png (or .exr) of --size W[,H] texels (docs/baking.md "Texture sets").
    #[arg(long, value_name = "MODEL")]
    pub mesh: Option<PathBuf>,
    /// With --mesh: evaluate at the mesh's object-space positions as stored, or in the default
    /// scene's world space (node transforms applied) [default: object].
    #[arg(long, value_enum, value_name = "object|world")]
    pub space: Option<crate::mesh::Space>,
    /// With --mesh: uncovered texels within N texels of a UV island take its nearest texel's
    /// value (0: none) [default: 8].
    #[arg(long, value_name = "N")]
    pub padding: Option<u32>,
    /// A tangent-space normal map STEM.normal.png from the exact gradient of this scalar
    /// output (the height): with --mesh in its MikkTSpace frame, on a flat bake (--size W,H,1)
    /// in the image's frame.
    #[arg(long, value_name = "NAME")]
    pub normal: Option<String>,
    /// The normal map's bump strength s: N' = normalize(N − s(∇h − (∇h·N)N)) [default: 1].
    #[arg(long = "normal-strength", value_name = "S", value_parser = parse_strength, allow_hyphen_values = true)]
    pub normal_strength: Option<f64>,
    /// The normal map's green channel: up (OpenGL, glTF, Blender) or down (DirectX)
    /// [default: up].
    #[arg(long = "normal-y", value_enum, value_name = "up|down")]
    pub normal_y: Option<crate::mesh::GreenAxis>,
    /// With --mesh: also write STEM.glb, the mesh with a glTF 2.0 metallic-roughness material
    /// whose textures are the baked images (embedded PNGs).
    #[arg(long)]
    pub gltf: bool,
    /// With --gltf: the output for baseColorTexture [default: the first colour output].
    #[arg(long = "base-color", value_name = "NAME")]
    pub base_color: Option<String>,
    /// With --gltf: the scalar output packed as roughness (G) into metallicRoughnessTexture.
    #[arg(long, value_name = "NAME")]
    pub roughness: Option<String>,
    /// With --gltf: the scalar output packed as metallic (B) into metallicRoughnessTexture.
    #[arg(long, value_name = "NAME")]
    pub metallic: Option<String>,
}

/// What a mesh bake reads of the `bake` command line.
pub struct Request<'a> {
    pub files: &'a [PathBuf],
    pub size: SizeArg,
    pub format: crate::bake::Format,
    pub out: &'a Path,
    pub force: bool,
    pub threads: usize,
    pub double: bool,
    pub depth: Option<u8>,
    pub transfer: Option<crate::bake::Transfer>,
    pub device: crate::gpu::Device,
    pub filter: crate::filter::Filter,
    pub allow_large: bool,
    pub graph: &'a GraphOptions,
    /// The volume-only options given (their flags): each a usage error with --mesh.
    pub volume_only: Vec<&'static str>,
    pub mesh: &'a MeshArgs,
}

pub fn parse_strength(text: &str) -> Result<f64, String> {
    let text = text.replace(MINUS, "-");
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() => Ok(s),
        _ => Err(format!(
            "the normal strength is a finite number, found `{text}`"
        )),
    }
}

/// Options that do not apply to a mesh bake (each a usage error), and mesh options given
/// without what they need.
pub(super) fn misuse(args: &Request) -> Vec<String> {
    use crate::bake::Format;
    let mut problems = Vec::new();
    if !matches!(args.format, Format::Png | Format::Exr) {
        problems.push(format!(
            "--mesh writes PNG or EXR images; --format {} does not apply",
            args.format.name()
        ));
    }
    if args.size.given == 3 {
        problems.push("--mesh takes the image size --size W or W,H (texels), not NX,NY,NZ".into());
    }
    for option in &args.volume_only {
        problems.push(format!("{option} applies to volume bakes, not to --mesh"));
    }
    if args.depth.is_some() && args.format != Format::Png {
        problems.push("--depth applies to --format png only".into());
    }
    if args.transfer.is_some() && args.format != Format::Png {
        problems.push("--transfer applies to 8/16-bit files (--format png) only".into());
    }
    if args.device == crate::gpu::Device::Gpu {
        problems.push(
            "--mesh bakes on the CPU; --device gpu does not apply (--device auto or cpu)".into(),
        );
    }
    for (given, option) in [
        (args.mesh.base_color.is_some(), "--base-color"),
        (args.mesh.roughness.is_some(), "--roughness"),
        (args.mesh.metallic.is_some(), "--metallic"),
    ] {
        if given && !args.mesh.gltf {
            problems.push(format!(
                "{option} chooses a material texture of the --gltf asset; give --gltf"
            ));
        }
    }
    problems
}

impl MeshArgs {
    /// Mesh options given to a volume bake (`--normal` applies to flat ones, one voxel deep).
    pub(super) fn volume_misuse(
        &self,
        size: SizeArg,
        format: crate::bake::Format,
        one_image_refused: bool,
    ) -> Vec<String> {
        let args = self;
        let mut problems = Vec::new();
        for (given, option) in [
            (args.space.is_some(), "--space"),
            (args.padding.is_some(), "--padding"),
            (args.gltf, "--gltf"),
            (args.base_color.is_some(), "--base-color"),
            (args.roughness.is_some(), "--roughness"),
            (args.metallic.is_some(), "--metallic"),
        ] {
            if given {
                problems.push(format!(
                    "{option} applies to texture sets: give --mesh MODEL"
                ));
            }
        }
        if size.given == 2 {
            problems.push("--size W,H is an image size for --mesh; a volume takes N or NX,NY,NZ (a flat bake: W,H,1)".into());
        }
        if args.normal.is_some() {
            if size.dims[2] != 1 {
                problems.push(
                "--normal without --mesh makes the normal map of a flat bake: give --size W,H,1"
                    .into(),
            );
            }
            if !matches!(format, crate::bake::Format::Png | crate::bake::Format::Exr) {
                problems.push(format!(
                    "--normal writes a PNG or EXR image; --format {} does not apply",
                    format.name()
                ));
            }
            if one_image_refused {
                problems.push("--normal makes one image; --mips and --part do not apply".into());
            }
        }
        problems
    }

    /// `--normal-strength` and `--normal-y` need `--normal`.
    pub(super) fn normal_misuse(&self) -> Vec<String> {
        let args = self;
        let mut problems = Vec::new();
        for (given, option) in [
            (args.normal_strength.is_some(), "--normal-strength"),
            (args.normal_y.is_some(), "--normal-y"),
        ] {
            if given && args.normal.is_none() {
                problems.push(format!(
                    "{option} applies to the normal map: give --normal NAME"
                ));
            }
        }
        problems
    }
}

/// The tape of `height`'s gradient (one vec3 output), for the normal map; an output named
/// `normal` (whose file the map would overwrite) is refused.
pub(super) fn gradient_tape(
    file: &Path,
    graph: &crate::graph::CheckedGraph,
    height: &str,
    compile_options: &crate::compile::CompileOptions,
) -> Result<crate::tape::Tape, Failure> {
    let refuse = |why: String| {
        eprintln!("error: {}: {why}", file.display());
        Failure::Usage
    };
    crate::mesh::gradient_tape(graph, height, compile_options)
        .map_err(|why| refuse(format!("--normal {height}: {why}")))
}

/// The options of a texture set bake from the command line.
fn mesh_options(args: &Request, [width, height]: [usize; 2]) -> MeshBakeOptions {
    MeshBakeOptions {
        width,
        height,
        filter: args.filter,
        padding: args.mesh.padding.unwrap_or(DEFAULT_PADDING),
        precision: if args.double {
            crate::bake::Precision::F64
        } else {
            crate::bake::Precision::F32
        },
        normal_strength: args.mesh.normal_strength.unwrap_or(1.0),
        green: args.mesh.normal_y.unwrap_or_default(),
    }
}

/// `--padding`'s default, in texels.
pub const DEFAULT_PADDING: u32 = 8;

/// The image size of a mesh bake: W or W,H.
fn image_size(args: &Request) -> [usize; 2] {
    [args.size.dims[0], args.size.dims[1]]
}

/// Refuses a size whose images (`channels` of the outputs, and the normal map when asked for)
/// would not fit the formats or the memory limit.
fn check_size(args: &Request, [width, height]: [usize; 2], channels: usize) -> Result<(), String> {
    const MAX_SIDE: usize = i32::MAX as usize;
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(format!(
            "--size {width},{height}: an image side is at most {MAX_SIDE} texels"
        ));
    }
    let held = crate::mesh::held_bytes(width, height, channels, args.mesh.normal.is_some());
    let limit = if args.allow_large {
        u64::MAX
    } else {
        crate::bake::DEFAULT_MAX_HELD_BYTES
    };
    if held > limit {
        return Err(format!(
            "a {width}×{height} texture set is made in memory: this one would hold about {}, more than the limit of {}; bake a smaller --size or pass --allow-large",
            crate::bake::human_bytes(held),
            crate::bake::human_bytes(limit)
        ));
    }
    Ok(())
}

/// `bake --mesh`: every graph file onto the model.
pub(super) fn bake_mesh(args: &Request) -> Result<(), Failure> {
    let mut problems = misuse(args);
    problems.extend(args.mesh.normal_misuse());
    if !problems.is_empty() {
        for problem in problems {
            eprintln!("error: {problem}");
        }
        return Err(Failure::Usage);
    }
    let size = image_size(args);
    // Refused before any work (the outputs' channels are not known yet: 3 per output is the
    // bound checked again per graph).
    check_size(args, size, 3).map_err(|why| {
        eprintln!("error: {why}");
        Failure::Usage
    })?;
    let Some(mesh_path) = args.mesh.mesh.as_deref() else {
        return Err(Failure::Usage);
    };
    let model =
        crate::mesh::load_model(mesh_path, args.mesh.space.unwrap_or_default()).map_err(|e| {
            eprintln!("error: {e}");
            Failure::from_exit_code(e.exit_code())
        })?;
    if model.skipped > 0 {
        eprintln!(
            "warning: {}: {} primitive(s) that are not triangle lists were left out",
            mesh_path.display(),
            model.skipped
        );
    }
    if args.device == crate::gpu::Device::Auto {
        eprintln!("texgraph: --mesh bakes on the CPU");
    }
    let threads = threads_or_warn(args.threads);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| {
            eprintln!("error: cannot start {threads} threads: {e}");
            Failure::Usage
        })?;
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = cancel.clone();
        let _ = ctrlc::set_handler(move || cancel.store(true, Ordering::Relaxed));
    }
    let mut worst = None;
    for file in args.files {
        let result = pool.install(|| one_graph(args, file, &model, size, &cancel, threads));
        if let Err(failure) = result {
            worst = Failure::worst(worst, failure);
            if matches!(failure, Failure::Interrupted) {
                return Err(failure);
            }
        }
    }
    worst.map_or(Ok(()), Err)
}

/// One graph's texture set: checked, baked, written all or nothing, reported.
fn one_graph(
    args: &Request,
    file: &Path,
    model: &Model,
    size: [usize; 2],
    cancel: &Arc<AtomicBool>,
    threads: usize,
) -> Result<(), Failure> {
    let (check_options, compile_options) = options(args.graph);
    let (graph, tape) =
        crate::load::load_tape(file, &check_options, &compile_options).map_err(print_load_error)?;
    let usage = |why: String| {
        eprintln!("error: {}: {why}", file.display());
        Failure::Usage
    };
    check_size(args, size, tape.channels()).map_err(usage)?;
    let gradient = match &args.mesh.normal {
        Some(height) => Some(gradient_tape(file, &graph, height, &compile_options)?),
        None => None,
    };
    let material = material_choice(args, &tape).map_err(usage)?;
    if !args.double {
        warn_shortfalls(file, &tape);
    }
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("graph");
    let files = planned_files(args, stem, &tape).map_err(usage)?;
    let options = mesh_options(args, size);
    let started = std::time::Instant::now();
    let set =
        crate::mesh::bake_texture_set(&tape, gradient.as_ref(), model, &options, Some(cancel))
            .map_err(|e| match e {
                crate::bake::BakeError::Cancelled => {
                    eprintln!(
                        "error: {}: interrupted; no output was written",
                        file.display()
                    );
                    Failure::Interrupted
                }
                other => usage(other.to_string()),
            })?;
    let seconds = started.elapsed().as_secs_f64();
    if set.overlaps > 0 {
        eprintln!(
            "warning: {}: {} texel centres are covered by more than one triangle (overlapping UVs); each took the first triangle's surface point",
            model.path.display(),
            set.overlaps
        );
    }
    let written = write_set(args, &files, &set, model, &material).map_err(|e| {
        eprintln!("error: {}: {e}", file.display());
        Failure::from_exit_code(e.exit_code())
    })?;
    let report = crate::bake::BakeReport {
        files: written,
        stats: set.stats.clone(),
        voxels: set.covered,
        seconds,
    };
    let text = mesh_report(
        file,
        model,
        &set,
        &report,
        threads,
        args.format == crate::bake::Format::Png,
    );
    write_stdout(|out| out.write_all(text.as_bytes()))?;
    warn_about_values(
        file,
        &report,
        args.format == crate::bake::Format::Png,
        args.format,
    );
    Ok(())
}

/// The material's images by output name: `--base-color` (default the first colour output),
/// `--roughness`, `--metallic` (scalars).
#[derive(Default)]
struct Material {
    base_color: Option<usize>,
    roughness: Option<usize>,
    metallic: Option<usize>,
}

fn material_choice(args: &Request, tape: &crate::tape::Tape) -> Result<Material, String> {
    if !args.mesh.gltf {
        return Ok(Material::default());
    }
    let find = |name: &str, option: &str, scalar: bool| -> Result<usize, String> {
        let index = tape
            .outputs()
            .iter()
            .position(|o| o.name == name)
            .ok_or_else(|| format!("{option} {name}: the graph has no output `{name}` (or it was not selected by --output)"))?;
        if scalar && tape.outputs()[index].ty != crate::graph::Type::Scalar {
            return Err(format!("{option} {name}: `{name}` is a colour; a scalar is packed into the metallic-roughness texture"));
        }
        Ok(index)
    };
    let base_color = match &args.mesh.base_color {
        Some(name) => Some(find(name, "--base-color", false)?),
        None => tape
            .outputs()
            .iter()
            .position(|o| o.ty == crate::graph::Type::Vec3),
    };
    Ok(Material {
        base_color,
        roughness: args
            .mesh
            .roughness
            .as_deref()
            .map(|n| find(n, "--roughness", true))
            .transpose()?,
        metallic: args
            .mesh
            .metallic
            .as_deref()
            .map(|n| find(n, "--metallic", true))
            .transpose()?,
    })
}

/// The final path of each image (outputs in order, then the normal map), and the GLB.
struct Planned {
    images: Vec<PathBuf>,
    normal: Option<PathBuf>,
    glb: Option<PathBuf>,
}

fn planned_files(args: &Request, stem: &str, tape: &crate::tape::Tape) -> Result<Planned, String> {
    let extension = if args.format == crate::bake::Format::Exr {
        "exr"
    } else {
        "png"
    };
    let path = |name: String| -> Result<PathBuf, String> {
        let path = crate::output::join_inside(args.out, &name).map_err(|e| e.to_string())?;
        crate::output::check_destination(&path, crate::output::Expect::File)
            .map_err(|e| e.to_string())?;
        if !args.force && std::fs::symlink_metadata(&path).is_ok() {
            return Err(format!(
                "{} exists; pass --force to overwrite it",
                path.display()
            ));
        }
        Ok(path)
    };
    if args.out.exists() {
        crate::output::check_out_folder(args.out).map_err(|e| e.to_string())?;
    }
    Ok(Planned {
        images: tape
            .outputs()
            .iter()
            .map(|o| path(format!("{stem}.{}.{extension}", o.name)))
            .collect::<Result<_, _>>()?,
        normal: args
            .mesh
            .normal
            .as_ref()
            .map(|_| path(format!("{stem}.normal.{extension}")))
            .transpose()?,
        glb: args
            .mesh
            .gltf
            .then(|| path(format!("{stem}.glb")))
            .transpose()?,
    })
}

/// Writes the images (and the GLB) into temporaries in `--out` (created if missing) and
/// moves them into place together; on any error nothing is left.
fn write_set(
    args: &Request,
    planned: &Planned,
    set: &TextureSet,
    model: &Model,
    material: &Material,
) -> Result<Vec<crate::bake::BakedFile>, crate::bake::BakeError> {
    use crate::bake::{BakeError, BakedFile, Format};
    let io = |path: &Path| {
        let path = path.display().to_string();
        move |source| BakeError::Io {
            path: path.clone(),
            source,
        }
    };
    let created = !args.out.exists();
    std::fs::create_dir_all(args.out).map_err(io(args.out))?;
    let result = (|| {
        let mut staged = Vec::new();
        let mut written = Vec::new();
        let depth16 = args.depth == Some(16);
        let srgb = args.transfer.unwrap_or_default() == crate::bake::Transfer::Srgb;
        let images = set.images.iter().zip(&planned.images);
        let normal = set.normal.iter().zip(&planned.normal);
        for (image, path) in images.chain(normal) {
            let temp = crate::output::temp_file(args.out, path).map_err(io(args.out))?;
            // The normal map and scalars are data (linear); colours follow --transfer.
            let srgb = srgb && planned.normal.as_ref() != Some(path);
            let description = match args.format {
                Format::Exr => {
                    let file = temp.reopen().map_err(io(path))?;
                    crate::bake::write_exr_image(
                        path,
                        file,
                        image.data.clone(),
                        image.ty,
                        [set.width, set.height],
                        &[],
                    )?;
                    format!("{}×{} EXR, 32-bit float", set.width, set.height)
                }
                _ => {
                    let bytes = crate::bake::png_bytes(
                        &image.data,
                        set.width,
                        set.height,
                        image.ty,
                        depth16,
                        srgb,
                    )
                    .map_err(|message| BakeError::Encode {
                        path: path.display().to_string(),
                        message,
                    })?;
                    std::fs::write(temp.path(), bytes).map_err(io(path))?;
                    let bits = if depth16 { 16 } else { 8 };
                    let encoding = if srgb && image.ty == crate::graph::Type::Vec3 {
                        "sRGB"
                    } else {
                        "linear"
                    };
                    format!("{}×{} PNG, {bits}-bit {encoding}", set.width, set.height)
                }
            };
            written.push(BakedFile {
                output: image.name.clone(),
                path: path.clone(),
                description,
            });
            staged.push((temp.into_temp_path(), path.clone()));
        }
        if let Some(path) = &planned.glb {
            let pick = |i: Option<usize>| i.map(|i| &set.images[i]);
            let images = crate::mesh::glb::MaterialImages {
                base_color: pick(material.base_color),
                normal: set.normal.as_ref(),
                roughness: pick(material.roughness),
                metallic: pick(material.metallic),
                normal_green: args.mesh.normal_y.unwrap_or_default(),
            };
            let bytes = crate::mesh::glb::glb_bytes(model, set, &images).map_err(|message| {
                BakeError::Encode {
                    path: path.display().to_string(),
                    message,
                }
            })?;
            let temp = crate::output::temp_file(args.out, path).map_err(io(args.out))?;
            std::fs::write(temp.path(), bytes).map_err(io(path))?;
            written.push(BakedFile {
                output: "glTF".into(),
                path: path.clone(),
                description: "glTF 2.0 binary, metallic-roughness material, textures embedded"
                    .into(),
            });
            staged.push((temp.into_temp_path(), path.clone()));
        }
        crate::bake::commit_files(staged, args.out)?;
        Ok(written)
    })();
    if result.is_err() && created {
        let _ = std::fs::remove_dir(args.out);
    }
    result
}

/// The per-graph report: coverage, files, statistics over the covered texels, speed.
fn mesh_report(
    file: &Path,
    model: &Model,
    set: &TextureSet,
    report: &crate::bake::BakeReport,
    threads: usize,
    clamps: bool,
) -> String {
    let texels = (set.width * set.height) as f64;
    let mut text = format!(
        "{}: {}×{} texels on {} ({} triangles): {} covered ({:.1} %), {} padded, {} overlapping\n",
        file.display(),
        set.width,
        set.height,
        model.path.display(),
        model.triangles(),
        set.covered,
        100.0 * set.covered as f64 / texels,
        set.padded,
        set.overlaps
    );
    text.push_str(&report_body(report, clamps));
    let rate = if report.seconds > 0.0 {
        report.voxels as f64 / report.seconds / 1e6
    } else {
        0.0
    };
    text.push_str(&format!(
        "  {} texels in {:.3} s: {rate:.2} Mtexels/s on {threads} thread(s)\n",
        report.voxels, report.seconds
    ));
    text
}

/// The normal map of a flat bake (`--size W,H,1 --normal NAME`): `STEM.normal.png` (or
/// `.exr`) beside the outputs, written after them.
pub(super) fn flat_normal(
    args: &Request,
    file: &Path,
    gradient: &crate::tape::Tape,
    grid: &crate::grid::Grid,
    cancel: &AtomicBool,
) -> Result<(), Failure> {
    let [nx, ny, _] = grid.size;
    let options = mesh_options(args, [nx, ny]);
    let image =
        crate::mesh::flat_normal_map(gradient, grid, &options, Some(cancel)).map_err(|e| {
            eprintln!("error: {}: {e}", file.display());
            Failure::from_exit_code(e.exit_code())
        })?;
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("graph");
    let set = TextureSet {
        width: nx,
        height: ny,
        images: Vec::new(),
        normal: Some(image),
        stats: Vec::new(),
        covered: (nx * ny) as u64,
        overlaps: 0,
        padded: 0,
        tangents: Vec::new(),
    };
    let extension = if args.format == crate::bake::Format::Exr {
        "exr"
    } else {
        "png"
    };
    let path = crate::output::join_inside(args.out, &format!("{stem}.normal.{extension}"))
        .map_err(|e| {
            eprintln!("error: {e}");
            Failure::Usage
        })?;
    let planned = Planned {
        images: Vec::new(),
        normal: Some(path),
        glb: None,
    };
    let model = Model {
        path: PathBuf::new(),
        parts: Vec::new(),
        skipped: 0,
    };
    let written = write_set(args, &planned, &set, &model, &Material::default()).map_err(|e| {
        eprintln!("error: {}: {e}", file.display());
        Failure::from_exit_code(e.exit_code())
    })?;
    for baked in written {
        let line = format!(
            "  {} -> {} ({})\n",
            baked.output,
            baked.path.display(),
            baked.description
        );
        write_stdout(|out| out.write_all(line.as_bytes()))?;
    }
    Ok(())
}
