//! Watching the style file of a live run: one report per settled change of its content.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;

/// How long the file must stay quiet after a change before it is read: editors write a file in
/// several steps (truncate, write, rename, chmod), and reading in the middle sees half a file.
pub const DEBOUNCE: Duration = Duration::from_millis(150);

/// Watches one style file for changes.
///
/// It watches the file's folder, not the file: editors that save by writing a new file and
/// renaming it over the old one (vim, many IDEs) replace the inode, and a watch on the old inode
/// would go silent after the first save.
pub struct StyleWatcher {
    path: PathBuf,
    // Kept alive: dropping it stops the watch.
    _watcher: notify::RecommendedWatcher,
    rx: Receiver<()>,
    /// Time of the last change not yet reported.
    pending: Option<Instant>,
    /// The text last reported, so that a save that changes nothing (or a burst of events for one
    /// save) is reported once.
    last_text: Option<String>,
}

impl StyleWatcher {
    /// Starts watching `path` (which must exist; its folder is watched).
    pub fn new(path: &Path) -> anyhow::Result<StyleWatcher> {
        use notify::Watcher as _;
        let path = path.to_path_buf();
        let name = path
            .file_name()
            .ok_or_else(|| anyhow::anyhow!("{}: not a file path", path.display()))?
            .to_os_string();
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let (tx, rx) = crossbeam_channel::unbounded();
        let mut watcher = notify::recommended_watcher(move |res: notify::Result<notify::Event>| {
            if let Ok(ev) = res {
                let ours = ev
                    .paths
                    .iter()
                    .any(|p| p.file_name() == Some(name.as_os_str()));
                let relevant = !matches!(ev.kind, notify::EventKind::Access(_));
                if ours && relevant {
                    // The receiver only goes away when the watcher does.
                    let _ = tx.send(());
                }
            }
        })
        .map_err(|e| anyhow::anyhow!("watching {}: {e}", path.display()))?;
        watcher
            .watch(&dir, notify::RecursiveMode::NonRecursive)
            .map_err(|e| anyhow::anyhow!("watching {}: {e}", dir.display()))?;
        let last_text = std::fs::read_to_string(&path).ok();
        Ok(StyleWatcher {
            path,
            _watcher: watcher,
            rx,
            pending: None,
            last_text,
        })
    }

    /// The watched file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// True once per settled change of the file's content (after [`DEBOUNCE`] of quiet).
    /// Never blocks.
    pub fn poll(&mut self) -> bool {
        while self.rx.try_recv().is_ok() {
            self.pending = Some(Instant::now());
        }
        match self.pending {
            Some(t) if t.elapsed() >= DEBOUNCE => {
                self.pending = None;
                // A missing file (between an editor's delete and rename) is a change too: the
                // reload reports it as an error, and the next write is noticed again.
                let text = std::fs::read_to_string(&self.path).ok();
                if text.is_some() && text == self.last_text {
                    return false;
                }
                self.last_text = text;
                true
            }
            _ => false,
        }
    }
}
