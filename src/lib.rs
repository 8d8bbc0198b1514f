#![warn(missing_docs)]
//! wisptree: long hair animated with the Adaptive Wisp Tree (Bertails, Kim, Cani, Neumann,
//! SCA 2003), streamed live to the Rerun viewer or to a `.rrd` recording, beside the models the
//! AWT grew from.
//!
//! The modules, in layer order: a module uses only the modules below it. `tests/layout.rs`
//! keeps this map in step with the tree and checks the order against every `use`.
//!
//! ```text
//! cli         arguments → option structs, exit codes
//! bench       the §5.2 table and the other benchmarks
//! app         run: simulation, render and logging threads, keys, reload, stop
//! web         the control page beside the web viewer (run --web)
//! stream      the only Rerun code: sinks, entity paths, blueprint, Logger
//! experiment  the papers' experiments, each a few solvers and a number
//! render      the CPU hair renderer: camera, shadow maps, shading, rasteriser, resolve
//! pipeline    stepping a frame, filling a Frame from a solver
//! scene       the one loader: style + motion + model choice → solver
//! solver      the Solver trait, the tables of tunables, the solvers: awt/ (single-level is its mode), layered/, guides/
//! frame       the Frame snapshot: primitives, strands, body, events, stats
//! report      what a step reports: events, counters, stats, stage timers
//! files       never lose a user's file: the one moved aside to NAME.bak before a write
//! error       user errors and exit codes
//! motion      head and body motion
//! model       the multiresolution GC hierarchy, built once from a style
//! style       the RON schema, validation, generation and import
//! par         the one thread pool: nothing spawned or allocated per job
//! simd        processor-specific code, each operation with a portable twin
//! ```
//!
//! Solvers know nothing of Rerun; `stream` does no physics.

pub mod app;
pub mod bench;
pub mod cli;
pub mod error;
pub mod experiment;
pub mod files;
pub mod frame;
pub mod model;
pub mod motion;
pub mod par;
pub mod pipeline;
pub mod render;
pub mod report;
pub mod scene;
pub mod simd;
pub mod solver;
pub mod stream;
pub mod style;
pub mod web;
