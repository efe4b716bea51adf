//! The preview renderer: goldens per object kind, object vs world space, thread-count
//! independence, watch-mode reloads that survive broken edits, scene-file diagnostics.
//!
//! Goldens are `tests/render/NAME.png` (8-bit sRGB), compared within a tolerance;
//! `TEXGRAPH_BLESS=1 cargo test --test it render::` re-blesses them.

use std::path::{Path, PathBuf};
use texgraph::render::timing::{timing_table, TimingOptions};
use texgraph::render::watch::Previewer;
use texgraph::render::{
    self, load_input, load_scene, render, InputKind, PreviewDefaults, PreviewObject, RenderError,
    RenderFilter, RenderLod, RenderOptions, RenderedImage, Scene, SceneDesc, Space,
};

const MARBLE: &str = "graphs/seed003_marble.ron";

use crate::common;
use common::blessing;

/// Small renders without level of detail: the goldens pin the shading and the textures at
/// every octave (level of detail per pixel has its own tests below).
fn small(samples: u32) -> RenderOptions {
    RenderOptions {
        size: Some((64, 48)),
        samples: Some(samples),
        threads: None,
        progress: false,
        cancel: None,
        lod: RenderLod::Off,
        filter: RenderFilter::Point,
        device: Default::default(),
    }
}

/// The seed 003 marble at 4 octaves (quick in debug builds).
fn marble_defaults(object: PreviewObject, space: Space) -> PreviewDefaults {
    PreviewDefaults {
        object,
        space,
        overrides: vec![("octaves".into(), 4.0)],
        output: None,
        bump: None,
    }
}

/// Compares against a golden PNG: at most 1% of the channel values may differ by more than 8
/// (of 255), and the mean difference must stay under 1 — room for libm differences between
/// platforms, none for a wrong texture, shape, light or camera.
fn assert_golden(name: &str, image: &RenderedImage) {
    let path = PathBuf::from(format!("tests/render/{name}.png"));
    let got = image.to_rgb8();
    if blessing() {
        std::fs::write(&path, got.encode_png()).expect("write golden");
        return;
    }
    let want = common::Png::open(&path)
        .unwrap_or_else(|e| panic!("{e}; run with TEXGRAPH_BLESS=1 to create it"));
    assert_eq!(got.dimensions(), want.dimensions(), "{name}: size");
    let diffs: Vec<i32> = got
        .as_raw()
        .iter()
        .zip(&want.rgb8())
        .map(|(a, b)| (*a as i32 - *b as i32).abs())
        .collect();
    let big = diffs.iter().filter(|d| **d > 8).count();
    let mean = diffs.iter().sum::<i32>() as f64 / diffs.len() as f64;
    if big * 100 > diffs.len() || mean > 1.0 {
        let actual = std::env::temp_dir().join(format!("texgraph-render-{name}.png"));
        let _ = std::fs::write(&actual, got.encode_png());
        panic!(
            "{name}: {big} of {} channel values differ by more than 8, mean difference {mean:.3}; \
             this render is at {}; if the change is intended, re-bless with TEXGRAPH_BLESS=1",
            diffs.len(),
            actual.display()
        );
    }
}

fn render_default(object: PreviewObject, space: Space) -> RenderedImage {
    let scene = Scene::from_graph_default(Path::new(MARBLE), &marble_defaults(object, space))
        .expect("scene");
    render(&scene, &small(2)).expect("render").0
}

#[test]
fn golden_sphere() {
    assert_golden(
        "sphere",
        &render_default(PreviewObject::Sphere, Space::Object),
    );
}

#[test]
fn golden_cube() {
    assert_golden("cube", &render_default(PreviewObject::Cube, Space::Object));
}

#[test]
fn golden_plane() {
    assert_golden(
        "plane",
        &render_default(PreviewObject::Plane, Space::Object),
    );
}

#[test]
fn golden_teapot() {
    assert_golden(
        "teapot",
        &render_default(PreviewObject::Teapot, Space::Object),
    );
}

#[test]
fn golden_obj_mesh() {
    assert_golden(
        "house",
        &render_default(
            PreviewObject::Obj("tests/render/house.obj".into()),
            Space::Object,
        ),
    );
}

/// The default scene, moved as a whole (camera, lights, objects) by `offset`.
fn moved(desc: &SceneDesc, offset: [f64; 3]) -> SceneDesc {
    let shift = |p: &mut [f64; 3]| {
        for (c, o) in p.iter_mut().zip(offset) {
            *c += o;
        }
    };
    let mut d = desc.clone();
    shift(&mut d.camera.position);
    shift(&mut d.camera.look_at);
    for light in &mut d.lights {
        if let render::LightDesc::Point { position, .. } = light {
            shift(position);
        }
    }
    for object in &mut d.objects {
        object.transform.push(render::TransformDesc::Translate(
            offset[0], offset[1], offset[2],
        ));
    }
    d
}

fn max_difference(a: &RenderedImage, b: &RenderedImage) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs()))
        .fold(0.0, f32::max)
}

#[test]
fn object_space_textures_move_with_the_object_and_world_space_ones_do_not() {
    // Translate everything (camera and lights too): the same surface points come back to the
    // same pixels. In object space they get the same texture values, so the image is the same;
    // in world space the object has moved through the texture, so it is not.
    let offset = [0.75, 0.5, -0.25];
    for (space, should_match) in [(Space::Object, true), (Space::World, false)] {
        let desc = marble_defaults(PreviewObject::Sphere, space).scene_desc(Path::new(MARBLE));
        let here = Scene::from_desc(&desc, Path::new("")).unwrap();
        let there = Scene::from_desc(&moved(&desc, offset), Path::new("")).unwrap();
        let a = render(&here, &small(1)).unwrap().0;
        let b = render(&there, &small(1)).unwrap().0;
        let diff = max_difference(&a, &b);
        if should_match {
            assert!(
                diff < 0.02,
                "{space:?}: the moved object's texture changed (max difference {diff})"
            );
        } else {
            assert!(
                diff > 0.2,
                "{space:?}: the texture moved with the object (max difference {diff})"
            );
        }
    }
}

#[test]
fn rotating_an_object_turns_its_object_space_texture_with_it() {
    // A cube turned by 90° about y shows, in object space, the texture of the face that was
    // facing sideways; turning the camera and lights with it gives back the same image.
    let desc = marble_defaults(PreviewObject::Cube, Space::Object).scene_desc(Path::new(MARBLE));
    let mut turned = desc.clone();
    let rotate = |p: &mut [f64; 3]| *p = [p[2], p[1], -p[0]]; // 90° about +y
    rotate(&mut turned.camera.position);
    rotate(&mut turned.camera.look_at);
    for light in &mut turned.lights {
        match light {
            render::LightDesc::Point { position, .. } => rotate(position),
            render::LightDesc::Directional { direction, .. } => rotate(direction),
        }
    }
    for object in &mut turned.objects {
        object.transform.push(render::TransformDesc::Rotate {
            axis: [0.0, 1.0, 0.0],
            degrees: 90.0,
        });
    }
    let a = render(&Scene::from_desc(&desc, Path::new("")).unwrap(), &small(1))
        .unwrap()
        .0;
    let b = render(
        &Scene::from_desc(&turned, Path::new("")).unwrap(),
        &small(1),
    )
    .unwrap()
    .0;
    let diff = max_difference(&a, &b);
    assert!(diff < 0.02, "max difference {diff}");
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    let scene = Scene::from_graph_default(
        Path::new(MARBLE),
        &marble_defaults(PreviewObject::Teapot, Space::World),
    )
    .unwrap();
    // With and without level of detail per pixel.
    let mut first: Vec<(RenderedImage, render::Counters)> = Vec::new();
    // Point samples with and without level of detail, and box-filtered.
    for (lod, filter) in [
        (RenderLod::Off, RenderFilter::Point),
        (RenderLod::default(), RenderFilter::Point),
        (RenderLod::default(), RenderFilter::Box),
    ] {
        let mut images = Vec::new();
        for threads in [1, 2, 3, 8] {
            let options = RenderOptions {
                size: Some((53, 37)), // tiles of every shape
                samples: Some(3),
                threads: Some(threads),
                progress: false,
                cancel: None,
                lod,
                filter,
                device: Default::default(),
            };
            let (image, stats) = render(&scene, &options).unwrap();
            assert_eq!(stats.threads, threads);
            images.push((image, stats.counters));
        }
        for other in &images[1..] {
            assert!(
                images[0].0 == other.0,
                "pixels differ between thread counts ({lod:?}, {filter:?})"
            );
            assert_eq!(images[0].1, other.1);
        }
        first.push(images.swap_remove(0));
    }
    assert!(
        first[0].0 != first[1].0,
        "level of detail changes this render"
    );
    assert!(
        first[1].0 != first[2].0,
        "box filtering changes this render"
    );
}

