//! Probe of a solver (layered by default): `layered_probe STYLE MOTION SECONDS [MODEL]` steps a
//! style under a motion and prints energy and interaction counts once per simulated second,
//! then the wall time per simulated second.
use std::time::Instant;
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let style = args.get(1).map(String::as_str).unwrap_or("long");
    let motion = args.get(2).map(String::as_str).unwrap_or("lean");
    let secs: f64 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(3.0);
    let t0 = Instant::now();
    let kind = match args.get(4) {
        Some(k) => SolverKind::parse(k).map_err(anyhow::Error::msg)?,
        None => SolverKind::Layered,
    };
    let scene = Scene::load(style, motion, kind)?;
    let mut s = scene.solver();
    let build = t0.elapsed();
    let mut r = s.new_report();
    let steps = (secs / s.dt()).round() as usize;
    let per_sec = (1.0 / s.dt()).round() as usize;
    let t1 = Instant::now();
    let (mut pairs, mut inter, mut coll, mut body) = (0u64, 0.0, 0.0, 0.0);
    let mut times = wisptree::report::StageTimes::default();
    for k in 0..steps {
        s.step(&mut r);
        times.add(&r.counters.times);
        pairs += r.counters.pairs_tested as u64;
        for st in &r.stats {
            match st.name {
                "interpenetrating_pairs" => inter += st.value,
                "collisions" => coll += st.value,
                "body_contacts" => body += st.value,
                _ => {}
            }
        }
        if (k + 1) % per_sec == 0 {
            println!(
                "t={:.1} ke={:.3e} valid={:?} pairs_tested={pairs} inter={inter} coll={coll} body={body}",
                s.time(),
                r.counters.kinetic_energy,
                s.validate()
            );
        }
    }
    let wall = t1.elapsed().as_secs_f64();
    println!(
        "{style}/{motion}/{kind}: build+settle {:.2}s, {:.0} ms wall per simulated s, {:.0} pairs tested per simulated s, dt {} spf {}",
        build.as_secs_f64(),
        wall * 1000.0 / secs,
        pairs as f64 / secs,
        s.dt(),
        s.steps_per_frame()
    );
    // Only the AWT times its stages.
    let total = times.total().as_secs_f64();
    if total == 0.0 {
        return Ok(());
    }
    let shares: Vec<String> = wisptree::report::Stage::ALL
        .iter()
        .map(|&st| {
            format!(
                "{} {:.1} %",
                st.name(),
                100.0 * times.get(st).as_secs_f64() / total
            )
        })
        .collect();
    println!(
        "stages ({:.0} ms per simulated s): {}",
        total * 1000.0 / secs,
        shares.join(", ")
    );
    Ok(())
}
