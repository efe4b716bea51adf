//! `texgraph bake`: the batch of graph files, options that must apply, the report text.

use super::*;
use clap::Args;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

mod mesh;

#[derive(Args)]
pub struct BakeArgs {
    /// Graph files to bake.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Voxels per axis: N (a cube) or NX,NY,NZ. With --mesh: the images' texels, W or W,H
    /// (H defaults to W).
    #[arg(long, value_name = "N|NX,NY,NZ|W,H", default_value = "64", value_parser = parse_size)]
    size: super::SizeArg,
    /// The box baked, X0,Y0,Z0:X1,Y1,Z1 (default: the unit cube 0,0,0:1,1,1).
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_region, allow_hyphen_values = true)]
    region: Option<crate::grid::Region>,
    /// File format.
    #[arg(long, value_enum, default_value_t)]
    format: crate::bake::Format,
    /// Folder the files go to (created if missing). Zarr: a path ending in `.zarr` is the store
    /// itself (one graph file), any other folder gets a store `STEM.zarr` per graph.
    #[arg(long, value_name = "DIR", default_value = "baked")]
    out: PathBuf,
    /// Zarr: voxels per inner chunk side [default: 64].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    chunk: Option<u64>,
    /// Zarr: voxels per shard side, a multiple of --chunk (one object per shard; the unit of
    /// --part and of resuming) [default: 512].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    shard: Option<u64>,
    /// Zarr: chunk compression [default: zstd, level from --zstd=LEVEL, default 3].
    #[arg(long, value_enum, value_name = "METHOD")]
    compression: Option<crate::bake::ZarrCompression>,
    /// Bake only part I of N (from 1): of a zarr store's shards (one graph file), or of the
    /// sorted list of graph files (several). `auto` reads a Kubernetes Indexed Job's
    /// JOB_COMPLETION_INDEX (with --parts N) or a Slurm job array's SLURM_ARRAY_TASK_ID and
    /// SLURM_ARRAY_TASK_COUNT.
    #[arg(long, value_name = "I/N|auto")]
    part: Option<String>,
    /// With --part auto under Kubernetes: how many parts (the Indexed Job's completions).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    parts: Option<u64>,
    /// Worker threads (default: one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Overwrite existing outputs.
    #[arg(long)]
    force: bool,
    /// EXR: 16-bit half floats instead of 32-bit. KTX2: half floats (R16_SFLOAT,
    /// R16G16B16A16_SFLOAT) instead of 8-bit. Zarr: float16 instead of uint8.
    #[arg(long)]
    half: bool,
    /// KTX2: 32-bit floats (R32_SFLOAT, R32G32B32A32_SFLOAT) instead of 8-bit. Zarr: float32.
    #[arg(long)]
    float: bool,
    /// KTX2: Zstandard supercompression, each level compressed on its own; --zstd=LEVEL picks
    /// the level, 1 (fastest) to 22 (smallest) [default level: 3]. Zarr: the zstd level.
    #[arg(
        long,
        value_name = "LEVEL",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "3",
        value_parser = clap::value_parser!(i32).range(1..=22)
    )]
    zstd: Option<i32>,
    /// EXR: lossless compression [default: zip].
    #[arg(long = "exr-compression", value_enum, value_name = "METHOD")]
    exr_compression: Option<crate::bake::ExrCompression>,
    /// PNG: bits per sample, 8 or 16 [default: 8].
    #[arg(long, value_name = "BITS", value_parser = parse_depth)]
    depth: Option<u8>,
    /// PNG: one tiled atlas image per output instead of a folder of slices.
    #[arg(long)]
    atlas: bool,
    /// Raw: sample type [default: u8].
    #[arg(long = "raw-type", value_enum, value_name = "TYPE")]
    raw_type: Option<crate::bake::RawSampleType>,
    /// Raw: add an opaque alpha channel (RGBA).
    #[arg(long)]
    alpha: bool,
    /// PNG, raw u8 and 8-bit KTX2: how colours are encoded in 8/16-bit files (scalars are always
    /// linear) [default: srgb].
    #[arg(long, value_enum, value_name = "TRANSFER")]
    transfer: Option<crate::bake::Transfer>,
    /// Evaluate with the f64 reference path (values still stored as f32 or less).
    #[arg(long = "f64")]
    double: bool,
    /// Where the voxels are evaluated: cpu, gpu (the tape compiled to a compute shader; every
    /// format and option as on the CPU; an error when no GPU is usable), or auto (the GPU when
    /// one is usable, else the CPU, saying which on stderr).
    #[arg(long, value_enum, default_value_t)]
    device: crate::gpu::Device,
    /// Prefiltered mip levels down to 1 voxel, each baked from the graph for its own voxels
    /// (box-filtered by default; with --filter point at the voxel centres with footprint level
    /// of detail for its spacing): KTX2 stores them in its file,
    /// zarr as OME-Zarr multiscales (a group per output, an array per level), PNG, EXR and raw
    /// in level folders OUT/mip0, OUT/mip1, ...
    #[arg(long)]
    mips: bool,
    /// What each voxel stores: point (the graph at its centre) or box (the estimate of the
    /// graph's mean over its cell, docs/filtering.md; on the GPU for the graphs its filtered
    /// form covers, docs/gpu.md) [default: point; box with --mips, every level the mean over
    /// its own voxels, unless --device gpu].
    #[arg(long, value_enum, value_name = "point|box")]
    filter: Option<FilterArg>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
    /// Level of detail from the voxel size: leave out fbm octaves finer than the grid resolves
    /// (the spacing is the smallest voxel side; --spacing overrides it).
    #[arg(long)]
    lod: bool,
    /// Bake even if the files would exceed the 16 GiB size limit, or the format would hold more
    /// than 2 GiB in memory (EXR: the whole volume; PNG atlas: a row of tiles; KTX2 --zstd: the
    /// encoders' tables).
    #[arg(long = "allow-large")]
    allow_large: bool,
    #[command(flatten)]
    mesh: mesh::MeshArgs,
    #[command(flatten)]
    graph: GraphOptions,
}