#[test]
fn textures_are_evaluated_only_at_hits() {
    // A sphere alone on the background: one evaluation group, one point per hit.
    let mut desc =
        marble_defaults(PreviewObject::Sphere, Space::Object).scene_desc(Path::new(MARBLE));
    desc.objects.truncate(1);
    let scene = Scene::from_desc(&desc, Path::new("")).unwrap();
    let (image, stats) = render(&scene, &small(1)).unwrap();
    let c = stats.counters;
    assert_eq!(c.primary_rays, 64 * 48);
    assert!(c.hits > 0 && c.hits < c.primary_rays, "{c:?}");
    assert_eq!(c.texture_points, c.hits);
    // The corner pixel sees the background.
    let bg = desc.background.map(|v| v as f32);
    assert_eq!(image.pixel(0, 0), bg);
}

#[test]
fn a_graph_shared_by_materials_is_compiled_once_for_the_outputs_bound() {
    let dir = tempfile::tempdir().unwrap();
    let graph = std::fs::canonicalize(MARBLE).unwrap();
    let scene_path = dir.path().join("shared.ron");
    let g = graph.display();
    std::fs::write(
        &scene_path,
        format!(
            r#"Scene(
    camera: Camera(position: (0, 0, 8), look_at: (0, 0, 0)),
    lights: [Point(position: (0, 5, 5))],
    materials: {{
        "a": Material(diffuse: Texture(graph: "{g}", output: "colour", set: {{ "octaves": 2 }})),
        "b": Material(diffuse: Texture(graph: "{g}", output: "colour", set: {{ "octaves": 2 }}, space: World),
                      specular: Texture(graph: "{g}", output: "colour", set: {{ "octaves": 2 }})),
        "c": Material(diffuse: Texture(graph: "{g}", set: {{ "octaves": 3 }}), shininess: Texture(graph: "{g}", set: {{ "octaves": 3 }})),
        "unused": Material(diffuse: Texture(graph: "missing.ron")),
    }},
    objects: [
        Object(shape: Sphere(), material: "a", transform: [Translate(-2.5, 0, 0)]),
        Object(shape: Sphere(), material: "b"),
        Object(shape: Sphere(), material: "c", transform: [Translate(2.5, 0, 0)]),
        Object(shape: Sphere(radius: 0.5), material: "a", transform: [Translate(0, 2, 0)]),
    ],
)"#
        ),
    )
    .unwrap();
    let scene = load_scene(&scene_path).unwrap();
    let textures = scene.textures();
    assert_eq!(textures.len(), 2, "{textures:#?}");
    assert_eq!(textures[0].outputs, ["colour"]);
    assert_eq!(textures[0].overrides, [("octaves".to_string(), 2.0)]);
    assert_eq!(textures[0].tape.outputs().len(), 1);
    // "c": colour for diffuse by default, the first scalar output ("vein") for shininess.
    assert_eq!(textures[1].outputs, ["colour", "vein"]);
    assert!(scene.files().contains(&graph));
    let (_, stats) = render(&scene, &small(1)).unwrap();
    assert!(stats.counters.texture_points > 0);
}

// ---------------------------------------------------------------------------------------------
// Watch mode: the reload function
// ---------------------------------------------------------------------------------------------

const GOOD_GRAPH: &str = r#"Graph(
    params: { "scale": 4.0 },
    nodes: {
        "n": Noise(input: Scale(input: Position, by: "scale"), basis: Perlin),
        "colour": ColorRamp(input: Add(0.5, "n"), stops: [(0.0, (0.1, 0.2, 0.8)), (1.0, (0.9, 0.9, 0.2))]),
    },
    outputs: { "colour": "colour" },
)
"#;

const BROKEN_GRAPH: &str = r#"Graph(
    params: { "scale": 4.0 },
    nodes: {
        "n": Noize(input: Scale(input: Position, by: "scale"), basis: Perlin),
        "colour": ColorRamp(input: Add(0.5, "n"), stops: [(0.0, (0.1, 0.2, 0.8)), (1.0, (0.9, 0.9, 0.2))]),
    },
    outputs: { "colour": "colour" },
)
"#;

#[test]
fn reload_survives_a_broken_graph_edit_and_recovers() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("live.ron");
    let out = dir.path().join("preview.png");
    std::fs::write(&graph, GOOD_GRAPH).unwrap();
    let mut previewer = Previewer::new(&graph, PreviewDefaults::default(), small(1), &out);
    assert!(previewer.image().is_none());

    let stats = previewer.reload().expect("the good graph renders");
    assert!(stats.counters.texture_points > 0);
    assert!(
        stats.total_seconds >= stats.seconds && stats.load_seconds > 0.0,
        "{stats:?}"
    );
    assert!(stats.to_string().contains("refreshed in"), "{stats}");
    let good = previewer.image().expect("an image").clone();
    let good_png = std::fs::read(&out).expect("the PNG is written");
    assert!(previewer.watched_files().contains(&graph));

    // A broken edit: the diagnostic names file, line and column; the last good image stays, in
    // memory and on disk.
    std::fs::write(&graph, BROKEN_GRAPH).unwrap();
    let error = previewer.reload().expect_err("the broken graph fails");
    assert_eq!(error.exit_code(), 1);
    let message = error.to_string();
    assert!(
        message.contains(&format!("{}:4:14", graph.display())),
        "{message}"
    );
    assert!(message.contains("Noize"), "{message}");
    assert_eq!(previewer.image(), Some(&good));
    assert_eq!(std::fs::read(&out).unwrap(), good_png);

    // A file that cannot be read at all (mid-save) is survived the same way.
    std::fs::remove_file(&graph).unwrap();
    let error = previewer.reload().expect_err("a missing file fails");
    assert_eq!(error.exit_code(), 2);
    assert_eq!(previewer.image(), Some(&good));

    // Fixed, with another colour: the reload succeeds and replaces the image.
    std::fs::write(
        &graph,
        GOOD_GRAPH.replace("(0.1, 0.2, 0.8)", "(0.8, 0.1, 0.1)"),
    )
    .unwrap();
    previewer.reload().expect("the fixed graph renders");
    assert_ne!(previewer.image(), Some(&good));
    assert_ne!(std::fs::read(&out).unwrap(), good_png);
    // No temporary files are left behind.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.ends_with(".partial")), "{names:?}");
}

#[test]
fn reload_of_a_scene_watches_its_graph_and_survives_a_broken_scene() {
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("g.ron");
    let scene = dir.path().join("scene.ron");
    let out = dir.path().join("out.png");
    std::fs::write(&graph, GOOD_GRAPH).unwrap();
    let good_scene = r#"Scene(
    camera: Camera(position: (0, 0, 4), look_at: (0, 0, 0)),
    lights: [Point(position: (2, 3, 4))],
    materials: { "m": Material(diffuse: Texture(graph: "g.ron")) },
    objects: [Object(shape: Sphere(), material: "m")],
)"#;
    std::fs::write(&scene, good_scene).unwrap();
    let mut previewer = Previewer::new(&scene, PreviewDefaults::default(), small(1), &out);
    previewer.reload().expect("renders");
    let good = previewer.image().unwrap().clone();
    assert!(previewer.watched_files().contains(&scene));
    assert!(
        previewer.watched_files().contains(&graph),
        "{:?}",
        previewer.watched_files()
    );

    // A typo in the scene: the RON error is located in the scene file.
    std::fs::write(&scene, good_scene.replace("Sphere()", "Sphear()")).unwrap();
    let message = previewer.reload().unwrap_err().to_string();
    assert!(
        message.contains(&format!("{}:5:", scene.display())),
        "{message}"
    );
    assert!(message.contains("Sphear"), "{message}");
    assert_eq!(previewer.image(), Some(&good));
    // The graph is still watched although the broken scene names no graph.
    assert!(previewer.watched_files().contains(&graph));

    // A broken graph under a good scene.
    std::fs::write(&scene, good_scene).unwrap();
    std::fs::write(&graph, BROKEN_GRAPH).unwrap();
    let message = previewer.reload().unwrap_err().to_string();
    assert!(
        message.contains(&format!("{}:4:14", graph.display())),
        "{message}"
    );
    std::fs::write(&graph, GOOD_GRAPH).unwrap();
    previewer.reload().expect("fixed");
    assert_eq!(previewer.image(), Some(&good));
}

#[test]
fn the_watch_loop_re_renders_when_the_graph_is_saved() {
    // The loop itself, thinly: render, save the graph from the callback, see the second
    // refresh come, stop. No sleeping: the test waits on the loop's own progress (bounded).
    let dir = tempfile::tempdir().unwrap();
    let graph = dir.path().join("live.ron");
    let out = dir.path().join("preview.png");
    std::fs::write(&graph, GOOD_GRAPH).unwrap();
    let (done_tx, done_rx) = std::sync::mpsc::channel();
    let path = graph.clone();
    std::thread::spawn(move || {
        let mut previewer = Previewer::new(&path, PreviewDefaults::default(), small(1), &out);
        let mut results = Vec::new();
        let outcome = render::watch::watch(&mut previewer, |result| {
            results.push(result.as_ref().map(|_| ()).map_err(|e| e.to_string()));
            if results.len() == 1 {
                // An editor saving a broken version.
                std::fs::write(&path, BROKEN_GRAPH).unwrap();
                std::ops::ControlFlow::Continue(())
            } else {
                std::ops::ControlFlow::Break(())
            }
        });
        let _ = done_tx.send((
            outcome.map_err(|e| e.to_string()),
            results,
            previewer.image().is_some(),
        ));
    });
    let (outcome, results, kept) = done_rx
        .recv_timeout(std::time::Duration::from_secs(60))
        .expect("the watch loop reacted to the save");
    outcome.expect("the loop ends cleanly");
    assert_eq!(results.len(), 2);
    assert!(results[0].is_ok(), "{results:?}");
    let message = results[1].as_ref().expect_err("the broken save fails");
    assert!(
        message.contains(&format!("{}:4:14", graph.display())),
        "{message}"
    );
    assert!(kept, "the last good image is kept");
}

