//! Sinks that write a bake's windows to files: EXR (whole volume, stacked slices), PNG (one file
//! per slice, or one atlas), raw (packed voxels). Each writes into a temporary file or folder;
//! `files.rs` renames it into place when the bake completed.

use super::engine::{BakeError, Sink, Window};
use crate::graph::Type;
use crate::grid::Grid;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The sRGB transfer function (IEC 61966-2-1): linear [0, 1] → encoded [0, 1].
#[inline]
pub fn srgb_encode(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// `x.round()` for `x` in [0, 2^24): half away from zero, without libm's `roundf` call (a
/// truncating conversion and one compare; ~8 % of an 8-bit bake's time went to `roundf`).
/// Exact: `x − trunc(x)` is computed without rounding for such `x` (Sterbenz), so the compare
/// with 0.5 decides exactly as `round` does.
#[inline]
fn round_non_negative(x: f32) -> u32 {
    let t = x as u32;
    t + u32::from(x - t as f32 >= 0.5)
}

/// Clamp to [0, 1] (NaN → 0), apply the transfer if asked, scale to 0..=255 and round.
#[inline]
pub fn encode_u8(v: f32, srgb: bool) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let v = if srgb { srgb_encode(v) } else { v };
    round_non_negative(v * 255.0).min(255) as u8
}

/// As [`encode_u8`], to 0..=65535.
#[inline]
pub fn encode_u16(v: f32, srgb: bool) -> u16 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let v = if srgb { srgb_encode(v) } else { v };
    round_non_negative(v * 65535.0).min(65535) as u16
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> BakeError + '_ {
    move |source| BakeError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// A PNG encoder for an output of type `ty`: RGB for colours (tagged sRGB when encoded so),
/// grey for scalars, 8 or 16 bits.
fn png_encoder<W: Write>(
    writer: W,
    width: usize,
    height: usize,
    ty: Type,
    depth16: bool,
    srgb: bool,
) -> png::Encoder<'static, W> {
    let mut encoder = png::Encoder::new(writer, width as u32, height as u32);
    // fdeflate's fast mode: several times faster than the default, files within ~10-20%.
    encoder.set_compression(png::Compression::Fast);
    encoder.set_color(if ty == Type::Vec3 {
        png::ColorType::Rgb
    } else {
        png::ColorType::Grayscale
    });
    encoder.set_depth(if depth16 {
        png::BitDepth::Sixteen
    } else {
        png::BitDepth::Eight
    });
    if srgb && ty == Type::Vec3 {
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    }
    encoder
}

/// Bytes of one PNG image: `samples` interleaved, `width` × `height`, 8 or 16 bits.
pub fn png_bytes(
    samples: &[f32],
    width: usize,
    height: usize,
    ty: Type,
    depth16: bool,
    srgb: bool,
) -> Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    {
        let encoder = png_encoder(&mut bytes, width, height, ty, depth16, srgb);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        writer
            .write_image_data(&encode_samples(samples, ty, depth16, srgb))
            .map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(bytes)
}

/// Samples to PNG sample bytes (16-bit big-endian). The transfer applies to colours only;
/// scalars are data, mapped linearly.
fn encode_samples(samples: &[f32], ty: Type, depth16: bool, srgb: bool) -> Vec<u8> {
    let srgb = srgb && ty == Type::Vec3;
    if depth16 {
        samples
            .iter()
            .flat_map(|&v| encode_u16(v, srgb).to_be_bytes())
            .collect()
    } else {
        samples.iter().map(|&v| encode_u8(v, srgb)).collect()
    }
}

/// One PNG per z slice, `z0000.png`, … in a folder. Windows of whole slices are encoded in
/// parallel, a slice at a time; a slice larger than a window is streamed through one PNG
/// encoder that stays open across windows (it keeps a row or two, not the slice).
pub(super) struct PngSlices {
    pub folder: PathBuf,
    pub output: usize,
    pub ty: Type,
    pub depth16: bool,
    pub srgb: bool,
    pub digits: usize,
    /// The slice being streamed, when slices span windows.
    pub open: Option<OpenSlice>,
}

