//! The worker: one generation at a time — check the file, publish the graph, a draft preview,
//! the slice, the node thumbnails and the full preview, in that order (the first pixels come
//! first) — each step abandoned when a newer change has bumped the generation.

use super::session::{self, Loaded};
use super::shared::{lock, Kick, Mode, Shared};
use crate::render::watch::WatchList;
use crate::render::{Cancel, RenderError};
use serde_json::{json, Value};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// File events are collected this long after the last one (an editor's save is several).
const DEBOUNCE: Duration = Duration::from_millis(50);
/// ... but never longer than this after the first.
const DEBOUNCE_MAX: Duration = Duration::from_millis(300);

/// Starts the worker thread and its file watcher.
pub(super) fn spawn(
    shared: Arc<Shared>,
    kicks: Receiver<Kick>,
) -> Result<std::thread::JoinHandle<()>, String> {
    let watched: Arc<Mutex<WatchList>> = Arc::default();
    let watcher = {
        let shared = shared.clone();
        let watched = watched.clone();
        notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
            if let Ok(event) = event {
                if crate::render::watch::relevant(&event, &lock(&watched)) {
                    shared.change(true);
                }
            }
        })
        .map_err(|e| format!("watching files: {e}"))?
    };
    std::thread::Builder::new()
        .name("texgraph-serve-worker".into())
        .spawn(move || {
            let mut worker = Worker {
                shared,
                watcher,
                watched,
                watched_dirs: Vec::new(),
                last_good: None,
                latency: [None; 2],
            };
            worker.run(kicks);
        })
        .map_err(|e| format!("cannot start the worker thread: {e}"))
}

struct Worker {
    shared: Arc<Shared>,
    watcher: notify::RecommendedWatcher,
    watched: Arc<Mutex<WatchList>>,
    watched_dirs: Vec<PathBuf>,
    /// The last good graph's `params`, `outputs`, `nodes` and `imports` (kept on the page,
    /// marked stale, while the file is broken).
    last_good: Option<Value>,
    /// The last generation's save-to-draft and save-to-full times (ms), shown in `status`.
    latency: [Option<f64>; 2],
}

/// Which latency a status message records.
#[derive(Clone, Copy)]
enum Mark {
    Draft = 0,
    Full = 1,
}

/// Why a generation stopped early.
enum Stop {
    Cancelled,
    Failed,
}

impl Worker {
    fn run(&mut self, kicks: Receiver<Kick>) {
        loop {
            let Ok(Kick::Change { mut file, at }) = kicks.recv() else {
                return;
            };
            let mut since = at;
            let first = Instant::now();
            loop {
                let wait = if file { DEBOUNCE } else { Duration::ZERO };
                match kicks.recv_timeout(wait) {
                    Ok(Kick::Change { file: f, at }) => {
                        file |= f;
                        since = since.min(at);
                        if first.elapsed() > DEBOUNCE_MAX {
                            break;
                        }
                    }
                    Ok(Kick::Stop) | Err(RecvTimeoutError::Disconnected) => return,
                    Err(RecvTimeoutError::Timeout) => break,
                }
            }
            let generation = self
                .shared
                .generation
                .load(std::sync::atomic::Ordering::Acquire);
            lock(&self.shared.counters).generations += 1;
            let cancel = Cancel::new(self.shared.generation.clone(), generation);
            let result = self.generation(generation, since, &cancel);
            if let Err(Stop::Cancelled) = result {
                lock(&self.shared.counters).cancelled += 1;
            }
            self.status(
                generation,
                false,
                match result {
                    Ok(()) => "ready",
                    Err(Stop::Cancelled) => "cancelled",
                    Err(Stop::Failed) => "error",
                },
                since,
                None,
            );
        }
    }

    /// Watches the folders of `files` (not watched yet) and makes them the relevant set.
    fn watch(&mut self, files: Vec<PathBuf>) {
        use notify::{RecursiveMode, Watcher};
        let list = crate::render::watch::watch_list(&files);
        for (dir, _) in &list {
            if !self.watched_dirs.contains(dir)
                && self.watcher.watch(dir, RecursiveMode::NonRecursive).is_ok()
            {
                self.watched_dirs.push(dir.clone());
            }
        }
        let mut watched = lock(&self.watched);
        for entry in list {
            if !watched.contains(&entry) {
                watched.push(entry);
            }
        }
    }

    fn status(
        &mut self,
        generation: u64,
        busy: bool,
        stage: &str,
        since: Instant,
        mark: Option<Mark>,
    ) {
        if let Some(mark) = mark {
            self.latency[mark as usize] = Some(since.elapsed().as_secs_f64() * 1e3);
        }
        let counters = *lock(&self.shared.counters);
        let [draft, full] = self.latency;
        self.shared.publish(
            "status",
            json!({
                "type": "status", "generation": generation, "busy": busy, "stage": stage,
                "counters": counters, "save_to_draft_ms": draft, "save_to_full_ms": full,
            }),
        );
    }

