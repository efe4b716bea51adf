//! Exported GLSL ES 3.00 run in WebGL 2 in headless Chromium (issue 35): the shared browser
//! of `serve_browser` (ANGLE over SwiftShader without a GPU) renders 4096 points into float
//! render targets, one texel a point, through a fragment shader that calls every exported
//! `_lod` (or `_filtered`) function; the texels read back meet the shader contract against the
//! CPU (`shader::shader_contract`, the same bound as the lavapipe runs; for the filtered forms
//! `shader::filtered_contract`).

use crate::common;
use crate::gltf_clients::serve_folders;
use crate::serve_browser::{browser_installed, Browser};
use crate::shader::{exported, run_of, selected, tape_of, Tally};
use crate::shader_run::{self, Call};
use serde_json::{json, Value};
use std::time::{Duration, Instant};
use texgraph::shader::{ExportedFunction, Lang};

/// The points' texture is `SIDE` × `SIDE` texels: 4096 points.
const SIDE: usize = 64;

/// What `cargo test` runs in the browser (`TEXGRAPH_FULL=1`: every graph): cellular,
/// simplex, Perlin, Value and white noise, a fractal with its octave fade, tiling, sines (the
/// exported sin and cos are written out: SwiftShader's are off by 1e-4), a vec3 colour output
/// and a graph of several outputs, chosen among the graphs SwiftShader compiles in a few
/// seconds (every graph: 300 s). The seed 003 marble (8 s) left the set when the test loop was
/// cut to five minutes (issue 46): its forms are the others', and
/// [`the_webgl2_page_shades_a_sphere_with_an_export`] draws it.
const WEBGL_SET: &[&str] = &[
    "cells",
    "tiling_marble",
    "seed000_wood",
    "seed002_noise",
    "seed002_sine",
    "seed002_smooth_noise",
    "seed004_checker3d",
    "seed004_wood_grain",
];

/// The graphs whose `_filtered` forms `cargo test` runs in the browser (`TEXGRAPH_FULL=1`:
/// every graph): a periodic chain (its shapes' data in a constant array). SwiftShader inlines
/// every call, so a filtered shader compiles slowly: 11 s for this one, 12 s for the seed 002
/// noise, 33 s for `cells`, 554 s for the seed 003 marble's (docs/shaders.md). Noise through
/// a ramp left the set when the test loop was cut to five minutes (issue 46): its values are
/// held to the CPU's in GLSL by `shader::exported_glsl_filtered_matches_the_cpu`, and
/// [`the_webgl2_page_shades_a_sphere_with_an_export`] draws it in the browser.
const WEBGL_FILTERED_SET: &[&str] = &["seed004_stripes"];

/// The page's script: compiles `fragment` with a full-screen triangle, uploads the points
/// (`arguments[1]`: f32 bit patterns, 4 or 12 per point) as an RGBA32F texture of `side`
/// columns and `side` rows per 4 floats (texel (x, y + k · side) holds floats 4k to 4k + 3 of
/// point y · side + x),
/// draws into `arguments[2]` RGBA32F colour attachments and returns each attachment's texels
/// as f32 bit patterns (exact through JSON, NaN and infinities included), or the compiler's log.
const RUN: &str = r#"
const [fragment, bits, targets, side, blocks] = arguments;
const canvas = document.createElement('canvas');
canvas.width = side;
canvas.height = side;
const gl = canvas.getContext('webgl2', { antialias: false });
if (!gl) return { error: 'no WebGL 2 context' };
try {
    if (!gl.getExtension('EXT_color_buffer_float')) return { error: 'no EXT_color_buffer_float' };
    const info = gl.getExtension('WEBGL_debug_renderer_info');
    const renderer = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
    const shader = (type, text) => {
        const s = gl.createShader(type);
        gl.shaderSource(s, text);
        gl.compileShader(s);
        if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
        return s;
    };
    const program = gl.createProgram();
    gl.attachShader(program, shader(gl.VERTEX_SHADER, `#version 300 es
void main() { gl_Position = vec4(float(gl_VertexID % 2) * 4.0 - 1.0, float(gl_VertexID / 2) * 4.0 - 1.0, 0.0, 1.0); }`));
    gl.attachShader(program, shader(gl.FRAGMENT_SHADER, fragment));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(program));
    gl.useProgram(program);
    const points = gl.createTexture();
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, points);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
    // The points' floats regrouped: block k of each point in rows k · side to (k + 1) · side.
    const floats = new Float32Array(new Uint32Array(bits).buffer);
    const stride = 4 * blocks;
    const texels = new Float32Array(side * side * stride);
    for (let i = 0; i < side * side; i++) {
        for (let k = 0; k < blocks; k++) {
            texels.set(floats.subarray(i * stride + 4 * k, i * stride + 4 * k + 4),
                       (k * side * side + i) * 4);
        }
    }
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, side, side * blocks, 0, gl.RGBA, gl.FLOAT, texels);
    gl.uniform1i(gl.getUniformLocation(program, 'tg_points'), 0);
    const framebuffer = gl.createFramebuffer();
    gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
    const attachments = [];
    for (let t = 0; t < targets; t++) {
        const texture = gl.createTexture();
        gl.bindTexture(gl.TEXTURE_2D, texture);
        gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, side, side);
        gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0 + t, gl.TEXTURE_2D, texture, 0);
        attachments.push(gl.COLOR_ATTACHMENT0 + t);
    }
    gl.drawBuffers(attachments);
    if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) {
        return { error: 'the float render targets are not complete' };
    }
    gl.bindTexture(gl.TEXTURE_2D, points);
    gl.viewport(0, 0, side, side);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
    const out = [];
    for (let t = 0; t < targets; t++) {
        const texels = new Float32Array(side * side * 4);
        gl.readBuffer(gl.COLOR_ATTACHMENT0 + t);
        gl.readPixels(0, 0, side, side, gl.RGBA, gl.FLOAT, texels);
        out.push(Array.from(new Uint32Array(texels.buffer)));
    }
    const error = gl.getError();
    if (error !== gl.NO_ERROR) return { error: 'WebGL error ' + error };
    return { renderer, targets: out };
} catch (e) {
    return { error: String(e.message || e) };
} finally {
    const lose = gl.getExtension('WEBGL_lose_context');
    if (lose) lose.loseContext();
}
"#;

