//! `texgraph serve` in a real browser: headless Chromium driven through WebDriver
//! (chromedriver, the `fantoccini` client) against a server started in-process. The page
//! draws its preview, slice and node thumbnails; a slider re-renders the preview; a broken
//! save shows its diagnostic at its line and a fix clears it; a save of an imported file
//! re-renders the importing graph; hovering the slice shows every output there, the wheel zooms
//! the slice window about the cursor and clicking a node makes it the output (docs/serve.md).
//!
//! Without `/usr/bin/chromium` and `/usr/bin/chromedriver` (Debian packages `chromium`,
//! `chromium-driver`) every test says SKIPPED and passes, unless `TEXGRAPH_REQUIRE_BROWSER=1`
//! (CI sets it once it has installed them): then a missing browser fails the test.

use common::{marble_copy, save_by_rename, serve, MARBLE};
use fantoccini::{Client, ClientBuilder};
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use texgraph::serve::Server;

use crate::common;

const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";
/// The marble's named nodes, in file order.
const MARBLE_NODES: [&str; 5] = ["v", "fractal", "phase", "vein", "colour"];
/// How long a wait on the page may take (a debug build renders the full preview).
const WAIT: Duration = Duration::from_secs(30);
const POLL: Duration = Duration::from_millis(100);
/// The image sizes the tests' servers start with (`common::SMALL_IMAGES`: the page lays them out
/// as it does the defaults, and they render 16 times faster in a debug build).
const PREVIEW: u64 = common::SMALL_IMAGES.preview as u64;
const SLICE: u64 = common::SMALL_IMAGES.slice as u64;
const THUMB: u64 = common::SMALL_IMAGES.thumb as u64;

/// Whether the browser is installed; if not, says SKIPPED (or fails under
/// `TEXGRAPH_REQUIRE_BROWSER=1`).
pub(crate) fn browser_installed(test: &str) -> bool {
    let missing: Vec<&str> = [CHROMIUM, CHROMEDRIVER]
        .into_iter()
        .filter(|p| !Path::new(p).exists())
        .collect();
    if missing.is_empty() {
        return true;
    }
    if std::env::var("TEXGRAPH_REQUIRE_BROWSER").is_ok_and(|v| v == "1") {
        panic!(
            "{test}: TEXGRAPH_REQUIRE_BROWSER=1 but {} missing (Debian packages chromium, \
             chromium-driver)",
            missing.join(" and ")
        );
    }
    eprintln!(
        "SKIPPED: {test}: chromium/chromedriver not installed (Debian packages chromium, \
         chromium-driver)"
    );
    false
}

/// A plain HTTP/1.1 GET: the response's status line and headers, and its body (read up to
/// its `Content-Length`: chromedriver keeps the connection open).
fn http_get(addr: SocketAddr, path: &str) -> std::io::Result<(String, String)> {
    let mut stream = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )?;
    let mut response = Vec::new();
    let mut buffer = [0u8; 65536];
    loop {
        let n = stream.read(&mut buffer)?;
        if n == 0 {
            break;
        }
        response.extend_from_slice(&buffer[..n]);
        let Some(end) = response.windows(4).position(|w| w == b"\r\n\r\n") else {
            continue;
        };
        let head = String::from_utf8_lossy(&response[..end]).to_ascii_lowercase();
        let length = head.lines().find_map(|l| {
            let (name, value) = l.split_once(':')?;
            (name.trim() == "content-length").then(|| value.trim().parse::<usize>().ok())?
        });
        if length.is_some_and(|length| response.len() >= end + 4 + length) {
            break;
        }
    }
    let response = String::from_utf8_lossy(&response).into_owned();
    let (head, body) = response.split_once("\r\n\r\n").unwrap_or((&response, ""));
    Ok((head.to_string(), body.to_string()))
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// The one chromedriver and Chromium session every browser test shares (issue 31: a browser
/// and a WebDriver started once, not once per test). The tests take turns (`TURN`): each
/// navigates the one window to its own server's page, so nothing of one test's page survives
/// into the next. The session's connection runs on a runtime of its own, which outlives every
/// test's runtime; the process that started chromedriver is watched by a small shell script,
/// which shuts chromedriver (and the browser with it) down once the test process is gone.
struct SharedBrowser {
    client: Client,
    /// The watchdog shell (chromedriver's parent), never waited for: it ends after this process.
    _watchdog: std::process::Child,
    _runtime: tokio::runtime::Runtime,
    _profile: tempfile::TempDir,
}

