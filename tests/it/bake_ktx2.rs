//! `bake --format ktx2`: every file is read back with an independent reader (the `ktx2` crate;
//! Zstandard levels inflated with the `zstd` crate) and checked field by field against the KTX 2.0
//! specification ("the spec"; section names in quotes are its), and every texel against
//! `eval_point` (f32, the bake's own precision) at the voxel centre: exactly for 32-bit floats,
//! through IEEE half rounding for 16-bit floats, within the 8-bit quantisation for 8-bit files.
//!
//! The grids are odd (5×3×4) over a box with negative coordinates, so that an axis mix-up, a
//! wrong texel order or a row padding shows.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use texgraph::bake::{
    bake_files, encode_u8, BakeError, BakeFileOptions, BakeReport, Format, Grid, Ktx2SampleType,
    Region, Transfer,
};
use texgraph::{CheckOptions, CompileOptions, SourceFile, Tape, Type};

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");
/// Outputs `colour` (vec3) and `vein` (scalar): noise, so every value is a fraction.
const MARBLE: &str = "graphs/seed003_marble.ron";
/// Values outside [0, 1] on both sides, NaN, and values past half's range (65504).
const EXTREMES: &str = r#"Graph(nodes: { "p": Position }, outputs: {
    "ramp": Sub(Mul("p.x", 1.5), 0.25),
    "tint": Combine(Sub("p.x", 0.25), Mul("p.y", 2.0), Sqrt(Sub(0.2, "p.z"))),
    "big": Mul("p.x", 100000.0),
})"#;

// ---------------------------------------------------------------------------------------------
// Graphs, grids and the reference

use common::{crate_root as root, load_graph_file as load_file};

fn load_text(text: &str) -> Tape {
    let graph = texgraph::check(
        SourceFile::new("inline.ron", text),
        &CheckOptions::default(),
    )
    .unwrap_or_else(|e| panic!("{}", e.render(false)));
    texgraph::compile(&graph, &CompileOptions::default()).expect("compile")
}

/// 5×3×4 voxels over [-0.5, 1.5] × [-1, 0.25] × [-0.75, 0.5].
fn odd_grid() -> Grid {
    Grid {
        size: [5, 3, 4],
        region: Region {
            min: [-0.5, -1.0, -0.75],
            max: [1.5, 0.25, 0.5],
        },
    }
}

use common::expected_volume as expected;

fn options(dir: &Path, grid: Grid, sample: Ktx2SampleType, zstd: Option<i32>) -> BakeFileOptions {
    let mut options = BakeFileOptions::new("g", dir);
    options.bake.grid = grid;
    options.bake.threads = 2;
    options.format = Format::Ktx2;
    options.ktx2_type = sample;
    options.zstd = zstd;
    options.graph_path = "graphs/g.ron".into();
    options.params = vec![("period".into(), 1.3), ("octaves".into(), 2.0)];
    options.overrides = vec![("octaves".into(), 2.0)];
    options
}

fn bake_ok(tape: &Tape, options: &BakeFileOptions) -> BakeReport {
    let report =
        bake_files(tape, options, &mut |_| {}).unwrap_or_else(|e| panic!("bake failed: {e}"));
    assert_no_hidden_entries(&options.out_dir);
    report
}

fn entries(dir: &Path) -> Vec<String> {
    let Ok(read) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = read
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn assert_no_hidden_entries(dir: &Path) {
    let hidden: Vec<String> = entries(dir)
        .into_iter()
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "temporaries left behind: {hidden:?}");
}

// ---------------------------------------------------------------------------------------------
// Reading a file back

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

fn u64_at(bytes: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
}

/// A KTX2 file as the `ktx2` crate reads it, plus the raw pieces the checks need.
struct Ktx2File {
    bytes: Vec<u8>,
    header: ktx2::Header,
    /// Key/value pairs in file order, values as stored (with their NUL).
    key_values: Vec<(String, Vec<u8>)>,
    /// byteOffset, byteLength, uncompressedByteLength of level 0.
    level_index: [u64; 3],
    /// Level 0's texels, inflated if supercompressed.
    texels: Vec<u8>,
}

fn read_ktx2(path: &Path) -> Ktx2File {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let reader = ktx2::Reader::new(&bytes[..])
        .unwrap_or_else(|e| panic!("{}: not a valid KTX2 file: {e:?}", path.display()));
    let header = reader.header();
    let key_values = reader
        .key_value_data()
        .map(|(k, v)| (k.to_string(), v.to_vec()))
        .collect();
    let levels: Vec<ktx2::Level> = reader.levels().collect();
    assert_eq!(levels.len(), 1);
    let texels = match header.supercompression_scheme {
        None => levels[0].data.to_vec(),
        Some(ktx2::SupercompressionScheme::Zstandard) => {
            // One Zstandard frame that records the level's size.
            let frame = levels[0].data;
            assert_eq!(
                zstd::zstd_safe::find_frame_compressed_size(frame).unwrap(),
                frame.len(),
                "the level is exactly one frame"
            );
            assert_eq!(
                zstd::zstd_safe::get_frame_content_size(frame).unwrap(),
                Some(levels[0].uncompressed_byte_length)
            );
            zstd::decode_all(frame).unwrap()
        }
        Some(other) => panic!("unexpected supercompression {other:?}"),
    };
    let level_index = [80, 88, 96].map(|at| u64_at(&bytes, at));
    Ktx2File {
        header,
        key_values,
        level_index,
        texels,
        bytes,
    }
}