/// The fragment shader around exported GLSL ES: the point at this texel (texel (x, y) is point
/// `y · SIDE + x`), every function's `call` form at it, channel `c` written to attachment
/// `c / 4`, component `c % 4`.
fn fragment(exported: &str, functions: &[ExportedFunction], call: Call) -> (String, usize) {
    let channels: usize = functions.iter().map(|f| f.channels).sum();
    let targets = channels.div_ceil(4).max(1);
    let mut body = format!("    float v[{}];\n", targets * 4);
    for k in 0..targets * 4 {
        body.push_str(&format!("    v[{k}] = 0.0;\n"));
    }
    body.push_str(&shader_run::assignments(functions, call, "vec3", |c| {
        format!("v[{c}]")
    }));
    let mut outs = String::new();
    for t in 0..targets {
        outs.push_str(&format!(
            "layout(location = {t}) out highp vec4 tg_out{t};\n"
        ));
        body.push_str(&format!(
            "    tg_out{t} = vec4(v[{}], v[{}], v[{}], v[{}]);\n",
            4 * t,
            4 * t + 1,
            4 * t + 2,
            4 * t + 3
        ));
    }
    // The point's three blocks of four floats (x, y, z, spacing or the footprint's edges).
    let text = format!(
        "#version 300 es\n{exported}\nuniform highp sampler2D tg_points;\n{outs}\
         void main() {{\n    ivec2 at = ivec2(gl_FragCoord.xy);\n\
         \x20   vec4 q = texelFetch(tg_points, at, 0);\n\
         \x20   vec3 p = q.xyz;\n    float h = q.w;\n\
         \x20   vec4 q1 = {q1};\n    vec4 q2 = {q2};\n\
         \x20   mat3 fp = mat3(vec3(q.w, q1.xy), vec3(q1.zw, q2.x), q2.yzw);\n{body}}}\n",
        q1 = fetch(call, 1),
        q2 = fetch(call, 2),
    );
    (text, targets)
}

/// The fragment shader's read of block `k` of its point's floats (zeros for a 4-float input).
fn fetch(call: Call, k: usize) -> String {
    if call.stride() > 4 * k {
        format!("texelFetch(tg_points, at + ivec2(0, {}), 0)", k * SIDE)
    } else {
        "vec4(0.0)".to_string()
    }
}

/// Runs `call`'s form of each graph's exported GLSL ES (the graphs of `set`, or all with
/// `TEXGRAPH_FULL=1`) in the browser at [`run_of`]'s points, held to its contract.
async fn every_graph_in_webgl2(test: &str, set: &[&str], call: Call) {
    if !browser_installed(test) {
        return;
    }
    let (input, contract) = run_of(call);
    let bits: Vec<u32> = input.iter().map(|v| v.to_bits()).collect();
    let browser = Browser::blank(Duration::from_secs(600)).await;
    let (mut tally, mut renderer) = (Tally::default(), String::new());
    for path in common::graph_files() {
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        if !selected(&stem, set) {
            continue;
        }
        let tape = tape_of(&path, &[]);
        let e = exported(&tape, Lang::GlslEs);
        let (text, targets) = fragment(&e.source, &e.functions, call);
        let started = Instant::now();
        let blocks = call.stride() / 4;
        let args = [
            json!(text),
            json!(bits),
            json!(targets),
            json!(SIDE),
            json!(blocks),
        ];
        let answer = browser.run(RUN, args.to_vec()).await;
        eprintln!("{stem}: {:.2} s", started.elapsed().as_secs_f64());
        let result = read_back(&answer, tape.channels()).and_then(|(name, out)| {
            renderer = name;
            contract(&tape, &out)
        });
        tally.record(&stem, result);
    }
    browser.close().await;
    tally.finish(test, &renderer);
}

