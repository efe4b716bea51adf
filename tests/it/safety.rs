//! Hostile inputs against the promises of docs/robustness.md ("Output safety", "Resource
//! limits"): an output name never chooses a path, nothing but a regular file is ever replaced,
//! bake memory stays bounded for any grid shape, every size knob is bounded, and options that
//! do not apply are usage errors. Each case runs the real binary and checks the exit code, the
//! message and what is (not) on disk afterwards.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");
const MARBLE: &str = "graphs/seed003_marble.ron";

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn run_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .expect("texgraph runs")
}

fn run(args: &[&str]) -> Output {
    run_in(root(), args)
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[track_caller]
fn expect(output: &Output, code: i32, stderr_has: &str) {
    let (out, err) = (text(&output.stdout), text(&output.stderr));
    assert_eq!(
        output.status.code(),
        Some(code),
        "exit code\nstdout:\n{out}\nstderr:\n{err}"
    );
    assert!(
        err.contains(stderr_has),
        "stderr lacks {stderr_has:?}:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

/// Every entry below `dir`, as paths relative to it, sorted (hidden temporaries included).
fn tree(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            found.push(
                path.strip_prefix(dir)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned(),
            );
            if entry.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(path);
            }
        }
    }
    found.sort();
    found
}

fn s(path: &Path) -> &str {
    path.to_str().expect("UTF-8 path")
}

// ---------------------------------------------------------------------------------------------
// Output names

#[test]
fn hostile_output_names_are_refused_and_nothing_is_written_anywhere() {
    let names = [
        "d/../../escape",
        "a/b",
        "..",
        "../x",
        "/abs",
        "a\\\\b",
        ".hidden",
        "zero\u{200b}width",
        "tab\\there",
        "bidi\u{202e}fdp.exe",
        "NUL",
        "com1.x",
        "",
        "caf\u{e9}",
    ];
    for name in names {
        let dir = tempfile::tempdir().unwrap();
        // A PNG bake first creates the out folder and a STEM.ok slice folder next to the bad
        // name, the situation where the traversal used to escape.
        let out = dir.path().join("work").join("out3");
        std::fs::create_dir_all(out.join("g.d")).unwrap();
        let graph = dir.path().join("work").join("g.ron");
        std::fs::write(
            &graph,
            format!("Graph(outputs: {{ \"ok\": 0.5, \"{name}\": 1.0 }})"),
        )
        .unwrap();
        let before = tree(dir.path());
        for format in ["raw", "png", "exr"] {
            let output = run(&[
                "bake",
                s(&graph),
                "--size",
                "2",
                "--format",
                format,
                "--out",
                s(&out),
            ]);
            expect(&output, 1, "error[bad-name]");
            assert_eq!(tree(dir.path()), before, "{name:?} {format}: files changed");
        }
        let output = run(&["check", s(&graph)]);
        expect(&output, 1, "not a valid output name");
    }
}

#[test]
fn a_bad_output_name_is_located_and_escaped_in_the_message() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("g.ron");
    std::fs::write(
        &graph,
        "Graph(\n    outputs: { \"ok\": 1.0, \"sneaky\u{200b}.raw\": 2.0 },\n)\n",
    )
    .unwrap();
    let output = run(&["check", s(&graph)]);
    expect(
        &output,
        1,
        "g.ron:2:27: node \"outputs.sneaky\\u{200b}.raw\"",
    );
    expect(&output, 1, "cannot contain the character '\\u{200b}'");
}

// ---------------------------------------------------------------------------------------------
// Destinations that are not regular files

