//! OpenVDB files: dense voxel boxes written as OpenVDB grids. No Rust crate writes OpenVDB, so
//! this writer is hand-written from the published file format (the OpenVDB sources:
//! `io/Archive.cc`, `io/GridDescriptor.cc`, `io/Compression.h`, `tree/RootNode.h`,
//! `tree/InternalNode.h`, `tree/LeafNode.h`, `math/Maps.h`, `MetaMap.cc`).
//!
//! It writes file format version [`FILE_VERSION`] (224, "multi-pass I/O") with library version
//! 10.0 in the header, so OpenVDB 10.0 and newer read it without a warning. A file is:
//!
//! * the header: magic `0x56444220` ("VDB " as a little-endian 64-bit integer), file version,
//!   library major and minor version, a "has grid offsets" byte (1), a 36-character UUID
//!   (derived from the file's content, so the output is deterministic), an empty file-level
//!   metadata map and the grid count;
//! * per grid, a grid descriptor (unique name, grid type, empty instance-parent name, and the
//!   absolute file offsets of the grid, of its leaf buffers and of its end), then the grid: its
//!   compression flags (`COMPRESS_ACTIVE_MASK` only: no zip, no blosc), its metadata, its
//!   transform, its tree topology, and its leaf buffers.
//!
//! The tree is OpenVDB's standard 5-4-3 tree: a root node whose children are
//! `InternalNode<5>` nodes (32³ children, 4096³ voxels each), whose children are
//! `InternalNode<4>` nodes (16³ children, 128³ voxels), whose children are `LeafNode<3>` (8³
//! voxels). Grid types are `Tree_float_5_4_3` ([`VdbGridKind::Float`]) and `Tree_vec3s_5_4_3`
//! ([`VdbGridKind::Vec3`]). The background value is 0; the root has no tiles; every voxel of the
//! box `[0, nx) × [0, ny) × [0, nz)` (index space) is active, and the voxels of a partial node
//! outside the box are inactive with the background value.
//!
//! Compression: active-mask compression only (`COMPRESS_ACTIVE_MASK`, part of OpenVDB's own
//! default; no zip or blosc, so a reader built without them reads the file). Each node's value
//! array is preceded by the per-node metadata byte `NO_MASK_OR_INACTIVE_VALS` (0: every inactive
//! value is the background) and holds only the node's active values, in offset order: none for
//! the internal nodes (no tiles), the voxels inside the box for a leaf (all 512 for a full one).
//! So the file holds the voxels once plus the tree's masks, whatever the box's shape. Values are
//! written little-endian, the byte order of every platform OpenVDB runs on in practice.
//!
//! Voxel (i, j, k) of the box is index coordinate (i, j, k); OpenVDB index coordinates are voxel
//! centres, so the transform maps it to `origin + (i, j, k) · voxel_size`: a
//! `UniformScaleTranslateMap` when the voxel size is the same on all axes, else a
//! `ScaleTranslateMap`.
//!
//! Grid metadata: `class` ("fog volume" for float grids, "unknown" for vec3 grids), `name`,
//! `file_bbox_min` / `file_bbox_max` (vec3i, inclusive), `file_compression` ("active values"),
//! `file_mem_bytes` (int64, the grid's `memUsage()` once loaded: exact for OpenVDB 10.0 on
//! x86-64), `file_voxel_count` (int64), `is_saved_as_half_float` (bool, false), for vec3 grids
//! `vector_type` ("invariant": colours and other tuples), and the caller's own entries as
//! strings. These are the statistics OpenVDB's own writer adds (less `file_delayed_load`, which
//! is optional).
//!
//! Memory: the caller hands over the whole volume; the writer adds no copy of it. Offsets are
//! computed up front from the node and voxel counts (no zip or blosc: known sizes), so the tree
//! is streamed node by node and leaf by leaf through an internal 64 KiB buffer.

use std::io::{self, Write};

/// The file format version written: 224, `OPENVDB_FILE_VERSION_MULTIPASS_IO`.
pub const FILE_VERSION: u32 = 224;
/// The library version written in the header: OpenVDB 10.0 (whose file format version is 224).
pub const LIBRARY_VERSION: [u32; 2] = [10, 0];
/// The file's magic number: "VDB " read as a little-endian 64-bit integer.
pub const MAGIC: u64 = 0x5644_4220;

/// Log2 of the dimension of a leaf node (8³ voxels).
const LEAF_LOG2: u32 = 3;
/// Log2 of the dimension of a lower internal node (16³ leaves).
const LOWER_LOG2: u32 = 4;
/// Log2 of the dimension of an upper internal node (32³ lower internal nodes).
const UPPER_LOG2: u32 = 5;
/// Voxels along one side of a leaf node.
const LEAF_SPAN: u64 = 1 << LEAF_LOG2;
/// Voxels along one side of a lower internal node.
const LOWER_SPAN: u64 = 1 << (LEAF_LOG2 + LOWER_LOG2);
/// Voxels along one side of an upper internal node (a root child).
const UPPER_SPAN: u64 = 1 << (LEAF_LOG2 + LOWER_LOG2 + UPPER_LOG2);
/// Values (and mask bits) of a node whose side has `2^log2` entries.
const fn node_values(log2: u32) -> u64 {
    1 << (3 * log2)
}
/// Bytes of the value mask or child mask of a node whose side has `2^log2` entries.
const fn mask_bytes(log2: u32) -> u64 {
    node_values(log2) / 8
}
/// The largest voxel count along an axis: the last index must fit OpenVDB's 32-bit coordinates.
pub const MAX_AXIS_VOXELS: usize = 1 << 31;

