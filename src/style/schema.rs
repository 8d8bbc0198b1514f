//! The hairstyle file format: what a `styles/*.ron` file may say.
//!
//! SI units throughout (metres, kilograms, seconds), right-handed, y up, the face looking
//! towards +z. Every field has a default (documented on the field) except `hair`, and unknown
//! fields are refused so that a typo never silently falls back to a default.

use serde::{Deserialize, Serialize};

pub use super::body::{BodyItem, Capsule, MeshRef};
pub use super::generated_section::{Curl, Generated, Region, Wisp, WispCopy};

/// A 3-vector in a style file: `(x, y, z)`.
pub type Vec3 = [f64; 3];

/// A complete hairstyle: the head, the hair, how the hair is cut into a wisp hierarchy, and
/// the simulation parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Style {
    /// A display name. Default: empty (the file stem is used).
    #[serde(default)]
    pub name: String,
    /// Seed of every random choice made while generating the hair (roots, offsets). Default 1.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The head and body in the rest pose. Default: [`Head::default`].
    #[serde(default)]
    pub head: Head,
    /// The strands: generated from wisps, or imported from TressFX, `.hair` or HairSalon files.
    /// Required.
    pub hair: Hair,
    /// The multiresolution structure. Default: [`Hierarchy::default`].
    #[serde(default)]
    pub hierarchy: Hierarchy,
    /// How consecutive nodes are linked. Default: `Rigid(iterations: 8)`.
    #[serde(default)]
    pub link: Link,
    /// Simulation parameters. Default: [`SimParams::default`].
    #[serde(default)]
    pub sim: SimParams,
    /// Parameters of the layered wisp model (`--model layered`). Default:
    /// [`LayeredParams::default`](super::LayeredParams::default).
    #[serde(default)]
    pub layered: super::LayeredParams,
    /// How the hair is rendered (shading, shadows, antialiasing). Default:
    /// [`RenderParams::default`](super::RenderParams).
    #[serde(default)]
    pub render: super::RenderParams,
    /// The guide-strand model's parameters (`--model guides`). Default:
    /// [`GuideParams::default`](super::GuideParams::default).
    #[serde(default)]
    pub guides: super::GuideParams,
}

fn default_seed() -> u64 {
    1
}

/// The head (scalp ellipsoid) and the body (bounding spheres, AWT §4.1), in the rest pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Head {
    /// The scalp, on which generated roots are placed (the motion's pivot, the viewer's head).
    /// Default: with `fit_body`, a sphere on the fitted head; else centre (0, 1.6, 0), radii
    /// (0.075, 0.095, 0.09) m. [`Head::scalp`] gives the one in force.
    #[serde(
        default,
        with = "super::scalp::given",
        skip_serializing_if = "Option::is_none"
    )]
    pub scalp: Option<Ellipsoid>,
    /// Collision bodies of the head and body, moving with the character: spheres
    /// `(center: .., radius: ..)` (or `Sphere(..)`), `Capsule(a: .., b: .., radius: ..)` and
    /// `Mesh(file: .., scale: .., translate: .., up: Y|Z)` (see [`super::body`]).
    /// Default: a head sphere just inside the scalp, a neck and two shoulders/torso spheres.
    #[serde(default = "super::body::default_body")]
    pub body: Vec<BodyItem>,
    /// Replace `body` by one sphere fitted to the strands' roots (least squares, shrunk so
    /// that every root lies on or outside it). For imported hair whose head is not given.
    /// Default false.
    #[serde(default)]
    pub fit_body: bool,
    /// Move strand roots that lie inside a mesh body onto its surface along its normal, at
    /// load. Default false.
    #[serde(default)]
    pub push_roots_out: bool,
}

impl Default for Head {
    fn default() -> Self {
        Head {
            scalp: None,
            body: super::body::default_body(),
            fit_body: false,
            push_roots_out: false,
        }
    }
}

pub(super) fn default_scalp() -> Ellipsoid {
    Ellipsoid {
        center: [0.0, 1.6, 0.0],
        radii: [0.075, 0.095, 0.09],
    }
}

/// An axis-aligned ellipsoid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ellipsoid {
    /// Centre, metres.
    pub center: Vec3,
    /// Semi-axes along x, y, z, metres (all > 0).
    pub radii: Vec3,
}

/// A sphere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sphere {
    /// Centre, metres.
    pub center: Vec3,
    /// Radius, metres (> 0).
    pub radius: f64,
}

