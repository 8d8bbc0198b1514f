//! Adaptive guides (Chang, Jin, Yu 2002, §4.3): where two strip neighbours drift apart, a
//! guide is inserted halfway; it is removed when they come close again.
//!
//! For every strip between two initial guides, the largest distance between corresponding
//! vertices is checked after each step. Above `insert_distance` (and while fewer than
//! `max_inserted` guides are inserted) a guide is inserted: its rest shape, root and current
//! positions and velocities are the halves of the two, its joint state comes from those
//! through the chain's inverse kinematics, and the strip becomes two strips around it. Below
//! `remove_distance` the inserted guide goes and the strip is restored. Only strips between
//! initial guides split, so an inserted guide never has inserted neighbours to outlive. An
//! inserted guide gets no static links: the paper spawns none, "to avoid discontinuous
//! motion" of the others.
//!
//! Each insertion or removal is an [`AdaptEvent`]: `tree` is the inserted guide's slot, `gc`
//! and `sub_gcs.start` the two neighbours, `cross_section` the vertex where they are farthest
//! apart, `position` the inserted guide's vertex there, `accel_radius` that distance (m).

use nalgebra::Vector3;

use super::{GuideSolver, Origin, NO_GUIDE};
use crate::solver::{AdaptEvent, EventKind, StepReport};

impl GuideSolver {
    /// Largest distance between corresponding vertices of guides `a` and `b`, and where.
    pub fn farthest(&self, a: usize, b: usize) -> (f64, usize) {
        let n = self.gp.segments;
        let mut best = (0.0, 0);
        for i in 1..=n {
            let d = (self.chains.x[a * (n + 1) + i] - self.chains.x[b * (n + 1) + i]).norm();
            if d > best.0 {
                best = (d, i);
            }
        }
        best
    }

    /// Number of inserted guides alive.
    pub fn inserted(&self) -> usize {
        self.alive.iter().filter(|&&g| g >= self.initial).count()
    }

    /// Checks every strip; inserts and removes guides; rebuilds strips and the dense binding if
    /// anything changed.
    pub(super) fn adapt(&mut self, report: &mut StepReport) {
        let mut changed = false;
        for p in 0..self.base_pairs.len() {
            let (a, b) = self.base_pairs[p];
            let (d, i) = self.farthest(a as usize, b as usize);
            let m = self.mid[p];
            if m == NO_GUIDE {
                if d > self.gp.insert_distance && self.inserted() < self.gp.max_inserted {
                    if let Some(slot) = self.insert_between(a as usize, b as usize) {
                        self.mid[p] = slot as u32;
                        changed = true;
                        report
                            .events
                            .push(self.event(EventKind::GuideInsert, slot, a, b, i, d));
                    }
                }
            } else if d < self.gp.remove_distance {
                report
                    .events
                    .push(self.event(EventKind::GuideRemove, m as usize, a, b, i, d));
                self.remove(m as usize);
                self.mid[p] = NO_GUIDE;
                changed = true;
            }
        }
        if changed {
            self.refresh_alive();
            self.rebuild_topology();
        }
    }

    fn event(&self, kind: EventKind, slot: usize, a: u32, b: u32, i: usize, d: f64) -> AdaptEvent {
        let n = self.gp.segments;
        let x = self.chains.x[slot * (n + 1) + i];
        AdaptEvent {
            kind,
            time: self.time,
            tree: slot as u32,
            level: 0,
            gc: a,
            cross_section: i as u16,
            sub_gcs: b..b + 1,
            position: [x.x, x.y, x.z],
            accel_radius: d,
            rel_velocity: 0.0,
        }
    }

    /// Inserts a guide halfway between `a` and `b` with interpolated rest shape, positions and
    /// velocities; returns its slot (`None` if no slot is free).
    pub fn insert_between(&mut self, a: usize, b: usize) -> Option<usize> {
        let slot = (self.initial..self.chains.capacity()).find(|&g| !self.chains.alive[g])?;
        let n = self.gp.segments;
        let half = |v: &[Vector3<f64>], i: usize| (v[a * (n + 1) + i] + v[b * (n + 1) + i]) * 0.5;
        let rest: Vec<Vector3<f64>> = (0..=n).map(|i| half(&self.rest_x, i)).collect();
        let pts: Vec<Vector3<f64>> = (0..=n).map(|i| half(&self.chains.x, i)).collect();
        let vel: Vec<Vector3<f64>> = (0..=n).map(|i| half(&self.chains.v, i)).collect();
        self.init_slot(slot, &rest);
        self.origin[slot] = Origin::Inserted(a as u32, b as u32);
        self.set_guide_state(slot, &pts, &vel);
        Some(slot)
    }

    /// Removes inserted guide `g`.
    pub fn remove(&mut self, g: usize) {
        self.chains.alive[g] = false;
        self.origin[g] = Origin::Free;
    }
}
