//! `texgraph::bake::vdb`: OpenVDB files read back by OpenVDB itself. The Python binding
//! (`pyopenvdb`, Debian/Ubuntu package `python3-openvdb`; the module is `openvdb` from OpenVDB 11
//! on) reads every file and reports grid names, types, classes, active voxel counts, bounding
//! boxes, transforms, metadata and every voxel's value and active state, over the box and one
//! voxel beyond it on every side; values are compared bit for bit. `vdb_print` (package
//! `libopenvdb-tools`) must print every file. The interpreter is `$TEXGRAPH_PYTHON`, `python3` or
//! `/usr/bin/python3`, the first that imports the binding. Without OpenVDB those checks print a
//! `SKIPPED` line and pass; CI installs the packages.
//!
//! The byte-structure test needs no OpenVDB: header fields, grid count, and the descriptors'
//! offsets, which must chain grid to grid and end at the file's length.
//!
//! Grids are odd-sized (19×8×33: partial leaves along x and z), vec3, anisotropic, two in one
//! file, and one wider than a root child (4099 voxels along x: two root children). Values are a
//! hash of the voxel index, negative and positive, with every mantissa bit in use.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;
use texgraph::bake::vdb::{write_vdb, VdbGrid, VdbGridKind};

/// A deterministic value in [-4, 4) for voxel `index` (channel included) of stream `salt`.
fn value(index: usize, salt: u32) -> f32 {
    let mut h = (index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ u64::from(salt);
    h ^= h >> 31;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 29;
    ((h >> 40) as f32 / (1u64 << 24) as f32) * 8.0 - 4.0
}

/// Owned data for one grid, borrowed by [`Spec::grid`].
struct Spec {
    name: &'static str,
    kind: VdbGridKind,
    size: [usize; 3],
    values: Vec<f32>,
    voxel_size: [f64; 3],
    origin: [f64; 3],
    metadata: Vec<(String, String)>,
}

impl Spec {
    fn new(name: &'static str, kind: VdbGridKind, size: [usize; 3], salt: u32) -> Spec {
        let n = size.iter().product::<usize>() * kind.channels();
        Spec {
            name,
            kind,
            size,
            values: (0..n).map(|i| value(i, salt)).collect(),
            voxel_size: [0.25; 3],
            origin: [-1.5, 2.0, 0.125],
            metadata: vec![
                ("texgraph_graph".into(), "graphs/seed003_marble.ron".into()),
                (
                    "texgraph_params".into(),
                    r#"{"scale":2.5,"name":"ü"}"#.into(),
                ),
            ],
        }
    }

    fn grid(&self) -> VdbGrid<'_> {
        VdbGrid {
            name: self.name,
            kind: self.kind,
            size: self.size,
            values: &self.values,
            voxel_size: self.voxel_size,
            origin: self.origin,
            metadata: &self.metadata,
        }
    }

    /// The value of channel `c` of voxel (i, j, k).
    fn at(&self, [i, j, k]: [usize; 3], c: usize) -> f32 {
        let [nx, ny, _] = self.size;
        self.values[((k * ny + j) * nx + i) * self.kind.channels() + c]
    }
}

/// The files of the test: a name and the grids in it.
fn cases() -> Vec<(&'static str, Vec<Spec>)> {
    let odd = Spec::new("density", VdbGridKind::Float, [19, 8, 33], 1);
    let mut vec3 = Spec::new("colour", VdbGridKind::Vec3, [10, 12, 9], 2);
    vec3.voxel_size = [0.1; 3];
    vec3.origin = [0.05, 0.05, 0.05];
    let mut aniso = Spec::new("aniso", VdbGridKind::Float, [7, 5, 11], 3);
    aniso.voxel_size = [0.5, 0.25, 2.0];
    aniso.origin = [1.0, -2.0, 3.0];
    let mut wide = Spec::new("wide", VdbGridKind::Float, [4099, 3, 2], 4);
    wide.metadata.clear();
    let both = vec![
        Spec::new("density", VdbGridKind::Float, [19, 8, 33], 5),
        Spec::new("colour", VdbGridKind::Vec3, [10, 12, 9], 6),
    ];
    vec![
        ("odd", vec![odd]),
        ("vec3", vec![vec3]),
        ("aniso", vec![aniso]),
        ("wide", vec![wide]),
        ("both", both),
    ]
}

fn write_file(dir: &Path, name: &str, specs: &[Spec]) -> PathBuf {
    let grids: Vec<VdbGrid<'_>> = specs.iter().map(Spec::grid).collect();
    let path = dir.join(format!("{name}.vdb"));
    let file = std::fs::File::create(&path).unwrap();
    write_vdb(file, &grids).unwrap();
    path
}

