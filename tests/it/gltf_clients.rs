//! Independent clients for every GLB the tests write (`bake --gltf`): the Khronos glTF
//! validator and three.js's GLTFLoader, both from npm (`tests/js/package.json`, exact versions
//! in `tests/js/package-lock.json`, installed by `npm ci` into the git-ignored
//! `tests/js/node_modules/`).
//!
//! - [`validate_glb`]: `node tests/js/validate.mjs FILE.glb`, the validator's report as JSON;
//!   [`assert_valid_glb`] fails the test on any error, naming each.
//! - [`draw_glb`]: three.js draws the GLB once (`tests/js/draw.html`: a fixed camera on the
//!   bounding box's centre from +z, a hemisphere light and a sun, a magenta background) into a
//!   256×256 WebGL canvas in the shared headless Chromium of `serve_browser` (ANGLE over
//!   SwiftShader without a GPU); [`Drawn`] holds the pixels and what GLTFLoader made of each
//!   material.
//!
//! A test calls [`clients_ready`] first: without Node.js, npm, an installable `node_modules` or
//! the browser it says SKIPPED and passes, unless `TEXGRAPH_REQUIRE_BROWSER=1` (CI sets it):
//! then it fails.

use crate::common;
use crate::serve_browser::{browser_installed, poll, Browser};
use base64::Engine as _;
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};

/// The npm package of the clients: `validate.mjs`, `draw.html`, `draw.mjs`, `node_modules/`.
fn js_dir() -> PathBuf {
    common::crate_root().join("tests/js")
}

/// Whether the clients can run: the browser of `serve_browser` (chromium, chromedriver),
/// `node`, and `tests/js/node_modules` as `package-lock.json` pins it (installed by `npm ci`
/// once per test process, under a file lock, when it is not: then `npm` too). If not, says
/// SKIPPED (or fails under `TEXGRAPH_REQUIRE_BROWSER=1`).
pub(crate) fn clients_ready(test: &str) -> bool {
    if !browser_installed(test) {
        return false;
    }
    static INSTALLED: OnceLock<Result<(), String>> = OnceLock::new();
    let Err(reason) = INSTALLED.get_or_init(install) else {
        return true;
    };
    if std::env::var("TEXGRAPH_REQUIRE_BROWSER").is_ok_and(|v| v == "1") {
        panic!("{test}: TEXGRAPH_REQUIRE_BROWSER=1 but the glTF clients cannot run: {reason}");
    }
    eprintln!("SKIPPED: {test}: the glTF clients cannot run: {reason}");
    false
}

/// `COMMAND --version`, or why it did not run.
fn version_of(command: &str) -> Result<String, String> {
    let out = Command::new(command)
        .arg("--version")
        .output()
        .map_err(|e| format!("`{command}` not found ({e}; Debian packages nodejs, npm)"))?;
    if !out.status.success() {
        return Err(format!("`{command} --version` failed: {}", out.status));
    }
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// Whether `node_modules` holds every package at the version `package-lock.json` pins.
fn installed_as_locked(js: &Path) -> Result<(), String> {
    let read = |path: &Path| -> Result<Value, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
    };
    let lock = read(&js.join("package-lock.json"))?;
    let packages = lock["packages"]
        .as_object()
        .ok_or("package-lock.json has no packages")?;
    for (key, entry) in packages.iter().filter(|(key, _)| !key.is_empty()) {
        let want = &entry["version"];
        let have = read(&js.join(key).join("package.json"))?["version"].clone();
        if &have != want {
            return Err(format!("{key} is {have}, package-lock.json pins {want}"));
        }
    }
    Ok(())
}

