//! The AWT's tunables (Bertails et al. 2003): the two adaptation thresholds (§3.1, §3.2), the
//! hair–hair friction and repulsion (§4.2), and the wind. The ranges are the control page's
//! sliders; `bench --live` runs the AWT at both ends of the thresholds' ranges.

use crate::solver::tunable::{Tunable, WIND};
use crate::tunable;

/// Split threshold: §3.1.
const SPLIT: Tunable = tunable!(
    "split_threshold",
    "split threshold",
    "N·m·kg⁻¹",
    0.05..=1.0,
    true,
    "A node splits when its acceleration times its radius exceeds this (AWT §3.1): lower \
     splits more wisps and costs more.",
    get: |t| t.sim.split_threshold,
    set: |t, v| t.sim.split_threshold = v,
);

/// Merge velocity threshold: §3.2.
const MERGE: Tunable = tunable!(
    "merge_velocity",
    "merge velocity threshold",
    "m/s",
    0.005..=1.0,
    true,
    "Sub-nodes merge back when their speeds differ by less than this (AWT §3.2): higher \
     merges sooner.",
    get: |t| t.sim.merge_velocity,
    set: |t, v| t.sim.merge_velocity = v,
);

/// Merge radius factor: §3.2, condition (1).
const MERGE_RADIUS: Tunable = tunable!(
    "merge_radius_factor",
    "merge radius factor",
    "× radius",
    1.0..=2.0,
    false,
    "Sub-nodes merge only within this many times the super-node's radius of their centre of \
     mass (AWT §3.2, condition 1; 1 is the strict reading): higher merges sooner.",
    get: |t| t.sim.merge_radius_factor,
    set: |t, v| t.sim.merge_radius_factor = v,
);

/// Friction α: §4.2, with α·dt < 1.
const FRICTION: Tunable = tunable!(
    "friction",
    "friction α",
    "s⁻¹",
    0.0..=1000.0,
    false,
    "Viscous friction between touching wisps, k_f = α·m (AWT §4.2).",
    get: |t| t.sim.friction,
    set: |t, v| t.sim.friction = v,
    below: |t| (
        1.0 / t.sim.dt,
        "α·dt must stay below 1 so friction never reverses a relative motion (AWT §4.2)",
    ),
);

/// Repulsion k_r: §4.2.
const REPULSION: Tunable = tunable!(
    "repulsion",
    "repulsion k_r",
    "s⁻²",
    0.0..=20000.0,
    false,
    "Repulsion between wisps crossing at a large angle, per kilogram (AWT §4.2).",
    get: |t| t.sim.repulsion,
    set: |t, v| t.sim.repulsion = v,
);

/// The AWT's table, in the order the page shows it.
pub const AWT: &[Tunable] = &[SPLIT, MERGE, MERGE_RADIUS, FRICTION, REPULSION, WIND];

/// Single-level (every finest node active, no adaptation: the §5.2 baseline) has no
/// thresholds.
pub const SINGLE_LEVEL: &[Tunable] = &[FRICTION, REPULSION, WIND];