/// `--filter`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FilterArg {
    Point,
    Box,
}

impl BakeArgs {
    /// What a mesh bake (or a flat bake's normal map) reads of the command line, with the
    /// volume-only options that were given.
    fn mesh_request(&self) -> mesh::Request<'_> {
        let volume_only = [
            (self.region.is_some(), "--region"),
            (self.part.is_some(), "--part"),
            (self.parts.is_some(), "--parts"),
            (self.mips, "--mips"),
            (self.atlas, "--atlas"),
            (self.chunk.is_some(), "--chunk"),
            (self.shard.is_some(), "--shard"),
            (self.compression.is_some(), "--compression"),
            (self.zstd.is_some(), "--zstd"),
            (self.half, "--half"),
            (self.float, "--float"),
            (self.raw_type.is_some(), "--raw-type"),
            (self.alpha, "--alpha"),
            (self.exr_compression.is_some(), "--exr-compression"),
            (self.lod, "--lod"),
            (self.graph.spacing.is_some(), "--spacing"),
        ];
        mesh::Request {
            files: &self.files,
            size: self.size,
            format: self.format,
            out: &self.out,
            force: self.force,
            threads: self.threads,
            double: self.double,
            depth: self.depth,
            transfer: self.transfer,
            device: self.device,
            filter: self.filter(),
            allow_large: self.allow_large,
            graph: &self.graph,
            volume_only: volume_only
                .into_iter()
                .filter_map(|(given, flag)| given.then_some(flag))
                .collect(),
            mesh: &self.mesh,
        }
    }

    /// The filter this bake uses: `--filter`, else point (docs/baking.md says why).
    /// Box when asked for, and by default with `--mips` (every level its voxels' means)
    /// unless the GPU is asked for (its filtered form does not cover every graph yet: an
    /// explicit `--filter box` asks for it); else point.
    fn filter(&self) -> crate::filter::Filter {
        match self.filter {
            Some(FilterArg::Box) => crate::filter::Filter::Box,
            Some(FilterArg::Point) => crate::filter::Filter::Point,
            None if self.mips && self.device != crate::gpu::Device::Gpu => {
                crate::filter::Filter::Box
            }
            None => crate::filter::Filter::Point,
        }
    }
}

