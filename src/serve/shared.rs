//! The state the worker, the watcher callback and every connection share: the settings, the
//! generation counter, the newest published message of each type.

use super::protocol::Settings;
use super::session;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// What `serve` was given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Graph,
    Scene,
    Folder,
}

impl Mode {
    pub(super) fn name(self) -> &'static str {
        match self {
            Mode::Graph => "graph",
            Mode::Scene => "scene",
            Mode::Folder => "folder",
        }
    }
}

/// The newest message of each type, each with the version it was published at.
#[derive(Clone, Debug, Default)]
pub(crate) struct Published {
    pub messages: BTreeMap<&'static str, (u64, Arc<str>)>,
    next: u64,
}

/// Counts shown in `status` messages (and read by the tests).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub(crate) struct Counters {
    pub generations: u64,
    pub drafts: u64,
    pub fulls: u64,
    pub cancelled: u64,
}

/// A reason for the worker to start a generation.
pub(crate) enum Kick {
    /// A watched file changed (debounced) or the page changed something.
    Change {
        file: bool,
        at: std::time::Instant,
    },
    Stop,
}

/// State shared by the worker, the watcher callback and every connection.
pub(crate) struct Shared {
    pub mode: Mode,
    /// Listening on a loopback address: requests must name this machine as their host.
    pub loopback: bool,
    pub input: PathBuf,
    /// Folder mode: the graph files listed (relative to the folder).
    pub graphs: Vec<String>,
    pub settings: Mutex<Settings>,
    pub generation: Arc<AtomicU64>,
    pub kicks: std::sync::mpsc::Sender<Kick>,
    pub state: tokio::sync::watch::Sender<Published>,
    pub loaded: Mutex<Option<Arc<session::Loaded>>>,
    /// A `report` request is running (one at a time).
    pub reporting: std::sync::atomic::AtomicBool,
    pub counters: Mutex<Counters>,
}

/// A `Mutex` whose holder panicked still holds consistent data here (every critical section
/// only assigns): use it rather than poisoning the server.
pub(crate) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Shared {
    /// Publishes `message` (an object with its `type`) to every tab and `/api/state`.
    pub fn publish(&self, kind: &'static str, message: Value) {
        let text: Arc<str> = message.to_string().into();
        self.state.send_modify(|p| {
            p.next += 1;
            let version = p.next;
            p.messages.insert(kind, (version, text));
        });
    }

    /// Starts a new generation: older work is cancelled at its next check.
    pub fn change(&self, file: bool) {
        self.generation.fetch_add(1, Ordering::AcqRel);
        let _ = self.kicks.send(Kick::Change {
            file,
            at: std::time::Instant::now(),
        });
    }

    pub fn publish_settings(&self) {
        let settings = lock(&self.settings).clone();
        let mut message = serde_json::to_value(&settings).expect("settings serialise");
        message["type"] = json!("settings");
        self.publish("settings", message);
    }

    /// The graph file shown now.
    pub fn graph_path(&self, settings: &Settings) -> Option<PathBuf> {
        match self.mode {
            Mode::Graph => Some(self.input.clone()),
            Mode::Folder => settings.graph.as_ref().map(|g| self.input.join(g)),
            // The scene's first graph, found when the scene is loaded.
            Mode::Scene => None,
        }
    }
}
