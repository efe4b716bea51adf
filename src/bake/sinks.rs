//! Sinks that write a bake's windows to files: EXR (whole volume, stacked slices), PNG (one file
//! per slice, or one atlas), raw (packed voxels). Each writes into a temporary file or folder;
//! `files.rs` renames it into place when the bake completed.

use super::error::BakeError;
use super::window::{Sink, Window};
use crate::encoding::Encoding;
use crate::graph::Type;
use crate::grid::Grid;
use rayon::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

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
    let encoding = png_encoding(ty, depth16, srgb);
    let mut encoded = vec![0u8; samples.len() * encoding.bytes()];
    for (v, out) in samples
        .iter()
        .zip(encoded.chunks_exact_mut(encoding.bytes()))
    {
        encoding.encode(*v, out);
    }
    png_encoded_bytes(&mut encoded, width, height, ty, depth16, srgb)
}

/// Bytes of one PNG image of samples already in [`png_encoding`] (16-bit ones little-endian,
/// swapped here to PNG's big-endian order).
fn png_encoded_bytes(
    encoded: &mut [u8],
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
        to_png_order(encoded, depth16);
        writer
            .write_image_data(encoded)
            .map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())?;
    }
    Ok(bytes)
}

/// The sample type a PNG of `ty` stores: 8 or 16 bits, the sRGB transfer for colours only
/// (scalars are data, mapped linearly).
fn png_encoding(ty: Type, depth16: bool, srgb: bool) -> Encoding {
    let srgb = srgb && ty == Type::Vec3;
    if depth16 {
        Encoding::U16 { srgb }
    } else {
        Encoding::U8 { srgb }
    }
}

