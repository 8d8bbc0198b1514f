//! The simulation as a whole: links, damping, obstacles, invariants over randomized runs, and
//! determinism, on small synthetic models (the paper styles have their own test file).

mod common;

use common::*;
use nalgebra::{Point3, Vector3};
use wisptree::solver::awt::{Simulation, StepReport, NO_SLOT};
use wisptree::solver::common::damp_relative;

const K: usize = 10;

fn rigid_text(sim: &str) -> String {
    style_text(3, &[3, 2], K, 3, "Rigid(iterations: 8)", sim)
}

fn spring_text(sim: &str) -> String {
    style_text(
        2,
        &[3],
        K,
        3,
        "Spring(stiffness: 400.0, damping: 20.0)",
        sim,
    )
}

fn link_lengths(sim: &Simulation) -> Vec<(f64, f64)> {
    let s = &sim.slots;
    (0..s.len())
        .filter(|&c| s.parent[c] != NO_SLOT)
        .map(|c| {
            (
                (s.pos[c] - s.pos[s.parent[c] as usize]).norm(),
                s.rest_len[c],
            )
        })
        .collect()
}

#[test]
fn rigid_links_keep_their_length_within_a_tenth_of_a_percent_after_a_violent_step() {
    let mut sim = synthetic_sim(&rigid_text("split_threshold: 0.1"), 90, "shake");
    let mut rng = Rng::new(3);
    // Violent: random velocities of several m/s on every node.
    for c in 0..sim.slots.len() {
        sim.slots.vel[c] = Vector3::new(
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
            rng.range(-5.0, 5.0),
        );
    }
    let mut r = StepReport::default();
    for _ in 0..30 {
        sim.step(&mut r);
        for (len, rest) in link_lengths(&sim) {
            assert!(
                ((len - rest) / rest).abs() < 1e-3,
                "length {len} rest {rest}"
            );
        }
    }
}

#[test]
fn springs_stretch_under_load_and_come_back() {
    // The springs alone: no body (static friction on the shoulders would rightly hold stretched
    // hair in place) and no hair–hair interaction (which jams overstretched hair).
    let text = spring_text("split_threshold: 100.0, bending: 0.0, friction: 0.0, repulsion: 0.0")
        .replacen('(', "(head: (body: []), ", 1);
    let mut sim = synthetic_sim(&text, 60, "still");
    let mut r = StepReport::default();
    let stretch = |sim: &Simulation| {
        link_lengths(sim)
            .iter()
            .map(|(l, r)| l / r)
            .fold(0.0, f64::max)
    };
    // Heavy load: gravity × 3.
    sim.params.gravity = [0.0, -30.0, 0.0];
    for _ in 0..200 {
        sim.step(&mut r);
    }
    let loaded = stretch(&sim);
    assert!(
        loaded > 1.02,
        "springs should stretch under load, max ratio {loaded}"
    );
    // Unload: back to (nearly) rest length.
    sim.params.gravity = [0.0, 0.0, 0.0];
    for _ in 0..400 {
        sim.step(&mut r);
    }
    let rest = stretch(&sim);
    assert!(rest < 1.005, "springs should come back, max ratio {rest}");
}

#[test]
fn damping_never_reverses_a_relative_velocity() {
    let mut rng = Rng::new(9);
    for _ in 0..1000 {
        let v1 = Vector3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        let v2 = Vector3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        );
        let (m1, m2) = (rng.range(1e-4, 1.0), rng.range(1e-4, 1.0));
        // ν·dt from gentle to ≫ 1.
        let nu = rng.range(0.0, 1e4);
        let (d1, d2) = damp_relative(v1, m1, v2, m2, nu, 0.01);
        let before = v2 - v1;
        let after = (v2 + d2) - (v1 + d1);
        assert!(after.dot(&before) >= -1e-12, "reversed: {before} → {after}");
        assert!(after.norm() <= before.norm() + 1e-12);
        // Momentum is conserved.
        assert!(((d1 * m1 + d2 * m2).norm()) < 1e-12);
    }
}

#[test]
fn no_node_ends_a_step_inside_a_body_sphere() {
    for motion_name in ["lean", "shake", "jump"] {
        let mut sim = synthetic_sim(&rigid_text("split_threshold: 0.2"), 90, motion_name);
        let mut r = StepReport::default();
        for step in 0..300 {
            sim.step(&mut r);
            let pose = *sim.pose();
            for sp in &sim.model.body {
                let c = pose
                    .transform_point(&Point3::from(Vector3::from(sp.center)))
                    .coords;
                for (n, x) in sim.slots.pos.iter().enumerate() {
                    if sim.slots.parent[n] == NO_SLOT {
                        continue;
                    }
                    let d = (x - c).norm();
                    assert!(
                        d >= sp.radius - 1e-6,
                        "{motion_name} step {step}: node {n} {d} inside sphere of radius {}",
                        sp.radius
                    );
                }
            }
        }
    }
}