/// A slice PNG being written across windows.
pub(super) struct OpenSlice {
    path: PathBuf,
    writer: png::StreamWriter<'static, std::io::BufWriter<std::fs::File>>,
}

impl PngSlices {
    fn slice_path(&self, k: usize) -> PathBuf {
        self.folder
            .join(format!("z{:0width$}.png", k, width = self.digits))
    }

    /// Streams the window's segments into the slice files they belong to.
    fn stream(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let [nx, ny, _] = window.grid.size;
        let mut samples = Vec::new();
        for (s, segment) in window.segments() {
            if segment.starts_slice() {
                let path = self.slice_path(segment.k);
                let file = std::fs::File::create(&path).map_err(io(&path))?;
                let encoder = png_encoder(
                    std::io::BufWriter::new(file),
                    nx,
                    ny,
                    self.ty,
                    self.depth16,
                    self.srgb,
                );
                let encode = |e: png::EncodingError| BakeError::Encode {
                    path: path.display().to_string(),
                    message: e.to_string(),
                };
                let writer = encoder
                    .write_header()
                    .map_err(encode)?
                    .into_stream_writer()
                    .map_err(encode)?;
                self.open = Some(OpenSlice { path, writer });
            }
            let Some(open) = self.open.as_mut() else {
                return Err(BakeError::Refused(
                    "internal: a PNG slice was continued before it was started".into(),
                ));
            };
            samples.clear();
            window.push_interleaved(self.output, s, &segment, &mut samples);
            let bytes = encode_samples(&samples, self.ty, self.depth16, self.srgb);
            open.writer.write_all(&bytes).map_err(io(&open.path))?;
            if segment.ends_slice(window.grid) {
                if let Some(open) = self.open.take() {
                    let path = open.path;
                    open.writer.finish().map_err(|e| BakeError::Encode {
                        path: path.display().to_string(),
                        message: e.to_string(),
                    })?;
                }
            }
        }
        Ok(())
    }
}

impl Sink for PngSlices {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let [nx, ny, _] = window.grid.size;
        let Some((z_start, depth)) = window.whole_slices() else {
            return self.stream(window);
        };
        // Slices of a window are independent files: encode them in parallel.
        (0..depth).into_par_iter().try_for_each(|k| {
            let mut samples = Vec::new();
            window.slice_interleaved(self.output, k, &mut samples);
            let path = self.slice_path(z_start + k);
            let bytes = png_bytes(&samples, nx, ny, self.ty, self.depth16, self.srgb).map_err(
                |message| BakeError::Encode {
                    path: path.display().to_string(),
                    message,
                },
            )?;
            std::fs::write(&path, bytes).map_err(io(&path))
        })
    }
}

/// All slices tiled into one PNG: `columns` tiles per row, row-major in z; streamed one row of
/// tiles at a time.
pub(super) struct PngAtlas {
    pub path: PathBuf,
    pub writer: png::StreamWriter<'static, std::fs::File>,
    /// A second handle on the file, to sync it once the encoder is done with it.
    pub file: std::fs::File,
    pub output: usize,
    pub ty: Type,
    pub depth16: bool,
    pub srgb: bool,
    pub columns: usize,
    /// Encoded bytes of the current row of tiles: `ny` image rows.
    pub pending: Vec<u8>,
    pub tiles_in_row: usize,
}

