//! The Adaptive Wisp Tree simulation (AWT §2.2–§4), without threads, I/O or Rerun.
//!
//! `Simulation::step` is the one place where the stages are ordered:
//!
//! ```text
//! pose → forces → interactions → integrate → links → obstacles → adapt (split, merge)
//! ```
//!
//! State lives in two forms. Every node of every level has a slot in the per-level arrays of
//! [`forest::Forest`] (position, velocity, acceleration, radius, following offset). The active
//! nodes are also gathered into compact structure-of-arrays [`Slots`], in topological order
//! (root → tip), on which the dynamics run; they are scattered back before the tree adapts and
//! gathered again only when the active set changed. Non-active nodes are not moved every step:
//! their followed positions (§3.3) are computed when needed (a split, a merge, a display frame).

mod as_solver;
pub mod collide;
pub mod dynamics;
pub mod forest;
pub mod inspect;
mod slots;
mod step;
pub mod tunables;

pub use slots::{Segments, Slots};

use std::sync::{Arc, OnceLock};

use nalgebra::Vector3;

use crate::model::HairModel;
use crate::motion::{Motion, Pose};
use crate::style::{Link, SimParams};

pub use crate::report::{AdaptEvent, Counters, EventKind, StepReport};
pub use forest::Forest;

/// Contacts reserved per finest node (AWT runs peak at ~8 per finest node on the paper styles
/// under `lean`; single-level runs need more and grow the list once while warming up).
pub const CONTACTS_PER_FINEST_NODE: usize = 12;

/// Threads the pair search uses by default: 2 on any machine with 2 or more cores, else 1, or
/// what the environment variable `WISPTREE_THREADS` says (1 or 2; larger numbers mean 2, and a
/// value that is not a whole number is ignored, with a warning on standard error, once). Read
/// once per process. The results do not depend on it.
///
/// 2 on a 2-core machine too (issue 25): on dense scenes (split threshold 0.05 under `shake`,
/// thousands of active nodes) the pair search is nearly the whole step, and a second core
/// halves it. Earlier this was 1 on 2 cores, because `wisptree run` keeps a logging thread busy
/// and a helper preempted in the middle of its chunk made the simulation wait for it; the
/// chunks are claimed from a shared counter (see [`collide::HairCollider`]), so a
/// descheduled helper only costs the chunk it holds.
pub fn default_threads() -> usize {
    static THREADS: OnceLock<usize> = OnceLock::new();
    *THREADS.get_or_init(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let default = if cores >= 2 { 2 } else { 1 };
        match std::env::var("WISPTREE_THREADS") {
            Ok(v) => match v.trim().parse::<usize>() {
                Ok(t) => t.clamp(1, 2),
                Err(_) => {
                    eprintln!(
                        "wisptree: WISPTREE_THREADS={v:?} is not a number of threads (1 or 2); \
                         using {default}"
                    );
                    default
                }
            },
            Err(_) => default,
        }
    })
}

/// Marks "no slot" (a root's parent).
pub const NO_SLOT: u32 = u32::MAX;

/// Parameters that may change while the simulation runs (keyboard, style reload).
#[derive(Debug, Clone, PartialEq)]
pub struct Tunables {
    /// The simulation parameters.
    pub params: SimParams,
    /// The link model.
    pub link: Link,
}

/// A running simulation of one hair model under one motion.
pub struct Simulation {
    /// The hair model.
    pub model: Arc<HairModel>,
    /// The motion of the head and body.
    pub motion: Motion,
    /// The parameters in force.
    pub params: SimParams,
    /// The link model in force.
    pub link: Link,
    /// Every finest node active and no adaptation (the §5.2 comparison).
    pub single_level: bool,
    /// Every node of every level (state, active set, offsets).
    pub forest: Forest,
    /// The active nodes in compact arrays.
    pub slots: Slots,
    time: f64,
    steps: u64,
    /// While settling, the pose stays at t = 0 and the tree does not adapt.
    settling: bool,
    pose: Pose,
    prev_pose: Pose,
    collider: collide::HairCollider,
    spheres: Vec<collide::BodySphere>,
    dyn_scratch: dynamics::Scratch,
    adapt_scratch: forest::AdaptScratch,
    /// Per finest node, its rest tangent as [`forest::min_rotation`] normalises it, computed
    /// once (the model does not change): [`Simulation::strand_points`] runs for every strand
    /// point of every rendered frame, and these two square roots and six divisions were a
    /// third of its time. Kept with the model they were computed from, and used only while
    /// `model` is still that one.
    rest_units: OnceLock<(Arc<HairModel>, Vec<Vector3<f64>>)>,
}