pub fn parse_depth(text: &str) -> Result<u8, String> {
    match text.trim() {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!("PNG depth is 8 or 16, found `{text}`")),
    }
}

pub fn parse_size(text: &str) -> Result<super::SizeArg, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let numbers: Result<Vec<usize>, _> = parts.iter().map(|p| p.parse::<usize>()).collect();
    match numbers.as_deref() {
        Ok([n]) if *n > 0 => Ok(super::SizeArg {
            dims: [*n; 3],
            given: 1,
        }),
        Ok([w, h]) if *w > 0 && *h > 0 => Ok(super::SizeArg {
            dims: [*w, *h, 0],
            given: 2,
        }),
        Ok([x, y, z]) if *x > 0 && *y > 0 && *z > 0 => Ok(super::SizeArg {
            dims: [*x, *y, *z],
            given: 3,
        }),
        _ => Err(format!(
            "expected N or NX,NY,NZ (with --mesh: W or W,H) with positive integers, found `{text}`"
        )),
    }
}

/// Options given that do not apply to the chosen format: each a usage error, not ignored.
pub fn bake_option_misuse(args: &BakeArgs) -> Vec<String> {
    use crate::bake::{Format, RawSampleType};
    let format = args.format;
    let name = format.name();
    let mut problems = Vec::new();
    let mut only = |given: bool, option: &str, applies: bool, to: &str| {
        if given && !applies {
            problems.push(format!(
                "{option} applies to {to} only, not to --format {name}"
            ));
        }
    };
    only(
        args.half,
        "--half",
        matches!(format, Format::Exr | Format::Ktx2 | Format::Zarr),
        "--format exr, ktx2 or zarr",
    );
    only(
        args.float,
        "--float",
        matches!(format, Format::Ktx2 | Format::Zarr),
        "--format ktx2 or zarr",
    );
    only(
        args.zstd.is_some(),
        "--zstd",
        format == Format::Ktx2
            || (format == Format::Zarr
                && args.compression.unwrap_or_default() == crate::bake::ZarrCompression::Zstd),
        "--format ktx2 and --format zarr with --compression zstd",
    );
    for (given, option) in [
        (args.chunk.is_some(), "--chunk"),
        (args.shard.is_some(), "--shard"),
        (args.compression.is_some(), "--compression"),
    ] {
        only(given, option, format == Format::Zarr, "--format zarr");
    }
    only(
        args.exr_compression.is_some(),
        "--exr-compression",
        format == Format::Exr,
        "--format exr",
    );
    only(
        args.depth.is_some(),
        "--depth",
        format == Format::Png,
        "--format png",
    );
    only(args.atlas, "--atlas", format == Format::Png, "--format png");
    only(
        args.raw_type.is_some(),
        "--raw-type",
        format == Format::Raw,
        "--format raw",
    );
    only(args.alpha, "--alpha", format == Format::Raw, "--format raw");
    let eight_bit = format == Format::Png
        || (format == Format::Raw && args.raw_type.unwrap_or_default() == RawSampleType::U8)
        || (matches!(format, Format::Ktx2 | Format::Zarr) && !args.half && !args.float);
    only(
        args.transfer.is_some(),
        "--transfer",
        eight_bit,
        "8/16-bit files (--format png, --format raw with --raw-type u8, --format ktx2 or zarr without --half or --float)",
    );
    if args.filter == Some(FilterArg::Box) && (args.lod || args.graph.spacing.is_some()) {
        problems.push("--filter box fades every octave by the voxel's own footprint; --lod and --spacing do not apply".into());
    }
    if args.mips && (args.lod || args.graph.spacing.is_some()) {
        problems.push("--mips bakes every level with the footprint of its own voxels; --lod and --spacing do not apply".into());
    }
    if args.parts.is_some() && args.part.as_deref() != Some("auto") {
        problems.push("--parts N goes with --part auto (a Kubernetes Indexed Job)".into());
    }
    if args.part.is_some() && args.files.len() == 1 && format != Format::Zarr {
        problems.push(format!("--part splits a zarr store's shards or a list of several graph files; one graph file baked to --format {name} is one job"));
    }
    if format == Format::Zarr
        && args.files.len() > 1
        && args
            .out
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
    {
        problems.push(format!("{} names one zarr store, but {} graph files each bake a store of their own: give --out a folder (each graph gets FOLDER/STEM.zarr)", args.out.display(), args.files.len()));
    }
    // `--zstd 5` reads 5 as a file (the level needs `=`): say so rather than "no such file".
    if args.zstd.is_some() {
        for file in &args.files {
            let text = file.to_string_lossy();
            let level = text.parse::<i32>().ok();
            if level.is_some_and(|l| crate::bake::ZSTD_LEVELS.contains(&l)) && !file.exists() {
                problems.push(format!(
                    "`{text}` is not a graph file; give the Zstandard level with `=`: --zstd={text}"
                ));
            }
        }
    }
    if matches!(format, Format::Ktx2 | Format::Zarr) && args.half && args.float {
        problems
            .push("--half and --float are alternatives (16- or 32-bit floats): give one".into());
    }
    problems
}