/// 16-bit samples from little-endian (as windows hold them) to PNG's big-endian order.
fn to_png_order(bytes: &mut [u8], depth16: bool) {
    if depth16 {
        for pair in bytes.chunks_exact_mut(2) {
            pair.swap(0, 1);
        }
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
        let encoding = png_encoding(self.ty, self.depth16, self.srgb);
        let mut bytes = Vec::new();
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
            bytes.clear();
            window.push_encoded(self.output, s, &segment, encoding, &mut bytes);
            to_png_order(&mut bytes, self.depth16);
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
    fn stores(&self, output: usize) -> Option<Encoding> {
        (output == self.output).then(|| png_encoding(self.ty, self.depth16, self.srgb))
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let [nx, ny, _] = window.grid.size;
        let Some((z_start, depth)) = window.whole_slices() else {
            return self.stream(window);
        };
        // Slices of a window are independent files: encode them in parallel.
        let encoding = png_encoding(self.ty, self.depth16, self.srgb);
        (0..depth).into_par_iter().try_for_each(|k| {
            let mut samples = Vec::new();
            window.slice_encoded(self.output, k, encoding, &mut samples);
            let path = self.slice_path(z_start + k);
            let bytes = png_encoded_bytes(&mut samples, nx, ny, self.ty, self.depth16, self.srgb)
                .map_err(|message| BakeError::Encode {
                path: path.display().to_string(),
                message,
            })?;
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
    fn stores(&self, output: usize) -> Option<Encoding> {
        (output == self.output).then(|| png_encoding(self.ty, self.depth16, self.srgb))
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let encoding = png_encoding(self.ty, self.depth16, self.srgb);
        for (s, segment) in window.segments() {
            let start = self.pending.len();
            window.push_encoded(self.output, s, &segment, encoding, &mut self.pending);
            to_png_order(&mut self.pending[start..], self.depth16);
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
    /// The batch's encoded bytes.
    pub bytes: Vec<u8>,
}

/// Most voxels a raw writer gathers and encodes at once (whole segments, which are at most
/// [`crate::grid::SEGMENT_VOXELS`] ≤ this): at most 16 bytes a voxel, 4 MiB.
const RAW_BATCH_VOXELS: usize = 1 << 18;
/// Voxels per parallel encoding task.
const RAW_TASK_VOXELS: usize = 1 << 14;

impl RawSamples {
    /// The encoding of the samples (sRGB for colours only).
    fn encoding(self, ty: Type) -> Encoding {
        match self {
            RawSamples::U8 { srgb, .. } => Encoding::U8 {
                srgb: srgb && ty == Type::Vec3,
            },
            RawSamples::F32 { .. } => Encoding::F32,
        }
    }

    fn alpha(self) -> bool {
        match self {
            RawSamples::U8 { alpha, .. } | RawSamples::F32 { alpha } => alpha,
        }
    }

    /// Encoded bytes of one voxel of `ty`, opaque alpha included.
    fn voxel_bytes(self, ty: Type) -> usize {
        (ty.channels() + usize::from(self.alpha())) * self.encoding(ty).bytes()
    }

    /// Segment `s` of `window` (output `output`, of `ty`) encoded into `out`, exactly its
    /// voxels' size; the opaque alpha, when asked, after each voxel's channels.
    fn encode(
        self,
        window: &Window<'_>,
        (output, ty): (usize, Type),
        (s, segment): (usize, &crate::grid::Segment),
        out: &mut [u8],
    ) {
        let encoding = self.encoding(ty);
        if self.alpha() {
            window.copy_encoded_opaque(output, s, segment, encoding, out);
        } else {
            window.copy_encoded(output, s, segment, encoding, out);
        }
    }
}

impl Sink for Raw {
    fn stores(&self, output: usize) -> Option<Encoding> {
        (output == self.output).then(|| self.samples.encoding(self.ty))
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        let (grid, layout) = (window.grid, window.layout);
        let (samples, ty, output) = (self.samples, self.ty, self.output);
        let size = samples.voxel_bytes(ty);
        // Tasks: runs of whole segments, about RAW_TASK_VOXELS voxels (or one segment); batches
        // of tasks, at most RAW_BATCH_VOXELS voxels.
        let per_task = (RAW_TASK_VOXELS / layout.segment_len).max(1);
        let per_batch = (RAW_BATCH_VOXELS / layout.segment_len).max(per_task);
        let voxel = |s: usize| layout.voxels_before(grid, window.first_segment + s as u64) as usize;
        for batch in (0..window.segments).step_by(per_batch) {
            let batch_end = (batch + per_batch).min(window.segments);
            self.bytes
                .resize((voxel(batch_end) - voxel(batch)) * size, 0);
            // Each task's segments and its share of the buffer.
            let mut tasks = Vec::new();
            let mut bytes = &mut self.bytes[..];
            for task in (batch..batch_end).step_by(per_task) {
                let task_end = (task + per_task).min(batch_end);
                let n = voxel(task_end) - voxel(task);
                let (task_bytes, rest) = std::mem::take(&mut bytes).split_at_mut(n * size);
                bytes = rest;
                tasks.push((task..task_end, task_bytes));
            }
            // Inside the bake's pool (sinks run there): gathered and encoded in parallel.
            tasks.into_par_iter().for_each(|(segments, task_bytes)| {
                let mut at = 0;
                for s in segments {
                    let segment = layout.segment(grid, window.first_segment + s as u64);
                    let n = segment.len * size;
                    let out = &mut task_bytes[at..at + n];
                    samples.encode(window, (output, ty), (s, &segment), out);
                    at += n;
                }
            });
            self.writer.write_all(&self.bytes).map_err(io(&self.path))?;
        }
        Ok(())
    }
}

/// Collects the whole volume (the exr writer needs the complete image), then writes one EXR:
/// slices stacked vertically, `ny · nz` rows, row `k · ny + j` holding voxel row (j, k). A
/// half-float EXR holds its samples as halves (half the memory; a GPU bake packs them so).
pub(super) struct Exr {
    pub output: usize,
    pub ty: Type,
    /// 16-bit half floats (`--half`) in `halves`, else 32-bit floats in `data`.
    pub half: bool,
    pub data: Vec<f32>,
    pub halves: Vec<half::f16>,
    /// One segment's half floats as bytes, on their way into `halves`.
    pub scratch: Vec<u8>,
}

impl Sink for Exr {
    fn stores(&self, output: usize) -> Option<Encoding> {
        (output == self.output).then_some(if self.half {
            Encoding::F16
        } else {
            Encoding::F32
        })
    }

    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError> {
        for (s, segment) in window.segments() {
            if self.half {
                self.scratch.clear();
                window.push_encoded(self.output, s, &segment, Encoding::F16, &mut self.scratch);
                let halves = self.scratch.chunks_exact(2);
                self.halves
                    .extend(halves.map(|b| half::f16::from_le_bytes([b[0], b[1]])));
            } else {
                window.push_interleaved(self.output, s, &segment, &mut self.data);
            }
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
        half: false,
        data,
        halves: Vec::new(),
        scratch: Vec::new(),
    };
    let zip = super::settings::ExrCompression::Zip;
    exr.write(path, file, &grid, zip, attributes)
}

impl Exr {
    /// Writes the EXR to `file` (32-bit float, or 16-bit half with `half`), with the grid in
    /// the header as custom attributes.
    pub fn write(
        &self,
        path: &Path,
        file: std::fs::File,
        grid: &Grid,
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
        let (data, halves) = (&self.data, &self.halves);
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
        match (self.ty, self.half) {
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
                    (halves[i], halves[i + 1], halves[i + 2])
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
                    .with_pixel_fn(|p: Vec2<usize>| (halves[p.y() * nx + p.x()],));
                write_layer!(channels)
            }
        }
    }
}
