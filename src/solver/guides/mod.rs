//! Guide strands (Chang, Jin, Yu 2002, "A practical model for hair mutual interactions") as
//! `--model guides`: a sparse set of guide strands, each a multibody chain in generalized
//! coordinates ([`chain`], advanced guide by guide on the pool's threads by `advance`), held
//! in shape by joint actuators and breakable static links
//! ([`links`], §4.1), kept apart by triangle strips ([`strips`], §4.2), out of the body
//! ([`body`], §3.3), with guides inserted and removed where neighbours drift apart
//! ([`adapt`], §4.3), and every strand of the model following its nearest guides ([`dense`],
//! §5).

pub mod adapt;
mod advance;
pub mod body;
pub mod chain;
pub mod dense;
mod display;
pub mod inspect;
pub mod links;
pub mod obstacle;
pub mod params;
mod solve;
pub mod strips;
pub mod tunables;

use std::sync::Arc;

use nalgebra::{Matrix3, Point3, Vector2, Vector3, Vector6};

use crate::model::HairModel;
use crate::motion::{Motion, Pose};
use crate::solver::Solver;
use crate::style::SimParams;

use body::PosedSphere;
use chain::{Base, Chains};
use dense::Dense;
use links::Links;
pub use params::{GuideParams, StripLayout};
use strips::Strips;

/// Largest angle a joint may turn in one integration step, rad.
const MAX_TURN: f64 = 0.1;

/// Most passes of the body correction per guide and sub-step (see `substep`). Three left a
/// node of Long curly under `shake` 5 mm inside the head at one 10 ms sub-step per step; the
/// passes stop as soon as one pushes nothing.
///
/// Most sub-steps resting on the body never got there (2026-12-07, counted in a throwaway
/// build, `examples/layered_probe long_curly stop 3 guides`): 60 % of the guides' sub-steps
/// ran all eight passes, because the joints give back positions 1e-9 to 1e-4 m within the
/// margin (rounding, and the crease of two spheres that six rounds leave a little inside),
/// and the passes cost more than the integration (545 against 157 ms of CPU per simulated
/// second). So a pass after the first runs only while a vertex is deeper than
/// [`CORRECTION_RESIDUAL`] within the margin. That changes the paths, which found the
/// guides' two whips: the lagging damping factor's (now capped, see [`Chains::soft`]) and a
/// tip joint outrunning the split integration (see [`MAX_SPLIT`]).
const CORRECTION_PASSES: usize = 8;

/// How deep within the body's margin (3 mm by default) a vertex may stay after the first
/// pass of the body correction without another, m: 1 µm, about a hundredth of a hair's width
/// and never inside the body itself. The first pass (the one with friction, §3.3) always runs.
const CORRECTION_RESIDUAL: f64 = 1e-6;

/// Most pieces a guide's sub-step is split into. At one 10 ms sub-step per step the whipped
/// tips of short hair under `shake` need pieces of about 0.1 ms (32 pieces left short hair's
/// root joints non-finite).
///
/// The step itself cannot simply grow to buy speed (2026-12-06, the style's `sim: (dt: 0.02,
/// steps_per_frame: 2)`, `examples/layered_probe STYLE MOTION 4 guides`): Long curly's
/// guides then kept up live under every motion (1.02–1.43 against 0.56–0.78 at 10 ms that
/// day), but Short and Short curly under `shake` went non-finite within 4 s, and the kinetic
/// energy at 4 s rose on every style that stayed finite (1.1–1.2× under `shake`, 1.3–2.7×
/// under `jump`).
///
/// Where 128 pieces were the cap, a whip could run away (2026-12-07, Short under `shake`
/// with [`CORRECTION_RESIDUAL`], traced step by step): one guide's fastest joint went 1,300 →
/// 2,600 → 7,000 rad/s in three steps (a piece of `h / 128` then turns it by more than
/// `MAX_TURN`, where the explicit velocity-product terms add energy), and the guide went
/// non-finite while its vertices' damping factors were 0.2–0.3: the split integration's
/// whip, not the contacts' damping. With 512 that run stays finite, and only the few guides
/// whose joints turn that fast take the extra pieces.
const MAX_SPLIT: f64 = 512.0;

