//! The Adaptive Wisp Tree simulation (AWT §2.2–§4), without threads, I/O or Rerun.
//!
//! `Simulation::step` is the one place where the stages are ordered:
//!
//! ```text
//! pose → forces → interactions → integrate → links → obstacles → adapt (split, merge)
//! ```
//!
//! State lives in two forms. Every node of every level has a slot in the per-level arrays of
//! [`awt::Forest`] (position, velocity, acceleration, radius, following offset). The active
//! nodes are also gathered into compact structure-of-arrays [`Slots`], in topological order
//! (root → tip), on which the dynamics run; they are scattered back before the tree adapts and
//! gathered again only when the active set changed. Non-active nodes are not moved every step:
//! their followed positions (§3.3) are computed when needed (a split, a merge, a display frame).

mod as_solver;
pub mod awt;
pub mod collide;
pub mod dynamics;
pub mod report;

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{Point3, Vector3};

use crate::model::HairModel;
use crate::motion::{Motion, Pose};
use crate::style::{Link, SimParams};

pub use awt::Forest;
pub use report::{AdaptEvent, Counters, EventKind, StepReport};

/// Contacts reserved per finest node (AWT runs peak at ~8 per finest node on the paper styles
/// under `lean`; single-level runs need more and grow the list once while warming up).
pub const CONTACTS_PER_FINEST_NODE: usize = 12;

/// Threads the pair search uses by default: 2 on a machine with 3 or more cores, else 1, or
/// what the environment variable `WISPTREE_THREADS` says (1 or 2). The results do not depend
/// on it.
///
/// Why not 2 on a 2-core machine: `wisptree run` already keeps two threads busy (simulation and
/// logging), and a helper preempted in the middle of its chunk makes the simulation wait for it:
/// measured on the 2-core development machine, the 10 s Long curly recording took 7.4–7.6 s
/// with the helper against 5.7 s without, in the same minute (and 3.9–4.1 against 4.1–4.3 s
/// when the machine was quiet).
pub fn default_threads() -> usize {
    if let Some(t) = std::env::var("WISPTREE_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        return t.clamp(1, 2);
    }
    match std::thread::available_parallelism().map_or(1, |n| n.get()) {
        0..=2 => 1,
        _ => 2,
    }
}

/// Marks "no slot" (a root's parent).
pub const NO_SLOT: u32 = u32::MAX;

/// The active nodes in compact arrays, topologically ordered (every parent before its children).
#[derive(Debug, Default, Clone)]
pub struct Slots {
    /// Level and node index (`g * K + i`) of each slot.
    pub level: Vec<u8>,
    pub node: Vec<u32>,
    /// Cross-section index.
    pub cs: Vec<u16>,
    /// Parent slot (`NO_SLOT` for roots, which are kinematic).
    pub parent: Vec<u32>,
    pub pos: Vec<Vector3<f64>>,
    pub prev_pos: Vec<Vector3<f64>>,
    pub vel: Vec<Vector3<f64>>,
    pub vel_start: Vec<Vector3<f64>>,
    pub acc: Vec<Vector3<f64>>,
    pub force: Vec<Vector3<f64>>,
    pub mass: Vec<f64>,
    /// Mass carried by the link ending at the node (node to tip of its GC).
    pub mass_below: Vec<f64>,
    pub radius: Vec<f64>,
    /// Rest vector from the parent to this node in the rest pose (the styled direction).
    pub rest_vec: Vec<Vector3<f64>>,
    pub rest_len: Vec<f64>,
    /// Scratch: positions before the body stage, and which nodes the body touched this step.
    pub pre_body: Vec<Vector3<f64>>,
    pub contact: Vec<bool>,
    /// Segments (non-root slots) for the collider.
    pub segs: Segments,
}

/// The active segments (one per non-root slot, in slot order), as the collider sees them.
#[derive(Debug, Default, Clone)]
pub struct Segments {
    /// Parent and child slot.
    pub parent: Vec<u32>,
    pub child: Vec<u32>,
    /// The child's radius (AWT §4.1) and mass.
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    /// The generalized cylinder `(level, GC)` of the child node, numbered over all levels.
    pub chain: Vec<u32>,
}

