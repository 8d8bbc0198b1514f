//! Ask one node why: the numbers behind its split test (AWT §3.1) and its merge test (§3.2),
//! read from the state after a step. `run --inspect TREE:LEVEL:INDEX` logs them every frame.

use super::forest::SETTLE_STEPS;
use super::Simulation;
use crate::model::HairModel;

/// A node named as a user names it: its tree (top-level GC), its level, and its index among
/// that tree's nodes of that level (GC by GC in model order, root to tip within a GC).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeId {
    /// Tree (top-level GC), from 0.
    pub tree: u32,
    /// Level of detail, 0 the coarsest.
    pub level: usize,
    /// Index among the tree's nodes of that level.
    pub index: usize,
}

impl NodeId {
    /// Parses `TREE:LEVEL:INDEX` (three non-negative integers).
    pub fn parse(s: &str) -> Result<NodeId, String> {
        let parts: Vec<&str> = s.split(':').collect();
        let [t, l, i] = parts[..] else {
            return Err(format!(
                "`{s}`: a node is TREE:LEVEL:INDEX, three numbers joined by `:` (0:1:12)"
            ));
        };
        let num = |v: &str, what: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: {what} `{v}` is not a non-negative integer"))
        };
        Ok(NodeId {
            tree: num(t, "TREE")? as u32,
            level: num(l, "LEVEL")?,
            index: num(i, "INDEX")?,
        })
    }

    /// The name of node `j` (`g·K + i`: GC `g`, cross-section `i`) of level `level` of model
    /// `m`: the inverse of [`resolve`].
    pub fn of(m: &HairModel, level: usize, j: usize) -> NodeId {
        let lv = &m.levels[level];
        let (g, i) = (j / m.k, j % m.k);
        let tree = lv.tree[g];
        let before = (0..g).filter(|&h| lv.tree[h] == tree).count();
        NodeId {
            tree,
            level,
            index: before * m.k + i,
        }
    }

    /// `tree/level/index`, the node's path under `/inspect`.
    pub fn path(&self) -> String {
        format!("{}/{}/{}", self.tree, self.level, self.index)
    }
}

/// The names [`Simulation::inspect`] fills, in its order (each logged as its own scalar).
pub const INSPECT_NAMES: [&str; 26] = [
    "active",
    "gc",
    "cross_section",
    "radius",
    "mass",
    "speed",
    "acceleration",
    "accel_radius",
    "split_threshold_in_force",
    "may_split",
    "merge_candidates",
    "merge_relative_velocity",
    "merge_velocity_in_force",
    "merge_spread",
    "merge_radius",
    "last_change_s",
    "height",
    "position_x",
    "position_y",
    "position_z",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "acceleration_x",
    "acceleration_y",
    "acceleration_z",
];

/// The level's GC and cross-section of node `id` of model `m`, or why there is none.
pub fn resolve(m: &HairModel, id: &NodeId) -> Result<(usize, usize), String> {
    {
        if id.level >= m.level_count() {
            return Err(format!(
                "level {} does not exist: the model has levels 0 to {}",
                id.level,
                m.level_count() - 1
            ));
        }
        let lv = &m.levels[id.level];
        let trees = m.levels[0].gc_count();
        if id.tree as usize >= trees {
            return Err(format!(
                "tree {} does not exist: the model has trees 0 to {}",
                id.tree,
                trees - 1
            ));
        }
        let gcs: Vec<usize> = (0..lv.gc_count())
            .filter(|&g| lv.tree[g] == id.tree)
            .collect();
        let (local, i) = (id.index / m.k, id.index % m.k);
        match gcs.get(local) {
            Some(&g) => Ok((g, i)),
            None => Err(format!(
                "index {} does not exist: tree {} has {} nodes on level {} (0 to {})",
                id.index,
                id.tree,
                gcs.len() * m.k,
                id.level,
                (gcs.len() * m.k).saturating_sub(1)
            )),
        }
    }
}