/// Makes `tests/js/node_modules` what `package-lock.json` pins, with `npm ci` if it is not.
fn install() -> Result<(), String> {
    let node = version_of("node")?;
    let js = js_dir();
    if installed_as_locked(&js).is_ok() {
        return Ok(());
    }
    version_of("npm")?;
    // One install at a time among test processes (`npm ci` first deletes node_modules).
    let lock_path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("npm-ci.lock");
    let lock =
        std::fs::File::create(&lock_path).map_err(|e| format!("{}: {e}", lock_path.display()))?;
    lock.lock()
        .map_err(|e| format!("locking {}: {e}", lock_path.display()))?;
    if installed_as_locked(&js).is_ok() {
        return Ok(());
    }
    let started = Instant::now();
    let out = Command::new("npm")
        .args(["ci", "--prefix"])
        .arg(&js)
        .args(["--no-audit", "--no-fund"])
        .output()
        .map_err(|e| format!("npm ci: {e}"))?;
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(12).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        return Err(format!(
            "`npm ci --prefix tests/js` failed ({}):\n{}",
            out.status,
            tail.join("\n")
        ));
    }
    eprintln!(
        "gltf_clients: npm ci --prefix tests/js in {:.1} s (node {node})",
        started.elapsed().as_secs_f64()
    );
    installed_as_locked(&js).map_err(|e| format!("after npm ci: {e}"))
}

/// The Khronos validator's report on `path` (a GLB or glTF file), as `validate.mjs` prints it:
/// `issues.numErrors`, `numWarnings`, `issues.messages` (each with `code`, `message`,
/// `severity`: 0 error, 1 warning, 2 info, 3 hint, and a `pointer` into the JSON or a byte
/// `offset`) and `info`. Panics only when the validator could not run or refused the file as
/// neither glTF nor GLB; call [`clients_ready`] first.
pub(crate) fn validate_glb(path: &Path) -> Value {
    let out = Command::new("node")
        .arg(js_dir().join("validate.mjs"))
        .arg(path)
        .output()
        .unwrap_or_else(|e| panic!("node tests/js/validate.mjs: {e}"));
    let code = out.status.code();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        matches!(code, Some(0 | 1)),
        "the glTF validator on {} exited with {}: {stderr}",
        path.display(),
        out.status
    );
    let report: Value = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "the glTF validator's report on {} is not JSON ({e}): {}",
            path.display(),
            String::from_utf8_lossy(&out.stdout)
        )
    });
    assert_eq!(
        code == Some(0),
        report["issues"]["numErrors"] == 0,
        "exit status {code:?}, report {report}"
    );
    report
}

/// The report's messages at `severity` or worse (0 errors, 1 warnings, 2 infos, 3 hints), one
/// line each: `CODE at POINTER: message`.
pub(crate) fn issues(report: &Value, severity: u64) -> Vec<String> {
    let messages = report["issues"]["messages"].as_array();
    messages
        .into_iter()
        .flatten()
        .filter(|m| m["severity"].as_u64().is_some_and(|s| s <= severity))
        .map(|m| {
            let at = match (&m["pointer"], &m["offset"]) {
                (Value::String(p), _) => p.clone(),
                (_, Value::Number(o)) => format!("byte {o}"),
                _ => "-".to_string(),
            };
            let code = m["code"].as_str().unwrap_or("?");
            format!("{code} at {at}: {}", m["message"].as_str().unwrap_or(""))
        })
        .collect()
}

/// [`validate_glb`], failing the test with every error of the report (warnings are printed).
pub(crate) fn assert_valid_glb(path: &Path) -> Value {
    valid_glb(path).unwrap_or_else(|e| panic!("{e}"))
}

/// [`validate_glb`]'s report, or every error in it.
fn valid_glb(path: &Path) -> Result<Value, String> {
    let report = validate_glb(path);
    let errors = issues(&report, 0);
    if !errors.is_empty() {
        return Err(format!(
            "the glTF validator finds {} error(s) in {}:\n{}",
            errors.len(),
            path.display(),
            errors.join("\n")
        ));
    }
    for warning in issues(&report, 1) {
        eprintln!("{}: validator warning: {warning}", path.display());
    }
    Ok(report)
}