    /// One generation: everything the page shows, in the order the author wants it.
    fn generation(&mut self, generation: u64, since: Instant, cancel: &Cancel) -> Result<(), Stop> {
        let shared = self.shared.clone();
        let settings = lock(&shared.settings).clone();
        self.status(generation, true, "checking", since, None);
        let mut files = Vec::new();
        // A scene: its own preview, and the nodes of its first graph.
        let scene = if shared.mode == Mode::Scene {
            let defaults = crate::render::PreviewDefaults::default();
            let scene = crate::render::load_input_tracking(&shared.input, &defaults, &mut files);
            match scene {
                Ok(scene) => Some(scene),
                Err(e) => {
                    self.watch(files);
                    return Err(self.failed(generation, render_failure(e)));
                }
            }
        } else {
            None
        };
        let path = match (&scene, shared.graph_path(&settings)) {
            (_, Some(path)) => path,
            (Some(scene), None) => match scene.textures().first() {
                Some(t) => t.graph.clone(),
                None => {
                    self.watch(files);
                    return self.scene_only(generation, since, scene, cancel);
                }
            },
            (None, None) => {
                return Err(self.failed(
                    generation,
                    (vec![], "the folder has no graph files (*.ron)\n".into()),
                ));
            }
        };
        let loaded = session::load(&path, &settings, &mut files);
        let loaded = match loaded {
            Ok(loaded) => Arc::new(loaded),
            Err(failure) => {
                self.watch(files);
                return Err(self.failed(generation, (failure.diagnostics, failure.text)));
            }
        };
        *lock(&shared.loaded) = Some(loaded.clone());
        let parts = session::graph_parts(&loaded);
        self.last_good = Some(parts.clone());
        let mut message = json!({
            "type": "graph", "generation": generation, "file": path.display().to_string(),
            "ok": true, "stale": false, "diagnostics": [], "text": "",
        });
        merge(&mut message, parts);
        shared.publish("graph", message);
        let output = session::chosen_output(&loaded.graph, &settings);
        let scene = match scene {
            Some(scene) => scene,
            None => {
                // A named node that is not an output is bound by probing the graph's nodes.
                let probe = output
                    .as_deref()
                    .is_some_and(|o| loaded.graph.output(o).is_none());
                // Only the overrides the file still has a param for (the check applied those).
                let mut view = settings.clone();
                view.params = loaded.overrides.iter().cloned().collect();
                let scene =
                    session::preview_scene(&loaded, &view, output.as_deref(), probe, &mut files);
                self.watch(files);
                scene.map_err(|e| self.render_failed(generation, e))?
            }
        };
        self.images(
            generation,
            since,
            &loaded,
            &scene,
            output.as_deref(),
            cancel,
        )
    }

    /// The draft, the slice and thumbnails, then the full preview.
    fn images(
        &mut self,
        generation: u64,
        since: Instant,
        loaded: &Loaded,
        scene: &crate::render::Scene,
        output: Option<&str>,
        cancel: &Cancel,
    ) -> Result<(), Stop> {
        let settings = lock(&self.shared.settings).clone();
        self.draft(generation, since, scene, output, cancel)?;
        self.status(generation, true, "slice", since, Some(Mark::Draft));
        if let Some(name) = output {
            let w = &settings.slice;
            let plane = session::slice(loaded, name, w, settings.slice_size, cancel)
                .ok_or(Stop::Cancelled)?;
            let range = plane.range();
            self.shared.publish("slice", json!({
                "type": "slice", "generation": generation, "output": name,
                "value_type": if plane.ty == crate::graph::Type::Scalar { "scalar" } else { "vec3" },
                "axis": w.axis, "depth": w.depth, "center": w.center, "width": w.width,
                "size": settings.slice_size, "min": range.map(|r| r.0), "max": range.map(|r| r.1),
                "png": plane.png(),
            }));
        }
        self.status(generation, true, "nodes", since, None);
        let thumbs = session::thumbnails(loaded, &settings.slice, settings.thumb_size, cancel)
            .ok_or(Stop::Cancelled)?;
        let nodes: Vec<Value> = thumbs
            .iter()
            .map(|t| {
                let range = t.plane.range();
                json!({
                    "name": t.name, "type": if t.plane.ty == crate::graph::Type::Scalar { "scalar" } else { "vec3" },
                    "min": range.map(|r| r.0), "max": range.map(|r| r.1), "png": t.plane.png(),
                    "ns_per_point": t.ns_per_point, "instructions": t.instructions,
                })
            })
            .collect();
        // The side served (smaller than asked when a large graph would not fit the bound).
        let side = thumbs.first().map_or(settings.thumb_size, |t| t.plane.side);
        let points = u64::from(side).pow(2);
        self.shared.publish(
            "nodes",
            json!({
                "type": "nodes", "generation": generation, "size": side,
                "points": points, "nodes": nodes,
            }),
        );
        self.status(generation, true, "rendering", since, None);
        self.full(generation, since, scene, output, cancel)?;
        self.status(generation, true, "ready", since, Some(Mark::Full));
        Ok(())
    }

