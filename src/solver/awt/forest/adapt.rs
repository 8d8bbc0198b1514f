//! Splitting and merging (AWT §3.1, §3.2): the adaptation pass of a step, and the two
//! operations it applies.

use crate::model::HairModel;
use crate::report::{AdaptEvent, EventKind};
use crate::style::SimParams;
use nalgebra::Vector3;

use super::*;

/// Splits (tip to root) and merges (root to tip) the forest once. The forest state must be
/// current for the active nodes. Returns whether the active set changed.
pub fn adapt(
    m: &HairModel,
    forest: &mut Forest,
    p: &SimParams,
    time: f64,
    scratch: &mut AdaptScratch,
    events: &mut Vec<AdaptEvent>,
) -> bool {
    let k = m.k;
    let nl = m.level_count();
    if nl < 2 {
        return false;
    }
    forest.adapt_step += 1;
    let now = forest.adapt_step;
    scratch.merge_refused = [0; 3];
    let mut changed = false;

    // Splitting (§3.1). Cross-sections are visited root first, so when node i is examined its
    // children at i + 1 are as they were at the start of the step: a split moves one
    // cross-section towards the root per step ("from tip to root").
    for i in 0..k {
        for l in 0..nl - 1 {
            for g in 0..m.levels[l].gc_count() {
                let j = g * k + i;
                // A node that just appeared (split or merge) first settles for a few steps:
                // the change itself jolts it (its links snap to their rest lengths), and that
                // jolt must not split it straight back. Condition (3) of merging is the paper's
                // guard against the same flip-flop; this is ours for its aftermath.
                let since = forest.state[l].changed_at[j];
                if !forest.active[l][j] || (since != 0 && now - since < SETTLE_STEPS) {
                    continue;
                }
                // (2) every AWT child has already split: the child at i + 1 is finer.
                if i + 1 < k && forest.active[l][j + 1] {
                    continue;
                }
                // (1) |a| r over the threshold.
                let ar = forest.state[l].acc[j].norm() * forest.state[l].radius[j];
                if ar <= p.split_threshold {
                    continue;
                }
                split(m, forest, l, g, i, now);
                let subs = m.levels[l].sub_gcs[g].clone();
                events.push(AdaptEvent {
                    kind: EventKind::Split,
                    time,
                    tree: m.levels[l].tree[g],
                    level: l as u8,
                    gc: g as u32,
                    cross_section: i as u16,
                    sub_gcs: subs,
                    position: forest.state[l].pos[j].into(),
                    accel_radius: ar,
                    rel_velocity: 0.0,
                });
                changed = true;
            }
        }
    }

    // Merging (§3.2), root first; a merge needs a parent that was already coarse at the start
    // of the step, so merging too moves one cross-section per step (towards the tip).
    for i in 0..k {
        for l in (0..nl - 1).rev() {
            for g in 0..m.levels[l].gc_count() {
                let j = g * k + i;
                if forest.active[l][j] {
                    continue;
                }
                let subs = m.levels[l].sub_gcs[g].clone();
                let sub_level = l + 1;
                let all_active = subs.clone().all(|s| {
                    let sj = s as usize * k + i;
                    forest.active[sub_level][sj] && forest.state[sub_level].changed_at[sj] != now
                });
                if !all_active {
                    continue;
                }
                // The shared parent is of level ≤ l (and not itself created this step).
                if i > 0 {
                    match forest.governor_above(m, l, g, i - 1) {
                        Some((pl, pj)) if forest.state[pl].changed_at[pj] != now => {}
                        _ => continue,
                    }
                }
                if let Some((com, rel_v, ar)) = merge_test(m, forest, l, g, i, p, scratch) {
                    let _ = com;
                    merge(m, forest, l, g, i, now);
                    events.push(AdaptEvent {
                        kind: EventKind::Merge,
                        time,
                        tree: m.levels[l].tree[g],
                        level: l as u8,
                        gc: g as u32,
                        cross_section: i as u16,
                        sub_gcs: subs,
                        position: forest.state[l].pos[j].into(),
                        accel_radius: ar,
                        rel_velocity: rel_v,
                    });
                    changed = true;
                }
            }
        }
    }
    changed
}

