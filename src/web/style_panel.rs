//! The page's Style panel: the requests it sends to `/api/style` (checked here, then applied
//! by the [`StyleEditor`]), the panel's state every page reads, and where an accepted edit
//! goes: its regenerated model to the run (which restarts on it, keeping the tuned
//! parameters), the key strands to draw to the logger (`/style/…`). No physics and no Rerun
//! here.

use std::path::PathBuf;
use std::sync::Mutex;

use crossbeam_channel::Sender;
use serde::Deserialize;

use super::style_editor::{EditorView, StyleEditor};
use crate::model::HairModel;
use crate::style::edit::{Edit, Marks};
use crate::style::{LoadedStyle, Vec3};

/// A request of the Style panel (JSON, `type` names the kind). Anything else is refused.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum StyleRequest {
    /// Select a wisp (its key strand is drawn highlighted), or none.
    Select {
        /// The wisp, or `null`.
        wisp: Option<String>,
    },
    /// Move a control point along its local frame (tangent, normal, perpendicular), m.
    Move {
        /// The wisp.
        wisp: String,
        /// The control point (1 = the first after the root).
        point: usize,
        /// Metres along the three axes.
        delta: Vec3,
    },
    /// Set a control point to an exact value in the wisp's styling frame, m.
    SetPoint {
        /// The wisp.
        wisp: String,
        /// The control point.
        point: usize,
        /// The value.
        value: Vec3,
    },
    /// A new wisp from the template key strand at a scalp position (degrees).
    Create {
        /// Azimuth.
        azimuth: f64,
        /// Elevation.
        elevation: f64,
    },
    /// Delete a wisp.
    Delete {
        /// The wisp.
        wisp: String,
    },
    /// Copy a wisp.
    Copy {
        /// The wisp.
        wisp: String,
    },
    /// Paste the copied wisp at a scalp position (degrees).
    Paste {
        /// Azimuth.
        azimuth: f64,
        /// Elevation.
        elevation: f64,
    },
    /// A mirror image of a wisp on the other side of the head.
    Mirror {
        /// The wisp.
        wisp: String,
    },
    /// Change a wisp's shape (any of the values).
    Shape {
        /// The wisp.
        wisp: String,
        /// Half-widths of its region, degrees (azimuth, elevation).
        #[serde(default)]
        radius: Option<[f64; 2]>,
        /// Strands per cm².
        #[serde(default)]
        density: Option<f64>,
        /// Tip spread, m (smooth ↔ fringy).
        #[serde(default)]
        tip_spread: Option<f64>,
    },
    /// Undo the last edit.
    Undo {},
    /// Redo.
    Redo {},
    /// Save the style: to its file, or to a new one.
    Save {
        /// A new file (must not exist); `null`: the style's own file.
        #[serde(default)]
        file: Option<String>,
        /// The user agreed that saving drops the file's comments.
        #[serde(default)]
        drop_comments: bool,
    },
}

/// A regenerated model for the run to restart on.
pub struct StyleApplied {
    /// The edited style.
    pub loaded: LoadedStyle,
    /// Its model.
    pub model: HairModel,
    /// What the edit did, for the log.
    pub message: String,
}

/// What an accepted request answers.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StyleReply {
    /// What it did.
    pub message: String,
    /// The hair was regenerated and the simulation restarts.
    pub restart: bool,
    /// The panel's version after it.
    pub version: u64,
    /// The edited model's strand-point hash.
    pub model_hash: String,
}

/// The Style panel's side of the page server: the editor, shared by every page.
pub struct StylePanel {
    editor: Mutex<Result<StyleEditor, String>>,
    applied: Sender<StyleApplied>,
    marks: Sender<Marks>,
}

