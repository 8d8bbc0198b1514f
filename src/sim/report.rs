//! What one simulation step reports: the AWT's split and merge events and the counters.

use std::time::Duration;

/// Which adaptation happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum EventKind {
    /// A node became its sub-nodes (AWT §3.1).
    Split,
    /// Sub-nodes became their super-node (AWT §3.2).
    Merge,
    /// A guide strand was inserted between two that drifted apart (Chang, Jin, Yu 2002, §4.3).
    GuideInsert,
    /// An inserted guide strand was removed when its neighbours came close again (§4.3).
    GuideRemove,
}

impl EventKind {
    /// Every kind, in the order the logger lists them.
    pub const ALL: [EventKind; 4] = [
        EventKind::Split,
        EventKind::Merge,
        EventKind::GuideInsert,
        EventKind::GuideRemove,
    ];

    /// The last segment of its entity path, `/events/<name>`.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Split => "split",
            EventKind::Merge => "merge",
            EventKind::GuideInsert => "guide_insert",
            EventKind::GuideRemove => "guide_remove",
        }
    }
}

/// How a stat of several steps becomes the stat of their frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Aggregate {
    /// The last step's value (a state: a count of links, of guides).
    Last,
    /// The sum over the frame's steps (an event count: collisions, contacts).
    Sum,
    /// The largest step value.
    Max,
}

/// One named number of a step or a frame: logged as a scalar at `path` (`/stats/<name>`),
/// printed and written to JSON by the bench under its last path segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stat {
    /// The entity path, `/stats/<name>` (an interface: documented in README).
    pub path: &'static str,
    pub value: f64,
    /// How the frame's value is made from its steps'.
    pub aggregate: Aggregate,
}

impl Stat {
    /// The last path segment (`interpenetrating_pairs` for `/stats/interpenetrating_pairs`).
    pub fn name(&self) -> &'static str {
        self.path.rsplit('/').next().unwrap_or(self.path)
    }
}

/// One split or merge.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptEvent {
    pub kind: EventKind,
    /// Simulated time at the end of the step in which it happened, s.
    pub time: f64,
    /// The AWT (top-level GC) it happened in.
    pub tree: u32,
    /// Level of the coarse node: the node that split, or the super-node merged into.
    pub level: u8,
    /// GC index of the coarse node within its level.
    pub gc: u32,
    /// Cross-section index i (0 = root).
    pub cross_section: u16,
    /// GC indices (within `level + 1`) of the sub-nodes activated or merged.
    pub sub_gcs: std::ops::Range<u32>,
    /// World position of the coarse node.
    pub position: [f64; 3],
    /// |a|·r of the coarse node when it happened (the split trigger), m²/s².
    pub accel_radius: f64,
    /// Largest relative speed among the sub-nodes (the merge trigger), m/s.
    pub rel_velocity: f64,
}

/// Time spent in each stage of a step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    pub forces: Duration,
    pub interactions: Duration,
    pub integrate: Duration,
    pub links: Duration,
    pub obstacles: Duration,
    pub adapt: Duration,
    pub follow: Duration,
}

impl StageTimes {
    pub fn total(&self) -> Duration {
        self.forces
            + self.interactions
            + self.integrate
            + self.links
            + self.obstacles
            + self.adapt
            + self.follow
    }

    pub fn add(&mut self, o: &StageTimes) {
        self.forces += o.forces;
        self.interactions += o.interactions;
        self.integrate += o.integrate;
        self.links += o.links;
        self.obstacles += o.obstacles;
        self.adapt += o.adapt;
        self.follow += o.follow;
    }
}

/// Counters of one step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Counters {
    /// Active nodes on each level, coarsest first (root nodes included).
    pub active_per_level: Vec<u32>,
    /// Active segments (active non-root nodes).
    pub segments: u32,
    /// Segment pairs that reached the cylinder test (sharing a voxel, not adjacent, moving
    /// relative to each other, boxes overlapping).
    pub pairs_tested: u32,
    /// Tested pairs found in contact.
    pub pairs_in_contact: u32,
    /// Segments pushed out of a body sphere.
    pub body_contacts: u32,
    /// Kinetic energy of the active nodes, J.
    pub kinetic_energy: f64,
    pub times: StageTimes,
}

/// What `Simulation::step` returns. Reused between steps: `events` is cleared, not reallocated.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    pub events: Vec<AdaptEvent>,
    pub counters: Counters,
    /// Stats particular to the solver (`/stats/collisions`, `/stats/links_intact`, …), beside
    /// the common [`Counters`]. Cleared by the solver at the start of a step.
    pub stats: Vec<Stat>,
}

impl StepReport {
    /// Sets stat `path` of this step (added if absent; no allocation once it exists).
    pub fn set_stat(&mut self, path: &'static str, value: f64, aggregate: Aggregate) {
        match self.stats.iter_mut().find(|s| s.path == path) {
            Some(s) => {
                s.value = value;
                s.aggregate = aggregate;
            }
            None => self.stats.push(Stat {
                path,
                value,
                aggregate,
            }),
        }
    }
}
