//! `bake --format zarr`: stores read back with `zarrs` (its reader: sharding index, crc32c,
//! zstd / blosc) and every voxel checked against `eval_point` at the documented voxel centre;
//! split bakes (`--part`), resuming, `texgraph verify`, and bad input. zarr-python ≥ 3 reads a
//! store too when it is installed (CI installs it; the test says so when it skips).
//!
//! Grids are odd (19×7×11 over a box with negative coordinates) and chunks small, so edge
//! shards and chunks, an axis mix-up or a wrong channel order show.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::Arc;

use texgraph::bake::part::Part;
use texgraph::bake::zarr::{verify_store, ShardState, ZarrCompression};
use texgraph::bake::{
    bake_files, encode_u8, BakeFileOptions, Format, Grid, Ktx2SampleType, Region,
};
use texgraph::{Tape, Type};
use zarrs::array::Array;
use zarrs::filesystem::FilesystemStore;

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");
/// Outputs `colour` (vec3) and `vein` (scalar).
const MARBLE: &str = "graphs/seed003_marble.ron";

use common::{crate_root as root, load_graph_file as load_file};

fn odd_grid() -> Grid {
    Grid {
        size: [19, 7, 11],
        region: Region {
            min: [-0.5, -1.0, -0.75],
            max: [1.5, 0.25, 0.5],
        },
    }
}

use common::expected_volume as expected;

fn options(out: &Path, grid: Grid, sample: Ktx2SampleType) -> BakeFileOptions {
    let mut options = BakeFileOptions::new("marble", out);
    options.bake.grid = grid;
    options.bake.threads = 2;
    options.format = Format::Zarr;
    options.ktx2_type = sample;
    options.zarr.chunk = 4;
    options.zarr.shard = 8;
    options.graph_path = MARBLE.into();
    options
}

fn marble() -> Tape {
    load_file(MARBLE, &[("octaves", 3.0)]).0
}

/// Reads a whole array with zarrs.
fn read_array<T: zarrs::array::ElementOwned>(store: &Path, name: &str) -> (Vec<u64>, Vec<T>) {
    let storage = Arc::new(FilesystemStore::new(store).expect("store"));
    let array = Array::open(storage, &format!("/{name}")).expect("open array");
    let shape = array.shape().to_vec();
    let ranges: Vec<std::ops::Range<u64>> = shape.iter().map(|&n| 0..n).collect();
    let values = array
        .retrieve_array_subset::<Vec<T>>(&ranges)
        .expect("read array");
    (shape, values)
}

fn srgb_encoded(v: f32, ty: Type) -> u8 {
    encode_u8(v, ty == Type::Vec3)
}

#[test]
fn every_sample_type_reads_back_through_zarrs_as_evaluated() {
    let tape = marble();
    let grid = odd_grid();
    let want = expected(&tape, &grid);
    for (sample, compression) in [
        (Ktx2SampleType::U8, ZarrCompression::Zstd),
        (Ktx2SampleType::F16, ZarrCompression::Blosc),
        (Ktx2SampleType::F32, ZarrCompression::None),
        (Ktx2SampleType::F32, ZarrCompression::Zstd),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let store = dir.path().join("m.zarr");
        let mut options = options(&store, grid, sample);
        options.zarr.compression = compression;
        let report = bake_files(&tape, &options, &mut |_| {}).expect("bake");
        assert_eq!(report.voxels, 19 * 7 * 11);
        for (o, want) in tape.outputs().iter().zip(&want) {
            let channels = o.ty.channels() as u64;
            let mut shape = vec![11, 7, 19];
            if o.ty == Type::Vec3 {
                shape.push(3);
            }
            let label = format!("{sample:?} {compression:?} {}", o.name);
            match sample {
                Ktx2SampleType::U8 => {
                    let (s, got) = read_array::<u8>(&store, &o.name);
                    assert_eq!(s, shape, "{label}");
                    let want: Vec<u8> = want.iter().map(|&v| srgb_encoded(v, o.ty)).collect();
                    assert_eq!(got, want, "{label}");
                }
                Ktx2SampleType::F16 => {
                    let (s, got) = read_array::<half::f16>(&store, &o.name);
                    assert_eq!(s, shape, "{label}");
                    let want: Vec<half::f16> =
                        want.iter().map(|&v| half::f16::from_f32(v)).collect();
                    assert_eq!(got, want, "{label}");
                }
                Ktx2SampleType::F32 => {
                    let (s, got) = read_array::<f32>(&store, &o.name);
                    assert_eq!(s, shape, "{label}");
                    let same = got
                        .iter()
                        .zip(want)
                        .all(|(a, b)| a.to_bits() == b.to_bits());
                    assert!(
                        same && got.len() as u64 == 19 * 7 * 11 * channels,
                        "{label}"
                    );
                }
            }
        }
        let checks = verify_store(&store).unwrap();
        assert_eq!(checks.len(), 2);
        for check in &checks {
            // Shards of 8 (clipped to whole chunks of 4): z 11 → 2, y 7 → 1, x 19 → 3.
            assert_eq!(check.shards, 2 * 3, "{}", check.name);
            assert!(check.problems.is_empty(), "{:?}", check.problems);
        }
    }
}