// ---------------------------------------------------------------------------------------------
// Scene-file errors: clear, located, never a panic
// ---------------------------------------------------------------------------------------------

/// Loads a scene written into a temporary folder (next to a copy of the marble graph) and
/// returns the rendered error with the folder replaced by `DIR`.
fn scene_error(text: &str) -> (RenderError, String) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(MARBLE, dir.path().join("marble.ron")).unwrap();
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(&path, text).unwrap();
    let error = load_scene(&path).expect_err("the scene is invalid");
    let message = error
        .to_string()
        .replace(&dir.path().display().to_string(), "DIR");
    (error, message)
}

#[test]
fn a_material_defined_twice_is_an_error_not_an_override() {
    let (error, message) = scene_error(&with(
        "        \"m\": Material(diffuse: Value(0.5)),\n        \"m\": Material(diffuse: Value(0.9)),",
        "        Object(shape: Sphere(), material: \"m\"),",
    ));
    assert_eq!(error.exit_code(), 1);
    assert!(
        message.contains(
            "error[duplicate-name]: DIR/scene.ron:6:9: scene: material \"m\" is defined twice"
        ),
        "{message}"
    );
}

fn with(materials: &str, objects: &str) -> String {
    format!(
        "Scene(\n    camera: Camera(position: (0, 0, 4), look_at: (0, 0, 0)),\n    lights: [Point(position: (1, 2, 3))],\n    materials: {{\n{materials}\n    }},\n    objects: [\n{objects}\n    ],\n)\n"
    )
}

const SPHERE_M: &str = r#"        Object(shape: Sphere(), material: "m"),"#;

#[test]
fn a_missing_graph_file_is_reported_at_its_path_in_the_scene() {
    let (error, message) = scene_error(&with(
        r#"        "m": Material(diffuse: Texture(graph: "nowhere.ron")),"#,
        SPHERE_M,
    ));
    assert_eq!(error.exit_code(), 1);
    assert!(
        message.contains("error[unknown-reference]: DIR/scene.ron:5:47:"),
        "{message}"
    );
    assert!(
        message.contains("cannot read the graph file DIR/nowhere.ron"),
        "{message}"
    );
    assert!(message.contains("relative to the scene file"), "{message}");
}

#[test]
fn an_unknown_output_is_reported_with_the_outputs_there_are() {
    let (_, message) = scene_error(&with(
        r#"        "m": Material(diffuse: Texture(graph: "marble.ron", output: "color")),"#,
        SPHERE_M,
    ));
    assert!(
        message.contains("error[unknown-output]: DIR/scene.ron:5:69:"),
        "{message}"
    );
    assert!(message.contains("has no output \"color\""), "{message}");
    assert!(
        message.contains("did you mean \"colour\"? Its outputs are: colour, vein"),
        "{message}"
    );
}

#[test]
fn bad_ron_is_reported_at_its_line_and_column() {
    let (error, message) =
        scene_error("Scene(\n    camera: Camera(position: (0, 0, 4), look_at: (0, 0 0)),\n)");
    assert_eq!(error.exit_code(), 1);
    assert!(message.contains("DIR/scene.ron:2:"), "{message}");
    let (_, message) = scene_error(&with(
        r#"        "m": Material(diffuse: Colour(1, 0, 0), shine: Value(3)),"#,
        SPHERE_M,
    ));
    assert!(
        message.contains("error[unknown-argument]: DIR/scene.ron:5:"),
        "{message}"
    );
    assert!(message.contains("shine"), "{message}");
    let (_, message) = scene_error("Scene(objects: [])");
    assert!(message.contains("error[missing-argument]"), "{message}");
    assert!(message.contains("camera"), "{message}");
    let (_, message) = scene_error("");
    assert!(message.contains("DIR/scene.ron:1:1"), "{message}");
}

#[test]
fn semantic_scene_errors_are_all_reported_at_once() {
    let (_, message) = scene_error(&with(
        r#"        "m": Material(diffuse: Texture(graph: "marble.ron", set: { "octave": 4 }), shininess: Colour(1, 1, 1)),
        "n": Material(shininess: Texture(graph: "marble.ron", output: "colour")),"#,
        r#"        Object(shape: Sphere(radius: -1), material: "m"),
        Object(shape: Sphere(), material: "mm"),
        Object(shape: Teapot(resolution: 0), material: "n"),
        Object(shape: Mesh(path: "none.obj"), material: "m", transform: [Scale(0)]),"#,
    ));
    for expected in [
        "error[bad-parameter]: DIR/scene.ron:9:38: object 1: the sphere's radius is -1",
        "error[unknown-reference]: DIR/scene.ron:10:43: object 2: no material named \"mm\"",
        "did you mean \"m\"?",
        "object 3: the teapot's resolution is 0",
        "object 4: cannot read the mesh DIR/none.obj",
        "object 4: Scale: every factor must be finite and not zero",
        "material \"m\": `shininess` is a number, not a colour",
        "error[type]: DIR/scene.ron:6:",
        "material \"n\": `shininess` is a number, and output \"colour\" is a colour",
        "error[unknown-param]: DIR/scene.ron:5:68: material \"m\": `diffuse`: the graph DIR/marble.ron has no param \"octave\"",
        "did you mean \"octaves\"?",
    ] {
        assert!(message.contains(expected), "missing {expected:?} in:\n{message}");
    }
}

#[test]
fn mesh_and_graph_problems_are_reported_in_their_own_files() {
    let (_, message) = scene_error(&with(
        r#"        "m": Material(diffuse: Value(0.5)),"#,
        r#"        Object(shape: Mesh(path: "bad.obj"), material: "m"),"#,
    ));
    assert!(
        message.contains("error[syntax]: DIR/bad.obj:3:7: OBJ: vertex index 3 is out of range"),
        "{message}"
    );

    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("broken.ron"), BROKEN_GRAPH).unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(
        &path,
        with(
            r#"        "m": Material(diffuse: Texture(graph: "broken.ron")),"#,
            SPHERE_M,
        ),
    )
    .unwrap();
    let message = load_scene(&path).unwrap_err().to_string();
    assert!(
        message.contains(&format!("{}:4:14", dir.path().join("broken.ron").display())),
        "{message}"
    );
}

#[test]
fn hostile_scenes_never_panic() {
    let cases = [
        "Scene(camera: Camera(position: (0, 0, 0), look_at: (0, 0, 0)), objects: [])",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0), up: (0, 0, 1), fov: 180), objects: [])",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), objects: [], size: (0, 10), samples: 0)",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), lights: [Directional(direction: (0, 0, 0))], objects: [])",
        "Scene(camera: Camera(position: (0, 0, 1e39), look_at: (0, 0, 0)), objects: [])",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), objects: [Object(shape: Box(size: (1, 0, 1)), material: \"x\")])",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), materials: { \"x\": Material(diffuse: Texture(graph: \"\")) }, objects: [Object(shape: Plane(size: (-1, 1)), material: \"x\")])",
        "Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), materials: { \"x\": Material(diffuse: Value(inf)) }, objects: [Object(shape: Plane(), material: \"x\", transform: [Rotate(axis: (0, 0, 0), degrees: 1)])])",
        "Scene(((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((((",
        "\u{feff}Scene(camera: Camera(position: (0, 0, 1), look_at: (0, 0, 0)), objects: [Object(shape: Mesh(path: \"/\"), material: \"x\")])",
    ];
    for text in cases {
        let (error, message) = scene_error(text);
        assert!(!message.is_empty());
        assert!(
            matches!(error, RenderError::Invalid(_)),
            "{text}: {message}"
        );
    }
}

#[test]
fn render_options_are_checked() {
    let scene = Scene::from_graph_default(Path::new(MARBLE), &PreviewDefaults::default()).unwrap();
    for options in [
        RenderOptions {
            size: Some((0, 10)),
            ..small(1)
        },
        RenderOptions {
            size: Some((100_000, 10)),
            ..small(1)
        },
        RenderOptions {
            samples: Some(0),
            ..small(1)
        },
        RenderOptions {
            threads: Some(0),
            ..small(1)
        },
    ] {
        let error = render(&scene, &options).expect_err("refused");
        assert_eq!(error.exit_code(), 2, "{error}");
    }
}

// ---------------------------------------------------------------------------------------------
// Inputs, files, scenes shipped, timing table
// ---------------------------------------------------------------------------------------------