/// Grid compression flags: `COMPRESS_ACTIVE_MASK` (only the active values of a node are stored).
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
/// Per-node compression metadata: `NO_MASK_OR_INACTIVE_VALS`, every inactive value is the
/// background, so only the active values follow.
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;
/// The separator OpenVDB puts between a grid name and the number that makes it unique.
const UNIQUE_NAME_SEPARATOR: char = '\u{1e}';

/// Metadata names the writer sets itself; the caller may not set them.
pub const RESERVED_METADATA: [&str; 10] = [
    "class",
    "file_bbox_max",
    "file_bbox_min",
    "file_compression",
    "file_delayed_load",
    "file_mem_bytes",
    "file_voxel_count",
    "is_saved_as_half_float",
    "name",
    "vector_type",
];

/// One grid to write.
#[derive(Clone, Copy, Debug)]
pub struct VdbGrid<'a> {
    /// The grid name, e.g. "density" or the output name.
    pub name: &'a str,
    /// Float (1 channel) or Vec3 (3 channels, a vec3s grid).
    pub kind: VdbGridKind,
    /// Voxels along x, y, z: a dense box, index space `[0, n)` per axis.
    pub size: [usize; 3],
    /// Interleaved channels, x fastest, then y, then z; `len = nx · ny · nz · channels`.
    pub values: &'a [f32],
    /// World spacing per axis (may differ per axis).
    pub voxel_size: [f64; 3],
    /// World position of voxel (0, 0, 0)'s centre.
    pub origin: [f64; 3],
    /// Extra string metadata on the grid (e.g. the texgraph graph path, params as JSON).
    pub metadata: &'a [(String, String)],
}

/// The value type of a grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VdbGridKind {
    /// One `float` a voxel: `Tree_float_5_4_3`.
    Float,
    /// Three `float`s a voxel: `Tree_vec3s_5_4_3`.
    Vec3,
}

impl VdbGridKind {
    /// Channels (floats) a voxel.
    pub fn channels(self) -> usize {
        match self {
            VdbGridKind::Float => 1,
            VdbGridKind::Vec3 => 3,
        }
    }

    /// OpenVDB's grid type name.
    pub fn type_name(self) -> &'static str {
        match self {
            VdbGridKind::Float => "Tree_float_5_4_3",
            VdbGridKind::Vec3 => "Tree_vec3s_5_4_3",
        }
    }

    /// Bytes of one value in the file.
    fn value_bytes(self) -> u64 {
        4 * self.channels() as u64
    }
}

/// Writes an OpenVDB file holding `grids` to `out`.
///
/// Every grid is checked before anything is written; an invalid one (wrong `values` length, a
/// zero or too large size, a voxel size that is not a positive finite number, a non-finite
/// origin, a name holding NUL, reserved, empty or repeated metadata names) gives an error of
/// kind [`io::ErrorKind::InvalidInput`]. Grids with the same name (or no name) get OpenVDB's
/// unique-name suffix, as OpenVDB's own writer does. `out` need not be buffered.
pub fn write_vdb<W: Write>(out: W, grids: &[VdbGrid<'_>]) -> io::Result<()> {
    let plans = plan_grids(grids)?;
    let grid_count = i32::try_from(plans.len()).map_err(|_| invalid("too many grids"))?;
    let mut out = Counter {
        inner: io::BufWriter::with_capacity(1 << 16, out),
        written: 0,
    };
    out.write_all(&file_header(&file_uuid(&plans), grid_count))?;
    for plan in &plans {
        write_grid(&mut out, plan)?;
    }
    out.flush()
}

/// A grid checked and laid out: everything needed to write it.
struct GridPlan<'g, 'a> {
    grid: &'g VdbGrid<'a>,
    /// The name in the descriptor: the grid name, made unique if needed.
    unique_name: String,
    size: [u64; 3],
    /// Compression flags, metadata and transform: everything before the topology.
    head: Vec<u8>,
    /// Bytes of the topology (tree structure) and of the leaf buffers.
    topology_bytes: u64,
    buffer_bytes: u64,
}

/// Checks every grid and lays it out, giving grids with a shared or empty name unique names.
fn plan_grids<'g, 'a>(grids: &'g [VdbGrid<'a>]) -> io::Result<Vec<GridPlan<'g, 'a>>> {
    let mut plans = Vec::with_capacity(grids.len());
    let mut used: Vec<String> = Vec::with_capacity(grids.len());
    for (index, grid) in grids.iter().enumerate() {
        let size = validate(grid)
            .map_err(|e| invalid(&format!("VDB grid {index} ({:?}): {e}", grid.name)))?;
        let shared = grids.iter().filter(|g| g.name == grid.name).count() > 1;
        let unique_name = unique_name(grid.name, shared, &used);
        used.push(unique_name.clone());
        let counts = NodeCounts::of(size);
        let vs = grid.kind.value_bytes();
        let too_large = || invalid(&format!("VDB grid {:?} is too large", grid.name));
        plans.push(GridPlan {
            grid,
            unique_name,
            size,
            head: grid_head(grid, size, counts)?,
            topology_bytes: counts.topology_bytes(vs).ok_or_else(too_large)?,
            buffer_bytes: counts
                .buffer_bytes(size.iter().product(), vs)
                .ok_or_else(too_large)?,
        });
    }
    Ok(plans)
}

