//! Could the AWT's broad phase reuse one frame's candidate pairs over the frame's steps (a
//! Verlet list with a margin, issue 25 §3 "temporal coherence")? Steps a style under a motion
//! for 3 s and reports, frame by frame (4 steps):
//!
//! * how many frames have split or merge events (the active segments change, so a list keyed
//!   by segment would be rebuilt anyway);
//! * the largest displacement of an active node over the frame, in the head's frame (a list
//!   built at the frame's start must inflate every box by it to stay complete);
//! * the pairs such a list holds against the pairs whose boxes overlap at one step.
//!
//! `cargo run --release --example coherence_probe -- STYLE MOTION [SPLIT_THRESHOLD]`
//! (brute force over all pairs of segments: a few seconds per style).

mod common;

use std::collections::HashMap;

use nalgebra::{Point3, Vector3};
use wisptree::report::StepReport;

/// A segment's box (radius included) and what the collider's exclusions compare.
struct SegmentBox {
    lo: [f64; 3],
    hi: [f64; 3],
    parent: u32,
    child: u32,
    chain: u32,
}

impl SegmentBox {
    /// The collider never tests these pairs: adjacent segments, or two pieces of one GC.
    fn excluded(&self, o: &SegmentBox) -> bool {
        self.chain == o.chain
            || [self.parent, self.child]
                .iter()
                .any(|n| *n == o.parent || *n == o.child)
    }

    /// Whether the two boxes, each inflated by `m`, overlap.
    fn overlap(&self, o: &SegmentBox, m: f64) -> bool {
        (0..3).all(|k| self.lo[k] - m <= o.hi[k] + m && o.lo[k] - m <= self.hi[k] + m)
    }
}

fn main() -> anyhow::Result<()> {
    let common::ProbeArgs {
        style,
        motion: motion_name,
        split,
    } = common::probe_args("coherence_probe")?;
    let (_, mut sim) = common::awt_simulation(&style, &motion_name, split)?;
    let mut report = StepReport::default();
    let spf = 4;
    let (mut frames, mut frames_with_events) = (0, 0);
    let (mut list_sum, mut tested_sum, mut now_sum) = (0u64, 0u64, 0u64);
    let mut disp_all = Vec::new();
    let mut seg_len = Vec::new();
    for _ in 0..30 {
        sim.step(&mut report);
    }
    while sim.time() < 3.0 {
        // Frame start: segments keyed by the child's (level, node).
        let s = &sim.slots;
        let key = |i: usize| (s.level[i], s.node[i]);
        let inv = sim.pose().iso.inverse();
        let start: HashMap<(u8, u32), Vector3<f64>> = (0..s.pos.len())
            .map(|i| (key(i), inv.transform_point(&Point3::from(s.pos[i])).coords))
            .collect();
        let view = s.segs.view();
        let boxes: Vec<SegmentBox> = (0..view.len())
            .map(|i| {
                let (a, b) = (
                    s.pos[view.parent[i] as usize],
                    s.pos[view.child[i] as usize],
                );
                let r = view.radius[i];
                SegmentBox {
                    lo: [0, 1, 2].map(|k| a[k].min(b[k]) - r),
                    hi: [0, 1, 2].map(|k| a[k].max(b[k]) + r),
                    parent: view.parent[i],
                    child: view.child[i],
                    chain: view.chain[i],
                }
            })
            .collect();
        for i in 0..view.len() {
            seg_len.push((s.pos[view.child[i] as usize] - s.pos[view.parent[i] as usize]).norm());
        }
        let mut events = 0;
        let mut tested = 0u64;
        let mut maxd: f64 = 0.0;
        for _ in 0..spf {
            sim.step(&mut report);
            events += report.events.len();
            tested += report.counters.pairs_tested as u64;
            let s = &sim.slots;
            let inv = sim.pose().iso.inverse();
            for i in 0..s.pos.len() {
                if let Some(p0) = start.get(&(s.level[i], s.node[i])) {
                    let local = inv.transform_point(&Point3::from(s.pos[i])).coords;
                    maxd = maxd.max((local - p0).norm());
                }
            }
        }
        disp_all.push(maxd);
        frames += 1;
        if events > 0 {
            frames_with_events += 1;
        }
        // Pairs a list built at the frame start must hold: boxes inflated by the frame's
        // largest displacement (each side), non-adjacent, other chain.
        let overlap = |m: f64| {
            let mut n = 0u64;
            for i in 0..boxes.len() {
                for j in i + 1..boxes.len() {
                    let (a, b) = (&boxes[i], &boxes[j]);
                    if !a.excluded(b) && a.overlap(b, m) {
                        n += 1;
                    }
                }
            }
            n
        };
        list_sum += overlap(maxd);
        now_sum += overlap(0.0);
        tested_sum += tested;
    }
    disp_all.sort_by(f64::total_cmp);
    seg_len.sort_by(f64::total_cmp);
    let q = |v: &Vec<f64>, f: f64| v[((v.len() - 1) as f64 * f) as usize];
    println!(
        "{style} {motion_name} split {split:?}: {frames} frames, {frames_with_events} with split/merge events; \
         largest node displacement over a frame in the head's frame: median {:.1} mm, p90 {:.1} mm, max {:.1} mm; \
         segment length median {:.1} mm; pairs per step: tested {:.0}, boxes overlapping now {:.0}, \
         a frame's list {:.0} ({:.2}x the boxes)",
        q(&disp_all, 0.5) * 1e3,
        q(&disp_all, 0.9) * 1e3,
        disp_all.last().unwrap() * 1e3,
        q(&seg_len, 0.5) * 1e3,
        tested_sum as f64 / (frames * spf) as f64,
        now_sum as f64 / frames as f64,
        list_sum as f64 / frames as f64,
        list_sum as f64 / now_sum as f64,
    );
    Ok(())
}
