//! The Style panel's editor: the style being edited, its undo and redo history (Zhang &
//! Wünsche 2007, §3), the model each edit regenerates, and the file it is saved to
//! ([`super::style_save`]).
//!
//! Every edit is applied to a copy of the style, checked (the style's own validation, and the
//! model built from it), and only then takes the place of the current style: a refused edit
//! changes nothing. The page ([`super::style_panel`]) turns requests into [`Edit`]s; the run
//! restarts on the model an edit returns.

use std::collections::VecDeque;
use std::path::PathBuf;

use serde::Serialize;

use crate::model::HairModel;
use crate::style::edit::{wisps, Edit, Marks, WispView};

use crate::style::{Generated, Hair, LoadedStyle, Style};

/// Undo keeps this many steps (the issue asks for at least 50).
pub const UNDO_STEPS: usize = 100;

/// What an accepted edit did.
pub struct Applied {
    /// One line for the page and the run's log.
    pub message: String,
    /// The regenerated model when the hair changed (the run restarts on it).
    pub model: Option<HairModel>,
}

/// A style state undo and redo go back to.
#[derive(Debug, Clone)]
struct Snapshot {
    style: Style,
    selected: Option<String>,
}

/// The style being edited, its history and the file it is saved to.
pub struct StyleEditor {
    pub(super) loaded: LoadedStyle,
    pub(super) model_hash: u64,
    strands: usize,
    undo: VecDeque<Snapshot>,
    redo: Vec<Snapshot>,
    clipboard: Option<crate::style::Wisp>,
    selected: Option<String>,
    /// Counts accepted changes (edits, selections, saves): pages refresh when it moves.
    pub(super) version: u64,
    /// The file Save writes without a new name (`None`: a built-in style).
    pub(super) file: Option<PathBuf>,
    /// The text of that file (or the built-in's) as last read or written: its comments are
    /// kept where an edit did not touch them.
    pub(super) text: String,
    /// The style that text holds (unsaved edits differ from it).
    pub(super) saved: Style,
    /// Whether saving now keeps the text's comments (else the page asks first).
    pub(super) keeps_comments: bool,
    /// Backups written by this editor (the next save may replace them; never another's).
    pub(super) own_backups: Vec<PathBuf>,
}

impl StyleEditor {
    /// An editor of a loaded `Generated` style whose text is `text`; `file` is where it is
    /// saved (`None` for a built-in style). An imported style cannot be edited: the error
    /// says so.
    pub fn new(
        loaded: LoadedStyle,
        model: &HairModel,
        text: String,
        file: Option<PathBuf>,
    ) -> Result<StyleEditor, String> {
        if !matches!(loaded.style.hair, Hair::Generated(_)) {
            return Err(format!(
                "{}: this style's strands are imported or given point by point, not generated \
                 from key strands, so they cannot be edited here",
                loaded.path.display()
            ));
        }
        let saved = loaded.style.clone();
        let mut e = StyleEditor {
            model_hash: model.point_hash(),
            strands: model.strands.len(),
            loaded,
            undo: VecDeque::new(),
            redo: Vec::new(),
            clipboard: None,
            selected: None,
            version: 1,
            file,
            text,
            saved,
            keeps_comments: true,
            own_backups: Vec::new(),
        };
        e.keeps_comments = e.patched_text().is_some();
        Ok(e)
    }

    /// The style as edited.
    pub fn loaded(&self) -> &LoadedStyle {
        &self.loaded
    }

    /// [`HairModel::point_hash`] of the edited style's model.
    pub fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// Counts accepted changes.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// The selected wisp or copy.
    pub fn selected(&self) -> Option<&str> {
        self.selected.as_deref()
    }

    fn generated(&self) -> &Generated {
        match &self.loaded.style.hair {
            Hair::Generated(g) => g,
            _ => unreachable!("StyleEditor::new takes Generated hair only"),
        }
    }