/// Where the strands come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Hair {
    /// Wisps grown on scalp regions from key strands (Zhang & Wünsche 2007, §3).
    Generated(Generated),
    /// Strands read from TressFX `.tfx` files (versions 3 and 4).
    TressFx(TressFx),
    /// Strands read from a Cem Yuksel `.hair` file (RON name `Hair`).
    #[serde(rename = "Hair")]
    HairFile(StrandFile),
    /// Strands read from a USC-HairSalon `.data` file.
    HairSalon(StrandFile),
    /// Strands given point by point, grouped into top-level wisps (the papers' head-less
    /// scenes: two wisps balancing, Plante, Cani, Poulin 2002, §7.1). Roots are pinned to the
    /// (still or moving) body frame like every root.
    Explicit(Explicit),
}

/// Hair given explicitly: `Explicit((wisps: [(name: "a", strands: [[(x, y, z), ...]])]))`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Explicit {
    /// The top-level wisps, each a group of strands.
    pub wisps: Vec<ExplicitWisp>,
}

/// One explicitly given wisp.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExplicitWisp {
    /// Display name. Default: `wisp <n>`.
    #[serde(default)]
    pub name: String,
    /// Its strands, each a polyline of world points, root first (at least 2 points).
    pub strands: Vec<Vec<Vec3>>,
}

/// Strands imported from TressFX files.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TressFx {
    /// `.tfx` files, relative to the style file.
    pub files: Vec<String>,
    /// Factor from file units to metres. Default 0.01 (TressFX exports are in centimetres).
    #[serde(default = "default_tfx_scale")]
    pub scale: f64,
    /// Translation applied after scaling, metres. Default (0, 0, 0).
    #[serde(default)]
    pub translate: Vec3,
    /// A `.tfxproj` file, relative to the style file, whose collision spheres (scaled and
    /// translated like the strands) replace `head.body`. Default: none.
    #[serde(default)]
    pub project: Option<String>,
}

fn default_tfx_scale() -> f64 {
    0.01
}

/// Strands imported from one `.hair` or `.data` file. A point `p` of the file becomes
/// `scale · R(up) · p + translate`, where `R(Z)` turns a z-up file to y-up.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrandFile {
    /// The file, relative to the style file.
    pub file: String,
    /// Factor from file units to metres. Default 1.
    #[serde(default = "default_strand_file_scale")]
    pub scale: f64,
    /// Translation applied after scaling, metres. Default (0, 0, 0).
    #[serde(default)]
    pub translate: Vec3,
    /// Which axis is up in the file. Default `Y`.
    #[serde(default)]
    pub up: Up,
}

fn default_strand_file_scale() -> f64 {
    1.0
}

/// The up axis of an imported file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Up {
    /// Already y-up: points are kept as they are.
    #[default]
    Y,
    /// Z-up (3ds Max, Blender): turned −90° about x, `(x, y, z) ↦ (x, z, −y)`, so that +z
    /// becomes +y and the −y front of a z-up file faces +z as wisptree expects.
    Z,
}

/// The multiresolution structure (AWT §2.1–2.2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Hierarchy {
    /// Levels of detail, ≥ 1. Default 3.
    #[serde(default = "default_levels")]
    pub levels: usize,
    /// Cross-sections (nodes) per generalized cylinder, root included, K ≥ 2. Default 12.
    #[serde(default = "default_k")]
    pub cross_sections: usize,
    /// Sub-GCs per GC for each refinement, `levels - 1` entries, each ≥ 2. Default [4, 4].
    #[serde(default = "default_branching")]
    pub branching: Vec<usize>,
    /// Imported hair only: how many top-level wisps to cluster the strands into (generated hair
    /// has one per wisp tile). Default 32.
    #[serde(default = "default_top_level")]
    pub top_level: usize,
}

impl Default for Hierarchy {
    fn default() -> Self {
        Hierarchy {
            levels: default_levels(),
            cross_sections: default_k(),
            branching: default_branching(),
            top_level: default_top_level(),
        }
    }
}

fn default_levels() -> usize {
    3
}
fn default_k() -> usize {
    12
}
fn default_branching() -> Vec<usize> {
    vec![4, 4]
}
fn default_top_level() -> usize {
    32
}