/// Each graph's exported GLSL ES `_lod` functions in WebGL 2 (spacing 0, the point form's
/// value, at every other point) against the CPU at 4096 points of the unit cube.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn exported_glsl_es_matches_the_cpu_in_webgl2() {
    let test = "exported_glsl_es_matches_the_cpu_in_webgl2";
    every_graph_in_webgl2(test, WEBGL_SET, Call::Lod).await;
}

/// The `_filtered` functions in WebGL 2 at 4096 points of the unit cube with footprints from
/// a point to half the cube, against the CPU's filtered estimates.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn exported_filtered_glsl_es_matches_the_cpu_in_webgl2() {
    let test = "exported_filtered_glsl_es_matches_the_cpu_in_webgl2";
    every_graph_in_webgl2(test, WEBGL_FILTERED_SET, Call::Filtered).await;
}

/// The script's answer as channel-planar values (channel `c` of point `i` at `c · n + i`) and
/// the renderer's name, or the page's error.
fn read_back(answer: &Value, channels: usize) -> Result<(String, Vec<f32>), String> {
    if let Some(error) = answer["error"].as_str() {
        return Err(format!("in the browser: {error}"));
    }
    let targets = answer["targets"]
        .as_array()
        .ok_or_else(|| format!("the page returned {answer}"))?;
    let n = SIDE * SIDE;
    let mut out = vec![0f32; channels * n];
    for c in 0..channels {
        let texels = targets[c / 4]
            .as_array()
            .ok_or("an attachment is missing")?;
        for i in 0..n {
            let bits = texels[4 * i + c % 4]
                .as_u64()
                .ok_or("a texel is not a number")?;
            out[c * n + i] = f32::from_bits(bits as u32);
        }
    }
    let renderer = answer["renderer"].as_str().unwrap_or("?").to_string();
    Ok((renderer, out))
}

/// The page's canvas read back: its size, how many distinct colours a sample of its pixels
/// has, and the colours at its centre (the sphere) and a corner (the background).
const CANVAS: &str = r#"
const c = document.getElementById('view');
const g = document.createElement('canvas');
g.width = c.width;
g.height = c.height;
const x = g.getContext('2d');
x.drawImage(c, 0, 0);
const d = x.getImageData(0, 0, g.width, g.height).data;
const at = (i, j) => { const k = 4 * (j * g.width + i); return [d[k], d[k + 1], d[k + 2]]; };
const seen = new Set();
for (let k = 0; k < d.length && seen.size < 64; k += 4 * 7) seen.add(d[k] << 16 | d[k + 1] << 8 | d[k + 2]);
return { w: g.width, h: g.height, distinct: seen.size, centre: at(g.width >> 1, g.height >> 1), corner: at(1, 1) };
"#;

/// The engine template `examples/shader/webgl2.html` itself, served with exported GLSL ES
/// beside it: it compiles, draws the sphere (textured: many colours, the centre unlike the
/// background) and says so, with the seed 003 marble's colour at its level of detail and a
/// plain noise's colour filtered over each pixel's footprint (the marble's filtered shader
/// takes SwiftShader minutes to compile).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_webgl2_page_shades_a_sphere_with_an_export() {
    if !browser_installed("the_webgl2_page_shades_a_sphere_with_an_export") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let root = common::crate_root();
    std::fs::copy(
        root.join("examples/shader/webgl2.html"),
        dir.path().join("webgl2.html"),
    )
    .unwrap();
    let pages = [("seed003_marble", "lod"), ("seed002_noise", "filtered")];
    for (graph, _) in pages {
        let tape = tape_of(&root.join(format!("graphs/{graph}.ron")), &[]);
        let source = exported(&tape, Lang::GlslEs).source;
        std::fs::write(dir.path().join(format!("{graph}.glsl")), source).unwrap();
    }
    let server = serve_folders(vec![dir.path().to_path_buf()]);
    let browser = Browser::blank(Duration::from_secs(60)).await;
    for (graph, form) in pages {
        let url = server.url(&format!(
            "webgl2.html?fn=texgraph_colour&src={graph}.glsl&form={form}&still=1&size=160"
        ));
        browser.goto(&url).await;
        let status = browser
            .text_when("the page's frame", "#status", |t| {
                t.contains("drawn") || t.starts_with("error")
            })
            .await;
        assert_eq!(
            status,
            format!("texgraph_colour ({form}) from {graph}.glsl: drawn"),
            "{url}"
        );
        let canvas = browser.run(CANVAS, vec![]).await;
        eprintln!("{graph} ({form}): {canvas}");
        assert_eq!(
            (canvas["w"].as_u64(), canvas["h"].as_u64()),
            (Some(160), Some(160))
        );
        assert!(
            canvas["distinct"].as_u64().unwrap_or(0) >= 16,
            "{url}: {canvas}"
        );
        assert_ne!(canvas["centre"], canvas["corner"], "{url}: no sphere");
    }
    browser.close().await;
}