impl PngAtlas {
    pub fn create(
        path: &Path,
        file: std::fs::File,
        grid: &Grid,
        output: usize,
        ty: Type,
        depth16: bool,
        srgb: bool,
    ) -> Result<PngAtlas, BakeError> {
        let [nx, ny, nz] = grid.size;
        let (columns, rows) = super::settings::atlas_shape(nz as u64);
        let (columns, rows) = (columns as usize, rows as usize);
        let handle = file.try_clone().map_err(io(path))?;
        // Unbuffered: the png encoder writes whole compressed chunks, and a write error then
        // surfaces at once instead of in a buffer's drop.
        let encoder = png_encoder(file, columns * nx, rows * ny, ty, depth16, srgb);
        let encode_error = |e: png::EncodingError| BakeError::Encode {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let writer = encoder
            .write_header()
            .map_err(encode_error)?
            .into_stream_writer()
            .map_err(encode_error)?;
        Ok(PngAtlas {
            path: path.to_path_buf(),
            writer,
            file: handle,
            output,
            ty,
            depth16,
            srgb,
            columns,
            pending: Vec::new(),
            tiles_in_row: 0,
        })
    }

    fn bytes_per_pixel(&self) -> usize {
        self.ty.channels() * if self.depth16 { 2 } else { 1 }
    }

    fn flush_row(&mut self, grid: &Grid) -> Result<(), BakeError> {
        if self.tiles_in_row == 0 {
            return Ok(());
        }
        // Pad the row with black tiles, then stream its image rows.
        let [nx, ny, _] = grid.size;
        let tile_row_bytes = nx * self.bytes_per_pixel();
        let full = self.columns * tile_row_bytes * ny;
        let mut rows = vec![0u8; full];
        for t in 0..self.tiles_in_row {
            for j in 0..ny {
                let src = &self.pending[(t * ny + j) * tile_row_bytes..][..tile_row_bytes];
                rows[(j * self.columns + t) * tile_row_bytes..][..tile_row_bytes]
                    .copy_from_slice(src);
            }
        }
        self.writer.write_all(&rows).map_err(io(&self.path))?;
        self.pending.clear();
        self.tiles_in_row = 0;
        Ok(())
    }

    pub fn finish(mut self, grid: &Grid) -> Result<(), BakeError> {
        self.flush_row(grid)?;
        let path = self.path.clone();
        self.writer.finish().map_err(|e| BakeError::Encode {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        self.file.sync_all().map_err(io(&path))
    }
}

impl Sink for PngAtlas {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let mut samples = Vec::new();
        for (s, segment) in window.segments() {
            samples.clear();
            window.push_interleaved(self.output, s, &segment, &mut samples);
            self.pending
                .extend(encode_samples(&samples, self.ty, self.depth16, self.srgb));
            if segment.ends_slice(window.grid) {
                self.tiles_in_row += 1;
                if self.tiles_in_row == self.columns {
                    self.flush_row(window.grid)?;
                }
            }
        }
        Ok(())
    }
}

/// Sample type of a raw volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RawSamples {
    /// u8, sRGB-encoded colours when `srgb`, optional opaque alpha.
    U8 { srgb: bool, alpha: bool },
    /// f32 little-endian, optional alpha 1.0.
    F32 { alpha: bool },
}

/// Tightly packed voxels, x fastest, then y, then z, channels interleaved: streamed, a batch of
/// segments at a time (at most [`RAW_BATCH_VOXELS`] voxels), each batch gathered and encoded in
/// parallel, then written.
pub(super) struct Raw {
    pub path: PathBuf,
    pub writer: std::io::BufWriter<std::fs::File>,
    pub output: usize,
    pub ty: Type,
    pub samples: RawSamples,
    /// The batch's samples, channels interleaved.
    pub scratch: Vec<f32>,
    /// The batch's encoded bytes.
    pub bytes: Vec<u8>,
}

/// Most voxels a raw writer gathers and encodes at once (whole segments, which are at most
/// [`crate::grid::SEGMENT_VOXELS`] ≤ this). It holds them twice, as f32 samples and as encoded bytes:
/// at most 12 + 16 bytes a voxel, 7 MiB.
const RAW_BATCH_VOXELS: usize = 1 << 18;
/// Voxels per parallel encoding task.
const RAW_TASK_VOXELS: usize = 1 << 14;

impl RawSamples {
    /// Encoded bytes of one voxel of `width` channels.
    fn voxel_bytes(self, width: usize) -> usize {
        match self {
            RawSamples::U8 { alpha, .. } => width + usize::from(alpha),
            RawSamples::F32 { alpha } => 4 * (width + usize::from(alpha)),
        }
    }

