//! Baking one graph to files: names, size limits, overwrite refusal, temporary files renamed into
//! place only when complete.
//!
//! Output names: `DIR/STEM.OUTPUT.exr`, `DIR/STEM.OUTPUT/zNNNN.png` (slices) or
//! `DIR/STEM.OUTPUT.png` (atlas), `DIR/STEM.OUTPUT.raw` with `DIR/STEM.OUTPUT.json`,
//! `DIR/STEM.OUTPUT.ktx2`. While a bake
//! runs, each goes to a hidden `.STEM.OUTPUT.*.partial` next to its final place; an interrupted
//! or failed bake removes it (or, if the process is killed, leaves only that hidden name behind,
//! which never looks finished).

use super::engine::{bake_into, OutputStats};
use super::error::BakeError;
use super::ktx2::{self, Ktx2Description, Ktx2Format, Ktx2Sink};
use super::settings::atlas_shape;
use super::settings::human_bytes;
use super::settings::mip_grid;
use super::settings::mip_level_count;
use super::settings::mips_note;
use super::settings::params_json;
use super::settings::params_map;
use super::settings::BakeFileOptions;
use super::settings::BakeReport;
use super::settings::BakedFile;
use super::settings::Format;
use super::settings::RawSampleType;
use super::settings::Transfer;
use super::sinks::{Exr, PngAtlas, PngSlices, Raw, RawSamples};
use super::window::{Sink, Window};
use crate::encoding::Encoding;
use crate::graph::Type;
use crate::grid::Grid;
use crate::output::{self, Expect};
use crate::tape::Tape;
use std::path::{Path, PathBuf};

impl BakeFileOptions {
    /// Bytes per voxel of one output in the chosen format (uncompressed).
    fn bytes_per_voxel(&self, ty: Type) -> u64 {
        let channels = ty.channels() as u64;
        match self.format {
            Format::Exr => channels * if self.half { 2 } else { 4 },
            Format::Png => channels * if self.depth16 { 2 } else { 1 },
            Format::Raw => {
                (channels + u64::from(self.alpha))
                    * if self.raw_type == RawSampleType::F32 {
                        4
                    } else {
                        1
                    }
            }
            Format::Ktx2 => u64::from(self.ktx2_format(ty).texel_bytes()),
            #[cfg(feature = "zarr")]
            Format::Zarr => channels * super::zarr::sample_type(self).bytes(),
            // Refused before anything is planned (`planned_outputs`): float32, the largest.
            #[cfg(not(feature = "zarr"))]
            Format::Zarr => channels * 4,
            Format::Vdb => channels * 4,
        }
    }

    /// The KTX2 format of an output of type `ty`.
    fn ktx2_format(&self, ty: Type) -> Ktx2Format {
        Ktx2Format::new(ty, self.ktx2_type, self.transfer == Transfer::Srgb)
    }
}

/// Why a build without the `zarr` feature bakes no zarr store.
#[cfg(not(feature = "zarr"))]
fn no_zarr() -> BakeError {
    BakeError::Refused(crate::diagnostic::without_feature("--format zarr", "zarr"))
}

/// The final path of each output's file (or slice folder), in output order. Each is a direct
/// child of the output folder: a name that would leave it is refused (the checker already
/// refuses such output names; this is the second line of defence).
pub fn planned_outputs(tape: &Tape, options: &BakeFileOptions) -> Result<Vec<PathBuf>, BakeError> {
    if options.format == Format::Zarr {
        #[cfg(feature = "zarr")]
        return Ok(vec![super::zarr::store_path(options)?]);
        #[cfg(not(feature = "zarr"))]
        return Err(no_zarr());
    }
    if options.format == Format::Vdb {
        let name = format!("{}.vdb", options.stem);
        return Ok(vec![output::join_inside(&options.out_dir, &name)?]);
    }
    tape.outputs
        .iter()
        .map(|o| {
            let base = format!("{}.{}", options.stem, o.name);
            let name = match options.format {
                Format::Exr => format!("{base}.exr"),
                Format::Png if options.atlas => format!("{base}.png"),
                Format::Png => base,
                Format::Raw => format!("{base}.raw"),
                Format::Ktx2 => format!("{base}.ktx2"),
                Format::Zarr | Format::Vdb => unreachable!("one store or file per graph"),
            };
            Ok(output::join_inside(&options.out_dir, &name)?)
        })
        .collect()
}

/// What a final destination must be if it exists: a folder for PNG slices, else a file.
fn expect(options: &BakeFileOptions) -> Expect {
    if options.format == Format::Png && !options.atlas {
        Expect::Folder
    } else {
        Expect::File
    }
}

