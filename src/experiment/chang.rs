//! Chang, Jin, Yu 2002 experiments on the guide-strand solver (`--model guides`).
//!
//! `chang-shake` (§7.1): a head shake, then stillness; how far the hairstyle is from its shape
//! one second after the motion stops, with strong static links, without links, and with a
//! violent shake that breaks most links.

use std::path::Path;
use std::sync::Arc;

use nalgebra::Point3;

use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::motion::Motion;
use crate::scene::Scene;
use crate::solver::guides::GuideSolver;
use crate::solver::{Solver, SolverKind};

/// `chang-shake`.
pub static CHANG_SHAKE: ExperimentDef = ExperimentDef {
    name: "chang-shake",
    description: "Chang, Jin, Yu 2002 §7.1: head shaking with strong static links, without links, and violently enough to break them",
    expectation: "shape_error_m: links < no_links; links_broken stays above links (its links are gone)",
    run: run_shake,
};

/// A shake about the neck of `amp` degrees, `half` seconds per swing, for `swings` swings,
/// then still.
fn shake_motion(
    amp: f64,
    half: f64,
    swings: usize,
    anchor: Point3<f64>,
) -> anyhow::Result<(Motion, f64)> {
    let mut keys = String::from("(time: 0.0, translation: (0, 0, 0), rotation: (0, 0, 0)),\n");
    for k in 0..swings {
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        keys += &format!(
            "(time: {}, translation: (0, 0, 0), rotation: (0, {}, 0)),\n",
            half * (k as f64 + 0.5),
            sign * amp
        );
    }
    let stop = half * (swings as f64 + 0.5);
    keys += &format!("(time: {stop}, translation: (0, 0, 0), rotation: (0, 0, 0)),\n");
    let text = format!(
        "KeyframedMotion(name: \"chang_shake\", pivot: (0.0, -0.12, 0.0), looping: false, keys: [\n{keys}])"
    );
    Ok((
        Motion::from_ron(Path::new("chang_shake.ron"), &text, anchor)?,
        stop,
    ))
}

fn run_shake(
    o: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let scene = Scene::load("long", "still", SolverKind::Guides)?;
    let anchor = Point3::from(scene.model.scalp_center);
    let mut runs = Vec::new();
    for (label, links, amp, half) in [
        ("links", true, 30.0, 0.3),
        ("no_links", false, 30.0, 0.3),
        ("links_broken", true, 80.0, 0.15),
    ] {
        let swings = ((6.0 * o.duration_scale).round() as usize).max(2);
        let (motion, stop) = shake_motion(amp, half, swings, anchor)?;
        let mut gp = scene.loaded.style.guides.clone();
        gp.count = 60;
        gp.max_inserted = 0;
        gp.link_strength = 1500.0;
        if !links {
            gp.links_per_segment = 0;
        }
        let mut s = GuideSolver::new(
            Arc::clone(&scene.model),
            motion,
            scene.loaded.style.sim.clone(),
            gp,
        );
        let mut rest = Vec::new();
        s.head_frame_positions(&mut rest);
        let mut report = s.new_report();
        let steps = ((stop + 1.0) / s.dt()).round() as usize;
        let spf = s.steps_per_frame();
        let mut events = Vec::new();
        for k in 0..steps {
            s.step(&mut report);
            events.extend(report.events.iter().cloned());
            if (k + 1) % spf == 0 {
                sink.frame(label, &mut s, &events)?;
                events.clear();
            }
        }
        let mut now = Vec::new();
        s.head_frame_positions(&mut now);
        let err = rest
            .iter()
            .zip(&now)
            .map(|(a, b)| (a - b).norm())
            .sum::<f64>()
            / rest.len() as f64;
        let total = s.links.len();
        let broken = total - s.links.intact();
        let mut metrics = serde_json::Map::new();
        metrics.insert("shape_error_m".into(), err.into());
        metrics.insert(
            "links_broken_fraction".into(),
            (if total == 0 {
                0.0
            } else {
                broken as f64 / total as f64
            })
            .into(),
        );
        runs.push(ExperimentRun {
            label: label.into(),
            metrics,
        });
    }
    Ok(runs)
}
