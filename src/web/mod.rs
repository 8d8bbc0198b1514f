//! `wisptree run --web`: a page of controls beside the Rerun web viewer.
//!
//! The stock viewer cannot host custom widgets (Rerun issue #2337) or send anything back to the
//! program (#2691), so wisptree serves its own page: the viewer embedded on one side, sliders
//! and buttons on the other. The page's requests are checked here ([`protocol`]) and handed to
//! the run as [`WebCommand`]s, which take the same path as the terminal keys and the style
//! reload; the simulation thread publishes what is in force into a [`SharedState`] that every
//! open page reads. No physics and no Rerun here.

pub mod protocol;
pub mod server;

pub use protocol::{Controls, LiveState, Param, ParamValues, SharedState, WebCommand, PARAMS};
pub use server::{ControlPage, PageConfig};
