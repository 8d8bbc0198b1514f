//! The adaptive wisp tree itself: which nodes are active, the tree they form, splitting (§3.1),
//! merging (§3.2) and the following of non-active nodes (§3.3).
//!
//! The active set is stored as one flag per node of every level. The invariant (checked by
//! [`Forest::validate`]): every finest cross-section `(f, i)` is governed by exactly one active
//! ancestor-or-self, and along every root→tip path the governing level never decreases. The AWT
//! parent of an active node `(l, g, i)` is then the unique active ancestor-or-self of
//! `(l, g, i − 1)` (level ≤ l), found by walking up the GC hierarchy.

use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use crate::model::{HairModel, NONE};
use crate::motion::Pose;

mod adapt;

pub use adapt::{adapt, merge, split};

/// Per-level state of every node (active or not), indexed `g * K + i`.
#[derive(Debug, Clone, Default)]
pub struct LevelState {
    /// Position: current for active nodes; the last followed position otherwise.
    pub pos: Vec<Vector3<f64>>,
    /// Velocity.
    pub vel: Vec<Vector3<f64>>,
    /// Smoothed world-frame acceleration (active nodes), used by the split test.
    pub acc: Vec<Vector3<f64>>,
    /// Radius: the model's, or refitted tightly at a merge (§3.2).
    pub radius: Vec<f64>,
    /// Non-active nodes below an active one: offset from their governing active node, recorded
    /// together with that node's `ref_tangent`.
    pub offset: Vec<Vector3<f64>>,
    /// Active nodes: the tangent of their segment when their followers' offsets were recorded.
    pub ref_tangent: Vec<Vector3<f64>>,
    /// Step number at which the node last became active or inactive (0 = never).
    pub changed_at: Vec<u64>,
}

/// The forest of AWTs: one per top-level GC, all sharing the per-level arrays.
#[derive(Debug, Clone, Default)]
pub struct Forest {
    /// Per level, per node: active or not.
    pub active: Vec<Vec<bool>>,
    /// Per level: the nodes' state.
    pub state: Vec<LevelState>,
    /// Slot of each active node in `Simulation::slots` (stale for non-active nodes).
    pub slot_of: Vec<Vec<u32>>,
    /// Adaptation counter (steps on which `adapt` ran), used for the `changed_at` stamps.
    pub adapt_step: u64,
    /// Scratch: AWT children `(level, gc)` of a node being split or merged.
    children: Vec<(usize, usize)>,
}

/// Scratch buffers of `adapt`, kept between steps.
#[derive(Debug, Default, Clone)]
pub struct AdaptScratch {
    sub_pos: Vec<Vector3<f64>>,
    /// Merge candidates of the last `adapt` refused by condition (1) radius, (2) relative
    /// velocity, (3) would split at once — for diagnostics.
    pub merge_refused: [u32; 3],
}

impl AdaptScratch {
    /// Scratch with room for the largest number of sub-GCs of any GC of `m`.
    pub fn for_model(m: &HairModel) -> AdaptScratch {
        let subs = m
            .levels
            .iter()
            .flat_map(|lv| lv.sub_gcs.iter().map(|r| r.len()))
            .max()
            .unwrap_or(0);
        AdaptScratch {
            sub_pos: Vec::with_capacity(subs),
            merge_refused: [0; 3],
        }
    }
}

/// The smallest rotation taking direction `from` to direction `to` (both non-zero).
pub fn min_rotation(from: &Vector3<f64>, to: &Vector3<f64>) -> Matrix3<f64> {
    min_rotation_from_unit(&from.normalize(), to)
}

/// [`min_rotation`] from `a`, the direction `from` already normalised (`from.normalize()`,
/// bit for bit the vector `min_rotation` would compute).
pub fn min_rotation_from_unit(a: &Vector3<f64>, to: &Vector3<f64>) -> Matrix3<f64> {
    let a = *a;
    let b = to.normalize();
    let c = a.dot(&b);
    let v = a.cross(&b);
    let s2 = v.norm_squared();
    if s2.is_nan() || s2 <= 1e-24 || !c.is_finite() {
        if c >= 0.0 || !c.is_finite() {
            return Matrix3::identity();
        }
        // Opposite directions: half a turn about any axis perpendicular to `a`.
        let axis = if a.x.abs() < 0.9 {
            a.cross(&Vector3::x())
        } else {
            a.cross(&Vector3::y())
        };
        return *Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(axis),
            std::f64::consts::PI,
        )
        .matrix();
    }
    // Rodrigues: R = I + [v]x + [v]x² (1 − c) / s².
    let vx = Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0);
    Matrix3::identity() + vx + vx * vx * ((1.0 - c) / s2)
}

fn normalize_or(v: Vector3<f64>, fallback: Vector3<f64>) -> Vector3<f64> {
    let n = v.norm();
    if n > 1e-12 {
        v / n
    } else {
        fallback
    }
}