impl Simulation {
    /// Fills `out` with [`INSPECT_NAMES`] for node `id`, from the state after the last step.
    ///
    /// * The split test (§3.1): `accel_radius` = |a|·r against `split_threshold_in_force`;
    ///   `may_split` is 1 when the node is active, on a level that has finer nodes, settled
    ///   since it last changed, and its child along the strand has already split (tip to root).
    ///   A node that is not active keeps the numbers it had when it stopped being active.
    /// * The merge test (§3.2) of the node with its siblings into their super-node, when the
    ///   super-node is not active: `merge_candidates` siblings (0 when no merge is possible),
    ///   their largest relative velocity against `merge_velocity_in_force`, and their largest
    ///   distance from their centre of mass (`merge_spread`) against the super-node's radius
    ///   times the merge radius factor (`merge_radius`).
    /// * `last_change_s`: simulated time at which the node last became active or inactive.
    /// * `position_*`, `velocity_*`, `acceleration_*`: the node's state in world axes (`height`
    ///   is `position_y`, kept for recordings made before the vectors were logged).
    pub fn inspect(&self, id: &NodeId, out: &mut Vec<(&'static str, f64)>) -> Result<(), String> {
        let (g, i) = resolve(&self.model, id)?;
        let m = &self.model;
        let (l, k) = (id.level, m.k);
        let j = g * k + i;
        let st = &self.forest.state[l];
        let active = self.forest.active[l][j];
        let p = &self.params;
        let ar = st.acc[j].norm() * st.radius[j];
        let since = st.changed_at[j];
        let settled = since == 0 || self.forest.adapt_step.saturating_sub(since) >= SETTLE_STEPS;
        let finer = l + 1 < m.level_count();
        let child_split = i + 1 == k || !self.forest.active[l][j + 1];
        let may_split = active && finer && settled && child_split;
        let (mut candidates, mut rel, mut spread, mut r_s) = (0.0, 0.0, 0.0, 0.0);
        if l > 0 {
            let sg = m.levels[l].super_gc[g] as usize;
            if !self.forest.active[l - 1][sg * k + i] {
                let subs = m.levels[l - 1].sub_gcs[sg].clone();
                let lm = &m.levels[l];
                let (mut mass, mut com) = (0.0, nalgebra::Vector3::zeros());
                for s in subs.clone() {
                    let sj = s as usize * k + i;
                    mass += lm.mass[sj];
                    com += st.pos[sj] * lm.mass[sj];
                }
                com /= mass;
                for a in subs.clone() {
                    let aj = a as usize * k + i;
                    spread = f64::max(spread, (st.pos[aj] - com).norm());
                    for b in subs.clone().filter(|&b| b > a) {
                        rel = f64::max(rel, (st.vel[aj] - st.vel[b as usize * k + i]).norm());
                    }
                }
                candidates = subs.len() as f64;
                r_s = m.levels[l - 1].radius[sg * k + i] * p.merge_radius_factor;
            }
        }
        let b = |x: bool| if x { 1.0 } else { 0.0 };
        out.clear();
        out.extend(INSPECT_NAMES.iter().copied().zip([
            b(active),
            g as f64,
            i as f64,
            st.radius[j],
            m.levels[l].mass[j],
            st.vel[j].norm(),
            st.acc[j].norm(),
            ar,
            p.split_threshold,
            b(may_split),
            candidates,
            rel,
            p.merge_velocity,
            spread,
            r_s,
            // `adapt` runs once per step: its counter is a step number.
            since as f64 * p.dt,
            st.pos[j].y,
            st.pos[j].x,
            st.pos[j].y,
            st.pos[j].z,
            st.vel[j].x,
            st.vel[j].y,
            st.vel[j].z,
            st.acc[j].x,
            st.acc[j].y,
            st.acc[j].z,
        ]));
        Ok(())
    }
}
