//! The commands that run a simulation: `wisptree run` (simulation and logging threads, keys,
//! style reload, stop), `wisptree export`, `wisptree experiment` and `wisptree sweep`.

mod console;
pub mod experiment;
pub mod export;
mod log_thread;
mod reload;
pub mod render_cmd;
pub mod render_thread;
pub mod run;
pub mod runs_log;
mod sim_thread;
pub mod stop;
pub mod sweep;
pub mod sweep_plan;
pub mod threads;
pub mod tune;

pub use run::{run, run_with, simulate_into, RunOptions, RunSummary, WebOptions};
pub use sim_thread::{slow_motion_message, Load};
pub use stop::{stop_on_ctrl_c, StopSignal};
pub use threads::{LoopOptions, WebLink};

/// Catmull-Rom points per span between two cross-sections of a drawn strand.
pub const STRAND_SUBDIVISIONS: usize = 2;