/// OpenVDB's unique grid name (`Archive::write`): the name itself, or, when it is empty or
/// shared with another grid, the name, a record separator (0x1E) and the first number not
/// already used.
fn unique_name(name: &str, shared: bool, used: &[String]) -> String {
    let mut candidate = name.to_owned();
    if name.is_empty() || shared {
        candidate = format!("{name}{UNIQUE_NAME_SEPARATOR}0");
    }
    let mut n = 1u64;
    while used.contains(&candidate) {
        candidate = format!("{name}{UNIQUE_NAME_SEPARATOR}{n}");
        n += 1;
    }
    candidate
}

/// Checks one grid; returns its size as u64. The message names the problem (the caller adds
/// which grid).
fn validate(grid: &VdbGrid<'_>) -> Result<[u64; 3], String> {
    if grid.name.contains(['\0', UNIQUE_NAME_SEPARATOR]) {
        return Err("the name must not contain NUL or 0x1E characters".into());
    }
    let mut voxels = 1usize;
    for (axis, &n) in grid.size.iter().enumerate() {
        if n == 0 || n > MAX_AXIS_VOXELS {
            return Err(format!(
                "size {:?}: every axis needs 1 to {MAX_AXIS_VOXELS} voxels (axis {axis} has {n})",
                grid.size
            ));
        }
        voxels = voxels
            .checked_mul(n)
            .ok_or_else(|| format!("size {:?} overflows", grid.size))?;
    }
    let expected = voxels
        .checked_mul(grid.kind.channels())
        .ok_or_else(|| format!("size {:?} overflows", grid.size))?;
    if grid.values.len() != expected {
        return Err(format!(
            "{} values for {:?} voxels of {} channel(s): expected {expected}",
            grid.values.len(),
            grid.size,
            grid.kind.channels()
        ));
    }
    for &v in &grid.voxel_size {
        let inverse = 1.0 / v;
        if !(v.is_normal() && v > 0.0 && inverse.is_normal() && (inverse * inverse).is_normal()) {
            return Err(format!(
                "voxel size {:?}: each must be a positive finite number between about 1e-154 \
                 and 1e153",
                grid.voxel_size
            ));
        }
    }
    if !grid.origin.iter().all(|o| o.is_finite()) {
        return Err(format!("origin {:?} is not finite", grid.origin));
    }
    validate_metadata(grid.metadata)?;
    Ok(grid.size.map(|n| n as u64))
}

/// Checks the caller's metadata names: non-empty, no NUL, not reserved, not repeated.
fn validate_metadata(metadata: &[(String, String)]) -> Result<(), String> {
    for (i, (key, _)) in metadata.iter().enumerate() {
        if key.is_empty() || key.contains('\0') {
            return Err(format!("metadata name {key:?} is empty or holds NUL"));
        }
        if RESERVED_METADATA.contains(&key.as_str()) {
            return Err(format!(
                "metadata name {key:?} is reserved (the writer sets it)"
            ));
        }
        if metadata[..i].iter().any(|(k, _)| k == key) {
            return Err(format!("metadata name {key:?} is repeated"));
        }
    }
    Ok(())
}

/// An `io::Error` of kind InvalidInput.
fn invalid(message: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message.to_owned())
}

/// How many nodes of each level a dense box `[0, n)` per axis needs. The box starts at the
/// origin, so at every level the nodes form a full grid of `ceil(n / span)` nodes per axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct NodeCounts {
    upper: u64,
    lower: u64,
    leaves: u64,
}

impl NodeCounts {
    fn of(size: [u64; 3]) -> NodeCounts {
        let count = |span: u64| size.iter().map(|n| n.div_ceil(span)).product::<u64>();
        NodeCounts {
            upper: count(UPPER_SPAN),
            lower: count(LOWER_SPAN),
            leaves: count(LEAF_SPAN),
        }
    }

    /// Bytes of the topology of a tree whose values take `vs` bytes: buffer count, background,
    /// tile and child counts, then per root child its origin and node, per internal node its
    /// two masks and metadata byte (no active values), per leaf its value mask.
    fn topology_bytes(self, vs: u64) -> Option<u64> {
        let upper = 12 + 2 * mask_bytes(UPPER_LOG2) + 1;
        let lower = 2 * mask_bytes(LOWER_LOG2) + 1;
        (4 + vs + 8)
            .checked_add(self.upper.checked_mul(upper)?)?
            .checked_add(self.lower.checked_mul(lower)?)?
            .checked_add(self.leaves.checked_mul(mask_bytes(LEAF_LOG2))?)
    }

    /// Bytes of the leaf buffers of a box of `voxels` voxels: per leaf its value mask and
    /// metadata byte, then the active values, every voxel of the box once.
    fn buffer_bytes(self, voxels: u64, vs: u64) -> Option<u64> {
        let leaf = mask_bytes(LEAF_LOG2) + 1;
        self.leaves
            .checked_mul(leaf)?
            .checked_add(voxels.checked_mul(vs)?)
    }

    /// The grid's in-memory size once loaded (`Grid::memUsage()` on a 64-bit build), for
    /// `file_mem_bytes`: per internal node its table of value/child unions, masks and origin;
    /// per leaf its struct and value buffer; plus the grid, tree and root objects. Exact for
    /// OpenVDB 10.0 on x86-64 (checked against it); other builds differ by a few bytes a node.
    fn mem_bytes(self, vs: u64) -> u64 {
        let union_bytes = if vs <= 8 { 8 } else { 16 };
        let fixed = if vs <= 8 { 1304 } else { 1320 };
        let upper = node_values(UPPER_LOG2) * union_bytes + 2 * mask_bytes(UPPER_LOG2) + 12;
        let lower = node_values(LOWER_LOG2) * union_bytes + 2 * mask_bytes(LOWER_LOG2) + 12;
        let leaf = 96 + node_values(LEAF_LOG2) * vs;
        (self.upper.saturating_mul(upper))
            .saturating_add(fixed)
            .saturating_add(self.lower.saturating_mul(lower))
            .saturating_add(self.leaves.saturating_mul(leaf))
    }
}