impl Ktx2File {
    fn value(&self, key: &str) -> Option<&[u8]> {
        self.key_values
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_slice())
    }

    /// A string value, which must be NUL-terminated (spec "keyAndValue").
    fn text(&self, key: &str) -> String {
        let value = self.value(key).unwrap_or_else(|| panic!("no key {key}"));
        let (last, text) = value.split_last().expect("empty value");
        assert_eq!(*last, 0, "{key}: value not NUL-terminated");
        String::from_utf8(text.to_vec()).unwrap()
    }

    fn dfd(&self) -> &[u8] {
        let offset = self.header.index.dfd_byte_offset as usize;
        &self.bytes[offset..offset + self.header.index.dfd_byte_length as usize]
    }
}

/// What a file of an output must be.
struct Expect {
    vk_format: ktx2::Format,
    type_size: u32,
    channels: usize,
    srgb: bool,
    sample: Ktx2SampleType,
}

fn expect(ty: Type, sample: Ktx2SampleType, transfer: Transfer) -> Expect {
    use ktx2::Format as F;
    let colour = ty == Type::Vec3;
    let srgb = colour && sample == Ktx2SampleType::U8 && transfer == Transfer::Srgb;
    let (vk_format, type_size) = match (sample, colour) {
        (Ktx2SampleType::U8, false) => (F::R8_UNORM, 1),
        (Ktx2SampleType::U8, true) if srgb => (F::R8G8B8A8_SRGB, 1),
        (Ktx2SampleType::U8, true) => (F::R8G8B8A8_UNORM, 1),
        (Ktx2SampleType::F16, false) => (F::R16_SFLOAT, 2),
        (Ktx2SampleType::F16, true) => (F::R16G16B16A16_SFLOAT, 2),
        (Ktx2SampleType::F32, false) => (F::R32_SFLOAT, 4),
        (Ktx2SampleType::F32, true) => (F::R32G32B32A32_SFLOAT, 4),
    };
    Expect {
        vk_format,
        type_size,
        channels: if colour { 4 } else { 1 },
        srgb,
        sample,
    }
}

