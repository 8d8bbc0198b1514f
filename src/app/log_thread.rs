//! The logging thread: hands each frame to the [`Logger`] and the emptied frame back.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use crossbeam_channel::{Receiver, Sender};

use crate::frame::Frame;
use crate::stream::sink::Recording;
use crate::stream::{Logger, LoggerSetup, MessageLevel};

/// Flush timeout for live sinks at the end.
const LIVE_FLUSH_TIMEOUT: Duration = Duration::from_secs(5);

/// The logging thread's inputs.
pub struct LogThread {
    /// Where to log.
    pub rec: Recording,
    /// What the logger logs once.
    pub setup: LoggerSetup,
    /// Filled frames from the simulation thread.
    pub frames: Receiver<Frame>,
    /// Emptied frames back to it.
    pub free: Sender<Frame>,
    /// Messages from the main thread (reload warnings).
    pub notes: Receiver<(MessageLevel, String)>,
    /// A live viewer: flush with a timeout at the end.
    pub live: bool,
    /// The Style panel's key strands to draw (`run --web`).
    pub style_marks: Option<Receiver<crate::style::edit::Marks>>,
}

impl LogThread {
    /// Logs until the simulation thread hangs up, then flushes. Counts frames in `logged`.
    pub fn run(self, logged: &AtomicU64) -> anyhow::Result<()> {
        let mut setup = self.setup;
        let mut logger = Logger::new(self.rec.clone(), &setup)?;
        let mut notes = self.notes;
        let mut marks = self.style_marks.unwrap_or_else(crossbeam_channel::never);
        // The Style panel's marks drawn last, drawn again by a new logger.
        let mut last_marks: Option<crate::style::edit::Marks> = None;
        loop {
            crossbeam_channel::select! {
                recv(self.frames) -> f => match f {
                    Ok(frame) => {
                        if frame.levels != setup.levels {
                            // A restart on a model with another number of levels: new
                            // annotation classes and per-level series.
                            setup.levels = frame.levels;
                            logger = Logger::new(self.rec.clone(), &setup)?;
                            if let Some(m) = &last_marks {
                                logger.log_style_marks(m)?;
                            }
                        }
                        logger.log_frame(&frame)?;
                        logged.fetch_add(1, Ordering::Relaxed);
                        // The simulation may have stopped; then the frame is simply freed.
                        let _ = self.free.send(frame);
                    }
                    Err(_) => break,
                },
                recv(notes) -> n => match n {
                    Ok((level, text)) => logger.log_message(level, &text)?,
                    // Closed: stop selecting on it (a closed channel is always ready).
                    Err(_) => notes = crossbeam_channel::never(),
                },
                recv(marks) -> m => match m {
                    Ok(m) => {
                        logger.log_style_marks(&m)?;
                        last_marks = Some(m);
                    }
                    Err(_) => marks = crossbeam_channel::never(),
                },
            }
        }
        for (level, text) in notes.try_iter() {
            logger.log_message(level, &text)?;
        }
        if self.live {
            logger.flush_with_timeout(LIVE_FLUSH_TIMEOUT)
        } else {
            logger.flush()
        }
    }
}