/// A metadata value, as OpenVDB's typed metadata.
enum MetaValue<'a> {
    Str(&'a str),
    Bool(bool),
    Int64(i64),
    Vec3i([i32; 3]),
}

/// The bytes of a grid before its topology: compression flags, metadata, transform.
fn grid_head(grid: &VdbGrid<'_>, size: [u64; 3], counts: NodeCounts) -> io::Result<Vec<u8>> {
    let max = size.map(|n| i32::try_from(n - 1).unwrap_or(i32::MAX));
    let voxels = size.iter().product::<u64>();
    let mut meta: Vec<(&str, MetaValue<'_>)> = vec![
        (
            "class",
            MetaValue::Str(match grid.kind {
                VdbGridKind::Float => "fog volume",
                VdbGridKind::Vec3 => "unknown",
            }),
        ),
        ("file_bbox_max", MetaValue::Vec3i(max)),
        ("file_bbox_min", MetaValue::Vec3i([0; 3])),
        ("file_compression", MetaValue::Str("active values")),
        (
            "file_mem_bytes",
            MetaValue::Int64(
                i64::try_from(counts.mem_bytes(grid.kind.value_bytes())).unwrap_or(i64::MAX),
            ),
        ),
        (
            "file_voxel_count",
            MetaValue::Int64(i64::try_from(voxels).unwrap_or(i64::MAX)),
        ),
        ("is_saved_as_half_float", MetaValue::Bool(false)),
        ("name", MetaValue::Str(grid.name)),
    ];
    if grid.kind == VdbGridKind::Vec3 {
        meta.push(("vector_type", MetaValue::Str("invariant")));
    }
    meta.extend(
        grid.metadata
            .iter()
            .map(|(k, v)| (k.as_str(), MetaValue::Str(v))),
    );
    // OpenVDB keeps metadata in a std::map, so its files list it sorted by name.
    meta.sort_by(|a, b| a.0.cmp(b.0));

    let mut head = Vec::new();
    head.extend_from_slice(&COMPRESS_ACTIVE_MASK.to_le_bytes());
    put_metadata(&mut head, &meta)?;
    put_transform(&mut head, grid.voxel_size, grid.origin)?;
    Ok(head)
}