/// What three.js drew of a GLB: `width` × `height` RGBA pixels, rows top to bottom.
#[derive(Debug, Clone)]
pub(crate) struct Drawn {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) rgba: Vec<u8>,
    /// The page's background colour, where nothing was drawn.
    pub(crate) background: [u8; 3],
    /// What GLTFLoader made of the model (`draw.mjs`): `meshes`, `triangles`, `calls`,
    /// `textures`, `box` (`min`, `max`) and `materials`, each with its `type`
    /// (`MeshStandardMaterial`), `metalness`, `roughness` and its `map`, `normalMap`,
    /// `metalnessMap`, `roughnessMap` (null or `{width, height, colorSpace, channel}`).
    pub(crate) scene: Value,
    /// The WebGL renderer (SwiftShader's name without a GPU).
    pub(crate) renderer: String,
}

impl Drawn {
    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub(crate) fn pixel(&self, x: usize, y: usize) -> [u8; 4] {
        assert!(x < self.width && y < self.height, "({x}, {y}) is outside");
        let i = 4 * (y * self.width + x);
        self.rgba[i..i + 4].try_into().unwrap()
    }

    /// Whether the pixel is the background (each channel within 2: nothing drawn there).
    pub(crate) fn is_background(&self, x: usize, y: usize) -> bool {
        let p = self.pixel(x, y);
        (0..3).all(|c| p[c].abs_diff(self.background[c]) <= 2)
    }

    /// The pixels where something was drawn, `(x, y, rgba)`, row by row.
    pub(crate) fn drawn_pixels(&self) -> impl Iterator<Item = (usize, usize, [u8; 4])> + '_ {
        (0..self.height)
            .flat_map(move |y| (0..self.width).map(move |x| (x, y)))
            .filter(|&(x, y)| !self.is_background(x, y))
            .map(|(x, y)| (x, y, self.pixel(x, y)))
    }

    /// The share of the canvas where something was drawn, in [0, 1].
    pub(crate) fn coverage(&self) -> f64 {
        self.drawn_pixels().count() as f64 / (self.width * self.height) as f64
    }

    /// The smallest box holding every drawn pixel: `(x0, y0, x1, y1)`, inclusive; None when
    /// nothing was drawn.
    pub(crate) fn drawn_box(&self) -> Option<(usize, usize, usize, usize)> {
        self.drawn_pixels().fold(None, |b, (x, y, _)| {
            let (x0, y0, x1, y1) = b.unwrap_or((x, y, x, y));
            Some((x0.min(x), y0.min(y), x1.max(x), y1.max(y)))
        })
    }

    /// Writes the picture as a PNG (to look at when a test fails).
    pub(crate) fn save_png(&self, path: &Path) {
        let file = std::fs::File::create(path).unwrap_or_else(|e| panic!("{path:?}: {e}"));
        let mut encoder = png::Encoder::new(
            std::io::BufWriter::new(file),
            self.width as u32,
            self.height as u32,
        );
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().expect("a PNG header");
        writer
            .write_image_data(&self.rgba)
            .expect("the PNG's pixels");
    }
}

/// three.js draws `path` (a GLB) from +z: [`draw_glb_from`] `[0, 0, 1]`.
pub(crate) fn draw_glb(path: &Path) -> Drawn {
    draw_glb_from(path, [0.0, 0.0, 1.0])
}

/// three.js draws `path` (a GLB) once in the shared browser, the camera at the model's
/// bounding-box centre plus a multiple of `direction`, looking at the centre (up is +y, or -z
/// looking down, +z looking up). Panics when the page could not load or draw it. Blocks (in a
/// thread of its own, so async tests may call it too); call [`clients_ready`] first.
pub(crate) fn draw_glb_from(path: &Path, direction: [f64; 3]) -> Drawn {
    std::thread::scope(|scope| {
        scope
            .spawn(|| {
                tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                    .expect("a runtime")
                    .block_on(draw(path, direction))
            })
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e))
    })
}

