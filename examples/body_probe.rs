//! What body collision costs in an AWT step (issue 28 §1): the mean step time and its
//! `obstacles` stage (push out of the body, static friction, rigid lengths restored outside it)
//! for a style, under a motion, after a settling second; with a mesh body, for both ways a mesh
//! answers queries (the triangle tree, and the signed distance field sampled at load), in turn,
//! in the same run.
//!
//! `cargo run --release --example body_probe -- STYLE.ron [motion] [seconds] [rounds]`
//!
//! Each round runs a fresh solver with each query, alternately (tree, field, tree, field, …),
//! so a machine whose speed drifts affects both alike; the medians over the rounds are printed
//! last. Run it on a style whose `head.body` is the real head mesh, then on the same style with
//! `body: []`: the difference of the obstacles stage is the mesh's cost.

use std::sync::Arc;
use std::time::Instant;

use wisptree::model::body::{Collider, MeshQuery};
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let style = args.first().map(String::as_str).unwrap_or("long");
    let motion = args.get(1).map(String::as_str).unwrap_or("lean");
    let secs: f64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(2.0);
    let rounds: usize = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(1);
    let scene = Scene::load(style, motion, SolverKind::Awt)?;
    let has_mesh = scene
        .model
        .colliders
        .iter()
        .any(|c| matches!(c, Collider::Mesh(_)));
    let queries: &[MeshQuery] = if has_mesh {
        &[MeshQuery::Tree, MeshQuery::Sdf]
    } else {
        &[MeshQuery::Tree]
    };
    // (step ms, obstacles ms, share %) per query, over the rounds.
    let mut stats: Vec<[Vec<f64>; 3]> = vec![Default::default(); queries.len()];
    let mut per_query: Vec<Vec<f64>> = vec![Vec::new(); queries.len()];
    let mut built: Vec<Vec<Collider>> = vec![Vec::new(); queries.len()];
    let mut points = Vec::new();
    for round in 0..rounds {
        for (qi, &q) in queries.iter().enumerate() {
            let t0 = Instant::now();
            let colliders: Vec<Collider> = scene
                .model
                .colliders
                .iter()
                .map(|c| c.with_mesh_query(q))
                .collect();
            let build_ms = t0.elapsed().as_secs_f64() * 1e3;
            let band = colliders.iter().find_map(|c| match c {
                Collider::Mesh(m) => m.sdf_counts(),
                _ => None,
            });
            let mut model = (*scene.model).clone();
            model.colliders = colliders;
            let mut sc = scene.clone();
            sc.model = Arc::new(model);
            let mut s = sc.solver();
            let steps = (secs / s.dt()).round() as usize;
            // One second first: the hair settles onto the body, where the collisions are.
            let settle = (1.0 / s.dt()).round() as usize;
            let _ = wisptree::bench::time_steps(s.as_mut(), settle, || {});
            let r = wisptree::bench::time_steps(s.as_mut(), steps, || {});
            let o = r.stages_ms.obstacles;
            let share = 100.0 * o / r.mean_ms_per_step;
            let field = band.map_or(String::new(), |(all, near)| {
                format!(", field {near} of {all} samples in the band")
            });
            println!(
                "round {round} {q:?}: {style}: {} colliders, {} spheres; built in {build_ms:.0} ms{field}; \
                 {steps} steps: step {:.3} ms, obstacles {o:.3} ms ({share:.1} % of the step), \
                 body contacts {:.0} per step, {:.0} active nodes, {} splits, {} merges",
                sc.model.colliders.len(),
                sc.model.body.len(),
                r.mean_ms_per_step,
                r.mean_body_contacts,
                r.mean_active_nodes,
                r.splits,
                r.merges
            );
            stats[qi][0].push(r.mean_ms_per_step);
            stats[qi][1].push(o);
            stats[qi][2].push(share);
            // The nodes where this run left them, in the body's rest frame: the same points
            // for both queries below.
            s.sync_display();
            let mut f = wisptree::frame::Frame::default();
            s.draw(&mut f);
            let pose = *s.pose();
            points.clear();
            points.extend(f.nodes.positions.iter().map(|p| {
                let w = nalgebra::Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                pose.iso.inverse_transform_point(&w).coords
            }));
            built[qi] = sc.model.colliders.clone();
        }
        if queries.len() == 2 {
            compare(&built, &points, &mut per_query);
        }
    }
    for (q, v) in queries.iter().zip(&mut per_query) {
        if !v.is_empty() {
            println!(
                "median of {rounds} rounds, {q:?}: {:.0} ns per query (the same node positions)",
                median(v)
            );
        }
    }
    for (qi, q) in queries.iter().enumerate() {
        let [a, b, c] = &mut stats[qi];
        println!(
            "median of {rounds} rounds, {q:?}: step {:.3} ms, obstacles {:.3} ms ({:.1} % of the step)",
            median(a),
            median(b),
            median(c)
        );
    }
    Ok(())
}

/// Times "how far inside, and which way out" at `points` with each set of colliders (tree,
/// then field), and says how far their answers differ.
fn compare(built: &[Vec<Collider>], points: &[nalgebra::Vector3<f64>], per_query: &mut [Vec<f64>]) {
    use wisptree::model::body::nearest;
    const REPEAT: usize = 20;
    for (qi, c) in built.iter().enumerate() {
        let t0 = Instant::now();
        let mut inside = 0usize;
        for _ in 0..REPEAT {
            for x in points {
                inside += nearest(c, x, 0.0).is_some_and(|p| p.distance < 0.0) as usize;
            }
        }
        let ns = t0.elapsed().as_secs_f64() * 1e9 / (REPEAT * points.len()).max(1) as f64;
        per_query[qi].push(ns);
        std::hint::black_box(inside);
    }
    // The real head is open at the bottom: there the side of a point is ill-defined (each
    // query tells it by the nearest triangle's pseudo-normal, the field between its samples),
    // so the points within 3 cm above the mesh's lowest vertex are counted apart.
    let bottom = built[0]
        .iter()
        .filter_map(|c| match c {
            Collider::Mesh(m) => m.mesh.vertices.iter().map(|v| v[1]).reduce(f64::min),
            _ => None,
        })
        .reduce(f64::min)
        .unwrap_or(f64::NEG_INFINITY);
    // (points, largest difference of distance, points on different sides): away, near bottom.
    let mut tally = [(0usize, 0.0f64, 0usize); 2];
    for x in points {
        let a = nearest(&built[0], x, 0.005);
        let b = nearest(&built[1], x, 0.005);
        if let (Some(a), Some(b)) = (a, b) {
            let t = &mut tally[(x.y < bottom + 0.03) as usize];
            t.0 += 1;
            t.1 = t.1.max((a.distance - b.distance).abs());
            t.2 += ((a.distance < 0.0) != (b.distance < 0.0)) as usize;
        }
    }
    println!(
        "  same {} points: tree {:.0} ns, field {:.0} ns per query; within 5 mm of the skin: \
         {} points over 3 cm above the open bottom, distances differ by up to {:.3} mm, {} on \
         different sides; {} near the open bottom, up to {:.1} mm, {} on different sides",
        points.len(),
        per_query[0].last().unwrap(),
        per_query[1].last().unwrap(),
        tally[0].0,
        tally[0].1 * 1e3,
        tally[0].2,
        tally[1].0,
        tally[1].1 * 1e3,
        tally[1].2,
    );
}