/// The link whose mass vertex `v` of guide `g` carries (`n` segments per guide): the link
/// ending at it, and link 0 for the root.
fn link_at(g: usize, v: usize, n: usize) -> usize {
    g * n + (v % (n + 1)).saturating_sub(1).min(n - 1)
}

/// Marks "no guide".
pub const NO_GUIDE: u32 = u32::MAX;

/// Where a guide slot's strand comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// An empty slot (room for adaptive guides).
    Free,
    /// Chosen from strand `s` of the model.
    Strand(u32),
    /// Inserted halfway between two guides (§4.3).
    Inserted(u32, u32),
}

/// The guide-strand solver.
pub struct GuideSolver {
    model: Arc<HairModel>,
    motion: Motion,
    params: SimParams,
    gp: GuideParams,
    /// The chains of every guide slot.
    pub chains: Chains,
    /// Per slot: where it comes from.
    pub origin: Vec<Origin>,
    /// Number of slots holding the initial guides (slots `0..initial`).
    pub initial: usize,
    /// Per vertex: rest position in the rest pose.
    rest_x: Vec<Vector3<f64>>,
    /// Per vertex: rest position in its guide's root frame, relative to the root.
    rest_local: Vec<Vector3<f64>>,
    /// Per slot: root frame at rest.
    gframe: Vec<Matrix3<f64>>,
    /// Strip pairs between initial guides, and the guide inserted in each (or `NO_GUIDE`).
    base_pairs: Vec<(u32, u32)>,
    mid: Vec<u32>,
    /// Per base pair × vertex: the distance of corresponding vertices on the settled hair.
    pair_d0: Vec<f64>,
    /// The triangle strips in force.
    pub strips: Strips,
    /// The static links.
    pub links: Links,
    dense: Dense,
    /// The alive guides changed since `dense` was bound to them.
    dense_stale: bool,
    /// The only strands the display reads (`Solver::display_strands`), unless `show_all`.
    /// Kept when `show_all` switches on and off (a live run with rendering switches every
    /// frame or two), so that switching allocates nothing.
    shown: Vec<u32>,
    /// Every strand is read (rendering).
    show_all: bool,
    alive: Vec<usize>,
    time: f64,
    pose: Pose,
    settling: bool,
    spheres: Vec<PosedSphere>,
    /// The pose of the body's capsules and meshes (with `spheres`).
    shape_pose: Pose,
    /// Scratch of the runs the guides advance in (see `advance`).
    run_buffers: Vec<std::sync::Mutex<advance::RunBuffers>>,
    disp: Vec<Vector3<f64>>,
    last_contacts: usize,
    last_body: usize,
    /// Integration steps taken by guides whose sub-step was split (see [`MAX_TURN`]).
    pub splits: u64,
    /// The threads of the strips' broad phase and contacts (none: the calling thread only).
    /// The result does not depend on it.
    pool: Option<crate::par::Pool>,
    /// Steps since the strips' contacts were last searched (see
    /// [`GuideParams::contact_search_every`]).
    since_search: u32,
}

/// The head's spatial velocity `(ω; v_O)` at the world origin.
fn spatial_velocity(p: &Pose) -> Vector6<f64> {
    let w = p.angular_velocity;
    let vo = p.linear_velocity - w.cross(&p.iso.translation.vector);
    Vector6::new(w.x, w.y, w.z, vo.x, vo.y, vo.z)
}

/// Resamples polyline `pts` to `m` points uniformly in arc length.
pub fn resample(pts: &[Vector3<f64>], m: usize) -> Vec<Vector3<f64>> {
    let mut cum = vec![0.0];
    for w in pts.windows(2) {
        cum.push(cum.last().unwrap() + (w[1] - w[0]).norm());
    }
    let total = *cum.last().unwrap();
    let mut out = Vec::with_capacity(m);
    let mut seg = 0;
    for j in 0..m {
        let s = total * j as f64 / (m - 1) as f64;
        while seg + 2 < pts.len() && cum[seg + 1] < s {
            seg += 1;
        }
        let span = (cum[seg + 1] - cum[seg]).max(1e-12);
        let t = ((s - cum[seg]) / span).clamp(0.0, 1.0);
        out.push(pts[seg].lerp(&pts[seg + 1], t));
    }
    out
}

