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
    /// Largest drift apart of corresponding vertices of guides `a` and `b` (their distance
    /// minus the distance `d0` they had at the start), and where.
    // (`i` indexes both guides' vertices and `d0` alike.)
    #[allow(clippy::needless_range_loop)]
    pub fn farthest(&self, a: usize, b: usize, d0: &[f64]) -> (f64, usize) {
        let n = self.gp.segments;
        let mut best = (f64::NEG_INFINITY, 0);
        for i in 1..=n {
            let d = (self.chains.x[a * (n + 1) + i] - self.chains.x[b * (n + 1) + i]).norm();
            if d - d0[i] > best.0 {
                best = (d - d0[i], i);
            }
        }
        best
    }

    /// Distances of corresponding vertices of every base strip pair now: the reference of
    /// the drift (taken on the settled hair).
    pub(super) fn record_pair_distances(&mut self) {
        let n = self.gp.segments;
        self.pair_d0.clear();
        for &(a, b) in &self.base_pairs {
            for i in 0..=n {
                let (va, vb) = (a as usize * (n + 1) + i, b as usize * (n + 1) + i);
                self.pair_d0
                    .push((self.chains.x[va] - self.chains.x[vb]).norm());
            }
        }
    }

    /// Number of inserted guides alive.
    pub fn inserted(&self) -> usize {
        self.alive.iter().filter(|&&g| g >= self.initial).count()
    }

    /// Checks every strip; inserts and removes guides, then rebuilds the strips and the dense
    /// binding once if any came or went (nothing in the loop reads them: under `shake` on the
    /// long styles a step inserts or removes about two).
    pub(super) fn adapt(&mut self, report: &mut StepReport) {
        let mut changed = false;
        for p in 0..self.base_pairs.len() {
            let (a, b) = self.base_pairs[p];
            let n1 = self.gp.segments + 1;
            let (d, i) = self.farthest(a as usize, b as usize, &self.pair_d0[p * n1..(p + 1) * n1]);
            let m = self.mid[p];
            if m == NO_GUIDE {
                if d > self.gp.insert_distance && self.inserted() < self.gp.max_inserted {
                    if let Some(slot) = self.insert_unbuilt(a as usize, b as usize) {
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
                self.remove_unbuilt(m as usize);
                changed = true;
            }
        }
        if changed {
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
        let slot = self.insert_unbuilt(a, b)?;
        self.rebuild_topology();
        Some(slot)
    }

    /// [`Self::insert_between`] without rebuilding the strips and the dense binding.
    fn insert_unbuilt(&mut self, a: usize, b: usize) -> Option<usize> {
        let slot = (self.initial..self.chains.capacity()).find(|&g| !self.chains.alive[g])?;
        let n = self.gp.segments;
        let rest = blend_polyline(&self.rest_x, a, b, n);
        let pts = blend_polyline(&self.chains.x, a, b, n);
        let vel: Vec<Vector3<f64>> = (0..=n)
            .map(|i| (self.chains.v[a * (n + 1) + i] + self.chains.v[b * (n + 1) + i]) * 0.5)
            .collect();
        // The mean of two roots lies under the scalp's curve: lift it (and the rest shape) out of
        // the body, so the new root does not start inside the head sphere.
        let mut rest = rest;
        let lift = self.out_of_body(&rest[0]) - rest[0];
        for p in &mut rest {
            *p += lift;
        }
        self.init_slot(slot, &rest);
        self.origin[slot] = Origin::Inserted(a as u32, b as u32);
        // Two neighbours on either side of the neck or a shoulder have their mean inside the
        // body: start the new guide outside it (§3.3's correction, without friction), or the
        // first sub-step's push-out becomes a whip.
        let mut pts = pts;
        let pose = self.pose;
        self.posed_spheres(&pose, self.time);
        let lens = self.chains.len[slot * n..(slot + 1) * n].to_vec();
        let root = pose
            .transform_point(&nalgebra::Point3::from(self.chains.root_rest[slot]))
            .coords;
        let shift = root - pts[0];
        for p in &mut pts {
            *p += shift;
        }
        let mut vel = vel;
        super::body::correct(
            &mut pts,
            &mut vel,
            &lens,
            &self.spheres,
            &super::body::Shapes {
                colliders: &self.model.colliders,
                pose: self.shape_pose,
            },
            self.gp.body_margin,
            0.0,
        );
        self.set_guide_state(slot, &pts, &vel);
        // Back in joint space the links keep the rest shape's lengths, not the blend's: the
        // forward kinematics can put vertices back inside the body (12 mm on Long under `lean`
        // when the insertion fell on a frame's last step). Correct the chain as it now stands,
        // as a sub-step does (§3.3), until nothing is pushed.
        for _ in 0..4 {
            let vr = self.chains.verts(slot);
            let mut x = self.chains.x[vr.clone()].to_vec();
            let mut v = self.chains.v[vr].to_vec();
            let pushed = super::body::correct(
                &mut x,
                &mut v,
                &lens,
                &self.spheres,
                &super::body::Shapes {
                    colliders: &self.model.colliders,
                    pose: self.shape_pose,
                },
                self.gp.body_margin,
                0.0,
            );
            if pushed == 0 {
                break;
            }
            self.set_guide_state(slot, &x, &v);
        }
        if let Some(p) = self
            .base_pairs
            .iter()
            .position(|&(x, y)| (x as usize, y as usize) == (a, b))
        {
            self.mid[p] = slot as u32;
        }
        self.refresh_alive();
        Some(slot)
    }

    /// `p` (rest pose) moved out of every body sphere it is inside, along the sphere's normal,
    /// to the surface plus the body margin.
    fn out_of_body(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let mut p = *p;
        for sp in &self.model.body {
            let c = Vector3::from(sp.center);
            let d = p - c;
            let r = sp.radius + self.gp.body_margin;
            if d.norm() < r {
                p = c + d.try_normalize(1e-12).unwrap_or_else(Vector3::y) * r;
            }
        }
        p
    }

    /// The strip pairs between initial guides (where guides may be inserted).
    pub fn base_pairs(&self) -> &[(u32, u32)] {
        &self.base_pairs
    }

    /// Removes inserted guide `g` (its strips become one again).
    pub fn remove(&mut self, g: usize) {
        self.remove_unbuilt(g);
        self.rebuild_topology();
    }

    /// [`Self::remove`] without rebuilding the strips and the dense binding.
    fn remove_unbuilt(&mut self, g: usize) {
        self.chains.alive[g] = false;
        self.origin[g] = Origin::Free;
        for m in &mut self.mid {
            if *m == g as u32 {
                *m = NO_GUIDE;
            }
        }
        self.refresh_alive();
    }
}

/// The polyline halfway between guides `a` and `b` of `x` (per vertex, `n + 1` per guide):
/// root at the midpoint of the roots, each segment along the mean of the two segment
/// directions with the mean length. Halving the positions instead would shrink the segments
/// of two guides that leave a parting in opposite directions to nothing.
fn blend_polyline(x: &[Vector3<f64>], a: usize, b: usize, n: usize) -> Vec<Vector3<f64>> {
    let (va, vb) = (a * (n + 1), b * (n + 1));
    let mut out = Vec::with_capacity(n + 1);
    out.push((x[va] + x[vb]) * 0.5);
    for i in 0..n {
        let da = x[va + i + 1] - x[va + i];
        let db = x[vb + i + 1] - x[vb + i];
        let len = 0.5 * (da.norm() + db.norm());
        let ua = da.try_normalize(1e-12).unwrap_or_else(Vector3::y);
        let ub = db.try_normalize(1e-12).unwrap_or(ua);
        let dir = (ua + ub).try_normalize(1e-6).unwrap_or(ua);
        let next = out[i] + dir * len;
        out.push(next);
    }
    out
}
