//! Interactive tuning while `wisptree run` is live: hot-reload of the style file and keyboard
//! control.
//!
//! Nothing here touches the simulation directly. The reload side turns a saved style file into a
//! [`StyleChange`] (new parameters, a new model, or an error to show), and the keyboard side turns
//! a key into a [`KeyAction`]; `run` carries both to the simulation thread over a channel, where
//! [`apply_key`] changes the parameters in force.
//!
//! What counts as a parameter and what as geometry: the style's `sim` section is tunable in
//! place, except `total_mass` (the model's node masses are built from it). The head, the hair, the
//! hierarchy, the link and the seed describe the model itself: a change there needs a new model
//! and a restart.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use crate::model::HairModel;
use crate::style::{self, LoadedStyle, SimParams, Style, StyleError, Wind};
use crate::web::Param;

/// Factor of one key press on a threshold.
pub const KEY_STEP: f64 = 1.25;

/// What a new version of the style file means for a running simulation.
#[derive(Debug)]
pub enum StyleChange {
    /// Same model and same parameters (an editor touched the file, or only comments changed).
    Unchanged,
    /// Only tunable parameters changed: apply them in place, keep the hair's state.
    Params(Box<LoadedStyle>),
    /// The model itself changed: the new style and its freshly built model; restart.
    Geometry(Box<(LoadedStyle, HairModel)>),
    /// The edit does not load or build: keep everything as it is and show the error.
    Invalid(StyleError),
}

/// Whether going from `old` to `new` needs a new model (and so a restart) rather than new
/// parameters. The display name does not count.
pub fn geometry_changed(old: &Style, new: &Style) -> bool {
    old.seed != new.seed
        || old.head != new.head
        || old.hair != new.hair
        || old.hierarchy != new.hierarchy
        || old.link != new.link
        // Node masses are built from the total mass.
        || old.sim.total_mass != new.sim.total_mass
}

/// Reads `path` again and says what changed relative to `current`. A model is built only when
/// the geometry changed (and then with the same code as every command: `style::load` +
/// `HairModel::from_style`, as in `cli::load_model`).
pub fn reload(path: &Path, current: &Style) -> StyleChange {
    let loaded = match style::load(path) {
        Ok(l) => l,
        Err(e) => return StyleChange::Invalid(e),
    };
    if geometry_changed(current, &loaded.style) {
        return match HairModel::from_style(&loaded) {
            Ok(model) => StyleChange::Geometry(Box::new((loaded, model))),
            Err(e) => StyleChange::Invalid(e),
        };
    }
    if loaded.style.sim == current.sim {
        StyleChange::Unchanged
    } else {
        StyleChange::Params(Box::new(loaded))
    }
}

/// The names and values of the parameters that differ, `name old → new`, for the log.
pub fn describe_param_changes(old: &SimParams, new: &SimParams) -> String {
    let mut parts = Vec::new();
    let mut num = |name: &str, a: f64, b: f64| {
        if a != b {
            parts.push(format!("{name} {a} → {b}"));
        }
    };
    num("split_threshold", old.split_threshold, new.split_threshold);
    num("merge_velocity", old.merge_velocity, new.merge_velocity);
    num("friction", old.friction, new.friction);
    num("repulsion", old.repulsion, new.repulsion);
    num("angle_threshold", old.angle_threshold, new.angle_threshold);
    num("dt", old.dt, new.dt);
    num(
        "steps_per_frame",
        old.steps_per_frame as f64,
        new.steps_per_frame as f64,
    );
    num("air_drag", old.air_drag, new.air_drag);
    num("bending", old.bending, new.bending);
    num("contact_epsilon", old.contact_epsilon, new.contact_epsilon);
    num("settle", old.settle, new.settle);
    num("accel_smoothing", old.accel_smoothing, new.accel_smoothing);
    if old.gravity != new.gravity {
        parts.push(format!("gravity {:?} → {:?}", old.gravity, new.gravity));
    }
    if old.wind != new.wind {
        parts.push("wind".to_owned());
    }
    if parts.is_empty() {
        "no parameter changed".to_owned()
    } else {
        parts.join(", ")
    }
}

// ---------------------------------------------------------------------------------------------
// Watching the style file

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

// ---------------------------------------------------------------------------------------------
// Keys

/// What a key does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum KeyAction {
    /// Split threshold × [`KEY_STEP`] (fewer splits).
    SplitUp,
    /// Split threshold ÷ [`KEY_STEP`] (more splits).
    SplitDown,
    /// Merge velocity threshold × [`KEY_STEP`] (easier merges).
    MergeUp,
    /// Merge velocity threshold ÷ [`KEY_STEP`] (harder merges).
    MergeDown,
    /// Pause or resume (space).
    TogglePause,
    /// Restart with the parameters in force (r).
    Restart,
    /// Stop the run (q, Ctrl-C).
    Quit,
    /// Show the keys (h).
    Help,
}