impl Segments {
    pub fn view(&self) -> collide::SegmentsView<'_> {
        collide::SegmentsView {
            parent: &self.parent,
            child: &self.child,
            radius: &self.radius,
            child_mass: &self.mass,
            chain: &self.chain,
        }
    }

    pub fn len(&self) -> usize {
        self.child.len()
    }

    pub fn is_empty(&self) -> bool {
        self.child.is_empty()
    }

    fn reserve(&mut self, n: usize) {
        self.parent.reserve(n);
        self.child.reserve(n);
        self.radius.reserve(n);
        self.mass.reserve(n);
        self.chain.reserve(n);
    }

    fn clear(&mut self) {
        self.parent.clear();
        self.child.clear();
        self.radius.clear();
        self.mass.clear();
        self.chain.clear();
    }
}

impl Slots {
    fn reserve(&mut self, n: usize) {
        let n = n.saturating_sub(self.level.len());
        self.level.reserve(n);
        self.node.reserve(n);
        self.cs.reserve(n);
        self.parent.reserve(n);
        self.pos.reserve(n);
        self.prev_pos.reserve(n);
        self.vel.reserve(n);
        self.vel_start.reserve(n);
        self.acc.reserve(n);
        self.force.reserve(n);
        self.mass.reserve(n);
        self.mass_below.reserve(n);
        self.radius.reserve(n);
        self.rest_vec.reserve(n);
        self.rest_len.reserve(n);
        self.pre_body.reserve(n);
        self.contact.reserve(n);
        self.segs.reserve(n);
    }

    pub fn len(&self) -> usize {
        self.level.len()
    }
    pub fn is_empty(&self) -> bool {
        self.level.is_empty()
    }
    fn clear(&mut self) {
        self.level.clear();
        self.node.clear();
        self.cs.clear();
        self.parent.clear();
        self.pos.clear();
        self.prev_pos.clear();
        self.vel.clear();
        self.vel_start.clear();
        self.acc.clear();
        self.force.clear();
        self.mass.clear();
        self.mass_below.clear();
        self.radius.clear();
        self.rest_vec.clear();
        self.rest_len.clear();
        self.pre_body.clear();
        self.contact.clear();
        self.segs.clear();
    }
}

/// Parameters that may change while the simulation runs (keyboard, style reload).
#[derive(Debug, Clone, PartialEq)]
pub struct Tunables {
    pub params: SimParams,
    pub link: Link,
}

/// A running simulation of one hair model under one motion.
pub struct Simulation {
    pub model: Arc<HairModel>,
    pub motion: Motion,
    pub params: SimParams,
    pub link: Link,
    /// Every finest node active and no adaptation (the §5.2 comparison).
    pub single_level: bool,
    pub forest: Forest,
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
    adapt_scratch: awt::AdaptScratch,
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
        let adapt_scratch = awt::AdaptScratch::for_model(&model);
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
        let steps = (self.params.settle / self.params.dt).round() as usize;
        if steps == 0 {
            return;
        }
        self.settling = true;
        let mut report = StepReport::default();
        for _ in 0..steps {
            self.step(&mut report);
        }
        self.settling = false;
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

    pub fn time(&self) -> f64 {
        self.time
    }
    pub fn steps(&self) -> u64 {
        self.steps
    }
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
    fn gather(&mut self) {
        let m = &*self.model;
        let k = m.k;
        let f = &mut self.forest;
        let s = &mut self.slots;
        s.clear();
        // At most one active node per finest cross-section: reserve that once, so the active
        // set can grow to anything without reallocating inside a step.
        s.reserve(m.nodes_on_level(m.level_count() - 1));
        for i in 0..k {
            for (l, lv) in m.levels.iter().enumerate() {
                for g in 0..lv.gc_count() {
                    let j = g * k + i;
                    if !f.active[l][j] {
                        continue;
                    }
                    let slot = s.level.len() as u32;
                    f.slot_of[l][j] = slot;
                    s.level.push(l as u8);
                    s.node.push(j as u32);
                    s.cs.push(i as u16);
                    let parent = if i == 0 {
                        NO_SLOT
                    } else {
                        let (pl, pj) = f
                            .governor_above(m, l, g, i - 1)
                            .expect("the AWT invariant gives every non-root node a parent");
                        f.slot_of[pl][pj]
                    };
                    s.parent.push(parent);
                    let st = &f.state[l];
                    s.pos.push(st.pos[j]);
                    s.prev_pos.push(st.pos[j]);
                    s.vel.push(st.vel[j]);
                    s.vel_start.push(st.vel[j]);
                    s.acc.push(st.acc[j]);
                    s.force.push(Vector3::zeros());
                    s.mass.push(lv.mass[j]);
                    s.mass_below.push(lv.mass_below[j]);
                    s.radius.push(st.radius[j]);
                    s.rest_vec.push(Vector3::zeros());
                    s.rest_len.push(0.0);
                    s.pre_body.push(Vector3::zeros());
                    s.contact.push(false);
                }
            }
        }
        self.refresh_slot_constants();
    }