#[test]
fn a_graph_alone_gets_the_default_preview_scene() {
    assert_eq!(
        render::input_kind(&std::fs::read_to_string(MARBLE).unwrap()),
        InputKind::Graph
    );
    let scene = load_input(Path::new(MARBLE), &PreviewDefaults::default()).unwrap();
    // The object and a ground plane; the diffuse channel bound to "colour" only.
    assert_eq!(scene.object_count(), 2);
    assert_eq!(scene.textures().len(), 1);
    assert_eq!(scene.textures()[0].outputs, ["colour"]);
    // An unknown --output is reported against the graph's outputs.
    let defaults = PreviewDefaults {
        output: Some("nope".into()),
        ..PreviewDefaults::default()
    };
    let message = load_input(Path::new(MARBLE), &defaults)
        .unwrap_err()
        .to_string();
    assert!(message.contains("has no output \"nope\""), "{message}");
    assert!(message.contains("colour, vein"), "{message}");
    // A scalar output as the diffuse colour is a grey.
    let defaults = PreviewDefaults {
        output: Some("vein".into()),
        ..PreviewDefaults::default()
    };
    let scene = load_input(Path::new(MARBLE), &defaults).unwrap();
    let (image, _) = render(&scene, &small(1)).unwrap();
    let centre = image.pixel(32, 24);
    assert!(
        (centre[0] - centre[1]).abs() < 0.05 && (centre[1] - centre[2]).abs() < 0.05,
        "{centre:?}"
    );
    // A --set of a param the graph does not have: the checker's own message.
    let defaults = PreviewDefaults {
        overrides: vec![("octave".into(), 3.0)],
        ..PreviewDefaults::default()
    };
    let message = load_input(Path::new(MARBLE), &defaults)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("--set octave: the graph has no param \"octave\""),
        "{message}"
    );
    assert!(message.contains("did you mean \"octaves\"?"), "{message}");
    // A missing mesh for --object.
    let defaults = PreviewDefaults {
        object: PreviewObject::Obj("tests/render/missing.obj".into()),
        ..PreviewDefaults::default()
    };
    let message = load_input(Path::new(MARBLE), &defaults)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("cannot read the mesh tests/render/missing.obj"),
        "{message}"
    );
    // Unknown objects are refused by the parser.
    assert!("pyramid".parse::<PreviewObject>().is_err());
    assert_eq!(
        "model.OBJ".parse::<PreviewObject>(),
        Ok(PreviewObject::Obj("model.OBJ".into()))
    );
}

#[test]
fn every_shipped_scene_loads_and_renders() {
    let mut count = 0;
    for entry in std::fs::read_dir("graphs/scenes").expect("graphs/scenes") {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            let scene = load_input(&path, &PreviewDefaults::default())
                .unwrap_or_else(|e| panic!("{}:\n{e}", path.display()));
            let options = RenderOptions {
                size: Some((24, 24)),
                samples: Some(1),
                ..RenderOptions::default()
            };
            let (_, stats) = render(&scene, &options).unwrap();
            assert!(stats.counters.hits > 0, "{}", path.display());
            count += 1;
        }
    }
    assert!(
        count >= 6,
        "expected seed 003's scenes in graphs/scenes, found {count}"
    );
}

#[test]
fn png_files_are_written_whole_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let image = RenderedImage {
        width: 2,
        height: 1,
        pixels: vec![[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
    };
    let path = dir.path().join("x.png");
    image.write_png(&path).unwrap();
    let back = common::Png::open(&path).unwrap().rgb8();
    assert_eq!(back, [255, 0, 0, 0, 0, 255]);
    let error = image
        .write_png(&dir.path().join("missing/x.png"))
        .unwrap_err();
    assert_eq!(error.exit_code(), 2);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn the_timing_table_runs_and_cites_seed_003() {
    let options = TimingOptions {
        size: (24, 24),
        octaves: vec![1, 8],
        repeats: 1,
        ..TimingOptions::default()
    };
    let table = timing_table(Path::new(MARBLE), &options).unwrap();
    assert_eq!(table.rows.len(), 2);
    assert_eq!(table.rows[1].seed003_seconds, Some(2.0));
    let text = table.to_string();
    assert!(text.contains("24×24 pixels"), "{text}");
    assert!(text.contains("PentiumIII 733 MHz"), "{text}");
}

/// Not a check: renders the pictures for the README and docs into `$TEXGRAPH_GALLERY`
/// (default `target/render-gallery`).
/// `cargo test --release --test it render::gallery -- --ignored`
#[test]
#[ignore]
fn gallery() {
    let dir = PathBuf::from(
        std::env::var("TEXGRAPH_GALLERY").unwrap_or_else(|_| "target/render-gallery".into()),
    );
    std::fs::create_dir_all(&dir).unwrap();
    let options = RenderOptions::default();
    for entry in std::fs::read_dir("graphs/scenes").unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
            let (image, stats) = render(&scene, &options).unwrap();
            let out = dir.join(path.with_extension("png").file_name().unwrap());
            image.write_png(&out).unwrap();
            eprintln!("{}: {stats}", out.display());
        }
    }
    for (graph, object) in [
        ("graphs/seed003_marble.ron", PreviewObject::Teapot),
        ("graphs/seed000_wood.ron", PreviewObject::Sphere),
        ("graphs/seed001_wood.ron", PreviewObject::Cube),
        ("graphs/seed004_checker3d.ron", PreviewObject::Cube),
        ("graphs/seed004_wood_grain.ron", PreviewObject::Teapot),
        ("graphs/seed000_marble_cracks.ron", PreviewObject::Sphere),
        ("graphs/seed002_marble.ron", PreviewObject::Plane),
    ] {
        let defaults = PreviewDefaults {
            object: object.clone(),
            ..PreviewDefaults::default()
        };
        let scene = Scene::from_graph_default(Path::new(graph), &defaults).unwrap();
        let (image, stats) = render(
            &scene,
            &RenderOptions {
                size: Some((480, 360)),
                ..options.clone()
            },
        )
        .unwrap();
        let stem = Path::new(graph).file_stem().unwrap().to_string_lossy();
        let out = dir.join(format!("preview_{stem}_{object:?}.png").to_lowercase());
        image.write_png(&out).unwrap();
        eprintln!("{}: {stats}", out.display());
    }
}

/// Not a check: prints seed 003's timing table (500×500 pixels, 1 sample per pixel, octaves 1,
/// 2, 4, 8) — what `texgraph render --timing-table` prints.
/// `cargo test --release --test it render::timing_table_print -- --ignored --nocapture`
#[test]
#[ignore]
fn timing_table_print() {
    for threads in [Some(1), None] {
        let options = TimingOptions {
            threads,
            ..TimingOptions::default()
        };
        let table = timing_table(Path::new(MARBLE), &options).unwrap();
        println!("{table}\n");
    }
}

// ---------------------------------------------------------------------------------------------
// docs/scenes.md, the reference of the scene format
// ---------------------------------------------------------------------------------------------

const SCENES_DOC: &str = "docs/scenes.md";

/// The files a scene example names: the strings after `graph:` and `path:`, and the file of a
/// bump's `height: "FILE.OUTPUT"` (before the last dot).
fn referenced_files(text: &str) -> Vec<String> {
    let mut files = Vec::new();
    for key in ["graph:", "path:", "height:"] {
        let mut rest = text;
        while let Some(at) = rest.find(key) {
            rest = rest[at + key.len()..].trim_start();
            if let Some((name, _)) = rest.strip_prefix('"').and_then(|r| r.split_once('"')) {
                let name = match key {
                    "height:" => name.rsplit_once('.').map_or(name, |(file, _)| file),
                    _ => name,
                };
                files.push(name.to_string());
            }
        }
    }
    files
}

/// Saves an example as `dir/name` next to copies of the repository's files it names (examples
/// are written as if saved in the repository root) and returns the scene's path.
fn save_doc_example(dir: &Path, block: &common::Block, name: &str) -> PathBuf {
    for file in referenced_files(&block.text) {
        let relative = Path::new(&file);
        assert!(
            relative
                .components()
                .all(|c| matches!(c, std::path::Component::Normal(_))),
            "{SCENES_DOC}:{}: `{file}`: examples name files relative to the repository root, \
             without `.` or `..`",
            block.line
        );
        // A file that does not exist is left for the example to fail on.
        if relative.is_file() {
            let copy = dir.join(relative);
            std::fs::create_dir_all(copy.parent().expect("a file has a folder")).unwrap();
            std::fs::copy(relative, &copy).unwrap();
        }
    }
    let path = dir.join(name);
    std::fs::write(&path, &block.text).unwrap();
    path
}

/// A scene example: its first line that is not blank or a `//` comment starts with `Scene(`.
fn is_scene(block: &common::Block) -> bool {
    block
        .text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with("//"))
        .is_some_and(|l| l.starts_with("Scene("))
}