    /// Encodes whole voxels of `ty` (`samples`, interleaved) into `out`, exactly their size.
    fn encode(self, ty: Type, samples: &[f32], out: &mut [u8]) {
        let width = ty.channels();
        let size = self.voxel_bytes(width);
        for (voxel, out) in samples.chunks_exact(width).zip(out.chunks_exact_mut(size)) {
            match self {
                RawSamples::U8 { srgb, alpha } => {
                    let srgb = srgb && ty == Type::Vec3;
                    for (o, &v) in out.iter_mut().zip(voxel) {
                        *o = encode_u8(v, srgb);
                    }
                    if alpha {
                        out[width] = 255;
                    }
                }
                RawSamples::F32 { alpha } => {
                    for (o, v) in out.chunks_exact_mut(4).zip(voxel) {
                        o.copy_from_slice(&v.to_le_bytes());
                    }
                    if alpha {
                        out[4 * width..].copy_from_slice(&1.0f32.to_le_bytes());
                    }
                }
            }
        }
    }
}

impl Sink for Raw {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let (grid, layout) = (window.grid, window.layout);
        let (samples, ty, output) = (self.samples, self.ty, self.output);
        let width = ty.channels();
        let size = samples.voxel_bytes(width);
        // Tasks: runs of whole segments, about RAW_TASK_VOXELS voxels (or one segment); batches
        // of tasks, at most RAW_BATCH_VOXELS voxels.
        let per_task = (RAW_TASK_VOXELS / layout.segment_len).max(1);
        let per_batch = (RAW_BATCH_VOXELS / layout.segment_len).max(per_task);
        let voxel = |s: usize| layout.voxels_before(grid, window.first_segment + s as u64) as usize;
        for batch in (0..window.segments).step_by(per_batch) {
            let batch_end = (batch + per_batch).min(window.segments);
            let voxels = voxel(batch_end) - voxel(batch);
            self.scratch.resize(voxels * width, 0.0);
            self.bytes.resize(voxels * size, 0);
            // Each task's segments and its share of the two buffers.
            let mut tasks = Vec::new();
            let (mut scratch, mut bytes) = (&mut self.scratch[..], &mut self.bytes[..]);
            for task in (batch..batch_end).step_by(per_task) {
                let task_end = (task + per_task).min(batch_end);
                let n = voxel(task_end) - voxel(task);
                let (task_samples, rest) = std::mem::take(&mut scratch).split_at_mut(n * width);
                scratch = rest;
                let (task_bytes, rest) = std::mem::take(&mut bytes).split_at_mut(n * size);
                bytes = rest;
                tasks.push((task..task_end, task_samples, task_bytes));
            }
            // Inside the bake's pool (sinks run there): gathered and encoded in parallel.
            tasks
                .into_par_iter()
                .for_each(|(segments, task_samples, task_bytes)| {
                    let mut at = 0;
                    for s in segments {
                        let segment = layout.segment(grid, window.first_segment + s as u64);
                        let n = segment.len * width;
                        window.copy_interleaved(output, s, &segment, &mut task_samples[at..at + n]);
                        at += n;
                    }
                    samples.encode(ty, task_samples, task_bytes);
                });
            self.writer.write_all(&self.bytes).map_err(io(&self.path))?;
        }
        Ok(())
    }
}

/// Collects the whole volume (the exr writer needs the complete image), then writes one EXR:
/// slices stacked vertically, `ny · nz` rows, row `k · ny + j` holding voxel row (j, k).
pub(super) struct Exr {
    pub output: usize,
    pub ty: Type,
    pub data: Vec<f32>,
}

impl Sink for Exr {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        for (s, segment) in window.segments() {
            window.push_interleaved(self.output, s, &segment, &mut self.data);
        }
        Ok(())
    }
}

/// Writes one `width` × `height` image (`data` interleaved, row-major) as a 32-bit float EXR
/// (zip-compressed) to `file` at `path`: a texture set's image.
pub fn write_exr_image(
    path: &Path,
    file: std::fs::File,
    data: Vec<f32>,
    ty: Type,
    [width, height]: [usize; 2],
    attributes: &[(&str, String)],
) -> Result<(), BakeError> {
    let grid = Grid {
        size: [width, height, 1],
        region: Default::default(),
    };
    let exr = Exr {
        output: 0,
        ty,
        data,
    };
    let zip = super::settings::ExrCompression::Zip;
    exr.write(path, file, &grid, false, zip, attributes)
}

