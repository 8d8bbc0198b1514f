//! Interactive styling of `Generated` hair (Zhang & Wünsche 2007, §3), on the style alone:
//! move a key strand's control points in their local frames (§3.1), create, delete, paste and
//! mirror wisps and change their shape (§3.2). The editor that keeps the history, builds the
//! model and saves the file is the page's (`crate::web::style_editor`); the logger draws the
//! [`Marks`].
//!
//! - [`frames`]: key strands in the world, the local frame at a control point, mirroring
//! - [`wisps`]: the edits, each checking its input, and the page's view of the wisps

pub mod frames;
pub mod wisps;

use crate::style::Vec3;

pub use wisps::{Marks, SelectedMarks, WispView};

/// One edit, as the page asks for it (the Style panel's JSON requests, `type` naming the
/// kind; anything else is refused). Wisps are named; control points are numbered from the
/// root (0, which is implicit and stays on the scalp) to the tip.
#[derive(Debug, Clone, PartialEq, serde::Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Edit {
    /// Select a wisp (or copy), or none (`null`): its key strand is drawn highlighted.
    Select {
        /// The wisp.
        wisp: Option<String>,
    },
    /// Move control point `point` of `wisp` by `delta` metres along its local frame: the
    /// curve's tangent, the scalp normal, their perpendicular (§3.1).
    Move {
        /// The wisp.
        wisp: String,
        /// The control point, 1 = the first after the root.
        point: usize,
        /// Metres along (tangent, normal, perpendicular).
        delta: Vec3,
    },
    /// Set control point `point` to `value` in the wisp's styling frame (tangent down the
    /// scalp, scalp normal, binormal at the root), metres: the exact value a style file holds.
    SetPoint {
        /// The wisp.
        wisp: String,
        /// The control point, from 1.
        point: usize,
        /// The new position.
        value: Vec3,
    },
    /// A new wisp from the template key strand, its region centred at this scalp position
    /// (degrees).
    Create {
        /// Azimuth, degrees from the face towards +x.
        azimuth: f64,
        /// Elevation, degrees above the scalp's centre.
        elevation: f64,
    },
    /// Delete a wisp or copy.
    Delete {
        /// The wisp.
        wisp: String,
    },
    /// Copy a wisp's key strand and shape to the clipboard.
    Copy {
        /// The wisp.
        wisp: String,
    },
    /// A new wisp from the clipboard, its region centred here: the key strand is kept in its
    /// root's styling frame, so it keeps its shape relative to the new root (§3.2).
    Paste {
        /// Azimuth, degrees.
        azimuth: f64,
        /// Elevation, degrees.
        elevation: f64,
    },
    /// A new wisp, the mirror image of this one across the head's sagittal plane (Fig. 6).
    Mirror {
        /// The wisp.
        wisp: String,
    },
    /// Change a wisp's shape (§3.2): its size on the scalp, density and spread (any of them).
    Shape {
        /// The wisp.
        wisp: String,
        /// Half-widths of the region, degrees of (azimuth, elevation), about its centre.
        #[serde(default)]
        radius: Option<[f64; 2]>,
        /// Strands per cm².
        #[serde(default)]
        density: Option<f64>,
        /// Largest distance of a member's tip from the key strand, m: small is smooth, large
        /// is fringy.
        #[serde(default)]
        tip_spread: Option<f64>,
    },
    /// Go back one edit.
    Undo {},
    /// Redo the edit undone last.
    Redo {},
}