pub fn bake(args: BakeArgs) -> Result<(), Failure> {
    if args.mesh.mesh.is_some() {
        return mesh::bake_mesh(&args.mesh_request());
    }
    let mut misuse = bake_option_misuse(&args);
    misuse.extend(args.mesh.volume_misuse(
        args.size,
        args.format,
        args.mips || args.part.is_some(),
    ));
    misuse.extend(args.mesh.normal_misuse());
    if !misuse.is_empty() {
        for problem in misuse {
            eprintln!("error: {problem}");
        }
        return Err(Failure::Usage);
    }
    let (files, shard_part) = this_part(&args)?;
    let device = run_device(&args)?;
    let cancel = Arc::new(AtomicBool::new(false));
    {
        // Ctrl-C stops between windows; temporary files are removed and nothing is renamed
        // into place. A second Ctrl-C is left to the default (the flag is already set).
        let cancel = cancel.clone();
        let _ = ctrlc::set_handler(move || cancel.store(true, Ordering::Relaxed));
    }
    let (check_options, mut compile_options) = options(&args.graph);
    let grid = crate::bake::Grid {
        size: args.size.dims,
        region: args.region.unwrap_or_default(),
    };
    // Precision per instruction for the region the voxel centres lie in.
    compile_options.extent = Some(crate::precision::Extent::new(
        grid.region.min,
        grid.region.max,
    ));
    if args.lod && compile_options.spacing.is_none() {
        let spacing = grid.spacing().into_iter().fold(f64::INFINITY, f64::min);
        compile_options.spacing = (spacing > 0.0 && spacing.is_finite()).then_some(spacing);
    }
    let mut batch = Batch {
        args: &args,
        grid,
        check_options,
        compile_options,
        device,
        shard_part,
        cancel,
        threads: threads_or_warn(args.threads),
        show_progress: !args.quiet && std::io::stderr().is_terminal(),
        worst: None,
        totals: (0, 0.0, 0),
        produced: std::collections::HashSet::new(),
    };
    for file in &files {
        if let Err(failure) = batch.one(file) {
            batch.worst = Failure::worst(batch.worst, failure);
            if matches!(failure, Failure::Interrupted) {
                return Err(failure);
            }
        }
    }
    batch.summary(files.len())?;
    batch.worst.map_or(Ok(()), Err)
}