impl StylePanel {
    /// A panel for the running style (`text` is its file's, or the built-in's, text; `file`
    /// is where Save writes, `None` for a built-in style). An imported style gets a panel that
    /// says it cannot be edited. The key strands are sent to the logger at once.
    pub fn new(
        loaded: LoadedStyle,
        model: &HairModel,
        text: String,
        file: Option<PathBuf>,
        applied: Sender<StyleApplied>,
        marks: Sender<Marks>,
    ) -> StylePanel {
        let editor = StyleEditor::new(loaded, model, text, file);
        if let Ok(e) = &editor {
            let _ = marks.send(e.marks());
        }
        StylePanel {
            editor: Mutex::new(editor),
            applied,
            marks,
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Result<StyleEditor, String>> {
        self.editor.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The panel's state as JSON.
    pub fn view(&self) -> EditorView {
        match &*self.lock() {
            Ok(e) => e.view(),
            Err(reason) => EditorView::not_editable(reason.clone()),
        }
    }

    /// The watched style file `path` was reloaded by the run (see
    /// [`StyleEditor::take_file`]).
    pub fn file_changed(&self, path: &std::path::Path, loaded: &LoadedStyle) {
        if let Ok(e) = self.lock().as_mut() {
            if e.take_file(path, loaded.clone()) {
                let _ = self.marks.send(e.marks());
            }
        }
    }

    /// Whether the watched file `path` holds what the page last saved there (see
    /// [`StyleEditor::holds_own_text`]; checked under the editor's lock, so no save comes in
    /// between).
    pub fn holds_own_text(&self, path: &std::path::Path) -> bool {
        self.lock().as_ref().is_ok_and(|e| e.holds_own_text(path))
    }

    /// Parses, checks and applies one request body. The error is the message the page shows
    /// (the style is then unchanged).
    pub fn handle(&self, body: &str) -> Result<StyleReply, String> {
        let req: StyleRequest = serde_json::from_str(body)
            .map_err(|e| format!("not a request the Style panel sends: {e}"))?;
        let mut guard = self.lock();
        let editor = guard.as_mut().map_err(|reason| reason.clone())?;
        let edit = match req {
            StyleRequest::Save {
                file,
                drop_comments,
            } => {
                let message = editor.save(file.as_deref(), drop_comments)?;
                return Ok(reply(editor, message, false));
            }
            StyleRequest::Select { wisp } => Edit::Select(wisp),
            StyleRequest::Move { wisp, point, delta } => Edit::Move { wisp, point, delta },
            StyleRequest::SetPoint { wisp, point, value } => Edit::SetPoint { wisp, point, value },
            StyleRequest::Create { azimuth, elevation } => Edit::Create { azimuth, elevation },
            StyleRequest::Delete { wisp } => Edit::Delete(wisp),
            StyleRequest::Copy { wisp } => Edit::Copy(wisp),
            StyleRequest::Paste { azimuth, elevation } => Edit::Paste { azimuth, elevation },
            StyleRequest::Mirror { wisp } => Edit::Mirror(wisp),
            StyleRequest::Shape {
                wisp,
                radius,
                density,
                tip_spread,
            } => Edit::Shape {
                wisp,
                radius,
                density,
                tip_spread,
            },
            StyleRequest::Undo {} => Edit::Undo,
            StyleRequest::Redo {} => Edit::Redo,
        };
        let applied = editor.apply(edit)?;
        let _ = self.marks.send(editor.marks());
        let restart = applied.model.is_some();
        if let Some(model) = applied.model {
            let sent = self.applied.send(StyleApplied {
                loaded: editor.loaded().clone(),
                model,
                message: applied.message.clone(),
            });
            if sent.is_err() {
                return Err("the simulation has ended".to_owned());
            }
        }
        Ok(reply(editor, applied.message, restart))
    }
}

impl std::fmt::Debug for StylePanel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StylePanel").finish_non_exhaustive()
    }
}

fn reply(e: &StyleEditor, message: String, restart: bool) -> StyleReply {
    StyleReply {
        message,
        restart,
        version: e.version(),
        model_hash: format!("{:016x}", e.model_hash()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_panels_requests_are_taken() {
        for (body, ok) in [
            (
                r#"{"type":"move","wisp":"a","point":1,"delta":[0,0.01,0]}"#,
                true,
            ),
            (r#"{"type":"undo"}"#, true),
            (r#"{"type":"save","file":"x.ron"}"#, true),
            (r#"{"type":"shape","wisp":"a","density":30}"#, true),
            (
                r#"{"type":"move","wisp":"a","point":1,"delta":[0,"NaN",0]}"#,
                false,
            ),
            (
                r#"{"type":"move","wisp":"a","point":-1,"delta":[0,0,0]}"#,
                false,
            ),
            (r#"{"type":"undo","steps":5}"#, false),
            (r#"{"type":"format_disk"}"#, false),
        ] {
            assert_eq!(
                serde_json::from_str::<StyleRequest>(body).is_ok(),
                ok,
                "{body}"
            );
        }
    }
}
