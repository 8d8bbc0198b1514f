//! The terminal: lines printed around the progress bar and the raw-mode terminal, and keys.

use std::time::Duration;

use super::keys::{self, KeyAction};
use super::terminal;

/// Prints lines around the progress bar and the raw terminal.
#[derive(Clone, Default)]
pub struct Console {
    /// The progress bar, when one is shown.
    pub bar: Option<indicatif::ProgressBar>,
    /// Say nothing (a run inside `bench --live`, whose rows are the output).
    pub quiet: bool,
}

impl Console {
    /// Prints one message line (several, if it has newlines) to stderr.
    pub fn say(&self, msg: &str) {
        if self.quiet {
            return;
        }
        if let Some(b) = &self.bar {
            b.println(msg);
        } else if terminal::raw_mode_active() {
            // Raw mode: a newline does not return the carriage.
            eprint!("{}\r\n", msg.replace('\n', "\r\n"));
        } else {
            eprintln!("{msg}");
        }
    }

    /// A console with a progress bar of `frames` frames, when stderr is a terminal.
    pub fn with_progress(frames: Option<u64>) -> Console {
        use std::io::IsTerminal as _;
        let mut console = Console::default();
        if let (Some(n), true) = (frames, std::io::stderr().is_terminal()) {
            let bar = indicatif::ProgressBar::new(n);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40.cyan/blue} {pos}/{len} frames  {elapsed} elapsed, ~{eta} left  {msg}",
                )
                .expect("a valid progress template"),
            );
            console.bar = Some(bar);
        }
        console
    }
}

/// The next key press within `timeout`, as an action.
pub fn poll_key(timeout: Duration) -> std::io::Result<Option<KeyAction>> {
    use crossterm::event::{poll, read, Event};
    if !poll(timeout)? {
        return Ok(None);
    }
    Ok(match read()? {
        Event::Key(k) => keys::key_action(&k),
        _ => None,
    })
}