fn sidecar_path(raw: &Path) -> PathBuf {
    raw.with_extension("json")
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> BakeError + '_ {
    move |source| BakeError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// One output's writer while the bake runs, with its temporary file or folder. (One per
/// output, never in a hot loop: the size difference between variants does not matter.)
#[allow(clippy::large_enum_variant)]
enum Pending {
    Ktx2 {
        sink: Ktx2Sink,
        temp: tempfile::NamedTempFile,
    },
    Exr {
        sink: Exr,
        temp: tempfile::NamedTempFile,
    },
    Slices {
        sink: PngSlices,
        temp: tempfile::TempDir,
    },
    Atlas {
        sink: PngAtlas,
        temp: tempfile::NamedTempFile,
    },
    Raw {
        sink: Raw,
        temp: tempfile::NamedTempFile,
    },
}

impl Pending {
    /// The temporary file or folder being written.
    fn temp_path(&self) -> &Path {
        match self {
            Pending::Exr { temp, .. }
            | Pending::Atlas { temp, .. }
            | Pending::Raw { temp, .. }
            | Pending::Ktx2 { temp, .. } => temp.path(),
            Pending::Slices { temp, .. } => temp.path(),
        }
    }

    fn sink_ref(&self) -> &dyn Sink {
        match self {
            Pending::Exr { sink, .. } => sink,
            Pending::Slices { sink, .. } => sink,
            Pending::Atlas { sink, .. } => sink,
            Pending::Raw { sink, .. } => sink,
            Pending::Ktx2 { sink, .. } => sink,
        }
    }

    fn sink(&mut self) -> &mut dyn Sink {
        match self {
            Pending::Exr { sink, .. } => sink,
            Pending::Slices { sink, .. } => sink,
            Pending::Atlas { sink, .. } => sink,
            Pending::Raw { sink, .. } => sink,
            Pending::Ktx2 { sink, .. } => sink,
        }
    }
}

struct Fanout<'a>(&'a mut [Pending]);

impl Sink for Fanout<'_> {
    fn stores(&self, output: usize) -> Option<Encoding> {
        self.0.iter().find_map(|p| p.sink_ref().stores(output))
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        for pending in self.0.iter_mut() {
            pending.sink().window(window)?;
        }
        Ok(())
    }
}

/// An error met while writing a temporary names the file the user asked for (the temporary is
/// removed, and its random name means nothing to them), then the temporary:
/// `out/a.colour.raw (being written as out/.a.colour.raw.x1y2z3.partial): No space left on device`.
fn name_final_file(error: BakeError, temps: &[(PathBuf, PathBuf)]) -> BakeError {
    let rename = |path: String| -> String {
        for (temp, final_path) in temps {
            if let Ok(rest) = Path::new(&path).strip_prefix(temp) {
                let shown = if rest.as_os_str().is_empty() {
                    final_path.clone()
                } else {
                    final_path.join(rest)
                };
                return format!("{} (being written as {path})", shown.display());
            }
        }
        path
    };
    match error {
        BakeError::Io { path, source } => BakeError::Io {
            path: rename(path),
            source,
        },
        BakeError::Encode { path, message } => BakeError::Encode {
            path: rename(path),
            message,
        },
        other => other,
    }
}

fn temp_file(dir: &Path, final_path: &Path) -> Result<tempfile::NamedTempFile, BakeError> {
    output::temp_file(dir, final_path).map_err(io(dir))
}

/// Bakes every output of `tape` to files. Checks everything that can be checked first (sizes,
/// limits, existing files), then bakes into temporary files and renames them into place only
/// when all of them are complete. On any error (or cancellation) no final file is created or
/// replaced.
pub fn bake_files(
    tape: &Tape,
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    if options.format == Format::Zarr {
        // A store is written in place, shard by shard, each shard atomically (zarr.rs).
        validate_grid(&options.bake.grid)?;
        #[cfg(feature = "zarr")]
        {
            super::zarr::preflight(tape, options)?;
            return super::zarr::bake_zarr(tape, options, progress);
        }
        #[cfg(not(feature = "zarr"))]
        return Err(no_zarr());
    }
    if options.format == Format::Vdb {
        let (finals, _) = preflight(tape, options)?;
        return super::vdb_bake::bake_vdb(tape, options, &finals[0], progress);
    }
    if options.levels > 1 {
        return Err(BakeError::Refused(
            "internal: a mip chain is baked by bake_mipmapped".into(),
        ));
    }
    bake_checked(&[tape], options, progress)
}

