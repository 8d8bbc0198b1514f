//! Prints a simulation's counters over time, without any display: a quick look at how a style
//! behaves under a motion.
//!
//! `cargo run --release --example probe -- styles/long.ron lean 5 [split_threshold]`
//! (`WT_EPS=0.01` overrides the contact epsilon, `WT_EVENTS=1` prints the events after 3 s)

use std::sync::Arc;

use nalgebra::Point3;
use wisptree::motion::Motion;
use wisptree::solver::awt::{EventKind, Simulation, StepReport};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let style = args
        .first()
        .map(String::as_str)
        .unwrap_or("styles/long.ron");
    let motion = args.get(1).map(String::as_str).unwrap_or("lean");
    let secs: f64 = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(5.0);
    let (loaded, model) =
        wisptree::scene::load_model(&wisptree::style::builtin::StyleSource::parse(style))?;
    let model = Arc::new(model);
    let motion = Motion::parse(motion, Point3::from(model.scalp_center))?;
    let mut sim = Simulation::from_style(model.clone(), &loaded.style, motion, false);
    if let Some(t) = args.get(3) {
        sim.params.split_threshold = t.parse()?;
    }
    if let Ok(e) = std::env::var("WT_EPS") {
        sim.params.contact_epsilon = e.parse()?;
    }
    let mut r = StepReport::default();
    let (mut splits, mut merges) = (0, 0);
    let mut ms = 0.0;
    let steps = (secs / sim.params.dt).round() as usize;
    for step in 1..=steps {
        sim.step(&mut r);
        ms += r.counters.times.total().as_secs_f64() * 1e3;
        for e in &r.events {
            if std::env::var_os("WT_EVENTS").is_some() && sim.time() > 3.0 {
                println!(
                    "{:?} t {:.2} l{} g{} i{} ar {:.3} rel {:.3}",
                    e.kind, e.time, e.level, e.gc, e.cross_section, e.accel_radius, e.rel_velocity
                );
            }
            match e.kind {
                EventKind::Split => splits += 1,
                EventKind::Merge => merges += 1,
                _ => {}
            }
        }
        if step % 25 == 0 {
            let head = sim
                .pose()
                .transform_point(&Point3::from(model.scalp_center))
                .coords;
            let reach = sim
                .slots
                .pos
                .iter()
                .map(|x| (x - head).norm())
                .fold(0.0, f64::max);
            print!("reach {reach:.3}  ");
            println!(
                "t {:5.2}  active {:?}  splits {splits:5} merges {merges:5}  refused {:?}  ke {:.4} J  pairs {}/{}  body {}  {:.3} ms/step",
                sim.time(),
                r.counters.active_per_level,
                sim.merge_refused(),
                r.counters.kinetic_energy,
                r.counters.pairs_in_contact,
                r.counters.pairs_tested,
                r.counters.body_contacts,
                ms / 25.0
            );
            ms = 0.0;
        }
    }
    Ok(())
}
