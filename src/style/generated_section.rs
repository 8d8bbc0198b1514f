//! The `Generated(..)` hair of a style: wisps grown on scalp regions from key strands, and
//! their copies (Zhang & Wünsche 2007, §3). What the fields mean; `super::generate` grows them.

use serde::{Deserialize, Serialize};

use super::schema::Vec3;

/// Generated hair: wisps on scalp regions, plus copies and mirror images of them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Generated {
    /// Strands per square centimetre of scalp region, used by every wisp that does not give its
    /// own. Default 20 (about 10,000 strands on a full scalp; real hair has ~150/cm², of which
    /// we simulate and draw a representative subset).
    #[serde(default = "default_density")]
    pub density: f64,
    /// Points each generated strand is sampled with before resampling to K cross-sections.
    /// Default 32.
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// The wisps, each grown on its own region.
    pub wisps: Vec<Wisp>,
    /// Copies of wisps (optionally mirrored left↔right), by name. Default: none.
    #[serde(default)]
    pub copies: Vec<WispCopy>,
    /// Turn each member strand about the scalp's vertical axis by its root's azimuth from its
    /// tile's centre, so that a tile's strands spread as the meridians do (radially from the
    /// crown) instead of running parallel to the key strand: parallel strands leave a wedge of
    /// bare scalp between neighbouring tiles that widens towards the crown. The turn is whole at
    /// the root and fades (smoothstep) to none at this arc length, metres, so long hair fans
    /// out where it lies on the scalp and falls as its key strand below. Default 0 (no turn:
    /// the key strand is moved to each root unturned, as Zhang & Wünsche 2007 §3.2, their
    /// Figure 7, reproduce it).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub fan_out: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

fn default_density() -> f64 {
    20.0
}

fn default_samples() -> usize {
    32
}

/// One wisp declaration: a region of the scalp, a key strand, and how members spread around it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wisp {
    /// Unique name, used by copies.
    pub name: String,
    /// The scalp region the roots are spread over.
    pub region: Region,
    /// Cut the region into a grid of `(azimuth, elevation)` tiles, each its own top-level wisp
    /// sharing this key strand (expressed in each tile's own styling frame). Default (1, 1).
    #[serde(default = "default_tiles")]
    pub tiles: (u32, u32),
    /// Control points of the key strand, as Catmull-Rom control points in the styling frame at
    /// the wisp's root: (tangent, normal, binormal) metres, where the normal is the scalp normal,
    /// the tangent points down the scalp (towards decreasing elevation) and binormal =
    /// tangent × normal. The root (0, 0, 0) is implicit and must not be repeated. At least one.
    pub key_strand: Vec<Vec3>,
    /// Largest distance of a member strand's tip from the key strand (its offset grows linearly
    /// from 0 at the root to at most this at the tip), metres. Default 0.01.
    #[serde(default = "default_tip_spread")]
    pub tip_spread: f64,
    /// Optional curl: a helix around the key strand.
    #[serde(default)]
    pub curl: Option<Curl>,
    /// Strands per cm² for this wisp. Default: the style's `density`.
    #[serde(default)]
    pub density: Option<f64>,
}

fn default_tiles() -> (u32, u32) {
    (1, 1)
}

fn default_tip_spread() -> f64 {
    0.01
}

/// A region of the scalp ellipsoid in spherical angles, degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Angle around the vertical axis, from +z (the face) towards +x: `(from, to)`, degrees.
    pub azimuth: (f64, f64),
    /// Angle above the horizontal plane through the scalp centre: `(from, to)`, degrees,
    /// -90..=90 (90 is the crown).
    pub elevation: (f64, f64),
}

/// A helix wound around a wisp's key strand.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Curl {
    /// Helix radius, metres.
    pub radius: f64,
    /// Turns per metre of strand.
    pub turns_per_metre: f64,
}

/// A copy of a wisp, by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WispCopy {
    /// The wisp (or earlier copy) to copy.
    pub source: String,
    /// The copy's own name.
    pub name: String,
    /// Mirror left↔right (x ↦ -x about the scalp centre): the copy is the exact mirror image of
    /// its source, strand for strand. Default false.
    #[serde(default)]
    pub mirror: bool,
    /// Without mirror: regrow the source's wisp on its region turned this many degrees of
    /// azimuth. Default 0.
    #[serde(default)]
    pub azimuth_shift: f64,
}
