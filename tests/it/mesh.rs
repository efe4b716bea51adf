//! `bake --mesh` (texture sets, docs/baking.md "Texture sets"), checked against independent
//! references: the models of `examples/meshes/` read here by a small OBJ reader of the test's
//! own and rasterised by brute force (every texel centre against every triangle, in f64), the
//! written GLB read back by the `gltf` crate, values against `Tape::eval_point` (what
//! `texgraph eval` prints) at the surface points found so, normal maps decoded as a glTF viewer
//! does against the analytic bump normal of a known height, and every written GLB through the
//! Khronos validator and three.js (`gltf_clients`).

use crate::common;
use crate::gltf_clients::{assert_valid_glb, clients_ready, draw_glb};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use texgraph::eval::Workspace;

const BIN: &str = env!("CARGO_BIN_EXE_texgraph");

fn texgraph(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(common::crate_root())
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .output()
        .expect("run texgraph")
}

fn succeed(args: &[&str]) -> String {
    let out = texgraph(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "texgraph {args:?} failed: {stderr}");
    String::from_utf8_lossy(&out.stdout).to_string()
}

fn model(name: &str) -> String {
    common::crate_root()
        .join("examples/meshes")
        .join(name)
        .display()
        .to_string()
}

/// A height with a known gradient: h = 0.05 sin(7x) + 0.2 y z; and a colour and a roughness.
const HEIGHT_GRAPH: &str = r#"Graph(
    nodes: {
        "p": Position,
        "h": Add(Mul(0.05, Sin(Mul(7.0, "p.x"))), Mul(0.2, Mul("p.y", "p.z"))),
        "colour": Mix((0.9, 0.45, 0.1), (0.1, 0.3, 0.9), "p.x"),
        "rough": Add(0.3, Mul(0.4, "p.y")),
    },
    outputs: { "colour": "colour", "h": "h", "rough": "rough" },
)
"#;

fn height_gradient(p: [f64; 3]) -> [f64; 3] {
    [0.35 * (7.0 * p[0]).cos(), 0.2 * p[2], 0.2 * p[1]]
}

/// A model as this test reads it: triangles of positions, normals and glTF-convention UVs.
struct Mesh {
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    uvs: Vec<[f64; 2]>,
    tangents: Vec<[f64; 4]>,
    triangles: Vec<[usize; 3]>,
}

/// The test's own OBJ reader: `v`, `vt` (flipped to v downwards), `vn`, triangle `f a/b/c`.
fn read_obj(path: &str) -> Mesh {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut v, mut vt, mut vn) = (Vec::new(), Vec::new(), Vec::new());
    let mut mesh = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        tangents: Vec::new(),
        triangles: Vec::new(),
    };
    let numbers = |rest: &[&str]| -> Vec<f64> {
        rest.iter()
            .map(|s| f64::from(s.parse::<f32>().unwrap()))
            .collect()
    };
    for line in text.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first() {
            Some(&"v") => v.push(numbers(&words[1..4])),
            Some(&"vt") => vt.push(numbers(&words[1..3])),
            Some(&"vn") => vn.push(numbers(&words[1..4])),
            Some(&"f") => {
                assert_eq!(words.len(), 4, "triangles only");
                let mut t = [0; 3];
                for (k, corner) in words[1..].iter().enumerate() {
                    let ids: Vec<usize> = corner.split('/').map(|s| s.parse().unwrap()).collect();
                    t[k] = mesh.positions.len();
                    let p = &v[ids[0] - 1];
                    let uv = &vt[ids[1] - 1];
                    let n = &vn[ids[2] - 1];
                    mesh.positions.push([p[0], p[1], p[2]]);
                    mesh.uvs.push([uv[0], 1.0 - uv[1]]);
                    mesh.normals.push([n[0], n[1], n[2]]);
                }
                mesh.triangles.push(t);
            }
            _ => {}
        }
    }
    mesh
}