/// Every ```ron block of docs/scenes.md is a scene that loads with `load_scene` and renders (at
/// 16×12 pixels, 1 sample) showing something; a ```ron preview block is also exactly the
/// preview scene of its graph; a ```ron invalid block fails to load, with the diagnostics of
/// the ```text block after it.
#[test]
fn docs_scenes_md_examples_load_and_render() {
    let doc = std::fs::read_to_string(SCENES_DOC).expect(SCENES_DOC);
    let blocks = common::code_blocks(SCENES_DOC, &doc);
    let options = RenderOptions {
        size: Some((16, 12)),
        samples: Some(1),
        ..Default::default()
    };
    let (mut scenes, mut previews, mut invalid) = (0, 0, 0);
    let mut failures = String::new();
    for (i, block) in blocks.iter().enumerate() {
        let mut words = block.info.split_whitespace();
        if words.next() != Some("ron") {
            continue;
        }
        let flags: Vec<&str> = words.collect();
        let at = format!("the ```{} block at {SCENES_DOC}:{}", block.info, block.line);
        let dir = tempfile::tempdir().unwrap();
        if flags.contains(&"invalid") {
            invalid += 1;
            let path = save_doc_example(dir.path(), block, "broken.ron");
            let error = match load_scene(&path) {
                Ok(_) => {
                    failures.push_str(&format!("{at} loads without errors\n"));
                    continue;
                }
                Err(e) => e,
            };
            // Colour off, as `texgraph render broken.ron` prints it in the folder of the file.
            let folder = format!("{}{}", dir.path().display(), std::path::MAIN_SEPARATOR);
            let rendered = error.render(false).replace(&folder, "");
            match blocks.get(i + 1).filter(|b| b.info == "text") {
                None => failures.push_str(&format!(
                    "{at} must be followed by a ```text block with its diagnostics:\n{rendered}\n"
                )),
                Some(shown) if shown.text.trim_end() != rendered.trim_end() => {
                    failures.push_str(&format!(
                        "the diagnostics shown at {SCENES_DOC}:{} are out of date; loading the \
                         block before them as broken.ron now prints:\n{rendered}\n",
                        shown.line
                    ))
                }
                Some(_) => {}
            }
            continue;
        }
        if !is_scene(block) {
            failures.push_str(&format!(
                "{at} is not a scene (its first line that is not a comment must start with \
                 `Scene(`): write other RON in ```text blocks\n"
            ));
            continue;
        }
        scenes += 1;
        let path = save_doc_example(dir.path(), block, "scene.ron");
        match load_scene(&path).and_then(|scene| render(&scene, &options)) {
            Ok((_, stats)) if stats.counters.hits == 0 => {
                failures.push_str(&format!("{at} renders nothing but the background\n"))
            }
            Ok(_) => {}
            Err(e) => failures.push_str(&format!("{at} does not load or render:\n{e}\n")),
        }
        if flags.contains(&"preview") {
            previews += 1;
            let graph = referenced_files(&block.text).into_iter().next();
            let graph = graph.unwrap_or_else(|| panic!("{at} names no graph"));
            let written: SceneDesc = ron::Options::default()
                .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
                .from_str(&block.text)
                .unwrap_or_else(|e| panic!("{at}: {e}"));
            let built = PreviewDefaults::default().scene_desc(Path::new(&graph));
            if format!("{written:#?}") != format!("{built:#?}") {
                failures.push_str(&format!(
                    "{at} is not the preview scene of {graph}, which is:\n{built:#?}\n"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures}");
    // Guards the block reader itself: the document has several examples of each kind.
    assert!(
        scenes >= 5 && previews >= 1 && invalid >= 1,
        "{SCENES_DOC}: found {scenes} scene, {previews} preview and {invalid} invalid examples; \
         is the code block reader broken?"
    );
}

/// Every field and variant name of the scene format, as read from src/render/scene.rs
/// (`SceneDesc` and the types in it, aliases included): docs/scenes.md names each in backticks.
const SCENE_FORMAT_NAMES: &[&str] = &[
    // Scene
    "Scene",
    "camera",
    "lights",
    "materials",
    "objects",
    "background",
    "background_color",
    "ambient_light",
    "size",
    "samples",
    // Camera
    "Camera",
    "position",
    "look_at",
    "up",
    "fov",
    // Lights
    "Point",
    "Directional",
    "direction",
    "colour",
    "color",
    "intensity",
    "shadows",
    // Materials and channels
    "Material",
    "ambient",
    "diffuse",
    "specular",
    "shininess",
    "bump",
    "Bump",
    "height",
    "strength",
    "Colour",
    "Color",
    "Rgb",
    "Value",
    "Texture",
    "graph",
    "output",
    "set",
    "space",
    "transform",
    "multiply",
    "Object",
    "World",
    // Transforms
    "Translate",
    "Rotate",
    "axis",
    "degrees",
    "Scale",
    // Objects and shapes
    "shape",
    "material",
    "Sphere",
    "radius",
    "Box",
    "Cube",
    "Plane",
    "Mesh",
    "path",
    "fit",
    "Teapot",
    "resolution",
];

/// The names the scene reader itself lists when `text` uses an unknown field or variant: the
/// fields or variants it expected, and the struct or variant the field was in (not the Rust
/// enum's name, which a file never writes). Empty when the error is of another kind.
fn names_the_reader_expects(dir: &Path, text: &str) -> Vec<String> {
    let path = dir.join("probe.ron");
    std::fs::write(&path, text).unwrap();
    let message = match load_scene(&path) {
        Err(RenderError::Invalid(list)) => list[0].list[0].message.clone(),
        Err(e) => panic!("{text}: {e}"),
        Ok(_) => panic!("{text}: loads"),
    };
    if !message.starts_with("scene: Unexpected") {
        return Vec::new();
    }
    let parts: Vec<&str> = message.split('`').collect();
    (1..parts.len())
        .step_by(2)
        .filter(|&k| !parts[k - 1].ends_with("in enum ") && !parts[k].eq_ignore_ascii_case("zzz"))
        .map(|k| parts[k].to_string())
        .collect()
}

#[test]
fn docs_scenes_md_names_every_field_and_variant() {
    // What the reader accepts, asked of the reader: unknown fields and variants in every place,
    // and in every variant of each enum.
    let dir = tempfile::tempdir().unwrap();
    let mut accepted = std::collections::BTreeSet::new();
    let mut probe = |text: &str| {
        let names = names_the_reader_expects(dir.path(), text);
        accepted.extend(names.iter().cloned());
        names
    };
    for text in [
        "Scene(zzz: 0)",
        "Scene(camera: Camera(zzz: 0))",
        r#"Scene(materials: { "m": Material(zzz: 0) })"#,
        r#"Scene(materials: { "m": Material(diffuse: Texture(space: Zzz)) })"#,
        r#"Scene(materials: { "m": Material(bump: (zzz: 0)) })"#,
        r#"Scene(materials: { "m": Material(bump: (height: Texture(zzz: 0))) })"#,
        "Scene(objects: [Object(zzz: 0)])",
    ] {
        assert!(!probe(text).is_empty(), "{text}: no names in the error");
    }
    for (variants, fields) in [
        ("Scene(lights: [Zzz])", "Scene(lights: [V(zzz: 0)])"),
        (
            r#"Scene(materials: { "m": Material(diffuse: Zzz) })"#,
            r#"Scene(materials: { "m": Material(diffuse: V(zzz: 0)) })"#,
        ),
        (
            "Scene(objects: [Object(transform: [Zzz])])",
            "Scene(objects: [Object(transform: [V(zzz: 0)])])",
        ),
        (
            "Scene(objects: [Object(shape: Zzz)])",
            "Scene(objects: [Object(shape: V(zzz: 0))])",
        ),
    ] {
        let names = probe(variants);
        assert!(!names.is_empty(), "{variants}: no variants in the error");
        for variant in names {
            probe(&fields.replace("V(", &format!("{variant}(")));
        }
    }
    let listed: std::collections::BTreeSet<String> =
        SCENE_FORMAT_NAMES.iter().map(|n| n.to_string()).collect();
    let unlisted: Vec<&String> = accepted.difference(&listed).collect();
    let stale: Vec<&String> = listed.difference(&accepted).collect();
    assert!(
        unlisted.is_empty() && stale.is_empty(),
        "SCENE_FORMAT_NAMES is out of date: the scene reader accepts {unlisted:?}, which the list \
         lacks (add them and document them in {SCENES_DOC}), and not {stale:?}, which it has"
    );
    let doc = std::fs::read_to_string(SCENES_DOC).expect(SCENES_DOC);
    let missing: Vec<&str> = SCENE_FORMAT_NAMES
        .iter()
        .copied()
        .filter(|name| !doc.contains(&format!("`{name}`")))
        .collect();
    assert!(
        missing.is_empty(),
        "{SCENES_DOC} does not name these fields or variants in backticks: {}",
        missing.join(", ")
    );
}

// ---------------------------------------------------------------------------------------------
// Bump mapping: n' = normalize(n − s·(g − (g·n) n)), g the world-space gradient of the height
// ---------------------------------------------------------------------------------------------

type V3 = [f64; 3];

fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalise(a: V3) -> V3 {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

/// A graph whose scalar output `h` is `expression` (of `p`, the point) and whose vec3 output
/// `c` is not a height.
fn height_graph(expression: &str) -> String {
    format!(
        "Graph(\n    nodes: {{ \"p\": Position, \"h\": {expression} }},\n    outputs: {{ \"h\": \"h\", \"c\": Combine(\"h\", 0.5, 0.5) }},\n)\n"
    )
}

/// `a.x·p.x + a.y·p.y + a.z·p.z` as a graph expression.
fn linear(a: V3) -> String {
    format!(
        "Add(Add(Mul({:?}, \"p.x\"), Mul({:?}, \"p.y\")), Mul({:?}, \"p.z\"))",
        a[0], a[1], a[2]
    )
}

const BUMP_EYE: V3 = [0.4, 3.0, 2.5];
/// The light travels along this direction (no shadows, no ambient light: every pixel is
/// diffuse n·l plus the highlight).
const BUMP_LIGHT: V3 = [0.5, -1.0, 0.3];
const BUMP_SIZE: (u32, u32) = (48, 36);

/// Renders a plane (`Plane()` with `object_transform`) of a material whose diffuse colour is
/// constant and whose bump is `bump` (scene text, or empty for none), in a folder holding the
/// `graphs` (name, text).
fn bump_plane(graphs: &[(&str, String)], bump: &str, object_transform: &str) -> RenderedImage {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in graphs {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let scene = format!(
        r#"Scene(
    camera: Camera(position: ({}, {}, {}), look_at: (0, 0, 0), fov: 40),
    lights: [Directional(direction: ({}, {}, {}), shadows: false)],
    ambient_light: (0, 0, 0),
    materials: {{
        "m": Material(diffuse: Colour(0.6, 0.5, 0.4), specular: Value(0.3), shininess: Value(8){bump}),
    }},
    objects: [Object(shape: Plane(), material: "m", transform: [{object_transform}])],
)"#,
        BUMP_EYE[0], BUMP_EYE[1], BUMP_EYE[2], BUMP_LIGHT[0], BUMP_LIGHT[1], BUMP_LIGHT[2]
    );
    let path = dir.path().join("scene.ron");
    std::fs::write(&path, scene).unwrap();
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    // Every octave: the expected shading below is computed from the height at full detail.
    let options = RenderOptions {
        size: Some(BUMP_SIZE),
        samples: Some(1),
        lod: RenderLod::Off,
        filter: RenderFilter::Point,
        ..Default::default()
    };
    render(&scene, &options).unwrap().0
}

/// Blinn–Phong of the plane y = 0 with shading normal `n` at pixel (x, y), computed here from
/// the camera's definition (docs/scenes.md): the pixel centre's ray, the light, the halfway
/// vector.
fn blinn_phong_on_the_plane(n: V3, x: u32, y: u32) -> V3 {
    let (w, h) = (BUMP_SIZE.0 as f64, BUMP_SIZE.1 as f64);
    let forward = normalise(BUMP_EYE.map(|c| -c));
    let cross = |a: V3, b: V3| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let right = normalise(cross(forward, [0.0, 1.0, 0.0]));
    let up = cross(right, forward);
    let tan_half = 20f64.to_radians().tan();
    let ndc_x = (x as f64 + 0.5) / w * 2.0 - 1.0;
    let ndc_y = 1.0 - (y as f64 + 0.5) / h * 2.0;
    let direction = normalise(std::array::from_fn(|i| {
        forward[i] + right[i] * ndc_x * tan_half * w / h + up[i] * ndc_y * tan_half
    }));
    let l = normalise(BUMP_LIGHT.map(|c| -c));
    let halfway = normalise(std::array::from_fn(|i| l[i] - direction[i]));
    let n_dot_l = dot(n, l);
    assert!(n_dot_l > 0.0, "the test's light must light the surface");
    let highlight = dot(n, halfway).max(0.0).powf(8.0);
    let diffuse = [0.6, 0.5, 0.4];
    diffuse.map(|d| d * n_dot_l + 0.3 * highlight)
}

/// The largest difference between `image` and the analytic plane shaded with normal `n`.
fn error_against_blinn_phong(image: &RenderedImage, n: V3) -> f64 {
    let mut worst = 0.0f64;
    for y in 0..image.height {
        for x in 0..image.width {
            let want = blinn_phong_on_the_plane(n, x, y);
            let got = image.pixel(x, y);
            for c in 0..3 {
                worst = worst.max((got[c] as f64 - want[c]).abs());
            }
        }
    }
    worst
}

#[test]
fn a_linear_height_tilts_a_plane_to_blinns_normal() {
    // h = a·x on the plane y = 0 (normal +y): ∇h = (a, 0, 0) is tangent to the plane, and the
    // shading normal is normalize((0, 1, 0) − s·(a, 0, 0)) on every pixel.
    let a = 0.8;
    let graphs = [("ramp.ron", height_graph(&format!("Mul({a:?}, \"p.x\")")))];
    let flat = bump_plane(&graphs, "", "");
    let up = [0.0, 1.0, 0.0];
    assert!(error_against_blinn_phong(&flat, up) < 2e-5);
    for s in [0.6, -0.6, 1.5] {
        for form in [
            format!(", bump: (height: \"ramp.ron.h\", strength: {s:?})"),
            format!(", bump: Bump(height: Texture(graph: \"ramp.ron\", output: \"h\"), strength: {s:?})"),
            // `multiply` is a factor on the height: the same tilt.
            format!(", bump: (height: Texture(graph: \"ramp.ron\", multiply: 2), strength: {:?})", s / 2.0),
        ] {
            let image = bump_plane(&graphs, &form, "");
            let tilted = normalise([-s * a, 1.0, 0.0]);
            let error = error_against_blinn_phong(&image, tilted);
            assert!(error < 2e-5, "{form}: off by {error}");
            // The tilt is visible: the flat plane's shading is far from it.
            let flat_error = error_against_blinn_phong(&image, up);
            assert!(flat_error > 0.05, "{form}: the bump changed little ({flat_error})");
        }
    }
}

#[test]
fn only_the_tangential_part_of_the_gradient_tilts_the_normal() {
    // A height that also grows along the plane's normal (+y) bumps exactly as one that does not.
    let graphs = [
        ("x.ron", height_graph(&linear([0.8, 0.0, -0.3]))),
        ("xy.ron", height_graph(&linear([0.8, 5.0, -0.3]))),
    ];
    let a = bump_plane(&graphs, ", bump: (height: \"x.ron.h\", strength: 1)", "");
    let b = bump_plane(&graphs, ", bump: (height: \"xy.ron.h\", strength: 1)", "");
    let diff = max_difference(&a, &b);
    assert!(diff < 1e-6, "max difference {diff}");
    let c = bump_plane(&graphs, "", "");
    assert!(max_difference(&a, &c) > 0.05);
}

/// The linear part of `[Scale(scale), Rotate(axis: (0, 1, 0), degrees)]`: R·S, as rows.
fn rotate_y_after_scale(scale: V3, degrees: f64) -> [V3; 3] {
    let (s, c) = degrees.to_radians().sin_cos();
    let r = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]];
    std::array::from_fn(|i| std::array::from_fn(|j| r[i][j] * scale[j]))
}

fn times(m: [V3; 3], v: V3) -> V3 {
    std::array::from_fn(|i| dot(m[i], v))
}

fn transposed(m: [V3; 3]) -> [V3; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[j][i]))
}

#[test]
fn gradients_follow_the_chain_rule_through_texture_transforms() {
    // The texture point is p_t = L·p + t (L = R·S: a non-uniform scale, then a turn). A height
    // c·p_t is (Lᵀc)·p + constant at the plane's point p: the bump must match the height with
    // Lᵀ folded into the graph. Lᵀ ≠ L here, so a missing transpose shows.
    let c = [0.5, 0.3, -0.4];
    let l = rotate_y_after_scale([3.0, 1.0, 0.5], 30.0);
    let folded = times(transposed(l), c);
    let not_transposed = times(l, c);
    let graphs = [
        ("h.ron", height_graph(&linear(c))),
        ("folded.ron", height_graph(&linear(folded))),
        ("wrong.ron", height_graph(&linear(not_transposed))),
    ];
    let transformed = bump_plane(
        &graphs,
        ", bump: (height: Texture(graph: \"h.ron\", output: \"h\", transform: [Scale((3, 1, 0.5)), \
         Rotate(axis: (0, 1, 0), degrees: 30), Translate(0.2, 7, 0.1)]), strength: 0.7)",
        "",
    );
    let want = bump_plane(
        &graphs,
        ", bump: (height: \"folded.ron.h\", strength: 0.7)",
        "",
    );
    let wrong = bump_plane(
        &graphs,
        ", bump: (height: \"wrong.ron.h\", strength: 0.7)",
        "",
    );
    let diff = max_difference(&transformed, &want);
    assert!(diff < 1e-5, "max difference {diff}");
    assert!(max_difference(&want, &wrong) > 0.02, "the test cannot tell");
    // Against the analytic tilt too: the folded gradient's part along the plane.
    let tilted = normalise([-0.7 * folded[0], 1.0, -0.7 * folded[2]]);
    assert!(error_against_blinn_phong(&transformed, tilted) < 2e-5);
}

#[test]
fn gradients_follow_the_chain_rule_through_object_transforms() {
    // An object-space height on an object scaled non-uniformly and turned: the object point is
    // p_o = L⁻¹·p_w (L = R·S), so ∇_w (c·p_o) = L⁻ᵀc = R·S⁻¹·c. The plane y = 0 stays the plane
    // y = 0 under these steps; the same plane with a world-space height (R·S⁻¹·c)·p must look
    // the same.
    let c = [0.5, 0.3, -0.4];
    let inverse_scale = rotate_y_after_scale([0.5, 1.0, 2.0], 40.0); // R·S⁻¹
    let folded = times(inverse_scale, c);
    let wrong = times(rotate_y_after_scale([2.0, 1.0, 0.5], 40.0), c); // R·S·c
    let graphs = [
        ("h.ron", height_graph(&linear(c))),
        ("folded.ron", height_graph(&linear(folded))),
        ("wrong.ron", height_graph(&linear(wrong))),
    ];
    let object_space = bump_plane(
        &graphs,
        ", bump: (height: Texture(graph: \"h.ron\", space: Object), strength: 0.7)",
        "Scale((2, 1, 0.5)), Rotate(axis: (0, 1, 0), degrees: 40)",
    );
    let world = |graph: &str| {
        bump_plane(
            &graphs,
            &format!(", bump: (height: Texture(graph: \"{graph}\", space: World), strength: 0.7)"),
            "",
        )
    };
    let diff = max_difference(&object_space, &world("folded.ron"));
    assert!(diff < 1e-5, "max difference {diff}");
    assert!(max_difference(&object_space, &world("wrong.ron")) > 0.02);
}

/// A sphere of stone (graphs/stone.ron) with `bump` (scene text) in its material.
fn stone_sphere(bump: &str) -> (RenderedImage, render::Counters) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy("graphs/stone.ron", dir.path().join("stone.ron")).unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(
        &path,
        format!(
            r#"Scene(
    camera: Camera(position: (0, 0.5, 3.4), look_at: (0, 0, 0), fov: 40),
    lights: [Point(position: (-4, 5, 6)), Directional(direction: (1, -0.3, -1), intensity: 0.3, shadows: false)],
    materials: {{
        "stone": Material(
            diffuse: Texture(graph: "stone.ron", set: {{ "octaves": 3 }}, transform: [Scale(0.5), Translate(0.5, 0.5, 0.5)]),
            specular: Value(0.3),
            shininess: Value(20),
            {bump}
        ),
    }},
    objects: [Object(shape: Sphere(), material: "stone")],
)"#
        ),
    )
    .unwrap();
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let (image, stats) = render(&scene, &small(1)).unwrap();
    (image, stats.counters)
}

