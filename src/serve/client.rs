//! The HTTP side: the page, `/api/state` and one WebSocket per tab. A tab is sent the newest
//! state when it is ready for it; its requests change the shared settings (and start a new
//! generation) or are answered to it alone (hover, report, write-back).

use super::protocol::{self, Request};
use super::shared::{lock, Mode, Shared};
use super::{session, writeback};
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::State;
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Json};
use axum::routing::get;
use axum::Router;
use futures_util::{SinkExt, StreamExt};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// The page, served from the binary.
pub(super) const PAGE: &str = include_str!("page.html");

/// Largest message a tab may send (requests are small; anything bigger is hostile).
const MAX_REQUEST_BYTES: usize = 64 * 1024;
/// A tab that takes longer than this to accept one message is dropped.
const SEND_TIMEOUT: Duration = Duration::from_secs(30);

/// Starts the HTTP server's thread: a small tokio runtime serving until `shutdown`.
pub(super) fn spawn_http(
    shared: Arc<Shared>,
    listener: std::net::TcpListener,
    shutdown: tokio::sync::oneshot::Receiver<()>,
) -> Result<std::thread::JoinHandle<()>, String> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name("texgraph-serve-http")
        .enable_all()
        .build()
        .map_err(|e| format!("cannot start the server's runtime: {e}"))?;
    let app = Router::new()
        .route("/", get(|| async { Html(PAGE) }))
        .route("/api/state", get(state))
        .route("/ws", get(upgrade))
        .with_state(shared);
    std::thread::Builder::new()
        .name("texgraph-serve".into())
        .spawn(move || {
            runtime.block_on(async move {
                let Ok(listener) = tokio::net::TcpListener::from_std(listener) else {
                    return;
                };
                let server = axum::serve(listener, app);
                tokio::select! {
                    _ = server => {}
                    _ = shutdown => {}
                }
            });
            runtime.shutdown_timeout(Duration::from_secs(2));
        })
        .map_err(|e| format!("cannot start the server thread: {e}"))
}

/// The host name of a `Host` header's value (`[::1]:7878` → `[::1]`, `localhost:7878` →
/// `localhost`).
fn host_name(host: &str) -> &str {
    match host.strip_prefix('[') {
        Some(rest) => rest
            .split_once(']')
            .map_or(host, |(name, _)| &host[..name.len() + 2]),
        None => host.split(':').next().unwrap_or(host),
    }
}

/// Whether a request may read the state or open the WebSocket. A browser lets any web page
/// open a WebSocket to localhost, so a foreign `Origin` is refused (a tool without one, an
/// editor plug-in, is not a browser page and is let in); on a loopback address the `Host` must
/// name this machine, which defeats DNS rebinding (a foreign name resolving to 127.0.0.1).
fn refused(headers: &HeaderMap, loopback: bool) -> Option<String> {
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    if loopback && !matches!(host_name(host), "localhost" | "127.0.0.1" | "[::1]") {
        return Some(format!("host `{host}` is not this machine"));
    }
    let origin = headers.get(header::ORIGIN)?;
    let origin = origin.to_str().unwrap_or("");
    let origin_host = origin
        .strip_prefix("http://")
        .or_else(|| origin.strip_prefix("https://"))
        .unwrap_or("");
    (origin_host != host).then(|| format!("origin `{origin}` is not this page ({host})"))
}

fn forbidden(message: String) -> axum::response::Response {
    (StatusCode::FORBIDDEN, message).into_response()
}

/// `GET /api/state`: the newest message of each type.
async fn state(State(shared): State<Arc<Shared>>, headers: HeaderMap) -> axum::response::Response {
    if let Some(message) = refused(&headers, shared.loopback) {
        return forbidden(message);
    }
    let published = shared.state.borrow().clone();
    let mut out = serde_json::Map::new();
    for kind in [
        "hello", "settings", "graph", "preview", "slice", "nodes", "status",
    ] {
        let value = published
            .messages
            .get(kind)
            .and_then(|(_, text)| serde_json::from_str(text).ok())
            .unwrap_or(Value::Null);
        out.insert(kind.to_string(), value);
    }
    Json(Value::Object(out)).into_response()
}

