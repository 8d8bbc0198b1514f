//! Single-key control of a live run: which key does what, and the thresholds the keys change.

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use crate::solver::Solver;

/// Factor of one key press on a threshold.
pub const KEY_STEP: f64 = 1.25;

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

/// The tunable a threshold key changes, and the factor of one press.
fn key_tunable(action: KeyAction) -> Option<(&'static str, f64)> {
    Some(match action {
        KeyAction::SplitUp => ("split_threshold", KEY_STEP),
        KeyAction::SplitDown => ("split_threshold", 1.0 / KEY_STEP),
        KeyAction::MergeUp => ("merge_velocity", KEY_STEP),
        KeyAction::MergeDown => ("merge_velocity", 1.0 / KEY_STEP),
        _ => return None,
    })
}

/// Applies a threshold key to the running solver through its table of tunables (the value
/// stays inside the entry's range) and returns the message for the log; `None` for the keys
/// that do not change a parameter.
pub fn apply_key(solver: &mut dyn Solver, action: KeyAction) -> Option<String> {
    let (name, factor) = key_tunable(action)?;
    let Some(entry) = crate::solver::tunable::find(solver.tunables(), name) else {
        return Some(format!(
            "model {} has no {name} (key ignored)",
            solver.kind()
        ));
    };
    let old = entry.value(&solver.tuning());
    let new = (old * factor).clamp(entry.min, entry.max);
    Some(match solver.set_tunable(name, new) {
        Ok(_) => format!("{} (key)", entry.describe_change(old, new)),
        Err(e) => format!("key not applied: {e}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::scene::Scene;
    use crate::solver::SolverKind;

    fn solver(kind: SolverKind) -> Box<dyn Solver> {
        let mut scene = Scene::load("short", "still", kind).unwrap();
        scene.loaded.style.sim.settle = 0.0;
        // A few strands are enough to hold parameters.
        scene.solver()
    }

    #[test]
    fn threshold_keys_scale_by_the_step_and_undo_each_other() {
        let mut s = solver(SolverKind::Awt);
        let get = |s: &dyn Solver| (s.params().split_threshold, s.params().merge_velocity);
        let (s0, m0) = get(&*s);
        let msg = apply_key(&mut *s, KeyAction::SplitUp).unwrap();
        assert!((get(&*s).0 - s0 * KEY_STEP).abs() < 1e-12);
        assert!(msg.contains("split threshold"), "{msg}");
        apply_key(&mut *s, KeyAction::SplitDown).unwrap();
        assert!((get(&*s).0 - s0).abs() < 1e-12);
        apply_key(&mut *s, KeyAction::MergeDown).unwrap();
        assert!((get(&*s).1 - m0 / KEY_STEP).abs() < 1e-12);
        assert!(
            (get(&*s).0 - s0).abs() < 1e-12,
            "merge keys leave the split threshold"
        );
        assert!(apply_key(&mut *s, KeyAction::Restart).is_none());
        // The table's range holds: many presses stop at the slider's end.
        for _ in 0..40 {
            apply_key(&mut *s, KeyAction::SplitDown).unwrap();
        }
        assert_eq!(get(&*s).0, 0.05);
    }

    #[test]
    fn a_model_without_thresholds_says_so_and_keeps_its_values() {
        let mut s = solver(SolverKind::Layered);
        let before = s.tuning();
        let msg = apply_key(&mut *s, KeyAction::SplitUp).unwrap();
        assert!(
            msg.contains("model layered has no split_threshold"),
            "{msg}"
        );
        assert_eq!(s.tuning(), before);
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
}
