//! The `layered:` section of a style: every parameter of the layered wisp model (Plante, Cani,
//! Poulin 2002) that the AWT's `sim:` section does not already give (gravity, air drag, wind,
//! total mass and the displayed frame length are taken from `sim:`).
//!
//! Plain data: the layered solver checks the values (`solver::layered::params`) and declares
//! which of them may change while the hair moves (its tunable table).

use serde::{Deserialize, Serialize};

/// Parameters of the layered wisp model. Rates and stiffnesses are per kilogram (s⁻² for
/// springs, s⁻¹ for damping and drag), so they do not depend on the hair's mass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayeredParams {
    /// Level of the style's GC hierarchy whose GCs become layered wisps (0 = coarsest). It
    /// must exist in `hierarchy.levels`, except the default 1, which means the finest level of
    /// a one-level hierarchy. A level with more than `max_segments` segments is coarsened.
    /// Default 1.
    #[serde(default = "d_level")]
    pub level: usize,
    /// Most wisp segments: when `level` has more (its GCs × (cross-sections − 1)), the next
    /// coarser level is taken, and so on (level 0 whatever its count). §4.1: the cost of the
    /// model is its segments; §7.2: the paper's styles have 796, 723 and 431 (199 wisps × 4.0
    /// segments, 73 × 9.9, 56 × 7.7). The finest level of a built-in short style has about
    /// 4600. 0: no limit. Default 1000.
    #[serde(default = "d_max_segments")]
    pub max_segments: usize,
    /// Integration rate, Hz (§7.2: 1000). Default 1000.
    #[serde(default = "d_rate")]
    pub rate: f64,
    /// Rate of body collision processing, Hz (§7.2: 120). Default 120.
    #[serde(default = "d_body_rate")]
    pub body_rate: f64,
    /// Rate of wisp–wisp interaction processing, Hz (§7.2: 24). Default 24.
    #[serde(default = "d_interaction_rate")]
    pub interaction_rate: f64,
    /// Stiffness of the skeleton's linear springs, per kilogram of the lighter end, s⁻²
    /// (§3.2: stiff for straight hair, soft for wavy hair). Default: 1e5 for rigid-link styles,
    /// 2e4 for spring-link (curly) styles.
    #[serde(default)]
    pub stiffness: Option<f64>,
    /// Damping ν of the skeleton's linear springs, s⁻¹ (a §5.2 velocity modification).
    /// Default 100.
    #[serde(default = "d_damping")]
    pub damping: f64,
    /// Stiffness of the angular springs, per kilogram, s⁻² (§3.2: "a slight resistance to
    /// bending"). Default 400.
    #[serde(default = "d_bending")]
    pub bending: f64,
    /// Damping of the angular springs (relative velocity across a segment), s⁻¹. Default 20.
    #[serde(default = "d_bending_damping")]
    pub bending_damping: f64,
    /// Mass of one envelope point over its skeleton point's (§3.3: "about 1/100").
    /// Default 0.01.
    #[serde(default = "d_envelope_mass")]
    pub envelope_mass: f64,
    /// Radial spring from an envelope point to its skeleton point, per kilogram, s⁻² (§3.3:
    /// soft: an envelope point sags by g / stiffness across the wisp under gravity). Default
    /// 4000.
    #[serde(default = "d_envelope_stiffness")]
    pub envelope_stiffness: f64,
    /// Springs between neighbouring envelope points of one section, per kilogram, s⁻².
    /// Default 2000.
    #[serde(default = "d_ring_stiffness")]
    pub ring_stiffness: f64,
    /// Damping ν of the envelope springs, s⁻¹ (§3.3: highly damped). Default 200.
    #[serde(default = "d_envelope_damping")]
    pub envelope_damping: f64,
    /// Process wisp–wisp interactions at all (§7.1, Fig. 8 first row: off). Default true.
    #[serde(default = "d_true")]
    pub interactions: bool,
    /// Allow the dissipative collision of §4.2.2 (off: every pair in contact interpenetrates).
    /// Default true.
    #[serde(default = "d_true")]
    pub collisions: bool,
    /// Largest angle between the relative velocity and the two segments' plane for which they
    /// interpenetrate, degrees (§7.1: 25). Default 25.
    #[serde(default = "d_interpenetration_angle")]
    pub interpenetration_angle: f64,
    /// Viscosity ν of the in-plane drag between interpenetrating wisps, s⁻¹ per unit relative
    /// density (§4.2.1; Fig. 9 uses 0.5 and 50). 0 turns the drag off. Default 10.
    #[serde(default = "d_viscosity")]
    pub viscosity: f64,
    /// Sliding contact distance from the body's surface, m (§4.3.1). Default 0.005.
    #[serde(default = "d_body_threshold")]
    pub body_threshold: f64,
    /// Tangential viscous friction against the body, s⁻¹ (§4.3.1). Default 20.
    #[serde(default = "d_body_friction")]
    pub body_friction: f64,
    /// Jitter of drawn strands towards the skeleton (§6): each strand's section coordinates
    /// are scaled by a fixed factor in [1 − jitter, 1]. Default 0.2.
    #[serde(default = "d_jitter")]
    pub jitter: f64,
}

impl Default for LayeredParams {
    fn default() -> Self {
        LayeredParams {
            level: d_level(),
            max_segments: d_max_segments(),
            rate: d_rate(),
            body_rate: d_body_rate(),
            interaction_rate: d_interaction_rate(),
            stiffness: None,
            damping: d_damping(),
            bending: d_bending(),
            bending_damping: d_bending_damping(),
            envelope_mass: d_envelope_mass(),
            envelope_stiffness: d_envelope_stiffness(),
            ring_stiffness: d_ring_stiffness(),
            envelope_damping: d_envelope_damping(),
            interactions: true,
            collisions: true,
            interpenetration_angle: d_interpenetration_angle(),
            viscosity: d_viscosity(),
            body_threshold: d_body_threshold(),
            body_friction: d_body_friction(),
            jitter: d_jitter(),
        }
    }
}

fn d_level() -> usize {
    1
}
fn d_max_segments() -> usize {
    1000
}
fn d_rate() -> f64 {
    1000.0
}
fn d_body_rate() -> f64 {
    120.0
}
fn d_interaction_rate() -> f64 {
    24.0
}
fn d_damping() -> f64 {
    100.0
}
fn d_bending() -> f64 {
    400.0
}
fn d_bending_damping() -> f64 {
    20.0
}
fn d_envelope_mass() -> f64 {
    0.01
}
fn d_envelope_stiffness() -> f64 {
    4000.0
}
fn d_ring_stiffness() -> f64 {
    2000.0
}
fn d_envelope_damping() -> f64 {
    200.0
}
fn d_true() -> bool {
    true
}
fn d_interpenetration_angle() -> f64 {
    25.0
}
fn d_viscosity() -> f64 {
    10.0
}
fn d_body_threshold() -> f64 {
    0.005
}
fn d_body_friction() -> f64 {
    20.0
}
fn d_jitter() -> f64 {
    0.2
}