#[test]
fn the_invariant_holds_after_every_step_of_randomized_runs() {
    let mut rng = Rng::new(21);
    for run in 0..8 {
        let motion_name = ["lean", "run", "jump", "shake", "stop", "still"][run % 6];
        let split = rng.range(0.02, 0.5);
        let merge_v = rng.range(0.01, 0.3);
        let sim_text = format!("split_threshold: {split}, merge_velocity: {merge_v}");
        let text = if run % 2 == 0 {
            rigid_text(&sim_text)
        } else {
            spring_text(&sim_text)
        };
        let (loaded, model) =
            synthetic_model(&text, 40 + 10 * run, 0.3 + 0.05 * run as f64, run as u64);
        let mut sim =
            Simulation::from_style(model.clone(), &loaded.style, motion(motion_name), false);
        let mut r = StepReport::default();
        let mass = model.total_mass;
        for step in 0..250 {
            sim.step(&mut r);
            sim.validate()
                .unwrap_or_else(|e| panic!("run {run} ({motion_name}) step {step}: {e}"));
            let m = sim.active_mass();
            assert!(((m - mass) / mass).abs() < 1e-9, "mass {m} vs {mass}");
        }
    }
}

#[test]
fn two_runs_with_the_same_inputs_are_bit_identical() {
    let text = rigid_text("split_threshold: 0.1");
    let run = || {
        let mut sim = synthetic_sim(&text, 80, "lean");
        let mut r = StepReport::default();
        let mut events = 0;
        for _ in 0..200 {
            sim.step(&mut r);
            events += r.events.len();
        }
        (sim.slots.pos.clone(), sim.slots.vel.clone(), events)
    };
    let (a, b) = (run(), run());
    assert!(a.2 > 0, "the run should adapt");
    assert_eq!(a.2, b.2);
    assert_eq!(a.0.len(), b.0.len());
    for (x, y) in a.0.iter().zip(&b.0).chain(a.1.iter().zip(&b.1)) {
        for d in 0..3 {
            assert_eq!(x[d].to_bits(), y[d].to_bits());
        }
    }
}

/// The hair–hair pair search on one thread or shared with a helper thread gives the same
/// simulation, bit for bit (on a shipped style big enough for the search to be shared).
#[test]
fn one_and_two_collider_threads_are_bit_identical() {
    let (loaded, model) = shipped("long.ron");
    let run = |threads: usize| {
        let mut sim = Simulation::from_style(model.clone(), &loaded.style, motion("lean"), false);
        sim.set_threads(threads);
        assert_eq!(sim.threads(), threads);
        let mut r = StepReport::default();
        let (mut events, mut contacts) = (0, 0);
        for _ in 0..60 {
            sim.step(&mut r);
            events += r.events.len();
            contacts += r.counters.pairs_in_contact;
        }
        (
            sim.slots.pos.clone(),
            sim.slots.vel.clone(),
            events,
            contacts,
        )
    };
    let (a, b) = (run(1), run(2));
    assert!(a.3 > 0, "the run should have hair-hair contacts");
    assert_eq!((a.2, a.3), (b.2, b.3));
    assert_eq!(a.0.len(), b.0.len());
    for (x, y) in a.0.iter().zip(&b.0).chain(a.1.iter().zip(&b.1)) {
        for d in 0..3 {
            assert_eq!(x[d].to_bits(), y[d].to_bits());
        }
    }
}

#[test]
fn wind_pushes_hair_downwind() {
    let calm = rigid_text("split_threshold: 100.0");
    let windy = rigid_text("split_threshold: 100.0, wind: (velocity: (3.0, 0.0, 0.0), gust: 1.0)");
    let mean_x = |text: &str| {
        let mut sim = synthetic_sim(text, 40, "still");
        let mut r = StepReport::default();
        for _ in 0..200 {
            sim.step(&mut r);
        }
        sim.slots.pos.iter().map(|p| p.x).sum::<f64>() / sim.slots.len() as f64
    };
    assert!(mean_x(&windy) > mean_x(&calm) + 0.01);
}

#[test]
fn single_level_mode_keeps_every_finest_node_active() {
    let text = rigid_text("split_threshold: 0.0");
    let (loaded, model) = synthetic_model(&text, 60, 0.4, 1);
    let mut sim = Simulation::from_style(model.clone(), &loaded.style, motion("shake"), true);
    let n = model.nodes_on_level(model.level_count() - 1);
    let mut r = StepReport::default();
    for _ in 0..50 {
        sim.step(&mut r);
        assert!(r.events.is_empty());
        assert_eq!(sim.active_count(), n);
        sim.validate().unwrap();
    }
}