async fn upgrade(
    ws: WebSocketUpgrade,
    State(shared): State<Arc<Shared>>,
    headers: HeaderMap,
) -> axum::response::Response {
    if let Some(message) = refused(&headers, shared.loopback) {
        return forbidden(message);
    }
    ws.max_message_size(MAX_REQUEST_BYTES)
        .max_frame_size(MAX_REQUEST_BYTES)
        .on_upgrade(move |socket| connection(socket, shared))
        .into_response()
}

type Sink = futures_util::stream::SplitSink<WebSocket, Message>;

/// Sends `text`, or fails when the tab is gone or too slow.
async fn send(sink: &mut Sink, text: &str) -> Result<(), ()> {
    match tokio::time::timeout(SEND_TIMEOUT, sink.send(Message::Text(text.into()))).await {
        Ok(Ok(())) => Ok(()),
        _ => Err(()),
    }
}

/// One tab: newest state out, requests in, replies out, until it goes.
async fn connection(socket: WebSocket, shared: Arc<Shared>) {
    let (mut sink, mut stream) = socket.split();
    let mut state = shared.state.subscribe();
    let mut sent: HashMap<&'static str, u64> = HashMap::new();
    let (reply_tx, mut reply_rx) = tokio::sync::mpsc::channel::<String>(8);
    state.mark_changed();
    loop {
        tokio::select! {
            changed = state.changed() => {
                if changed.is_err() {
                    break;
                }
                let published = state.borrow_and_update().clone();
                let mut failed = false;
                for (kind, (version, text)) in &published.messages {
                    if sent.get(kind).is_some_and(|v| v >= version) {
                        continue;
                    }
                    if send(&mut sink, text).await.is_err() {
                        failed = true;
                        break;
                    }
                    sent.insert(kind, *version);
                }
                if failed {
                    break;
                }
            }
            incoming = stream.next() => match incoming {
                Some(Ok(Message::Text(text))) => request(&shared, text.as_str(), &reply_tx),
                Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
                Some(Ok(_)) => {}
            },
            Some(reply) = reply_rx.recv() => {
                if send(&mut sink, &reply).await.is_err() {
                    break;
                }
            }
        }
    }
}

fn error(request: &str, message: impl Into<String>) -> String {
    json!({"type": "error", "request": request, "message": message.into()}).to_string()
}

/// Runs blocking work off the async threads and sends its reply to this tab (dropped if the
/// tab has gone or has eight replies waiting).
fn reply_with(
    reply: &tokio::sync::mpsc::Sender<String>,
    work: impl FnOnce() -> String + Send + 'static,
) {
    let reply = reply.clone();
    tokio::task::spawn_blocking(move || {
        let _ = reply.try_send(work());
    });
}

