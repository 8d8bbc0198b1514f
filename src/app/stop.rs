//! Stopping a run: Ctrl-C, the `q` key, a lost viewer and tests all go through one
//! [`StopSignal`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use anyhow::Context as _;

/// The one way a run is told to stop. Ctrl-C, the `q` key, a lost viewer and tests all call
/// [`StopSignal::stop`].
#[derive(Debug, Clone, Default)]
pub struct StopSignal(Arc<AtomicBool>);

impl StopSignal {
    /// A signal not yet given.
    pub fn new() -> StopSignal {
        StopSignal::default()
    }
    /// Tells everything watching this signal to stop.
    pub fn stop(&self) {
        self.0.store(true, Ordering::SeqCst);
    }
    /// Whether [`StopSignal::stop`] was called.
    pub fn is_stopped(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// The signal Ctrl-C triggers. The handler can be installed once per process, so it stops
/// whichever run registered last.
static CTRL_C_TARGET: OnceLock<Mutex<Option<StopSignal>>> = OnceLock::new();

/// Makes Ctrl-C (SIGINT/SIGTERM) call `stop.stop()` instead of killing the process.
pub fn stop_on_ctrl_c(stop: &StopSignal) -> anyhow::Result<()> {
    let mut first = false;
    let target = CTRL_C_TARGET.get_or_init(|| {
        first = true;
        Mutex::new(None)
    });
    *target.lock().unwrap_or_else(|e| e.into_inner()) = Some(stop.clone());
    if first {
        ctrlc::set_handler(|| {
            if let Some(t) = CTRL_C_TARGET.get() {
                if let Some(s) = t.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                    s.stop();
                }
            }
        })
        .context("installing the Ctrl-C handler")?;
    }
    Ok(())
}