/// The sRGB transfer of IEC 61966-2-1 in f64, written here again, independently of the crate.
fn srgb_f64(v: f64) -> f64 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Checks one file: header, index, DFD, key/value data, level layout, every texel.
fn check_file(
    file: &Ktx2File,
    grid: &Grid,
    options: &BakeFileOptions,
    output: &str,
    ty: Type,
    values: &[f32],
) {
    let e = expect(ty, options.ktx2_type, options.transfer);
    let h = &file.header;
    let what = format!("{output} {:?} zstd {:?}", options.ktx2_type, options.zstd);
    let voxels = grid.size.iter().product::<usize>();
    let texel = e.channels * e.type_size as usize;

    // Header (spec "File Structure", "Field Descriptions").
    assert_eq!(file.bytes[..12], ktx2::MAGIC, "{what}: identifier");
    assert_eq!(h.format, Some(e.vk_format), "{what}");
    assert_eq!(h.type_size, e.type_size, "{what}: typeSize");
    assert_eq!(
        [h.pixel_width, h.pixel_height, h.pixel_depth],
        grid.size.map(|n| n as u32),
        "{what}: a 3D texture of nx × ny × nz"
    );
    assert_eq!(h.layer_count, 0, "{what}: not an array");
    assert_eq!(h.face_count, 1, "{what}: not a cubemap");
    assert_eq!(h.level_count, 1, "{what}");
    match options.zstd {
        None => assert_eq!(h.supercompression_scheme, None, "{what}"),
        Some(_) => assert_eq!(
            h.supercompression_scheme,
            Some(ktx2::SupercompressionScheme::Zstandard),
            "{what}"
        ),
    }

    // Index (spec "Index"): the DFD right after the level index, the key/value data right after
    // the DFD, no supercompression global data.
    let index = &h.index;
    assert_eq!(index.dfd_byte_offset, 80 + 24, "{what}");
    assert_eq!(
        index.dfd_byte_length,
        u32_at(file.dfd(), 0),
        "{what}: dfdTotalSize"
    );
    assert_eq!(
        index.kvd_byte_offset,
        index.dfd_byte_offset + index.dfd_byte_length,
        "{what}: dfdTotalSize = kvdByteOffset - dfdByteOffset"
    );
    assert_eq!(
        (index.sgd_byte_offset, index.sgd_byte_length),
        (0, 0),
        "{what}"
    );

    // DFD (spec "Data Format Descriptor", Khronos Data Format 1.3 basic descriptor block).
    let reader = ktx2::Reader::new(&file.bytes[..]).unwrap();
    assert_eq!(reader.dfd_blocks().len(), 1, "{what}: one descriptor block");
    let dfd = reader.basic_dfd().expect("a basic descriptor block");
    assert_eq!(dfd.color_model, Some(ktx2::ColorModel::RGBSDA), "{what}");
    assert_eq!(
        dfd.color_primaries,
        Some(ktx2::ColorPrimaries::BT709),
        "{what}"
    );
    let transfer = if e.srgb {
        ktx2::TransferFunction::SRGB
    } else {
        ktx2::TransferFunction::Linear
    };
    assert_eq!(dfd.transfer_function, Some(transfer), "{what}");
    assert_eq!(
        dfd.flags,
        ktx2::dfd::DataFormatFlags::STRAIGHT_ALPHA,
        "{what}"
    );
    assert!(
        dfd.texel_block_dimensions.iter().all(|d| d.get() == 1),
        "{what}"
    );
    // bytesPlane0 is the texel size with Zstandard too (spec "DFD for Supercompressed Data").
    assert_eq!(
        dfd.bytes_planes,
        [texel as u8, 0, 0, 0, 0, 0, 0, 0],
        "{what}"
    );
    assert_eq!(dfd.sample_information.len(), e.channels, "{what}");
    let bits = 8 * e.type_size;
    for (c, sample) in dfd.sample_information.iter().enumerate() {
        let channel = [0u8, 1, 2, 15][c];
        assert_eq!(sample.channel_type, channel, "{what} sample {c}");
        assert_eq!(
            u32::from(sample.bit_offset),
            c as u32 * bits,
            "{what} sample {c}"
        );
        assert_eq!(
            u32::from(sample.bit_length.get()),
            bits,
            "{what} sample {c}"
        );
        assert_eq!(sample.sample_positions, [0; 4], "{what} sample {c}");
        use ktx2::dfd::ChannelTypeQualifiers as Q;
        let (qualifiers, lower, upper) = match e.sample {
            // Spec "Restrictions": with the sRGB transfer the alpha sample is linear.
            Ktx2SampleType::U8 if e.srgb && channel == 15 => (Q::LINEAR, 0, 255),
            Ktx2SampleType::U8 => (Q::empty(), 0, 255),
            // -1.0 and 1.0 as 32-bit floats.
            _ => (Q::FLOAT | Q::SIGNED, 0xBF80_0000, 0x3F80_0000),
        };
        assert_eq!(
            sample.channel_type_qualifiers, qualifiers,
            "{what} sample {c}"
        );
        assert_eq!(
            (sample.lower, sample.upper),
            (lower, upper),
            "{what} sample {c}"
        );
    }
    // And the whole descriptor is the one the `ktx2` crate derives from the vkFormat.
    let (canonical, type_size) = ktx2::dfd::Basic::from_format(e.vk_format).unwrap();
    assert_eq!(type_size, e.type_size);
    let block = ktx2::dfd::Block::Basic(canonical).to_vec();
    assert_eq!(&file.dfd()[4..], &block[..], "{what}: DFD");

    // Key/value data (spec "Key/Value Data"): sorted by key, each length-prefixed and padded to
    // 4 bytes, the lengths summing to kvdByteLength.
    let kvd = &file.bytes[index.kvd_byte_offset as usize..][..index.kvd_byte_length as usize];
    let (mut at, mut keys) = (0usize, Vec::new());
    while at < kvd.len() {
        let length = u32_at(kvd, at) as usize;
        let pair = &kvd[at + 4..at + 4 + length];
        let key_end = pair.iter().position(|&b| b == 0).expect("key NUL");
        keys.push(String::from_utf8(pair[..key_end].to_vec()).unwrap());
        let padded = length.div_ceil(4) * 4;
        assert!(kvd[at + 4 + length..at + 4 + padded]
            .iter()
            .all(|&b| b == 0));
        at += 4 + padded;
    }
    assert_eq!(at, kvd.len(), "{what}: kvdByteLength");
    let mut sorted = keys.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(keys, sorted, "{what}: keys sorted by code point, each once");
    let mut wanted = vec![
        "KTXorientation",
        "KTXwriter",
        "texgraph.graph",
        "texgraph.output",
        "texgraph.overrides",
        "texgraph.params",
        "texgraph.region",
        "texgraph.voxel_centre",
    ];
    if options.zstd.is_some() {
        wanted.insert(2, "KTXwriterScParams");
    }
    assert_eq!(keys, wanted, "{what}");
    assert_eq!(file.text("KTXorientation"), "ruo", "{what}");
    assert_eq!(
        file.text("KTXwriter"),
        format!("texgraph {}", env!("CARGO_PKG_VERSION"))
    );
    if let Some(level) = options.zstd {
        assert_eq!(file.text("KTXwriterScParams"), format!("--zstd={level}"));
    }
    assert_eq!(file.text("texgraph.graph"), options.graph_path);
    assert_eq!(file.text("texgraph.output"), output);
    let json = |key: &str| -> serde_json::Value { serde_json::from_str(&file.text(key)).unwrap() };
    assert_eq!(
        json("texgraph.params"),
        serde_json::json!({"period": 1.3, "octaves": 2.0})
    );
    assert_eq!(
        json("texgraph.overrides"),
        serde_json::json!({"octaves": 2.0})
    );
    assert_eq!(
        json("texgraph.region"),
        serde_json::json!({"min": grid.region.min, "max": grid.region.max})
    );
    assert!(file.text("texgraph.voxel_centre").contains("(index + 0.5)"));

    // The level (spec "Level Index", "mipPadding"): after the key/value data, aligned to
    // lcm(texel size, 4) uncompressed (zero padding) and not at all supercompressed, running to
    // the end of the file.
    let [offset, length, uncompressed] = file.level_index;
    let kvd_end = u64::from(index.kvd_byte_offset + index.kvd_byte_length);
    let alignment = match options.zstd {
        Some(_) => 1,
        None => (texel as u64).max(4), // lcm(1|2|4|8|16, 4)
    };
    assert_eq!(
        offset,
        kvd_end.div_ceil(alignment) * alignment,
        "{what}: level offset"
    );
    assert!(file.bytes[kvd_end as usize..offset as usize]
        .iter()
        .all(|&b| b == 0));
    assert_eq!(offset + length, file.bytes.len() as u64, "{what}");
    assert_eq!(uncompressed, (voxels * texel) as u64, "{what}");
    if options.zstd.is_none() {
        assert_eq!(length, uncompressed, "{what}");
    }
    assert_eq!(file.texels.len(), voxels * texel, "{what}");

    // Every texel, x fastest, then y, then z.
    let width = ty.channels();
    assert_eq!(values.len(), voxels * width);
    for (v, (texel_bytes, expected)) in file
        .texels
        .chunks_exact(texel)
        .zip(values.chunks_exact(width))
        .enumerate()
    {
        let samples = texel_bytes.chunks_exact(e.type_size as usize);
        for (c, sample) in samples.enumerate() {
            let at = format!("{what}: voxel {v} channel {c}");
            let alpha = c == 3;
            match e.sample {
                Ktx2SampleType::U8 => {
                    let got = sample[0];
                    if alpha {
                        assert_eq!(got, 255, "{at}");
                        continue;
                    }
                    let x = expected[c];
                    assert_eq!(got, encode_u8(x, e.srgb), "{at}: {x}");
                    // Independently: within half a step of the clamped (encoded) value.
                    let x = if x.is_nan() {
                        0.0
                    } else {
                        f64::from(x).clamp(0.0, 1.0)
                    };
                    let ideal = 255.0 * if e.srgb { srgb_f64(x) } else { x };
                    assert!((f64::from(got) - ideal).abs() <= 0.5 + 1e-4, "{at}: {x}");
                }
                Ktx2SampleType::F16 => {
                    let got = half::f16::from_le_bytes([sample[0], sample[1]]);
                    let want = if alpha {
                        half::f16::ONE
                    } else {
                        half::f16::from_f32(expected[c])
                    };
                    assert!(
                        got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                        "{at}: {got} vs {want}"
                    );
                    if !alpha && expected[c].is_finite() && expected[c].abs() < 65504.0 {
                        // Rounded to nearest: within half an f16 step of the value.
                        let step = (f32::from(got).abs().max(6.1e-5) * 2f32.powi(-10)).max(5.97e-8);
                        assert!(
                            (f32::from(got) - expected[c]).abs() <= step / 2.0 + 1e-12,
                            "{at}"
                        );
                    }
                }
                Ktx2SampleType::F32 => {
                    let got = f32::from_le_bytes(sample.try_into().unwrap());
                    let want = if alpha { 1.0 } else { expected[c] };
                    assert!(
                        got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                        "{at}: {got} vs {want}"
                    );
                }
            }
        }
    }
}