    /// Applies one edit, or refuses it (the message says why) and changes nothing.
    pub fn apply(&mut self, edit: Edit) -> Result<Applied, String> {
        let mut style = self.loaded.style.clone();
        let Hair::Generated(g) = &mut style.hair else {
            unreachable!("StyleEditor::new takes Generated hair only")
        };
        let scalp = self.loaded.style.head.scalp();
        let (message, selected) = match edit {
            Edit::Select { wisp: name } => {
                if let Some(n) = &name {
                    wisps::entry(g, n)?;
                }
                let msg = match &name {
                    Some(n) => format!("selected the key strand of `{n}`"),
                    None => "no key strand selected".to_owned(),
                };
                self.selected = name;
                self.version += 1;
                return Ok(Applied {
                    message: msg,
                    model: None,
                });
            }
            Edit::Copy { wisp: name } => {
                let w = wisps::resolved(g, &name)?;
                self.clipboard = Some(w);
                self.version += 1;
                return Ok(Applied {
                    message: format!("copied the wisp `{name}`: Paste puts it at a scalp position"),
                    model: None,
                });
            }
            Edit::Undo {} => return self.step_back(),
            Edit::Redo {} => return self.step_forward(),
            Edit::Move { wisp, point, delta } => {
                let msg = wisps::move_point(g, &scalp, &wisp, point, delta)?;
                (msg, Some(wisp))
            }
            Edit::SetPoint { wisp, point, value } => {
                let msg = wisps::set_point(g, &scalp, &wisp, point, value)?;
                (msg, Some(wisp))
            }
            Edit::Create { azimuth, elevation } => {
                let name = wisps::create(g, &scalp, azimuth, elevation)?;
                (format!("created the wisp `{name}`"), Some(name))
            }
            Edit::Paste { azimuth, elevation } => {
                let clip = self
                    .clipboard
                    .clone()
                    .ok_or("nothing to paste: Copy a wisp first")?;
                let name = wisps::paste(g, &scalp, clip, azimuth, elevation)?;
                (format!("pasted the wisp `{name}`"), Some(name))
            }
            Edit::Delete { wisp: name } => {
                wisps::delete(g, &name)?;
                (format!("deleted the wisp `{name}`"), None)
            }
            Edit::Mirror { wisp: name } => {
                let new = wisps::mirror(g, &name)?;
                (
                    format!("mirrored `{name}` across the head's sagittal plane: `{new}`"),
                    Some(new),
                )
            }
            Edit::Shape {
                wisp,
                radius,
                density,
                tip_spread,
            } => {
                wisps::shape(g, &wisp, radius, density, tip_spread)?;
                (format!("changed the shape of `{wisp}`"), Some(wisp))
            }
        };
        let model = self.commit(style, selected)?;
        Ok(Applied {
            message,
            model: Some(model),
        })
    }

    /// Checks `style` and builds its model; on success it becomes the current style (the
    /// old one goes on the undo stack).
    fn commit(&mut self, style: Style, selected: Option<String>) -> Result<HairModel, String> {
        let model = self.build(&style)?;
        let old = Snapshot {
            style: std::mem::replace(&mut self.loaded.style, style),
            selected: std::mem::replace(&mut self.selected, selected),
        };
        self.undo.push_back(old);
        while self.undo.len() > UNDO_STEPS {
            self.undo.pop_front();
        }
        self.redo.clear();
        self.took(&model);
        Ok(model)
    }

    /// The model of `style`, or why it cannot be built.
    fn build(&self, style: &Style) -> Result<HairModel, String> {
        crate::style::validate(style)
            .map_err(|(field, msg)| format!("not applied: field `{field}`: {msg}"))?;
        let loaded = LoadedStyle {
            style: style.clone(),
            ..self.loaded.clone()
        };
        HairModel::from_style(&loaded).map_err(|e| format!("not applied: {e}"))
    }

    /// Records a new current model.
    fn took(&mut self, model: &HairModel) {
        self.model_hash = model.point_hash();
        self.strands = model.strands.len();
        self.version += 1;
        self.keeps_comments = self.patched_text().is_some();
    }

    fn step_back(&mut self) -> Result<Applied, String> {
        let back = self.undo.back().cloned().ok_or("nothing to undo")?;
        let model = self.build(&back.style)?;
        self.undo.pop_back();
        self.redo.push(Snapshot {
            style: std::mem::replace(&mut self.loaded.style, back.style),
            selected: std::mem::replace(&mut self.selected, back.selected),
        });
        self.took(&model);
        Ok(Applied {
            message: format!("undone ({} more steps can be undone)", self.undo.len()),
            model: Some(model),
        })
    }

    fn step_forward(&mut self) -> Result<Applied, String> {
        let next = self.redo.last().cloned().ok_or("nothing to redo")?;
        let model = self.build(&next.style)?;
        self.redo.pop();
        self.undo.push_back(Snapshot {
            style: std::mem::replace(&mut self.loaded.style, next.style),
            selected: std::mem::replace(&mut self.selected, next.selected),
        });
        self.took(&model);
        Ok(Applied {
            message: format!("redone ({} more steps can be redone)", self.redo.len()),
            model: Some(model),
        })
    }