#[test]
fn metadata_names_the_shape_chunks_codecs_and_the_bake() {
    let tape = marble();
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("m.zarr");
    let mut options = options(&store, odd_grid(), Ktx2SampleType::U8);
    options.zstd = Some(7);
    bake_files(&tape, &options, &mut |_| {}).expect("bake");
    let read = |p: &str| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(store.join(p)).unwrap()).unwrap()
    };
    let group = read("zarr.json");
    assert_eq!(group["zarr_format"], 3);
    assert_eq!(group["node_type"], "group");
    let colour = read("colour/zarr.json");
    assert_eq!(colour["shape"], serde_json::json!([11, 7, 19, 3]));
    assert_eq!(
        colour["dimension_names"],
        serde_json::json!(["z", "y", "x", "c"])
    );
    assert_eq!(colour["data_type"], "uint8");
    assert_eq!(
        colour["chunk_grid"]["configuration"]["chunk_shape"],
        serde_json::json!([8, 8, 8, 3])
    );
    let sharding = &colour["codecs"][0];
    assert_eq!(sharding["name"], "sharding_indexed");
    assert_eq!(
        sharding["configuration"]["chunk_shape"],
        serde_json::json!([4, 4, 4, 3])
    );
    assert_eq!(sharding["configuration"]["codecs"][1]["name"], "zstd");
    assert_eq!(
        sharding["configuration"]["codecs"][1]["configuration"]["level"],
        7
    );
    assert_eq!(
        sharding["configuration"]["index_codecs"][1]["name"],
        "crc32c"
    );
    let t = &colour["attributes"]["texgraph"];
    assert_eq!(t["graph"], "seed003_marble.ron");
    assert_eq!(t["region"]["min"], serde_json::json!([-0.5, -1.0, -0.75]));
    assert_eq!(t["size"], serde_json::json!([19, 7, 11]));
    assert_eq!(t["transfer"], "srgb");
    assert_eq!(t["output"], "colour");
    assert!(t["voxel_centres"].as_str().unwrap().contains("+ 0.5"));
    assert_eq!(t["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(t["tape"], format!("{:016x}", tape.fingerprint()));
    let vein = read("vein/zarr.json");
    assert_eq!(vein["shape"], serde_json::json!([11, 7, 19]));
    assert_eq!(vein["attributes"]["texgraph"]["transfer"], "linear");
}

/// Every file of a store, by relative path. Tolerates files renamed or removed while it walks
/// (a bake running beside it): those are left out.
fn tree(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(base, &path, out);
            } else if let Ok(bytes) = std::fs::read(&path) {
                let rel = path.strip_prefix(base).unwrap().display().to_string();
                out.insert(rel, bytes);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// Asserts two stores hold the same files with the same bytes, naming those that differ.
fn assert_same_store(got: &Path, want: &Path, label: &str) {
    let (got, want) = (tree(got), tree(want));
    let differ: Vec<&String> = got
        .keys()
        .chain(want.keys())
        .filter(|k| got.get(*k) != want.get(*k))
        .collect();
    assert!(differ.is_empty(), "{label}: files differ: {differ:?}");
}

#[test]
fn parts_in_any_order_make_the_one_process_store_byte_for_byte() {
    let tape = marble();
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.zarr");
    bake_files(
        &tape,
        &options(&whole, odd_grid(), Ktx2SampleType::U8),
        &mut |_| {},
    )
    .unwrap();
    assert!(tree(&whole).keys().any(|k| k.ends_with(".texgraph.json")));
    for (count, order) in [
        (4u64, vec![3, 1, 4, 2]),
        (6, vec![6, 5, 4, 3, 2, 1]),
        (2, vec![2, 1]),
    ] {
        let split = dir.path().join(format!("split{count}.zarr"));
        let mut baked = 0;
        for index in order {
            let mut options = options(&split, odd_grid(), Ktx2SampleType::U8);
            options.bake.threads = 1;
            options.zarr.part = Part::new(index, count).unwrap();
            let report = bake_files(&tape, &options, &mut |_| {}).unwrap();
            baked += report.voxels;
        }
        assert_eq!(
            baked,
            19 * 7 * 11,
            "{count} parts evaluate every voxel once"
        );
        assert_same_store(&split, &whole, &format!("{count} parts"));
    }
}

#[test]
fn a_rerun_resumes_missing_unfinished_and_corrupt_shards_only() {
    let tape = marble();
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("m.zarr");
    let options = options(&store, odd_grid(), Ktx2SampleType::F32);
    bake_files(&tape, &options, &mut |_| {}).unwrap();
    let want = tree(&store);
    // A shard lost, one whose manifest never got written (killed between the two), one
    // damaged, and a temporary a killed bake left behind.
    std::fs::remove_file(store.join("vein/c/1/0/2")).unwrap();
    std::fs::remove_file(store.join("colour/c/0/0/1/0.texgraph.json")).unwrap();
    let damaged = store.join("colour/c/1/0/0/0");
    let mut bytes = std::fs::read(&damaged).unwrap();
    bytes[10] ^= 0x40;
    std::fs::write(&damaged, bytes).unwrap();
    std::fs::write(store.join("vein/c/1/0/.2.Ab12Cd.partial"), b"half").unwrap();
    let checks = verify_store(&store).unwrap();
    let problems: Vec<(String, ShardState)> = checks.into_iter().flat_map(|c| c.problems).collect();
    assert_eq!(problems.len(), 3, "{problems:?}");
    assert!(problems.contains(&("vein/c/1/0/2".into(), ShardState::Missing)));
    assert!(problems.contains(&("colour/c/0/0/1/0".into(), ShardState::NoManifest)));
    assert!(problems
        .iter()
        .any(|(k, s)| k == "colour/c/1/0/0/0" && matches!(s, ShardState::Corrupt(_))));
    let report = bake_files(&tape, &options, &mut |_| {}).unwrap();
    // Three shards (each rebaked for both outputs): (z1, x2), (z0, x1), (z1, x0).
    // Shard sides: z 8, 3; y 7; x 8, 8, 3.
    let voxels = (3 * 7 * 3) + (8 * 7 * 8) + (3 * 7 * 8);
    assert_eq!(report.voxels, voxels as u64);
    assert_eq!(tree(&store), want);
    // Complete: nothing to do; --force rebakes everything, to the same bytes.
    assert_eq!(bake_files(&tape, &options, &mut |_| {}).unwrap().voxels, 0);
    let mut forced = options.clone();
    forced.force = true;
    assert_eq!(
        bake_files(&tape, &forced, &mut |_| {}).unwrap().voxels,
        19 * 7 * 11
    );
    assert_eq!(tree(&store), want);
}

#[test]
fn bad_stores_and_settings_are_refused_and_lose_nothing() {
    let tape = marble();
    let dir = tempfile::tempdir().unwrap();
    // A folder that is not a store.
    let folder = dir.path().join("photos.zarr");
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("holiday.jpg"), b"jpeg").unwrap();
    let error = bake_files(
        &tape,
        &options(&folder, odd_grid(), Ktx2SampleType::U8),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("not a Zarr store"), "{error}");
    assert_eq!(tree(&folder).len(), 1);
    // Resuming with other chunks, another sample type or another graph.
    let store = dir.path().join("m.zarr");
    bake_files(
        &tape,
        &options(&store, odd_grid(), Ktx2SampleType::U8),
        &mut |_| {},
    )
    .unwrap();
    let before = tree(&store);
    let mut other = options(&store, odd_grid(), Ktx2SampleType::U8);
    other.zarr.chunk = 2;
    let error = bake_files(&tape, &other, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("other settings") && error.contains("chunks"),
        "{error}"
    );
    let error = bake_files(
        &tape,
        &options(&store, odd_grid(), Ktx2SampleType::F32),
        &mut |_| {},
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("data_type"), "{error}");
    let other_tape = load_file(MARBLE, &[("octaves", 2.0)]).0;
    let mut split = options(&store, odd_grid(), Ktx2SampleType::U8);
    split.zarr.part = Part::new(1, 2).unwrap();
    split.force = true;
    let error = bake_files(&other_tape, &split, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("tape") && error.contains("every part"),
        "{error}"
    );
    assert_eq!(tree(&store), before, "refused bakes change nothing");
    // A whole bake with --force replaces the arrays with the new settings.
    other.force = true;
    bake_files(&tape, &other, &mut |_| {}).unwrap();
    assert!(verify_store(&store)
        .unwrap()
        .iter()
        .all(|c| c.problems.is_empty()));
    // Shards that are not whole chunks, and shards too large for the memory bound.
    let mut odd = options(&dir.path().join("n.zarr"), odd_grid(), Ktx2SampleType::U8);
    odd.zarr.shard = 6;
    let error = bake_files(&tape, &odd, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(error.contains("multiple of --chunk"), "{error}");
    let mut big = options(
        &dir.path().join("b.zarr"),
        Grid::cube(2048),
        Ktx2SampleType::F32,
    );
    big.zarr.chunk = 64;
    big.zarr.shard = 1024;
    big.max_bytes = u64::MAX;
    let error = bake_files(&tape, &big, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(error.contains("smaller --shard"), "{error}");
    assert!(!dir.path().join("n.zarr").exists() && !dir.path().join("b.zarr").exists());
}

// ---------------------------------------------------------------------------------------------
// The command line: processes, parts, verify

fn texgraph(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut command = Command::new(BIN);
    command.args(args).current_dir(root());
    for name in [
        "JOB_COMPLETION_INDEX",
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_COUNT",
    ] {
        command.env_remove(name);
    }
    command.envs(envs.iter().copied());
    command.output().expect("run texgraph")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn bake_args<'a>(store: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "bake",
        MARBLE,
        "--format",
        "zarr",
        "--out",
        store,
        "--size",
        "80,64,48",
        "--chunk",
        "8",
        "--shard",
        "16",
        "--set",
        "octaves=4",
        "-q",
    ];
    args.extend_from_slice(extra);
    args
}

#[test]
fn four_processes_one_killed_and_rerun_make_the_one_process_store() {
    let dir = tempfile::tempdir().unwrap();
    let whole = dir.path().join("whole.zarr");
    let whole = whole.to_str().unwrap();
    let out = texgraph(&bake_args(whole, &[]), &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let split = dir.path().join("split.zarr");
    let split_str = split.to_str().unwrap().to_string();
    let spawn = |part: &str| {
        Command::new(BIN)
            .args(bake_args(&split_str, &["--part", part, "--threads", "1"]))
            .current_dir(root())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn")
    };
    let mut children: Vec<_> = ["1/4", "2/4", "3/4", "4/4"]
        .iter()
        .map(|p| spawn(p))
        .collect();
    // Kill part 3 once it has finished a shard or two (or at once if it is fast).
    let started = std::time::Instant::now();
    let manifests = |dir: &Path| {
        tree(dir)
            .keys()
            .filter(|k| k.ends_with(".texgraph.json"))
            .count()
    };
    while manifests(&split) < 6 && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let mut killed = children.remove(2);
    killed.kill().unwrap();
    let _ = killed.wait();
    for child in children {
        let out = child.wait_with_output().unwrap();
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    // Part 3 was killed midway: the store is incomplete, and verify says so.
    let verify = texgraph(&["verify", &split_str], &[]);
    assert_eq!(verify.status.code(), Some(1), "{}", text(&verify.stdout));
    // Part 3 re-run: only its unfinished shards are baked.
    let out = texgraph(&bake_args(&split_str, &["--part", "3/4"]), &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let verify = texgraph(&["verify", &split_str], &[]);
    assert!(verify.status.success(), "{}", text(&verify.stdout));
    assert!(
        text(&verify.stdout).contains("60 of 60 shards complete"),
        "{}",
        text(&verify.stdout)
    );
    assert_same_store(
        &split,
        Path::new(whole),
        "4 processes, one killed and re-run",
    );
}

#[test]
fn cli_parts_from_the_scheduler_and_bad_parts() {
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("s.zarr");
    let store = store.to_str().unwrap();
    // A Kubernetes Indexed Job (0-based index, --parts) and a Slurm array (1-based here).
    for (envs, extra) in [
        (
            vec![("JOB_COMPLETION_INDEX", "0")],
            vec!["--part", "auto", "--parts", "2"],
        ),
        (
            vec![
                ("SLURM_ARRAY_TASK_ID", "2"),
                ("SLURM_ARRAY_TASK_MIN", "1"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
            ],
            vec!["--part", "auto"],
        ),
    ] {
        let out = texgraph(&bake_args(store, &extra), &envs);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let verify = texgraph(&["verify", store], &[]);
    assert!(verify.status.success(), "{}", text(&verify.stdout));
    for (extra, message) in [
        (vec!["--part", "5/4"], "part 5 of 4 does not exist"),
        (vec!["--part", "auto"], "JOB_COMPLETION_INDEX"),
        (vec!["--part", "two/4"], "whole numbers"),
        (vec!["--parts", "4"], "--part auto"),
    ] {
        let out = texgraph(&bake_args(store, &extra), &[]);
        assert_eq!(out.status.code(), Some(2), "{extra:?}");
        assert!(
            text(&out.stderr).contains(message),
            "{extra:?}: {}",
            text(&out.stderr)
        );
    }
    // verify: a damaged shard is named and the exit code is 1; not a store is 2.
    let shard = Path::new(store).join("vein/c/0/1/2");
    let mut bytes = std::fs::read(&shard).unwrap();
    bytes.truncate(bytes.len() - 1);
    std::fs::write(&shard, bytes).unwrap();
    let verify = texgraph(&["verify", store], &[]);
    assert_eq!(verify.status.code(), Some(1));
    let stdout = text(&verify.stdout);
    assert!(stdout.contains("vein/c/0/1/2: corrupt"), "{stdout}");
    let verify = texgraph(&["verify", dir.path().to_str().unwrap()], &[]);
    assert_eq!(verify.status.code(), Some(2));
}

#[test]
fn cli_splits_a_batch_of_graph_files_by_sorted_position() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().to_str().unwrap();
    let files = [
        "graphs/seed003_marble.ron",
        "graphs/cells.ron",
        "graphs/seed000_marble.ron",
        "graphs/ridged_rock.ron",
    ];
    let mut baked: Vec<PathBuf> = Vec::new();
    for part in ["1/3", "2/3", "3/3"] {
        let mut args = vec!["bake"];
        args.extend_from_slice(&files);
        args.extend_from_slice(&["--size", "8", "--out", out_dir, "--format", "raw", "-q"]);
        args.extend_from_slice(&["--part", part]);
        let out = texgraph(&args, &[]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        baked.push(PathBuf::from(text(&out.stdout)));
    }
    // Sorted: cells, ridged_rock, seed000_marble, seed003_marble → parts 1, 2, 3, 1.
    let owners: Vec<(&str, usize)> = vec![
        ("cells", 0),
        ("ridged_rock", 1),
        ("seed000_marble", 2),
        ("seed003_marble", 0),
    ];
    for (stem, part) in owners {
        let stdout = baked[part].to_string_lossy().into_owned();
        assert!(
            stdout.contains(&format!("{stem}.ron")),
            "part {part}: {stdout}"
        );
        for (other, out) in baked.iter().enumerate() {
            if other != part {
                assert!(!out.to_string_lossy().contains(&format!("/{stem}.ron")));
            }
        }
    }
}

/// zarr-python ≥ 3 opens the store (run when it is installed: CI installs it with pip).
#[test]
fn zarr_python_reads_the_store() {
    let probe = Command::new("python3")
        .args([
            "-c",
            "import zarr, sys; sys.exit(0 if int(zarr.__version__.split('.')[0]) >= 3 else 1)",
        ])
        .output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("SKIPPED: zarr-python >= 3 is not installed (pip install 'zarr>=3')");
        return;
    }
    let tape = marble();
    let grid = odd_grid();
    let want = expected(&tape, &grid);
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("m.zarr");
    bake_files(
        &tape,
        &options(&store, grid, Ktx2SampleType::F32),
        &mut |_| {},
    )
    .unwrap();
    let script = r#"
import sys, zarr, numpy as np
g = zarr.open_group(sys.argv[1], mode="r")
for name in ("colour", "vein"):
    a = g[name][...]
    sys.stdout.write(name + " " + " ".join(str(n) for n in a.shape) + " " + a.astype("<f4").tobytes().hex() + "\n")
"#;
    let out = Command::new("python3")
        .args(["-c", script, store.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    for (line, (o, want)) in text(&out.stdout)
        .lines()
        .zip(tape.outputs().iter().zip(&want))
    {
        let fields: Vec<&str> = line.split(' ').collect();
        assert_eq!(fields[0], o.name);
        let hex = fields.last().unwrap();
        let got: Vec<f32> = (0..hex.len() / 8)
            .map(|i| {
                let b = u32::from_str_radix(&hex[i * 8..i * 8 + 8], 16).unwrap();
                f32::from_le_bytes(b.to_be_bytes())
            })
            .collect();
        assert_eq!(got.len(), want.len(), "{}", o.name);
        assert!(
            got.iter()
                .zip(want)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{}",
            o.name
        );
    }
}

/// `--filter box` reaches the zarr shards: every voxel the filtered estimate of its cell's mean,
/// the value a raw bake's engine writes (`Filtered` over the grid spacing), not the point
/// value at its centre.
#[test]
fn box_filtered_stores_hold_the_cells_means() {
    use texgraph::filter::{Filter, Filtered, Footprint};
    let tape = marble();
    let grid = odd_grid();
    let dir = tempfile::tempdir().unwrap();
    let store = dir.path().join("m.zarr");
    let mut options = options(&store, grid, Ktx2SampleType::F32);
    options.bake.filter = Filter::Box;
    bake_files(&tape, &options, &mut |_| {}).expect("bake");
    let footprint = Footprint::from_sides(grid.spacing().map(f64::abs)).unwrap();
    let filtered = Filtered::new(&tape);
    let point = expected(&tape, &grid);
    let (_, vein) = read_array::<f32>(&store, "vein");
    let vi = tape
        .outputs()
        .iter()
        .position(|o| o.name == "vein")
        .unwrap();
    let vein_channel = tape.outputs()[vi].first_channel;
    let mut differs = 0;
    for k in 0..11 {
        for j in 0..7 {
            for i in 0..19 {
                let p = [0, 1, 2].map(|a| common::voxel_centre(&grid, a, [i, j, k][a]));
                let mut out = vec![0f32; tape.channels()];
                filtered.eval_point(p, &footprint, &mut out);
                let at = (k * 7 + j) * 19 + i;
                assert_eq!(
                    vein[at].to_bits(),
                    out[vein_channel].to_bits(),
                    "voxel {i} {j} {k}"
                );
                differs += usize::from(vein[at] != point[vi][at]);
            }
        }
    }
    assert!(
        differs > 100,
        "box-filtered voxels are not point values ({differs} differ)"
    );
}