/// Makes a special file of each kind texgraph must never replace, named `NAME`; returns
/// `(kind, path)` for those this machine allows (a device node needs root).
fn specials(dir: &Path, name: &str) -> Vec<(&'static str, PathBuf)> {
    let mut made = Vec::new();
    let fifo = dir.join(format!("fifo-{name}"));
    if Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success())
    {
        made.push(("FIFO", fifo));
    } else {
        eprintln!("SKIPPED: mkfifo is not available: the FIFO cases did not run");
    }
    let device = dir.join(format!("dev-{name}"));
    if Command::new("mknod")
        .arg(&device)
        .args(["c", "1", "3"])
        .status()
        .is_ok_and(|s| s.success())
    {
        made.push(("character device", device));
    } else {
        eprintln!("SKIPPED: mknod failed (not root?): the device-node cases did not run");
    }
    let target = dir.join("link-target.txt");
    std::fs::write(&target, b"precious").unwrap();
    let link = dir.join(format!("link-{name}"));
    std::os::unix::fs::symlink(&target, &link).unwrap();
    made.push(("symbolic link", link));
    let socket = dir.join(format!("sock-{name}"));
    let listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
    std::mem::forget(listener); // the socket file stays while the test runs
    made.push(("socket", socket));
    let folder = dir.join(format!("dir-{name}"));
    std::fs::create_dir(&folder).unwrap();
    std::fs::write(folder.join("keep"), b"x").unwrap();
    made.push(("folder", folder));
    made
}

fn kind_of(path: &Path) -> String {
    use std::os::unix::fs::FileTypeExt;
    let t = std::fs::symlink_metadata(path).unwrap().file_type();
    format!(
        "file {} dir {} link {} fifo {} char {} socket {}",
        t.is_file(),
        t.is_dir(),
        t.is_symlink(),
        t.is_fifo(),
        t.is_char_device(),
        t.is_socket()
    )
}

#[test]
fn render_never_replaces_what_is_not_a_regular_file() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, path) in specials(dir.path(), "out.png") {
        let before = kind_of(&path);
        let output = run(&["render", MARBLE, "--size", "8,6", "-o", s(&path)]);
        expect(&output, 2, "texgraph replaces only regular files");
        expect(&output, 2, kind);
        assert_eq!(kind_of(&path), before, "{kind} changed");
    }
    assert_eq!(
        std::fs::read(dir.path().join("link-target.txt")).unwrap(),
        b"precious"
    );
    assert!(
        !tree(dir.path()).iter().any(|n| n.contains(".partial")),
        "{:?}",
        tree(dir.path())
    );
    // The classic: /dev/null stays a device (refused before anything is done), and so does a
    // device without the .png extension.
    let output = run(&["render", MARBLE, "--size", "8,6", "-o", "/dev/null"]);
    expect(&output, 2, "/dev/null: is a character device");
    assert!(kind_of(Path::new("/dev/null")).contains("char true"));
    // A path whose folder does not exist is refused before rendering.
    let missing = dir.path().join("no").join("such").join("x.png");
    expect(
        &run(&["render", MARBLE, "--size", "8,6", "-o", s(&missing)]),
        2,
        "No such file or directory",
    );
}