    /// Rest vectors and lengths of the active links, and the collider's segment lists.
    fn refresh_slot_constants(&mut self) {
        let m = &*self.model;
        let s = &mut self.slots;
        s.segs.clear();
        // First GC number of each level, for the segments' chain ids.
        let mut first_gc = [0u32; 256];
        for l in 1..m.level_count() {
            first_gc[l] = first_gc[l - 1] + m.levels[l - 1].gc_count() as u32;
        }
        for c in 0..s.len() {
            let p = s.parent[c];
            if p == NO_SLOT {
                continue;
            }
            let rc = m.levels[s.level[c] as usize].rest_pos[s.node[c] as usize];
            let rp = m.levels[s.level[p as usize] as usize].rest_pos[s.node[p as usize] as usize];
            s.rest_vec[c] = rc - rp;
            s.rest_len[c] = (rc - rp).norm();
            let level = s.level[c] as usize;
            s.segs.parent.push(p);
            s.segs.child.push(c as u32);
            s.segs.radius.push(s.radius[c]);
            s.segs.mass.push(s.mass[c]);
            s.segs.chain.push(first_gc[level] + s.node[c] / m.k as u32);
        }
    }

    /// Writes the active nodes' state back into the forest.
    fn scatter(&mut self) {
        let s = &self.slots;
        for c in 0..s.len() {
            let st = &mut self.forest.state[s.level[c] as usize];
            let j = s.node[c] as usize;
            st.pos[j] = s.pos[c];
            st.vel[j] = s.vel[c];
            st.acc[j] = s.acc[c];
            st.radius[j] = s.radius[c];
        }
    }

