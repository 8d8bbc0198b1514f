//! Which wisps touch? Steps an AWT style under a motion for 3 s and, every quarter second,
//! sorts the hair–hair contacts (AWT §4.1: active segments whose axes come closer than the sum
//! of their radii; adjacent segments and segments of one GC excluded, as the collider does)
//! by how the two wisps are related in the tree:
//!
//! * siblings: sub-wisps of one split wisp (the same super-GC);
//! * same tree: other wisps of the same top-level wisp;
//! * other trees: wisps of different top-level wisps.
//!
//! This sizes a reading DESIGN.md leaves open (should split sub-wisps rub against each other?),
//! not something the collider does: it counts every pair by brute force. It also says how the
//! contacts are grouped by pairs of chains (GCs), and how many continue to the next segment of
//! both chains: what a pair search that walks two touching wisps along each other would reuse.
//!
//! `cargo run --release --example contact_kinds -- STYLE MOTION [SPLIT_THRESHOLD]`

mod common;

use wisptree::report::StepReport;
use wisptree::solver::common::closest_segment_params;

fn main() -> anyhow::Result<()> {
    let common::ProbeArgs {
        style,
        motion: motion_name,
        split,
    } = common::probe_args("contact_kinds")?;
    let (model, mut sim) = common::awt_simulation(&style, &motion_name, split)?;
    let k = model.levels[0].rest_pos.len() / model.levels[0].gc_count();
    let mut report = StepReport::default();
    // [siblings, same tree, other trees]
    let mut kinds = [0u64; 3];
    let mut samples = 0;
    // Distinct pairs of chains in contact, and contacts whose successor pair is one too.
    let (mut chain_pairs, mut continued) = (0u64, 0u64);
    while sim.time() < 3.0 {
        for _ in 0..25 {
            sim.step(&mut report);
        }
        let s = &sim.slots;
        let view = s.segs.view();
        let n = view.len();
        // Per segment: its GC's level, super-GC and tree.
        let gc: Vec<(usize, u32, u32)> = (0..n)
            .map(|i| {
                let c = view.child[i] as usize;
                let l = s.level[c] as usize;
                let g = s.node[c] as usize / k;
                let level = &model.levels[l];
                (l, level.super_gc[g], level.tree[g])
            })
            .collect();
        // The next segment of each segment's chain (the one whose parent is its child).
        let by_parent: std::collections::HashMap<(u32, u32), usize> = (0..n)
            .map(|i| ((view.parent[i], view.chain[i]), i))
            .collect();
        let next: Vec<Option<usize>> = (0..n)
            .map(|i| by_parent.get(&(view.child[i], view.chain[i])).copied())
            .collect();
        let mut contacts = std::collections::HashSet::new();
        for i in 0..n {
            for j in i + 1..n {
                let (pi, ci) = (view.parent[i], view.child[i]);
                let (pj, cj) = (view.parent[j], view.child[j]);
                if view.chain[i] == view.chain[j] || pi == pj || pi == cj || ci == pj || ci == cj {
                    continue;
                }
                let (a1, b1) = (&s.pos[pi as usize], &s.pos[ci as usize]);
                let (a2, b2) = (&s.pos[pj as usize], &s.pos[cj as usize]);
                let (u, v) = closest_segment_params(a1, b1, a2, b2);
                let d = (a1 + (b1 - a1) * u - (a2 + (b2 - a2) * v)).norm();
                if d >= view.radius[i] + view.radius[j] {
                    continue;
                }
                let ((li, si, ti), (lj, sj, tj)) = (gc[i], gc[j]);
                let kind = if li == lj && li > 0 && si == sj {
                    0
                } else if ti == tj {
                    1
                } else {
                    2
                };
                kinds[kind] += 1;
                contacts.insert((i, j));
            }
        }
        let pairs: std::collections::HashSet<(u32, u32)> = contacts
            .iter()
            .map(|&(i, j)| (view.chain[i], view.chain[j]))
            .collect();
        chain_pairs += pairs.len() as u64;
        continued += contacts
            .iter()
            .filter(|&&(i, j)| match (next[i], next[j]) {
                (Some(a), Some(b)) => contacts.contains(&(a.min(b), a.max(b))),
                _ => false,
            })
            .count() as u64;
        samples += 1;
    }
    let total: u64 = kinds.iter().sum();
    let share = |x: u64| 100.0 * x as f64 / total.max(1) as f64;
    println!(
        "{style} {motion_name} split {split:?}: {:.0} contacts per step (mean of {samples} \
         samples): siblings {:.1} %, same top-level wisp {:.1} %, other top-level wisps {:.1} %; \
         {:.0} pairs of chains in contact ({:.1} contacts each), {:.1} % of the contacts go on \
         to the next segment of both chains",
        total as f64 / samples as f64,
        share(kinds[0]),
        share(kinds[1]),
        share(kinds[2]),
        chain_pairs as f64 / samples as f64,
        total as f64 / chain_pairs.max(1) as f64,
        share(continued),
    );
    Ok(())
}