/// Bakes `tape` with `options` and checks each output's file.
fn bake_and_check(tape: &Tape, grid: &Grid, options: &BakeFileOptions) {
    let report = bake_ok(tape, options);
    let values = expected(tape, grid);
    assert_eq!(report.files.len(), tape.outputs().len());
    for ((output, file), values) in tape.outputs().iter().zip(&report.files).zip(&values) {
        assert_eq!(
            file.path,
            options
                .out_dir
                .join(format!("{}.{}.ktx2", options.stem, output.name))
        );
        check_file(
            &read_ktx2(&file.path),
            grid,
            options,
            &output.name,
            output.ty,
            values,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Files read back

#[test]
fn every_sample_type_with_and_without_zstd_matches_eval() {
    let grid = odd_grid();
    let graphs = [
        ("marble", load_file(MARBLE, &[]).0),
        ("extremes", load_text(EXTREMES)),
    ];
    for (name, tape) in &graphs {
        for sample in [Ktx2SampleType::U8, Ktx2SampleType::F16, Ktx2SampleType::F32] {
            for zstd in [None, Some(1), Some(3), Some(19)] {
                let dir = tempfile::tempdir().unwrap();
                let options = options(dir.path(), grid, sample, zstd);
                bake_and_check(tape, &grid, &options);
                assert_eq!(
                    entries(dir.path()).len(),
                    tape.outputs().len(),
                    "{name}: one file per output, nothing else"
                );
            }
        }
    }
}

#[test]
fn eight_bit_colours_with_the_linear_transfer_are_rgba8_unorm() {
    let grid = odd_grid();
    let (tape, _) = load_file(MARBLE, &[]);
    for zstd in [None, Some(3)] {
        let dir = tempfile::tempdir().unwrap();
        let options = BakeFileOptions {
            transfer: Transfer::Linear,
            ..options(dir.path(), grid, Ktx2SampleType::U8, zstd)
        };
        bake_and_check(&tape, &grid, &options);
    }
}

/// Rows longer than a bake segment (65 536 voxels) and several windows: the level is streamed
/// piece by piece, and the file does not depend on the thread count.
#[test]
fn levels_stream_across_segments_and_windows_whatever_the_thread_count() {
    let grid = Grid {
        size: [70_001, 2, 3],
        region: Region {
            min: [-1.0, 0.0, 0.0],
            max: [1.0, 1.0, 1.0],
        },
    };
    let tape = load_text(EXTREMES);
    for (sample, zstd) in [
        (Ktx2SampleType::U8, None),
        (Ktx2SampleType::F16, Some(3)),
        (Ktx2SampleType::F32, None),
    ] {
        let mut files = Vec::new();
        for threads in [1, 3] {
            let dir = tempfile::tempdir().unwrap();
            let mut options = options(dir.path(), grid, sample, zstd);
            options.bake.threads = threads;
            if threads == 1 {
                bake_and_check(&tape, &grid, &options);
            } else {
                bake_ok(&tape, &options);
            }
            let names = entries(dir.path());
            let bytes: Vec<Vec<u8>> = names
                .iter()
                .map(|n| std::fs::read(dir.path().join(n)).unwrap())
                .collect();
            files.push((names, bytes));
        }
        assert!(
            files[0] == files[1],
            "{sample:?} {zstd:?}: files differ with the thread count"
        );
    }
}

/// The Data Format Descriptor of `VK_FORMAT_R8G8B8A8_SRGB` and of `VK_FORMAT_R32_SFLOAT`, word
/// by word as computed by hand from the specifications.
#[test]
fn the_dfd_is_the_specification_layout_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let grid = odd_grid();
    let (tape, _) = load_file(MARBLE, &[]);
    bake_ok(&tape, &options(dir.path(), grid, Ktx2SampleType::U8, None));
    let colour = read_ktx2(&dir.path().join("g.colour.ktx2"));
    let words: Vec<u32> = colour
        .dfd()
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
        .collect();
    #[rustfmt::skip]
    let rgba8_srgb: [u32; 23] = [
        // KTX spec "dfdTotalSize": the whole descriptor, this word included: 4 + 24 + 4 × 16.
        92,
        // Khronos Data Format 1.3, "Descriptor block": vendorId (17 bits) = 0 (Khronos),
        // descriptorType (15 bits) = 0 (basic format).
        0x0000_0000,
        // versionNumber (16 bits) = 2 (KHR_DF_VERSIONNUMBER_1_3), descriptorBlockSize (16 bits)
        // = 24 + 4 samples × 16 = 88 = 0x58.
        0x0058_0002,
        // colorModel = 1 (RGBSDA), colorPrimaries = 1 (BT709), transferFunction = 2 (SRGB: the
        // KTX spec "Restrictions" demands it of an _SRGB vkFormat), flags = 0 (straight alpha).
        0x0002_0101,
        // texelBlockDimension0..3 = 0 (a 1×1×1×1 block, stored minus one).
        0x0000_0000,
        // bytesPlane0 = 4 bytes a texel; bytesPlane1..3 = 0.
        0x0000_0004,
        // bytesPlane4..7 = 0.
        0x0000_0000,
        // Sample 0, red: bitOffset 0, bitLength 8 - 1 = 7, channelType 0 (RED), no qualifiers;
        // samplePosition 0; sampleLower 0, sampleUpper 255 (8-bit UNORM).
        0x0007_0000, 0, 0, 255,
        // Sample 1, green: bitOffset 8, channelType 1.
        0x0107_0008, 0, 0, 255,
        // Sample 2, blue: bitOffset 16, channelType 2.
        0x0207_0010, 0, 0, 255,
        // Sample 3, alpha: bitOffset 24, channelType 15 (ALPHA) with the LINEAR qualifier (0x10;
        // KTX spec "Restrictions": with a non-linear transfer the alpha sample is linear): 0x1F.
        0x1F07_0018, 0, 0, 255,
    ];
    assert_eq!(words, rgba8_srgb);
    // The same bytes sit at dfdByteOffset = 80 (header) + 24 (one level index entry) = 104.
    assert_eq!(colour.header.index.dfd_byte_offset, 104);

    let dir = tempfile::tempdir().unwrap();
    bake_ok(
        &tape,
        &options(dir.path(), grid, Ktx2SampleType::F32, Some(3)),
    );
    let vein = read_ktx2(&dir.path().join("g.vein.ktx2"));
    let words: Vec<u32> = vein
        .dfd()
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
        .collect();
    #[rustfmt::skip]
    let r32_sfloat: [u32; 11] = [
        44,          // dfdTotalSize = 4 + 24 + 16
        0,           // Khronos, basic format
        0x0028_0002, // version 2, descriptorBlockSize 40
        0x0001_0101, // RGBSDA, BT709, LINEAR, straight alpha
        0,           // 1×1×1×1 texel block
        4,           // bytesPlane0 = 4: the texel size, unchanged by Zstandard (KTX spec "DFD for
                     // Supercompressed Data")
        0,
        // Red: bitOffset 0, bitLength 31, channelType 0 with FLOAT (0x80) | SIGNED (0x40).
        0xC01F_0000,
        0,
        0xBF80_0000, // sampleLower -1.0f
        0x3F80_0000, // sampleUpper 1.0f
    ];
    assert_eq!(words, r32_sfloat);
}

/// The first 80 bytes of one file, computed by hand (spec "File Structure").
#[test]
fn the_header_is_the_specification_layout_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let (tape, _) = load_file(MARBLE, &[]);
    bake_ok(
        &tape,
        &options(dir.path(), odd_grid(), Ktx2SampleType::F16, Some(7)),
    );
    let file = read_ktx2(&dir.path().join("g.colour.ktx2"));
    let dfd_length = 4 + 24 + 4 * 16;
    let kvd_offset = 104 + dfd_length;
    let mut expected = vec![
        0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
    ];
    for word in [
        97,  // vkFormat VK_FORMAT_R16G16B16A16_SFLOAT
        2,   // typeSize: 16-bit components
        5,   // pixelWidth
        3,   // pixelHeight
        4,   // pixelDepth
        0,   // layerCount
        1,   // faceCount
        1,   // levelCount
        2,   // supercompressionScheme: Zstandard
        104, // dfdByteOffset
        dfd_length,
        kvd_offset,
        file.header.index.kvd_byte_length,
    ] {
        expected.extend(u32::to_le_bytes(word));
    }
    expected.extend([0u8; 16]); // sgdByteOffset, sgdByteLength
    assert_eq!(&file.bytes[..80], &expected[..]);
    // The level starts right after the key/value data (no alignment with supercompression).
    assert_eq!(
        file.level_index[0],
        u64::from(kvd_offset + file.header.index.kvd_byte_length)
    );
}

// ---------------------------------------------------------------------------------------------
// The checks before a bake, interrupted and replaced bakes

#[test]
fn existing_files_are_refused_without_force_and_replaced_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let (tape, _) = load_file(MARBLE, &[]);
    let grid = odd_grid();
    let first = options(dir.path(), grid, Ktx2SampleType::U8, None);
    bake_ok(&tape, &first);
    let before = std::fs::read(dir.path().join("g.colour.ktx2")).unwrap();
    let second = options(dir.path(), grid, Ktx2SampleType::F32, Some(3));
    let error = bake_files(&tape, &second, &mut |_| {}).unwrap_err();
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("--force")),
        "{error}"
    );
    assert_eq!(
        std::fs::read(dir.path().join("g.colour.ktx2")).unwrap(),
        before
    );
    bake_ok(
        &tape,
        &BakeFileOptions {
            force: true,
            ..second.clone()
        },
    );
    let after = read_ktx2(&dir.path().join("g.colour.ktx2"));
    assert_eq!(after.header.format, Some(ktx2::Format::R32G32B32A32_SFLOAT));
    assert_eq!(entries(dir.path()), ["g.colour.ktx2", "g.vein.ktx2"]);
}

