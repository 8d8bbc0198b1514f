//! The `guides:` section of a style: every parameter of the guide-strand model (Chang, Jin, Yu
//! 2002, "A practical model for hair mutual interactions"). Every field has a default, so a
//! style without the section simulates with the values below.
//!
//! Plain data: the guide solver checks the values (`solver::guides::params::validate`) and
//! declares which of them may change while the hair moves (its tunable table).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// Which guides a triangle strip joins (§4.2, Fig. 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum StripLayout {
    /// Horizontally adjacent roots only (a human scalp, Fig. 3b).
    #[default]
    Horizontal,
    /// Horizontally and vertically adjacent roots of a root grid (a brush, Fig. 3a): each
    /// guide is joined to its nearest neighbour along +x and along +z.
    Grid,
}

/// Parameters of the guide-strand solver (`--model guides`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GuideParams {
    /// Number of guide strands, chosen uniformly over the roots (§4.3: "initially we select
    /// guide hairs uniformly on the scalp"). Default 200 (§7: "around 200 initial guide
    /// hairs").
    #[serde(default = "d_count")]
    pub count: usize,
    /// Segments per guide (§7: 15). Default 15.
    #[serde(default = "d_segments")]
    pub segments: usize,
    /// Integration sub-steps per style step (`sim.dt`). Default 1 (10 ms at the styles' 10 ms
    /// step). The paper gives no time step; what needs a short one here is integrated
    /// implicitly (the joint actuators in the articulated-body step, the damping of drag,
    /// links and contacts by backward Euler per vertex), and a guide whose joint would turn
    /// fast splits its own sub-step (into up to 512 pieces), so one holds the stability tests
    /// and the paper's experiments (`chang-shake`, `chang-fig6`, `chang-fig7`) as two and four
    /// did, with half the contact evaluations of two and a broad phase that searches only the
    /// contact distance (the contacts are evaluated on the positions it searched): the guides'
    /// share of keeping up live.
    #[serde(default = "d_substeps")]
    pub substeps: u32,
    /// The strips' contacts are searched afresh every this many steps (with one sub-step per
    /// step); in between, the pairs found in contact by the last search are evaluated again on
    /// the current positions and velocities, so a lasting contact never acts on stale data and
    /// only a pair that has just come into contact waits for the next search (at most
    /// `contact_search_every − 1` steps). The paper does not say how often its strips are
    /// searched. Default 2: the search is about two thirds of the strips' cost, and with 2 the
    /// paper's experiments and the stability tests hold as with 1; under `shake`, where a
    /// third of a step's contacts can be new, 12–20 % fewer contacts act per step
    /// (`docs/performance-history.md`, 2026-12-07). 1 searches every step, as before.
    #[serde(default = "d_contact_search_every")]
    pub contact_search_every: u32,
    /// Joint actuator stiffness (§3.2), s⁻²: the spring of a joint is this times the rest
    /// moment of inertia of the chain beyond it about the joint, so that every joint alone
    /// would oscillate at the same rate. Decreases linearly from root to tip to
    /// `stiffness · tip_stiffness`. Default 400.
    #[serde(default = "d_stiffness")]
    pub stiffness: f64,
    /// Fraction of `stiffness` left at the tip, in [0, 1]. Default 0.2.
    #[serde(default = "d_tip_stiffness")]
    pub tip_stiffness: f64,
    /// Joint damping rate, s⁻¹ (same scaling as the stiffness). Default 4.
    #[serde(default = "d_joint_damping")]
    pub joint_damping: f64,
    /// Static links (§4.1): closest points on nearby strands per segment. 0 disables the links.
    /// Default 3.
    #[serde(default = "d_links_per_segment")]
    pub links_per_segment: usize,
    /// Largest distance between a segment and a linked point at rest, m. Default 0.03.
    #[serde(default = "d_link_radius")]
    pub link_radius: f64,
    /// Static link spring constant per kilogram of the lighter vertex, s⁻² (§4.1, Eq. 2).
    /// Default 300.
    #[serde(default = "d_link_strength")]
    pub link_strength: f64,
    /// Damping of a static link per kilogram, s⁻¹ (the paper's universal k_d). Default 5.
    #[serde(default = "d_link_damping")]
    pub link_damping: f64,
    /// Reference length of a link's stretch (displacement / reference), m. Default: none, the
    /// length of the link's segment.
    #[serde(default)]
    pub link_reference: Option<f64>,
    /// Hair–hair collision through triangle strips and segments (§4.2). Default true.
    #[serde(default = "d_true")]
    pub collision: bool,
    /// Which guides the strips join. Default `Horizontal`.
    #[serde(default)]
    pub strip_layout: StripLayout,
    /// Largest distance between two roots joined by a strip, m. Default 0.05.
    #[serde(default = "d_strip_root_distance")]
    pub strip_root_distance: f64,
    /// Distance below which two hair elements collide (a guide stands for a cluster with a
    /// thickness), m. Default 0.006.
    #[serde(default = "d_contact_distance")]
    pub contact_distance: f64,
    /// Repulsive spring of a contact per kilogram, s⁻². Default 3000.
    #[serde(default = "d_contact_stiffness")]
    pub contact_stiffness: f64,
    /// Damping of the normal relative velocity of a contact ("strongly damped"), s⁻¹.
    /// Default 60.
    #[serde(default = "d_contact_damping")]
    pub contact_damping: f64,
    /// Viscous friction on the tangential relative velocity of a contact, s⁻¹. Default 20.
    #[serde(default = "d_contact_friction")]
    pub contact_friction: f64,
    /// A strip triangle whose width exceeds this multiple of its rest width is broken while it
    /// stays so (§4.2, reversible). Default 2.5.
    #[serde(default = "d_strip_break")]
    pub strip_break: f64,
    /// Fraction of a body-contact vertex's tangential motion (relative to the body) removed per
    /// sub-step: the body friction of §3.3, in [0, 1]. Default 0.3.
    #[serde(default = "d_body_friction")]
    pub body_friction: f64,
    /// Distance from a body sphere below which a vertex is in contact, m. Default 0.003.
    #[serde(default = "d_body_margin")]
    pub body_margin: f64,
    /// Adaptive guides (§4.3): most inserted guides alive at once. 0 disables. Default 40.
    #[serde(default = "d_max_inserted")]
    pub max_inserted: usize,
    /// A guide is inserted between two strip neighbours when a pair of corresponding vertices
    /// has drifted this much farther apart than on the settled hair, m. Default 0.12.
    #[serde(default = "d_insert_distance")]
    pub insert_distance: f64,
    /// An inserted guide is removed when no pair of corresponding vertices of its two
    /// neighbours has drifted more than this apart (compared with the settled hair), m.
    /// Default 0.06.
    #[serde(default = "d_remove_distance")]
    pub remove_distance: f64,
    /// Guides blended per dense strand (§5.1). Default 3.
    #[serde(default = "d_blend")]
    pub blend: usize,
    /// Spheres that move on their own keyframed path, independently of the head and the roots
    /// (the sphere hitting a brush, §7.4): `[(radius: 0.05, path: [(time: 0, center: (x, y,
    /// z)), …])]`, world coordinates. Default: none.
    #[serde(default)]
    pub obstacles: Vec<MovingSphere>,
}