/// Bakes a mip chain: `tapes[L]` is the graph compiled for level L's footprint
/// ([`mip_spacing`](super::settings::mip_spacing)), level 0 first. KTX2 writes one file holding every level; PNG, EXR and raw
/// write each level into its own folder `OUT/mipL/` (named as a bake of that level alone);
/// zarr writes an OME-Zarr multiscale group per output. Every level is checked before any is
/// baked. Returns one report per file set (one for KTX2 and zarr, one per level otherwise).
pub fn bake_mipmapped(
    tapes: &[Tape],
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<Vec<BakeReport>, BakeError> {
    let grid = options.bake.grid;
    validate_grid(&grid)?;
    let most = mip_level_count(&grid);
    if tapes.is_empty() || tapes.len() as u32 > most {
        return Err(BakeError::Refused(format!(
            "a grid of {:?} voxels has 1 to {most} mip levels, not {}",
            grid.size,
            tapes.len()
        )));
    }
    let mut options = options.clone();
    options.levels = tapes.len() as u32;
    let refs: Vec<&Tape> = tapes.iter().collect();
    match options.format {
        Format::Ktx2 => Ok(vec![bake_checked(&refs, &options, progress)?]),
        Format::Vdb => Err(BakeError::Refused(
            "--mips applies to --format ktx2, zarr, png, exr and raw; an OpenVDB grid has no mip levels".into(),
        )),
        #[cfg(feature = "zarr")]
        Format::Zarr => {
            super::zarr::preflight(&tapes[0], &options)?;
            Ok(vec![super::zarr::bake_zarr_levels(
                &refs, &options, progress,
            )?])
        }
        #[cfg(not(feature = "zarr"))]
        Format::Zarr => Err(no_zarr()),
        Format::Png | Format::Exr | Format::Raw => {
            let level_options: Vec<BakeFileOptions> = (0..options.levels)
                .map(|level| {
                    let mut o = options.clone();
                    o.levels = 1;
                    o.bake.grid = mip_grid(&grid, level);
                    o.out_dir = options.out_dir.join(format!("mip{level}"));
                    o
                })
                .collect();
            output::check_out_folder(&options.out_dir)?;
            for (tape, o) in tapes.iter().zip(&level_options) {
                preflight(tape, o)?;
            }
            let mut done = 0u64;
            let mut reports = Vec::with_capacity(tapes.len());
            for (tape, o) in tapes.iter().zip(&level_options) {
                let before = done;
                let report = bake_files(tape, o, &mut |v| progress(before + v))?;
                done += report.voxels;
                reports.push(report);
            }
            Ok(reports)
        }
    }
}

/// [`bake_files`] after the format dispatch, for one level or (KTX2) a mip chain.
fn bake_checked(
    tapes: &[&Tape],
    options: &BakeFileOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    let (finals, _) = preflight(tapes[0], options)?;
    let created_out_dir = !options.out_dir.exists();
    std::fs::create_dir_all(&options.out_dir).map_err(io(&options.out_dir))?;
    let result = bake_into_files(tapes, options, &finals, progress);
    if result.is_err() && created_out_dir {
        // Leave no trace of a bake that did not happen (only if the folder is still empty).
        let _ = std::fs::remove_dir(&options.out_dir);
    }
    result
}

/// Everything checked before a bake starts: the grid, the size on disk, what the format must
/// hold in memory, the format's dimension limits, and every destination. Returns the final
/// paths and the voxel count.
fn preflight(tape: &Tape, options: &BakeFileOptions) -> Result<(Vec<PathBuf>, u64), BakeError> {
    let grid = options.bake.grid;
    validate_grid(&grid)?;
    let voxels = grid
        .voxels()
        .ok_or_else(|| BakeError::Refused("the grid has too many voxels to count".into()))?;
    let estimate: u64 = tape
        .outputs
        .iter()
        .map(|o| voxels.saturating_mul(options.bytes_per_voxel(o.ty)))
        .fold(0u64, |a, b| a.saturating_add(b));
    if estimate > options.max_bytes {
        return Err(BakeError::Refused(format!(
            "the bake would write about {} ({} voxels × {} output(s)), more than the limit of {}; raise the limit to bake it anyway (the command line's --allow-large)",
            human_bytes(estimate),
            voxels,
            tape.outputs.len(),
            human_bytes(options.max_bytes)
        )));
    }
    check_dimensions(&grid, options)?;
    let held = held_bytes(tape, options);
    if held > options.max_held_bytes {
        let (why, instead) = match options.format {
            Format::Exr => (
                "an EXR file is written from the whole volume, held in memory",
                "bake --format raw (streamed)",
            ),
            Format::Png if options.atlas => (
                "a PNG atlas holds one row of tiles in memory",
                "bake --format raw (streamed)",
            ),
            Format::Ktx2 => (
                "a KTX2 file's Zstandard encoder holds its window and match tables in memory, one encoder per output",
                "use a lower --zstd level",
            ),
            Format::Vdb => (
                "a VDB file is written from the whole volume, held in memory",
                "bake --format zarr (chunked, streamed shard by shard)",
            ),
            _ => (
                "a PNG slice is encoded a row at a time, two rows held in memory",
                "bake --format raw (streamed)",
            ),
        };
        return Err(BakeError::Refused(format!(
            "{why}: this bake would hold about {}, more than the limit of {}; {instead}, a smaller grid, or pass --allow-large",
            human_bytes(held),
            human_bytes(options.max_held_bytes)
        )));
    }
    output::check_out_folder(&options.out_dir)?;
    let finals = planned_outputs(tape, options)?;
    for path in &finals {
        output::check_destination(path, expect(options))?;
        if options.format == Format::Raw {
            output::check_destination(&sidecar_path(path), Expect::File)?;
        }
    }
    if !options.force {
        for path in &finals {
            let exists = std::fs::symlink_metadata(path).is_ok()
                || (options.format == Format::Raw
                    && std::fs::symlink_metadata(sidecar_path(path)).is_ok());
            if exists {
                return Err(BakeError::Refused(format!(
                    "{} exists; pass --force to overwrite it",
                    path.display()
                )));
            }
        }
    }
    Ok((finals, voxels))
}

/// Largest width or height of a PNG image (the PNG specification's 2^31 − 1) and of an EXR
/// image (OpenEXR stores coordinates as 32-bit signed integers).
const MAX_IMAGE_SIDE: u64 = i32::MAX as u64;

/// Refuses grids whose images the format cannot represent.
fn check_dimensions(grid: &Grid, options: &BakeFileOptions) -> Result<(), BakeError> {
    let [nx, ny, nz] = grid.size.map(|n| n as u64);
    let (what, width, height) = match options.format {
        Format::Raw | Format::Zarr => return Ok(()),
        Format::Vdb => {
            return super::vdb_bake::check_size(grid);
        }
        Format::Ktx2 => {
            let Some(size) = ktx2::texture_size(grid) else {
                return Err(BakeError::Refused(format!(
                    "a KTX2 texture would be {nx}×{ny}×{nz} texels; KTX2 stores each side as a 32-bit unsigned integer, at most {} (bake --format raw for any shape)",
                    u32::MAX
                )));
            };
            // Every level's byte length must fit the level index's 64 bits.
            for output in [Type::Scalar, Type::Vec3] {
                ktx2_description(options, options.ktx2_format(output), size, Vec::new())
                    .validate()
                    .map_err(BakeError::Refused)?;
            }
            return Ok(());
        }
        Format::Exr => ("an EXR image (slices stacked)", nx, ny.saturating_mul(nz)),
        Format::Png if options.atlas => {
            let (columns, rows) = atlas_shape(nz);
            (
                "a PNG atlas",
                columns.saturating_mul(nx),
                rows.saturating_mul(ny),
            )
        }
        Format::Png => ("a PNG slice", nx, ny),
    };
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        return Err(BakeError::Refused(format!(
            "{what} would be {width}×{height} pixels; the format allows at most {MAX_IMAGE_SIDE} a side (bake --format raw for any shape)"
        )));
    }
    Ok(())
}

