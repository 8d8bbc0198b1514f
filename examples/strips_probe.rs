//! Times the guide strips' search and contacts of one sub-step (Chang, Jin, Yu 2002, §4.2) on a
//! frozen state: `strips_probe STYLE MOTION SECONDS [CALLS]` runs the guides for SECONDS, then
//! calls `Strips::detect_evaluate_on` and `Strips::add_forces` CALLS times on the same
//! positions, on one thread (`THREADS=2`: on a pool of two), and prints the median milliseconds per call, the candidates and the
//! contacts. A fixed state makes before/after comparisons of the search steadier than a whole
//! run's: every call finds the same candidates.
use std::time::Instant;

use wisptree::scene::Scene;
use wisptree::solver::guides::GuideSolver;
use wisptree::solver::Solver;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let style = args.get(1).map(String::as_str).unwrap_or("long_curly");
    let motion = args.get(2).map(String::as_str).unwrap_or("shake");
    let secs: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let calls: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(200);
    let scene = Scene::load(style, motion, wisptree::solver::SolverKind::Guides)?;
    let mut s = GuideSolver::new(
        scene.model.clone(),
        scene.motion.clone(),
        scene.loaded.style.sim.clone(),
        scene.loaded.style.guides.clone(),
    );
    s.set_pool_threads(1);
    let mut r = s.new_report();
    let steps = (secs / s.dt()).round() as usize;
    for _ in 0..steps {
        s.step(&mut r);
    }
    let gp = s.guide_params().clone();
    let alive = s.alive().to_vec();
    let mut chains = s.chains.clone();
    let mut strips = std::mem::take(&mut s.strips);
    let threads: usize = std::env::var("THREADS")
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or(1);
    let pool = (threads > 1).then(|| wisptree::par::Pool::new(threads).expect("a pool"));
    let mut times = Vec::with_capacity(calls);
    let mut contacts = 0;
    for _ in 0..calls {
        let t = Instant::now();
        contacts = strips.detect_evaluate_on(pool.as_ref(), &mut chains, &alive, &gp);
        // As a sub-step does (and as this probe timed before the forces were deferred).
        strips.add_forces(&mut chains);
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{style}/{motion} at {secs} s: {} guides, {:.3} ms per call (median of {calls}; quartiles {:.3}–{:.3}), {} candidates, {contacts} contacts",
        alive.len(),
        times[calls / 2],
        times[calls / 4],
        times[3 * calls / 4],
        strips.candidates(),
    );
    Ok(())
}