impl Default for GuideParams {
    fn default() -> Self {
        GuideParams {
            count: d_count(),
            segments: d_segments(),
            substeps: d_substeps(),
            contact_search_every: d_contact_search_every(),
            stiffness: d_stiffness(),
            tip_stiffness: d_tip_stiffness(),
            joint_damping: d_joint_damping(),
            links_per_segment: d_links_per_segment(),
            link_radius: d_link_radius(),
            link_strength: d_link_strength(),
            link_damping: d_link_damping(),
            link_reference: None,
            collision: true,
            strip_layout: StripLayout::Horizontal,
            strip_root_distance: d_strip_root_distance(),
            contact_distance: d_contact_distance(),
            contact_stiffness: d_contact_stiffness(),
            contact_damping: d_contact_damping(),
            contact_friction: d_contact_friction(),
            strip_break: d_strip_break(),
            body_friction: d_body_friction(),
            body_margin: d_body_margin(),
            max_inserted: d_max_inserted(),
            insert_distance: d_insert_distance(),
            remove_distance: d_remove_distance(),
            blend: d_blend(),
            obstacles: Vec::new(),
        }
    }
}

fn d_count() -> usize {
    200
}
fn d_segments() -> usize {
    15
}
fn d_substeps() -> u32 {
    1
}
fn d_contact_search_every() -> u32 {
    2
}
fn d_stiffness() -> f64 {
    400.0
}
fn d_tip_stiffness() -> f64 {
    0.2
}
fn d_joint_damping() -> f64 {
    4.0
}
fn d_links_per_segment() -> usize {
    3
}
fn d_link_radius() -> f64 {
    0.03
}
fn d_link_strength() -> f64 {
    300.0
}
fn d_link_damping() -> f64 {
    5.0
}
fn d_true() -> bool {
    true
}
fn d_strip_root_distance() -> f64 {
    0.05
}
fn d_contact_distance() -> f64 {
    0.006
}
fn d_contact_stiffness() -> f64 {
    3000.0
}
fn d_contact_damping() -> f64 {
    60.0
}
fn d_contact_friction() -> f64 {
    20.0
}
fn d_strip_break() -> f64 {
    2.5
}
fn d_body_friction() -> f64 {
    0.3
}
fn d_body_margin() -> f64 {
    0.003
}
fn d_max_inserted() -> usize {
    40
}
fn d_insert_distance() -> f64 {
    0.12
}
fn d_remove_distance() -> f64 {
    0.06
}
fn d_blend() -> usize {
    3
}

/// One key of an obstacle's path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathKey {
    /// Seconds from the start of the run (after settling), ≥ 0, strictly increasing.
    pub time: f64,
    /// Centre of the sphere at that time, world coordinates, m.
    pub center: [f64; 3],
}

/// A sphere on a keyframed path: `(radius: 0.05, path: [(time: 0, center: (x, y, z)), …])`.
///
/// Between two keys the centre eases in and out (a cubic Hermite segment with zero end
/// tangents), so position and velocity are continuous and the velocity is the exact
/// derivative of the position; the sphere is at rest at every key, before the first and after
/// the last. A single key is a still sphere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovingSphere {
    /// Radius, m.
    pub radius: f64,
    /// The keys of its centre path (at least one).
    pub path: Vec<PathKey>,
}

impl MovingSphere {
    /// Centre and velocity at time `t`.
    pub fn center_at(&self, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.path;
        let at = |k: usize| Vector3::from(p[k].center);
        let j = p.partition_point(|k| k.time <= t);
        if j == 0 {
            return (at(0), Vector3::zeros());
        }
        if j == p.len() {
            return (at(p.len() - 1), Vector3::zeros());
        }
        let (a, b) = (&p[j - 1], &p[j]);
        let span = b.time - a.time;
        let u = (t - a.time) / span;
        let d = at(j) - at(j - 1);
        let s = u * u * (3.0 - 2.0 * u);
        let ds = 6.0 * u * (1.0 - u) / span;
        (at(j - 1) + d * s, d * ds)
    }

    /// Time of the last key: the sphere is still from then on.
    pub fn stop_time(&self) -> f64 {
        self.path.last().map_or(0.0, |k| k.time)
    }
}