/// Picks `count` strands whose roots cover the scalp uniformly: farthest-point sampling from
/// strand 0 (deterministic; ties go to the lower index).
// (`s` indexes strands and their distances alike.)
#[allow(clippy::needless_range_loop)]
pub fn pick_guides(model: &HairModel, count: usize) -> Vec<usize> {
    let k = model.k;
    let n = model.strands.len();
    let count = count.min(n);
    let root = |s: usize| model.strands.rest[s * k];
    let mut d = vec![f64::INFINITY; n];
    let mut out = Vec::with_capacity(count);
    let mut cur = 0;
    for _ in 0..count {
        out.push(cur);
        let r = root(cur);
        let mut best = (f64::NEG_INFINITY, 0);
        for s in 0..n {
            d[s] = d[s].min((root(s) - r).norm_squared());
            if d[s] > best.0 {
                best = (d[s], s);
            }
        }
        cur = best.1;
    }
    out
}

impl GuideSolver {
    /// A solver on `model` under `motion`, settled for `params.settle` seconds.
    pub fn new(
        model: Arc<HairModel>,
        motion: Motion,
        params: SimParams,
        gp: GuideParams,
    ) -> GuideSolver {
        let n = gp.segments;
        let picks = pick_guides(&model, gp.count);
        let initial = picks.len();
        let cap = initial + gp.max_inserted;
        let k = model.k;
        let mut s = GuideSolver {
            chains: Chains::new(n, cap),
            origin: vec![Origin::Free; cap],
            initial,
            rest_x: vec![Vector3::zeros(); cap * (n + 1)],
            rest_local: vec![Vector3::zeros(); cap * (n + 1)],
            gframe: vec![Matrix3::identity(); cap],
            base_pairs: Vec::new(),
            mid: Vec::new(),
            pair_d0: Vec::new(),
            strips: Strips::default(),
            links: Links::default(),
            dense: Dense::new(&model, gp.blend),
            dense_stale: true,
            alive: Vec::with_capacity(cap),
            time: 0.0,
            pose: motion.pose(0.0),
            settling: false,
            spheres: Vec::new(),
            shape_pose: Pose::identity(),
            run_buffers: Vec::new(),
            shown: Vec::new(),
            show_all: true,
            disp: vec![Vector3::zeros(); cap * (n + 1)],
            last_contacts: 0,
            since_search: u32::MAX,
            last_body: 0,
            splits: 0,
            pool: None,
            model,
            motion,
            params,
            gp,
        };
        let rest_spheres: Vec<PosedSphere> = s
            .model
            .body
            .iter()
            .map(|sp| PosedSphere {
                center: Vector3::from(sp.center),
                radius: sp.radius,
                velocity: Vector3::zeros(),
                spin: Vector3::zeros(),
            })
            .collect();
        for (slot, &st) in picks.iter().enumerate() {
            let mut rest = resample(&s.model.strands.rest[st * k..(st + 1) * k], n + 1);
            // A styled shape that dips into the body (curls hugging the scalp) would have the
            // actuators pull it into the body at every step against the §3.3 correction: the
            // rest shape is corrected out of the body once, as the correction would do.
            let lens: Vec<f64> = rest.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
            let mut vel = vec![Vector3::zeros(); n + 1];
            body::correct(
                &mut rest,
                &mut vel,
                &lens,
                &rest_spheres,
                &body::Shapes {
                    colliders: &s.model.colliders,
                    pose: Pose::identity(),
                },
                s.gp.body_margin,
                0.0,
            );
            s.origin[slot] = Origin::Strand(st as u32);
            s.init_slot(slot, &rest);
        }
        s.refresh_alive();
        if s.gp.collision {
            let roots: Vec<_> = s
                .alive
                .iter()
                .map(|&g| (g, s.chains.root_rest[g]))
                .collect();
            s.base_pairs = strips::strip_pairs(
                &roots,
                s.gp.strip_layout,
                s.gp.strip_root_distance,
                &s.model.scalp_center,
            );
            s.mid = vec![NO_GUIDE; s.base_pairs.len()];
        }
        s.set_pool_threads(crate::solver::awt::default_threads());
        s.rebuild_topology();
        s.fk_all(&s.base_at(0.0, 1e-3).0, 0.0);
        s.settle();
        s
    }