/// A GLB read back with the `gltf` crate (its binary chunk as the one buffer).
fn read_glb(path: &Path) -> (Mesh, Vec<gltf::Material<'static>>) {
    let bytes = std::fs::read(path).unwrap();
    let gltf = Box::leak(Box::new(gltf::Gltf::from_slice(&bytes).unwrap()));
    let blob = gltf.blob.clone().unwrap();
    let mut mesh = Mesh {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        tangents: Vec::new(),
        triangles: Vec::new(),
    };
    for m in gltf.document.meshes() {
        for primitive in m.primitives() {
            let reader = primitive.reader(|_| Some(&blob[..]));
            let base = mesh.positions.len();
            let f = |a: [f32; 3]| a.map(f64::from);
            mesh.positions
                .extend(reader.read_positions().unwrap().map(f));
            mesh.normals.extend(reader.read_normals().unwrap().map(f));
            mesh.uvs.extend(
                reader
                    .read_tex_coords(0)
                    .unwrap()
                    .into_f32()
                    .map(|t| t.map(f64::from)),
            );
            if let Some(tangents) = reader.read_tangents() {
                mesh.tangents.extend(tangents.map(|t| t.map(f64::from)));
            }
            let indices: Vec<usize> = reader
                .read_indices()
                .unwrap()
                .into_u32()
                .map(|i| base + i as usize)
                .collect();
            mesh.triangles
                .extend(indices.chunks(3).map(|t| [t[0], t[1], t[2]]));
        }
    }
    (mesh, gltf.document.materials().collect())
}

/// Brute-force coverage: per texel, the first triangle whose closed UV triangle holds the
/// centre, and the barycentric coordinates there.
fn rasterise(mesh: &Mesh, width: usize, height: usize) -> Vec<Option<(usize, [f64; 3])>> {
    let mut out = vec![None; width * height];
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| mesh.uvs[i]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area == 0.0 {
            continue;
        }
        for (texel, slot) in out.iter_mut().enumerate() {
            if slot.is_some() {
                continue;
            }
            let p = [
                ((texel % width) as f64 + 0.5) / width as f64,
                ((texel / width) as f64 + 0.5) / height as f64,
            ];
            let l1 = ((p[0] - a[0]) * (c[1] - a[1]) - (p[1] - a[1]) * (c[0] - a[0])) / area;
            let l2 = ((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])) / area;
            let l0 = 1.0 - l1 - l2;
            if l0 >= -1e-12 && l1 >= -1e-12 && l2 >= -1e-12 {
                *slot = Some((t, [l0, l1, l2]));
            }
        }
    }
    out
}

/// How far (in texels) a texel centre is from the nearest triangle edge in UV space.
fn edge_distance(mesh: &Mesh, width: usize, height: usize, texel: usize) -> f64 {
    let p = [(texel % width) as f64 + 0.5, (texel / width) as f64 + 0.5];
    let mut best = f64::INFINITY;
    for tri in &mesh.triangles {
        let q = tri.map(|i| {
            [
                mesh.uvs[i][0] * width as f64,
                mesh.uvs[i][1] * height as f64,
            ]
        });
        for k in 0..3 {
            let (a, b) = (q[k], q[(k + 1) % 3]);
            let d = [b[0] - a[0], b[1] - a[1]];
            let len2 = d[0] * d[0] + d[1] * d[1];
            let t = (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0);
            let e = [a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]];
            best = best.min((e[0] * e[0] + e[1] * e[1]).sqrt());
        }
    }
    best
}

fn interpolate<const N: usize>(values: &[[f64; N]], tri: [usize; 3], bary: [f64; 3]) -> [f64; N] {
    std::array::from_fn(|c| (0..3).map(|k| bary[k] * values[tri[k]][c]).sum())
}

/// An EXR's channels, interleaved per texel (Y, or R G B).
fn read_exr(path: &Path) -> (usize, usize, usize, Vec<f32>) {
    use exr::prelude::*;
    let image = read_first_flat_layer_from_file(path).unwrap();
    let layer = image.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let mut channels: Vec<(String, Vec<f32>)> = layer
        .channel_data
        .list
        .into_iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    // EXR sorts channels by name: B G R → R G B.
    channels.sort_by_key(|(name, _)| ["R", "G", "B", "Y"].iter().position(|n| *n == name));
    let k = channels.len();
    let mut data = vec![0.0; w * h * k];
    for (c, (_, values)) in channels.iter().enumerate() {
        for (i, v) in values.iter().enumerate() {
            data[i * k + c] = *v;
        }
    }
    (w, h, k, data)
}

