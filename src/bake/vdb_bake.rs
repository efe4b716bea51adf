//! `bake --format vdb`: the bake's voxels gathered per output, then written as one OpenVDB file
//! per graph by [`super::vdb`] (a grid per output, named by it), through a temporary renamed
//! into place. An OpenVDB file is written from whole grids, so the volume is held in memory:
//! `voxels × channels × 4` bytes, checked against the memory bound before the bake.

use super::error::BakeError;
use super::settings::{BakeFileOptions, BakeReport, BakedFile};
use super::vdb::{write_vdb, VdbGrid, VdbGridKind, MAX_AXIS_VOXELS};
use crate::graph::Type;
use crate::grid::Grid;
use crate::output;
use crate::tape::Tape;
use std::path::Path;

/// Refuses grids a VDB index space cannot hold (coordinates are 32-bit signed integers).
pub(super) fn check_size(grid: &Grid) -> Result<(), BakeError> {
    if grid.size.iter().any(|&n| n > MAX_AXIS_VOXELS) {
        return Err(BakeError::Refused(format!(
            "a VDB grid would be {:?} voxels; OpenVDB's index coordinates are 32-bit, at most {MAX_AXIS_VOXELS} a side",
            grid.size
        )));
    }
    Ok(())
}

/// Bakes `tape` and writes `path` (checked by the caller's preflight: size, memory bound,
/// destination).
pub(super) fn bake_vdb(
    tape: &Tape,
    options: &BakeFileOptions,
    path: &Path,
    progress: &mut dyn FnMut(u64),
) -> Result<BakeReport, BakeError> {
    let grid = options.bake.grid;
    let started = std::time::Instant::now();
    let volume = super::engine::bake_volume_with_progress(tape, &options.bake, progress)?;
    let voxels = grid.voxels().unwrap_or(u64::MAX);
    let spacing = grid.spacing();
    let origin = [0, 1, 2].map(|a| grid.centre(a, 0));
    let metadata: Vec<Vec<(String, String)>> = tape
        .outputs
        .iter()
        .map(|o| {
            vec![
                ("texgraph.graph".into(), options.graph_path.clone()),
                ("texgraph.output".into(), o.name.clone()),
                (
                    "texgraph.params".into(),
                    super::settings::params_json(&options.params),
                ),
                (
                    "texgraph.region".into(),
                    serde_json::to_string(&grid.region).unwrap_or_default(),
                ),
                (
                    "texgraph.voxel_centre".into(),
                    "index (i, j, k) samples region.min + (index + 0.5) * (region.max - region.min) / size".into(),
                ),
                ("texgraph.version".into(), env!("CARGO_PKG_VERSION").into()),
            ]
        })
        .collect();
    let grids: Vec<VdbGrid<'_>> = tape
        .outputs
        .iter()
        .zip(&volume.outputs)
        .zip(&metadata)
        .map(|((o, volume_output), metadata)| VdbGrid {
            name: &o.name,
            kind: if o.ty == Type::Vec3 {
                VdbGridKind::Vec3
            } else {
                VdbGridKind::Float
            },
            size: grid.size,
            values: &volume_output.data,
            voxel_size: spacing,
            origin,
            metadata,
        })
        .collect();
    if !options.out_dir.exists() {
        std::fs::create_dir_all(&options.out_dir).map_err(|e| BakeError::Io {
            path: options.out_dir.display().to_string(),
            source: e,
        })?;
    }
    output::write_atomic(path, |w| write_vdb(w, &grids))?;
    let seconds = started.elapsed().as_secs_f64();
    let [nx, ny, nz] = grid.size;
    let files = tape
        .outputs
        .iter()
        .map(|o| BakedFile {
            output: o.name.clone(),
            path: path.to_path_buf(),
            description: format!(
                "OpenVDB grid \"{}\" ({}) {nx}×{ny}×{nz}, voxel size {:?}",
                o.name,
                if o.ty == Type::Vec3 { "vec3s" } else { "float" },
                spacing
            ),
        })
        .collect();
    Ok(BakeReport {
        files,
        stats: volume.stats,
        voxels,
        seconds,
    })
}