/// Handles one request of a tab.
fn request(shared: &Arc<Shared>, text: &str, reply: &tokio::sync::mpsc::Sender<String>) {
    let parsed: Result<Request, _> = serde_json::from_str(text);
    let request = match parsed {
        Ok(r) => r,
        Err(e) => {
            let _ = reply.try_send(error("unknown", format!("malformed request: {e}")));
            return;
        }
    };
    let loaded = lock(&shared.loaded).clone();
    match request {
        Request::Set { params, reset } => {
            if let Some(loaded) = &loaded {
                let known = |name: &String| loaded.graph.params().iter().any(|(p, _)| p == name);
                if let Some(unknown) = params.keys().find(|n| !known(n)) {
                    let _ = reply.try_send(error(
                        "set",
                        format!("the graph has no param \"{unknown}\""),
                    ));
                    return;
                }
            }
            let changed = {
                let mut settings = lock(&shared.settings);
                protocol::apply_set(&settings, params, reset).map(|s| *settings = s)
            };
            settings_changed(shared, "set", changed, reply);
        }
        Request::View {
            output,
            object,
            space,
            slice,
            preview_size,
            slice_size,
            thumb_size,
        } => {
            if let (Some(loaded), Some(Some(name))) = (&loaded, &output) {
                let graph = &loaded.graph;
                if graph.output(name).is_none() && !graph.named_nodes().any(|(n, _)| n == name) {
                    let _ = reply.try_send(error(
                        "view",
                        format!("the graph has no output or node \"{name}\""),
                    ));
                    return;
                }
            }
            let changed = {
                let mut settings = lock(&shared.settings);
                protocol::apply_view(
                    &settings,
                    output,
                    object,
                    space,
                    slice,
                    [preview_size, slice_size, thumb_size],
                )
                .map(|s| *settings = s)
            };
            settings_changed(shared, "view", changed, reply);
        }
        Request::Open { graph } => {
            if shared.mode != Mode::Folder || !shared.graphs.contains(&graph) {
                let _ = reply.try_send(error(
                    "open",
                    format!("\"{graph}\" is not a graph of the served folder"),
                ));
                return;
            }
            {
                let mut settings = lock(&shared.settings);
                settings.graph = Some(graph);
                settings.output = None;
                settings.params.clear();
            }
            settings_changed(shared, "open", Ok(()), reply);
        }
        Request::Hover { id, u, v } => {
            let Some(loaded) = loaded else {
                let _ = reply.try_send(error("hover", "no graph has checked yet"));
                return;
            };
            let window = lock(&shared.settings).slice.clone();
            reply_with(reply, move || {
                let point = session::slice_point(&window, u, v);
                let values = session::hover(&loaded, point);
                json!({"type": "hover", "id": id, "point": point.map(session::number_json), "values": values}).to_string()
            });
        }
        Request::Report {} => {
            let Some(loaded) = loaded else {
                let _ = reply.try_send(error("report", "no graph has checked yet"));
                return;
            };
            // One report at a time for the whole server: each takes seconds of every core.
            if shared
                .reporting
                .swap(true, std::sync::atomic::Ordering::AcqRel)
            {
                let _ = reply.try_send(error(
                    "report",
                    "a report is already running; try again when it is done",
                ));
                return;
            }
            let shared = shared.clone();
            reply_with(reply, move || {
                let answer = match session::report(&loaded) {
                    Ok(message) => message.to_string(),
                    Err(e) => error("report", e),
                };
                shared
                    .reporting
                    .store(false, std::sync::atomic::Ordering::Release);
                answer
            });
        }
        Request::Write {} => write_back(shared, loaded, reply),
    }
}

/// After a settings change: every tab is told, and a new generation starts.
fn settings_changed(
    shared: &Arc<Shared>,
    request: &str,
    changed: Result<(), String>,
    reply: &tokio::sync::mpsc::Sender<String>,
) {
    match changed {
        Ok(()) => {
            shared.publish_settings();
            shared.change(false);
        }
        Err(message) => {
            let _ = reply.try_send(error(request, message));
        }
    }
}

/// Writes the overrides into the graph file; they are then the file's values, so they are
/// dropped from the settings (the save arrives as a file change like any other).
fn write_back(
    shared: &Arc<Shared>,
    loaded: Option<Arc<session::Loaded>>,
    reply: &tokio::sync::mpsc::Sender<String>,
) {
    let Some(loaded) = loaded else {
        let _ = reply.try_send(error("write", "no graph has checked yet"));
        return;
    };
    // The values the page shows now (not necessarily rendered yet), for params the file writes.
    let values: Vec<(String, f64)> = lock(&shared.settings)
        .params
        .iter()
        .filter(|(name, _)| loaded.written.iter().any(|w| w.name == **name))
        .map(|(name, v)| (name.clone(), *v))
        .collect();
    let shared = shared.clone();
    reply_with(reply, move || {
        let file = loaded.path.display().to_string();
        if values.is_empty() {
            // Nothing differs from the file: it is left alone (no save, no reload).
            return json!({"type": "written", "file": file, "params": {}}).to_string();
        }
        if let Err(e) = writeback::write_params(&loaded.path, &values) {
            return error("write", e);
        }
        {
            let mut settings = lock(&shared.settings);
            for (name, _) in &values {
                settings.params.remove(name);
            }
        }
        shared.publish_settings();
        shared.change(true);
        let params: serde_json::Map<String, Value> =
            values.iter().map(|(k, v)| (k.clone(), json!(v))).collect();
        json!({"type": "written", "file": file, "params": params}).to_string()
    });
}
