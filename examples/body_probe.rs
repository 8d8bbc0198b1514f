//! What body collision costs in an AWT step (issue 28 §1): the mean step time and its
//! `obstacles` stage (push out of the body, static friction, rigid lengths restored outside it)
//! for a style, under a motion, after a settling second.
//!
//! `cargo run --release --example body_probe -- STYLE.ron [motion] [seconds]`
//!
//! Run it on a style whose `head.body` is the real head mesh, then on the same style with
//! `body: []`: the difference of the obstacles stage is the mesh's cost.

use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let style = args.first().map(String::as_str).unwrap_or("long");
    let motion = args.get(1).map(String::as_str).unwrap_or("lean");
    let secs: f64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(2.0);
    let scene = Scene::load(style, motion, SolverKind::Awt)?;
    let mut s = scene.solver();
    let steps = (secs / s.dt()).round() as usize;
    // One second first: the hair settles onto the body, where the collisions are.
    let settle = (1.0 / s.dt()).round() as usize;
    let _ = wisptree::bench::time_steps(s.as_mut(), settle, || {});
    let r = wisptree::bench::time_steps(s.as_mut(), steps, || {});
    let o = r.stages_ms.obstacles;
    println!(
        "{style}: {} colliders, {} spheres; {steps} steps: step {:.3} ms, obstacles {:.3} ms \
         ({:.1} % of the step), body contacts {:.0} per step",
        scene.model.colliders.len(),
        scene.model.body.len(),
        r.mean_ms_per_step,
        o,
        100.0 * o / r.mean_ms_per_step,
        r.mean_body_contacts
    );
    Ok(())
}