static SHARED: std::sync::OnceLock<SharedBrowser> = std::sync::OnceLock::new();
static TURN: tokio::sync::Mutex<()> = tokio::sync::Mutex::const_new(());

/// Starts chromedriver on a free port with its watchdog: once this process has exited, the
/// watchdog asks chromedriver to shut down (it quits its browsers), then kills it.
// The watchdog is meant to outlive this function and this process (that is its job); it is
// killed and waited for only when chromedriver never answers.
#[allow(clippy::zombie_processes)]
fn start_driver() -> (SocketAddr, std::process::Child) {
    let port = free_port();
    let watchdog = format!(
        "{CHROMEDRIVER} --port={port} >/dev/null 2>&1 & driver=$!
         while kill -0 {parent} 2>/dev/null; do sleep 0.5; done
         exec 3<>/dev/tcp/127.0.0.1/{port} && printf 'GET /shutdown HTTP/1.1\r\nHost: localhost\r\n\r\n' >&3
         sleep 2; kill $driver 2>/dev/null; wait $driver",
        parent = std::process::id()
    );
    let watchdog = Command::new("bash")
        .args(["-c", &watchdog])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("bash starts chromedriver");
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        if let Ok((_, body)) = http_get(addr, "/status") {
            if body.replace(' ', "").contains("\"ready\":true") {
                return (addr, watchdog);
            }
        }
        if Instant::now() >= deadline {
            let mut watchdog = watchdog;
            let _ = watchdog.kill();
            let _ = watchdog.wait();
            panic!("chromedriver did not answer on port {port} within 10 s");
        }
        std::thread::sleep(POLL);
    }
}

impl SharedBrowser {
    /// The shared session, started by the first test that asks.
    fn get() -> &'static SharedBrowser {
        SHARED.get_or_init(|| {
            let (addr, watchdog) = start_driver();
            let profile = tempfile::tempdir().expect("a profile folder");
            let runtime = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(1)
                .enable_all()
                .build()
                .expect("the browser's runtime");
            let mut capabilities = serde_json::Map::new();
            capabilities.insert("browserName".into(), json!("chrome"));
            capabilities.insert(
                "goog:chromeOptions".into(),
                json!({
                    "binary": CHROMIUM,
                    "args": [
                        "--headless=new", "--no-sandbox", "--disable-gpu",
                        "--disable-dev-shm-usage", "--disable-quic", "--no-first-run",
                        "--disable-background-networking", "--disable-component-update",
                        "--disable-sync",
                        format!("--user-data-dir={}", profile.path().display()),
                        "--window-size=1400,1000",
                    ],
                }),
            );
            let url = format!("http://{addr}");
            // The session's own task lives on `runtime`, which no test's runtime outlives.
            let client = std::thread::scope(|scope| {
                scope
                    .spawn(|| {
                        runtime
                            .block_on(
                                ClientBuilder::new(
                                    hyper_util::client::legacy::connect::HttpConnector::new(),
                                )
                                .capabilities(capabilities)
                                .connect(&url),
                            )
                            .map_err(|e| e.to_string())
                    })
                    .join()
                    .expect("the connecting thread")
            })
            .unwrap_or_else(|e| panic!("a Chromium session through chromedriver: {e}"));
            SharedBrowser {
                client,
                _watchdog: watchdog,
                _runtime: runtime,
                _profile: profile,
            }
        })
    }
}

/// One test's turn with the shared browser, on its server's page (or a blank one).
pub(crate) struct Browser {
    client: Client,
    _turn: tokio::sync::MutexGuard<'static, ()>,
}