async fn draw(path: &Path, direction: [f64; 3]) -> Drawn {
    let started = Instant::now();
    let dir = tempfile::tempdir().expect("a folder for the served model");
    let name = match path.extension().and_then(|e| e.to_str()) {
        Some("gltf") => "model.gltf",
        _ => "model.glb",
    };
    std::fs::copy(path, dir.path().join(name))
        .unwrap_or_else(|e| panic!("copying {}: {e}", path.display()));
    let server = serve_folders(vec![dir.path().to_path_buf(), js_dir()]);
    let [x, y, z] = direction;
    let url = server.url(&format!("draw.html?glb={name}&dir={x},{y},{z}"));
    let browser = Browser::blank(Duration::from_secs(30)).await;
    browser.goto(&url).await;
    let result = poll(
        &format!("three.js drawing {}", path.display()),
        async || {
            let result = browser
                .run(
                    "return window.result === undefined ? null : window.result;",
                    vec![],
                )
                .await;
            (!result.is_null()).then_some(result)
        },
    )
    .await;
    browser.close().await;
    drop(server);
    assert!(
        result["ok"] == true,
        "three.js could not draw {}: {}",
        path.display(),
        result["error"].as_str().unwrap_or(&result.to_string())
    );
    let rgba = base64::engine::general_purpose::STANDARD
        .decode(result["pixels"].as_str().expect("the pixels"))
        .expect("base64 pixels");
    let size = |key: &str| result[key].as_u64().expect("the canvas size") as usize;
    let (width, height) = (size("width"), size("height"));
    assert_eq!(rgba.len(), 4 * width * height);
    let background: Vec<u8> = serde_json::from_value(result["background"].clone()).unwrap();
    eprintln!(
        "gltf_clients: drew {} in {:.2} s",
        path.display(),
        started.elapsed().as_secs_f64()
    );
    let drawn = Drawn {
        width,
        height,
        rgba,
        background: background.try_into().expect("an RGB background"),
        scene: result["scene"].clone(),
        renderer: result["renderer"].as_str().unwrap_or("?").to_string(),
    };
    // `TEXGRAPH_SAVE_DRAWN=DIR`: every picture kept as DIR/STEM_X_Y_Z.png, to look at.
    if let Some(keep) = std::env::var_os("TEXGRAPH_SAVE_DRAWN") {
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        let keep = Path::new(&keep).join(format!("{stem}_{x}_{y}_{z}.png"));
        drawn.save_png(&keep);
        eprintln!("gltf_clients: saved {}", keep.display());
    }
    drawn
}

/// A static HTTP server on localhost (pages fetch their files, which `file://` pages may
/// not): `GET /a/b.js` answers the first of `roots` holding `a/b.js`, with its content type
/// (module scripts need a JavaScript one), until dropped. Each connection has a thread.
pub(crate) struct Served {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
}

impl Served {
    /// `http://ADDR/PATH`.
    pub(crate) fn url(&self, path: &str) -> String {
        format!("http://{}/{path}", self.addr)
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wakes the accepting thread, which then sees the stop.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_secs(1));
    }
}

/// Serves `roots` (see [`Served`]) on a free port of 127.0.0.1.
pub(crate) fn serve_folders(roots: Vec<PathBuf>) -> Served {
    let listener = TcpListener::bind("127.0.0.1:0").expect("a local port");
    let addr = listener.local_addr().expect("its address");
    let stop = Arc::new(AtomicBool::new(false));
    let stopped = stop.clone();
    let roots = Arc::new(roots);
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            if stopped.load(Ordering::SeqCst) {
                break;
            }
            if let Ok(stream) = stream {
                let roots = roots.clone();
                std::thread::spawn(move || answer(&roots, stream));
            }
        }
    });
    Served { addr, stop }
}

