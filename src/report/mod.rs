//! What one simulation step reports, whatever the solver: events (AWT splits and merges, guide
//! insertions and removals), the common counters, the solver's own stats, stage timings.

use std::time::Duration;

pub mod tempo;

/// Names of the stats every solver reports (see README, "Entity paths": `stream` logs a stat
/// at `/stats/<name>`); a solver's own stats are named where it sets them.
pub mod names {
    /// The per-level active node counts are named below this.
    pub const ACTIVE_LEVEL_PREFIX: &str = "active_nodes/";
    /// Names of the per-level active node counts, `active_nodes/level_N` (a model has at most
    /// this many levels: the style validation refuses more).
    pub const ACTIVE_LEVELS: [&str; 8] = [
        "active_nodes/level_0",
        "active_nodes/level_1",
        "active_nodes/level_2",
        "active_nodes/level_3",
        "active_nodes/level_4",
        "active_nodes/level_5",
        "active_nodes/level_6",
        "active_nodes/level_7",
    ];
    /// Splits in the frame (AWT §3.1).
    pub const SPLITS: &str = "splits";
    /// Merges in the frame (AWT §3.2).
    pub const MERGES: &str = "merges";
    /// Segment pairs that reached the exact test, summed over the frame's steps.
    pub const PAIRS_TESTED: &str = "pairs_tested";
    /// Tested pairs found in contact, summed over the frame's steps.
    pub const PAIRS_IN_CONTACT: &str = "pairs_in_contact";
    /// Body contacts, summed over the frame's steps.
    pub const BODY_CONTACTS: &str = "body_contacts";
    /// Kinetic energy at the end of the frame, J.
    pub const KINETIC_ENERGY: &str = "kinetic_energy";
    /// Wall-clock time per step, ms.
    pub const STEP_MS: &str = "step_ms";
    /// Frames dropped so far because the logger fell behind (live only).
    pub const DROPPED_FRAMES: &str = "dropped_frames";
    /// Simulated seconds per wall second over the last second of frames: 1 is live, under 1
    /// slow motion (in a recording: how fast the run went). See [`super::tempo`].
    pub const REALTIME_FACTOR: &str = "realtime_factor";
}

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

/// What a stat is: a count or measure of the run, or a tunable parameter in force. `stream`
/// logs the first at `/stats/<name>` and the second at `/params/<name>`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StatGroup {
    /// A count or measure (`/stats/<name>`).
    Stats,
    /// A tunable in force, by its table name (`/params/<name>`).
    Params,
}

/// One named number of a step or a frame: logged as a scalar by `stream` (at `/stats/<name>`
/// or `/params/<name>`), printed and written to JSON by the bench under its name.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stat {
    /// The name (`links_intact`; an interface: documented in README).
    pub name: &'static str,
    /// A measure or a tunable in force.
    pub group: StatGroup,
    /// The value (unit in the name's documentation).
    pub value: f64,
    /// How the frame's value is made from its steps'.
    pub aggregate: Aggregate,
}

impl Stat {
    /// A measure `name` (group [`StatGroup::Stats`]).
    pub fn new(name: &'static str, value: f64, aggregate: Aggregate) -> Stat {
        Stat {
            name,
            group: StatGroup::Stats,
            value,
            aggregate,
        }
    }
}

/// One split or merge.
#[derive(Debug, Clone, PartialEq)]
pub struct AdaptEvent {
    /// What happened.
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
    /// |a|·r of the coarse node when it happened (the split trigger), N·m·kg⁻¹.
    pub accel_radius: f64,
    /// Largest relative speed among the sub-nodes (the merge trigger), m/s.
    pub rel_velocity: f64,
}

/// The stages of a step, named once: every solver times its stages with these (a solver
/// without one of them leaves it at zero), and the bench prints them in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Pose, external forces (gravity, drag, wind).
    Forces,
    /// Hair–hair interaction detection and response.
    Interactions,
    /// Integration of the dynamics.
    Integrate,
    /// Link constraints (rigid links, springs between steps).
    Links,
    /// Body collisions.
    Obstacles,
    /// Adaptation (AWT split and merge, guide insertion and removal).
    Adapt,
    /// Following (non-simulated nodes and strands).
    Follow,
}

impl Stage {
    /// Every stage, in step order.
    pub const ALL: [Stage; 7] = [
        Stage::Forces,
        Stage::Interactions,
        Stage::Integrate,
        Stage::Links,
        Stage::Obstacles,
        Stage::Adapt,
        Stage::Follow,
    ];

    /// Its name in tables and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Forces => "forces",
            Stage::Interactions => "interactions",
            Stage::Integrate => "integrate",
            Stage::Links => "links",
            Stage::Obstacles => "obstacles",
            Stage::Adapt => "adapt",
            Stage::Follow => "follow",
        }
    }
}

/// Time spent in each stage of a step: one timer per [`Stage`] (rapier keeps one `Timer` per
/// stage in its `counters`; this is the same idea without the compile-time switch: a clock read
/// per stage is nothing next to a stage).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes([Duration; 7]);

impl StageTimes {
    /// Runs `f` and adds its wall time to `stage`.
    #[inline]
    pub fn time<R>(&mut self, stage: Stage, f: impl FnOnce() -> R) -> R {
        let t0 = std::time::Instant::now();
        let r = f();
        self.0[stage as usize] += t0.elapsed();
        r
    }

    /// The time of one stage.
    pub fn get(&self, stage: Stage) -> Duration {
        self.0[stage as usize]
    }

    /// All stages together.
    pub fn total(&self) -> Duration {
        self.0.iter().sum()
    }

    /// Adds another step's times.
    pub fn add(&mut self, o: &StageTimes) {
        for (a, b) in self.0.iter_mut().zip(o.0) {
            *a += b;
        }
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
    /// Wall time per stage.
    pub times: StageTimes,
}

/// What `Simulation::step` returns. Reused between steps: `events` is cleared, not reallocated.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    /// Events of the step, in order.
    pub events: Vec<AdaptEvent>,
    /// The common counters.
    pub counters: Counters,
    /// Stats particular to the solver (`/stats/collisions`, `/stats/links_intact`, …), beside
    /// the common [`Counters`]. Cleared by the solver at the start of a step.
    pub stats: Vec<Stat>,
}

impl StepReport {
    /// Sets stat `name` of this step (added if absent; no allocation once it exists).
    pub fn set_stat(&mut self, name: &'static str, value: f64, aggregate: Aggregate) {
        match self.stats.iter_mut().find(|s| s.name == name) {
            Some(s) => {
                s.value = value;
                s.aggregate = aggregate;
            }
            None => self.stats.push(Stat::new(name, value, aggregate)),
        }
    }
}