/// The page's state as the tests read it, in one script run.
const SNAPSHOT: &str = r#"
const text = (sel) => { const e = document.querySelector(sel); return e ? e.textContent : null; };
const img = (sel) => {
    const e = document.querySelector(sel);
    if (!e) return null;
    const src = e.getAttribute('src') || '';
    return { w: e.naturalWidth, h: e.naturalHeight, complete: e.complete,
             png: src.startsWith('data:image/png'), len: src.length,
             same: window.__texgraphBaseline !== undefined && src === window.__texgraphBaseline };
};
const diagnostics = document.getElementById('diagnostics');
return {
    preview: img('#preview'),
    preview_stage: text('#preview-stage'),
    slice: img('#slice'),
    nodes: [...document.querySelectorAll('#nodes div.node')].map((n) => {
        const t = n.querySelector('img.thumb');
        return { name: n.dataset.name, w: t ? t.naturalWidth : -1, h: t ? t.naturalHeight : -1,
                 complete: t ? t.complete : false,
                 png: !!t && (t.getAttribute('src') || '').startsWith('data:image/png') };
    }),
    params: [...document.querySelectorAll('#params div.param')].map((p) => p.dataset.param),
    diagnostics: diagnostics
        ? [...diagnostics.querySelectorAll('.diagnostic')].map((d) => d.textContent) : null,
    diagnostic_children: diagnostics ? diagnostics.children.length : -1,
    stale: document.body.classList.contains('stale'),
    status: text('#status'),
    connection: text('#connection'),
};
"#;

/// Every image of the page drawn into a canvas: its size and whether its pixels differ.
const PIXELS: &str = r#"
const out = [];
for (const e of document.querySelectorAll('#preview, #slice, #nodes img.thumb')) {
    const c = document.createElement('canvas');
    c.width = e.naturalWidth;
    c.height = e.naturalHeight;
    const what = e.id ? '#' + e.id : 'thumbnail of ' + e.closest('.node').dataset.name;
    if (c.width === 0 || c.height === 0) { out.push({ what, w: 0, h: 0, distinct: 0 }); continue; }
    const g = c.getContext('2d');
    g.drawImage(e, 0, 0);
    const d = g.getImageData(0, 0, c.width, c.height).data;
    const seen = new Set();
    for (let i = 0; i < d.length && seen.size < 16; i += 4) {
        seen.add((d[i] << 24 | d[i + 1] << 16 | d[i + 2] << 8 | d[i + 3]) >>> 0);
    }
    out.push({ what, w: c.width, h: c.height, distinct: seen.size });
}
return out;
"#;

impl Browser {
    /// Waits for the shared browser's turn, then opens `server`'s page in it.
    async fn open(server: &Server) -> Browser {
        let turn = TURN.lock().await;
        let client = SharedBrowser::get().client.clone();
        client
            .goto(&server.url())
            .await
            .unwrap_or_else(|e| panic!("opening {}: {e}", server.url()));
        Browser {
            client,
            _turn: turn,
        }
    }

    /// Waits for the shared browser's turn on a blank page (no server), where a script may run
    /// for up to `script_timeout` (the WebGL 2 test of `shader_webgl` compiles large shaders).
    pub(crate) async fn blank(script_timeout: Duration) -> Browser {
        let turn = TURN.lock().await;
        let client = SharedBrowser::get().client.clone();
        client.goto("about:blank").await.expect("about:blank");
        client
            .update_timeouts(fantoccini::wd::TimeoutConfiguration::new(
                Some(script_timeout),
                None,
                None,
            ))
            .await
            .expect("the script timeout");
        Browser {
            client,
            _turn: turn,
        }
    }

    /// Opens `url` in this turn's window.
    pub(crate) async fn goto(&self, url: &str) {
        self.client
            .goto(url)
            .await
            .unwrap_or_else(|e| panic!("opening {url}: {e}"));
    }

    /// Ends this test's turn: the page is left for `about:blank`, so it stops talking to a
    /// server about to stop.
    pub(crate) async fn close(self) {
        let _ = self.client.goto("about:blank").await;
    }

    /// Runs `script` (a function body: `arguments` are `args`) and returns what it returns.
    pub(crate) async fn run(&self, script: &str, args: Vec<Value>) -> Value {
        self.client
            .execute(script, args)
            .await
            .unwrap_or_else(|e| panic!("script failed: {e}\n{script}"))
    }

