//! What the bake engine hands its sinks: a [`Window`] of evaluated segments, in file order, and
//! the [`Sink`] trait. A window holds 32-bit floats (the CPU's bakes) or, from a GPU bake,
//! each channel in the sample type its sink stores ([`Sink::stores`], packed on the device);
//! sinks read either through the same accessors.

use super::error::BakeError;
use crate::encoding::{Encoding, Packing};
use crate::graph::Type;
use crate::grid::{Grid, Layout, Segment};

/// One window of evaluated segments, handed to a sink in file order.
///
/// Layout of 32-bit windows: segment-planar. Segment `s` of the window holds every channel of
/// every output for its voxels: channel `c` (numbered across outputs) of its voxel `i` at
/// `(s * channels + c) * segment_len + i`. Encoded windows: as [`Packing`] says.
pub struct Window<'a> {
    pub grid: &'a Grid,
    pub layout: &'a Layout,
    /// Index of the window's first segment in the grid, and how many it holds.
    pub first_segment: u64,
    pub segments: usize,
    /// Channels per voxel across all outputs, and the first channel of each output.
    pub channels: usize,
    pub outputs: &'a [WindowOutput],
    pub(super) data: WindowData<'a>,
}

/// A window's samples.
pub(super) enum WindowData<'a> {
    /// Every channel as 32-bit floats.
    F32(&'a [f32]),
    /// Each channel in its encoding (a GPU bake's read-back).
    Packed {
        bytes: &'a [u8],
        packing: &'a Packing,
    },
}

/// Where an output's channels are in a window.
#[derive(Clone, Debug)]
pub struct WindowOutput {
    pub name: String,
    pub ty: Type,
    pub first_channel: usize,
}