#[test]
fn an_interrupted_bake_leaves_no_file() {
    let tape = load_file(MARBLE, &[("octaves", 1.0)]).0;
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    // 128×128×64 on 2 threads: several windows.
    let grid = Grid {
        size: [128, 128, 64],
        region: Region::default(),
    };
    for zstd in [None, Some(3)] {
        let cancel = Arc::new(AtomicBool::new(false));
        let mut options = options(&out, grid, Ktx2SampleType::U8, zstd);
        options.bake.cancel = Some(cancel.clone());
        let result = bake_files(&tape, &options, &mut |_| {
            cancel.store(true, Ordering::Relaxed)
        });
        assert!(
            matches!(result, Err(BakeError::Cancelled)),
            "{:?}",
            result.map(|r| r.files)
        );
        assert_eq!(entries(&out), Vec::<String>::new());
    }
    assert_eq!(entries(tmp.path()), Vec::<String>::new());
}

#[test]
fn an_interrupted_forced_bake_keeps_the_previous_files() {
    let tape = load_file(MARBLE, &[("octaves", 1.0)]).0;
    let grid = Grid {
        size: [128, 128, 64],
        region: Region::default(),
    };
    for zstd in [None, Some(3)] {
        let dir = tempfile::tempdir().unwrap();
        bake_ok(
            &tape,
            &options(dir.path(), odd_grid(), Ktx2SampleType::U8, zstd),
        );
        let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
        let before = (read("g.colour.ktx2"), read("g.vein.ktx2"));
        let cancel = Arc::new(AtomicBool::new(false));
        let mut forced = options(dir.path(), grid, Ktx2SampleType::F16, zstd);
        forced.force = true;
        forced.bake.cancel = Some(cancel.clone());
        let result = bake_files(&tape, &forced, &mut |_| {
            cancel.store(true, Ordering::Relaxed)
        });
        assert!(matches!(result, Err(BakeError::Cancelled)));
        assert!((read("g.colour.ktx2"), read("g.vein.ktx2")) == before);
        assert_eq!(entries(dir.path()), ["g.colour.ktx2", "g.vein.ktx2"]);
    }
}