// ---------------------------------------------------------------------------------------------
// Byte structure (no OpenVDB needed)

/// A little-endian reader over the file's bytes.
struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl Cursor<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        s
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let n = self.u32() as usize;
        String::from_utf8(self.take(n).to_vec()).unwrap()
    }
}

/// Metadata names of the grid whose head starts at the cursor (compression flags first).
fn metadata_names(c: &mut Cursor<'_>) -> Vec<(String, String)> {
    assert_eq!(c.u32(), 2, "compression flags: COMPRESS_ACTIVE_MASK");
    let count = c.u32();
    (0..count)
        .map(|_| {
            let name = c.string();
            let type_name = c.string();
            let n = c.u32() as usize;
            c.take(n);
            (name, type_name)
        })
        .collect()
}

#[test]
fn file_structure() {
    let dir = tempfile::tempdir().unwrap();
    for (name, specs) in cases() {
        let bytes = std::fs::read(write_file(dir.path(), name, &specs)).unwrap();
        let mut c = Cursor {
            bytes: &bytes,
            pos: 0,
        };
        assert_eq!(c.take(8), b" BDV\0\0\0\0", "{name}: magic");
        assert_eq!(c.u32(), 224, "{name}: file version");
        assert_eq!([c.u32(), c.u32()], [10, 0], "{name}: library version");
        assert_eq!(c.take(1), [1], "{name}: has grid offsets");
        let uuid = std::str::from_utf8(c.take(36)).unwrap().to_owned();
        let dashes: Vec<usize> = uuid.match_indices('-').map(|(i, _)| i).collect();
        assert_eq!(dashes, [8, 13, 18, 23], "{name}: uuid {uuid}");
        assert_eq!(c.u32(), 0, "{name}: file metadata count");
        assert_eq!(c.u32() as usize, specs.len(), "{name}: grid count");
        for spec in &specs {
            assert_eq!(c.string(), spec.name);
            assert_eq!(c.string(), spec.kind.type_name());
            assert_eq!(c.string(), "", "instance parent");
            let [grid, block, end] = [c.i64(), c.i64(), c.i64()].map(|p| p as usize);
            assert_eq!(grid, c.pos, "{name}: the grid follows its descriptor");
            assert!(grid < block && block < end && end <= bytes.len(), "{name}");
            let leaves = spec.size.iter().map(|n| n.div_ceil(8)).product::<usize>();
            // Per leaf its value mask and metadata byte, then each voxel once (active values).
            let voxels = spec.size.iter().product::<usize>();
            let values = voxels * 4 * spec.kind.channels();
            assert_eq!(end - block, leaves * 65 + values, "{name}: leaf buffers");
            let meta = metadata_names(&mut c);
            for key in [
                "class",
                "name",
                "file_bbox_min",
                "file_bbox_max",
                "file_voxel_count",
            ] {
                assert!(
                    meta.iter().any(|(k, _)| k == key),
                    "{name}: {key} in {meta:?}"
                );
            }
            for (key, _) in &spec.metadata {
                assert!(
                    meta.contains(&(key.clone(), "string".into())),
                    "{name}: {key}"
                );
            }
            let map = c.string();
            let uniform = spec.voxel_size.iter().all(|&v| v == spec.voxel_size[0]);
            let expected = ["ScaleTranslateMap", "UniformScaleTranslateMap"][usize::from(uniform)];
            assert_eq!(map, expected, "{name}");
            c.pos = end;
        }
        assert_eq!(c.pos, bytes.len(), "{name}: the last grid ends the file");
        let again = std::fs::read(write_file(dir.path(), name, &specs)).unwrap();
        assert_eq!(bytes, again, "{name}: the output is deterministic");
    }
}

#[test]
fn invalid_input_writes_nothing() {
    let mut spec = Spec::new("density", VdbGridKind::Float, [3, 3, 3], 9);
    spec.values.pop();
    let mut out = Vec::new();
    let err = write_vdb(&mut out, &[spec.grid()]).unwrap_err();
    assert_eq!(err.kind(), std::io::ErrorKind::InvalidInput);
    assert!(err.to_string().contains("expected 27"), "{err}");
    assert!(out.is_empty());
}

// ---------------------------------------------------------------------------------------------
// OpenVDB's reader

/// Reads the file named by argv[1] with OpenVDB and prints JSON. Values are reported as the bits
/// of the float32 each component holds, with the active state last: `[bits..., active]`, for
/// every voxel of the active bounding box grown by one voxel on every side, x fastest.
const READER: &str = r#"
import json, struct, sys
try:
    import openvdb as vdb