fn answer(roots: &[PathBuf], mut stream: TcpStream) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(5)))?;
    let mut request = Vec::new();
    let mut buffer = [0u8; 4096];
    while !request.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = stream.read(&mut buffer)?;
        if n == 0 {
            break;
        }
        request.extend_from_slice(&buffer[..n]);
    }
    let request = String::from_utf8_lossy(&request);
    let target = request.split_whitespace().nth(1).unwrap_or("/");
    let name = target.split(['?', '#']).next().unwrap_or("");
    // Plain names only: nothing outside the roots.
    let parts: Vec<&str> = name.trim_start_matches('/').split('/').collect();
    let plain = parts.iter().all(|p| {
        !p.is_empty()
            && !p.starts_with('.')
            && p.chars()
                .all(|c| c.is_ascii_alphanumeric() || "._-".contains(c))
    });
    let relative: PathBuf = parts.iter().collect();
    let file = roots
        .iter()
        .map(|root| root.join(&relative))
        .find(|path| plain && path.is_file());
    let (status, body) = match file.map(std::fs::read) {
        Some(Ok(body)) => ("200 OK", body),
        _ => ("404 Not Found", b"not found".to_vec()),
    };
    let extension = relative.extension().and_then(|e| e.to_str()).unwrap_or("");
    let kind = match (status, extension) {
        ("200 OK", "html") => "text/html; charset=utf-8",
        ("200 OK", "js" | "mjs") => "text/javascript; charset=utf-8",
        ("200 OK", "json") => "application/json",
        ("200 OK", "glb") => "model/gltf-binary",
        ("200 OK", "gltf") => "model/gltf+json",
        ("200 OK", "png") => "image/png",
        ("200 OK", "bin") => "application/octet-stream",
        _ => "text/plain; charset=utf-8",
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\n\
         Cache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(&body)
}

/// A GLB file: `json` and the binary chunk `bin`, each padded to 4 bytes (JSON with spaces,
/// the binary chunk with zeros).
pub(crate) fn glb_bytes(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = serde_json::to_vec(json).expect("glTF JSON");
    text.resize(text.len().next_multiple_of(4), b' ');
    let mut bin = bin.to_vec();
    bin.resize(bin.len().next_multiple_of(4), 0);
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    for word in [
        0x4654_6C67u32,
        2,
        total as u32,
        text.len() as u32,
        0x4E4F_534A,
    ] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&text);
    for word in [bin.len() as u32, 0x004E_4942] {
        out.extend_from_slice(&word.to_le_bytes());
    }
    out.extend_from_slice(&bin);
    out
}

/// The checker's colours: texel (i, j) of [`CHECKER`] is red where i + j is even.
const RED: [u8; 4] = [230, 30, 30, 255];
const GREEN: [u8; 4] = [30, 200, 30, 255];
/// The checker's cells a side.
const CHECKER: usize = 8;

/// A red and green checker, `CHECKER` texels a side, as a PNG.
fn checker_png() -> Vec<u8> {
    let mut pixels = Vec::with_capacity(CHECKER * CHECKER * 4);
    for j in 0..CHECKER {
        for i in 0..CHECKER {
            pixels.extend_from_slice(if (i + j) % 2 == 0 { &RED } else { &GREEN });
        }
    }
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, CHECKER as u32, CHECKER as u32);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&pixels).unwrap();
    writer.finish().unwrap();
    png_bytes
}