    /// Threads of the strips' broad phase and contacts (1 or 2; the result is the same bit for
    /// bit). A pool that cannot be started leaves one thread.
    pub fn set_pool_threads(&mut self, threads: usize) {
        let threads = threads.clamp(1, 2);
        if threads == self.pool_threads() {
            return;
        }
        self.pool = if threads > 1 {
            crate::par::Pool::new(threads).ok()
        } else {
            None
        };
    }

    /// Threads of the strips' broad phase and contacts.
    pub fn pool_threads(&self) -> usize {
        self.pool.as_ref().map_or(1, |p| p.workers())
    }

    /// Runs the strips' pieces and the guides' runs on the build of `level` (`None`: the
    /// process's, [`crate::simd::level`]), so that tests compare the AVX2 build with the
    /// portable one; the result is the same bit for bit.
    #[doc(hidden)]
    pub fn set_simd_level(&mut self, level: Option<crate::simd::Level>) {
        self.strips.set_simd_level(level);
    }

    /// Sets slot `g` up from its rest polyline.
    fn init_slot(&mut self, g: usize, rest: &[Vector3<f64>]) {
        let n = self.gp.segments;
        let mass = self.params.total_mass / self.initial.max(1) as f64;
        self.chains.init_guide(
            g,
            rest,
            mass,
            (
                self.gp.stiffness,
                self.gp.tip_stiffness,
                self.gp.joint_damping,
            ),
        );
        let f = dense::root_frame(&self.model, &rest[0]);
        self.gframe[g] = f;
        for (i, p) in rest.iter().enumerate() {
            self.rest_x[g * (n + 1) + i] = *p;
            self.rest_local[g * (n + 1) + i] = f.transpose() * (p - rest[0]);
        }
    }

    fn refresh_alive(&mut self) {
        self.alive.clear();
        for g in 0..self.chains.capacity() {
            if self.chains.alive[g] {
                self.alive.push(g);
            }
        }
    }

    /// Strips from the base pairs and the inserted guides; the dense binding is redone before
    /// the next display ([`GuideSolver::bind_dense`]).
    fn rebuild_topology(&mut self) {
        let mut pairs = Vec::with_capacity(self.base_pairs.len() * 2);
        for (p, &(a, b)) in self.base_pairs.iter().enumerate() {
            match self.mid[p] {
                NO_GUIDE => pairs.push((a, b)),
                m => {
                    pairs.push((a, m));
                    pairs.push((m, b));
                }
            }
        }
        self.strips.rebuild(
            self.gp.segments,
            &pairs,
            &self.rest_x,
            self.gp.contact_distance,
        );
        self.dense_stale = true;
    }

    /// Binds the dense strands to the guides alive now if the guides changed since the last
    /// binding. Only the display reads the binding: binding once per frame, however often a
    /// frame's steps insert and remove guides, gives the same strands (the binding depends on
    /// the alive guides only, and [`Dense::bind`] gives the full search's result) for less
    /// work.
    fn bind_dense(&mut self) {
        if !self.dense_stale {
            return;
        }
        let roots: Vec<_> = self
            .alive
            .iter()
            .map(|&g| (g, self.chains.root_rest[g]))
            .collect();
        self.dense.bind(&self.model, &roots);
        self.dense_stale = false;
    }

    /// The head's motion at `t` for a sub-step `h`: base of the chains (gravity folded in) and
    /// the pose.
    fn base_at(&self, t: f64, h: f64) -> (Base, Pose) {
        let g = Vector3::from(self.params.gravity);
        advance::head_at(&self.motion, &g, self.settling, t, h)
    }

