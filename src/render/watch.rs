//! `texgraph watch`: a scene or graph rendered to a PNG, again after each edit of it or of a file
//! it reads (imports, meshes), keeping the last good image when an edit breaks something. The
//! folders of the watched files are watched (editors save by renaming), events filtered to
//! writes of those files and coalesced over 100 ms. `texgraph serve` shares the filter
//! (`relevant`, `watch_list`).

use super::{
    load_input_tracking, render, PreviewDefaults, RenderError, RenderOptions, RenderStats,
    RenderedImage,
};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// `texgraph watch`: renders a scene or graph to a PNG, again after each edit, and keeps the
/// last good image when an edit breaks something.
#[derive(Debug)]
pub struct Previewer {
    input: PathBuf,
    defaults: PreviewDefaults,
    options: RenderOptions,
    output: PathBuf,
    last_good: Option<RenderedImage>,
    files: Vec<PathBuf>,
}

impl Previewer {
    /// A previewer of `input` (a scene or graph file) writing `output`. Nothing is read until
    /// [`reload`](Previewer::reload).
    pub fn new(
        input: impl Into<PathBuf>,
        defaults: PreviewDefaults,
        options: RenderOptions,
        output: impl Into<PathBuf>,
    ) -> Previewer {
        let input = input.into();
        Previewer {
            files: vec![input.clone()],
            input,
            defaults,
            options,
            output: output.into(),
            last_good: None,
        }
    }

    /// Re-reads the input (and the graphs and meshes it uses), renders it and writes the output
    /// image. On any error the last good image — in memory and on disk — is kept and the
    /// diagnostic returned (rendered with file:line:column by its `Display`).
    pub fn reload(&mut self) -> Result<RenderStats, RenderError> {
        let mut files = Vec::new();
        let started = Instant::now();
        let result =
            load_input_tracking(&self.input, &self.defaults, &mut files).and_then(|scene| {
                let load_seconds = started.elapsed().as_secs_f64();
                let (image, mut stats) = render(&scene, &self.options)?;
                image.write_png(&self.output)?;
                stats.load_seconds = load_seconds;
                stats.total_seconds = started.elapsed().as_secs_f64();
                Ok((image, stats))
            });
        // Watch what this attempt read as well as what earlier ones did: a scene broken before
        // it names its graphs still depends on them.
        for f in files {
            if !self.files.contains(&f) {
                self.files.push(f);
            }
        }
        let (image, stats) = result?;
        self.last_good = Some(image);
        Ok(stats)
    }

    /// The last image rendered without error.
    pub fn image(&self) -> Option<&RenderedImage> {
        self.last_good.as_ref()
    }

    /// The files whose changes trigger a reload.
    pub fn watched_files(&self) -> &[PathBuf] {
        &self.files
    }

    pub fn output(&self) -> &Path {
        &self.output
    }
}

/// Watched files as (canonical folder, file name).
pub(crate) type WatchList = Vec<(PathBuf, std::ffi::OsString)>;

/// Whether a file-system event can change what the previewer renders.
pub(crate) fn relevant(event: &notify::Event, watched: &[(PathBuf, std::ffi::OsString)]) -> bool {
    use notify::event::{AccessKind, AccessMode, EventKind};
    let kind_matters = match event.kind {
        EventKind::Create(_) | EventKind::Modify(_) | EventKind::Remove(_) | EventKind::Any => true,
        EventKind::Access(AccessKind::Close(AccessMode::Write)) => true,
        // Reading the files (as a reload does) must not trigger another reload.
        EventKind::Access(_) | EventKind::Other => false,
    };
    kind_matters
        && event.paths.iter().any(|p| {
            let (Some(dir), Some(name)) = (p.parent(), p.file_name()) else {
                return false;
            };
            let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
            watched.iter().any(|(d, n)| *d == dir && n == name)
        })
}

/// The folders to watch and the (folder, name) pairs that matter. Folders rather than files:
/// editors often save by writing a new file and renaming it over the old one.
pub(crate) fn watch_list(files: &[PathBuf]) -> WatchList {
    files
        .iter()
        .filter_map(|f| {
            let name = f.file_name()?.to_os_string();
            let dir = match f.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            };
            let dir = dir.canonicalize().ok()?;
            Some((dir, name))
        })
        .collect()
}