impl Forest {
    /// All nodes at their posed rest positions, at rest; only level 0 active (or only the finest
    /// level in single-level mode). Offsets are recorded from the rest geometry (§3.3).
    pub fn new(m: &HairModel, pose: &Pose, single_level: bool) -> Forest {
        let k = m.k;
        let nl = m.level_count();
        let on = if single_level { nl - 1 } else { 0 };
        let mut f = Forest::default();
        // Scratch sized for the worst case up front (no allocation inside a step).
        f.children.reserve(m.finest().gc_count());
        for (l, lv) in m.levels.iter().enumerate() {
            let n = lv.gc_count() * k;
            f.active.push(vec![l == on; n]);
            f.slot_of.push(vec![u32::MAX; n]);
            let pos: Vec<Vector3<f64>> = lv
                .rest_pos
                .iter()
                .map(|p| pose.transform_point(&Point3::from(*p)).coords)
                .collect();
            let vel = pos
                .iter()
                .map(|p| pose.velocity_at(&Point3::from(*p)))
                .collect();
            f.state.push(LevelState {
                pos,
                vel,
                acc: vec![Vector3::zeros(); n],
                radius: lv.radius.clone(),
                offset: vec![Vector3::zeros(); n],
                ref_tangent: vec![Vector3::y(); n],
                changed_at: vec![0; n],
            });
        }
        // Reference tangents of the active nodes and offsets of everything below them.
        for g in 0..m.levels[on].gc_count() {
            for i in 1..k {
                f.record_followers(m, on, g, i);
            }
        }
        f
    }

    /// Ancestor of GC `g` of level `l` on level `target ≤ l`.
    pub fn ancestor(m: &HairModel, mut l: usize, mut g: usize, target: usize) -> usize {
        while l > target {
            g = m.levels[l].super_gc[g] as usize;
            debug_assert!(g as u32 != NONE);
            l -= 1;
        }
        g
    }

    /// The active ancestor-or-self of `(l, g, i)`, if any: `(level, node index)`.
    pub fn governor_above(
        &self,
        m: &HairModel,
        l: usize,
        g: usize,
        i: usize,
    ) -> Option<(usize, usize)> {
        let k = m.k;
        let mut gg = g;
        let mut ll = l;
        loop {
            if self.active[ll][gg * k + i] {
                return Some((ll, gg * k + i));
            }
            if ll == 0 {
                return None;
            }
            gg = m.levels[ll].super_gc[gg] as usize;
            ll -= 1;
        }
    }

    /// Position of the AWT parent of the active node `(l, g, i)`, i ≥ 1.
    fn parent_pos(&self, m: &HairModel, l: usize, g: usize, i: usize) -> Option<Vector3<f64>> {
        self.governor_above(m, l, g, i - 1)
            .map(|(pl, pj)| self.state[pl].pos[pj])
    }

    /// Records the reference tangent of active node `(l, g, i)` (i ≥ 1) and the offsets of all
    /// its descendants at cross-section `i` from their current positions.
    fn record_followers(&mut self, m: &HairModel, l: usize, g: usize, i: usize) {
        let k = m.k;
        let a = self.state[l].pos[g * k + i];
        let parent = self.parent_pos(m, l, g, i).unwrap_or(a - Vector3::y());
        self.state[l].ref_tangent[g * k + i] = normalize_or(a - parent, Vector3::y());
        let mut range = g..g + 1;
        for ll in l + 1..m.level_count() {
            let lv = &m.levels[ll - 1];
            range = lv.sub_gcs[range.start].start as usize..lv.sub_gcs[range.end - 1].end as usize;
            let st = &mut self.state[ll];
            for d in range.clone() {
                st.offset[d * k + i] = st.pos[d * k + i] - a;
            }
        }
    }

    /// The rotation that carries the followers of active node `(l, g, i)` from their recorded
    /// frame to now: the minimal rotation between its reference and current segment tangents.
    fn follow_rotation(&self, m: &HairModel, l: usize, g: usize, i: usize) -> Matrix3<f64> {
        let k = m.k;
        let a = self.state[l].pos[g * k + i];
        match self.parent_pos(m, l, g, i) {
            Some(p) => min_rotation(&self.state[l].ref_tangent[g * k + i], &(a - p)),
            None => Matrix3::identity(),
        }
    }

    /// The active nodes at cross-section `i` among the descendants-or-self of GC `(l, g)`, into
    /// `self.children`.
    fn collect_active(&mut self, m: &HairModel, l: usize, g: usize, i: usize) {
        let k = m.k;
        self.children.clear();
        let mut range = g..g + 1;
        for ll in l..m.level_count() {
            if ll > l {
                let lv = &m.levels[ll - 1];
                range =
                    lv.sub_gcs[range.start].start as usize..lv.sub_gcs[range.end - 1].end as usize;
            }
            for d in range.clone() {
                if self.active[ll][d * k + i] {
                    self.children.push((ll, d));
                }
            }
        }
    }

