//! The AWT (and its single-level mode) behind the [`Solver`] trait.

use std::sync::Arc;

use nalgebra::Vector3;

use crate::frame::Frame;
use crate::model::HairModel;
use crate::motion::Pose;
use crate::solver::{Solver, SolverKind, StepReport};
use crate::style::SimParams;

use super::{Simulation, Tunables, NO_SLOT};

impl Solver for Simulation {
    fn kind(&self) -> SolverKind {
        if self.single_level {
            SolverKind::SingleLevel
        } else {
            SolverKind::Awt
        }
    }

    fn model(&self) -> &Arc<HairModel> {
        &self.model
    }

    fn time(&self) -> f64 {
        Simulation::time(self)
    }

    fn dt(&self) -> f64 {
        self.params.dt
    }

    fn steps_per_frame(&self) -> usize {
        self.params.steps_per_frame.max(1) as usize
    }

    fn pose(&self) -> &Pose {
        Simulation::pose(self)
    }

    fn params(&self) -> &SimParams {
        &self.params
    }

    fn set_params(&mut self, params: &SimParams) {
        let link = self.link.clone();
        self.set_tunables(Tunables {
            params: params.clone(),
            link,
        });
    }

    fn ignored_params(&self) -> &'static [&'static str] {
        if self.single_level {
            &[
                "split_threshold",
                "merge_velocity",
                "merge_radius_factor",
                "accel_smoothing",
            ]
        } else {
            &[]
        }
    }

    fn new_report(&self) -> StepReport {
        Simulation::new_report(self)
    }

    fn step(&mut self, report: &mut StepReport) {
        Simulation::step(self, report)
    }

    fn sync_display(&mut self) {
        self.update_followers();
    }

    fn draw(&self, f: &mut Frame) {
        let to32 = |v: &Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
        let s = &self.slots;
        f.levels = self.model.level_count() as u16;
        for c in 0..s.len() {
            f.nodes.positions.push(to32(&s.pos[c]));
            f.nodes.radii.push(s.radius[c] as f32);
            f.nodes.levels.push(s.level[c] as u16);
            let p = s.parent[c];
            if p != NO_SLOT {
                f.segments.starts.push(to32(&s.pos[p as usize]));
                f.segments.ends.push(to32(&s.pos[c]));
                f.segments.radii.push(s.radius[c] as f32);
                f.segments.levels.push(s.level[c] as u16);
            }
        }
    }

    fn strand_points(&self, strand: usize, out: &mut Vec<Vector3<f64>>) {
        Simulation::strand_points(self, strand, out)
    }

    fn validate(&self) -> Result<(), String> {
        Simulation::validate(self)
    }

    fn set_threads(&mut self, threads: usize) {
        Simulation::set_threads(self, threads)
    }

    fn reserved_bytes(&self) -> usize {
        Simulation::reserved_bytes(self)
    }

    fn inspect(
        &self,
        node: &super::inspect::NodeId,
        out: &mut Vec<(&'static str, f64)>,
    ) -> Result<(), String> {
        Simulation::inspect(self, node, out)
    }

    fn pick_node(
        &self,
        instance: Option<usize>,
        near: Option<[f64; 3]>,
    ) -> Option<super::inspect::NodeId> {
        let s = &self.slots;
        let slot = match near {
            // The click lands on a sphere's surface: the node whose surface is nearest.
            Some(p) => {
                let p = Vector3::new(p[0], p[1], p[2]);
                (0..s.len()).min_by(|&a, &b| {
                    let gap = |c: usize| ((s.pos[c] - p).norm() - s.radius[c]).abs();
                    gap(a).total_cmp(&gap(b))
                })?
            }
            None => instance.filter(|&c| c < s.len())?,
        };
        Some(super::inspect::NodeId::of(
            &self.model,
            s.level[slot] as usize,
            s.node[slot] as usize,
        ))
    }
}