#[test]
fn bake_never_replaces_what_is_not_a_regular_file_even_with_force() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("g.ron");
    std::fs::write(&graph, "Graph(outputs: { \"v\": 0.5 })").unwrap();
    // Each special file takes the place of an output's final file (raw, its sidecar, EXR, the
    // PNG atlas) or of the folder of PNG slices.
    for (format, extra, final_name) in [
        ("raw", None, "g.v.raw"),
        ("raw", None, "g.v.json"),
        ("exr", None, "g.v.exr"),
        ("png", Some("--atlas"), "g.v.png"),
        ("png", None, "g.v"),
    ] {
        let case = tempfile::tempdir_in(dir.path()).unwrap();
        let out = case.path().join("out");
        std::fs::create_dir(&out).unwrap();
        for (kind, special) in specials(case.path(), "x") {
            if kind == "folder" && final_name == "g.v" {
                continue; // a folder is what PNG slices replace (with --force)
            }
            let at = out.join(final_name);
            std::fs::rename(&special, &at).unwrap();
            let before = kind_of(&at);
            let listing = tree(case.path());
            for force in [false, true] {
                let mut args = vec!["bake", s(&graph), "--size", "2", "--format", format];
                args.extend(extra);
                args.extend(["--out", s(&out)]);
                if force {
                    args.push("--force");
                }
                let output = run(&args);
                expect(&output, 2, kind);
                assert_eq!(kind_of(&at), before, "{format} {final_name} {kind}");
                assert_eq!(tree(case.path()), listing, "{format} {final_name} {kind}");
            }
            std::fs::rename(&at, &special).unwrap();
        }
    }
    // A regular file where a slice folder goes is refused too.
    let out = dir.path().join("slices");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("g.v"), b"x").unwrap();
    expect(
        &run(&[
            "bake",
            s(&graph),
            "--size",
            "2",
            "--out",
            s(&out),
            "--force",
        ]),
        2,
        "is a regular file",
    );
    // The output folder itself must be a folder.
    for (kind, special) in specials(dir.path(), "outdir") {
        if kind == "folder" || kind == "symbolic link" {
            continue; // a folder is fine; the link points at a regular file, tested below
        }
        let before = kind_of(&special);
        expect(
            &run(&["bake", s(&graph), "--size", "2", "--out", s(&special)]),
            2,
            "the output folder is",
        );
        assert_eq!(kind_of(&special), before);
    }
    let link = dir.path().join("link-outdir");
    expect(
        &run(&["bake", s(&graph), "--size", "2", "--out", s(&link)]),
        2,
        "the output folder is a regular file",
    );
}

#[test]
fn report_plot_is_checked_before_any_work_and_written_whole() {
    let dir = tempfile::tempdir().unwrap();
    let jpg = dir.path().join("x.jpg");
    let started = std::time::Instant::now();
    expect(
        &run(&["report", MARBLE, "--plot", s(&jpg)]),
        2,
        "give a name ending in .png",
    );
    assert!(!jpg.exists(), "no empty x.jpg is left");
    // The default report takes many seconds in a debug build: refusing must not run it.
    assert!(started.elapsed().as_secs() < 20, "{:?}", started.elapsed());
    for (kind, special) in specials(dir.path(), "plot.png") {
        let before = kind_of(&special);
        expect(&run(&["report", MARBLE, "--plot", s(&special)]), 2, kind);
        assert_eq!(kind_of(&special), before);
    }
    let png = dir.path().join("plot.png");
    let output = run(&[
        "report",
        "graphs/seed004_stripes.ron",
        "--points",
        "200",
        "--runs",
        "1",
        "--plot",
        s(&png),
    ]);
    expect(&output, 0, "");
    let bytes = std::fs::read(&png).unwrap();
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "a PNG");
    assert!(
        !tree(dir.path()).iter().any(|n| n.contains(".partial")),
        "{:?}",
        tree(dir.path())
    );
}

// ---------------------------------------------------------------------------------------------
// Memory and size knobs

/// A graph as cheap as can be, so that a debug build bakes millions of voxels in seconds.
const CHEAP: &str = "Graph(nodes: { \"p\": Position }, outputs: { \"x\": \"p.x\" })";

/// Runs a bake under an address-space limit (`prlimit --as`): a bake that held a whole row or
/// slice of these wide grids (256 MiB of samples, plus 512 MiB of coordinates for the row)
/// fails instead of
/// swapping, where a bounded one streams (about 16 MB resident, well under the 160 MiB of
/// address space allowed).
fn bake_capped(dir: &Path, size: &str, limit_mib: u64) -> Option<Output> {
    let graph = dir.join("cheap.ron");
    std::fs::write(&graph, CHEAP).unwrap();
    let probe = Command::new("prlimit").arg("--version").output();
    if !probe.is_ok_and(|o| o.status.success()) {
        eprintln!("SKIPPED: prlimit (util-linux) is missing: the memory-cap bakes did not run");
        return None;
    }
    let out = dir.join("out");
    Some(
        Command::new("prlimit")
            .arg(format!("--as={}", limit_mib << 20))
            .arg(BIN)
            .args([
                "bake",
                s(&graph),
                "--size",
                size,
                "--format",
                "raw",
                "--threads",
                "2",
                "--quiet",
                "--force",
                "--out",
                s(&out),
            ])
            // One malloc arena per thread would reserve 64 MiB of address space each.
            .env("MALLOC_ARENA_MAX", "2")
            .output()
            .expect("prlimit runs"),
    )
}

