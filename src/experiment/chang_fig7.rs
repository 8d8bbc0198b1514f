//! Chang, Jin, Yu 2002, "A practical model for hair mutual interactions", §7.4 and Fig. 7: a
//! brush hit by a moving sphere, with and without hair–hair interaction (static links, §4.1,
//! and the strips' collision, §4.2, whose strips on a brush join horizontal and vertical
//! neighbours). The scene is `scenes/chang_fig7.ron` (compiled in); the sphere is an obstacle
//! on its own path (`guides.obstacles`), the brush's base never moves.
//!
//! Three runs: `interaction` and `no_interaction` on the scene as it is, whose sphere stops the
//! hair that touches it (§3.3's strand–body collision, `body_friction` 1); and
//! `no_interaction_sliding`, the same without interaction but with the guides' default body
//! friction (0.3, the hair slides on the sphere), to show what the draping owes to the stop.
//!
//! Two numbers, both computed from the simulation:
//! * `hairs_behind`: at the end of the run (the sphere has stopped past the brush, so every
//!   root lies behind the plane through its centre across its motion), the hairs whose tip lies
//!   beyond that plane: hairs carried over the sphere and draped down its far side.
//! * `settle_s`: seconds from the sphere's stop until the brush is still for good: the first
//!   time after which the hair's RMS vertex speed, `√(2·KE / mass)`, stays below
//!   [`STILL_SPEED`] to the end of the run; `null` if it is still moving at the end.

use nalgebra::Vector3;
use serde_json::{json, Map, Value};

use super::chang::{load_scene, scene_solver};
use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::solver::guides::GuideSolver;
use crate::solver::Solver;

const SCENE: &str = include_str!("../../scenes/chang_fig7.ron");

/// Seconds each run lasts after the sphere stops.
const AFTER_STOP: f64 = 8.0;

/// RMS vertex speed below which the brush counts as still, m/s.
pub const STILL_SPEED: f64 = 0.02;

/// `chang-fig7`.
pub static CHANG_FIG7: ExperimentDef = ExperimentDef {
    name: "chang-fig7",
    description: "Chang, Jin, Yu 2002, Fig. 7: a brush hit by a moving sphere, with and \
                  without hair-hair interaction (links and strips)",
    expectation: "without interaction a small number of hairs stay draped over the sphere: \
                  hairs_behind (tips beyond the stopped sphere's centre plane across its \
                  motion) at least 1 in no_interaction; with interaction the brush settles \
                  faster: settle_s (from the sphere's stop until the hair's RMS vertex speed \
                  stays below 2 cm/s; null if never) shorter than without; \
                  no_interaction_sliding (the hair slides on the sphere instead of being \
                  stopped by it, Chang §3.3) is reported as measured",
    run: run_fig7,
};

/// The one obstacle's unit direction of motion on its last leg, and its final centre.
fn sphere_end(s: &GuideSolver) -> anyhow::Result<(Vector3<f64>, Vector3<f64>, f64)> {
    let o = s
        .guide_params()
        .obstacles
        .first()
        .ok_or_else(|| anyhow::anyhow!("scenes/chang_fig7.ron: no obstacle"))?;
    let p = &o.path;
    anyhow::ensure!(
        p.len() >= 2,
        "scenes/chang_fig7.ron: the sphere does not move"
    );
    let (a, b) = (
        Vector3::from(p[p.len() - 2].center),
        Vector3::from(p[p.len() - 1].center),
    );
    Ok(((b - a).normalize(), b, o.stop_time()))
}

/// Hairs whose tip is beyond the plane through `center` across `dir`.
fn tips_beyond(s: &GuideSolver, center: &Vector3<f64>, dir: &Vector3<f64>) -> usize {
    let n = s.guide_params().segments;
    s.alive()
        .iter()
        .filter(|&&g| (s.chains.x[g * (n + 1) + n] - center).dot(dir) > 0.0)
        .count()
}

fn run_fig7(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let (loaded, model) = load_scene("scenes/chang_fig7.ron", SCENE)?;
    let mass = loaded.style.sim.total_mass;
    let mut out = Vec::new();
    let sliding = crate::solver::guides::GuideParams::default().body_friction;
    for (label, interaction, slide) in [
        ("interaction", true, false),
        ("no_interaction", false, false),
        ("no_interaction_sliding", false, true),
    ] {
        let mut s = scene_solver(&loaded, &model, |gp| {
            gp.collision = interaction;
            if !interaction {
                gp.links_per_segment = 0;
            }
            if slide {
                gp.body_friction = sliding;
            }
        })?;
        let (dir, center, stop) = sphere_end(&s)?;
        let spf = s.steps_per_frame();
        let seconds = stop + AFTER_STOP * opts.duration_scale;
        let frames = ((seconds / (s.dt() * spf as f64)).round() as usize).max(1);
        let mut report = s.new_report();
        // The last step after the stop at which the brush was still moving.
        let mut moving: Option<f64> = None;
        let mut still_at_end = false;
        for _ in 0..frames {
            for _ in 0..spf {
                s.step(&mut report);
                let rms = (2.0 * report.counters.kinetic_energy / mass).sqrt();
                still_at_end = rms < STILL_SPEED;
                if s.time() > stop && !still_at_end {
                    moving = Some(s.time());
                }
            }
            sink.frame(label, &mut s, &[])?;
        }
        let settle = if still_at_end {
            json!(moving.map_or(0.0, |t| t + s.dt() - stop))
        } else {
            Value::Null
        };
        let mut m = Map::new();
        m.insert("hairs_behind".into(), json!(tips_beyond(&s, &center, &dir)));
        m.insert("settle_s".into(), settle);
        out.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
    }
    Ok(out)
}
