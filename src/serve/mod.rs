//! `texgraph serve`: a local page that shows a graph's preview, slice, every node, its params
//! and its errors live while the author edits the file in their own editor (docs/serve.md).
//!
//! Three parts, by what they wait on:
//! - the **worker** (`worker.rs`, one OS thread): file events (notify) and changes from the
//!   page wake it; it checks, evaluates and renders one *generation* at a time through
//!   `session.rs`, which is library code only, and publishes each result as it is ready;
//! - the **server** (axum on a small tokio runtime): the static page, `/api/state` and one
//!   WebSocket per tab (`client.rs`);
//! - the **published state**: the newest message of each type, in a `tokio::sync::watch`
//!   channel. A tab is sent what changed when it is ready for more, so a slow tab skips
//!   intermediate states instead of queueing them or holding anyone up.
//!
//! A change bumps the generation counter at once, which cancels the work of older generations
//! at their next block of points or tile (`render::Cancel`).

mod client;
pub mod protocol;
pub mod session;
mod shared;
mod worker;
pub mod writeback;

pub use shared::Mode;
use shared::{Counters, Kick, Published, Shared};

use protocol::Settings;
use serde_json::json;
use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// Where and what to serve.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// A graph file, a scene file or a folder of graph files.
    pub input: PathBuf,
    /// The address to listen on (127.0.0.1 unless the user says otherwise).
    pub host: IpAddr,
    /// The port; 0 picks a free one.
    pub port: u16,
    /// The images' sizes when the page opens (a tab changes them with a `view` request).
    pub sizes: Sizes,
}

/// The sides in pixels of the preview, the slice and the node thumbnails.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sizes {
    pub preview: u32,
    pub slice: u32,
    pub thumb: u32,
}

impl Default for Sizes {
    /// 512, 256 and 96 pixels (docs/serve.md).
    fn default() -> Self {
        let s = Settings::default();
        Sizes {
            preview: s.preview_size,
            slice: s.slice_size,
            thumb: s.thumb_size,
        }
    }
}

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// An image size out of its range (`--preview-size` and the others).
    #[error("{0}")]
    Sizes(String),
    #[error("{}: {source}", path.display())]
    Input {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot listen on {addr}: {source}")]
    Listen {
        addr: SocketAddr,
        source: std::io::Error,
    },
    #[error("{0}")]
    Start(String),
}

/// A running server.
pub struct Server {
    addr: SocketAddr,
    shared: Arc<Shared>,
    shutdown: Option<tokio::sync::oneshot::Sender<()>>,
    http: Option<std::thread::JoinHandle<()>>,
    worker: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Blocks until the server stops (it does not, unless its thread fails).
    pub fn wait(mut self) {
        if let Some(http) = self.http.take() {
            let _ = http.join();
        }
    }

    /// Stops serving: connections are closed, the worker's current generation cancelled.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        if let Some(tx) = self.shutdown.take() {
            let _ = tx.send(());
        }
        self.shared.generation.fetch_add(1, Ordering::AcqRel);
        let _ = self.shared.kicks.send(Kick::Stop);
        for handle in [self.http.take(), self.worker.take()].into_iter().flatten() {
            let _ = handle.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.halt();
    }
}

/// The graph files of a folder, and of its subfolders one level down, sorted.
fn folder_graphs(dir: &Path) -> Result<Vec<String>, std::io::Error> {
    let mut out = Vec::new();
    let mut visit =
        |sub: &Path, prefix: &str, deep: bool| -> Result<Vec<PathBuf>, std::io::Error> {
            let mut dirs = Vec::new();
            for entry in std::fs::read_dir(sub)? {
                let path = entry?.path();
                let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
                let Some(name) = name else { continue };
                if path.is_dir() && deep && !name.starts_with('.') {
                    dirs.push(path);
                } else if name.ends_with(".ron") {
                    out.push(format!("{prefix}{name}"));
                }
            }
            Ok(dirs)
        };
    for sub in visit(dir, "", true)? {
        let prefix = format!("{}/", sub.file_name().unwrap_or_default().to_string_lossy());
        visit(&sub, &prefix, false)?;
    }
    out.sort();
    Ok(out)
}

/// What the input is: a folder, a scene file or a graph file (a file that cannot be read is
/// refused before the server starts).
fn mode_of(input: &Path) -> Result<(Mode, Vec<String>), ServeError> {
    let io = |source| ServeError::Input {
        path: input.to_path_buf(),
        source,
    };
    if std::fs::metadata(input).map_err(io)?.is_dir() {
        return Ok((Mode::Folder, folder_graphs(input).map_err(io)?));
    }
    let text = std::fs::read_to_string(input).map_err(io)?;
    match crate::render::input_kind(&text) {
        crate::render::InputKind::Scene => Ok((Mode::Scene, Vec::new())),
        crate::render::InputKind::Graph => Ok((Mode::Graph, Vec::new())),
    }
}

/// Starts serving `options.input`: binds the address, starts the worker (which checks and
/// renders the input at once) and the HTTP server, and returns.
pub fn start(options: ServeOptions) -> Result<Server, ServeError> {
    let (mode, graphs) = mode_of(&options.input)?;
    let addr = SocketAddr::new(options.host, options.port);
    let listener =
        std::net::TcpListener::bind(addr).map_err(|source| ServeError::Listen { addr, source })?;
    listener
        .set_nonblocking(true)
        .map_err(|source| ServeError::Listen { addr, source })?;
    let addr = listener
        .local_addr()
        .map_err(|source| ServeError::Listen { addr, source })?;
    let (kicks, kick_rx) = std::sync::mpsc::channel();
    let settings = protocol::apply_view(
        &Settings {
            graph: graphs.first().cloned(),
            ..Settings::default()
        },
        None,
        None,
        None,
        None,
        [
            Some(options.sizes.preview),
            Some(options.sizes.slice),
            Some(options.sizes.thumb),
        ],
    )
    .map_err(ServeError::Sizes)?;
    let shared = Arc::new(Shared {
        mode,
        loopback: options.host.is_loopback(),
        input: options.input.clone(),
        graphs,
        settings: Mutex::new(settings),
        generation: Arc::new(AtomicU64::new(1)),
        kicks,
        state: tokio::sync::watch::Sender::new(Published::default()),
        loaded: Mutex::new(None),
        reporting: std::sync::atomic::AtomicBool::new(false),
        counters: Mutex::new(Counters::default()),
    });
    shared.publish(
        "hello",
        json!({
            "type": "hello", "version": 1, "input": options.input.display().to_string(),
            "mode": mode.name(), "graphs": shared.graphs,
            "limits": {"preview": protocol::MAX_PREVIEW, "slice": protocol::MAX_SLICE,
                       "thumb": protocol::MAX_THUMB},
        }),
    );
    shared.publish_settings();
    let worker = worker::spawn(shared.clone(), kick_rx).map_err(ServeError::Start)?;
    shared.change(true);
    let (shutdown, shutdown_rx) = tokio::sync::oneshot::channel();
    let http =
        client::spawn_http(shared.clone(), listener, shutdown_rx).map_err(ServeError::Start)?;
    Ok(Server {
        addr,
        shared,
        shutdown: Some(shutdown),
        http: Some(http),
        worker: Some(worker),
    })
}

/// The page's HTML (for tests and tools that embed it).
pub fn page() -> &'static str {
    client::PAGE
}