/// A destination that is not a regular file is never replaced, with or without `force`.
#[cfg(unix)]
#[test]
fn a_link_or_folder_in_the_way_is_refused_even_with_force() {
    let (tape, _) = load_file(MARBLE, &[]);
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("elsewhere");
    std::fs::write(&target, b"keep").unwrap();
    std::os::unix::fs::symlink(&target, dir.path().join("g.colour.ktx2")).unwrap();
    std::fs::create_dir(dir.path().join("g.vein.ktx2")).unwrap();
    for force in [false, true] {
        let options = BakeFileOptions {
            force,
            ..options(dir.path(), odd_grid(), Ktx2SampleType::U8, None)
        };
        let error = bake_files(&tape, &options, &mut |_| {}).unwrap_err();
        assert!(error.to_string().contains("symbolic link"), "{error}");
        assert_eq!(error.exit_code(), 2);
    }
    assert_eq!(std::fs::read(&target).unwrap(), b"keep");
    assert_eq!(
        entries(dir.path()),
        ["elsewhere", "g.colour.ktx2", "g.vein.ktx2"]
    );
}

#[test]
fn sizes_a_ktx2_file_cannot_hold_and_encoder_memory_are_refused_before_anything_is_written() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let tape = load_text(EXTREMES);
    // pixelWidth is a UInt32.
    let wide = Grid {
        size: [1 << 32, 1, 1],
        region: Region::default(),
    };
    let mut options_wide = options(&out, wide, Ktx2SampleType::U8, None);
    options_wide.max_bytes = u64::MAX;
    let started = std::time::Instant::now();
    let error = bake_files(&tape, &options_wide, &mut |_| {}).unwrap_err();
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("32-bit")),
        "{error}"
    );
    assert!(started.elapsed().as_secs() < 5, "nothing is evaluated");
    // Three outputs at level 22 of a 256³ grid: three encoders of over 800 MiB each.
    let grid = Grid::cube(256);
    let error = bake_files(
        &tape,
        &options(&out, grid, Ktx2SampleType::F32, Some(22)),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("Zstandard encoder") && m.contains("--allow-large")),
        "{error}"
    );
    // A level out of range is refused by the library too.
    let error = bake_files(
        &tape,
        &options(&out, odd_grid(), Ktx2SampleType::U8, Some(23)),
        &mut |_| {},
    )
    .unwrap_err();
    assert!(
        matches!(&error, BakeError::Refused(m) if m.contains("1 to 22")),
        "{error}"
    );
    assert!(!out.exists(), "a refused bake created its folder");
}

