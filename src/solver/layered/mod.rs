//! The layered wisp model (Plante, Cani, Poulin 2002, *Capturing the Complexity of Hair
//! Motion*) behind the [`Solver`] trait (`--model layered`).
//!
//! One wisp per GC of the style's `layered.level`: a skeleton chain of point masses whose root
//! moves with the head, an envelope of 4 radial point masses per skeleton point, twist-free
//! section frames ([`wisp`]). One step (§5.1): forces ([`forces`]) → detection of wisp–wisp
//! interactions ([`detect`], at `layered.interaction_rate`) → velocities, then velocity
//! modifications (spring damping, air drag, the §4.2 response of [`response`], the §4.3.1
//! sliding contact of [`body`] at `layered.body_rate`) → positions, then position
//! modifications (the §4.3.2 penetration reaction). Strands are drawn in the envelope
//! ([`strands`]).
//!
//! From `sim:` it takes gravity, air drag, the steady wind, the settling time and the displayed
//! frame length (`dt · steps_per_frame`); its own step is `1 / layered.rate`.

pub mod body;
pub mod detect;
pub mod forces;
pub mod inspect;
pub mod params;
pub mod response;
pub mod shapes;
pub mod strands;
pub mod tunables;
pub mod wisp;

use std::sync::Arc;

use nalgebra::Vector3;

pub use params::LayeredParams;

use crate::frame::{Frame, PrimitiveKind};
use crate::model::HairModel;
use crate::motion::{Motion, Pose};
use crate::solver::tunable::Tuning;
use crate::solver::{Aggregate, Solver, SolverKind, StepReport};
use crate::style::{SimParams, Style};

use body::Ball;
use detect::Detector;
use forces::Coeffs;
use strands::StrandMap;
use wisp::{Wisps, ENV};

/// Entity path of the envelope points.
pub const ENVELOPE_PATH: &str = "/hair/layered/envelope";
/// Entity path of the cross-sections' outlines.
pub const SECTIONS_PATH: &str = "/hair/layered/sections";
/// Stat: segment pairs in contact that interpenetrate (§4.2.1), summed over a frame's steps.
pub const STAT_INTERPENETRATING: &str = "interpenetrating_pairs";
/// Stat: segment pairs in contact that collide (§4.2.2).
pub const STAT_COLLISIONS: &str = "collisions";
/// Stat: skeleton and envelope points in sliding contact with the body (§4.3.1).
pub const STAT_BODY_CONTACTS: &str = "body_contacts";

/// The `sim:` fields this model does not use.
const IGNORED: &[&str] = &[
    "split_threshold",
    "merge_velocity",
    "merge_radius_factor",
    "friction",
    "repulsion",
    "angle_threshold",
    "bending",
    "contact_epsilon",
    "accel_smoothing",
];

/// The layered wisp model in motion.
pub struct LayeredSolver {
    model: Arc<HairModel>,
    motion: Motion,
    pose: Pose,
    params: SimParams,
    /// The `layered:` section in force.
    pub layered: LayeredParams,
    coeffs: Coeffs,
    shares: forces::Shares,
    /// The wisps' state.
    pub wisps: Wisps,
    detector: Detector,
    section_cache: response::SectionCache,
    balls: Vec<Ball>,
    strand_map: StrandMap,
    level: usize,
    time: f64,
    steps: u64,
    dt: f64,
    steps_per_frame: usize,
    body_every: u64,
    interaction_every: u64,
    settling: bool,
}

impl LayeredSolver {
    /// Builds the wisps of `style.layered.level` on `model`, then lets them settle for
    /// `params.settle` seconds in the starting pose.
    pub fn new(model: Arc<HairModel>, motion: Motion, params: &SimParams, style: &Style) -> Self {
        let lp = style.layered.clone();
        let level = wisp_level(&model, &lp);
        let wisps = Wisps::build(&model, level);
        let strand_map = StrandMap::build(&model, &wisps, level, lp.jitter);
        let dt = 1.0 / lp.rate;
        let frame = params.dt * params.steps_per_frame.max(1) as f64;
        let every = |hz: f64| ((lp.rate / hz).round() as u64).max(1);
        let stiffness = lp
            .stiffness
            .unwrap_or_else(|| params::default_stiffness(&style.link));
        let coeffs = coeffs(params, &lp, stiffness);
        let mut s = LayeredSolver {
            shares: forces::Shares::new(&wisps, &coeffs, dt),
            detector: Detector::new(&wisps),
            section_cache: response::SectionCache::new(&wisps),
            coeffs,
            pose: motion.pose(0.0),
            body_every: every(lp.body_rate),
            interaction_every: every(lp.interaction_rate),
            steps_per_frame: ((frame / dt).round() as usize).max(1),
            model,
            motion,
            params: params.clone(),
            layered: lp,
            wisps,
            balls: Vec::new(),
            strand_map,
            level,
            time: 0.0,
            steps: 0,
            dt,
            settling: false,
        };
        s.balls.reserve(s.model.body.len());
        s.wisps.pose_roots(&s.pose);
        s.wisps.compute_frames(&s.pose);
        s.settle();
        s
    }

