//! [`GuideSolver`] behind the [`Solver`] trait: stepping, stats, display and dense strands.

use nalgebra::{Point3, Vector3};

use super::GuideSolver;
use crate::solver::tunable::Tuning;
use crate::solver::{Aggregate, Solver, SolverKind, StepReport};
use crate::style::SimParams;

impl Solver for GuideSolver {
    fn kind(&self) -> SolverKind {
        SolverKind::Guides
    }

    crate::solver::state_getters!();

    fn dt(&self) -> f64 {
        self.params.dt
    }

    fn steps_per_frame(&self) -> usize {
        self.params.steps_per_frame.max(1) as usize
    }

    fn set_params(&mut self, params: &SimParams) {
        self.params = params.clone();
    }

    fn tuning(&self) -> Tuning {
        Tuning {
            sim: self.params.clone(),
            guides: self.gp.clone(),
            ..Tuning::default()
        }
    }

    /// Every tunable of the `guides:` section is read afresh at each sub-step.
    fn set_tuning(&mut self, t: &Tuning) {
        self.gp = t.guides.clone();
        self.set_params(&t.sim);
    }

    fn ignored_params(&self) -> &'static [&'static str] {
        &[
            "split_threshold",
            "merge_velocity",
            "merge_radius_factor",
            "accel_smoothing",
            "friction",
            "repulsion",
            "angle_threshold",
            "bending",
            "contact_epsilon",
        ]
    }

    fn new_report(&self) -> StepReport {
        let mut r = StepReport::default();
        r.events.reserve(2 * self.gp.max_inserted + 8);
        r.stats.reserve(8);
        r.counters.active_per_level.reserve(2);
        r
    }

    fn step(&mut self, report: &mut StepReport) {
        report.events.clear();
        report.stats.clear();
        let sub = self.gp.substeps.max(1);
        let h = self.params.dt / sub as f64;
        let mut contacts = 0;
        let mut body = 0;
        if self.gp.collision {
            self.strips.update_broken(&self.chains, self.gp.strip_break);
            // Candidates within twice the contact distance cover the hair's motion over the
            // step's later sub-steps. With one sub-step the contacts are evaluated on the very
            // positions searched, so the sub-step searches and evaluates at once, within the
            // contact distance itself (`Strips::detect_evaluate_on`).
            if sub > 1 {
                self.strips.detect_on(
                    self.pool.as_ref(),
                    &self.chains,
                    &self.alive,
                    2.0 * self.gp.contact_distance,
                );
            }
        }
        let splits0 = self.splits;
        for _ in 0..sub {
            let (c, b) = self.substep(h, sub == 1);
            contacts += c;
            body += b;
        }
        if !self.settling && self.gp.max_inserted > 0 {
            self.adapt(report);
        }
        self.last_contacts = contacts;
        self.last_body = body;
        let intact = self.links.intact();
        let c = &mut report.counters;
        c.active_per_level.clear();
        c.active_per_level.push(self.alive.len() as u32);
        c.segments = (self.alive.len() * self.gp.segments) as u32;
        c.pairs_tested = self.strips.candidates() as u32;
        c.pairs_in_contact = contacts as u32;
        c.body_contacts = body as u32;
        c.kinetic_energy = self
            .alive
            .iter()
            .flat_map(|&g| self.chains.verts(g).skip(1))
            .map(|v| {
                let l = (v / (self.gp.segments + 1)) * self.gp.segments
                    + (v % (self.gp.segments + 1)).saturating_sub(1);
                0.5 * self.chains.m[l] * self.chains.v[v].norm_squared()
            })
            .sum();
        report.set_stat("links_intact", intact as f64, Aggregate::Last);
        report.set_stat(
            "links_broken",
            (self.links.len() - intact) as f64,
            Aggregate::Last,
        );
        report.set_stat("contacts", contacts as f64, Aggregate::Sum);
        report.set_stat("guides", self.alive.len() as f64, Aggregate::Last);
        // Integration steps of guides whose sub-step was split (fast joints), this step.
        report.set_stat(
            "split_steps",
            (self.splits - splits0) as f64,
            Aggregate::Sum,
        );
    }

    fn sync_display(&mut self) {
        self.bind_dense();
        let n = self.gp.segments;
        let rot = *self.pose.iso.rotation.to_rotation_matrix().matrix();
        for &g in &self.alive {
            let f = rot * self.gframe[g];
            let root = self.chains.x[g * (n + 1)];
            for v in self.chains.verts(g) {
                self.disp[v] = f.transpose() * (self.chains.x[v] - root) - self.rest_local[v];
            }
        }
        let disp = &self.disp;
        let iso = self.pose.iso;
        self.dense.update(
            self.pool.as_ref(),
            (!self.show_all).then_some(&self.shown[..]),
            &self.model,
            &rot,
            |r| iso.transform_point(&Point3::from(*r)).coords,
            |g, u| {
                let i = (u.floor() as usize).min(n - 1);
                let t = u - i as f64;
                let v = g * (n + 1) + i;
                disp[v].lerp(&disp[v + 1], t)
            },
            n,
        );
    }

    fn draw(&self, frame: &mut crate::frame::Frame) {
        super::display::draw(self, frame);
    }

    fn display_strands(&mut self, strands: Option<&[u32]>) {
        self.show_all = strands.is_none();
        if let Some(list) = strands {
            if self.shown != list {
                self.shown.clear();
                self.shown.extend_from_slice(list);
            }
        }
    }

    fn obstacle_spheres(&self, out: &mut Vec<(nalgebra::Vector3<f64>, f64)>) {
        out.extend(self.gp.obstacles.iter().map(|o| {
            let p = super::obstacle::posed(o, self.time);
            (p.center, p.radius)
        }));
    }

    fn strand_points(&self, strand: usize, out: &mut Vec<Vector3<f64>>) {
        let k = self.model.k;
        out.extend_from_slice(&self.dense.points[strand * k..(strand + 1) * k]);
    }

    fn validate(&self) -> Result<(), String> {
        let n = self.gp.segments;
        if self.alive.is_empty() {
            return Err("no guide is simulated".into());
        }
        for &g in &self.alive {
            for i in 0..n {
                let l = g * n + i;
                if !(self.chains.q[l].coords.iter().all(|v| v.is_finite())
                    && self.chains.qd[l].iter().all(|v| v.is_finite()))
                {
                    return Err(format!("guide {g} joint {i}: non-finite state"));
                }
                let v = g * (n + 1) + i;
                let d = (self.chains.x[v + 1] - self.chains.x[v]).norm();
                if (d - self.chains.len[l]).abs() > 1e-9 * (1.0 + self.chains.len[l]) {
                    return Err(format!(
                        "guide {g} segment {i}: length {d} instead of {}",
                        self.chains.len[l]
                    ));
                }
            }
        }
        Ok(())
    }

    fn set_threads(&mut self, threads: usize) {
        self.set_pool_threads(threads);
    }

    fn reserved_bytes(&self) -> usize {
        self.strips.reserved_bytes()
    }

    fn inspect(
        &self,
        node: &crate::solver::NodeId,
        out: &mut Vec<(&'static str, f64)>,
    ) -> Result<(), String> {
        GuideSolver::inspect(self, node, out)
    }

    fn pick_node(
        &self,
        instance: Option<usize>,
        near: Option<[f64; 3]>,
    ) -> Option<crate::solver::NodeId> {
        self.pick(instance, near)
    }
}