/// Bytes the format's writers keep in memory beyond the bake's window, summed over outputs.
fn held_bytes(tape: &Tape, options: &BakeFileOptions) -> u64 {
    let grid = options.bake.grid;
    let [nx, ny, nz] = grid.size.map(|n| n as u64);
    let voxels = grid.voxels().unwrap_or(u64::MAX);
    tape.outputs
        .iter()
        .map(|o| {
            let channels = o.ty.channels() as u64;
            let sample = if options.depth16 { 2 } else { 1 };
            match options.format {
                Format::Raw | Format::Zarr => 0,
                Format::Exr if options.half => voxels.saturating_mul(channels * 2),
                Format::Exr | Format::Vdb => voxels.saturating_mul(channels * 4),
                Format::Png if options.atlas => {
                    let (columns, _) = atlas_shape(nz);
                    (2 * columns)
                        .saturating_mul(nx)
                        .saturating_mul(ny)
                        .saturating_mul(channels * sample)
                }
                Format::Png => (2 * nx).saturating_mul(channels * sample),
                // Texels go through a buffered block; an encoder's state is the only large part.
                Format::Ktx2 => options.zstd.map_or(0, |level| {
                    let level_bytes =
                        voxels.saturating_mul(u64::from(options.ktx2_format(o.ty).texel_bytes()));
                    ktx2::zstd_encoder_bytes(level, level_bytes)
                }),
            }
        })
        .fold(0, u64::saturating_add)
}