// ---------------------------------------------------------------------------------------------
// The command line

fn texgraph(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(root())
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .output()
        .expect("run texgraph")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("UTF-8 temp path")
}

#[test]
fn cli_bakes_ktx2_files_with_every_option() {
    let tmp = tempfile::tempdir().unwrap();
    for (args, colour_format, level) in [
        (vec![], ktx2::Format::R8G8B8A8_SRGB, None),
        (
            vec!["--transfer", "linear"],
            ktx2::Format::R8G8B8A8_UNORM,
            None,
        ),
        (
            vec!["--half", "--zstd"],
            ktx2::Format::R16G16B16A16_SFLOAT,
            // A bare --zstd is the documented default level.
            Some(texgraph::bake::DEFAULT_ZSTD_LEVEL),
        ),
        (
            vec!["--float", "--zstd=12"],
            ktx2::Format::R32G32B32A32_SFLOAT,
            Some(12),
        ),
    ] {
        let out: PathBuf = tmp.path().join(format!("out{}", args.join("")));
        let mut all = vec![
            "bake",
            MARBLE,
            "--size",
            "5,3,4",
            "--format",
            "ktx2",
            "--out",
            path_str(&out),
        ];
        all.extend(args.iter().copied());
        let output = texgraph(&all);
        let (stdout, stderr) = (text(&output.stdout), text(&output.stderr));
        assert_eq!(
            output.status.code(),
            Some(0),
            "{args:?}\n{stdout}\n{stderr}"
        );
        let colour = read_ktx2(&out.join("seed003_marble.colour.ktx2"));
        assert_eq!(colour.header.format, Some(colour_format), "{args:?}");
        let vein = read_ktx2(&out.join("seed003_marble.vein.ktx2"));
        assert_eq!(
            [
                vein.header.pixel_width,
                vein.header.pixel_height,
                vein.header.pixel_depth
            ],
            [5, 3, 4]
        );
        assert_eq!(
            colour.value("KTXwriterScParams").map(text),
            level.map(|l| format!("--zstd={l}\0")),
            "{args:?}"
        );
        assert_eq!(colour.text("texgraph.graph"), MARBLE);
        let zstd = level.map_or(String::new(), |l| format!(", Zstandard level {l}"));
        let name = format!("{colour_format:?}");
        assert!(
            stdout.contains(&format!(
                "colour -> {} (KTX2 3D texture 5×3×4 {name}{zstd})",
                out.join("seed003_marble.colour.ktx2").display()
            )),
            "{stdout}"
        );
    }
}