/// 8-bit PNG samples.
fn read_png8(path: &Path) -> (usize, usize, usize, Vec<u8>) {
    let png = common::Png::open(path).unwrap();
    assert!(matches!(png.channels, 1 | 3), "{} channels", png.channels);
    (png.width, png.height, png.channels, png.samples8())
}

fn tape_of(path: &str) -> texgraph::tape::Tape {
    common::load_graph_file(path, &[]).0
}

#[test]
fn texels_are_the_graph_at_surface_points_of_an_independent_rasterisation() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().display().to_string();
    let tape = tape_of("graphs/seed003_marble.ron");
    let mut ws = Workspace::<f32>::new();
    for name in ["plane", "sphere", "cube"] {
        let (width, height) = (40, 28);
        let obj = model(&format!("{name}.obj"));
        succeed(&[
            "bake",
            "graphs/seed003_marble.ron",
            "--mesh",
            &obj,
            "--size",
            "40,28",
            "--format",
            "exr",
            "--padding",
            "0",
            "--out",
            &out,
            "--force",
            "--quiet",
        ]);
        let mesh = read_obj(&obj);
        let coverage = rasterise(&mesh, width, height);
        let covered = coverage.iter().filter(|c| c.is_some()).count();
        assert!(
            covered > width * height / 10,
            "{name}: {covered} texels covered"
        );
        for output in tape.outputs() {
            let (w, h, k, data) = read_exr(
                &dir.path()
                    .join(format!("seed003_marble.{}.exr", output.name)),
            );
            assert_eq!((w, h, k), (width, height, output.ty.channels()), "{name}");
            for (texel, hit) in coverage.iter().enumerate() {
                let value = &data[texel * k..texel * k + k];
                let Some((t, bary)) = hit else {
                    // Uncovered here; the bake may cover it only within 1/128 texel of an edge.
                    if value.iter().any(|v| *v != 0.0) {
                        let d = edge_distance(&mesh, width, height, texel);
                        assert!(
                            d < 1.0 / 128.0,
                            "{name}: texel {texel} baked but uncovered ({d} texels from an edge)"
                        );
                    }
                    continue;
                };
                let p = interpolate(&mesh.positions, mesh.triangles[*t], *bary);
                let mut expected = vec![0.0f32; tape.channels()];
                tape.eval_point(&mut ws, p, &mut expected);
                let expected = &expected[output.first_channel..output.first_channel + k];
                if value.iter().all(|v| *v == 0.0) && expected.iter().any(|v| *v != 0.0) {
                    let d = edge_distance(&mesh, width, height, texel);
                    assert!(
                        d < 1.0 / 128.0,
                        "{name}: texel {texel} covered but not baked ({d} texels from an edge)"
                    );
                    continue;
                }
                for (v, e) in value.iter().zip(expected) {
                    assert!(
                        (v - e).abs() <= 1e-5 * e.abs().max(1.0),
                        "{name} {} texel ({}, {}): baked {v}, eval {e} at {p:?}",
                        output.name,
                        texel % width,
                        texel / width
                    );
                }
            }
        }
    }
}

#[test]
fn gltf_and_obj_of_one_model_bake_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let bake = |model_file: &str, sub: &str| -> Vec<u8> {
        let out = dir.path().join(sub).display().to_string();
        succeed(&[
            "bake",
            "graphs/seed003_marble.ron",
            "--mesh",
            &model(model_file),
            "--size",
            "64,48",
            "--out",
            &out,
            "--quiet",
        ]);
        std::fs::read(dir.path().join(sub).join("seed003_marble.colour.png")).unwrap()
    };
    for (a, b) in [
        ("plane.gltf", "plane.obj"),
        ("sphere.glb", "sphere.obj"),
        ("sphere_embedded.gltf", "sphere.obj"),
        ("cube.glb", "cube.obj"),
    ] {
        let (x, y) = (bake(a, &format!("{a}.a")), bake(b, &format!("{a}.b")));
        assert!(x == y, "{a} and {b} baked different images");
    }
}