/// `--part`: the graph files this process bakes and the share of one file's zarr shards. Several
/// graph files: the part is a share of the sorted list, each file baked whole. One file: the
/// part is a share of its zarr store's shards.
fn this_part(args: &BakeArgs) -> Result<(Vec<PathBuf>, crate::bake::part::Part), Failure> {
    use crate::bake::part::Part;
    let part = match args.part.as_deref() {
        None => Ok(Part::WHOLE),
        Some("auto") => Part::from_env(args.parts, |name| std::env::var(name).ok()),
        Some(text) => Part::parse(text).map_err(|e| format!("--part: {e}")),
    }
    .map_err(|problem| {
        eprintln!("error: {problem}");
        Failure::Usage
    })?;
    if args.files.len() == 1 {
        return Ok((args.files.clone(), part));
    }
    let mut sorted = args.files.clone();
    sorted.sort();
    let mine: Vec<PathBuf> = sorted
        .into_iter()
        .enumerate()
        .filter(|(i, _)| part.owns(*i as u64))
        .map(|(_, f)| f)
        .collect();
    if !part.is_whole() {
        eprintln!(
            "part {part}: {} of the {} graph files",
            mine.len(),
            args.files.len()
        );
    }
    Ok((mine, Part::WHOLE))
}

/// `--device` for the whole run: `gpu` needs a usable adapter (else a usage error), `auto`
/// looks for one once (saying what it found). Which device bakes each graph is then
/// `crate::bake::choose_device`'s per graph, as in every sink.
fn run_device(args: &BakeArgs) -> Result<crate::gpu::Device, Failure> {
    use crate::gpu::Device;
    match (
        args.device,
        super::resolve_device(args.device, args.double)?,
    ) {
        // A usable GPU under `auto`: each graph still falls back to the CPU where the GPU
        // cannot run it (said per graph).
        (Device::Auto, Device::Gpu) => Ok(Device::Auto),
        (_, resolved) => Ok(resolved),
    }
}

/// One `bake` run over its graph files: the settings they share and what the run has done.
struct Batch<'a> {
    args: &'a BakeArgs,
    grid: crate::bake::Grid,
    check_options: crate::check::CheckOptions,
    compile_options: crate::compile::CompileOptions,
    device: crate::gpu::Device,
    shard_part: crate::bake::part::Part,
    cancel: Arc<AtomicBool>,
    threads: usize,
    show_progress: bool,
    /// The worst failure so far (the exit code of a batch).
    worst: Option<Failure>,
    /// Voxels, seconds and graphs baked.
    totals: (u64, f64, usize),
    /// Every file written so far (two graphs of one name would write the same files).
    produced: std::collections::HashSet<PathBuf>,
}