impl Simulation {
    /// Starts at rest in the motion's pose at t = 0, with only the coarsest nodes active (or,
    /// in single-level mode, only the finest).
    pub fn new(model: Arc<HairModel>, motion: Motion, single_level: bool) -> Simulation {
        Self::with_params(model, motion, single_level, None)
    }

    /// Like `new`, with parameters other than the style's.
    pub fn with_params(
        model: Arc<HairModel>,
        motion: Motion,
        single_level: bool,
        tunables: Option<Tunables>,
    ) -> Simulation {
        let (params, link) = match tunables {
            Some(t) => (t.params, t.link),
            None => (SimParams::default(), model.link.clone()),
        };
        let pose = motion.pose(0.0);
        let forest = Forest::new(&model, &pose, single_level);
        let collider = Self::collider_for(&model);
        let adapt_scratch = forest::AdaptScratch::for_model(&model);
        let mut sim = Simulation {
            model,
            motion,
            params,
            link,
            single_level,
            forest,
            slots: Slots::default(),
            time: 0.0,
            steps: 0,
            settling: false,
            pose,
            prev_pose: pose,
            collider,
            spheres: Vec::new(),
            dyn_scratch: dynamics::Scratch::default(),
            adapt_scratch,
            rest_units: OnceLock::new(),
        };
        sim.gather();
        sim.settle();
        sim
    }

    /// A collider with every buffer reserved from the model's size (at most one active node
    /// per finest cross-section; [`CONTACTS_PER_FINEST_NODE`] contacts per finest node), using
    /// [`default_threads`] threads.
    fn collider_for(model: &HairModel) -> collide::HairCollider {
        let nodes = model.nodes_on_level(model.level_count() - 1);
        let mut c =
            collide::HairCollider::with_capacity(nodes, nodes, CONTACTS_PER_FINEST_NODE * nodes);
        c.set_threads(default_threads());
        c
    }

    /// A report with room for everything a step of this simulation writes into it, so that
    /// even the first step with it does not allocate.
    pub fn new_report(&self) -> StepReport {
        let mut r = StepReport::default();
        r.events
            .reserve(self.model.nodes_on_level(self.model.level_count() - 1));
        r.counters.active_per_level = vec![0; self.model.level_count()];
        r
    }

    /// Threads of the hair–hair pair search (1 or 2). The simulation's result does not depend
    /// on it (see [`collide::HairCollider`]).
    pub fn set_threads(&mut self, threads: usize) {
        self.collider.set_threads(threads);
    }

    /// Threads of the hair–hair pair search.
    pub fn threads(&self) -> usize {
        self.collider.threads()
    }

    /// Bytes held by the collider's reused buffers (both threads'): constant while no buffer
    /// grows.
    pub fn reserved_bytes(&self) -> usize {
        self.collider.capacity_bytes()
    }

    /// Lets the hair hang in the starting pose for `params.settle` seconds, then starts the
    /// clock at 0 with everything at rest.
    fn settle(&mut self) {
        self.settling = true;
        let (seconds, dt) = (self.params.settle, self.params.dt);
        let steps = crate::solver::settle_steps(seconds, dt, |r| self.step(r));
        self.settling = false;
        if steps == 0 {
            return;
        }
        self.time = 0.0;
        self.steps = 0;
        let s = &mut self.slots;
        for c in 0..s.len() {
            if s.parent[c] != NO_SLOT {
                s.vel[c] = Vector3::zeros();
            }
            s.acc[c] = Vector3::zeros();
        }
        dynamics::pose_roots(&self.model, &self.pose, &mut self.slots);
        self.scatter();
        self.forest.follow_all(&self.model, &self.pose);
    }