/// The key list, as printed at start and in the README.
pub const KEY_HELP: &str = "\
keys:  S / ↑  raise split threshold (×1.25)    s / ↓  lower split threshold (÷1.25)
       M / →  raise merge velocity (×1.25)     m / ←  lower merge velocity (÷1.25)
       space  pause / resume    r  restart    q, Esc or Ctrl-C  quit    h or ?  this list";

/// The action of a key press, if it has one. Releases and repeats of a release are ignored (some
/// terminals report both presses and releases).
pub fn key_action(k: &KeyEvent) -> Option<KeyAction> {
    if k.kind == KeyEventKind::Release {
        return None;
    }
    // In raw mode the terminal does not turn Ctrl-C into SIGINT: it arrives here.
    if k.modifiers.contains(KeyModifiers::CONTROL) {
        return match k.code {
            KeyCode::Char('c') | KeyCode::Char('C') | KeyCode::Char('d') => Some(KeyAction::Quit),
            _ => None,
        };
    }
    Some(match k.code {
        KeyCode::Char('S') | KeyCode::Up => KeyAction::SplitUp,
        KeyCode::Char('s') | KeyCode::Down => KeyAction::SplitDown,
        KeyCode::Char('M') | KeyCode::Right => KeyAction::MergeUp,
        KeyCode::Char('m') | KeyCode::Left => KeyAction::MergeDown,
        KeyCode::Char(' ') | KeyCode::Char('p') => KeyAction::TogglePause,
        KeyCode::Char('r') | KeyCode::Char('R') => KeyAction::Restart,
        KeyCode::Char('q') | KeyCode::Char('Q') | KeyCode::Esc => KeyAction::Quit,
        KeyCode::Char('h') | KeyCode::Char('?') => KeyAction::Help,
        _ => return None,
    })
}

/// Applies a threshold key to `p` and returns the message for the log; `None` for the keys that
/// do not change a parameter.
pub fn apply_key(p: &mut SimParams, action: KeyAction) -> Option<String> {
    let (name, value, factor) = match action {
        KeyAction::SplitUp => ("split threshold", &mut p.split_threshold, KEY_STEP),
        KeyAction::SplitDown => ("split threshold", &mut p.split_threshold, 1.0 / KEY_STEP),
        KeyAction::MergeUp => ("merge velocity threshold", &mut p.merge_velocity, KEY_STEP),
        KeyAction::MergeDown => (
            "merge velocity threshold",
            &mut p.merge_velocity,
            1.0 / KEY_STEP,
        ),
        _ => return None,
    };
    let old = *value;
    *value = old * factor;
    let unit = if name.starts_with("split") {
        "N·m·kg⁻¹"
    } else {
        "m/s"
    };
    Some(format!("{name} {old:.4} → {:.4} {unit} (key)", *value))
}

// ---------------------------------------------------------------------------------------------
// Values set from the control page

/// The wind a wind strength of 1 gives: the style's own wind, or 1 m/s along +x when the style
/// has none (so the page's wind slider always does something).
pub fn base_wind(style_wind: &Wind) -> Wind {
    if has_wind(style_wind) {
        style_wind.clone()
    } else {
        Wind {
            velocity: [1.0, 0.0, 0.0],
            ..style_wind.clone()
        }
    }
}

/// The wind strength a style starts with: 1 (its own wind) if it has wind, else 0.
pub fn initial_wind_strength(style_wind: &Wind) -> f64 {
    if has_wind(style_wind) {
        1.0
    } else {
        0.0
    }
}

fn has_wind(w: &Wind) -> bool {
    w.velocity.iter().any(|v| *v != 0.0) || w.gust != 0.0
}

/// Sets one parameter from the control page (the value is already checked against its range
/// and α·dt < 1) and returns the message for the log. `wind_strength` is the page's wind
/// value in force; `base` the wind it scales.
pub fn apply_param(
    p: &mut SimParams,
    wind_strength: &mut f64,
    base: &Wind,
    param: Param,
    value: f64,
) -> String {
    let spec = param.spec();
    let old = match param {
        Param::SplitThreshold => std::mem::replace(&mut p.split_threshold, value),
        Param::MergeVelocity => std::mem::replace(&mut p.merge_velocity, value),
        Param::Friction => std::mem::replace(&mut p.friction, value),
        Param::Repulsion => std::mem::replace(&mut p.repulsion, value),
        Param::Wind => {
            p.wind.velocity = base.velocity.map(|v| v * value);
            p.wind.gust = base.gust * value;
            std::mem::replace(wind_strength, value)
        }
    };
    format!(
        "{} {old:.4} → {value:.4} {} (web page)",
        spec.label, spec.unit
    )
}

// ---------------------------------------------------------------------------------------------
// Raw terminal mode

/// Raw mode on stdin's terminal for single-key control, restored when dropped, and on panic by
/// a hook installed once. Hold it in a scope that every exit path leaves (return, `?`, panic).
pub struct RawTerminal {
    _private: (),
}

static RAW_ACTIVE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