    /// The text of the element `selector` picks, once `done` accepts it (polled; panics after
    /// [`WAIT`], naming `what`).
    pub(crate) async fn text_when(
        &self,
        what: &str,
        selector: &str,
        done: impl Fn(&str) -> bool,
    ) -> String {
        let script =
            "const e = document.querySelector(arguments[0]); return e ? e.textContent : '';";
        poll(what, async || {
            let text = self.run(script, vec![Value::from(selector)]).await;
            let text = text.as_str().unwrap_or("").to_string();
            done(&text).then_some(text)
        })
        .await
    }

    async fn snapshot(&self) -> Result<Value, String> {
        self.client
            .execute(SNAPSHOT, vec![])
            .await
            .map_err(|e| e.to_string())
    }

    /// Polls the page's [`SNAPSHOT`] until `done` holds for it (returned), or panics after
    /// [`WAIT`] with the page's status and diagnostics.
    async fn wait_for(&self, what: &str, done: impl Fn(&Value) -> bool) -> Value {
        let deadline = Instant::now() + WAIT;
        let mut last = Err("no snapshot taken".to_string());
        while Instant::now() < deadline {
            last = self.snapshot().await;
            if let Ok(snapshot) = &last {
                if done(snapshot) {
                    return snapshot.clone();
                }
            }
            tokio::time::sleep(POLL).await;
        }
        let page = match &last {
            Ok(s) => format!(
                "#status {:?}, #connection {:?}, #diagnostics {:?}\nlast snapshot: {s}",
                s["status"], s["connection"], s["diagnostics"]
            ),
            Err(e) => format!("the page could not be read: {e}"),
        };
        panic!("timed out after {WAIT:?} waiting for {what}; {page}");
    }

    /// Remembers the preview's current image, for [`preview_changed`].
    async fn remember_preview(&self) -> String {
        let src = self
            .run(
                "const s = document.querySelector('#preview').getAttribute('src') || ''; \
                 window.__texgraphBaseline = s; return s;",
                vec![],
            )
            .await;
        src.as_str().expect("the preview's src").to_string()
    }

    async fn preview_src(&self) -> String {
        let src = self
            .run(
                "return document.querySelector('#preview').getAttribute('src') || '';",
                vec![],
            )
            .await;
        src.as_str().expect("the preview's src").to_string()
    }
}

/// Polls `probe` every [`POLL`] until it answers `Some` (returned), or panics after [`WAIT`].
pub(crate) async fn poll<T>(what: &str, mut probe: impl AsyncFnMut() -> Option<T>) -> T {
    let deadline = Instant::now() + WAIT;
    loop {
        if let Some(found) = probe().await {
            return found;
        }
        assert!(
            Instant::now() < deadline,
            "timed out after {WAIT:?} waiting for {what}"
        );
        tokio::time::sleep(POLL).await;
    }
}

fn image_loaded(image: &Value, size: u64) -> bool {
    image["complete"] == true && image["png"] == true && image["w"] == size && image["h"] == size
}

/// The page shows a checked graph: every image at its full default size, no diagnostics.
fn drawn(s: &Value, nodes: &[&str]) -> bool {
    let names: Vec<&str> = s["nodes"]
        .as_array()
        .map(|a| a.iter().filter_map(|n| n["name"].as_str()).collect())
        .unwrap_or_default();
    full_preview(s)
        && image_loaded(&s["slice"], SLICE)
        && names == nodes
        && s["nodes"]
            .as_array()
            .is_some_and(|a| a.iter().all(|n| image_loaded(n, THUMB)))
        && s["diagnostic_children"] == 0
        && s["stale"] == false
}

/// The preview shows a full render at the full size. The draft that comes first has the
/// same size when the preview is small (`common::SMALL_IMAGES`'s 128 is the draft's size too), so
/// the size alone does not tell them apart: the stage the page shows does.
fn full_preview(s: &Value) -> bool {
    image_loaded(&s["preview"], PREVIEW)
        && s["preview_stage"]
            .as_str()
            .is_some_and(|t| t.starts_with("full"))
}