    fn fk_all(&mut self, base: &Base, _t: f64) {
        let pose_iso = self.pose.iso;
        for idx in 0..self.alive.len() {
            let g = self.alive[idx];
            let root = pose_iso
                .transform_point(&Point3::from(self.chains.root_rest[g]))
                .coords;
            self.chains.fk(g, base, &root);
        }
    }

    /// Lets the hair hang in the starting pose, then builds the static links on the settled
    /// shape and starts at rest.
    fn settle(&mut self) {
        self.settling = true;
        let (seconds, dt) = (self.params.settle, self.params.dt);
        crate::solver::settle_steps(seconds, dt, |r| self.step(r));
        self.settling = false;
        self.time = 0.0;
        self.pose = self.motion.pose(0.0);
        for q in &mut self.chains.qd {
            *q = Vector2::zeros();
        }
        let (base, _) = self.base_at(0.0, self.params.dt);
        self.fk_all(&base, 0.0);
        let originals: Vec<usize> = (0..self.initial).collect();
        self.links = Links::build(
            &self.chains,
            &originals,
            self.gp.links_per_segment,
            self.gp.link_radius,
            self.gp.link_reference,
        );
        self.record_pair_distances();
    }

    /// The guide-strand parameters in force.
    pub fn guide_params(&self) -> &GuideParams {
        &self.gp
    }

    /// Slots of the guides simulated now.
    pub fn alive(&self) -> &[usize] {
        &self.alive
    }

    /// Sum of the guides' energies (kinetic, gravitational, actuators), J.
    pub fn energy(&self) -> f64 {
        let g = Vector3::from(self.params.gravity);
        self.alive.iter().map(|&s| self.chains.energy(s, &g)).sum()
    }

    /// Rest-pose polyline of slot `g` (as styled).
    pub fn rest_polyline(&self, g: usize) -> &[Vector3<f64>] {
        let n = self.gp.segments;
        &self.rest_x[g * (n + 1)..(g + 1) * (n + 1)]
    }

    /// The body spheres at `pose` and the obstacles (`guides.obstacles`) at time `t`.
    fn posed_spheres(&mut self, pose: &Pose, t: f64) {
        self.shape_pose = *pose;
        self.spheres.clear();
        for sp in &self.model.body {
            let c = pose.transform_point(&Point3::from(Vector3::from(sp.center)));
            self.spheres.push(PosedSphere {
                center: c.coords,
                radius: sp.radius,
                velocity: pose.velocity_at(&c),
                spin: pose.angular_velocity,
            });
        }
        // While settling, the obstacles stay where they start.
        let t = if self.settling { 0.0 } else { t };
        for o in &self.gp.obstacles {
            self.spheres.push(obstacle::posed(o, t));
        }
    }