impl RawTerminal {
    /// Enters raw mode if stdin and stdout are terminals; `None` otherwise (CI, pipes, tests),
    /// silently.
    pub fn enter() -> Option<RawTerminal> {
        use std::io::IsTerminal as _;
        if !std::io::stdin().is_terminal() || !std::io::stderr().is_terminal() {
            return None;
        }
        install_panic_hook();
        crossterm::terminal::enable_raw_mode().ok()?;
        RAW_ACTIVE.store(true, std::sync::atomic::Ordering::SeqCst);
        Some(RawTerminal { _private: () })
    }
}

impl Drop for RawTerminal {
    fn drop(&mut self) {
        restore_terminal();
    }
}

/// Leaves raw mode if it is on. Idempotent.
pub fn restore_terminal() {
    if RAW_ACTIVE.swap(false, std::sync::atomic::Ordering::SeqCst) {
        let _ = crossterm::terminal::disable_raw_mode();
    }
}

/// Whether raw mode is on (lines printed then need `\r\n`).
pub fn raw_mode_active() -> bool {
    RAW_ACTIVE.load(std::sync::atomic::Ordering::SeqCst)
}

fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // Restore first, so the panic message is readable.
            restore_terminal();
            previous(info);
        }));
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threshold_keys_scale_by_the_step_and_undo_each_other() {
        let mut p = SimParams::default();
        let s0 = p.split_threshold;
        let m0 = p.merge_velocity;
        let msg = apply_key(&mut p, KeyAction::SplitUp).unwrap();
        assert!((p.split_threshold - s0 * KEY_STEP).abs() < 1e-12);
        assert!(msg.contains("split threshold"), "{msg}");
        apply_key(&mut p, KeyAction::SplitDown).unwrap();
        assert!((p.split_threshold - s0).abs() < 1e-12);
        apply_key(&mut p, KeyAction::MergeDown).unwrap();
        assert!((p.merge_velocity - m0 / KEY_STEP).abs() < 1e-12);
        assert!(
            (p.split_threshold - s0).abs() < 1e-12,
            "merge keys leave the split threshold"
        );
        assert!(apply_key(&mut p, KeyAction::Restart).is_none());
    }

    #[test]
    fn ctrl_c_quits_and_plain_c_does_nothing() {
        let ctrl_c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert_eq!(key_action(&ctrl_c), Some(KeyAction::Quit));
        let c = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE);
        assert_eq!(key_action(&c), None);
        let s = KeyEvent::new(KeyCode::Char('S'), KeyModifiers::SHIFT);
        assert_eq!(key_action(&s), Some(KeyAction::SplitUp));
    }

    #[test]
    fn geometry_and_parameters_are_told_apart() {
        let text =
            std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/long.ron"))
                .unwrap();
        let a = style::parse(Path::new("long.ron"), &text).unwrap().style;
        let mut b = a.clone();
        b.sim.split_threshold *= 2.0;
        assert!(!geometry_changed(&a, &b));
        b.sim.total_mass *= 2.0;
        assert!(geometry_changed(&a, &b));
        let mut c = a.clone();
        c.hierarchy.levels = 2;
        assert!(geometry_changed(&a, &c));
        let mut d = a.clone();
        d.name = "renamed".into();
        assert!(!geometry_changed(&a, &d));
    }

    #[test]
    fn the_pages_values_set_their_parameter_and_wind_scales_the_styles_wind() {
        let mut p = SimParams::default();
        let mut strength = initial_wind_strength(&p.wind);
        assert_eq!(strength, 0.0, "the default style has no wind");
        let base = base_wind(&p.wind);
        let msg = apply_param(&mut p, &mut strength, &base, Param::SplitThreshold, 0.42);
        assert_eq!(p.split_threshold, 0.42);
        assert!(
            msg.contains("split threshold") && msg.contains("0.4200"),
            "{msg}"
        );
        apply_param(&mut p, &mut strength, &base, Param::MergeVelocity, 0.07);
        apply_param(&mut p, &mut strength, &base, Param::Friction, 12.0);
        apply_param(&mut p, &mut strength, &base, Param::Repulsion, 900.0);
        assert_eq!(
            (p.merge_velocity, p.friction, p.repulsion),
            (0.07, 12.0, 900.0)
        );
        // No wind in the style: the strength is m/s along +x.
        apply_param(&mut p, &mut strength, &base, Param::Wind, 2.0);
        assert_eq!((p.wind.velocity, strength), ([2.0, 0.0, 0.0], 2.0));
        // A style's own wind is scaled, gusts too.
        let styled = Wind {
            velocity: [0.0, 0.0, -1.5],
            gust: 0.4,
            ..Wind::default()
        };
        assert_eq!(initial_wind_strength(&styled), 1.0);
        let base = base_wind(&styled);
        apply_param(&mut p, &mut strength, &base, Param::Wind, 0.5);
        assert_eq!((p.wind.velocity, p.wind.gust), ([0.0, 0.0, -0.75], 0.2));
    }
}