impl Batch<'_> {
    /// Bakes one graph file: its errors are printed here; `Err` says how it failed.
    fn one(&mut self, file: &Path) -> Result<(), Failure> {
        use crate::bake::{BakeError, BakeOptions, Precision};
        let args = self.args;
        let (graph, tape) =
            crate::load::load_tape(file, &self.check_options, &self.compile_options)
                .map_err(print_load_error)?;
        let refused = |error: BakeError| {
            eprintln!("error: {}: {error}", file.display());
            Failure::from_exit_code(error.exit_code())
        };
        // A flat bake's normal map: its gradient compiled (and refused) before any work.
        let gradient = match &args.mesh.normal {
            Some(height) => Some(mesh::gradient_tape(
                file,
                &graph,
                height,
                &self.compile_options,
            )?),
            None => None,
        };
        // The device as every sink decides it: `--device gpu` that cannot run this graph is an
        // error, `auto` says when it bakes on the CPU.
        let choice = crate::bake::choose_device(&tape, self.device, args.filter(), args.double)
            .map_err(|why| refused(BakeError::Refused(why)))?;
        if let Some(note) = &choice.note {
            eprintln!("texgraph: {}: {note}", file.display());
        }
        let bake = BakeOptions {
            grid: self.grid,
            threads: self.threads,
            precision: if args.double {
                Precision::F64
            } else {
                Precision::F32
            },
            cancel: Some(self.cancel.clone()),
            device: choice.evaluator.device(),
            filter: args.filter(),
            replay: None,
        };
        let mut options = file_options(args, file, &graph.params, bake);
        options.zarr.part = self.shard_part;
        let planned = crate::bake::planned_outputs(&tape, &options).map_err(refused)?;
        if let Some(clash) = planned.iter().find(|p| self.produced.contains(*p)) {
            eprintln!("error: {}: {} was already written by an earlier graph of this batch (same file name); bake them into different --out folders", file.display(), clash.display());
            return Err(Failure::Usage);
        }
        if !args.double {
            warn_shortfalls(file, &tape);
        }
        let tapes = if args.mips {
            // Filtered levels fade every octave by their own voxels: no level of detail then.
            let lod = args.filter() == crate::filter::Filter::Point;
            mip_tapes(&graph, &self.compile_options, &self.grid, lod).map_err(print_load_error)?
        } else {
            vec![tape]
        };
        let reports = match self.run(file, &tapes, &options) {
            Ok(reports) => reports,
            Err(BakeError::Cancelled) => {
                eprintln!(
                    "error: {}: interrupted; no output was written",
                    file.display()
                );
                return Err(Failure::Interrupted);
            }
            Err(error) => return Err(refused(error)),
        };
        self.produced.extend(planned);
        self.totals.2 += 1;
        // One report per level folder (PNG, EXR, raw), else one for the whole chain.
        for (level, report) in reports.iter().enumerate() {
            self.totals.0 += report.voxels;
            self.totals.1 += report.seconds;
            let level_grid = crate::bake::mip_grid(&self.grid, level as u32);
            let clamps = eight_or_sixteen_bit(&options);
            let text = bake_report(file, &level_grid, report, self.threads, clamps);
            write_stdout(|out| out.write_all(text.as_bytes()))?;
            warn_about_values(file, report, clamps, options.format);
        }
        if let Some(gradient) = &gradient {
            mesh::flat_normal(
                &args.mesh_request(),
                file,
                gradient,
                &self.grid,
                &self.cancel,
            )?;
        }
        Ok(())
    }

    /// The bake of one graph's tapes (one, or a mip chain's), with a progress bar on a terminal.
    fn run(
        &self,
        file: &Path,
        tapes: &[crate::tape::Tape],
        options: &crate::bake::BakeFileOptions,
    ) -> Result<Vec<crate::bake::BakeReport>, crate::bake::BakeError> {
        let all_voxels = (0..tapes.len() as u32)
            .map(|l| {
                crate::bake::mip_grid(&self.grid, l)
                    .voxels()
                    .unwrap_or(u64::MAX)
            })
            .fold(0u64, u64::saturating_add);
        let bar = self.show_progress.then(|| progress_bar(file, all_voxels));
        let mut show = |done| {
            if let Some(bar) = &bar {
                bar.set_position(done);
            }
        };
        let result = if self.args.mips {
            crate::bake::bake_mipmapped(tapes, options, &mut show)
        } else {
            crate::bake::bake_files(&tapes[0], options, &mut show).map(|r| vec![r])
        };
        if let Some(bar) = &bar {
            bar.finish_and_clear();
        }
        result
    }

    /// The line after several graph files: how many baked, voxels and rate.
    fn summary(&self, files: usize) -> Result<(), Failure> {
        if files <= 1 {
            return Ok(());
        }
        let (total_voxels, total_seconds, baked) = self.totals;
        let failed = files - baked;
        let rate = if total_seconds > 0.0 {
            total_voxels as f64 / total_seconds / 1e6
        } else {
            0.0
        };
        let failed = if failed > 0 {
            format!("; {failed} failed")
        } else {
            String::new()
        };
        let line = format!("baked {baked} of {files} graphs: {total_voxels} voxels in {total_seconds:.3} s, {rate:.2} Mvoxels/s{failed}\n");
        write_stdout(|out| out.write_all(line.as_bytes()))
    }
}

