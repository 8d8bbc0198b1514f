//! `wisptree run --web`: a page of controls beside the Rerun web viewer.
//!
//! The stock viewer cannot host custom widgets (Rerun issue #2337) or send anything back to the
//! program (#2691), so wisptree serves its own page: the viewer on one side, sliders and
//! buttons on the other. The page runs the viewer's wasm itself (served by [`server`]), which
//! hands the page its selection events: a node clicked in the 3D view is inspected
//! ([`WebCommand::Pick`]). The page's requests are checked here ([`protocol`]) against the
//! running solver's table of tunables, which the simulation thread publishes with the values in
//! force into a [`SharedState`] that every open page reads. A tunable's new value goes straight
//! to the simulation thread on a channel of its own ([`SetTunable`]); the other requests
//! (pause, restart, motion, model, inspect) are handed to the run as [`WebCommand`]s. The Style
//! panel ([`style_panel`]) edits `Generated` hair (Zhang & Wünsche 2007, §3) and hands the run
//! the regenerated model. No physics and no Rerun here.

pub mod protocol;
pub mod server;
pub mod style_editor;
pub mod style_panel;
pub mod style_save;

pub use protocol::{Controls, LiveState, SetTunable, SharedState, WebCommand};
pub use server::{ControlPage, PageConfig};