    /// A scene whose objects use no graph: only its preview.
    fn scene_only(
        &mut self,
        generation: u64,
        since: Instant,
        scene: &crate::render::Scene,
        cancel: &Cancel,
    ) -> Result<(), Stop> {
        self.draft(generation, since, scene, None, cancel)?;
        self.full(generation, since, scene, None, cancel)
    }

    /// The first pixels: a small preview at one sample per pixel.
    fn draft(
        &mut self,
        generation: u64,
        since: Instant,
        scene: &crate::render::Scene,
        output: Option<&str>,
        cancel: &Cancel,
    ) -> Result<(), Stop> {
        let size = lock(&self.shared.settings).preview_size;
        let image = (super::protocol::DRAFT_SIZE.min(size), 1);
        self.preview(generation, since, scene, image, "draft", output, cancel)
    }

    /// The full preview: the settings' size at the scene's samples per pixel, else
    /// `render`'s default (point samples with level of detail: at equal time several of them
    /// beat one box-filtered sample, docs/filtering.md, "Renders").
    fn full(
        &mut self,
        generation: u64,
        since: Instant,
        scene: &crate::render::Scene,
        output: Option<&str>,
        cancel: &Cancel,
    ) -> Result<(), Stop> {
        let size = lock(&self.shared.settings).preview_size;
        let samples = scene.samples().unwrap_or(crate::render::DEFAULT_SAMPLES);
        self.preview(
            generation,
            since,
            scene,
            (size, samples),
            "full",
            output,
            cancel,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn preview(
        &mut self,
        generation: u64,
        since: Instant,
        scene: &crate::render::Scene,
        (size, samples): (u32, u32),
        stage: &str,
        output: Option<&str>,
        cancel: &Cancel,
    ) -> Result<(), Stop> {
        let (image, _) = match session::preview(scene, size, samples, cancel) {
            Ok(done) => done,
            Err(e) => return Err(self.render_failed(generation, e)),
        };
        let (width, height) = image.dimensions();
        self.shared.publish(
            "preview",
            json!({
                "type": "preview", "generation": generation, "stage": stage, "width": width,
                "height": height, "output": output, "png": session::png_data_url(&image),
                "millis": since.elapsed().as_secs_f64() * 1e3,
            }),
        );
        let mut counters = lock(&self.shared.counters);
        if stage == "draft" {
            counters.drafts += 1;
        } else {
            counters.fulls += 1;
        }
        Ok(())
    }

    fn render_failed(&mut self, generation: u64, e: RenderError) -> Stop {
        if matches!(e, RenderError::Cancelled) {
            return Stop::Cancelled;
        }
        self.failed(generation, render_failure(e))
    }

    /// Publishes a broken state: the diagnostics, with the last good graph's parts, stale. A
    /// generation already superseded publishes nothing and counts as cancelled: what failed may
    /// be a file read in the middle of the newer edit (the graph checked, then its preview read
    /// the next save's text).
    fn failed(&mut self, generation: u64, (diagnostics, text): (Vec<Value>, String)) -> Stop {
        if self
            .shared
            .generation
            .load(std::sync::atomic::Ordering::Acquire)
            != generation
        {
            return Stop::Cancelled;
        }
        let mut message = json!({
            "type": "graph", "generation": generation,
            "file": self.shared.input.display().to_string(), "ok": false, "stale": true,
            "diagnostics": diagnostics, "text": text,
            "params": [], "outputs": [], "nodes": [], "imports": [],
        });
        if let Some(parts) = &self.last_good {
            merge(&mut message, parts.clone());
        }
        self.shared.publish("graph", message);
        Stop::Failed
    }
}

/// Copies the fields of the object `from` into the object `into`.
fn merge(into: &mut Value, from: Value) {
    if let (Some(into), Value::Object(from)) = (into.as_object_mut(), from) {
        into.extend(from);
    }
}

/// A render's failure as the `graph` message's diagnostics and text.
fn render_failure(e: RenderError) -> (Vec<Value>, String) {
    match e {
        RenderError::Invalid(list) => {
            let diagnostics = list.iter().flat_map(session::diagnostics_json).collect();
            let text = list.iter().map(|d| d.render_plain()).collect();
            (diagnostics, text)
        }
        other => {
            let text = format!("error: {other}\n");
            let diagnostic = json!({
                "file": null, "line": null, "column": null, "class": "render", "node": null,
                "message": other.to_string(), "label": null, "help": null,
                "source_line": null, "caret": null, "chain": [],
            });
            (vec![diagnostic], text)
        }
    }
}
