//! Entity paths and timelines: the recording's interface (see the module docs of `stream`).
//! The solvers and the pipeline name their stats ([`crate::report::names`], a solver's own where
//! it sets them); the paths are made here: `/stats/<name>`, and `/params/<name>` for the
//! tunables in force.

use crate::report::StatGroup;

/// The entity path of a measure named `name`: `/stats/<name>`.
pub fn stat(name: &str) -> String {
    format!("/stats/{name}")
}

/// The entity path of a tunable in force: `/params/<name>`.
pub fn param(name: &str) -> String {
    format!("/params/{name}")
}

/// The entity path of a stat of `group`.
pub fn stat_path(group: StatGroup, name: &str) -> String {
    match group {
        StatGroup::Stats => stat(name),
        StatGroup::Params => param(name),
    }
}

/// The AWT's active nodes (a solver's nodes are at [`nodes`]).
pub const NODES: &str = "/hair/awt/nodes";
/// The AWT's active segments.
pub const SEGMENTS: &str = "/hair/awt/segments";
/// The inspected node's numbers (`run --inspect`): `/inspect/<tree>/<level>/<index>/<name>`.
pub const INSPECT: &str = "/inspect";
/// The inspected node drawn among the model's nodes: a ring larger than the node.
pub const INSPECTED_MARKER: &str = "/hair/inspected";
/// The drawn hair strands.
pub const STRANDS: &str = "/hair/strands";
/// The body's collision spheres.
pub const BODY_SPHERES: &str = "/body/spheres";
/// The body's capsules.
pub const BODY_CAPSULES: &str = "/body/capsules";
/// The body's meshes (one `Mesh3D`, static, moved by a transform every frame).
pub const BODY_MESH: &str = "/body/mesh";
/// The scalp ellipsoid.
pub const SCALP: &str = "/head/scalp";
/// Split events (`/events/<kind>` for every [`crate::report::EventKind`]).
pub const SPLITS: &str = "/events/split";
/// Merge events.
pub const MERGES: &str = "/events/merge";
/// The rendered hair (an encoded JPEG per rendered frame).
pub const RENDER: &str = "/render/hair";
/// Free-text messages.
pub const LOG: &str = "/log";
/// Per-level counts live below this: `/stats/active_nodes/level_N`.
pub const ACTIVE_NODES: &str = "/stats/active_nodes";

/// `/stats/active_nodes/level_N`.
pub fn active_nodes_level(level: usize) -> String {
    format!("{ACTIVE_NODES}/level_{level}")
}

/// A solver's nodes: `/hair/<solver>/nodes` (`/hair/awt/nodes` for the AWT).
pub fn nodes(solver: &str) -> String {
    format!("/hair/{solver}/nodes")
}

/// A solver's segments: `/hair/<solver>/segments`.
pub fn segments(solver: &str) -> String {
    format!("/hair/{solver}/segments")
}

/// Events of one kind: `/events/<kind>`.
pub fn events(kind: crate::report::EventKind) -> String {
    format!("/events/{}", kind.name())
}

/// The `frame` timeline (sequence: frame number).
pub const TIMELINE_FRAME: &str = "frame";
/// The `sim_time` timeline (duration: simulated seconds).
pub const TIMELINE_SIM_TIME: &str = "sim_time";