/// The graph compiled for every level of `grid`'s mip chain, each with its level's footprint
/// (level of detail for its voxel size) when `lod`.
fn mip_tapes(
    graph: &crate::graph::CheckedGraph,
    compile_options: &crate::compile::CompileOptions,
    grid: &crate::grid::Grid,
    lod: bool,
) -> Result<Vec<crate::tape::Tape>, crate::source::LoadError> {
    (0..crate::bake::mip_level_count(grid))
        .map(|level| {
            let mut options = compile_options.clone();
            if lod {
                options.spacing = crate::bake::mip_spacing(grid, level);
            }
            crate::compile::compile(graph, &options).map_err(crate::source::LoadError::Invalid)
        })
        .collect()
}

/// The files hold 8/16-bit samples, so values outside [0, 1] are clamped.
fn eight_or_sixteen_bit(options: &crate::bake::BakeFileOptions) -> bool {
    use crate::bake::{Format, Ktx2SampleType, RawSampleType};
    match options.format {
        Format::Png => true,
        Format::Raw => options.raw_type == RawSampleType::U8,
        Format::Ktx2 | Format::Zarr => options.ktx2_type == Ktx2SampleType::U8,
        Format::Exr | Format::Vdb => false,
    }
}

/// The options of one graph's bake, from the command line.
fn file_options(
    args: &BakeArgs,
    file: &Path,
    params: &[(String, f64)],
    bake: crate::bake::BakeOptions,
) -> crate::bake::BakeFileOptions {
    let stem = file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("graph")
        .to_string();
    let mut options = crate::bake::BakeFileOptions::new(stem, &args.out);
    options.bake = bake;
    options.format = args.format;
    options.force = args.force;
    options.half = args.half;
    options.exr_compression = args.exr_compression.unwrap_or_default();
    options.depth16 = args.depth == Some(16);
    options.atlas = args.atlas;
    options.raw_type = args.raw_type.unwrap_or_default();
    options.alpha = args.alpha;
    options.ktx2_type = match (args.half, args.float) {
        (_, true) => crate::bake::Ktx2SampleType::F32,
        (true, false) => crate::bake::Ktx2SampleType::F16,
        (false, false) => crate::bake::Ktx2SampleType::U8,
    };
    options.zstd = args.zstd;
    options.zarr.chunk = args.chunk.unwrap_or(crate::bake::DEFAULT_CHUNK);
    options.zarr.shard = args.shard.unwrap_or(crate::bake::DEFAULT_SHARD);
    options.zarr.compression = args.compression.unwrap_or_default();
    options.transfer = args.transfer.unwrap_or_default();
    options.graph_path = file.display().to_string();
    options.params = params.to_vec();
    options.overrides = args.graph.sets.clone();
    if args.allow_large {
        options.max_bytes = u64::MAX;
        options.max_held_bytes = u64::MAX;
    }
    options
}

/// A progress bar on stderr for one graph's voxels.
fn progress_bar(file: &Path, voxels: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(voxels);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg} [{bar:30}] {percent:>3}% {human_pos}/{human_len} voxels, {eta} left",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar.set_message(file.display().to_string());
    bar
}

/// The per-graph report: files, statistics per output, and the speed line.
pub fn bake_report(
    file: &Path,
    grid: &crate::grid::Grid,
    report: &crate::bake::BakeReport,
    threads: usize,
    clamps: bool,
) -> String {
    let [nx, ny, nz] = grid.size;
    let (lo, hi) = (grid.region.min, grid.region.max);
    let mut text = format!(
        "{}: {nx}×{ny}×{nz} voxels over [{}, {}, {}]..[{}, {}, {}]\n",
        file.display(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2]
    );
    text.push_str(&report_body(report, clamps));
    let rate = if report.seconds > 0.0 {
        report.voxels as f64 / report.seconds / 1e6
    } else {
        0.0
    };
    let threads = crate::bake::capped_threads(threads).0;
    text.push_str(&format!(
        "  {} voxels in {:.3} s: {rate:.2} Mvoxels/s on {threads} thread(s)\n",
        report.voxels, report.seconds
    ));
    text
}