impl Exr {
    /// Writes the EXR to `file` (32-bit float, or 16-bit half when `half`), with the grid in
    /// the header as custom attributes.
    pub fn write(
        &self,
        path: &Path,
        file: std::fs::File,
        grid: &Grid,
        half: bool,
        compression: super::settings::ExrCompression,
        attributes: &[(&str, String)],
    ) -> Result<(), BakeError> {
        use exr::prelude::*;
        let [nx, ny, nz] = grid.size;
        let size = (nx, ny * nz);
        let mut layer_attributes = LayerAttributes::named("texgraph");
        for (key, value) in attributes {
            layer_attributes.other.insert(
                Text::from(format!("texgraph:{key}").as_str()),
                AttributeValue::Text(Text::from(value.as_str())),
            );
        }
        let encode = |e: exr::error::Error| BakeError::Encode {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let writer = std::io::BufWriter::new(file);
        let data = &self.data;
        let encoding = match compression {
            super::settings::ExrCompression::Zip => Encoding::SMALL_LOSSLESS,
            super::settings::ExrCompression::Piz => Encoding::SMALL_FAST_LOSSLESS,
            super::settings::ExrCompression::Rle => Encoding::FAST_LOSSLESS,
            super::settings::ExrCompression::None => Encoding::UNCOMPRESSED,
        };
        // The four arms differ only in the channels' sample types, which exr encodes in the
        // channel set's type: one macro writes each.
        macro_rules! write_layer {
            ($channels:expr) => {
                Image::from_layer(Layer::new(size, layer_attributes, encoding, $channels))
                    .write()
                    .to_buffered(writer)
                    .map_err(encode)
            };
        }
        match (self.ty, half) {
            (Type::Vec3, false) => {
                let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
                    let i = (p.y() * nx + p.x()) * 3;
                    (data[i], data[i + 1], data[i + 2])
                });
                write_layer!(channels)
            }
            (Type::Vec3, true) => {
                let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
                    let i = (p.y() * nx + p.x()) * 3;
                    (
                        f16::from_f32(data[i]),
                        f16::from_f32(data[i + 1]),
                        f16::from_f32(data[i + 2]),
                    )
                });
                write_layer!(channels)
            }
            (Type::Scalar, false) => {
                let channels = SpecificChannels::build()
                    .with_channel("Y")
                    .with_pixel_fn(|p: Vec2<usize>| (data[p.y() * nx + p.x()],));
                write_layer!(channels)
            }
            (Type::Scalar, true) => {
                let channels = SpecificChannels::build()
                    .with_channel("Y")
                    .with_pixel_fn(|p: Vec2<usize>| (f16::from_f32(data[p.y() * nx + p.x()]),));
                write_layer!(channels)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_is_roundf_exactly() {
        // Every 31st float in [0, 1], scaled as both encodings scale, and every half-way point
        // and its neighbours.
        let mut bits = 0u32;
        while bits <= 1.0f32.to_bits() {
            let v = f32::from_bits(bits);
            for scale in [255.0f32, 65535.0] {
                let x = v * scale;
                assert_eq!(round_non_negative(x), x.round() as u32, "{x:?}");
            }
            bits += 31;
        }
        for k in 0..65536u32 {
            let half = k as f32 + 0.5;
            for x in [half, half.next_down(), half.next_up(), k as f32] {
                assert_eq!(round_non_negative(x), x.round() as u32, "{x:?}");
            }
        }
        assert_eq!(encode_u8(f32::NAN, true), 0);
        assert_eq!(encode_u8(2.0, true), 255);
        assert_eq!(encode_u16(1.0, false), 65535);
    }

    #[test]
    fn srgb_transfer_hits_its_anchor_points() {
        assert_eq!(encode_u8(0.0, true), 0);
        assert_eq!(encode_u8(1.0, true), 255);
        assert_eq!(encode_u8(0.5, false), 128);
        // Linear 0.5 is sRGB 188 (0.7354).
        assert_eq!(encode_u8(0.5, true), 188);
        assert_eq!(encode_u8(f32::NAN, true), 0);
        assert_eq!(encode_u8(7.0, false), 255);
        assert_eq!(encode_u16(1.0, false), 65535);
        assert!((srgb_encode(0.0031308) - 0.04045).abs() < 1e-4);
    }
}