/// An 8-bit file clamps; the warning says how to keep the values.
#[test]
fn cli_warns_about_clamped_values_in_8_bit_files_only() {
    let tmp = tempfile::tempdir().unwrap();
    let graph = tmp.path().join("extremes.ron");
    std::fs::write(&graph, EXTREMES).unwrap();
    let out = tmp.path().join("out");
    let output = texgraph(&[
        "bake",
        path_str(&graph),
        "--size",
        "4",
        "--region=-1,-1,-1:1,1,1",
        "--format",
        "ktx2",
        "--out",
        path_str(&out),
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("output \"ramp\"")
            && stderr.contains("bake with --half or --float to keep them"),
        "{stderr}"
    );
    assert!(text(&output.stdout).contains("clamped to [0, 1]"));
    let output = texgraph(&[
        "bake",
        path_str(&graph),
        "--size",
        "4",
        "--region=-1,-1,-1:1,1,1",
        "--format",
        "ktx2",
        "--half",
        "--force",
        "--out",
        path_str(&out),
    ]);
    assert_eq!(output.status.code(), Some(0), "{}", text(&output.stderr));
    assert!(
        !text(&output.stderr).contains("clamped"),
        "{}",
        text(&output.stderr)
    );
}

/// Options that do not apply are usage errors (exit code 2), before anything is written.
#[test]
fn cli_options_that_do_not_apply_are_usage_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    for (args, message) in [
        (
            vec!["--zstd"],
            "--zstd applies to --format ktx2 and --format zarr with --compression zstd only, not to --format png",
        ),
        (
            vec!["--format", "raw", "--zstd=5"],
            "--zstd applies to --format ktx2 and --format zarr with --compression zstd only, not to --format raw",
        ),
        (
            vec!["--format", "exr", "--float"],
            "--float applies to --format ktx2 or zarr only, not to --format exr",
        ),
        (
            vec!["--half"],
            "--half applies to --format exr, ktx2 or zarr only, not to --format png",
        ),
        (
            vec!["--format", "ktx2", "--atlas"],
            "--atlas applies to --format png only, not to --format ktx2",
        ),
        (
            vec!["--format", "ktx2", "--depth", "16"],
            "--depth applies to --format png only, not to --format ktx2",
        ),
        (
            vec!["--format", "ktx2", "--raw-type", "f32"],
            "--raw-type applies to --format raw only, not to --format ktx2",
        ),
        (
            vec!["--format", "ktx2", "--alpha"],
            "--alpha applies to --format raw only, not to --format ktx2",
        ),
        (
            vec!["--format", "ktx2", "--exr-compression", "zip"],
            "--exr-compression applies to --format exr only, not to --format ktx2",
        ),
        (
            vec!["--format", "ktx2", "--half", "--float"],
            "--half and --float are alternatives",
        ),
        (
            vec!["--format", "ktx2", "--half", "--transfer", "linear"],
            "--transfer applies to 8/16-bit files",
        ),
        (
            vec!["--format", "ktx2", "--float", "--transfer", "srgb"],
            "--transfer applies to 8/16-bit files",
        ),
        (vec!["--format", "ktx2", "--zstd=0"], "--zstd"),
        (vec!["--format", "ktx2", "--zstd=23"], "--zstd"),
        (vec!["--format", "ktx2", "--zstd=fast"], "--zstd"),
        (
            vec!["--format", "zarr", "--compression", "blosc", "--zstd=5"],
            "--zstd applies to --format ktx2 and --format zarr with --compression zstd only",
        ),
        (
            vec!["--format", "ktx2", "--chunk", "8"],
            "--chunk applies to --format zarr only, not to --format ktx2",
        ),
        (
            vec!["--format", "raw", "--shard", "8"],
            "--shard applies to --format zarr only, not to --format raw",
        ),
        (
            vec!["--format", "png", "--compression", "none"],
            "--compression applies to --format zarr only",
        ),
        (vec!["--format", "png", "--part", "1/2"], "--part splits a zarr store's shards"),
        (vec!["--format", "zarr", "--parts", "2"], "--parts N goes with --part auto"),
    ] {
        let mut all = vec!["bake", MARBLE, "--size", "2", "--out", path_str(&out)];
        all.extend(args.iter().copied());
        let output = texgraph(&all);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains(message),
            "{args:?}: stderr lacks {message:?}:\n{stderr}"
        );
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            !out.exists(),
            "{args:?}: a usage error created the output folder"
        );
    }
    // `--zstd 9` would read 9 as a graph file.
    let output = texgraph(&[
        "bake",
        MARBLE,
        "--format",
        "ktx2",
        "--zstd",
        "9",
        "--out",
        path_str(&out),
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output.stderr));
    assert!(
        text(&output.stderr).contains("--zstd=9"),
        "{}",
        text(&output.stderr)
    );
    assert!(!out.exists());
    // A size KTX2 cannot hold is refused (exit 2) before anything is evaluated.
    let output = texgraph(&[
        "bake",
        MARBLE,
        "--size",
        "4294967296,1,1",
        "--format",
        "ktx2",
        "--allow-large",
        "--out",
        path_str(&out),
    ]);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output.stderr));
    assert!(
        text(&output.stderr).contains("32-bit unsigned integer"),
        "{}",
        text(&output.stderr)
    );
    assert!(!out.exists());
}