#[test]
fn a_bump_of_strength_zero_changes_no_bit() {
    let texture = |strength: &str| {
        format!(
            "bump: (height: Texture(graph: \"stone.ron\", output: \"stone\", set: {{ \"octaves\": 3 }}, \
             transform: [Scale(0.5), Translate(0.5, 0.5, 0.5)]), strength: {strength}),"
        )
    };
    let (plain, plain_counters) = stone_sphere("");
    let (zero, zero_counters) = stone_sphere(&texture("0"));
    assert!(plain.pixels == zero.pixels, "a zero bump changed the image");
    assert_eq!(plain_counters, zero_counters);
    let (short_zero, _) = stone_sphere("bump: (height: \"stone.ron.stone\", strength: 0),");
    assert!(plain.pixels == short_zero.pixels);
    let (bumped, counters) = stone_sphere(&texture("0.1"));
    assert!(max_difference(&plain, &bumped) > 0.05);
    // The height's gradient shares the colour's tape and evaluation (same graph, set, space and
    // transform): one evaluation per hit, as without the bump.
    assert_eq!(counters.texture_points, plain_counters.texture_points);
    assert_eq!(counters.non_finite, 0);
}

#[test]
fn a_bump_shares_the_compiled_tape_of_its_graph() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(MARBLE, dir.path().join("marble.ron")).unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(
        &path,
        with(
            r#"        "m": Material(diffuse: Texture(graph: "marble.ron", output: "colour"), bump: (height: Texture(graph: "marble.ron", output: "vein"))),
        "n": Material(bump: (height: "marble.ron.vein", strength: -2)),"#,
            r#"        Object(shape: Sphere(), material: "m"),
        Object(shape: Sphere(), material: "n", transform: [Translate(2, 0, 0)]),"#,
        ),
    )
    .unwrap();
    let scene = load_scene(&path).unwrap();
    // One graph, one tape: the colour and the height's gradient (not the height itself).
    assert_eq!(scene.textures().len(), 1);
    assert_eq!(scene.textures()[0].outputs, ["colour", "∇vein"]);
    assert_eq!(scene.textures()[0].tape.outputs().len(), 2);
    let (_, stats) = render(&scene, &small(1)).unwrap();
    assert!(stats.counters.texture_points > 0);
}