/// One writer per output, each on its hidden temporary next to its final path.
fn open_pending(
    tape: &Tape,
    options: &BakeFileOptions,
    finals: &[PathBuf],
) -> Result<Vec<Pending>, BakeError> {
    let grid = options.bake.grid;
    let srgb = options.transfer == Transfer::Srgb;
    let digits = grid.size[2].saturating_sub(1).to_string().len().max(4);
    let mut pending = Vec::with_capacity(finals.len());
    for (index, (output, final_path)) in tape.outputs.iter().zip(finals).enumerate() {
        pending.push(match options.format {
            Format::Zarr | Format::Vdb => unreachable!("zarr and vdb bakes are written apart"),
            Format::Ktx2 => {
                let temp = temp_file(&options.out_dir, final_path)?;
                let file = temp.reopen().map_err(io(temp.path()))?;
                let size = ktx2::texture_size(&grid).ok_or_else(|| {
                    BakeError::Refused(
                        "internal: a KTX2 side over 32 bits passed the checks".into(),
                    )
                })?;
                let description = ktx2_description(
                    options,
                    options.ktx2_format(output.ty),
                    size,
                    ktx2_key_values(&grid, options, &output.name),
                );
                let sink = Ktx2Sink::create(temp.path(), file, index, description)?;
                Pending::Ktx2 { sink, temp }
            }
            Format::Exr => Pending::Exr {
                sink: Exr {
                    output: index,
                    ty: output.ty,
                    half: options.half,
                    data: Vec::new(),
                    halves: Vec::new(),
                    scratch: Vec::new(),
                },
                temp: temp_file(&options.out_dir, final_path)?,
            },
            Format::Png if options.atlas => {
                let temp = temp_file(&options.out_dir, final_path)?;
                let file = temp.reopen().map_err(io(temp.path()))?;
                let sink = PngAtlas::create(
                    temp.path(),
                    file,
                    &grid,
                    index,
                    output.ty,
                    options.depth16,
                    srgb,
                )?;
                Pending::Atlas { sink, temp }
            }
            Format::Png => {
                let temp =
                    output::temp_dir(&options.out_dir, final_path).map_err(io(&options.out_dir))?;
                let sink = PngSlices {
                    folder: temp.path().to_path_buf(),
                    output: index,
                    ty: output.ty,
                    depth16: options.depth16,
                    srgb,
                    digits,
                    open: None,
                };
                Pending::Slices { sink, temp }
            }
            Format::Raw => {
                let temp = temp_file(&options.out_dir, final_path)?;
                let file = temp.reopen().map_err(io(temp.path()))?;
                let samples = match options.raw_type {
                    RawSampleType::U8 => RawSamples::U8 {
                        srgb,
                        alpha: options.alpha,
                    },
                    RawSampleType::F32 => RawSamples::F32 {
                        alpha: options.alpha,
                    },
                };
                let sink = Raw {
                    path: temp.path().to_path_buf(),
                    writer: std::io::BufWriter::new(file),
                    output: index,
                    ty: output.ty,
                    samples,
                    bytes: Vec::new(),
                };
                Pending::Raw { sink, temp }
            }
        });
    }
    Ok(pending)
}

/// Bakes every level (`tapes[L]` over [`mip_grid`] L; one level without mips) into the
/// writers, the smallest level first (KTX2 stores them so). Returns level 0's statistics.
fn bake_levels(
    tapes: &[&Tape],
    options: &BakeFileOptions,
    pending: &mut [Pending],
    progress: &mut dyn FnMut(u64),
) -> Result<(Vec<OutputStats>, u64), BakeError> {
    let grid = options.bake.grid;
    let mut done = 0u64;
    let mut level0 = Vec::new();
    for (level, tape) in tapes.iter().enumerate().rev() {
        let mut bake = options.bake.clone();
        bake.grid = mip_grid(&grid, level as u32);
        let before = done;
        let stats = bake_into(tape, &bake, &mut Fanout(pending), &mut |v| {
            progress(before + v)
        })?;
        done += bake.grid.voxels().unwrap_or(0);
        if level > 0 {
            for p in pending.iter_mut() {
                if let Pending::Ktx2 { sink, .. } = p {
                    sink.next_level()?;
                }
            }
        } else {
            level0 = stats;
        }
    }
    Ok((level0, done))
}

