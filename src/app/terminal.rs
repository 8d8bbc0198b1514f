//! Raw terminal mode for single-key control, restored on every way out (drop, panic).

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
