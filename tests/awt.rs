//! The AWT's rules, one by one (AWT §3, DESIGN.md), on small synthetic models.

mod common;

use common::*;
use nalgebra::{Rotation3, Vector3};
use wisptree::model::HairModel;
use wisptree::motion::Pose;
use wisptree::solver::awt::forest::{self as awt, AdaptScratch, Forest};
use wisptree::solver::awt::{EventKind, StepReport};
use wisptree::style::SimParams;

const K: usize = 8;

fn model3() -> std::sync::Arc<HairModel> {
    let text = style_text(3, &[3, 2], K, 2, "Rigid(iterations: 8)", "");
    synthetic_model(&text, 60, 0.4, 3).1
}

fn params(split: f64, merge_v: f64) -> SimParams {
    SimParams {
        split_threshold: split,
        merge_velocity: merge_v,
        merge_radius_factor: 1.0,
        ..SimParams::default()
    }
}

fn adapt_once(
    m: &HairModel,
    f: &mut Forest,
    p: &SimParams,
) -> Vec<wisptree::solver::awt::AdaptEvent> {
    let mut ev = Vec::new();
    awt::adapt(m, f, p, 0.0, &mut AdaptScratch::default(), &mut ev);
    ev
}

fn fresh(m: &HairModel) -> Forest {
    Forest::new(m, &Pose::identity(), false)
}

/// Gives every active node of tree 0 an acceleration with |a|·r = `ar`.
fn shake_tree(m: &HairModel, f: &mut Forest, ar: f64) {
    for l in 0..m.level_count() {
        for g in 0..m.levels[l].gc_count() {
            if m.levels[l].tree[g] != 0 {
                continue;
            }
            for i in 0..K {
                let j = g * K + i;
                let r = f.state[l].radius[j];
                f.state[l].acc[j] = Vector3::new(ar / r, 0.0, 0.0);
            }
        }
    }
}

#[test]
fn forest_starts_with_only_coarsest_nodes_active() {
    let m = model3();
    let f = fresh(&m);
    assert!(f.active[0].iter().all(|a| *a));
    assert!(f.active[1].iter().all(|a| !*a));
    assert!(f.active[2].iter().all(|a| !*a));
    f.validate(&m, &Pose::identity()).unwrap();
}

#[test]
fn split_needs_both_conditions() {
    let m = model3();
    let p = params(0.2, 0.05);
    // (1) without (2): a mid node over the threshold whose child has not split stays.
    let mut f = fresh(&m);
    let mid = 3;
    f.state[0].acc[mid] = Vector3::new(1.0 / f.state[0].radius[mid], 0.0, 0.0);
    assert!(adapt_once(&m, &mut f, &p).is_empty());
    assert!(f.active[0][mid]);
    // (2) without (1): a tip under the threshold stays.
    let tip = K - 1;
    f.state[0].acc[tip] = Vector3::new(0.1 / f.state[0].radius[tip], 0.0, 0.0);
    assert!(adapt_once(&m, &mut f, &p).is_empty());
    // Both: the tip splits.
    f.state[0].acc[tip] = Vector3::new(0.3 / f.state[0].radius[tip], 0.0, 0.0);
    let ev = adapt_once(&m, &mut f, &p);
    assert_eq!(ev.len(), 1);
    assert_eq!(ev[0].kind, EventKind::Split);
    assert_eq!(ev[0].cross_section as usize, tip);
    assert!(ev[0].accel_radius > 0.2);
    assert!(!f.active[0][tip]);
    for s in m.levels[0].sub_gcs[0].clone() {
        assert!(f.active[1][s as usize * K + tip]);
    }
    f.validate(&m, &Pose::identity()).unwrap();
}

#[test]
fn splitting_travels_from_tip_to_root_one_cross_section_per_step() {
    let m = model3();
    let p = params(0.2, 0.0);
    let mut f = fresh(&m);
    for step in 1..=K {
        shake_tree(&m, &mut f, 1.0);
        let ev = adapt_once(&m, &mut f, &p);
        // Level-0 splits this step are exactly at cross-section K - step.
        let l0: Vec<usize> = ev
            .iter()
            .filter(|e| e.level == 0)
            .map(|e| e.cross_section as usize)
            .collect();
        assert!(!l0.is_empty(), "step {step}: nothing split");
        assert!(l0.iter().all(|&i| i == K - step), "step {step}: {l0:?}");
        f.validate(&m, &Pose::identity()).unwrap();
    }
}