#[test]
fn padding_fills_from_the_nearest_covered_texel_within_reach() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().display().to_string();
    let (width, height) = (64, 64);
    for padding in [0usize, 3] {
        succeed(&[
            "bake",
            "graphs/seed003_marble.ron",
            "--mesh",
            &model("cube.obj"),
            "--size",
            "64",
            "--format",
            "exr",
            "--padding",
            &padding.to_string(),
            "--out",
            &out,
            "--force",
            "--quiet",
            "--output",
            "vein",
        ]);
        let (_, _, _, data) = read_exr(&dir.path().join("seed003_marble.vein.exr"));
        let mesh = read_obj(&model("cube.obj"));
        let covered: Vec<bool> = rasterise(&mesh, width, height)
            .iter()
            .map(|c| c.is_some())
            .collect();
        let mut padded = 0;
        for texel in (0..width * height).filter(|t| !covered[*t]) {
            let (i, j) = ((texel % width) as i64, (texel / width) as i64);
            let d2 = |s: usize| ((s % width) as i64 - i).pow(2) + ((s / width) as i64 - j).pow(2);
            let nearest = (0..width * height)
                .filter(|s| covered[*s])
                .map(d2)
                .min()
                .unwrap();
            if nearest > (padding * padding) as i64 {
                assert_eq!(
                    data[texel], 0.0,
                    "padding {padding}: texel {texel} is out of reach"
                );
                continue;
            }
            padded += 1;
            let candidates: Vec<f32> = (0..width * height)
                .filter(|s| covered[*s] && d2(*s) == nearest)
                .map(|s| data[s])
                .collect();
            assert!(candidates.contains(&data[texel]), "padding {padding}: texel ({i}, {j}) = {} is none of its nearest covered texels' {candidates:?}", data[texel]);
        }
        assert_eq!(padded > 0, padding > 0);
    }
}

/// The angle (degrees) between two vectors.
fn angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    let dot: f64 = (0..3).map(|c| a[c] * b[c]).sum();
    let n = |v: [f64; 3]| (0..3).map(|c| v[c] * v[c]).sum::<f64>().sqrt();
    (dot / (n(a) * n(b))).clamp(-1.0, 1.0).acos().to_degrees()
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|c| c / n)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The bump normal of unit normal `n`: normalize(n − s(g − (g·n)n)).
fn bump(n: [f64; 3], g: [f64; 3], s: f64) -> [f64; 3] {
    let gn: f64 = (0..3).map(|c| g[c] * n[c]).sum();
    normalize(std::array::from_fn(|c| n[c] - s * (g[c] - gn * n[c])))
}

#[test]
fn normal_maps_decode_to_the_analytic_bump_normal_in_both_conventions() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("height.ron");
    std::fs::write(&graph, HEIGHT_GRAPH).unwrap();
    let graph = graph.display().to_string();
    let (width, height) = (96, 64);
    for (name, green, strength) in [
        ("sphere.glb", "up", "1"),
        ("plane.gltf", "up", "2.5"),
        ("sphere.glb", "down", "2.5"),
    ] {
        let out = dir.path().join(format!("{name}.{green}"));
        let out_text = out.display().to_string();
        succeed(&[
            "bake",
            &graph,
            "--mesh",
            &model(name),
            "--size",
            "96,64",
            "--normal",
            "h",
            "--normal-y",
            green,
            "--normal-strength",
            strength,
            "--gltf",
            "--out",
            &out_text,
            "--quiet",
        ]);
        let (mesh, _) = read_glb(&out.join("height.glb"));
        assert_eq!(
            mesh.tangents.len(),
            mesh.positions.len(),
            "{name}: TANGENT written"
        );
        let (w, h, k, png) = read_png8(&out.join("height.normal.png"));
        assert_eq!((w, h, k), (width, height, 3));
        let s: f64 = strength.parse().unwrap();
        let (mut worst, mut tilted) = (0.0f64, 0usize);
        for (texel, hit) in rasterise(&mesh, width, height).iter().enumerate() {
            let Some((t, bary)) = hit else { continue };
            let tri = mesh.triangles[*t];
            let p = interpolate(&mesh.positions, tri, *bary);
            let n = interpolate(&mesh.normals, tri, *bary);
            let tangent = interpolate(&mesh.tangents, tri, *bary);
            let tv = [tangent[0], tangent[1], tangent[2]];
            let sign = mesh.tangents[tri[0]][3];
            let b = cross(n, tv).map(|c| c * sign);
            let c: Vec<f64> = png[texel * 3..texel * 3 + 3]
                .iter()
                .map(|&v| f64::from(v) / 255.0 * 2.0 - 1.0)
                .collect();
            let y = if green == "up" { c[1] } else { -c[1] };
            let decoded: [f64; 3] = std::array::from_fn(|i| c[0] * tv[i] + y * b[i] + c[2] * n[i]);
            let expected = bump(normalize(n), height_gradient(p), s);
            let a = angle(decoded, expected);
            worst = worst.max(a);
            tilted += usize::from(angle(expected, n) > 5.0);
        }
        assert!(
            worst <= 2.0,
            "{name} green {green}: a decoded normal is {worst:.2}° from the analytic bump normal"
        );
        assert!(
            tilted > 100,
            "{name}: the height must tilt the normals ({tilted} texels > 5°)"
        );
    }
}