    /// What the page shows.
    pub fn view(&self) -> EditorView {
        let g = self.generated();
        let scalp = self.loaded.style.head.scalp();
        EditorView {
            version: self.version,
            editable: true,
            reason: None,
            file: self.file.as_ref().map(|p| p.display().to_string()),
            model_hash: format!("{:016x}", self.model_hash),
            strands: self.strands,
            wisps: wisps::views(g, &scalp),
            selected: self.selected.clone(),
            clipboard: self.clipboard.as_ref().map(|w| w.name.clone()),
            undo_steps: self.undo.len(),
            redo_steps: self.redo.len(),
            unsaved: self.loaded.style != self.saved,
            save_keeps_comments: self.keeps_comments,
        }
    }

    /// The style file changed on disk and the run reloaded it (`loaded`): an edit made in an
    /// editor becomes the panel's style too (one undoable step), so that the next edit on the
    /// page does not silently undo it. Saving from the page reloads the same style: then only
    /// the text is taken. True if the style changed.
    pub fn take_file(&mut self, path: &std::path::Path, loaded: LoadedStyle) -> bool {
        if self.file.as_deref() != Some(path) {
            return false;
        }
        let Ok(text) = std::fs::read_to_string(path) else {
            return false;
        };
        if !matches!(loaded.style.hair, Hair::Generated(_)) {
            return false;
        }
        if loaded.style == self.loaded.style {
            self.text = text;
            self.saved = loaded.style;
            self.keeps_comments = self.patched_text().is_some();
            return false;
        }
        let Ok(model) = self.build(&loaded.style) else {
            return false;
        };
        let old = std::mem::replace(&mut self.loaded, loaded);
        self.undo.push_back(Snapshot {
            style: old.style,
            selected: self.selected.clone(),
        });
        while self.undo.len() > UNDO_STEPS {
            self.undo.pop_front();
        }
        self.redo.clear();
        self.text = text;
        self.saved = self.loaded.style.clone();
        if self
            .selected
            .as_deref()
            .is_some_and(|n| wisps::entry(self.generated(), n).is_err())
        {
            self.selected = None;
        }
        self.took(&model);
        true
    }

    /// Whether `path` is the file this editor saves to and holds the text it last read or
    /// wrote: then a change the run's watcher sees there is the page's own save, which the
    /// run already has (its edits went ahead of it), and must not be reloaded (a reload of an
    /// older save could undo an edit made since).
    pub fn holds_own_text(&self, path: &std::path::Path) -> bool {
        self.file.as_deref() == Some(path)
            && std::fs::read_to_string(path).is_ok_and(|t| t == self.text)
    }

    /// What the logger draws: every key strand, and the selected one with its control points
    /// and local frames.
    pub fn marks(&self) -> Marks {
        wisps::marks(
            self.generated(),
            &self.loaded.style.head.scalp(),
            self.selected.as_deref(),
        )
    }
}

/// The Style panel's state as every page shows it.
#[derive(Debug, Clone, Serialize)]
pub struct EditorView {
    /// Counts accepted changes: pages refresh when it moves.
    pub version: u64,
    /// Whether the style can be edited (`Generated` hair).
    pub editable: bool,
    /// Why not, when it cannot.
    pub reason: Option<String>,
    /// The file Save writes (`None`: a built-in style; Save asks for a new file's name).
    pub file: Option<String>,
    /// The edited model's strand-point hash (as `wisptree inspect --json` prints it).
    pub model_hash: String,
    /// Strands of the edited model.
    pub strands: usize,
    /// The wisps and copies, in the style's order.
    pub wisps: Vec<WispView>,
    /// The selected wisp.
    pub selected: Option<String>,
    /// The wisp copied last.
    pub clipboard: Option<String>,
    /// Steps Undo can go back.
    pub undo_steps: usize,
    /// Steps Redo can go forward.
    pub redo_steps: usize,
    /// The edited style differs from its file.
    pub unsaved: bool,
    /// Saving keeps the file's comments (else the page asks before saving).
    pub save_keeps_comments: bool,
}

impl EditorView {
    /// The panel of a style that cannot be edited.
    pub fn not_editable(reason: String) -> EditorView {
        EditorView {
            version: 1,
            editable: false,
            reason: Some(reason),
            file: None,
            model_hash: String::new(),
            strands: 0,
            wisps: Vec::new(),
            selected: None,
            clipboard: None,
            undo_steps: 0,
            redo_steps: 0,
            unsaved: false,
            save_keeps_comments: true,
        }
    }
}