    /// One sub-step of length `h` from `self.time`: forces, articulated-body dynamics,
    /// body correction. `search`: the strips' broad phase is run here too, on this
    /// sub-step's positions (the step has one sub-step).
    fn substep(&mut self, h: f64, search: bool) -> (usize, usize) {
        let t = self.time;
        let (base0, _) = self.base_at(t, h);
        let (base1, pose1) = self.base_at(t + h, h);
        let pose0 = if self.settling {
            pose1
        } else {
            self.motion.pose(t)
        };
        self.posed_spheres(&pose1, t + h);
        // Backward Euler on the damping of every force (see `Chains::soft`), with its factor
        // from the sub-step before, capped by this sub-step's damping: the damping
        // coefficients of the forces are gathered first (air drag, links, contacts), then each
        // vertex's factor is set, and only then are the forces added, each scaled by it.
        let n = self.gp.segments;
        let drag = self.params.air_drag;
        for &g in &self.alive {
            for v in self.chains.verts(g) {
                let l = link_at(g, v, n);
                let c = drag * self.chains.m[l];
                self.chains.soft[v] =
                    1.0 / (1.0 + h * (self.chains.damp[v] + c) / self.chains.m[l]);
                self.chains.damp[v] = c;
            }
        }
        let linked = !self.settling && self.gp.link_strength > 0.0;
        if linked {
            self.links.evaluate(
                &mut self.chains,
                self.gp.link_strength,
                self.gp.link_damping,
            );
        }
        let contacts = if self.gp.collision && search {
            // A fresh search every `contact_search_every` steps; in between, the contacts it
            // found, evaluated again on the current state.
            self.since_search = self.since_search.saturating_add(1);
            if self.since_search >= self.gp.contact_search_every {
                self.since_search = 0;
                self.strips.detect_evaluate_on(
                    self.pool.as_ref(),
                    &mut self.chains,
                    &self.alive,
                    &self.gp,
                )
            } else {
                self.strips
                    .reevaluate_on(self.pool.as_ref(), &mut self.chains, &self.gp)
            }
        } else if self.gp.collision {
            self.strips
                .evaluate_on(self.pool.as_ref(), &mut self.chains, &self.gp)
        } else {
            0
        };
        for &g in &self.alive {
            for v in self.chains.verts(g) {
                let l = link_at(g, v, n);
                let m = self.chains.m[l];
                let soft = self.chains.soft[v].min(m / (h * self.chains.damp[v]));
                self.chains.soft[v] = soft;
                let wind = crate::solver::common::wind_at(&self.params, &self.chains.x[v], t);
                self.chains.f[v] = (wind - self.chains.v[v]) * (drag * m * soft);
            }
        }
        if linked {
            self.links.add_forces(&mut self.chains);
        }
        if self.gp.collision {
            self.strips.add_forces(&mut self.chains);
        }
        let sub = advance::SubStep {
            motion: &self.motion,
            gravity: Vector3::from(self.params.gravity),
            settling: self.settling,
            t,
            h,
            base0,
            pose0,
            base1,
            pose1,
            spheres: &self.spheres,
            shapes: body::Shapes {
                colliders: &self.model.colliders,
                pose: self.shape_pose,
            },
            margin: self.gp.body_margin,
            friction: self.gp.body_friction,
        };
        let (pushed, splits) = advance::advance_guides(
            self.strips.level(),
            &mut self.chains,
            &self.alive,
            self.pool.as_ref(),
            &mut self.run_buffers,
            &sub,
        );
        self.splits += splits;
        self.time = t + h;
        self.pose = if self.settling {
            pose1
        } else {
            self.motion.pose(self.time)
        };
        (contacts, pushed)
    }

    /// The vertices of the initial guides in the head frame (world positions mapped back
    /// through the current pose), guide by guide, into `out`.
    pub fn head_frame_positions(&self, out: &mut Vec<Vector3<f64>>) {
        out.clear();
        let inv = self.pose.iso.inverse();
        for &g in &self.alive[..] {
            if g >= self.initial {
                continue;
            }
            for v in self.chains.verts(g) {
                out.push(inv.transform_point(&Point3::from(self.chains.x[v])).coords);
            }
        }
    }

    /// Moves time and pose to `t` without simulating (the guides keep their joint state, so
    /// they move with the head). For tests and experiments that place the hair by hand.
    pub fn place(&mut self, t: f64) {
        self.time = t;
        self.pose = self.motion.pose(t);
        let (base, _) = self.base_at(t, self.params.dt);
        self.fk_all(&base, t);
    }

    /// Puts guide `g` in the configuration `pts` (`n + 1` world points, root first, directions
    /// only) moving with `vel` (world vertex velocities; only their parts that the joints can
    /// produce). Used for insertion and by tests.
    pub fn set_guide_state(&mut self, g: usize, pts: &[Vector3<f64>], vel: &[Vector3<f64>]) {
        let (base, pose) = self.base_at(self.time, self.params.dt);
        let root = pose
            .transform_point(&Point3::from(self.chains.root_rest[g]))
            .coords;
        self.chains.fk(g, &base, &root);
        self.chains.set_state(g, &base, pts, vel);
        self.chains.fk(g, &base, &root);
    }
}