#[test]
fn a_flat_bake_takes_a_normal_map_in_the_image_frame() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("height.ron");
    std::fs::write(&graph, HEIGHT_GRAPH).unwrap();
    let out = dir.path().join("out");
    succeed(&[
        "bake",
        &graph.display().to_string(),
        "--size",
        "32,24,1",
        "--region",
        "0,0,0.5:1,1,0.5",
        "--normal",
        "h",
        "--normal-strength",
        "3",
        "--out",
        &out.display().to_string(),
        "--quiet",
    ]);
    let (w, h, _, png) = read_png8(&out.join("height.normal.png"));
    assert_eq!((w, h), (32, 24));
    for j in 0..h {
        for i in 0..w {
            let p = [(i as f64 + 0.5) / 32.0, (j as f64 + 0.5) / 24.0, 0.5];
            let c: Vec<f64> = png[(j * w + i) * 3..][..3]
                .iter()
                .map(|&v| f64::from(v) / 255.0 * 2.0 - 1.0)
                .collect();
            // Frame: x right, y down the rows, z out; green up: the image's up is −y.
            let decoded = [c[0], -c[1], c[2]];
            let expected = bump([0.0, 0.0, 1.0], height_gradient(p), 3.0);
            assert!(
                angle(decoded, expected) <= 2.0,
                "texel ({i}, {j}): {decoded:?} vs {expected:?}"
            );
        }
    }
}

#[test]
fn box_filter_is_closer_to_supersampled_texel_means_than_centre_samples() {
    let dir = tempfile::tempdir().unwrap();
    let (width, height) = (24, 24);
    let tape = tape_of("graphs/seed003_marble.ron");
    let vein = tape.output("vein").unwrap().first_channel;
    let mut ws = Workspace::<f64>::new();
    let mut values = vec![0.0f64; tape.channels()];
    let mut errors = Vec::new();
    for filter in ["point", "box"] {
        let out = dir.path().join(filter);
        succeed(&[
            "bake",
            "graphs/seed003_marble.ron",
            "--mesh",
            &model("plane.obj"),
            "--size",
            "24",
            "--format",
            "exr",
            "--filter",
            filter,
            "--out",
            &out.display().to_string(),
            "--quiet",
        ]);
        let (_, _, _, data) = read_exr(&out.join("seed003_marble.vein.exr"));
        let mut sum = 0.0;
        for j in 0..height {
            for i in 0..width {
                // The plane maps (u, v) to (u, 1 − v, 0.5): the texel's mean by 16 × 16 samples.
                let mut mean = 0.0;
                for a in 0..16 {
                    for b in 0..16 {
                        let u = (i as f64 + (a as f64 + 0.5) / 16.0) / width as f64;
                        let v = (j as f64 + (b as f64 + 0.5) / 16.0) / height as f64;
                        tape.eval_point(&mut ws, [u, 1.0 - v, 0.5], &mut values);
                        mean += values[vein] / 256.0;
                    }
                }
                sum += (f64::from(data[j * width + i]) - mean).powi(2);
            }
        }
        errors.push((sum / (width * height) as f64).sqrt());
    }
    assert!(
        errors[1] < 0.8 * errors[0],
        "RMS against the texel means: point {}, box {}",
        errors[0],
        errors[1]
    );
}