fn bake_into_files(
    tapes: &[&Tape],
    options: &BakeFileOptions,
    finals: &[PathBuf],
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    let grid = options.bake.grid;
    let tape = tapes[0];
    let mut pending = open_pending(tape, options, finals)?;

    let temps: Vec<(PathBuf, PathBuf)> = pending
        .iter()
        .zip(finals)
        .map(|(p, f)| (p.temp_path().to_path_buf(), f.clone()))
        .collect();
    let started = std::time::Instant::now();
    let (stats, voxels) = bake_levels(tapes, options, &mut pending, progress)
        .map_err(|e| name_final_file(e, &temps))?;
    let seconds = started.elapsed().as_secs_f64();

    // Finish every temporary first; only then move them all into place, as one transaction.
    let finish = || -> Result<_, BakeError> {
        let mut staged: Vec<(Staged, PathBuf)> = Vec::with_capacity(pending.len() * 2);
        let mut files = Vec::with_capacity(pending.len());
        for ((entry, final_path), output) in pending.into_iter().zip(finals).zip(&tape.outputs) {
            let [nx, ny, nz] = grid.size;
            let kind = if output.ty == Type::Vec3 {
                "RGB"
            } else {
                "grey"
            };
            let bits = if options.depth16 { 16 } else { 8 };
            let description = match entry {
                Pending::Ktx2 { sink, temp } => {
                    sink.finish()?;
                    staged.push((Staged::File(temp.into_temp_path()), final_path.clone()));
                    let format = options.ktx2_format(output.ty);
                    let zstd = options
                        .zstd
                        .map_or(String::new(), |level| format!(", Zstandard level {level}"));
                    let mips = if options.levels > 1 {
                        format!(", {} mip levels baked from the graph", options.levels)
                    } else {
                        String::new()
                    };
                    format!("KTX2 3D texture {nx}×{ny}×{nz} {}{zstd}{mips}", format.name)
                }
                Pending::Exr { sink, temp } => {
                    let file = temp.reopen().map_err(io(temp.path()))?;
                    let attributes = exr_attributes(&grid, options, &output.name);
                    let attributes: Vec<(&str, String)> =
                        attributes.iter().map(|(k, v)| (*k, v.clone())).collect();
                    sink.write(
                        temp.path(),
                        file,
                        &grid,
                        options.exr_compression,
                        &attributes,
                    )?;
                    staged.push((Staged::File(temp.into_temp_path()), final_path.clone()));
                    let depth = if options.half { "f16" } else { "f32" };
                    format!(
                        "EXR {nx}×{ny}×{nz} {kind} {depth}, slices stacked ({} rows)",
                        ny * nz
                    )
                }
                Pending::Slices { temp, .. } => {
                    staged.push((Staged::Dir(temp), final_path.clone()));
                    format!("{nz} PNG slices {nx}×{ny} {kind} {bits}-bit")
                }
                Pending::Atlas { sink, temp } => {
                    let columns = sink.columns;
                    sink.finish(&grid)?;
                    staged.push((Staged::File(temp.into_temp_path()), final_path.clone()));
                    format!("PNG atlas of {nz} slices, {columns} per row, {kind} {bits}-bit")
                }
                Pending::Raw { mut sink, temp } => {
                    use std::io::Write;
                    sink.writer.flush().map_err(io(temp.path()))?;
                    sink.writer.get_ref().sync_all().map_err(io(temp.path()))?;
                    let sidecar = raw_sidecar(&grid, options, output, &stats, final_path);
                    let sidecar_temp = temp_file(&options.out_dir, &sidecar_path(final_path))?;
                    std::fs::write(sidecar_temp.path(), sidecar)
                        .map_err(io(sidecar_temp.path()))?;
                    // The volume first, its sidecar after: a sidecar marks a complete volume.
                    staged.push((Staged::File(temp.into_temp_path()), final_path.clone()));
                    staged.push((
                        Staged::File(sidecar_temp.into_temp_path()),
                        sidecar_path(final_path),
                    ));
                    let sample = match options.raw_type {
                        RawSampleType::U8 => "u8",
                        RawSampleType::F32 => "f32",
                    };
                    let channels = output.ty.channels() + usize::from(options.alpha);
                    format!("raw {nx}×{ny}×{nz} × {channels} {sample}, x fastest (+ .json sidecar)")
                }
            };
            files.push(BakedFile {
                output: output.name.clone(),
                path: final_path.clone(),
                description,
            });
        }
        Ok((staged, files))
    };
    let (staged, files) = finish().map_err(|e| name_final_file(e, &temps))?;
    commit(staged, &options.out_dir)?;
    Ok(BakeReport {
        files,
        stats,
        voxels,
        seconds,
    })
}

/// A finished temporary, waiting to be moved into place (deleted if dropped).
enum Staged {
    File(tempfile::TempPath),
    Dir(tempfile::TempDir),
}

/// Moves finished temporary files to their final paths in `out_dir`, all or nothing (as a
/// bake's files): a texture set's images and asset.
pub fn commit_files(
    files: Vec<(tempfile::TempPath, PathBuf)>,
    out_dir: &Path,
) -> Result<(), BakeError> {
    let staged = files
        .into_iter()
        .map(|(temp, path)| (Staged::File(temp), path))
        .collect();
    commit(staged, out_dir)
}