/// The mechanical link between consecutive nodes of the AWT (§2.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Link {
    /// Rigid links for straight hair, by iterative constraint projection (Van Overveld).
    Rigid {
        /// Projection sweeps per step. Default 8.
        #[serde(default = "default_link_iterations")]
        iterations: u32,
    },
    /// Viscous springs for curly hair, integrated implicitly so curls can stretch.
    Spring {
        /// Stiffness per kilogram of hair the link carries (from its child node to the tip),
        /// s⁻²: under gravity g a link stretches by about g / stiffness metres. Default 4000.
        #[serde(default = "default_spring_stiffness")]
        stiffness: f64,
        /// Damping rate of the relative velocity along the link, per kilogram carried, s⁻¹.
        /// Default 20.
        #[serde(default = "default_spring_damping")]
        damping: f64,
    },
}

impl Default for Link {
    fn default() -> Self {
        Link::Rigid {
            iterations: default_link_iterations(),
        }
    }
}

fn default_link_iterations() -> u32 {
    8
}
fn default_spring_stiffness() -> f64 {
    4000.0
}
fn default_spring_damping() -> f64 {
    20.0
}

/// Simulation parameters. The ones marked *tunable* may change while the simulation runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimParams {
    /// Mass of the whole hair, kg. Default 1.0 (the paper: 0.5–2 kg).
    #[serde(default = "d_total_mass")]
    pub total_mass: f64,
    /// Split threshold on |acceleration| × radius, N·m·kg⁻¹ (= m²·s⁻²). *Tunable.* Default 0.3
    /// (the paper: 0.1–0.5).
    #[serde(default = "d_split_threshold")]
    pub split_threshold: f64,
    /// Merge velocity threshold: largest relative speed of merging nodes, m/s. *Tunable.*
    /// Default 0.1.
    #[serde(default = "d_merge_velocity")]
    pub merge_velocity: f64,
    /// Merge condition (1) reads "each sub-node lies within the super-node's radius of their
    /// centre of mass"; this factor scales that radius. 1 is the strict reading; hair at rest
    /// after a fast move lies a little fluffier than as styled, hence the default 1.2.
    /// *Tunable.*
    #[serde(default = "d_merge_radius_factor")]
    pub merge_radius_factor: f64,
    /// Friction α of hair–hair interaction (k_f = α·m_child), s⁻¹; α·dt must be < 1.
    /// *Tunable.* Default 30.
    #[serde(default = "d_friction")]
    pub friction: f64,
    /// Repulsion k_r between segments crossing at a large angle, per kilogram of the lighter
    /// child node, s⁻². *Tunable.* Default 2000.
    #[serde(default = "d_repulsion")]
    pub repulsion: f64,
    /// Angle between two segments' axes above which repulsion is added, degrees. *Tunable.*
    /// Default 30.
    #[serde(default = "d_angle_threshold")]
    pub angle_threshold: f64,
    /// Integration step, s. Default 0.01 (the paper).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// Integration steps per displayed frame. Default 4 (the paper).
    #[serde(default = "d_steps_per_frame")]
    pub steps_per_frame: u32,
    /// Gravity, m/s². *Tunable.* Default (0, -9.81, 0).
    #[serde(default = "d_gravity")]
    pub gravity: Vec3,
    /// Air drag: rate at which a node's velocity relative to the wind is damped, s⁻¹ (it also
    /// stands for the hair's internal damping).
    /// *Tunable.* Default 2.
    #[serde(default = "d_air_drag")]
    pub air_drag: f64,
    /// The wind field. *Tunable.* Default: still air.
    #[serde(default)]
    pub wind: Wind,
    /// Pull of every segment towards its styled direction in the head frame, per kilogram, s⁻²;
    /// keeps a hairstyle's shape (the AWT paper's links carry no bending stiffness). Decreases
    /// linearly from the root to zero at the tip. *Tunable.* Default 60.
    #[serde(default = "d_bending")]
    pub bending: f64,
    /// Relative speed below which two segments are not tested for collision (AWT §4.1), m/s.
    /// Default 1e-3.
    #[serde(default = "d_contact_epsilon")]
    pub contact_epsilon: f64,
    /// Seconds of settling before the animation starts: the hair hangs under gravity in the
    /// starting pose, adaptation off, then starts at rest (AWT §2.3: "often at rest"), so the
    /// styled shape relaxing is not mistaken for motion by the split test. Default 1.
    #[serde(default = "d_settle")]
    pub settle: f64,
    /// Smoothing of the acceleration used by the split test: the exponential moving-average
    /// weight of the newest step, in (0, 1]. Default 0.5.
    #[serde(default = "d_accel_smoothing")]
    pub accel_smoothing: f64,
}