/// A quad from (-1, -1, 0) to (1, 1, 0) facing +z, single-sided, textured with the checker
/// (texel row 0 at the top, +y: glTF's UV origin is the image's top-left corner), as a GLB.
/// `positions` is the position accessor's count (4; more makes it overrun its buffer view).
fn checker_quad_glb(positions: u32) -> Vec<u8> {
    let floats = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
    let mut bin = floats(&[-1., -1., 0., 1., -1., 0., 1., 1., 0., -1., 1., 0.]);
    bin.extend(floats(&[0., 0., 1.].repeat(4)));
    bin.extend(floats(&[0., 1., 1., 1., 1., 0., 0., 0.]));
    bin.extend(
        [0u16, 1, 2, 0, 2, 3, 0, 0]
            .iter()
            .flat_map(|i| i.to_le_bytes()),
    );
    let image = checker_png();
    bin.extend(&image);
    let view = |offset: usize, length: usize, target: Option<u32>| {
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": length});
        if let Some(target) = target {
            v["target"] = json!(target);
        }
        v
    };
    let gltf = json!({
        "asset": {"version": "2.0", "generator": "texgraph tests (gltf_clients.rs)"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3,
            "material": 0,
        }]}],
        "materials": [{"pbrMetallicRoughness": {
            "baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0,
        }}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": [{"bufferView": 4, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions, "type": "VEC3",
             "min": [-1.0, -1.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [
            view(0, 48, Some(34962)),
            view(48, 48, Some(34962)),
            view(96, 32, Some(34962)),
            view(128, 12, Some(34963)),
            view(144, image.len(), None),
        ],
        "buffers": [{"byteLength": bin.len().next_multiple_of(4)}],
    });
    glb_bytes(&gltf, &bin)
}

fn red_ish(p: [u8; 4]) -> bool {
    p[0] as i32 > p[1] as i32 + 60 && p[0] as i32 > p[2] as i32 + 60
}

fn green_ish(p: [u8; 4]) -> bool {
    p[1] as i32 > p[0] as i32 + 60 && p[1] as i32 > p[2] as i32 + 60
}

/// The checker quad is valid glTF, and three.js draws it: the quad in the middle of the
/// background, its cells red and green the right way up (top-left red, its right neighbour
/// green); seen from behind, the single-sided quad is not drawn.
#[test]
fn the_validator_passes_and_three_js_draws_a_checker_quad() {
    let test = "the_validator_passes_and_three_js_draws_a_checker_quad";
    if !clients_ready(test) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("quad.glb");
    std::fs::write(&path, checker_quad_glb(4)).unwrap();
    let started = Instant::now();
    let report = assert_valid_glb(&path);
    eprintln!(
        "gltf_clients: validated in {:.2} s",
        started.elapsed().as_secs_f64()
    );
    assert_eq!(issues(&report, 3), Vec::<String>::new(), "{report:#}");
    assert_eq!(report["info"]["totalTriangleCount"], 2, "{report:#}");
    assert_eq!(report["info"]["hasTextures"], true, "{report:#}");

    let drawn = draw_glb(&path);
    eprintln!("renderer {}; scene {}", drawn.renderer, drawn.scene);
    let keep = dir.path().join("front.png");
    drawn.save_png(&keep);
    assert_eq!((drawn.width, drawn.height), (256, 256));
    let material = &drawn.scene["materials"][0];
    assert_eq!(material["type"], "MeshStandardMaterial", "{material}");
    assert_eq!(material["map"]["width"], CHECKER, "{material}");
    assert_eq!(material["map"]["colorSpace"], "srgb", "{material}");
    assert!(drawn.is_background(0, 0) && drawn.is_background(255, 255));
    let (x0, y0, x1, y1) = drawn.drawn_box().expect("the quad is drawn");
    let (w, h) = (x1 + 1 - x0, y1 + 1 - y0);
    assert!(
        w > 64 && h > 64 && w.abs_diff(h) <= 2,
        "the quad covers {w}×{h} pixels"
    );
    assert!(
        (x0 + x1).abs_diff(255) <= 2 && (y0 + y1).abs_diff(255) <= 2,
        "the quad is centred: {:?}",
        (x0, y0, x1, y1)
    );
    // Every pixel of the quad is one of the two lit colours, and both appear about equally.
    let (mut red, mut green, mut other) = (0, 0, Vec::new());
    for (x, y, p) in drawn.drawn_pixels() {
        match (red_ish(p), green_ish(p)) {
            (true, _) => red += 1,
            (_, true) => green += 1,
            _ => other.push((x, y, p)),
        }
    }
    assert!(
        other.len() * 100 <= w * h,
        "{} pixels neither red nor green, e.g. {:?}",
        other.len(),
        &other[..other.len().min(5)]
    );
    assert!(
        red * 10 > w * h * 4 && green * 10 > w * h * 4,
        "red {red}, green {green} of {} pixels",
        w * h
    );
    // The cells the right way up: the centres of the top-left cell and its neighbours.
    let cell = |i: usize, j: usize| {
        let x = x0 + (2 * i + 1) * w / (2 * CHECKER);
        let y = y0 + (2 * j + 1) * h / (2 * CHECKER);
        drawn.pixel(x, y)
    };
    let saved = format!("(picture: {})", keep.display());
    assert!(red_ish(cell(0, 0)), "top-left {:?} {saved}", cell(0, 0));
    assert!(green_ish(cell(1, 0)), "{:?} {saved}", cell(1, 0));
    assert!(green_ish(cell(0, 1)), "{:?} {saved}", cell(0, 1));
    assert!(red_ish(cell(7, 7)), "{:?} {saved}", cell(7, 7));

    let behind = draw_glb_from(&path, [0.0, 0.0, -1.0]);
    assert_eq!(
        behind.coverage(),
        0.0,
        "a single-sided quad seen from behind"
    );
    let above = draw_glb_from(&path, [0.0, 1.0, 0.0]);
    assert!(
        above.coverage() < 0.01,
        "the quad seen edge-on covers {}",
        above.coverage()
    );
}