/// Moves every staged temporary to its final path, all or nothing: existing finals are moved
/// aside first; if any move fails, the ones already made are undone and the old files put back.
fn commit(staged: Vec<(Staged, PathBuf)>, out_dir: &Path) -> Result<(), BakeError> {
    let aside_dir = tempfile::Builder::new()
        .prefix(".replaced.")
        .tempdir_in(out_dir)
        .map_err(io(out_dir))?;
    let mut moved_aside: Vec<(PathBuf, PathBuf)> = Vec::new();
    let mut placed: Vec<PathBuf> = Vec::new();
    let undo = |placed: &[PathBuf], moved_aside: &[(PathBuf, PathBuf)]| {
        for path in placed {
            let _ = if path.is_dir() {
                std::fs::remove_dir_all(path)
            } else {
                std::fs::remove_file(path)
            };
        }
        for (final_path, aside) in moved_aside {
            let _ = std::fs::rename(aside, final_path);
        }
    };
    // The destinations were checked before the bake; check again right before replacing them.
    for (entry, final_path) in &staged {
        let expect = match entry {
            Staged::File(_) => Expect::File,
            Staged::Dir(_) => Expect::Folder,
        };
        output::check_destination(final_path, expect)?;
    }
    for (index, (_, final_path)) in staged.iter().enumerate() {
        if std::fs::symlink_metadata(final_path).is_ok() {
            let aside = aside_dir.path().join(index.to_string());
            if let Err(e) = std::fs::rename(final_path, &aside) {
                undo(&placed, &moved_aside);
                return Err(BakeError::Io {
                    path: final_path.display().to_string(),
                    source: e,
                });
            }
            moved_aside.push((final_path.clone(), aside));
        }
    }
    for (entry, final_path) in staged {
        let result = match entry {
            Staged::File(temp) => temp.persist(&final_path).map_err(|e| e.error),
            Staged::Dir(temp) => {
                let temp_path = temp.keep();
                std::fs::rename(&temp_path, &final_path).inspect_err(|_| {
                    let _ = std::fs::remove_dir_all(&temp_path);
                })
            }
        };
        if let Err(e) = result {
            undo(&placed, &moved_aside);
            return Err(BakeError::Io {
                path: final_path.display().to_string(),
                source: e,
            });
        }
        placed.push(final_path);
    }
    drop(aside_dir); // deletes what was replaced
    Ok(())
}

/// The checks every bake makes of its grid first: no zero dimension, each region axis a finite
/// interval.
pub fn validate_grid(grid: &Grid) -> Result<(), BakeError> {
    if grid.size.contains(&0) {
        return Err(BakeError::Refused(format!(
            "the grid size {:?} has a zero dimension",
            grid.size
        )));
    }
    for axis in 0..3 {
        let (lo, hi) = (grid.region.min[axis], grid.region.max[axis]);
        if !lo.is_finite() || !hi.is_finite() || lo > hi {
            return Err(BakeError::Refused(format!(
                "the region's {} range [{lo}, {hi}] is not a finite interval",
                ["x", "y", "z"][axis]
            )));
        }
    }
    Ok(())
}

fn exr_attributes(
    grid: &Grid,
    options: &BakeFileOptions,
    output: &str,
) -> Vec<(&'static str, String)> {
    vec![
        ("size", format!("{} {} {}", grid.size[0], grid.size[1], grid.size[2])),
        ("region", format!("{} {} {} : {} {} {}", grid.region.min[0], grid.region.min[1], grid.region.min[2], grid.region.max[0], grid.region.max[1], grid.region.max[2])),
        ("layout", "slices stacked: row k*ny + j holds voxel row (j, k); voxel centres at min + (index + 0.5) * (max - min) / size".into()),
        ("graph", options.graph_path.clone()),
        ("params", params_json(&options.params)),
        ("overrides", params_json(&options.overrides)),
        ("compression", options.exr_compression.name().to_string()),
        ("output", output.to_string()),
        ("version", env!("CARGO_PKG_VERSION").to_string()),
    ]
}

/// What a KTX2 file of the bake holds besides its texels: its levels (1, or the mip chain), the
/// format of the output, supercompression, key/value pairs.
fn ktx2_description(
    options: &BakeFileOptions,
    format: Ktx2Format,
    size: [u32; 3],
    key_values: Vec<(String, String)>,
) -> Ktx2Description {
    Ktx2Description {
        format,
        size,
        levels: options.levels.max(1),
        zstd: options.zstd,
        key_values,
    }
}