/// Appends a metadata map (`MetaMap::writeMeta`): the entry count, then per entry its name,
/// type name, value size and value bytes.
fn put_metadata(out: &mut Vec<u8>, meta: &[(&str, MetaValue<'_>)]) -> io::Result<()> {
    let count = u32::try_from(meta.len()).map_err(|_| invalid("too many metadata entries"))?;
    out.extend_from_slice(&count.to_le_bytes());
    for (name, value) in meta {
        put_string(out, name)?;
        match value {
            MetaValue::Str(s) => {
                put_string(out, "string")?;
                put_string(out, s)?;
            }
            MetaValue::Bool(b) => {
                put_string(out, "bool")?;
                out.extend_from_slice(&1u32.to_le_bytes());
                out.push(u8::from(*b));
            }
            MetaValue::Int64(v) => {
                put_string(out, "int64")?;
                out.extend_from_slice(&8u32.to_le_bytes());
                out.extend_from_slice(&v.to_le_bytes());
            }
            MetaValue::Vec3i(v) => {
                put_string(out, "vec3i")?;
                out.extend_from_slice(&12u32.to_le_bytes());
                for c in v {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
    }
    Ok(())
}

/// Appends the transform (`Transform::write`): the map type name, then the map's fields as
/// `ScaleTranslateMap::write` lays them out: translation, scale, voxel size, inverse scale,
/// inverse scale squared, half the inverse scale (three doubles each).
fn put_transform(out: &mut Vec<u8>, voxel_size: [f64; 3], origin: [f64; 3]) -> io::Result<()> {
    let uniform = voxel_size[0] == voxel_size[1] && voxel_size[1] == voxel_size[2];
    put_string(
        out,
        if uniform {
            "UniformScaleTranslateMap"
        } else {
            "ScaleTranslateMap"
        },
    )?;
    let inverse = voxel_size.map(|v| 1.0 / v);
    let fields = [
        origin,
        voxel_size,
        voxel_size.map(f64::abs),
        inverse,
        inverse.map(|v| v * v),
        inverse.map(|v| v / 2.0),
    ];
    for v in fields.iter().flatten() {
        out.extend_from_slice(&v.to_le_bytes());
    }
    Ok(())
}

/// Appends a string as OpenVDB writes one: a 32-bit length, then the bytes (no terminator).
fn put_string(out: &mut Vec<u8>, s: &str) -> io::Result<()> {
    let len = u32::try_from(s.len()).map_err(|_| invalid("a string is longer than 4 GiB"))?;
    out.extend_from_slice(&len.to_le_bytes());
    out.extend_from_slice(s.as_bytes());
    Ok(())
}

/// The file header (`Archive::writeHeader`), the empty file metadata and the grid count.
fn file_header(uuid: &str, grid_count: i32) -> Vec<u8> {
    let mut out = Vec::with_capacity(65);
    out.extend_from_slice(&MAGIC.to_le_bytes());
    out.extend_from_slice(&FILE_VERSION.to_le_bytes());
    out.extend_from_slice(&LIBRARY_VERSION[0].to_le_bytes());
    out.extend_from_slice(&LIBRARY_VERSION[1].to_le_bytes());
    out.push(1); // has grid offsets
    out.extend_from_slice(uuid.as_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // file metadata: no entries
    out.extend_from_slice(&grid_count.to_le_bytes());
    out
}

/// A 128-bit fingerprint of the data, not cryptographic: two multiply-xor lanes.
struct Fingerprint([u64; 2]);

impl Fingerprint {
    fn new() -> Fingerprint {
        Fingerprint([0x9E37_79B9_7F4A_7C15, 0xC2B2_AE3D_27D4_EB4F])
    }

    fn word(&mut self, v: u64) {
        let [a, b] = &mut self.0;
        *a = (*a ^ v).wrapping_mul(0x0000_0100_0000_01B3);
        *a ^= *a >> 29;
        *b = (*b ^ v.rotate_left(32)).wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        *b ^= *b >> 31;
    }

    fn bytes(&mut self, bytes: &[u8]) {
        self.word(bytes.len() as u64);
        let mut chunks = bytes.chunks_exact(8);
        for chunk in &mut chunks {
            let mut word = [0u8; 8];
            word.copy_from_slice(chunk);
            self.word(u64::from_le_bytes(word));
        }
        let mut last = [0u8; 8];
        last[..chunks.remainder().len()].copy_from_slice(chunks.remainder());
        self.word(u64::from_le_bytes(last));
    }

    fn finish(&self) -> u128 {
        let mix = |mut z: u64| {
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        (u128::from(mix(self.0[0] ^ self.0[1].rotate_left(17))) << 64)
            | u128::from(mix(self.0[1] ^ self.0[0]))
    }
}

/// The file's UUID: a fingerprint of everything written (names, types, sizes, metadata,
/// transforms, values) formatted as a version-4 UUID, so the same input gives the same file and
/// changed content gives a different UUID (OpenVDB tools compare UUIDs to notice a changed file).
fn file_uuid(plans: &[GridPlan<'_, '_>]) -> String {
    let mut print = Fingerprint::new();
    print.word(u64::from(FILE_VERSION));
    for plan in plans {
        print.bytes(plan.unique_name.as_bytes());
        print.bytes(plan.grid.kind.type_name().as_bytes());
        plan.size.iter().for_each(|&n| print.word(n));
        print.bytes(&plan.head);
        let mut pairs = plan.grid.values.chunks_exact(2);
        for pair in &mut pairs {
            print.word(u64::from(pair[0].to_bits()) | (u64::from(pair[1].to_bits()) << 32));
        }
        pairs
            .remainder()
            .iter()
            .for_each(|v| print.word(u64::from(v.to_bits())));
    }
    uuid_string(print.finish())
}

/// Formats 128 bits as a version-4, RFC 4122 variant UUID: 8-4-4-4-12 lowercase hex digits.
fn uuid_string(bits: u128) -> String {
    let bits = (bits & !(0xF << 76) & !(0x3 << 62)) | (0x4 << 76) | (0x2 << 62);
    let hex = format!("{bits:032x}");
    format!(
        "{}-{}-{}-{}-{}",
        &hex[..8],
        &hex[8..12],
        &hex[12..16],
        &hex[16..20],
        &hex[20..]
    )
}

/// A writer that counts the bytes written through it, to check the offsets computed up front.
struct Counter<W: Write> {
    inner: W,
    written: u64,
}

impl<W: Write> Write for Counter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.written += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// Writes one grid: its descriptor (with the absolute offsets of the grid, its leaf buffers and
/// its end, computed from the planned sizes), head, topology and buffers, checking that each
/// part ends where the descriptor says.
fn write_grid<W: Write>(out: &mut Counter<W>, plan: &GridPlan<'_, '_>) -> io::Result<()> {
    let mut descriptor = Vec::new();
    put_string(&mut descriptor, &plan.unique_name)?;
    put_string(&mut descriptor, plan.grid.kind.type_name())?;
    put_string(&mut descriptor, "")?; // instance parent: none
    let too_large = || invalid("the VDB file would be larger than 8 EiB");
    let grid_pos = (out.written + descriptor.len() as u64 + 24) as i64;
    let block_pos = grid_pos
        .checked_add(plan.head.len() as i64)
        .and_then(|p| p.checked_add(i64::try_from(plan.topology_bytes).ok()?))
        .ok_or_else(too_large)?;
    let end_pos = block_pos
        .checked_add(i64::try_from(plan.buffer_bytes).map_err(|_| too_large())?)
        .ok_or_else(too_large)?;
    for pos in [grid_pos, block_pos, end_pos] {
        descriptor.extend_from_slice(&pos.to_le_bytes());
    }
    out.write_all(&descriptor)?;
    out.write_all(&plan.head)?;
    let vs = plan.grid.kind.value_bytes();
    write_topology(out, plan.size, vs)?;
    check_position(out, block_pos, "topology")?;
    write_buffers(out, plan.grid, plan.size)?;
    check_position(out, end_pos, "leaf buffers")
}

/// Fails if the writer is not at `expected`: the planned sizes were wrong (a bug, reported
/// rather than leaving a file whose offsets lie).
fn check_position<W: Write>(out: &Counter<W>, expected: i64, part: &str) -> io::Result<()> {
    if out.written as i64 != expected {
        return Err(io::Error::other(format!(
            "VDB writer bug: the {part} ended at byte {} instead of {expected}",
            out.written
        )));
    }
    Ok(())
}

/// Calls `f` with the origin of every child of the node at `origin` whose side spans `span`
/// voxels (`u64::MAX` for the root), children spanning `child_span` voxels, that overlaps the box
/// `[0, size)`, in OpenVDB's order: x slowest, z fastest (the child table's offset order, and the
/// root's coordinate order).
fn for_each_child<F>(
    origin: [u64; 3],
    span: u64,
    child_span: u64,
    size: [u64; 3],
    mut f: F,
) -> io::Result<()>
where
    F: FnMut([u64; 3]) -> io::Result<()>,
{
    let counts = child_counts(origin, span, child_span, size);
    for a in 0..counts[0] {
        for b in 0..counts[1] {
            for c in 0..counts[2] {
                f([
                    origin[0] + a * child_span,
                    origin[1] + b * child_span,
                    origin[2] + c * child_span,
                ])?;
            }
        }
    }
    Ok(())
}

/// Children (or voxels, with `child_span` 1) of the node at `origin` that overlap the box
/// `[0, size)`, per axis. The node must overlap the box.
fn child_counts(origin: [u64; 3], span: u64, child_span: u64, size: [u64; 3]) -> [u64; 3] {
    [0, 1, 2].map(|axis| (size[axis] - origin[axis]).min(span).div_ceil(child_span))
}

/// Sets the bits of `words` (a node mask, all bits cleared first) for the entries `(a, b, c)`
/// with `a < counts[0]`, `b < counts[1]`, `c < counts[2]` of a node whose side has `2^log2`
/// entries: bit `(a << 2·log2) | (b << log2) | c`, as OpenVDB numbers them (x slowest).
fn set_box_mask(words: &mut [u64], log2: u32, counts: [u64; 3]) {
    words.fill(0);
    for a in 0..counts[0] {
        for b in 0..counts[1] {
            for c in 0..counts[2] {
                let bit = (a << (2 * log2)) | (b << log2) | c;
                words[(bit >> 6) as usize] |= 1 << (bit & 63);
            }
        }
    }
}

/// Writes a node mask: its 64-bit words, little-endian (`NodeMask::save`).
fn write_mask<W: Write>(out: &mut W, words: &[u64], scratch: &mut Vec<u8>) -> io::Result<()> {
    scratch.clear();
    scratch.extend(words.iter().flat_map(|w| w.to_le_bytes()));
    out.write_all(scratch)
}

/// Writes `n` zero bytes.
fn write_zeros<W: Write>(out: &mut W, mut n: u64) -> io::Result<()> {
    const ZEROS: [u8; 4096] = [0; 4096];
    while n > 0 {
        let chunk = n.min(ZEROS.len() as u64);
        out.write_all(&ZEROS[..chunk as usize])?;
        n -= chunk;
    }
    Ok(())
}

/// Writes the tree topology (`Tree::writeTopology`): buffer count 1, background 0, no tiles,
/// the root children (origin, then the node), each upper internal node's child mask, value
/// mask (all off: no tiles) and metadata byte (no active values follow), then its children's
/// topology, down to each leaf's value mask.
fn write_topology<W: Write>(out: &mut W, size: [u64; 3], vs: u64) -> io::Result<()> {
    let children = NodeCounts::of(size).upper;
    let children = u32::try_from(children).map_err(|_| invalid("too many root children"))?;
    out.write_all(&1i32.to_le_bytes())?;
    write_zeros(out, vs)?; // background
    out.write_all(&0u32.to_le_bytes())?; // tiles
    out.write_all(&children.to_le_bytes())?;
    let mut upper_mask = vec![0u64; (node_values(UPPER_LOG2) / 64) as usize];
    let mut lower_mask = vec![0u64; (node_values(LOWER_LOG2) / 64) as usize];
    let mut leaf_mask = [0u64; (node_values(LEAF_LOG2) / 64) as usize];
    let mut scratch = Vec::new();
    for_each_child([0; 3], u64::MAX, UPPER_SPAN, size, |upper| {
        for c in upper {
            // Validated: every index fits i32, and so does every node origin.
            out.write_all(&(c as i32).to_le_bytes())?;
        }
        let counts = child_counts(upper, UPPER_SPAN, LOWER_SPAN, size);
        set_box_mask(&mut upper_mask, UPPER_LOG2, counts);
        write_mask(out, &upper_mask, &mut scratch)?;
        write_zeros(out, mask_bytes(UPPER_LOG2))?; // value mask
        out.write_all(&[NO_MASK_OR_INACTIVE_VALS])?;
        for_each_child(upper, UPPER_SPAN, LOWER_SPAN, size, |lower| {
            let counts = child_counts(lower, LOWER_SPAN, LEAF_SPAN, size);
            set_box_mask(&mut lower_mask, LOWER_LOG2, counts);
            write_mask(out, &lower_mask, &mut scratch)?;
            write_zeros(out, mask_bytes(LOWER_LOG2))?; // value mask
            out.write_all(&[NO_MASK_OR_INACTIVE_VALS])?;
            for_each_child(lower, LOWER_SPAN, LEAF_SPAN, size, |leaf| {
                set_box_mask(
                    &mut leaf_mask,
                    LEAF_LOG2,
                    child_counts(leaf, LEAF_SPAN, 1, size),
                );
                write_mask(out, &leaf_mask, &mut scratch)
            })
        })
    })
}

/// Writes the leaf buffers (`Tree::writeBuffers`), leaf by leaf in topology order: the value
/// mask, the metadata byte, then the active values (the voxels inside the box, x slowest, z
/// fastest).
fn write_buffers<W: Write>(out: &mut W, grid: &VdbGrid<'_>, size: [u64; 3]) -> io::Result<()> {
    let mut leaf_mask = [0u64; (node_values(LEAF_LOG2) / 64) as usize];
    let mut scratch = Vec::new();
    let mut values = vec![0u8; (node_values(LEAF_LOG2) * grid.kind.value_bytes()) as usize];
    for_each_child([0; 3], u64::MAX, UPPER_SPAN, size, |upper| {
        for_each_child(upper, UPPER_SPAN, LOWER_SPAN, size, |lower| {
            for_each_child(lower, LOWER_SPAN, LEAF_SPAN, size, |leaf| {
                let extent = child_counts(leaf, LEAF_SPAN, 1, size);
                set_box_mask(&mut leaf_mask, LEAF_LOG2, extent);
                write_mask(out, &leaf_mask, &mut scratch)?;
                out.write_all(&[NO_MASK_OR_INACTIVE_VALS])?;
                let len = fill_leaf(&mut values, grid, leaf, extent);
                out.write_all(&values[..len])
            })
        })
    })
}

/// Puts into `dest` the active values of the leaf at `origin`, whose first `extent` voxels per
/// axis lie in the box, in OpenVDB's leaf order (offset `x·64 + y·8 + z`, so x slowest, z
/// fastest); returns the bytes used.
fn fill_leaf(dest: &mut [u8], grid: &VdbGrid<'_>, origin: [u64; 3], extent: [u64; 3]) -> usize {
    let channels = grid.kind.channels();
    let mut len = 0;
    let [nx, ny, _] = grid.size;
    // Validated: every index of the box fits usize (the values slice holds them all).
    let [ox, oy, oz] = origin.map(|o| o as usize);
    for x in 0..extent[0] as usize {
        for y in 0..extent[1] as usize {
            for z in 0..extent[2] as usize {
                let voxel = ((oz + z) * ny + (oy + y)) * nx + (ox + x);
                for v in &grid.values[voxel * channels..(voxel + 1) * channels] {
                    dest[len..len + 4].copy_from_slice(&v.to_le_bytes());
                    len += 4;
                }
            }
        }
    }
    len
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid<'a>(values: &'a [f32], size: [usize; 3], kind: VdbGridKind) -> VdbGrid<'a> {
        VdbGrid {
            name: "density",
            kind,
            size,
            values,
            voxel_size: [0.5; 3],
            origin: [0.25; 3],
            metadata: &[],
        }
    }

    fn write(grids: &[VdbGrid<'_>]) -> io::Result<Vec<u8>> {
        let mut bytes = Vec::new();
        write_vdb(&mut bytes, grids)?;
        Ok(bytes)
    }

    #[test]
    fn box_mask_bits_follow_openvdb_offsets() {
        let mut words = [u64::MAX; 8];
        set_box_mask(&mut words, LEAF_LOG2, [1, 1, 3]);
        assert_eq!(words, [0b111, 0, 0, 0, 0, 0, 0, 0]);
        set_box_mask(&mut words, LEAF_LOG2, [2, 1, 1]);
        // (1, 0, 0) is offset 64: bit 0 of word 1.
        assert_eq!(words, [1, 1, 0, 0, 0, 0, 0, 0]);
        set_box_mask(&mut words, LEAF_LOG2, [1, 2, 8]);
        assert_eq!(words[0], 0xFFFF);
        set_box_mask(&mut words, LEAF_LOG2, [8, 8, 8]);
        assert_eq!(words, [u64::MAX; 8]);
        let mut upper = vec![0u64; 512];
        set_box_mask(&mut upper, UPPER_LOG2, [1, 1, 32]);
        assert_eq!(upper[0], 0xFFFF_FFFF);
        assert_eq!(upper.iter().map(|w| w.count_ones()).sum::<u32>(), 32);
    }

    #[test]
    fn child_counts_clip_to_the_box() {
        assert_eq!(
            child_counts([0; 3], u64::MAX, UPPER_SPAN, [1, 4096, 4097]),
            [1, 1, 2]
        );
        assert_eq!(
            child_counts([0, 0, 4096], UPPER_SPAN, LOWER_SPAN, [1, 1, 4097]),
            [1, 1, 1]
        );
        assert_eq!(
            child_counts([8, 0, 0], LEAF_SPAN, 1, [19, 8, 33]),
            [8, 8, 8]
        );
        assert_eq!(
            child_counts([16, 0, 32], LEAF_SPAN, 1, [19, 8, 33]),
            [3, 8, 1]
        );
    }

    #[test]
    fn header_bytes() {
        let uuid = uuid_string(0);
        let header = file_header(&uuid, 2);
        assert_eq!(header.len(), 65);
        assert_eq!(&header[..8], b" BDV\0\0\0\0");
        assert_eq!(header[8..12], 224u32.to_le_bytes());
        assert_eq!(header[12..16], 10u32.to_le_bytes());
        assert_eq!(header[16..20], 0u32.to_le_bytes());
        assert_eq!(header[20], 1);
        assert_eq!(&header[21..57], uuid.as_bytes());
        assert_eq!(header[57..61], 0u32.to_le_bytes());
        assert_eq!(header[61..65], 2i32.to_le_bytes());
    }

    #[test]
    fn uuids_look_valid() {
        for bits in [0u128, u128::MAX, 0x0123_4567_89AB_CDEF_0123_4567_89AB_CDEF] {
            let uuid = uuid_string(bits);
            assert_eq!(uuid.len(), 36);
            for (i, c) in uuid.char_indices() {
                match i {
                    8 | 13 | 18 | 23 => assert_eq!(c, '-'),
                    14 => assert_eq!(c, '4'),
                    19 => assert!("89ab".contains(c), "{uuid}"),
                    _ => assert!(c.is_ascii_hexdigit() && !c.is_ascii_uppercase()),
                }
            }
        }
    }

    #[test]
    fn transform_bytes() {
        let mut out = Vec::new();
        put_transform(&mut out, [0.5, 0.5, 0.5], [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(&out[4..28], b"UniformScaleTranslateMap");
        let doubles: Vec<f64> = out[28..]
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        let expected = [
            1.0, 2.0, 3.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 2.0, 2.0, 2.0, 4.0, 4.0, 4.0, 1.0, 1.0,
            1.0,
        ];
        assert_eq!(doubles, expected);
        out.clear();
        put_transform(&mut out, [0.5, 1.0, 0.5], [0.0; 3]).unwrap();
        assert_eq!(&out[4..21], b"ScaleTranslateMap");
    }

    #[test]
    fn unique_names_follow_openvdb() {
        assert_eq!(unique_name("a", false, &[]), "a");
        assert_eq!(unique_name("a", true, &[]), "a\u{1e}0");
        assert_eq!(unique_name("a", true, &["a\u{1e}0".into()]), "a\u{1e}1");
        assert_eq!(unique_name("", false, &[]), "\u{1e}0");
    }

    #[test]
    fn planned_sizes_match_the_bytes_written() {
        for (size, kind) in [
            ([1, 1, 1], VdbGridKind::Float),
            ([19, 8, 33], VdbGridKind::Float),
            ([10, 12, 9], VdbGridKind::Vec3),
            ([129, 3, 2], VdbGridKind::Vec3),
            ([4097, 1, 2], VdbGridKind::Float),
            ([1, 4100, 1], VdbGridKind::Vec3),
        ] {
            let n = size.iter().product::<usize>() * kind.channels();
            let values: Vec<f32> = (0..n).map(|i| i as f32 - 7.5).collect();
            // write_grid checks every planned offset against the bytes actually written.
            let bytes = write(&[grid(&values, size, kind)]).unwrap();
            let counts = NodeCounts::of(size.map(|n| n as u64));
            let vs = kind.value_bytes();
            let voxels = (n / kind.channels()) as u64;
            let tree =
                counts.topology_bytes(vs).unwrap() + counts.buffer_bytes(voxels, vs).unwrap();
            assert!(bytes.len() as u64 > tree);
        }
    }

    #[test]
    fn node_counts() {
        let counts = NodeCounts::of([4097, 129, 8]);
        assert_eq!(
            counts,
            NodeCounts {
                upper: 2,
                lower: 33 * 2,
                leaves: 513 * 17
            }
        );
    }

    #[test]
    fn output_is_deterministic_and_the_uuid_follows_the_content() {
        let mut values = vec![1.0f32; 27];
        let a = write(&[grid(&values, [3, 3, 3], VdbGridKind::Float)]).unwrap();
        let b = write(&[grid(&values, [3, 3, 3], VdbGridKind::Float)]).unwrap();
        assert_eq!(a, b);
        values[26] = 2.0;
        let c = write(&[grid(&values, [3, 3, 3], VdbGridKind::Float)]).unwrap();
        assert_ne!(a[21..57], c[21..57]);
    }

    #[test]
    fn invalid_grids_are_refused() {
        let values = vec![0.0f32; 8];
        let meta = [("name".to_owned(), "x".to_owned())];
        let repeated = [
            ("a".to_owned(), "x".to_owned()),
            ("a".to_owned(), "y".to_owned()),
        ];
        let cases: [fn(&mut VdbGrid<'_>); 13] = [
            |g| g.size = [2, 2, 3],
            |g| g.size = [0, 2, 2],
            |g| g.size = [usize::MAX, usize::MAX, 1],
            |g| g.kind = VdbGridKind::Vec3,
            |g| g.voxel_size = [1.0, 0.0, 1.0],
            |g| g.voxel_size = [1.0, -1.0, 1.0],
            |g| g.voxel_size = [f64::NAN, 1.0, 1.0],
            |g| g.voxel_size = [1.0, 1.0, f64::INFINITY],
            |g| g.voxel_size = [1e-300, 1.0, 1.0],
            |g| g.origin = [0.0, f64::NAN, 0.0],
            |g| g.size = [MAX_AXIS_VOXELS; 3],
            |g| g.name = "a\0b",
            |g| g.name = "a\u{1e}0",
        ];
        for (i, case) in cases.iter().enumerate() {
            let mut g = grid(&values, [2, 2, 2], VdbGridKind::Float);
            case(&mut g);
            let err = write(&[g]).expect_err(&format!("case {i}"));
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "case {i}: {err}");
        }
        for metadata in [&meta[..], &repeated[..]] {
            let mut g = grid(&values, [2, 2, 2], VdbGridKind::Float);
            g.metadata = metadata;
            let err = write(&[g]).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{err}");
        }
        let empty_key = [(String::new(), "x".to_owned())];
        let mut g = grid(&values, [2, 2, 2], VdbGridKind::Float);
        g.metadata = &empty_key;
        assert_eq!(write(&[g]).unwrap_err().kind(), io::ErrorKind::InvalidInput);
    }

    #[test]
    fn no_grids_is_a_valid_file() {
        let bytes = write(&[]).unwrap();
        assert_eq!(bytes.len(), 65);
        assert_eq!(bytes[61..65], 0i32.to_le_bytes());
    }
}