impl Default for SimParams {
    fn default() -> Self {
        SimParams {
            total_mass: d_total_mass(),
            split_threshold: d_split_threshold(),
            merge_velocity: d_merge_velocity(),
            merge_radius_factor: d_merge_radius_factor(),
            friction: d_friction(),
            repulsion: d_repulsion(),
            angle_threshold: d_angle_threshold(),
            dt: d_dt(),
            steps_per_frame: d_steps_per_frame(),
            gravity: d_gravity(),
            air_drag: d_air_drag(),
            wind: Wind::default(),
            bending: d_bending(),
            contact_epsilon: d_contact_epsilon(),
            accel_smoothing: d_accel_smoothing(),
            settle: d_settle(),
        }
    }
}

fn d_total_mass() -> f64 {
    1.0
}
fn d_split_threshold() -> f64 {
    0.3
}
fn d_merge_velocity() -> f64 {
    0.1
}
fn d_merge_radius_factor() -> f64 {
    1.2
}
fn d_friction() -> f64 {
    30.0
}
fn d_repulsion() -> f64 {
    2000.0
}
fn d_angle_threshold() -> f64 {
    30.0
}
fn d_dt() -> f64 {
    0.01
}
fn d_steps_per_frame() -> u32 {
    4
}
fn d_gravity() -> Vec3 {
    [0.0, -9.81, 0.0]
}
fn d_air_drag() -> f64 {
    2.0
}
fn d_bending() -> f64 {
    60.0
}
fn d_contact_epsilon() -> f64 {
    1e-3
}
fn d_settle() -> f64 {
    1.0
}
fn d_accel_smoothing() -> f64 {
    0.5
}

/// Wind: a steady velocity plus a gust travelling through space,
/// `w(x, t) = velocity + gust · sin(2π (frequency · t − x·direction / wavelength))`,
/// along `velocity`'s direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wind {
    /// Mean air velocity, m/s. Default (0, 0, 0).
    #[serde(default)]
    pub velocity: Vec3,
    /// Gust amplitude, m/s. Default 0.
    #[serde(default)]
    pub gust: f64,
    /// Gust frequency, Hz. Default 0.5.
    #[serde(default = "d_gust_frequency")]
    pub frequency: f64,
    /// Gust wavelength, m. Default 2.
    #[serde(default = "d_gust_wavelength")]
    pub wavelength: f64,
    /// The strength set while running (the control page's wind slider) and the wind it
    /// scales; never in a file.
    #[serde(skip)]
    pub strength: Option<WindStrength>,
}

/// A wind strength in force and the wind it scales: the style's own, or 1 m/s along +x when
/// the style has none (so that the strength always does something).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindStrength {
    /// The factor.
    pub factor: f64,
    /// The velocity at factor 1, m/s.
    pub velocity: Vec3,
    /// The gust amplitude at factor 1, m/s.
    pub gust: f64,
}

impl Wind {
    /// Whether the style has any wind.
    fn blows(&self) -> bool {
        self.velocity.iter().any(|v| *v != 0.0) || self.gust != 0.0
    }

    /// The strength in force: as set, else 1 for a style with wind and 0 without.
    pub fn strength(&self) -> f64 {
        match self.strength {
            Some(s) => s.factor,
            None => f64::from(u8::from(self.blows())),
        }
    }

    /// Scales the wind this strength started from (the style's, or 1 m/s along +x) by
    /// `factor`.
    pub fn set_strength(&mut self, factor: f64) {
        let base = self.strength.unwrap_or(if self.blows() {
            WindStrength {
                factor: 1.0,
                velocity: self.velocity,
                gust: self.gust,
            }
        } else {
            WindStrength {
                factor: 0.0,
                velocity: [1.0, 0.0, 0.0],
                gust: 0.0,
            }
        });
        self.velocity = base.velocity.map(|v| v * factor);
        self.gust = base.gust * factor;
        self.strength = Some(WindStrength { factor, ..base });
    }
}

impl Default for Wind {
    fn default() -> Self {
        Wind {
            velocity: [0.0; 3],
            gust: 0.0,
            frequency: d_gust_frequency(),
            wavelength: d_gust_wavelength(),
            strength: None,
        }
    }
}

fn d_gust_frequency() -> f64 {
    0.5
}
fn d_gust_wavelength() -> f64 {
    2.0
}
