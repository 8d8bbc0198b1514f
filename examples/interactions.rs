//! Times the hair–hair interaction stage alone on warmed-up states of the paper styles: a
//! quieter instrument than whole steps on a shared machine (the best of 10 batches of 5 calls
//! per state, averaged over 6 states along 3 s of `lean`).
//!
//! `cargo run --release --example interactions -- [short long …] [--threads 2] [-v]
//! [--motion shake] [--split 0.05]` (the motion and the split threshold default to `lean` and
//! the style's own).

mod common;

use std::time::Instant;

use wisptree::solver::awt::collide::{ContactParams, HairCollider, PairStats};
use wisptree::solver::awt::StepReport;

fn main() -> anyhow::Result<()> {
    let mut styles = Vec::new();
    let (mut threads, mut verbose) = (1, false);
    let (mut motion_name, mut split) = ("lean".to_owned(), None::<f64>);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--threads" => threads = args.next().unwrap_or_default().parse()?,
            "-v" => verbose = true,
            "--motion" => motion_name = args.next().unwrap_or_default(),
            "--split" => split = Some(args.next().unwrap_or_default().parse()?),
            _ => styles.push(a),
        }
    }
    if styles.is_empty() {
        styles = wisptree::bench::PAPER_MODELS.map(String::from).to_vec();
    }
    for style in styles {
        let (_, mut sim) = common::awt_simulation(&style, &motion_name, split)?;
        let mut report = StepReport::default();
        let mut collider = HairCollider::new();
        collider.set_threads(threads);
        let (mut sum, mut states, mut contacts) = (0.0, 0, 0);
        for _ in 0..6 {
            for _ in 0..50 {
                sim.step(&mut report);
            }
            let p = &sim.params;
            let cp = ContactParams {
                friction: p.friction,
                repulsion: p.repulsion,
                cos_angle_threshold: p.angle_threshold.to_radians().cos(),
                epsilon: p.contact_epsilon,
                dt: p.dt,
            };
            let s = &sim.slots;
            let view = s.segs.view();
            let mut force = s.force.clone();
            let mut best = f64::MAX;
            let mut stats = PairStats::default();
            for _ in 0..10 {
                let t = Instant::now();
                for _ in 0..5 {
                    stats = collider.accumulate(&view, &s.pos, &s.vel, &cp, &mut force);
                }
                best = best.min(t.elapsed().as_secs_f64() * 1e3 / 5.0);
            }
            if verbose {
                println!(
                    "  {style} t {:.1} s: {stats:?} {best:.3} ms, helper found {}",
                    sim.time(),
                    collider.helper_contacts()
                );
            }
            sum += best;
            states += 1;
            contacts += stats.in_contact;
        }
        println!(
            "{style:12} interactions {:.3} ms ({} thread(s), {:.0} contacts)",
            sum / states as f64,
            threads,
            contacts as f64 / states as f64
        );
    }
    Ok(())
}