#[test]
fn bad_input_is_refused_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let corrupt = dir.path().join("corrupt.glb");
    std::fs::write(&corrupt, b"glTF\x02\x00\x00\x00garbage").unwrap();
    let corrupt = corrupt.display().to_string();
    let missing = dir.path().join("missing.obj").display().to_string();
    let marble = "graphs/seed003_marble.ron";
    // (model, further arguments, exit code, what the message names)
    let no_uv_obj = model("no_uv.obj");
    let no_uv_glb = model("no_uv.glb");
    let nan = model("nan.obj");
    let plane = model("plane.obj");
    let cases: [(&str, &[&str], i32, &str); 15] = [
        (&no_uv_obj, &[], 1, "vt"),
        (&no_uv_glb, &[], 1, "TEXCOORD_0"),
        (&nan, &[], 1, "non-finite position"),
        (&missing, &[], 2, "missing.obj"),
        (&corrupt, &[], 2, "corrupt.glb"),
        (&plane, &["--format", "zarr"], 2, "--format zarr"),
        (&plane, &["--format", "ktx2"], 2, "--format ktx2"),
        (&plane, &["--part", "1/2"], 2, "--part"),
        (&plane, &["--region", "0,0,0:2,2,2"], 2, "--region"),
        (&plane, &["--size", "8,8,8"], 2, "W,H"),
        (&plane, &["--size", "200000"], 2, "--allow-large"),
        (&plane, &["--roughness", "vein"], 2, "--gltf"),
        (&plane, &["--gltf", "--roughness", "colour"], 2, "colour"),
        (&plane, &["--normal", "colour"], 2, "scalar"),
        (&plane, &["--device", "gpu"], 2, "--device gpu"),
    ];
    for (model_file, extra, code, needle) in cases {
        let out = dir.path().join("out");
        let out_text = out.display().to_string();
        let mut args = vec!["bake", marble, "--out", &out_text, "--mesh", model_file];
        args.extend(extra);
        if !extra.contains(&"--size") {
            args.extend(["--size", "16"]);
        }
        let result = texgraph(&args);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(code), "{extra:?}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{extra:?}: `{needle}` not in: {stderr}"
        );
        assert!(
            !out.exists(),
            "{extra:?}: {} was left behind",
            out.display()
        );
    }
    // Mesh options without --mesh are usage errors too.
    let result = texgraph(&[
        "bake",
        marble,
        "--gltf",
        "--out",
        &dir.path().join("x").display().to_string(),
    ]);
    assert_eq!(result.status.code(), Some(2));
}