/// Renders once, then again whenever a watched file changes, calling `on_refresh` after each
/// attempt with its result (print it; return `ControlFlow::Break(())` to stop). A broken edit
/// keeps the last good image. Bursts of events (an editor's save) are coalesced over 100 ms.
pub fn watch(
    previewer: &mut Previewer,
    mut on_refresh: impl FnMut(&Result<RenderStats, RenderError>) -> ControlFlow<()>,
) -> Result<(), RenderError> {
    use notify::{RecursiveMode, Watcher};
    let (tx, rx) = std::sync::mpsc::channel();
    let mut watcher = notify::recommended_watcher(move |event| {
        let _ = tx.send(event);
    })?;
    let mut watched_dirs: Vec<PathBuf> = Vec::new();
    // Watches every folder of `files` not watched yet.
    let mut watch_folders = |watcher: &mut notify::RecommendedWatcher,
                             files: &[PathBuf]|
     -> Result<WatchList, RenderError> {
        let list = watch_list(files);
        for (dir, _) in &list {
            if !watched_dirs.contains(dir) {
                watcher.watch(dir, RecursiveMode::NonRecursive)?;
                watched_dirs.push(dir.clone());
            }
        }
        Ok(list)
    };
    // The input's folder is watched before the first render, and each render's files before
    // its result is reported: a save made meanwhile is not missed.
    watch_folders(&mut watcher, previewer.watched_files())?;
    let mut refresh = |previewer: &mut Previewer,
                       watcher: &mut notify::RecommendedWatcher|
     -> Result<(ControlFlow<()>, WatchList), RenderError> {
        let result = previewer.reload();
        let list = watch_folders(watcher, previewer.watched_files())?;
        Ok((on_refresh(&result), list))
    };
    let (flow, mut list) = refresh(previewer, &mut watcher)?;
    if flow.is_break() {
        return Ok(());
    }
    loop {
        let Ok(event) = rx.recv() else {
            return Ok(());
        };
        match event {
            Ok(event) if relevant(&event, &list) => {}
            Ok(_) => continue,
            Err(e) => return Err(e.into()),
        }
        // Let the save finish: swallow the rest of the burst.
        while rx.recv_timeout(Duration::from_millis(100)).is_ok() {}
        let (flow, new_list) = refresh(previewer, &mut watcher)?;
        list = new_list;
        if flow.is_break() {
            return Ok(());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn watch_reacts_to_writes_of_watched_files_only() {
        use notify::event::{AccessKind, AccessMode, CreateKind, EventKind, ModifyKind};
        let dir = tempfile::tempdir().unwrap();
        let graph = dir.path().join("g.ron");
        std::fs::write(&graph, "Graph()").unwrap();
        let list = watch_list(&[graph.clone(), dir.path().join("gone/x.ron")]);
        assert_eq!(list.len(), 1, "a file in a missing folder is not watched");
        let canonical = dir.path().canonicalize().unwrap();
        let event = |kind, name: &str| notify::Event::new(kind).add_path(canonical.join(name));
        let modify = EventKind::Modify(ModifyKind::Any);
        assert!(relevant(&event(modify, "g.ron"), &list));
        assert!(relevant(
            &event(EventKind::Create(CreateKind::File), "g.ron"),
            &list
        ));
        assert!(relevant(
            &event(
                EventKind::Access(AccessKind::Close(AccessMode::Write)),
                "g.ron"
            ),
            &list
        ));
        // Reading the graph (as a reload does) or writing the output image next to it does not
        // trigger a reload.
        assert!(!relevant(
            &event(
                EventKind::Access(AccessKind::Open(AccessMode::Read)),
                "g.ron"
            ),
            &list
        ));
        assert!(!relevant(
            &event(
                EventKind::Access(AccessKind::Close(AccessMode::Read)),
                "g.ron"
            ),
            &list
        ));
        assert!(!relevant(&event(modify, "preview.png"), &list));
        assert!(!relevant(
            &event(modify, ".preview.png.x1y2.partial"),
            &list
        ));
    }
}