    /// The level of the hierarchy whose GCs are the wisps.
    pub fn level(&self) -> usize {
        self.level
    }

    /// The wisp that draws strand `s`.
    pub fn strand_wisp(&self, s: usize) -> usize {
        self.strand_map.wisp[s] as usize
    }

    /// Main steps between two interaction steps, and between two body steps.
    pub fn rates(&self) -> (u64, u64) {
        (self.interaction_every, self.body_every)
    }

    /// Kinetic energy of the skeleton and envelope points, J.
    pub fn kinetic_energy(&self) -> f64 {
        // An envelope point moves at its skeleton point's velocity plus its radial rate along
        // ±u or ±v: over the 4 of a section, |v_e|² sums to 4|v|² + 2(v·u)(ρ̇₀ − ρ̇₂)
        // + 2(v·v̂)(ρ̇₁ − ρ̇₃) + Σρ̇².
        let w = &self.wisps;
        let mut e = 0.0;
        for p in 0..w.point_count() {
            let v = w.vel[p];
            let r = &w.rho_rate[p * ENV..p * ENV + ENV];
            let v2 = v.norm_squared();
            let env = 4.0 * v2
                + 2.0 * (v.dot(&w.u[p]) * (r[0] - r[2]) + v.dot(&w.v[p]) * (r[1] - r[3]))
                + r.iter().map(|x| x * x).sum::<f64>();
            e += 0.5 * w.mass[p] * (v2 + self.layered.envelope_mass * env);
        }
        e
    }

    fn settle(&mut self) {
        self.settling = true;
        let (seconds, dt) = (self.params.settle, self.dt);
        let steps = crate::solver::settle_steps(seconds, dt, |r| self.step(r));
        self.settling = false;
        if steps == 0 {
            return;
        }
        self.time = 0.0;
        self.steps = 0;
        let w = &mut self.wisps;
        w.vel.iter_mut().for_each(|v| *v = Vector3::zeros());
        w.prev_vel.iter_mut().for_each(|v| *v = Vector3::zeros());
        w.rho_rate.iter_mut().for_each(|v| *v = 0.0);
        self.pose = self.motion.pose(0.0);
        w.pose_roots(&self.pose);
        w.compute_frames(&self.pose);
    }
}

/// The level whose GCs become wisps: `layered.level`, coarsened while it has more than
/// `layered.max_segments` segments.
pub fn wisp_level(model: &HairModel, lp: &LayeredParams) -> usize {
    let mut level = lp.level.min(model.level_count() - 1);
    let segments = |l: usize| model.levels[l].gc_count() * model.k.saturating_sub(1);
    while level > 0 && lp.max_segments > 0 && segments(level) > lp.max_segments {
        level -= 1;
    }
    level
}

fn coeffs(p: &SimParams, lp: &LayeredParams, stiffness: f64) -> Coeffs {
    Coeffs {
        gravity: Vector3::from(p.gravity),
        air_drag: p.air_drag,
        wind: Vector3::from(p.wind.velocity),
        stiffness,
        damping: lp.damping,
        bending: lp.bending,
        bending_damping: lp.bending_damping,
        envelope_mass: lp.envelope_mass,
        envelope_stiffness: lp.envelope_stiffness,
        ring_stiffness: lp.ring_stiffness,
        envelope_damping: lp.envelope_damping,
    }
}

impl Solver for LayeredSolver {
    fn kind(&self) -> SolverKind {
        SolverKind::Layered
    }

    crate::solver::state_getters!();

    fn dt(&self) -> f64 {
        self.dt
    }

    fn steps_per_frame(&self) -> usize {
        self.steps_per_frame
    }