/// A new full preview: not the remembered one.
fn preview_changed(s: &Value) -> bool {
    full_preview(s) && s["preview"]["same"] == false
}

/// The server's newest state (`/api/state`).
fn api_state(server: &Server) -> Value {
    let (head, body) = http_get(server.addr(), "/api/state").expect("GET /api/state");
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    serde_json::from_str(&body).expect("/api/state is JSON")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_draws_its_preview_slice_and_thumbnails() {
    if !browser_installed("the_page_draws_its_preview_slice_and_thumbnails") {
        return;
    }
    let (_dir, path) = marble_copy();
    let server = serve(&path);
    let browser = Browser::open(&server).await;
    let shown = browser
        .wait_for("the full preview, the slice and every thumbnail", |s| {
            drawn(s, &MARBLE_NODES)
        })
        .await;
    assert_eq!(
        shown["params"],
        json!(["scale", "period", "distortion", "octaves"]),
        "a slider per param, in file order"
    );
    let images = browser.run(PIXELS, vec![]).await;
    let images = images.as_array().expect("the images' pixels");
    assert_eq!(images.len(), 2 + MARBLE_NODES.len(), "{images:?}");
    for image in images {
        let size = match image["what"].as_str().unwrap() {
            "#preview" => PREVIEW,
            "#slice" => SLICE,
            _ => THUMB,
        };
        assert_eq!(image["w"], size, "{image}");
        assert_eq!(image["h"], size, "{image}");
        assert!(
            image["distinct"].as_u64().unwrap() > 1,
            "{} is blank (every pixel the same): {image}",
            image["what"]
        );
    }
    // Each node's thumbnail shows its own values: not all the same picture.
    let thumbs = browser
        .run(
            "return [...document.querySelectorAll('#nodes img.thumb')].map((t) => t.src);",
            vec![],
        )
        .await;
    let thumbs: Vec<&str> = thumbs
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    let mut distinct = thumbs.clone();
    distinct.sort_unstable();
    distinct.dedup();
    assert!(
        distinct.len() > 1,
        "every thumbnail is the same image ({} of them)",
        thumbs.len()
    );
    browser.close().await;
    server.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn moving_a_slider_re_renders_the_preview() {
    if !browser_installed("moving_a_slider_re_renders_the_preview") {
        return;
    }
    let (_dir, path) = marble_copy();
    let server = serve(&path);
    let browser = Browser::open(&server).await;
    browser
        .wait_for("the first full preview", |s| drawn(s, &MARBLE_NODES))
        .await;
    let before = browser.remember_preview().await;
    // `period` is 1.3 in the file: its slider runs over [0, 5.2].
    let moved = browser
        .run(
            r#"
            const p = document.querySelector('#params div.param[data-param="period"]');
            const slider = p && p.querySelector('input.slider[type=range]');
            if (!slider) return null;
            slider.value = arguments[0];
            slider.dispatchEvent(new Event('input', { bubbles: true }));
            return slider.value;
            "#,
            vec![json!("3")],
        )
        .await;
    let moved: f64 = moved
        .as_str()
        .unwrap_or_else(|| panic!("no period slider: {moved}"))
        .parse()
        .unwrap();
    assert!((moved - 3.0).abs() < 0.01, "the slider took {moved}");
    browser
        .wait_for("a new full preview after the slider moved", preview_changed)
        .await;
    let after = browser.preview_src().await;
    assert_ne!(before, after, "the preview changed");
    // The number field follows the slider, and the server has the override.
    let number = browser
        .run(
            "return document.querySelector('#params div.param[data-param=\"period\"] \
             input.number[type=number]').value;",
            vec![],
        )
        .await;
    let number: f64 = number.as_str().unwrap_or("NaN").parse().unwrap_or(f64::NAN);
    assert!(
        (number - moved).abs() < 0.01,
        "the number field shows {number}, the slider {moved}"
    );
    let state = api_state(&server);
    let period = state["settings"]["params"]["period"].as_f64();
    assert!(
        period.is_some_and(|p| (p - moved).abs() < 1e-6),
        "the server's period override is {period:?}, the slider's {moved}"
    );
    // The file is untouched.
    assert_eq!(
        std::fs::read_to_string(&path).unwrap(),
        std::fs::read_to_string(MARBLE).unwrap()
    );
    browser.close().await;
    server.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_broken_save_shows_its_line_and_a_fix_clears_it() {
    if !browser_installed("a_broken_save_shows_its_line_and_a_fix_clears_it") {
        return;
    }
    let (_dir, path) = marble_copy();
    let good = std::fs::read_to_string(&path).unwrap();
    let server = serve(&path);
    let browser = Browser::open(&server).await;
    browser
        .wait_for("the first full preview", |s| drawn(s, &MARBLE_NODES))
        .await;
    let before = browser.remember_preview().await;

    // A typo'd node kind on the `fractal` line.
    let index = good
        .lines()
        .position(|l| l.contains("\"fractal\": Fbm("))
        .expect("the marble's fractal line");
    let line = index + 1;
    let broken: String = good
        .lines()
        .enumerate()
        .map(|(i, l)| {
            let l = if i == index {
                l.replacen("Fbm(", "Fbmm(", 1)
            } else {
                l.to_string()
            };
            l + "\n"
        })
        .collect();
    save_by_rename(&path, &broken);
    let shown = browser
        .wait_for(&format!("a diagnostic at marble.ron:{line}"), |s| {
            s["diagnostics"].as_array().is_some_and(|d| {
                d.iter().any(|t| {
                    t.as_str()
                        .is_some_and(|t| t.contains(&format!("marble.ron:{line}:")))
                })
            })
        })
        .await;
    let texts: Vec<&str> = shown["diagnostics"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|t| t.as_str())
        .collect();
    let text = texts
        .iter()
        .find(|t| t.contains(&format!("marble.ron:{line}:")))
        .unwrap()
        .trim_start();
    // `FILE:LINE:COLUMN: message`
    let (place, message) = text
        .split_once(": ")
        .unwrap_or_else(|| panic!("no `FILE:LINE:COLUMN: ` at the start of {text:?}"));
    let mut parts = place.rsplitn(3, ':');
    let (column, at, file) = (parts.next(), parts.next(), parts.next());
    assert!(
        file.is_some_and(|f| f.ends_with("marble.ron")),
        "the diagnostic starts with its file: {text:?}"
    );
    assert_eq!(at, Some(line.to_string().as_str()), "{text:?}");
    assert!(
        column.is_some_and(|c| c.parse::<u32>().is_ok_and(|c| c >= 1)),
        "{text:?}"
    );
    assert!(!message.trim().is_empty(), "{text:?}");
    assert_eq!(shown["stale"], true, "body.stale while the file is broken");
    // The last good images stay.
    assert!(
        image_loaded(&shown["preview"], PREVIEW) && shown["preview"]["same"] == true,
        "the last good preview is kept: {}",
        shown["preview"]
    );
    assert!(!before.is_empty());

    // The fix, saved in place this time.
    std::fs::write(&path, &good).unwrap();
    browser
        .wait_for("the diagnostics cleared and the images fresh", |s| {
            s["diagnostic_children"] == 0 && s["stale"] == false && drawn(s, &MARBLE_NODES)
        })
        .await;
    browser.close().await;
    server.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn saving_an_imported_file_re_renders() {
    if !browser_installed("saving_an_imported_file_re_renders") {
        return;
    }
    let (dir, marble) = marble_copy();
    let floor = dir.path().join("floor.ron");
    std::fs::write(
        &floor,
        r#"// Marble imported, seen at half scale.
Graph(
    params: { "zoom": 0.5 },
    nodes: {
        "p": Position,
        "stone": Import(
            file: "marble.ron",
            output: "colour",
            input: Scale(input: "p", by: "zoom"),
        ),
    },
    outputs: { "colour": "stone" },
)
"#,
    )
    .unwrap();
    let server = serve(&floor);
    let browser = Browser::open(&server).await;
    browser
        .wait_for("the first full preview", |s| drawn(s, &["p", "stone"]))
        .await;
    let before = browser.remember_preview().await;
    let state = api_state(&server);
    assert!(
        state["graph"]["imports"].as_array().is_some_and(|i| i
            .iter()
            .any(|f| f.as_str().is_some_and(|f| f.ends_with("marble.ron")))),
        "floor.ron imports marble.ron: {}",
        state["graph"]["imports"]
    );

    // Another period in the imported file.
    let text = std::fs::read_to_string(&marble).unwrap();
    assert!(text.contains("\"period\": 1.3,"));
    save_by_rename(
        &marble,
        &text.replace("\"period\": 1.3,", "\"period\": 3.1,"),
    );
    browser
        .wait_for("a new full preview after the imported file changed", |s| {
            preview_changed(s) && s["diagnostic_children"] == 0 && s["stale"] == false
        })
        .await;
    let after = browser.preview_src().await;
    assert_ne!(before, after, "the preview changed");
    browser.close().await;
    server.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hovering_zooming_and_clicking_a_node_drive_the_server() {
    if !browser_installed("hovering_zooming_and_clicking_a_node_drive_the_server") {
        return;
    }
    let (_dir, path) = marble_copy();
    let server = serve(&path);
    let browser = Browser::open(&server).await;
    browser
        .wait_for("the first full preview", |s| drawn(s, &MARBLE_NODES))
        .await;
    // The mouse over the slice's centre: the values of every output there.
    let hover = r#"
        const img = document.querySelector('#slice'), r = img.getBoundingClientRect();
        const at = { clientX: r.left + r.width / 2, clientY: r.top + r.height / 2, bubbles: true };
        document.querySelector('#slice-view').dispatchEvent(new MouseEvent('mousemove', at));
        return true;"#;
    browser.run(hover, vec![]).await;
    let text = browser
        .text_when("the hover values", "#hover", |t| t.contains("vein:"))
        .await;
    // The point under the cursor: the slice's centre (to a pixel) at its depth, z = 0.5.
    let point: Vec<f64> = text
        .lines()
        .next()
        .unwrap_or("")
        .trim_matches(|c| c == '(' || c == ')')
        .split(", ")
        .filter_map(|v| v.parse().ok())
        .collect();
    assert_eq!(point.len(), 3, "{text}");
    assert!(
        (point[0] - 0.5).abs() < 0.01 && (point[1] - 0.5).abs() < 0.01,
        "{text}"
    );
    assert_eq!(point[2], 0.5, "{text}");
    assert!(text.contains("colour:") && text.contains("vein:"), "{text}");
    // Three wheel steps about the centre narrow the window by 1.1^3, kept centred.
    let wheel = r#"
        const img = document.querySelector('#slice'), r = img.getBoundingClientRect();
        for (let i = 0; i < 3; i++) {
            document.querySelector('#slice-view').dispatchEvent(new WheelEvent('wheel', {
                deltaY: -100, clientX: r.left + r.width / 2, clientY: r.top + r.height / 2,
                bubbles: true, cancelable: true }));
        }
        return true;"#;
    browser.run(wheel, vec![]).await;
    // Throttled: the first step goes at once, the last one 30 ms later.
    let window = poll("the wheel's zoom", async || {
        let window = api_state(&server)["settings"]["slice"].clone();
        ((window["width"].as_f64().unwrap() - 1.1f64.powi(-3)).abs() < 1e-9).then_some(window)
    })
    .await;
    let center = &window["center"];
    assert!((center[0].as_f64().unwrap() - 0.5).abs() < 0.01, "{center}");
    assert!((center[1].as_f64().unwrap() - 0.5).abs() < 0.01, "{center}");
    // Clicking a node makes it the preview's output ...
    browser
        .run(
            "document.querySelector('.node[data-name=\"fractal\"]').click(); return true;",
            vec![],
        )
        .await;
    poll("the node previewed", async || {
        let preview = api_state(&server)["preview"].clone();
        (preview["output"] == "fractal" && preview["stage"] == "full").then_some(())
    })
    .await;
    // ... and the page marks it.
    poll("the node marked selected", async || {
        let selected = browser
            .run(
                "return [...document.querySelectorAll('.node.selected')].map(n => n.dataset.name);",
                vec![],
            )
            .await;
        (selected == json!(["fractal"])).then_some(())
    })
    .await;
    browser.close().await;
    server.stop();
}