#[test]
fn wide_bakes_stream_in_bounded_memory() {
    for size in ["67108864,1,1", "8192,8192,1"] {
        let dir = tempfile::tempdir().unwrap();
        let Some(output) = bake_capped(dir.path(), size, 160) else {
            return;
        };
        expect(&output, 0, "");
        let raw = dir.path().join("out").join("cheap.x.raw");
        let bytes = std::fs::read(&raw).unwrap();
        assert_eq!(bytes.len(), 67_108_864, "{size}");
        // Spot checks of the values: x runs from 0 to 1 along the first axis (u8, linear).
        let nx: usize = size.split(',').next().unwrap().parse().unwrap();
        for i in [0, nx / 2, nx - 1] {
            let expected = ((i as f64 + 0.5) / nx as f64 * 255.0).round() as u8;
            assert_eq!(bytes[i], expected, "{size} voxel {i}");
        }
        assert_eq!(bytes[bytes.len() - 1], 255);
    }
}

#[test]
fn formats_that_hold_data_in_memory_are_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    for (args, message) in [
        (
            vec!["--size", "4294967296,1,1"],
            "a PNG slice would be 4294967296×1 pixels",
        ),
        (
            vec!["--size", "4294967296,1,1", "--format", "png", "--atlas"],
            "a PNG atlas would be",
        ),
        (
            vec!["--size", "1024", "--format", "exr"],
            "an EXR file is written from the whole volume, held in memory: this bake would hold about 16.0 GiB, more than the limit of 2.0 GiB",
        ),
        (
            vec!["--size", "3000000000,1,1", "--format", "exr", "--allow-large"],
            "an EXR image (slices stacked) would be 3000000000×1 pixels",
        ),
        (
            vec!["--size", "8192,8192,64", "--format", "png", "--atlas"],
            "a PNG atlas holds one row of tiles in memory",
        ),
    ] {
        let mut all = vec!["bake", MARBLE, "--out", s(&out)];
        all.extend(args);
        let started = std::time::Instant::now();
        expect(&run(&all), 2, message);
        assert!(started.elapsed().as_secs() < 10, "refused before any work");
        assert!(!out.exists(), "nothing created: {:?}", tree(dir.path()));
    }
}

#[test]
fn threads_are_capped_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let started = std::time::Instant::now();
    let output = run(&[
        "bake",
        MARBLE,
        "--size",
        "4",
        "--threads",
        "100000",
        "--out",
        s(&out),
    ]);
    expect(
        &output,
        0,
        "warning: --threads 100000 is more than 4 per core; using ",
    );
    assert!(started.elapsed().as_secs() < 30, "{:?}", started.elapsed());
    let output = run(&[
        "render",
        MARBLE,
        "--size",
        "8,6",
        "--threads",
        "100000",
        "-o",
        s(&dir.path().join("r.png")),
    ]);
    expect(
        &output,
        0,
        "warning: --threads 100000 is more than 4 per core",
    );
}

#[test]
fn report_knobs_are_bounded() {
    for (args, message) in [
        (vec!["--runs", "0"], "invalid value '0' for '--runs <N>'"),
        (vec!["--runs", "101"], "101 is not in 1..=100"),
        (
            vec!["--points", "0"],
            "invalid value '0' for '--points <N>'",
        ),
        (
            vec!["--points", "1000000000"],
            "1000000000 is not in 1..=2000000",
        ),
        (vec!["--stability", "--points", "10"], "cannot be used with"),
        (
            vec!["--stability", "--plot", "x.png"],
            "cannot be used with",
        ),
        (
            vec!["--stability", "--output", "vein"],
            "cannot be used with",
        ),
    ] {
        let mut all = vec!["report", MARBLE];
        all.extend(args);
        expect(&run(&all), 2, message);
    }
}