    fn set_params(&mut self, params: &SimParams) {
        self.params = params.clone();
        self.coeffs = coeffs(params, &self.layered, self.coeffs.stiffness);
        self.shares.update(&self.wisps, &self.coeffs, self.dt);
    }

    fn tuning(&self) -> Tuning {
        Tuning {
            sim: self.params.clone(),
            layered: self.layered.clone(),
            ..Tuning::default()
        }
    }

    /// The `layered:` values are read at every step (viscosity, angle, body friction) or folded
    /// into the spring coefficients here (damping, bending).
    fn set_tuning(&mut self, t: &Tuning) {
        self.layered = t.layered.clone();
        self.set_params(&t.sim);
    }

    fn ignored_params(&self) -> &'static [&'static str] {
        IGNORED
    }

    fn new_report(&self) -> StepReport {
        let mut r = StepReport::default();
        r.counters.active_per_level.reserve(1);
        r.stats.reserve(4);
        for path in [STAT_INTERPENETRATING, STAT_COLLISIONS, STAT_BODY_CONTACTS] {
            r.set_stat(path, 0.0, Aggregate::Sum);
        }
        r
    }

    fn step(&mut self, report: &mut StepReport) {
        report.events.clear();
        let dt = self.dt;
        let t_new = self.time + dt;
        let lp = &self.layered;
        self.pose = self.motion.pose(if self.settling { 0.0 } else { t_new });
        let w = &mut self.wisps;
        w.prev_vel.copy_from_slice(&w.vel);
        w.pose_roots(&self.pose);
        w.compute_frames(&self.pose);
        body::pose_balls(&self.model.body, &self.pose, &mut self.balls);
        // 1. Forces.
        forces::accumulate_forces(w, &self.coeffs);
        // 2. Detection (at the interaction rate).
        let interact = lp.interactions && self.steps.is_multiple_of(self.interaction_every);
        // §4.3 at `layered.body_rate` (§7: collisions at 120 Hz), phased so that one falls on
        // the last step of every displayed frame: what is shown and rendered comes after a
        // penetration reaction (§4.3.2), never after up to a body period of motion into the
        // body (3.5 mm on Long under `shake` when the phase was free). With the styles' 40
        // steps per frame and 8 per body step the rate is unchanged.
        let last_of_frame = (self.steps + 1).is_multiple_of(self.steps_per_frame as u64);
        let body_step = (self.steps + 1).is_multiple_of(self.body_every) || last_of_frame;
        if interact {
            self.detector.detect(w);
        }
        // 3. Velocities, then velocity modifications.
        forces::integrate_velocities(w, &self.coeffs, &self.shares, dt);
        let mut counts = response::PairCounts::default();
        if interact {
            let pp = response::PairParams {
                collisions: lp.collisions,
                sin_threshold: lp.interpenetration_angle.to_radians().sin(),
                viscosity: lp.viscosity,
                envelope_mass: lp.envelope_mass,
                dt_c: dt * self.interaction_every as f64,
            };
            counts = response::respond(
                w,
                &self.detector.pairs,
                &self.detector.contacts,
                &pp,
                &mut self.section_cache,
            );
        }
        let mut body_contacts = 0;
        if body_step {
            let dt_c = dt * self.body_every as f64;
            let drag = response::scaled_fraction(lp.body_friction, dt, dt_c);
            body_contacts =
                body::sliding_contact(w, &self.balls, &self.pose, lp.body_threshold, drag);
            let shapes = &self.model.colliders;
            if !shapes.is_empty() {
                body_contacts +=
                    shapes::sliding_contact(w, shapes, &self.pose, lp.body_threshold, drag);
            }
        }
        // 4. Positions, then position modifications.
        forces::integrate_positions(w, dt);
        if body_step {
            // The reaction moves envelope points along their half-lines in the new sections:
            // those of the wisps near the body are computed (the next step's forces and
            // `sync_display` recompute every frame anyway).
            let margin = 0.9 * lp.body_threshold;
            body::penetration_reaction_framing(w, &self.balls, &self.pose, margin);
            if !self.model.colliders.is_empty() {
                shapes::penetration_reaction(w, &self.model.colliders, &self.pose, margin);
            }
        }
        self.time = t_new;
        self.steps += 1;

        let c = &mut report.counters;
        c.active_per_level.clear();
        c.active_per_level.push(w.point_count() as u32);
        c.segments = (w.point_count() - w.len()) as u32;
        c.pairs_tested = if interact {
            self.detector.pairs_tested
        } else {
            0
        };
        c.pairs_in_contact = if interact {
            self.detector.pairs.len() as u32
        } else {
            0
        };
        c.body_contacts = body_contacts;
        c.kinetic_energy = self.kinetic_energy();
        report.set_stat(
            STAT_INTERPENETRATING,
            counts.interpenetrating as f64,
            Aggregate::Sum,
        );
        report.set_stat(STAT_COLLISIONS, counts.collisions as f64, Aggregate::Sum);
        report.set_stat(STAT_BODY_CONTACTS, body_contacts as f64, Aggregate::Sum);
    }

    fn sync_display(&mut self) {
        self.wisps.compute_frames(&self.pose);
    }

    fn draw(&self, f: &mut Frame) {
        let to32 = |v: &Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
        let w = &self.wisps;
        f.levels = self.model.level_count() as u16;
        for wi in 0..w.len() {
            let r = w.points(wi);
            for p in r.clone() {
                let rho = &w.rho[p * ENV..p * ENV + ENV];
                let radius = rho.iter().sum::<f64>() / ENV as f64;
                f.nodes.positions.push(to32(&w.pos[p]));
                f.nodes.radii.push(radius as f32);
                f.nodes.levels.push(self.level as u16);
                if p > r.start {
                    f.segments.starts.push(to32(&w.pos[p - 1]));
                    f.segments.ends.push(to32(&w.pos[p]));
                    f.segments.radii.push(radius as f32);
                    f.segments.levels.push(self.level as u16);
                }
            }
        }
        let env = f.primitives(ENVELOPE_PATH, PrimitiveKind::Points);
        env.color = [255, 200, 80, 255];
        env.radius_ui = 2.0;
        for p in 0..w.point_count() {
            for j in 0..ENV {
                env.points.push(to32(&w.env_pos(p, j)));
            }
        }
        let sec = f.primitives(SECTIONS_PATH, PrimitiveKind::LineStrips);
        sec.color = [255, 200, 80, 160];
        sec.radius_ui = 0.5;
        for p in 0..w.point_count() {
            sec.push_strip((0..=8).map(|k| to32(&outline_point(w, p, k))));
        }
    }

    fn strand_points(&self, strand: usize, out: &mut Vec<Vector3<f64>>) {
        self.strand_map
            .points(&self.wisps, strand, self.model.k, out)
    }

    fn validate(&self) -> Result<(), String> {
        let w = &self.wisps;
        if let Some(p) = (0..w.point_count()).find(|&p| {
            !(w.pos[p].iter().all(|x| x.is_finite()) && w.vel[p].iter().all(|x| x.is_finite()))
        }) {
            return Err(format!("skeleton point {p} is not finite"));
        }
        if let Some(e) = (0..w.rho.len())
            .find(|&e| !(w.rho[e].is_finite() && w.rho[e] > 0.0 && w.rho_rate[e].is_finite()))
        {
            return Err(format!("envelope point {e} has radius {}", w.rho[e]));
        }
        Ok(())
    }

    fn reserved_bytes(&self) -> usize {
        self.detector.capacity_bytes() + self.section_cache.capacity_bytes()
    }

    fn inspect(
        &self,
        node: &crate::solver::NodeId,
        out: &mut Vec<(&'static str, f64)>,
    ) -> Result<(), String> {
        LayeredSolver::inspect(self, node, out)
    }

    fn pick_node(
        &self,
        instance: Option<usize>,
        near: Option<[f64; 3]>,
    ) -> Option<crate::solver::NodeId> {
        self.pick(instance, near)
    }
}

/// Point `k` of 8 around section `p`'s outline (k = 8 closes it): the envelope points at even
/// `k`, the ellipse quadrant through its two envelope points between them.
fn outline_point(w: &Wisps, p: usize, k: usize) -> Vector3<f64> {
    let k = k % 8;
    let rho = &w.rho[p * ENV..p * ENV + ENV];
    let u = w.u[p];
    let v = w.t[p].cross(&u);
    let a = k as f64 * std::f64::consts::FRAC_PI_4;
    let (c, s) = (a.cos(), a.sin());
    let rx = if c >= 0.0 { rho[0] } else { rho[2] };
    let ry = if s >= 0.0 { rho[1] } else { rho[3] };
    w.pos[p] + u * (c * rx) + v * (s * ry)
}
