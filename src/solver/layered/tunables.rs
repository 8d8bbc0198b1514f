//! The layered model's tunables (Plante, Cani, Poulin 2002): the wisp–wisp interaction of §4.2
//! (viscosity of interpenetrating wisps, the angle that decides between interpenetration and
//! collision), the skeleton's springs of §3.2, the body friction of §4.3.1, and the wind.

use crate::solver::tunable::{Tunable, WIND};
use crate::tunable;

/// The layered model's table, in the order the page shows it.
pub const LAYERED: &[Tunable] = &[
    tunable!(
        "viscosity",
        "interpenetration viscosity ν",
        "s⁻¹",
        0.0..=100.0,
        false,
        "In-plane drag between interpenetrating wisps, per unit relative density (Plante §4.2.1; \
         Fig. 9 compares 0.5 and 50).",
        get: |t| t.layered.viscosity,
        set: |t, v| t.layered.viscosity = v,
    ),
    tunable!(
        "interpenetration_angle",
        "interpenetration angle",
        "°",
        0.0..=90.0,
        false,
        "Wisps whose relative velocity lies within this angle of their plane interpenetrate; \
         the others collide (Plante §4.2, §7.1: 25°).",
        get: |t| t.layered.interpenetration_angle,
        set: |t, v| t.layered.interpenetration_angle = v,
    ),
    tunable!(
        "damping",
        "skeleton damping",
        "s⁻¹",
        0.0..=400.0,
        false,
        "Damping of the skeleton's linear springs (Plante §3.2, a §5.2 velocity modification).",
        get: |t| t.layered.damping,
        set: |t, v| t.layered.damping = v,
    ),
    tunable!(
        "bending",
        "bending stiffness",
        "s⁻²",
        0.0..=2000.0,
        false,
        "Angular springs of the skeleton, per kilogram: \"a slight resistance to bending\" \
         (Plante §3.2).",
        get: |t| t.layered.bending,
        set: |t, v| t.layered.bending = v,
    ),
    tunable!(
        "body_friction",
        "body friction",
        "s⁻¹",
        0.0..=100.0,
        false,
        "Tangential viscous friction of wisps sliding on the body (Plante §4.3.1).",
        get: |t| t.layered.body_friction,
        set: |t, v| t.layered.body_friction = v,
    ),
    WIND,
];