#[test]
fn sub_nodes_take_the_split_nodes_velocity_and_conserve_mass_and_momentum() {
    let m = model3();
    let mut f = fresh(&m);
    let tip = K - 1;
    let v = Vector3::new(0.3, -1.2, 0.7);
    f.state[0].vel[tip] = v;
    let before_m = m.levels[0].mass[tip];
    let before_p = v * before_m;
    let now = f.adapt_step;
    awt::split(&m, &mut f, 0, 0, tip, now);
    let mut mass = 0.0;
    let mut mom = Vector3::zeros();
    for s in m.levels[0].sub_gcs[0].clone() {
        let j = s as usize * K + tip;
        assert_eq!(f.state[1].vel[j], v);
        mass += m.levels[1].mass[j];
        mom += f.state[1].vel[j] * m.levels[1].mass[j];
    }
    assert!(((mass - before_m) / before_m).abs() < 1e-12);
    assert!((mom - before_p).norm() / before_p.norm() < 1e-12);
}

/// Splits the tip of tree 0 and returns the forest, ready for merge tests.
fn split_tip(m: &HairModel) -> Forest {
    let mut f = fresh(m);
    let now = f.adapt_step;
    awt::split(m, &mut f, 0, 0, K - 1, now);
    f
}

fn subs(m: &HairModel) -> Vec<usize> {
    m.levels[0].sub_gcs[0]
        .clone()
        .map(|s| s as usize * K + K - 1)
        .collect()
}

#[test]
fn merge_places_the_super_node_at_the_centre_of_mass_with_mean_velocity_and_tight_radius() {
    let m = model3();
    let p = params(0.3, 0.05);
    let mut f = split_tip(&m);
    let subs = subs(&m);
    let mut mass = 0.0;
    let mut com = Vector3::zeros();
    let mut mom = Vector3::zeros();
    for (n, &j) in subs.iter().enumerate() {
        f.state[1].vel[j] = Vector3::new(0.01 * n as f64, 0.0, 0.0);
        let mj = m.levels[1].mass[j];
        mass += mj;
        com += f.state[1].pos[j] * mj;
        mom += f.state[1].vel[j] * mj;
    }
    com /= mass;
    let ev = adapt_once(&m, &mut f, &p);
    assert_eq!(ev.len(), 1, "{ev:?}");
    assert_eq!(ev[0].kind, EventKind::Merge);
    let s = K - 1;
    assert!(f.active[0][s]);
    assert!((f.state[0].pos[s] - com).norm() < 1e-12);
    assert!((f.state[0].vel[s] * mass - mom).norm() < 1e-15);
    let tight = subs
        .iter()
        .map(|&j| (f.state[1].pos[j] - com).norm() + f.state[1].radius[j])
        .fold(0.0, f64::max);
    assert!((f.state[0].radius[s] - tight).abs() < 1e-12);
    f.validate(&m, &Pose::identity()).unwrap();
}

fn no_merge(ev: Vec<wisptree::solver::awt::AdaptEvent>) -> bool {
    ev.iter().all(|e| e.kind != EventKind::Merge)
}

#[test]
fn each_merge_condition_blocks_merging_on_its_own() {
    let m = model3();
    let p = params(0.3, 0.05);
    let subs = subs(&m);
    let rs = m.levels[0].radius[K - 1];
    // (1) a sub-node farther than the super radius from the centre of mass.
    let mut f = split_tip(&m);
    f.state[1].pos[subs[0]] += Vector3::new(3.0 * rs, 0.0, 0.0);
    assert!(no_merge(adapt_once(&m, &mut f, &p)));
    // (2) relative velocity over the threshold.
    let mut f = split_tip(&m);
    f.state[1].vel[subs[0]] = Vector3::new(0.06, 0.0, 0.0);
    assert!(no_merge(adapt_once(&m, &mut f, &p)));
    // (3) the merged node would split at once.
    let mut f = split_tip(&m);
    for &j in &subs {
        f.state[1].acc[j] = Vector3::new(1.0 / rs, 0.0, 0.0);
    }
    assert!(no_merge(adapt_once(&m, &mut f, &p)));
    // And with none of them, it merges.
    let mut f = split_tip(&m);
    assert_eq!(adapt_once(&m, &mut f, &p).len(), 1);
}