// ---------------------------------------------------------------------------------------------
// Options that do not apply

#[test]
fn options_that_do_not_apply_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    for (args, message) in [
        (
            vec!["--half"],
            "--half applies to --format exr, ktx2 or zarr only, not to --format png",
        ),
        (
            vec!["--format", "raw", "--half"],
            "--half applies to --format exr, ktx2 or zarr only, not to --format raw",
        ),
        (
            vec!["--raw-type", "f32"],
            "--raw-type applies to --format raw only",
        ),
        (vec!["--alpha"], "--alpha applies to --format raw only"),
        (
            vec!["--format", "exr", "--atlas"],
            "--atlas applies to --format png only, not to --format exr",
        ),
        (
            vec!["--format", "exr", "--depth", "16"],
            "--depth applies to --format png only",
        ),
        (
            vec!["--format", "exr", "--transfer", "linear"],
            "--transfer applies to 8/16-bit files",
        ),
        (
            vec!["--format", "raw", "--raw-type", "f32", "--transfer", "srgb"],
            "--transfer applies to 8/16-bit files",
        ),
        (
            vec!["--exr-compression", "piz"],
            "--exr-compression applies to --format exr only",
        ),
    ] {
        let mut all = vec!["bake", MARBLE, "--size", "2", "--out", s(&out)];
        all.extend(args);
        expect(&run(&all), 2, message);
        assert!(!out.exists());
    }
    // Graph-only render options with a scene file.
    let png = dir.path().join("scene.png");
    for args in [
        vec!["--set", "period=2"],
        vec!["--object", "cube"],
        vec!["--space", "world"],
        vec!["--output", "vein"],
        vec!["--bump", "vein"],
    ] {
        let mut all = vec![
            "render",
            "graphs/scenes/seed003_sphere.ron",
            "--size",
            "8,6",
            "-o",
            s(&png),
        ];
        all.extend(args.iter().copied());
        let output = run(&all);
        expect(
            &output,
            2,
            &format!("{} applies to graph files only", args[0]),
        );
        assert!(!png.exists());
    }
    // They do apply to graph files.
    let output = run(&[
        "render",
        MARBLE,
        "--size",
        "8,6",
        "--set",
        "period=2",
        "--object",
        "cube",
        "-o",
        s(&png),
    ]);
    expect(&output, 0, "");
}

// ---------------------------------------------------------------------------------------------
// Silent surprises

#[test]
fn clamped_values_are_counted_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("wide.ron");
    // x·4 − 1 over 4 voxels along x: −0.5, 0.5, 1.5, 2.5 → one below 0, two above 1, per row.
    std::fs::write(
        &graph,
        "Graph(nodes: { \"p\": Position }, outputs: { \"v\": Sub(Mul(4.0, \"p.x\"), 1.0), \"ok\": \"p.y\" })",
    )
    .unwrap();
    let out = dir.path().join("out");
    let output = run(&[
        "bake",
        s(&graph),
        "--size",
        "4,2,1",
        "--format",
        "raw",
        "--out",
        s(&out),
    ]);
    expect(
        &output,
        0,
        "output \"v\": 2 values below 0 and 4 above 1 were clamped to [0, 1]",
    );
    assert!(!text(&output.stderr).contains("output \"ok\""));
    assert!(
        text(&output.stdout).contains(
            "v: min -0.5 max 2.5 mean 1; non-finite 0; clamped to [0, 1]: 2 below 0, 4 above 1"
        ),
        "{}",
        text(&output.stdout)
    );
    let sidecar: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("wide.v.json")).unwrap()).unwrap();
    assert_eq!(sidecar["stats"]["channels"][0]["below_zero"], 2);
    assert_eq!(sidecar["stats"]["channels"][0]["above_one"], 4);
    // EXR keeps the values: no warning.
    let output = run(&[
        "bake",
        s(&graph),
        "--size",
        "4,2,1",
        "--format",
        "exr",
        "--out",
        s(&out),
    ]);
    expect(&output, 0, "");
    assert!(!text(&output.stderr).contains("clamped"));
}