/// The rendered error of a scene with the materials `materials` (on spheres named "a" to "h"),
/// next to the marble graph and a graph whose scalar output `slope` uses a noise gradient.
fn bump_error(materials: &str) -> String {
    let objects: String = materials
        .lines()
        .filter_map(|l| l.trim().strip_prefix('"')?.split_once('"'))
        .map(|(name, _)| format!("        Object(shape: Sphere(), material: \"{name}\"),\n"))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    std::fs::copy(MARBLE, dir.path().join("marble.ron")).unwrap();
    std::fs::write(
        dir.path().join("slope.ron"),
        r#"Graph(
    nodes: { "h": Fbm(input: Position, basis: Perlin, octaves: 4), "slope": Length(Gradient(of: "h")) },
    outputs: { "slope": "slope" },
)"#,
    )
    .unwrap();
    let path = dir.path().join("scene.ron");
    std::fs::write(&path, with(materials, objects.trim_end())).unwrap();
    let error = load_scene(&path).expect_err("the scene is invalid");
    assert_eq!(error.exit_code(), 1);
    error
        .render(false)
        .replace(&dir.path().display().to_string(), "DIR")
}

#[test]
fn bump_problems_are_located_in_the_scene() {
    let message = bump_error(
        r#"        "a": Material(bump: (height: "marble.ron.veins")),
        "b": Material(bump: (height: Texture(graph: "marble.ron", output: "colour"))),
        "c": Material(bump: (height: "nowhere.ron.h")),
        "d": Material(bump: (height: "marble.ron.vein", strength: inf)),
        "e": Material(bump: (height: "slope.ron.slope")),
        "f": Material(bump: (height: "marble")),
        "g": Material(bump: (height: Textur(graph: "marble.ron"))),
        "h": Material(bump: (height: Texture(graph: "marble.ron", set: { "octave": 2 }, transform: [Scale(0)])))"#,
    );
    for expected in [
        "error[unknown-output]: DIR/scene.ron:5:38: material \"a\": `bump`: the graph DIR/marble.ron has no output \"veins\"",
        "did you mean \"vein\"? Its outputs are: colour, vein",
        "error[type]: DIR/scene.ron:6:75: material \"b\": `bump`: a height is a number, and output \"colour\" is a vec3",
        "error[unknown-reference]: DIR/scene.ron:7:38: material \"c\": cannot read the graph file DIR/nowhere.ron",
        "`height: \"FILE.OUTPUT\"` is split at the last dot",
        "error[bad-parameter]: DIR/scene.ron:8:67: material \"d\": `bump`: `strength` is inf; it must be finite",
        "error[not-differentiable]: DIR/scene.ron:9:38: material \"e\": `bump`: the graph DIR/slope.ron: output `slope` uses a noise gradient",
        "error[bad-parameter]: DIR/scene.ron:10:38: material \"f\": `bump`: `height` is \"marble\"; it must name a graph file and its output",
        "error[unknown-kind]: DIR/scene.ron:11:38: material \"g\": `bump`: `height` is `Textur(...)`",
        "error[bad-parameter]: DIR/scene.ron:12:101: material \"h\": `bump`: Scale: every factor must be finite and not zero",
        "error[unknown-param]: DIR/scene.ron:12:74: material \"h\": `bump`: the graph DIR/marble.ron has no param \"octave\"",
    ] {
        assert!(message.contains(expected), "missing {expected:?} in:\n{message}");
    }
    // A height that is not a string or a struct, and a bump without a height: the reader's.
    let message = bump_error(r#"        "a": Material(bump: (height: 3)),"#);
    assert!(
        message.contains("error[type]: DIR/scene.ron:5:39:") && message.contains("FILE.OUTPUT"),
        "{message}"
    );
    let message = bump_error(r#"        "a": Material(bump: (strength: 2)),"#);
    assert!(
        message.contains("error[missing-argument]") && message.contains("height"),
        "{message}"
    );
}

#[test]
fn a_bare_graph_is_bumped_by_its_scalar_output() {
    let plain = Scene::from_graph_default(
        Path::new("graphs/stone.ron"),
        &PreviewDefaults {
            overrides: vec![("octaves".into(), 3.0)],
            ..PreviewDefaults::default()
        },
    )
    .unwrap();
    let bumped = |output: &str, strength: f64| {
        Scene::from_graph_default(
            Path::new("graphs/stone.ron"),
            &PreviewDefaults {
                overrides: vec![("octaves".into(), 3.0)],
                bump: Some(render::PreviewBump {
                    output: output.into(),
                    strength,
                }),
                ..PreviewDefaults::default()
            },
        )
    };
    let scene = bumped("stone", 0.2).unwrap();
    assert_eq!(
        scene.textures().len(),
        1,
        "the colour and the bump share a tape"
    );
    assert_eq!(scene.textures()[0].outputs, ["colour", "∇stone"]);
    let a = render(&plain, &small(1)).unwrap().0;
    let b = render(&scene, &small(1)).unwrap().0;
    assert!(max_difference(&a, &b) > 0.05);
    let zero = render(&bumped("stone", 0.0).unwrap(), &small(1)).unwrap().0;
    assert!(a.pixels == zero.pixels);
    let message = bumped("colour", 1.0).unwrap_err().to_string();
    assert!(message.contains("output \"colour\" is a vec3"), "{message}");
    let message = bumped("nope", 1.0).unwrap_err().to_string();
    assert!(message.contains("has no output \"nope\""), "{message}");
}

/// Runs the texgraph binary in the crate root: (exit code, stderr).
fn texgraph(args: &[&str]) -> (i32, String) {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_texgraph"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("NO_COLOR", "1")
        .output()
        .expect("run texgraph");
    (
        output.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

#[test]
fn render_bump_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let png = |name: &str| dir.path().join(name).display().to_string();
    let stone = "graphs/stone.ron";
    let base = [
        "render",
        stone,
        "--size",
        "40,30",
        "--samples",
        "1",
        "--set",
        "octaves=2",
        "-q",
    ];
    let run = |extra: &[&str], out: &str| {
        let mut args: Vec<&str> = base.to_vec();
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out]);
        texgraph(&args)
    };
    let pixels = |path: &str| common::Png::open(Path::new(path)).unwrap().rgb8();
    assert_eq!(run(&[], &png("plain.png")).0, 0);
    let (code, err) = run(&["--bump", "stone"], &png("bumped.png"));
    assert_eq!(code, 0, "{err}");
    assert_ne!(pixels(&png("plain.png")), pixels(&png("bumped.png")));
    // Negative strengths are numbers, not flags; strength 0 is the plain image.
    let (code, err) = run(
        &["--bump", "stone", "--bump-strength", "-0.5"],
        &png("neg.png"),
    );
    assert_eq!(code, 0, "{err}");
    assert_ne!(pixels(&png("neg.png")), pixels(&png("bumped.png")));
    let (code, err) = run(
        &["--bump", "stone", "--bump-strength", "0"],
        &png("zero.png"),
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(pixels(&png("plain.png")), pixels(&png("zero.png")));
    // Usage errors: exit 2.
    for (extra, message) in [
        (vec!["--bump-strength", "2"], "--bump <OUTPUT>"),
        (vec!["--bump", "stone", "--bump-strength", "inf"], "finite"),
        (vec!["--bump", "stone", "--bump-strength", "x"], "finite"),
    ] {
        let (code, err) = run(&extra, &png("x.png"));
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(err.contains(message), "{extra:?}: {err}");
    }
    // A height that is not a scalar output of the graph: exit 1, as for --output.
    let (code, err) = run(&["--bump", "colour"], &png("x.png"));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("output \"colour\" is a vec3"), "{err}");
    let (code, err) = run(&["--bump", "nope"], &png("x.png"));
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("has no output \"nope\""), "{err}");
    assert!(err.contains("its outputs are: colour, stone"), "{err}");
    assert!(!dir.path().join("x.png").exists());
    // Scene files set their own bumps, for render and watch alike; the timing table has none.
    for command in ["render", "watch"] {
        for extra in [
            vec!["--bump", "vein"],
            vec!["--bump", "vein", "--bump-strength", "2"],
        ] {
            let mut args = vec![command, "graphs/scenes/seed003_sphere.ron", "-o"];
            let out = png("scene.png");
            args.push(&out);
            args.extend_from_slice(&extra);
            let (code, err) = texgraph(&args);
            assert_eq!(code, 2, "{args:?}: {err}");
            assert!(err.contains("--bump"), "{err}");
            assert!(err.contains("to graph files only"), "{err}");
        }
    }
    let (code, err) = texgraph(&["render", "--timing-table", "--bump", "vein"]);
    assert_eq!(code, 2, "{err}");
}

