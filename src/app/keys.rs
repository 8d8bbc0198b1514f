//! Single-key control of a live run: which key does what, and the thresholds the keys change.

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

use crate::style::SimParams;

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
}
