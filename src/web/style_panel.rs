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
use crate::style::LoadedStyle;

/// A request of the Style panel (JSON, `type` names the kind): an [`Edit`], or Save.
/// Anything else is refused.
#[derive(Debug, Clone, PartialEq)]
pub enum StyleRequest {
    /// An edit of the style.
    Edit(Edit),
    /// Save the style: to its file, or to a new one.
    Save(SaveRequest),
}

/// Save the style (`{"type":"save", …}`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SaveRequest {
    /// A new file (must not exist); `null`: the style's own file.
    #[serde(default)]
    pub file: Option<String>,
    /// The user agreed that saving drops the file's comments.
    #[serde(default)]
    pub drop_comments: bool,
}

impl StyleRequest {
    /// Parses one request body; the error says why it is not one.
    pub fn parse(body: &str) -> Result<StyleRequest, String> {
        let bad = |e: serde_json::Error| format!("not a request the Style panel sends: {e}");
        let mut value: serde_json::Value = serde_json::from_str(body).map_err(bad)?;
        if value.get("type").and_then(|t| t.as_str()) == Some("save") {
            // Save's own fields are the others (an object: `type` was found in it).
            if let Some(fields) = value.as_object_mut() {
                fields.remove("type");
            }
            serde_json::from_value(value)
                .map(StyleRequest::Save)
                .map_err(bad)
        } else {
            serde_json::from_value(value)
                .map(StyleRequest::Edit)
                .map_err(bad)
        }
    }
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
        let req = StyleRequest::parse(body)?;
        let mut guard = self.lock();
        let editor = guard.as_mut().map_err(|reason| reason.clone())?;
        let edit = match req {
            StyleRequest::Save(SaveRequest {
                file,
                drop_comments,
            }) => {
                let message = editor.save(file.as_deref(), drop_comments)?;
                return Ok(reply(editor, message, false));
            }
            StyleRequest::Edit(edit) => edit,
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
            (r#"{"type":"select","wisp":null}"#, true),
            (r#"{"type":"mirror","wisp":"a"}"#, true),
            (r#"{"type":"save","file":"x.ron","force":true}"#, false),
            (r#"{"wisp":"a"}"#, false),
            (r#"{"type":"format_disk"}"#, false),
        ] {
            assert_eq!(StyleRequest::parse(body).is_ok(), ok, "{body}");
        }
    }
}