/// The key/value data of a KTX2 file: the spec's `KTXorientation`, `KTXwriter` and (with
/// Zstandard) `KTXwriterScParams`, and texgraph's own keys (keys not starting with `KTX`/`ktx`
/// are free for applications).
fn ktx2_key_values(grid: &Grid, options: &BakeFileOptions, output: &str) -> Vec<(String, String)> {
    let mut pairs = vec![
        ("KTXorientation", ktx2::ORIENTATION.to_string()),
        (
            "KTXwriter",
            format!("texgraph {}", env!("CARGO_PKG_VERSION")),
        ),
        ("texgraph.graph", options.graph_path.clone()),
        ("texgraph.output", output.to_string()),
        ("texgraph.params", params_json(&options.params)),
        ("texgraph.overrides", params_json(&options.overrides)),
        (
            "texgraph.region",
            serde_json::to_string(&grid.region).unwrap_or_default(),
        ),
        (
            "texgraph.voxel_centre",
            "region.min + (index + 0.5) * (region.max - region.min) / size".to_string(),
        ),
    ];
    if let Some(level) = options.zstd {
        pairs.push(("KTXwriterScParams", format!("--zstd={level}")));
    }
    if options.levels > 1 {
        pairs.push(("texgraph.mips", mips_note(options.bake.filter).to_string()));
    }
    pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

fn raw_sidecar(
    grid: &Grid,
    options: &BakeFileOptions,
    output: &crate::tape::TapeOutput,
    stats: &[OutputStats],
    final_path: &Path,
) -> String {
    let channels: Vec<&str> = match (output.ty, options.alpha) {
        (Type::Vec3, false) => vec!["r", "g", "b"],
        (Type::Vec3, true) => vec!["r", "g", "b", "a"],
        (Type::Scalar, false) => vec!["value"],
        (Type::Scalar, true) => vec!["value", "a"],
    };
    let sample = match options.raw_type {
        RawSampleType::U8 => "u8",
        RawSampleType::F32 => "f32",
    };
    let transfer = match (options.raw_type, output.ty, options.transfer) {
        (RawSampleType::F32, _, _) => "none (values as evaluated)",
        (RawSampleType::U8, Type::Scalar, _) => "linear: clamp to [0, 1], x 255, round; NaN -> 0",
        (RawSampleType::U8, Type::Vec3, Transfer::Srgb) => {
            "srgb: clamp to [0, 1], sRGB transfer (IEC 61966-2-1), x 255, round; NaN -> 0"
        }
        (RawSampleType::U8, Type::Vec3, Transfer::Linear) => {
            "linear: clamp to [0, 1], x 255, round; NaN -> 0"
        }
    };
    let stats = stats.iter().find(|s| s.name == output.name);
    let json = serde_json::json!({
        "texgraph_version": env!("CARGO_PKG_VERSION"),
        "file": final_path.file_name().and_then(|n| n.to_str()).unwrap_or_default(),
        "graph": options.graph_path,
        "output": output.name,
        "size": grid.size,
        "region": grid.region,
        "voxel_centre": "region.min + (index + 0.5) * (region.max - region.min) / size",
        "layout": "x fastest, then y, then z; channels interleaved (glTexImage3D order)",
        "channels": channels,
        "type": sample,
        "byte_order": "little-endian",
        "transfer": transfer,
        "bytes": grid.voxels().unwrap_or(0) * (channels.len() as u64) * if sample == "f32" { 4 } else { 1 },
        "params": params_map(&options.params),
        "overrides": params_map(&options.overrides),
        "stats": stats,
    });
    serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_errors_name_the_final_file_then_the_temporary() {
        let temps = vec![
            (
                PathBuf::from("out/.a.v.raw.x1.partial"),
                PathBuf::from("out/a.v.raw"),
            ),
            (
                PathBuf::from("out/.a.c.x2.partial"),
                PathBuf::from("out/a.c"),
            ),
        ];
        let full =
            || std::io::Error::new(std::io::ErrorKind::StorageFull, "No space left on device");
        let file = name_final_file(
            BakeError::Io {
                path: "out/.a.v.raw.x1.partial".into(),
                source: full(),
            },
            &temps,
        );
        assert_eq!(
            file.to_string(),
            "out/a.v.raw (being written as out/.a.v.raw.x1.partial): No space left on device"
        );
        let slice = name_final_file(
            BakeError::Io {
                path: "out/.a.c.x2.partial/z0003.png".into(),
                source: full(),
            },
            &temps,
        );
        assert!(
            slice
                .to_string()
                .starts_with("out/a.c/z0003.png (being written as "),
            "{slice}"
        );
        // Other paths are left alone.
        let other = name_final_file(
            BakeError::Io {
                path: "out".into(),
                source: full(),
            },
            &temps,
        );
        assert_eq!(other.to_string(), "out: No space left on device");
    }

    /// A move that fails half-way through the commit undoes the moves already made and puts the
    /// replaced files back.
    #[test]
    fn a_failed_commit_is_undone() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        std::fs::write(out.join("a.raw"), b"old a").unwrap();
        let staged_file = |text: &[u8]| {
            let temp = tempfile::NamedTempFile::new_in(out).unwrap();
            std::fs::write(temp.path(), text).unwrap();
            Staged::File(temp.into_temp_path())
        };
        let staged = vec![
            (staged_file(b"new a"), out.join("a.raw")),
            (staged_file(b"new b"), out.join("b.raw")),
            // Its folder does not exist: this move fails.
            (staged_file(b"new c"), out.join("missing").join("c.raw")),
        ];
        assert!(commit(staged, out).is_err());
        assert_eq!(std::fs::read(out.join("a.raw")).unwrap(), b"old a");
        assert!(!out.join("b.raw").exists());
        let left: Vec<_> = std::fs::read_dir(out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(
            left,
            vec![std::ffi::OsString::from("a.raw")],
            "temporaries and the aside folder are gone"
        );
    }
}