    /// Before the node `(l, g, i)` changes (split or merge), brings the followers of its AWT
    /// children at `i + 1` to the present: their reference tangents were taken against it.
    fn children_to_present(&mut self, m: &HairModel, l: usize, g: usize, i: usize) {
        if i + 1 >= m.k {
            return;
        }
        self.collect_active(m, l, g, i + 1);
        let children = std::mem::take(&mut self.children);
        for &(cl, cg) in &children {
            self.follow_below(m, cl, cg, i + 1);
        }
        self.children = children;
    }

    /// After the node `(l, g, i)` changed: the AWT children at `i + 1` have a new parent, so
    /// their followers' offsets are recorded again against the new segment tangent.
    fn children_rerecord(&mut self, m: &HairModel, i: usize) {
        if i + 1 >= m.k {
            return;
        }
        let children = std::mem::take(&mut self.children);
        for &(cl, cg) in &children {
            self.record_followers(m, cl, cg, i + 1);
        }
        self.children = children;
    }

    /// Moves the descendants of active node `(l, g, i)` to their followed positions.
    fn follow_below(&mut self, m: &HairModel, l: usize, g: usize, i: usize) {
        let k = m.k;
        let r = self.follow_rotation(m, l, g, i);
        let a = self.state[l].pos[g * k + i];
        let v = self.state[l].vel[g * k + i];
        let mut range = g..g + 1;
        for ll in l + 1..m.level_count() {
            let lv = &m.levels[ll - 1];
            range = lv.sub_gcs[range.start].start as usize..lv.sub_gcs[range.end - 1].end as usize;
            let st = &mut self.state[ll];
            for d in range.clone() {
                st.pos[d * k + i] = a + r * st.offset[d * k + i];
                st.vel[d * k + i] = v;
            }
        }
    }

    /// Updates every non-active node below an active one (§3.3); root nodes follow the scalp.
    pub fn follow_all(&mut self, m: &HairModel, pose: &Pose) {
        let k = m.k;
        for (l, lv) in m.levels.iter().enumerate() {
            for g in 0..lv.gc_count() {
                // Roots are attached to the scalp, active or not.
                let j = g * k;
                if !self.active[l][j] {
                    let p = pose.transform_point(&Point3::from(lv.rest_pos[j])).coords;
                    self.state[l].pos[j] = p;
                    self.state[l].vel[j] = pose.velocity_at(&Point3::from(p));
                }
            }
        }
        for i in 1..k {
            for l in 0..m.level_count() - 1 {
                for g in 0..m.levels[l].gc_count() {
                    if self.active[l][g * k + i] {
                        self.follow_below(m, l, g, i);
                    }
                }
            }
        }
    }

    /// Checks the AWT invariant (see the module docs) and that roots are on the scalp.
    pub fn validate(&self, m: &HairModel, pose: &Pose) -> Result<(), String> {
        let k = m.k;
        let fin = m.level_count() - 1;
        for f in 0..m.finest().gc_count() {
            let mut prev_level = 0;
            for i in 0..k {
                let mut count = 0;
                let mut gov = None;
                for l in 0..=fin {
                    let a = Self::ancestor(m, fin, f, l);
                    if self.active[l][a * k + i] {
                        count += 1;
                        gov = Some((l, a));
                    }
                }
                if count != 1 {
                    return Err(format!(
                        "finest GC {f}, cross-section {i}: governed by {count} active nodes"
                    ));
                }
                let (l, a) = gov.expect("count is 1");
                if i > 0 && l < prev_level {
                    return Err(format!(
                        "finest GC {f}: level decreases from {prev_level} to {l} at cross-section {i}"
                    ));
                }
                prev_level = l;
                if i > 0 {
                    // One parent, of a level no finer, governing all of a's finest descendants.
                    let Some((pl, pj)) = self.governor_above(m, l, a, i - 1) else {
                        return Err(format!("node ({l}, {a}, {i}) has no parent"));
                    };
                    for ff in m.levels[l].finest[a].clone() {
                        let (ql, qj) = self
                            .governor_above(m, fin, ff as usize, i - 1)
                            .ok_or_else(|| format!("finest ({ff}, {}) ungoverned", i - 1))?;
                        if (ql, qj) != (pl, pj) {
                            return Err(format!(
                                "node ({l}, {a}, {i}) has more than one parent: ({pl}, {pj}) and ({ql}, {qj})"
                            ));
                        }
                    }
                } else {
                    let rest = m.levels[l].rest_pos[a * k];
                    let want = pose.transform_point(&Point3::from(rest)).coords;
                    let got = self.state[l].pos[a * k];
                    if (want - got).norm() > 1e-9 {
                        return Err(format!(
                            "root ({l}, {a}) is {:.3e} m off the scalp",
                            (want - got).norm()
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// Adaptation steps a node stays as it is after it appeared by a split or merge.
pub const SETTLE_STEPS: u64 = 5;