    /// A simulation with the style's own parameters.
    pub fn from_style(
        model: Arc<HairModel>,
        style: &crate::style::Style,
        motion: Motion,
        single_level: bool,
    ) -> Simulation {
        Self::with_params(
            model,
            motion,
            single_level,
            Some(Tunables {
                params: style.sim.clone(),
                link: style.link.clone(),
            }),
        )
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps since t = 0.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// The head and body pose now.
    pub fn pose(&self) -> &Pose {
        &self.pose
    }

    /// Applies new parameters from the next step on (the hair state is kept).
    pub fn set_tunables(&mut self, t: Tunables) {
        self.params = t.params;
        self.link = t.link;
        self.refresh_slot_constants();
    }

    /// Rebuilds the compact arrays from the forest's active set.
    /// Computes the followed positions of every non-active node below an active one (§3.3).
    /// Call before reading non-active positions (display, tests).
    pub fn update_followers(&mut self) {
        self.scatter();
        self.forest.follow_all(&self.model, &self.pose);
    }

    /// Position of the node `(level, g*K+i)` as of the last `update_followers` (active nodes:
    /// current).
    pub fn node_position(&self, level: usize, node: usize) -> Vector3<f64> {
        let slot = self.forest.slot_of[level][node];
        if self.forest.active[level][node] && (slot as usize) < self.slots.len() {
            self.slots.pos[slot as usize]
        } else {
            self.forest.state[level].pos[node]
        }
    }

    /// Writes the points of strand `s` (K of them) into `out`, following its finest GC.
    /// Requires `update_followers` since the last step.
    pub fn strand_points(&self, s: usize, out: &mut Vec<Vector3<f64>>) {
        let m = &*self.model;
        let k = m.k;
        let f = m.strands.finest_gc[s] as usize;
        let fin = m.level_count() - 1;
        let pos = &self.forest.state[fin].pos;
        let (from, units) = self.rest_units.get_or_init(|| {
            let units = (0..m.nodes_on_level(fin))
                .map(|node| m.rest_tangent(fin, node / k, node % k).normalize())
                .collect();
            (self.model.clone(), units)
        });
        let cached = Arc::ptr_eq(from, &self.model);
        for i in 0..k {
            let x = pos[f * k + i];
            let t_now = if i == 0 {
                pos[f * k + 1] - x
            } else {
                x - pos[f * k + i - 1]
            };
            // The same rotation as `min_rotation(&m.rest_tangent(fin, f, i), &t_now)`.
            let r = if cached {
                forest::min_rotation_from_unit(&units[f * k + i], &t_now)
            } else {
                forest::min_rotation(&m.rest_tangent(fin, f, i), &t_now)
            };
            out.push(x + r * m.strands.offset[s * k + i]);
        }
    }

    /// Checks the AWT invariant; see [`Forest::validate`].
    pub fn validate(&self) -> Result<(), String> {
        self.forest.validate(&self.model, &self.pose)?;
        // Slots agree with the forest.
        let active: usize = self
            .forest
            .active
            .iter()
            .map(|a| a.iter().filter(|x| **x).count())
            .sum();
        if active != self.slots.len() {
            return Err(format!(
                "{} active nodes but {} slots",
                active,
                self.slots.len()
            ));
        }
        for c in 0..self.slots.len() {
            let p = self.slots.parent[c];
            if p != NO_SLOT && self.slots.level[p as usize] > self.slots.level[c] {
                return Err(format!("slot {c}: parent is finer than the node"));
            }
            if !self.slots.pos[c].iter().all(|x| x.is_finite()) {
                return Err(format!("slot {c}: position is not finite"));
            }
        }
        Ok(())
    }

    /// Total momentum of the active non-root nodes.
    pub fn momentum(&self) -> Vector3<f64> {
        let s = &self.slots;
        (0..s.len())
            .filter(|&c| s.parent[c] != NO_SLOT)
            .map(|c| s.vel[c] * s.mass[c])
            .sum()
    }

    /// Mass of the active nodes (root nodes included): always the hair's total mass.
    pub fn active_mass(&self) -> f64 {
        self.slots.mass.iter().sum()
    }

    /// Merge candidates refused in the last step by condition (1) radius, (2) relative
    /// velocity, (3) would split at once.
    pub fn merge_refused(&self) -> [u32; 3] {
        self.adapt_scratch.merge_refused
    }

    /// Number of active nodes.
    pub fn active_count(&self) -> usize {
        self.slots.len()
    }
}