impl Window<'_> {
    /// The window's segments, in file order, with their position in the window.
    pub fn segments(&self) -> impl Iterator<Item = (usize, Segment)> + '_ {
        (0..self.segments).map(|s| {
            (
                s,
                self.layout
                    .segment(self.grid, self.first_segment + s as u64),
            )
        })
    }

    /// The z slices the window holds whole, `(first, count)`, when it holds only whole slices.
    pub fn whole_slices(&self) -> Option<(usize, usize)> {
        let slice = self.layout.per_row as u64 * self.grid.size[1] as u64;
        (self.first_segment.is_multiple_of(slice) && (self.segments as u64).is_multiple_of(slice))
            .then(|| {
                (
                    (self.first_segment / slice) as usize,
                    (self.segments as u64 / slice) as usize,
                )
            })
    }

    /// Appends the voxels of the window's segment `s` (of `segment` geometry) for output
    /// `output` to `out`, channels interleaved.
    pub fn push_interleaved(&self, output: usize, s: usize, segment: &Segment, out: &mut Vec<f32>) {
        let start = out.len();
        out.resize(
            start + segment.len * self.outputs[output].ty.channels(),
            0.0,
        );
        self.copy_interleaved(output, s, segment, &mut out[start..]);
    }

    /// Writes the voxels of the window's segment `s` (of `segment` geometry) for output
    /// `output` into `out`, channels interleaved; `out` holds exactly `segment.len` voxels.
    /// In an encoded window, only for channels stored as 32-bit floats (the engine packs a
    /// channel otherwise only for a sink that reads it with [`Window::copy_encoded`]).
    pub fn copy_interleaved(&self, output: usize, s: usize, segment: &Segment, out: &mut [f32]) {
        let o = &self.outputs[output];
        let width = o.ty.channels();
        assert_eq!(out.len(), segment.len * width, "a segment's voxels");
        match self.data {
            WindowData::F32(data) => {
                let len = self.layout.segment_len;
                let base = s * self.channels * len;
                for c in 0..width {
                    let start = base + (o.first_channel + c) * len;
                    let channel = &data[start..start + segment.len];
                    if width == 1 {
                        out.copy_from_slice(channel);
                    } else {
                        for (t, v) in out[c..].iter_mut().step_by(width).zip(channel) {
                            *t = *v;
                        }
                    }
                }
            }
            WindowData::Packed { bytes, packing } => {
                for c in 0..width {
                    let channel = o.first_channel + c;
                    assert_eq!(
                        packing.encodings[channel],
                        Encoding::F32,
                        "internal: a sink read 32-bit floats of a channel packed for another"
                    );
                    let samples = packing.channel(bytes, s, channel, segment.len);
                    for (t, b) in out[c..].iter_mut().step_by(width).zip(samples.chunks(4)) {
                        *t = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                    }
                }
            }
        }
    }

    /// Writes the voxels of segment `s` for output `output` into `out` in `encoding`
    /// (little-endian samples, channels interleaved; `out` exactly `segment.len × channels ×
    /// encoding.bytes()` long): copied where the window holds them so (a GPU bake packed them),
    /// else encoded here.
    pub fn copy_encoded(
        &self,
        output: usize,
        s: usize,
        segment: &Segment,
        encoding: Encoding,
        out: &mut [u8],
    ) {
        let voxel = self.outputs[output].ty.channels() * encoding.bytes();
        assert_eq!(out.len(), segment.len * voxel, "a segment's voxels");
        self.copy_encoded_strided(output, s, segment, encoding, out, voxel);
    }

    /// [`Window::copy_encoded`] with voxel `i`'s channels at byte `i × voxel_bytes` of `out`
    /// (at least the channels' bytes; bytes after them, an alpha's, are left as they are).
    pub fn copy_encoded_strided(
        &self,
        output: usize,
        s: usize,
        segment: &Segment,
        encoding: Encoding,
        out: &mut [u8],
        voxel_bytes: usize,
    ) {
        let o = &self.outputs[output];
        let size = encoding.bytes();
        assert!(voxel_bytes >= o.ty.channels() * size && out.len() >= segment.len * voxel_bytes);
        for c in 0..o.ty.channels() {
            let channel = o.first_channel + c;
            let out = &mut out[c * size..];
            match self.data {
                WindowData::F32(data) => {
                    let start = (s * self.channels + channel) * self.layout.segment_len;
                    encoding.encode_run(&data[start..start + segment.len], out, voxel_bytes);
                }
                WindowData::Packed { bytes, packing } => {
                    let held = packing.encodings[channel];
                    let samples = packing.channel(bytes, s, channel, segment.len);
                    if held == encoding && voxel_bytes == size {
                        out[..samples.len()].copy_from_slice(samples);
                    } else if held == encoding {
                        for (t, b) in out.chunks_mut(voxel_bytes).zip(samples.chunks(size)) {
                            t[..size].copy_from_slice(b);
                        }
                    } else {
                        assert_eq!(
                            held,
                            Encoding::F32,
                            "internal: a channel packed for another sink"
                        );
                        for (t, b) in out.chunks_mut(voxel_bytes).zip(samples.chunks(4)) {
                            let v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                            encoding.encode(v, &mut t[..size]);
                        }
                    }
                }
            }
        }
    }

    /// [`Window::copy_encoded`] with an opaque alpha (1 in `encoding`) after each voxel's
    /// channels: RGBA from RGB, grey and alpha from grey.
    pub fn copy_encoded_opaque(
        &self,
        output: usize,
        s: usize,
        segment: &Segment,
        encoding: Encoding,
        out: &mut [u8],
    ) {
        let size = encoding.bytes();
        let colour = self.outputs[output].ty.channels() * size;
        assert_eq!(
            out.len(),
            segment.len * (colour + size),
            "a segment's voxels"
        );
        self.copy_encoded_strided(output, s, segment, encoding, out, colour + size);
        let mut opaque = [0u8; 4];
        encoding.encode(1.0, &mut opaque[..size]);
        for voxel in out.chunks_exact_mut(colour + size) {
            voxel[colour..].copy_from_slice(&opaque[..size]);
        }
    }

    /// Appends [`Window::copy_encoded`]'s bytes to `out`.
    pub fn push_encoded(
        &self,
        output: usize,
        s: usize,
        segment: &Segment,
        encoding: Encoding,
        out: &mut Vec<u8>,
    ) {
        let start = out.len();
        let width = self.outputs[output].ty.channels();
        out.resize(start + segment.len * width * encoding.bytes(), 0);
        self.copy_encoded(output, s, segment, encoding, &mut out[start..]);
    }

    /// Every voxel of the window for output `output`, channels interleaved, in file order.
    pub fn interleaved(&self, output: usize, out: &mut Vec<f32>) {
        out.clear();
        for (s, segment) in self.segments() {
            self.push_interleaved(output, s, &segment, out);
        }
    }

    /// Slice `k_local` of a window of whole slices (see [`Window::whole_slices`]) for output
    /// `output` in `encoding`, channels interleaved, x fastest then y, into `out`.
    pub fn slice_encoded(
        &self,
        output: usize,
        k_local: usize,
        encoding: Encoding,
        out: &mut Vec<u8>,
    ) {
        out.clear();
        let slice = self.layout.per_row * self.grid.size[1];
        for s in k_local * slice..(k_local + 1) * slice {
            let segment = self
                .layout
                .segment(self.grid, self.first_segment + s as u64);
            self.push_encoded(output, s, &segment, encoding, out);
        }
    }
}

/// Receives the windows of a bake, in file order.
pub trait Sink: Send {
    fn window(&mut self, window: &Window<'_>) -> Result<(), BakeError>;

    /// The sample type this sink stores output `output` in, when it writes that output in one
    /// fixed type and reads it with [`Window::copy_encoded`]: a GPU bake then packs the
    /// output's channels so on the device and reads back that, not 32-bit floats. `None`
    /// (the default): the sink reads 32-bit floats, or does not write this output.
    fn stores(&self, _output: usize) -> Option<Encoding> {
        None
    }
}