/// `watch` follows imports: the files a graph imports (directly or not) are watched, a broken
/// imported file keeps the last good image with the problem located in that file, and fixing it
/// renders the new look.
#[test]
fn watch_follows_the_files_a_graph_imports() {
    let dir = tempfile::tempdir().unwrap();
    let leaf = dir.path().join("leaf.ron");
    let mid = dir.path().join("mid.ron");
    let top = dir.path().join("top.ron");
    let out = dir.path().join("out.png");
    std::fs::write(
        &leaf,
        r#"Graph(outputs: { "colour": Combine(0.9, 0.2, 0.1) })"#,
    )
    .unwrap();
    std::fs::write(
        &mid,
        r#"Graph(outputs: { "colour": Import(file: "leaf.ron", output: "colour") })"#,
    )
    .unwrap();
    std::fs::write(
        &top,
        r#"Graph(outputs: { "colour": Import(file: "mid.ron", output: "colour") })"#,
    )
    .unwrap();
    let mut previewer = Previewer::new(&top, PreviewDefaults::default(), small(1), &out);
    previewer.reload().expect("renders");
    let red = previewer.image().unwrap().clone();
    for f in [&top, &mid, &leaf] {
        assert!(
            previewer
                .watched_files()
                .iter()
                .any(|w| w.ends_with(f.file_name().unwrap())),
            "{} is not watched: {:?}",
            f.display(),
            previewer.watched_files()
        );
    }
    // Broken two imports down: located in leaf.ron, with the chain; the red image stays.
    std::fs::write(&leaf, r#"Graph(outputs: { "colour": Combine(0.1, 0.2) })"#).unwrap();
    let message = previewer.reload().unwrap_err().to_string();
    assert!(message.contains("leaf.ron:1:"), "{message}");
    assert!(message.contains("imported from"), "{message}");
    assert_eq!(previewer.image(), Some(&red));
    // Fixed to blue: the new look renders.
    std::fs::write(
        &leaf,
        r#"Graph(outputs: { "colour": Combine(0.1, 0.2, 0.9) })"#,
    )
    .unwrap();
    previewer.reload().expect("renders again");
    assert_ne!(previewer.image(), Some(&red));
}

/// Level of detail per pixel (issue 18): on the horizon scene at one sample per pixel, the
/// render with it is closer to a many-sample reference without it than the render without it
/// (the fine octaves alias into noise where a pixel covers metres; level of detail puts their
/// mean there instead). Box filtering (issue 33) closer still.
#[test]
fn level_of_detail_brings_the_horizon_closer_to_its_reference() {
    let scene =
        load_scene(Path::new("graphs/scenes/horizon.ron")).unwrap_or_else(|e| panic!("{e}"));
    let comparison = render::lod_figures::LodComparison {
        size: (120, 68),
        reference_samples: 64,
        runs: 1,
        threads: None,
        bias: 0.0,
    };
    let figures = render::lod_figures::compare_lod(&scene, &comparison).unwrap();
    assert!(
        figures.rms_lod <= 0.7 * figures.rms_plain,
        "RMS error with LOD {} vs without {}",
        figures.rms_lod,
        figures.rms_plain
    );
    // Box filtering (issue 33's render goal): one filtered sample per pixel is as close to
    // the reference as four point samples with level of detail, and closer than one.
    assert!(
        figures.rms_filtered <= figures.rms_four && figures.rms_filtered < figures.rms_lod,
        "RMS error box-filtered {} vs 4 point samples {} vs 1 point sample with LOD {}",
        figures.rms_filtered,
        figures.rms_four,
        figures.rms_lod
    );
    // The bias moves the trade-off: far finer footprints bring the aliasing back.
    let sharp = render::lod_figures::compare_lod(
        &scene,
        &render::lod_figures::LodComparison {
            bias: -RenderLod::MAX_BIAS,
            ..comparison
        },
    )
    .unwrap();
    assert!(sharp.rms_lod > figures.rms_lod, "{sharp:?} vs {figures:?}");
}

/// Where every pixel resolves every octave (a 2-octave marble on the preview's plane, seen at
/// a steep angle, no silhouette), level of detail changes nothing, bit for bit; the bias is
/// checked.
#[test]
fn level_of_detail_keeps_every_octave_a_pixel_resolves() {
    let defaults = PreviewDefaults {
        object: PreviewObject::Plane,
        overrides: vec![("octaves".into(), 2.0)],
        ..PreviewDefaults::default()
    };
    let scene = Scene::from_graph_default(Path::new(MARBLE), &defaults).unwrap();
    let (plain, _) = render(&scene, &small(1)).unwrap();
    let with = RenderOptions {
        lod: RenderLod::default(),
        ..small(1)
    };
    let (lod, _) = render(&scene, &with).unwrap();
    assert!(
        plain == lod,
        "max difference {}",
        max_difference(&plain, &lod)
    );
    // Eight octaves blur: the sphere's pixels cover the finest ones.
    let defaults = PreviewDefaults {
        overrides: vec![("octaves".into(), 8.0)],
        ..PreviewDefaults::default()
    };
    let scene = Scene::from_graph_default(Path::new(MARBLE), &defaults).unwrap();
    assert!(render(&scene, &small(1)).unwrap().0 != render(&scene, &with).unwrap().0);
    for bias in [f64::NAN, 16.5, -1e9] {
        let options = RenderOptions {
            lod: RenderLod::On { bias },
            ..small(1)
        };
        let error = render(&scene, &options).expect_err("refused");
        assert_eq!(error.exit_code(), 2, "{error}");
    }
}