    /// Advances the simulation by one step of `params.dt`, filling `report`.
    pub fn step(&mut self, report: &mut StepReport) {
        report.events.clear();
        // At most one event per node and step: reserved once, so a step never allocates.
        report
            .events
            .reserve(self.model.nodes_on_level(self.model.level_count() - 1));
        let dt = self.params.dt;
        let t_new = self.time + dt;
        let mut times = report::StageTimes::default();

        // Pose: roots and body spheres move with the character.
        let clock = Instant::now();
        self.prev_pose = self.pose;
        self.pose = self.motion.pose(if self.settling { 0.0 } else { t_new });
        self.spheres.clear();
        for sp in &self.model.body {
            let c = self
                .pose
                .transform_point(&Point3::from(Vector3::from(sp.center)));
            self.spheres.push(collide::BodySphere {
                center: c.coords,
                radius: sp.radius,
            });
        }
        dynamics::begin_step(&mut self.slots);
        dynamics::pose_roots(&self.model, &self.pose, &mut self.slots);
        dynamics::external_forces(
            &self.model,
            &self.params,
            &self.pose,
            t_new,
            &mut self.slots,
        );
        times.forces = clock.elapsed();

        let clock = Instant::now();
        let stats = if self.params.friction > 0.0 || self.params.repulsion > 0.0 {
            let s = &mut self.slots;
            let view = s.segs.view();
            let cp = collide::ContactParams {
                friction: self.params.friction,
                repulsion: self.params.repulsion,
                cos_angle_threshold: self.params.angle_threshold.to_radians().cos(),
                epsilon: self.params.contact_epsilon,
                dt,
            };
            self.collider
                .accumulate(&view, &s.pos, &s.vel, &cp, &mut s.force)
        } else {
            collide::PairStats::default()
        };
        times.interactions = clock.elapsed();

        let clock = Instant::now();
        dynamics::integrate(
            &self.link,
            &self.params,
            t_new,
            dt,
            &mut self.slots,
            &mut self.dyn_scratch,
        );
        times.integrate = clock.elapsed();

        let clock = Instant::now();
        if let Link::Rigid { iterations } = self.link {
            dynamics::project_rigid_links(&mut self.slots, iterations);
        }
        times.links = clock.elapsed();

        let clock = Instant::now();
        let pose = &self.pose;
        let body_contacts = {
            let s = &mut self.slots;
            s.pre_body.copy_from_slice(&s.pos);
            let view = s.segs.view();
            collide::resolve_body(&view, &mut s.pos, &mut s.vel, &self.spheres, |x| {
                pose.velocity_at(&Point3::from(*x))
            })
        };
        {
            // Static friction (§4.3): a node the body pushed keeps its place on the body, i.e.
            // its start-of-step position carried by the body's motion, when that is outside
            // every sphere; otherwise it would slide down the sphere a little every step.
            let carry = self.pose.iso * self.prev_pose.iso.inverse();
            let s = &mut self.slots;
            for c in 0..s.len() {
                s.contact[c] = s.pos[c] != s.pre_body[c];
                if s.contact[c] {
                    let held = (carry * Point3::from(s.prev_pos[c])).coords;
                    if self
                        .spheres
                        .iter()
                        .all(|sp| (held - sp.center).norm() >= sp.radius)
                    {
                        s.pos[c] = held;
                    }
                }
            }
        }
        if matches!(self.link, Link::Rigid { .. }) {
            dynamics::restore_lengths_outside(&mut self.slots, &self.spheres, pose);
            dynamics::rigid_velocities(&mut self.slots, dt);
        }
        dynamics::update_accelerations(&mut self.slots, dt, self.params.accel_smoothing);
        times.obstacles = clock.elapsed();

        self.time = t_new;
        self.steps += 1;

        let clock = Instant::now();
        if !self.single_level && !self.settling {
            self.scatter();
            let changed = awt::adapt(
                &self.model,
                &mut self.forest,
                &self.params,
                self.time,
                &mut self.adapt_scratch,
                &mut report.events,
            );
            if changed {
                self.gather();
                // Roots activated by a split or merge sit exactly on the scalp.
                dynamics::pose_roots(&self.model, &self.pose, &mut self.slots);
                // New links join followed positions, which need not be at rest length (and a
                // followed node may sit inside the body): one exact pass ends the step valid.
                if matches!(self.link, Link::Rigid { .. }) {
                    dynamics::restore_lengths_outside(&mut self.slots, &self.spheres, &self.pose);
                } else {
                    let s = &mut self.slots;
                    let view = s.segs.view();
                    let pose = &self.pose;
                    collide::resolve_body(&view, &mut s.pos, &mut s.vel, &self.spheres, |x| {
                        pose.velocity_at(&Point3::from(*x))
                    });
                }
            }
        }
        self.scatter();
        times.adapt = clock.elapsed();

        let c = &mut report.counters;
        c.active_per_level.clear();
        c.active_per_level.resize(self.model.level_count(), 0);
        let mut ke = 0.0;
        for (slot, &l) in self.slots.level.iter().enumerate() {
            c.active_per_level[l as usize] += 1;
            if self.slots.parent[slot] != NO_SLOT {
                ke += 0.5 * self.slots.mass[slot] * self.slots.vel[slot].norm_squared();
            }
        }
        c.segments = self.slots.segs.len() as u32;
        c.pairs_tested = stats.tested;
        c.pairs_in_contact = stats.in_contact;
        c.body_contacts = body_contacts;
        c.kinetic_energy = ke;
        c.times = times;
    }

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
        for i in 0..k {
            let x = pos[f * k + i];
            let t_now = if i == 0 {
                pos[f * k + 1] - x
            } else {
                x - pos[f * k + i - 1]
            };
            let t_ref = m.rest_tangent(fin, f, i);
            let r = awt::min_rotation(&t_ref, &t_now);
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
