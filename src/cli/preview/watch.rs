//! The preview's file watcher: every file the scene read, watched through its folder (editors
//! save by writing a new file and renaming it over the old one, which a watch on the file itself
//! would lose), with a quiet period so that a burst of saves is one reload.

use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use notify::{EventKind, RecursiveMode, Watcher as _};

use super::{lock, Shared};

/// How long the files must stay unchanged before a reload: an editor's save (write, rename,
/// attribute change) and a script's burst of writes are one reload.
pub(crate) const QUIET: Duration = Duration::from_millis(150);

/// The files a render depends on, as the watcher compares paths (folder canonicalised, so
/// `scenes/../scenes/a.json` and `/abs/scenes/a.json` are one file).
pub(crate) struct Files {
    /// Every file the last successful load read (and the scene file).
    files: HashSet<PathBuf>,
    /// Folders of those files, watched.
    dirs: HashSet<PathBuf>,
    /// The last load failed: any change in a watched folder may fix it (a texture the scene
    /// names but that did not exist, say), so any change there reloads.
    relaxed: bool,
    /// Files never to react to: the save button's output.
    ignored: HashSet<PathBuf>,
    /// The OS watcher: folders are added and removed as the scene's files change, at once, so
    /// that a change right after a load is not missed.
    watcher: notify::RecommendedWatcher,
}

/// `path` with its folder canonicalised (the file itself may not exist).
fn key(path: &Path) -> PathBuf {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match (dir.canonicalize(), path.file_name()) {
        (Ok(d), Some(name)) => d.join(name),
        _ => path.to_path_buf(),
    }
}

impl Files {
    fn new(scene: &[PathBuf], output: &Path, watcher: notify::RecommendedWatcher) -> Files {
        let mut f = Files {
            files: HashSet::new(),
            dirs: HashSet::new(),
            relaxed: false,
            ignored: HashSet::from([key(output)]),
            watcher,
        };
        f.set(scene.to_vec(), SystemTime::now());
        f
    }

    /// The files the scene read, after a successful load that started at `loaded_at` (the
    /// scene file among them). Returns whether one of them changed since then in a folder that
    /// was not watched yet: such a change had no event, and the load is stale.
    pub(crate) fn set(&mut self, files: Vec<PathBuf>, loaded_at: SystemTime) -> bool {
        self.files = files.iter().map(|f| key(f)).collect();
        let dirs: HashSet<PathBuf> = self
            .files
            .iter()
            .filter_map(|f| f.parent().map(Path::to_path_buf))
            .collect();
        for d in self.dirs.difference(&dirs) {
            let _ = self.watcher.unwatch(d);
        }
        let mut stale = false;
        for d in dirs.difference(&self.dirs) {
            if let Err(e) = self.watcher.watch(d, RecursiveMode::NonRecursive) {
                eprintln!("warning: cannot watch {}: {e}", d.display());
            }
            stale |= self.files.iter().any(|f| {
                f.parent() == Some(d.as_path())
                    && std::fs::metadata(f)
                        .and_then(|m| m.modified())
                        .is_ok_and(|t| t > loaded_at)
            });
        }
        self.dirs = dirs;
        self.relaxed = false;
        stale
    }

    /// The load failed: keep watching what was watched, and react to any change there.
    pub(crate) fn load_failed(&mut self) {
        self.relaxed = true;
    }

    /// Whether a change of `path` may change the render.
    fn concerns(&self, path: &Path) -> bool {
        let k = key(path);
        if self.ignored.contains(&k) {
            return false;
        }
        if self.files.contains(&k) {
            return true;
        }
        // lumo's own temporary files (atomic writes) never matter.
        let ours = k
            .file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with(".lumo-"));
        self.relaxed && !ours && k.parent().is_some_and(|d| self.dirs.contains(d))
    }
}

/// The running watcher: reloads are triggered through `triggers`; the reload loop updates `files`.
pub(crate) struct Watcher {
    /// One message per reload to do.
    pub triggers: Receiver<()>,
    /// What to watch, updated by the reload loop after each load.
    pub files: Arc<Mutex<Files>>,
}

impl Watcher {
    /// Starts watching the scene's own files (the scene and the `--patch` file; the reload loop
    /// adds what the scene reads once loaded).
    pub(crate) fn start(shared: Arc<Shared>, scene: &[PathBuf]) -> notify::Result<Watcher> {
        let (events_tx, events) = channel();
        let watcher = notify::recommended_watcher(move |event| {
            let _ = events_tx.send(event);
        })?;
        let files = Arc::new(Mutex::new(Files::new(scene, shared.output(), watcher)));
        let (triggers_tx, triggers) = channel();
        let thread_files = Arc::clone(&files);
        std::thread::Builder::new()
            .name("lumo-preview-watch".into())
            .spawn(move || run(&events, &triggers_tx, &thread_files, &shared))?;
        Ok(Watcher { triggers, files })
    }
}

/// The watcher thread: stops the render on every relevant change, and triggers a reload once
/// the files have been quiet for [`QUIET`].
fn run(
    events: &Receiver<notify::Result<notify::Event>>,
    triggers: &Sender<()>,
    files: &Mutex<Files>,
    shared: &Shared,
) {
    let mut last_change: Option<Instant> = None;
    loop {
        if last_change.is_some_and(|t| t.elapsed() >= QUIET) {
            last_change = None;
            if triggers.send(()).is_err() {
                return;
            }
        }
        let wait = match last_change {
            Some(t) => QUIET.saturating_sub(t.elapsed()),
            None => Duration::from_secs(3600),
        };
        match events.recv_timeout(wait) {
            Ok(Ok(event)) => {
                if matches!(event.kind, EventKind::Access(_)) {
                    continue;
                }
                let f = lock(files);
                if event.paths.iter().any(|p| f.concerns(p)) {
                    shared.note_change();
                    last_change = Some(Instant::now());
                }
            }
            Ok(Err(e)) => eprintln!("warning: file watcher: {e}"),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}