/// The validator fails a broken GLB: a position accessor longer than its buffer view.
#[test]
fn the_validator_reports_a_broken_glb() {
    let test = "the_validator_reports_a_broken_glb";
    if !clients_ready(test) {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.glb");
    std::fs::write(&path, checker_quad_glb(5)).unwrap();
    let report = validate_glb(&path);
    let errors = issues(&report, 0);
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with("ACCESSOR_TOO_LONG at /accessors/0")),
        "{errors:#?}"
    );
    assert!(
        errors
            .iter()
            .any(|e| e.starts_with("MESH_PRIMITIVE_UNEQUAL_ACCESSOR_COUNT")),
        "{errors:#?}"
    );
    assert_eq!(report["issues"]["numErrors"], errors.len(), "{report:#}");
    let refused = valid_glb(&path).expect_err("assert_valid_glb passes a broken GLB");
    assert!(refused.contains("ACCESSOR_TOO_LONG"), "{refused}");
    // Not GLB at all: a truncated header.
    std::fs::write(&path, &checker_quad_glb(4)[..10]).unwrap();
    assert!(validate_glb(&path)["issues"]["numErrors"].as_u64() > Some(0));
}

/// The sample models of `examples/meshes/` (the inputs of `bake --mesh`): each valid, and
/// drawn by three.js.
#[test]
fn the_sample_meshes_are_valid_and_drawn() {
    let test = "the_sample_meshes_are_valid_and_drawn";
    let folder = common::crate_root().join("examples/meshes");
    let mut models: Vec<PathBuf> = std::fs::read_dir(&folder)
        .into_iter()
        .flatten()
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "glb"))
        .collect();
    models.sort();
    if models.is_empty() {
        eprintln!("{test}: no examples/meshes/*.glb");
        return;
    }
    if !clients_ready(test) {
        return;
    }
    for model in models {
        assert_valid_glb(&model);
        let drawn = draw_glb(&model);
        assert!(
            drawn.coverage() > 0.02,
            "{} covers {} of the picture",
            model.display(),
            drawn.coverage()
        );
    }
}