except ImportError:
    import pyopenvdb as vdb

def plain(v):
    if isinstance(v, (tuple, list)):
        return [plain(x) for x in v]
    return v

def map_type(xf):
    t = getattr(xf, "typeName", None)
    return t() if callable(t) else t

def bits(x):
    return struct.unpack('<I', struct.pack('<f', x))[0]

grids, file_meta = vdb.readAll(sys.argv[1])
out = {
    "library": plain(vdb.LIBRARY_VERSION),
    "file_metadata": {k: str(v) for k, v in file_meta.items()},
    "grids": [],
}
for g in grids:
    lo, hi = g.evalActiveVoxelBoundingBox()
    xf = g.transform
    acc = g.getConstAccessor()
    values = []
    for k in range(lo[2] - 1, hi[2] + 2):
        for j in range(lo[1] - 1, hi[1] + 2):
            for i in range(lo[0] - 1, hi[0] + 2):
                v, active = acc.probeValue((i, j, k))
                comps = v if isinstance(v, (tuple, list)) else (v,)
                values.append([bits(x) for x in comps] + [1 if active else 0])
    # Every leaf is loaded now (OpenVDB loads leaf buffers lazily).
    mem_usage = g.memUsage()
    out["grids"].append({
        "name": g.name,
        "type": g.valueTypeName,
        "class": str(g.gridClass),
        "active": g.activeVoxelCount(),
        "leaves": g.leafCount(),
        "mem_usage": mem_usage,
        "bbox": [plain(lo), plain(hi)],
        "background": plain(g.background),
        "voxel_size": plain(xf.voxelSize()),
        "map": map_type(xf),
        "world": [plain(xf.indexToWorld(p)) for p in [(0, 0, 0), (1, 2, 3), (-1, 5, 7)]],
        "metadata": {k: plain(v) for k, v in g.metadata.items()},
        "values": values,
    })
print(json.dumps(out))
"#;