#[test]
fn merging_never_happens_while_the_parent_is_finer() {
    let m = model3();
    let p = params(0.3, 0.05);
    let mut f = fresh(&m);
    let now = f.adapt_step;
    awt::split(&m, &mut f, 0, 0, K - 1, now);
    awt::split(&m, &mut f, 0, 0, K - 2, now);
    f.validate(&m, &Pose::identity()).unwrap();
    // One adapt: only K-2 may merge (its parent is coarse); K-1's parent was finer at the start.
    let ev = adapt_once(&m, &mut f, &p);
    assert_eq!(ev.len(), 1, "{ev:?}");
    assert_eq!(ev[0].cross_section as usize, K - 2);
    assert!(!f.active[0][K - 1]);
    // Next step the tip follows.
    let ev = adapt_once(&m, &mut f, &p);
    assert_eq!(ev.len(), 1);
    assert_eq!(ev[0].cross_section as usize, K - 1);
    f.validate(&m, &Pose::identity()).unwrap();
}

#[test]
fn a_non_active_node_rotates_with_its_segment() {
    let m = model3();
    let mut f = fresh(&m);
    let i = 4;
    let parent = f.state[0].pos[i - 1];
    let a = f.state[0].pos[i];
    let d = f.state[1].pos[i] - a; // a sub-node (GC 0 of level 1) relative to its governor
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.6);
    let a_new = parent + rot * (a - parent);
    f.state[0].pos[i] = a_new;
    f.follow_all(&m, &Pose::identity());
    let got = f.state[1].pos[i] - a_new;
    let want = wisptree::solver::awt::forest::min_rotation(&(a - parent), &(a_new - parent)) * d;
    assert!((got - want).norm() < 1e-12, "{got} vs {want}");
    // The rotation is a real one: the offset changed direction.
    assert!((got - d).norm() > 1e-3 * d.norm().max(1e-6));
}

#[test]
fn a_strand_whose_wisp_never_splits_moves_rigidly_with_it() {
    let text = style_text(2, &[3], K, 1, "Rigid(iterations: 8)", "");
    let (loaded, model) = synthetic_model(&text, 30, 0.4, 5);
    let mut sim = wisptree::solver::awt::Simulation::from_style(
        model.clone(),
        &loaded.style,
        motion("still"),
        false,
    );
    sim.update_followers();
    let mut before = Vec::new();
    for s in 0..model.strands.len() {
        sim.strand_points(s, &mut before);
    }
    // Swing the whole coarse wisp rigidly about a horizontal axis through its root.
    let root = sim.slots.pos[0];
    let rot = Rotation3::from_axis_angle(&Vector3::x_axis(), 0.4);
    for c in 0..sim.slots.len() {
        sim.slots.pos[c] = root + rot * (sim.slots.pos[c] - root);
    }
    sim.update_followers();
    let mut after = Vec::new();
    for s in 0..model.strands.len() {
        sim.strand_points(s, &mut after);
    }
    // Strands hang straight down (tangents ⟂ the axis), so following is exactly rigid; the
    // root cross-section follows the (still) scalp and is skipped.
    let k = model.k;
    let mut worst: f64 = 0.0;
    for (n, (b, a)) in before.iter().zip(&after).enumerate() {
        if n % k == 0 {
            continue;
        }
        worst = worst.max((a - (root + rot * (b - root))).norm());
    }
    assert!(worst < 2e-3, "worst deviation {worst} m");
}

#[test]
fn adapt_keeps_the_invariant_over_random_accelerations() {
    let m = model3();
    let mut rng = Rng::new(11);
    for trial in 0..5 {
        let p = params(rng.range(0.05, 0.5), rng.range(0.0, 0.3));
        let mut f = fresh(&m);
        for _ in 0..60 {
            for l in 0..m.level_count() {
                for j in 0..f.state[l].acc.len() {
                    let a = if rng.f64() < 0.5 {
                        rng.range(0.0, 40.0)
                    } else {
                        0.0
                    };
                    f.state[l].acc[j] = Vector3::new(a, 0.0, 0.0);
                    f.state[l].vel[j] = Vector3::new(rng.range(-0.02, 0.02), 0.0, 0.0);
                }
            }
            adapt_once(&m, &mut f, &p);
            f.follow_all(&m, &Pose::identity());
            f.validate(&m, &Pose::identity())
                .unwrap_or_else(|e| panic!("trial {trial}: {e}"));
        }
    }
}

#[test]
fn step_report_counts_active_nodes() {
    let text = style_text(3, &[3, 2], K, 2, "Rigid(iterations: 8)", "");
    let mut sim = synthetic_sim(&text, 60, "still");
    let mut r = StepReport::default();
    sim.step(&mut r);
    let total: u32 = r.counters.active_per_level.iter().sum();
    assert_eq!(total as usize, sim.active_count());
    assert_eq!(r.counters.segments as usize, sim.active_count() - 2);
}