/// Merge conditions (1)–(3) for the sub-nodes of `(l, g, i)`. On success returns the centre of
/// mass, the largest relative speed, and |a_S|·r_S of the merged node.
fn merge_test(
    m: &HairModel,
    forest: &Forest,
    l: usize,
    g: usize,
    i: usize,
    p: &SimParams,
    scratch: &mut AdaptScratch,
) -> Option<(Vector3<f64>, f64, f64)> {
    let k = m.k;
    let subs = m.levels[l].sub_gcs[g].clone();
    let sl = &forest.state[l + 1];
    let lm = &m.levels[l + 1];
    let mut mass = 0.0;
    let mut com = Vector3::zeros();
    let mut acc = Vector3::zeros();
    scratch.sub_pos.clear();
    scratch.sub_pos.reserve(subs.len());
    for s in subs.clone() {
        let sj = s as usize * k + i;
        mass += lm.mass[sj];
        com += sl.pos[sj] * lm.mass[sj];
        acc += sl.acc[sj] * lm.mass[sj];
        scratch.sub_pos.push(sl.pos[sj]);
    }
    com /= mass;
    acc /= mass;
    // (1) every merging node lies within the super-node's radius of their centre of mass.
    let r_s = m.levels[l].radius[g * k + i] * p.merge_radius_factor;
    if scratch.sub_pos.iter().any(|x| (x - com).norm() > r_s) {
        scratch.merge_refused[0] += 1;
        return None;
    }
    // (2) relative velocities under the threshold (largest pairwise difference).
    let mut rel: f64 = 0.0;
    for a in subs.clone() {
        for b in subs.clone() {
            if b > a {
                let d = sl.vel[a as usize * k + i] - sl.vel[b as usize * k + i];
                rel = rel.max(d.norm());
            }
        }
    }
    if rel >= p.merge_velocity {
        scratch.merge_refused[1] += 1;
        return None;
    }
    // (3) the merged node would not split at once: |a_S| r_S ≤ threshold, r_S refitted.
    let r_fit = refit_radius(m, forest, l, g, i, &com);
    let ar = acc.norm() * r_fit;
    if ar > p.split_threshold {
        scratch.merge_refused[2] += 1;
        return None;
    }
    Some((com, rel, ar))
}

/// The radius that tightly encloses the sub-nodes of `(l, g, i)` around `centre`.
fn refit_radius(
    m: &HairModel,
    forest: &Forest,
    l: usize,
    g: usize,
    i: usize,
    centre: &Vector3<f64>,
) -> f64 {
    let k = m.k;
    let sl = &forest.state[l + 1];
    m.levels[l].sub_gcs[g]
        .clone()
        .map(|s| {
            let sj = s as usize * k + i;
            (sl.pos[sj] - centre).norm() + sl.radius[sj]
        })
        .fold(crate::model::MIN_RADIUS, f64::max)
}

/// `now` stamps the nodes that changed (pass `forest.adapt_step` outside `adapt`: a node stamped
/// with the current adaptation step is left alone by the rest of that step).
/// Replaces active node `(l, g, i)` by its sub-nodes at their followed positions, with its
/// velocity (and acceleration, so the smoothing continues).
pub fn split(m: &HairModel, forest: &mut Forest, l: usize, g: usize, i: usize, now: u64) {
    let k = m.k;
    let j = g * k + i;
    // Bring every follower of the node, and of its children, to the present before the tree
    // changes under them.
    if i > 0 {
        forest.follow_below(m, l, g, i);
    }
    forest.children_to_present(m, l, g, i);
    let (v, a) = (forest.state[l].vel[j], forest.state[l].acc[j]);
    forest.active[l][j] = false;
    forest.state[l].changed_at[j] = now;
    let subs = m.levels[l].sub_gcs[g].clone();
    for s in subs.clone() {
        let sj = s as usize * k + i;
        forest.active[l + 1][sj] = true;
        let st = &mut forest.state[l + 1];
        st.changed_at[sj] = now;
        st.vel[sj] = v;
        st.acc[sj] = a;
        st.radius[sj] = m.levels[l + 1].radius[sj];
    }
    if i > 0 {
        for s in subs {
            forest.record_followers(m, l + 1, s as usize, i);
        }
    }
    forest.children_rerecord(m, i);
}

/// Merges the sub-nodes of `(l, g, i)` into it: centre of mass, mass-weighted velocity, tight
/// radius; the merged nodes' offsets are recorded (§3.2).
pub fn merge(m: &HairModel, forest: &mut Forest, l: usize, g: usize, i: usize, now: u64) {
    let k = m.k;
    let j = g * k + i;
    let subs = m.levels[l].sub_gcs[g].clone();
    // Deeper followers of the sub-nodes, and the children's followers, to the present first.
    forest.children_to_present(m, l, g, i);
    if i > 0 {
        for s in subs.clone() {
            if l + 2 < m.level_count() {
                forest.follow_below(m, l + 1, s as usize, i);
            }
        }
    }
    let lm = &m.levels[l + 1];
    let mut mass = 0.0;
    let mut mom = Vector3::zeros();
    let mut com = Vector3::zeros();
    let mut acc = Vector3::zeros();
    for s in subs.clone() {
        let sj = s as usize * k + i;
        let st = &forest.state[l + 1];
        mass += lm.mass[sj];
        com += st.pos[sj] * lm.mass[sj];
        mom += st.vel[sj] * lm.mass[sj];
        acc += st.acc[sj] * lm.mass[sj];
    }
    com /= mass;
    let radius = refit_radius(m, forest, l, g, i, &com);
    for s in subs {
        let sj = s as usize * k + i;
        forest.active[l + 1][sj] = false;
        forest.state[l + 1].changed_at[sj] = now;
    }
    forest.active[l][j] = true;
    let st = &mut forest.state[l];
    st.changed_at[j] = now;
    st.pos[j] = com;
    st.vel[j] = mom / mass;
    st.acc[j] = acc / mass;
    st.radius[j] = radius;
    if i > 0 {
        forest.record_followers(m, l, g, i);
    }
    forest.children_rerecord(m, i);
}
