//! Chang, Jin, Yu 2002 experiments on the guide-strand solver (`--model guides`).
//!
//! `chang-shake` (§7.1): a head shake, then stillness; how far the hairstyle is from its shape
//! one second after the motion stops, with strong static links, without links, and with a
//! violent shake that breaks most links. The braid (§7.2, Fig. 6) and the brush (§7.4, Fig. 7)
//! are in [`super::chang_fig6`] and [`super::chang_fig7`]; their scenes load through
//! [`load_scene`] and [`scene_solver`] here.

use std::path::Path;
use std::sync::Arc;

use nalgebra::Point3;

use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::model::HairModel;
use crate::motion::Motion;
use crate::scene::Scene;
use crate::solver::guides::{GuideParams, GuideSolver};
use crate::solver::{Solver, SolverKind};
use crate::style::LoadedStyle;

/// `chang-shake`.
pub static CHANG_SHAKE: ExperimentDef = ExperimentDef {
    name: "chang-shake",
    description: "Chang, Jin, Yu 2002 §7.1: head shaking with strong static links, without links, and violently enough to break them",
    expectation: "shape_error_m: links < no_links; links_broken stays above links (its links are gone)",
    run: run_shake,
};

/// A compiled-in scene file (`scenes/….ron`, named `name` in errors): its style and model.
pub(super) fn load_scene(name: &str, text: &str) -> anyhow::Result<(LoadedStyle, Arc<HairModel>)> {
    let loaded = crate::scene::parse_style(Path::new(name), text)?;
    let model = HairModel::from_style(&loaded)?;
    Ok((loaded, Arc::new(model)))
}

/// A guide solver on a head-less scene (the `still` motion: roots never move), with the
/// scene's `guides:` section changed by `tweak`.
pub(super) fn scene_solver(
    loaded: &LoadedStyle,
    model: &Arc<HairModel>,
    tweak: impl FnOnce(&mut GuideParams),
) -> anyhow::Result<GuideSolver> {
    let mut gp = loaded.style.guides.clone();
    tweak(&mut gp);
    let motion = Motion::parse("still", Point3::from(model.scalp_center))?;
    Ok(GuideSolver::new(
        Arc::clone(model),
        motion,
        loaded.style.sim.clone(),
        gp,
    ))
}

/// The top-level wisp (a scene's named set of strands) each guide slot comes from; `u32::MAX`
/// for a slot that holds no strand of the model.
pub(super) fn guide_wisps(s: &GuideSolver) -> Vec<u32> {
    let m = s.model();
    s.origin
        .iter()
        .map(|o| match o {
            crate::solver::guides::Origin::Strand(st) => {
                m.finest().tree[m.strands.finest_gc[*st as usize] as usize]
            }
            _ => u32::MAX,
        })
        .collect()
}

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