#[test]
fn exr_headers_record_params_overrides_and_compression() {
    use exr::prelude::*;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let output = run(&[
        "bake",
        MARBLE,
        "--size",
        "4",
        "--format",
        "exr",
        "--set",
        "distortion=2",
        "--out",
        s(&out),
    ]);
    expect(&output, 0, "");
    let image = read_first_flat_layer_from_file(out.join("seed003_marble.vein.exr")).unwrap();
    let text_attribute = |key: &str| -> String {
        match image
            .layer_data
            .attributes
            .other
            .get(&Text::from(key))
            .unwrap_or_else(|| panic!("no {key}"))
        {
            AttributeValue::Text(t) => t.to_string(),
            other => panic!("{key}: {other:?}"),
        }
    };
    let params: serde_json::Value =
        serde_json::from_str(&text_attribute("texgraph:params")).unwrap();
    assert_eq!(params["distortion"], 2.0);
    assert_eq!(params["period"], 1.3);
    let overrides: serde_json::Value =
        serde_json::from_str(&text_attribute("texgraph:overrides")).unwrap();
    assert_eq!(overrides, serde_json::json!({ "distortion": 2.0 }));
    assert_eq!(
        text_attribute("texgraph:compression"),
        "ZIP (16 scan lines per block)"
    );
    assert_eq!(
        image.layer_data.encoding.compression,
        exr::compression::Compression::ZIP16
    );
}

#[test]
fn watch_on_a_missing_file_or_a_folder_exits_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.ron");
    let started = std::time::Instant::now();
    expect(
        &run(&["watch", s(&missing), "-o", s(&dir.path().join("w.png"))]),
        2,
        "No such file or directory",
    );
    expect(
        &run(&["watch", s(dir.path()), "-o", s(&dir.path().join("w.png"))]),
        2,
        "is a folder",
    );
    assert!(started.elapsed().as_secs() < 20);
}

#[test]
fn eval_blames_the_output_not_the_points_file_when_writing_fails() {
    let dir = tempfile::tempdir().unwrap();
    let points = dir.path().join("points.txt");
    std::fs::write(&points, "0 0 0\n1 2 3\n".repeat(5000)).unwrap();
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        eprintln!("SKIPPED: /dev/full is missing: the full-disk case did not run");
        return;
    };
    let output = Command::new(BIN)
        .args(["eval", MARBLE, "--points", s(&points)])
        .current_dir(root())
        .stdout(full)
        .output()
        .unwrap();
    expect(&output, 2, "writing the results: No space left on device");
    assert!(!text(&output.stderr).contains("points.txt"));
    // A points file without line breaks is refused at the line limit, not read whole.
    std::fs::write(&points, "1".repeat(100_000)).unwrap();
    expect(
        &run(&["eval", MARBLE, "--points", s(&points)]),
        1,
        "points.txt:1: expected three numbers",
    );
}

#[test]
fn negative_values_are_echoed_as_written() {
    expect(
        &run(&["check", MARBLE, "--spacing", "-1"]),
        2,
        "invalid value '-1' for '--spacing <H>'",
    );
    let output = run(&["check", MARBLE, "--spacing", "-1"]);
    assert!(!text(&output.stderr).contains('\u{2212}'));
    // Coordinates still take negative numbers of every form.
    let output = run(&["eval", MARBLE, "-1e-3", "-.5", "-4"]);
    expect(&output, 0, "");
}