#[test]
fn the_glb_is_valid_and_three_js_draws_its_textures() {
    const T: &str = "the_glb_is_valid_and_three_js_draws_its_textures";
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("height.ron");
    std::fs::write(&graph, HEIGHT_GRAPH).unwrap();
    let out = dir.path().join("out");
    succeed(&[
        "bake",
        &graph.display().to_string(),
        "--mesh",
        &model("sphere.glb"),
        "--size",
        "128",
        "--normal",
        "h",
        "--gltf",
        "--roughness",
        "rough",
        "--out",
        &out.display().to_string(),
        "--quiet",
    ]);
    succeed(&[
        "bake",
        "graphs/seed003_marble.ron",
        "--mesh",
        &model("cube.obj"),
        "--size",
        "64",
        "--gltf",
        "--out",
        &out.display().to_string(),
        "--quiet",
    ]);
    let (_, materials) = read_glb(&out.join("height.glb"));
    let pbr = materials[0].pbr_metallic_roughness();
    assert!(pbr.base_color_texture().is_some() && pbr.metallic_roughness_texture().is_some());
    assert!(materials[0].normal_texture().is_some());
    if !clients_ready(T) {
        return;
    }
    for glb in ["height.glb", "seed003_marble.glb"] {
        assert_valid_glb(&out.join(glb));
    }
    let drawn = draw_glb(&out.join("height.glb"));
    let material = &drawn.scene["materials"][0];
    for map in ["map", "normalMap", "roughnessMap"] {
        assert!(
            !material[map].is_null(),
            "three.js did not load the {map}: {material}"
        );
    }
    assert!(
        drawn.coverage() > 0.1,
        "the sphere covers {} of the image",
        drawn.coverage()
    );
    // The colour runs from orange (x = 0) to blue (x = 1): seen from +z, the left half of the
    // sphere is redder than the right half.
    let (mut left, mut right) = ([0.0f64; 3], [0.0f64; 3]);
    for (x, _, p) in drawn.drawn_pixels() {
        let side = if x < drawn.width / 2 {
            &mut left
        } else {
            &mut right
        };
        for c in 0..3 {
            side[c] += f64::from(p[c]);
        }
    }
    assert!(
        left[0] / left[2] > 1.5 * right[0] / right[2],
        "left {left:?}, right {right:?}"
    );
    // The 10 000-triangle knot with the marble and a normal map from its vein (the picture of
    // docs/baking.md: TEXGRAPH_SAVE_DRAWN=DIR keeps it).
    succeed(&[
        "bake",
        "graphs/seed003_marble.ron",
        "--mesh",
        &model("knot.glb"),
        "--size",
        "512",
        "--normal",
        "vein",
        "--normal-strength",
        "0.5",
        "--gltf",
        "--out",
        &out.display().to_string(),
        "--quiet",
        "--force",
    ]);
    assert_valid_glb(&out.join("seed003_marble.glb"));
    let knot = draw_glb(&out.join("seed003_marble.glb"));
    assert!(
        knot.coverage() > 0.05,
        "the knot covers {}",
        knot.coverage()
    );
    assert!(!knot.scene["materials"][0]["normalMap"].is_null());
}

#[test]
fn world_space_applies_the_scene_s_node_transforms() {
    // plane.gltf under a parent node that moves it by +0.25 in z and a child scaled by 2 in x:
    // z = 0.5 as stored, 0.75 in world space, x doubled.
    let dir = tempfile::tempdir().unwrap();
    let mut json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(model("plane.gltf")).unwrap()).unwrap();
    json["nodes"] = serde_json::json!([
        {"children": [1], "translation": [0.0, 0.0, 0.25]},
        {"mesh": 0, "scale": [2.0, 1.0, 1.0]},
    ]);
    std::fs::write(dir.path().join("moved.gltf"), json.to_string()).unwrap();
    std::fs::copy(model("plane.bin"), dir.path().join("plane.bin")).unwrap();
    let graph = dir.path().join("coords.ron");
    std::fs::write(
        &graph,
        "Graph(nodes: { \"p\": Position }, outputs: { \"x\": \"p.x\", \"z\": \"p.z\" })\n",
    )
    .unwrap();
    let moved = dir.path().join("moved.gltf").display().to_string();
    for (space, x_scale, z) in [("object", 1.0, 0.5), ("world", 2.0, 0.75)] {
        let out = dir.path().join(space);
        succeed(&[
            "bake",
            &graph.display().to_string(),
            "--mesh",
            &moved,
            "--space",
            space,
            "--size",
            "8",
            "--format",
            "exr",
            "--out",
            &out.display().to_string(),
            "--quiet",
        ]);
        let (_, _, _, zs) = read_exr(&out.join("coords.z.exr"));
        assert!(zs.iter().all(|v| *v == z), "{space}: z {zs:?}");
        let (_, _, _, xs) = read_exr(&out.join("coords.x.exr"));
        // Texel column i samples u = (i + 0.5)/8 = x as stored.
        for (t, x) in xs.iter().enumerate() {
            let u = ((t % 8) as f64 + 0.5) / 8.0;
            assert!(
                (f64::from(*x) - x_scale * u).abs() < 1e-6,
                "{space}: texel {t}: {x}"
            );
        }
    }
}
