//! The commands that run a simulation: `wisptree run` (simulation and logging threads, keys,
//! style reload, stop), `wisptree export`, `wisptree experiment`, `wisptree sweep` and
//! `wisptree gallery` (`gallery`: the command; `gallery_page`: its HTML). `out_dir` is the
//! folder that `gallery`, `render` and `export` write their files into, never losing a user's
//! file.
//!
//! `run`, by concern, its arrows pointing down this list:
//!
//! ```text
//! run           the command: load, open the sink, announce, report the end
//! threads       start the workers, watch them from the main thread
//! reload        a saved style edit → new parameters or a new model
//! sim_thread    the simulation thread: step, fill, pace, apply controls
//! render_thread the render thread: images for the frames, skipped when behind (live)
//! log_thread    the logging thread: frames to Rerun
//! keys          which key does what
//! style_watcher the style file's settled changes
//! console       lines printed around the progress bar
//! terminal      raw mode, restored on every way out
//! stop          the one stop signal (Ctrl-C, q, the end)
//! ```
//!
//! `export` writes `.hair` and `.tfx` files itself, and a USD layer through `export_usd` (the
//! layer's prims) and `usda` (the text format); `export_space` checks the free space first.

mod console;
pub mod coverage;
pub mod experiment;
pub mod export;
mod export_space;
pub mod export_usd;
pub mod gallery;
mod gallery_page;
pub mod keys;
mod log_thread;
mod out_dir;
pub mod reload;
pub mod render_cmd;
pub mod render_thread;
pub mod run;
pub mod runs_log;
mod sim_thread;
pub mod stop;
pub mod style_watcher;
pub mod sweep;
pub mod sweep_plan;
pub mod terminal;
pub mod threads;
pub mod usda;

pub use run::{run, run_with, simulate_into, RunOptions, WebOptions};
pub use sim_thread::{slow_motion_message, Load};
pub use stop::{stop_on_ctrl_c, StopSignal};
pub use threads::{LoopOptions, RunSummary, WebLink};

/// Catmull-Rom points per span between two cross-sections of a drawn strand.
pub const STRAND_SUBDIVISIONS: usize = 2;
