//! wisptree: long hair animated with the Adaptive Wisp Tree (Bertails, Kim, Cani, Neumann,
//! SCA 2003), streamed live to the Rerun viewer or to a `.rrd` recording.
//!
//! The pipeline, in module order:
//!
//! ```text
//! style ──▶ model ──▶ sim (+ motion) ──▶ frame ──▶ stream (Rerun)
//!   RON      GC hierarchy   AWT step         snapshot    logging thread
//! ```
//!
//! `style`, `model`, `motion` and `sim` know nothing of Rerun; `stream` does no physics.

pub mod bench;
pub mod cli;
pub mod experiment;
pub mod frame;
pub mod model;
pub mod motion;
pub mod render;
pub mod run;
pub mod scene;
pub mod sim;
pub mod solver;
pub mod stream;
pub mod style;
pub mod tune;