/// A Python interpreter that imports OpenVDB's binding: `$TEXGRAPH_PYTHON`, `python3`, or the
/// system's `/usr/bin/python3` (where Debian's `python3-openvdb` installs it, when `python3` on
/// the PATH is another interpreter, e.g. pyenv's).
fn openvdb_python() -> Option<String> {
    let probe = "try:\n import openvdb\nexcept ImportError:\n import pyopenvdb";
    let mut candidates: Vec<String> = std::env::var("TEXGRAPH_PYTHON").into_iter().collect();
    candidates.extend(["python3".into(), "/usr/bin/python3".into()]);
    candidates.into_iter().find(|python| {
        Command::new(python)
            .args(["-c", probe])
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

fn read_with_openvdb(python: &str, path: &Path) -> Value {
    let output = Command::new(python)
        .args(["-c", READER])
        .arg(path)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "OpenVDB failed to read {}: {stderr}",
        path.display()
    );
    assert!(
        !stderr.contains("WARN") && !stderr.contains("ERROR"),
        "OpenVDB complained reading {}: {stderr}",
        path.display()
    );
    serde_json::from_slice(&output.stdout).unwrap()
}

/// Checks one grid as OpenVDB read it against the spec it was written from.
fn check_grid(file: &str, spec: &Spec, got: &Value) {
    let [nx, ny, nz] = spec.size;
    let what = format!("{file}/{}", spec.name);
    assert_eq!(got["name"], spec.name, "{what}");
    let (value_type, class) = match spec.kind {
        VdbGridKind::Float => ("float", "fog volume"),
        VdbGridKind::Vec3 => ("vec3s", "unknown"),
    };
    assert_eq!(got["type"], value_type, "{what}");
    assert_eq!(got["class"], class, "{what}");
    assert_eq!(
        got["active"],
        (nx * ny * nz) as u64,
        "{what}: active voxels"
    );
    let leaves = spec.size.iter().map(|n| n.div_ceil(8)).product::<usize>();
    assert_eq!(got["leaves"], leaves as u64, "{what}: leaves");
    let bbox = serde_json::json!([[0, 0, 0], [nx - 1, ny - 1, nz - 1]]);
    assert_eq!(got["bbox"], bbox, "{what}: bbox");
    let voxel: Vec<f64> = serde_json::from_value(got["voxel_size"].clone()).unwrap();
    assert_eq!(voxel, spec.voxel_size, "{what}: voxel size");
    for (point, world) in [[0, 0, 0], [1, 2, 3], [-1, 5, 7]]
        .iter()
        .zip(got["world"].as_array().unwrap())
    {
        let world: Vec<f64> = serde_json::from_value(world.clone()).unwrap();
        for axis in 0..3 {
            let expected = spec.origin[axis] + f64::from(point[axis]) * spec.voxel_size[axis];
            assert!(
                (world[axis] - expected).abs() <= 1e-12 * expected.abs().max(1.0),
                "{what}: index {point:?} -> world {world:?}"
            );
        }
    }
    check_metadata(&what, spec, &got["metadata"], &got["mem_usage"]);
    check_values(&what, spec, got["values"].as_array().unwrap());
}

fn check_metadata(what: &str, spec: &Spec, meta: &Value, got_mem_usage: &Value) {
    let [nx, ny, nz] = spec.size;
    assert_eq!(meta["name"], spec.name, "{what}: {meta}");
    assert_eq!(
        meta["file_bbox_min"],
        serde_json::json!([0, 0, 0]),
        "{what}"
    );
    let max = serde_json::json!([nx - 1, ny - 1, nz - 1]);
    assert_eq!(meta["file_bbox_max"], max, "{what}");
    assert_eq!(meta["file_voxel_count"], (nx * ny * nz) as u64, "{what}");
    // OpenVDB's own writer stores the grid's memUsage(); ours is exact for OpenVDB 10.0 on
    // x86-64, close elsewhere.
    let (mem, loaded) = (meta["file_mem_bytes"].as_f64(), got_mem_usage.as_f64());
    let (mem, loaded) = (mem.unwrap(), loaded.unwrap());
    assert!(
        (mem - loaded).abs() <= 0.05 * loaded,
        "{what}: file_mem_bytes {mem} vs {loaded}"
    );
    assert_eq!(meta["is_saved_as_half_float"], false, "{what}");
    assert_eq!(meta["file_compression"], "active values", "{what}");
    if spec.kind == VdbGridKind::Vec3 {
        assert_eq!(meta["vector_type"], "invariant", "{what}");
    }
    for (key, value) in &spec.metadata {
        assert_eq!(meta[key], value.as_str(), "{what}: {key}");
    }
}

/// Every voxel of the box grown by one: inside, active with the written bits; outside,
/// inactive with the background 0.
fn check_values(what: &str, spec: &Spec, values: &[Value]) {
    let [nx, ny, nz] = spec.size;
    let channels = spec.kind.channels();
    assert_eq!(values.len(), (nx + 2) * (ny + 2) * (nz + 2), "{what}");
    let mut n = 0;
    for k in -1..=nz as i64 {
        for j in -1..=ny as i64 {
            for i in -1..=nx as i64 {
                let got: Vec<u64> = serde_json::from_value(values[n].clone()).unwrap();
                n += 1;
                let inside = [i, j, k]
                    .iter()
                    .zip(spec.size)
                    .all(|(&c, n)| c >= 0 && c < n as i64);
                let mut expected: Vec<u64> = (0..channels)
                    .map(|c| match inside {
                        true => u64::from(spec.at([i, j, k].map(|c| c as usize), c).to_bits()),
                        false => 0,
                    })
                    .collect();
                expected.push(u64::from(inside));
                assert_eq!(got, expected, "{what}: voxel ({i}, {j}, {k})");
            }
        }
    }
}

/// Runs `vdb_print -l -m`; `None` when it is not installed.
fn vdb_print(path: &Path) -> Option<String> {
    let output = Command::new("vdb_print")
        .args(["-l", "-m"])
        .arg(path)
        .output()
        .ok()?;
    let text = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    assert!(
        output.status.success(),
        "vdb_print {}: {text}",
        path.display()
    );
    assert!(!text.contains("ERROR") && !text.contains("WARN"), "{text}");
    Some(text)
}

#[test]
fn openvdb_reads_every_voxel() {
    let Some(python) = openvdb_python() else {
        eprintln!("SKIPPED: OpenVDB (python3-openvdb) is not installed");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let mut printed = false;
    for (name, specs) in cases() {
        let path = write_file(dir.path(), name, &specs);
        let got = read_with_openvdb(&python, &path);
        let grids = got["grids"].as_array().unwrap();
        assert_eq!(grids.len(), specs.len(), "{name}: grid count");
        // OpenVDB lists a file's grids by name, not in file order.
        for spec in &specs {
            let grid = grids.iter().find(|g| g["name"] == spec.name);
            check_grid(name, spec, grid.expect(spec.name));
        }
        if let Some(text) = vdb_print(&path) {
            printed = true;
            // Each grid's section: "Name: ..." then, among others, "Number of active voxels: N"
            // (N with thousands separators).
            for spec in &specs {
                let section = text
                    .split("Name: ")
                    .find(|s| s.starts_with(&format!("{}\n", spec.name)))
                    .unwrap_or_else(|| panic!("{name}: no grid {} in {text}", spec.name));
                let count = section
                    .lines()
                    .find_map(|l| l.trim().strip_prefix("Number of active voxels:"))
                    .map(|n| n.trim().replace(',', ""));
                let voxels = spec.size.iter().product::<usize>().to_string();
                assert_eq!(count, Some(voxels), "{name}: {section}");
            }
        }
    }
    if !printed {
        eprintln!("SKIPPED: vdb_print (libopenvdb-tools) is not installed");
    }
    eprintln!("OpenVDB ({python}) read every file");
}

/// `bake --format vdb` end to end: the marble baked over a box with negative corners, read back
/// by OpenVDB: one file per graph, a grid per output named by it, every voxel as `eval_point`
/// gives it at the documented voxel centre, the transform mapping index (i, j, k) to that centre.
#[test]
fn openvdb_reads_a_bake_as_evaluated() {
    use texgraph::bake::{bake_files, BakeFileOptions, Format, Grid, Region};
    let Some(python) = openvdb_python() else {
        eprintln!("SKIPPED: OpenVDB (python3-openvdb) is not installed");
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("graphs/seed003_marble.ron");
    let text = std::fs::read_to_string(&path).unwrap();
    let graph = texgraph::check(
        texgraph::SourceFile::new(path.to_str().unwrap(), &text),
        &texgraph::CheckOptions::default(),
    )
    .unwrap();
    let tape = texgraph::compile(&graph, &texgraph::CompileOptions::default()).unwrap();
    let grid = Grid {
        size: [11, 6, 5],
        region: Region {
            min: [-1.0, -0.5, 0.25],
            max: [1.2, 0.7, 1.25],
        },
    };
    let dir = tempfile::tempdir().unwrap();
    let mut options = BakeFileOptions::new("marble", dir.path());
    options.bake.grid = grid;
    options.format = Format::Vdb;
    options.graph_path = "graphs/seed003_marble.ron".into();
    bake_files(&tape, &options, &mut |_| {}).unwrap();
    let file = dir.path().join("marble.vdb");
    let got = read_with_openvdb(&python, &file);
    let grids = got["grids"].as_array().unwrap();
    assert_eq!(grids.len(), 2);
    let mut workspace = texgraph::Workspace::<f32>::new();
    let mut out = vec![0f32; tape.channels()];
    let centre = |a: usize, i: i64| {
        let (lo, hi) = (grid.region.min[a], grid.region.max[a]);
        lo + (i as f64 + 0.5) * (hi - lo) / grid.size[a] as f64
    };
    for o in tape.outputs() {
        let g = grids.iter().find(|g| g["name"] == o.name.as_str()).unwrap();
        let channels = o.ty.channels();
        assert_eq!(g["active"], 11 * 6 * 5, "{}", o.name);
        assert_eq!(g["metadata"]["texgraph.output"], o.name.as_str());
        // indexToWorld((1, 2, 3)) is the centre of voxel (1, 2, 3).
        let world: Vec<f64> = serde_json::from_value(g["world"][1].clone()).unwrap();
        for (a, i) in [1, 2, 3].into_iter().enumerate() {
            assert!(
                (world[a] - centre(a, i)).abs() < 1e-12,
                "{}: {world:?}",
                o.name
            );
        }
        // Values over the active box plus a margin of one voxel, x fastest.
        let values = g["values"].as_array().unwrap();
        let mut n = 0;
        for k in -1..=5i64 {
            for j in -1..=6i64 {
                for i in -1..=11i64 {
                    let v: Vec<u64> = serde_json::from_value(values[n].clone()).unwrap();
                    n += 1;
                    let inside = i >= 0 && j >= 0 && k >= 0 && i < 11 && j < 6 && k < 5;
                    if !inside {
                        assert_eq!(*v.last().unwrap(), 0);
                        continue;
                    }
                    let p = [centre(0, i), centre(1, j), centre(2, k)];
                    tape.eval_point(&mut workspace, p, &mut out);
                    let want: Vec<u64> = out[o.first_channel..][..channels]
                        .iter()
                        .map(|x| u64::from(x.to_bits()))
                        .chain([1])
                        .collect();
                    assert_eq!(v, want, "{} voxel ({i}, {j}, {k})", o.name);
                }
            }
        }
    }
}
