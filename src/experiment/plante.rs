//! The layered wisp paper's two-wisp experiments (Plante, Cani, Poulin 2002, §7.1): Fig. 8, two
//! wisps swinging through each other with and without friction and collision, and Fig. 9, two
//! interpenetrating wisps separating under gravity at two viscosities. The scenes are
//! `scenes/plante_fig8.ron` and `scenes/plante_fig9.ron` (compiled in).

use std::path::Path;
use std::sync::Arc;

use nalgebra::{Point3, Vector3};
use serde_json::{json, Map, Value};

use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::model::HairModel;
use crate::motion::Motion;
use crate::solver::layered::detect::inside_segment;
use crate::solver::layered::wisp::{Wisps, ENV};
use crate::solver::layered::{LayeredParams, LayeredSolver};
use crate::solver::Solver;
use crate::style::LoadedStyle;

const FIG8: &str = include_str!("../../scenes/plante_fig8.ron");
const FIG9: &str = include_str!("../../scenes/plante_fig9.ron");

/// Seconds of the Fig. 8 runs.
const FIG8_SECONDS: f64 = 4.0;
/// Seconds of the Fig. 9 runs.
const FIG9_SECONDS: f64 = 3.0;

/// `plante-fig8`.
pub static PLANTE_FIG8: ExperimentDef = ExperimentDef {
    name: "plante-fig8",
    description: "Plante, Cani, Poulin 2002, Fig. 8: two wisps swinging through each other; \
                  no interaction, friction, collision, both",
    expectation: "with collision, 0 crossings; with friction, a lower relative speed after the \
                  first encounter than with no interaction",
    run: run_fig8,
};

/// `plante-fig9`.
pub static PLANTE_FIG9: ExperimentDef = ExperimentDef {
    name: "plante-fig9",
    description: "Plante, Cani, Poulin 2002, Fig. 9: two interpenetrating wisps separating under \
                  gravity, viscosity 0.5 and 50",
    expectation: "at viscosity 50 they separate much later than at 0.5, or never (null)",
    run: run_fig9,
};

/// A scene file's style and model.
fn load(name: &str, text: &str) -> anyhow::Result<(LoadedStyle, Arc<HairModel>)> {
    let loaded = crate::scene::parse_style(Path::new(name), text)?;
    let model = HairModel::from_style(&loaded)?;
    Ok((loaded, Arc::new(model)))
}

/// A layered solver on the scene with its `layered:` section changed by `tweak`.
fn solver(
    loaded: &LoadedStyle,
    model: &Arc<HairModel>,
    tweak: impl FnOnce(&mut LayeredParams),
) -> anyhow::Result<LayeredSolver> {
    let mut style = loaded.style.clone();
    tweak(&mut style.layered);
    let motion = Motion::parse("still", Point3::from(model.scalp_center))?;
    Ok(LayeredSolver::new(
        model.clone(),
        motion,
        &style.sim,
        &style,
    ))
}

/// Whether any skeleton or envelope point of wisp `a` is inside a segment of wisp `b`.
fn points_inside(w: &Wisps, a: usize, b: usize) -> bool {
    let rb = w.points(b);
    w.points(a).skip(1).any(|q| {
        (0..=ENV).any(|j| {
            let x = if j == ENV { w.pos[q] } else { w.env_pos(q, j) };
            (rb.start..rb.end - 1).any(|p| inside_segment(w, p, &x).is_some())
        })
    })
}

/// The two wisps are in contact (the §4.1 test, either way round).
pub fn in_contact(w: &Wisps) -> bool {
    points_inside(w, 0, 1) || points_inside(w, 1, 0)
}

/// Mass-weighted mean velocity of wisp `a`'s skeleton.
fn mean_velocity(w: &Wisps, a: usize) -> Vector3<f64> {
    let (mut m, mut p) = (0.0, Vector3::zeros());
    for q in w.points(a) {
        m += w.mass[q];
        p += w.vel[q] * w.mass[q];
    }
    p / m
}

/// Closest points of segments `p0 → p1` and `q0 → q1`.
fn closest(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let (c, b) = (d1.dot(&r), d1.dot(&d2));
    let denom = a * e - b * b;
    let mut s = if denom > 1e-15 {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut t = if e > 1e-15 { (b * s + f) / e } else { 0.0 };
    if t < 0.0 {
        t = 0.0;
        s = if a > 1e-15 {
            (-c / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    } else if t > 1.0 {
        t = 1.0;
        s = if a > 1e-15 {
            ((b - c) / a).clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
    (p0 + d1 * s, q0 + d2 * t)
}

/// The closest approach of the two skeletons: its distance and on which side of the other
/// wisp's plane each is (the sign of (p_a − p_b)·(σ_a × σ_b)); the sign flips when one
/// skeleton passes through the other.
pub fn approach(w: &Wisps) -> (f64, f64) {
    let (ra, rb) = (w.points(0), w.points(1));
    let mut best = (f64::INFINITY, 0.0);
    for p in ra.start..ra.end - 1 {
        for q in rb.start..rb.end - 1 {
            let (x, y) = closest(&w.pos[p], &w.pos[p + 1], &w.pos[q], &w.pos[q + 1]);
            let d = (x - y).norm();
            if d < best.0 {
                let n = (w.pos[p + 1] - w.pos[p]).cross(&(w.pos[q + 1] - w.pos[q]));
                best = (d, (x - y).dot(&n).signum());
            }
        }
    }
    best
}

/// Sum of the two wisps' mean rest envelope radii. A sign change of [`approach`] counts as a
/// crossing only when the skeletons are then closer than a quarter of it: a real pass goes
/// through distance 0 (at 1 m/s it moves 1 mm per step), while a switch of the closest segment
/// pair at a distance can flip the sign too.
fn thickness(w: &Wisps) -> f64 {
    let mean = |a: usize| {
        let r = w.points(a);
        let s: f64 = w.rho_rest[r.start * ENV..r.end * ENV].iter().sum();
        s / ((r.end - r.start) * ENV) as f64
    };
    mean(0) + mean(1)
}

fn run_fig8(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let (loaded, model) = load("scenes/plante_fig8.ron", FIG8)?;
    let viscosity = loaded.style.layered.viscosity;
    let runs: [(&str, bool, bool, f64); 4] = [
        ("none", false, false, 0.0),
        ("friction", true, false, viscosity),
        ("collision", true, true, 0.0),
        ("both", true, true, viscosity),
    ];
    let mut out = Vec::new();
    for (label, interactions, collisions, nu) in runs {
        let mut s = solver(&loaded, &model, |l| {
            l.interactions = interactions;
            l.collisions = collisions;
            l.viscosity = nu;
        })?;
        let frames = s_frames(&s, FIG8_SECONDS * opts.duration_scale);
        let thick = thickness(&s.wisps);
        let mut report = s.new_report();
        let (mut crossings, mut side, mut touching) = (0u32, 0.0, false);
        let mut speed_after: Option<f64> = None;
        for _ in 0..frames {
            for _ in 0..s.steps_per_frame() {
                s.step(&mut report);
                let (d, sign) = approach(&s.wisps);
                if side != 0.0 && sign != 0.0 && sign != side && d < 0.25 * thick {
                    crossings += 1;
                }
                if sign != 0.0 {
                    side = sign;
                }
                let now = in_contact(&s.wisps);
                if touching && !now && speed_after.is_none() {
                    let rel = mean_velocity(&s.wisps, 0) - mean_velocity(&s.wisps, 1);
                    speed_after = Some(rel.norm());
                }
                touching = now;
            }
            sink.frame(label, &mut s, &[])?;
        }
        let mut m = Map::new();
        m.insert("crossings".into(), json!(crossings));
        m.insert(
            "speed_after_first_encounter".into(),
            speed_after.map_or(Value::Null, |v| json!(v)),
        );
        out.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
    }
    Ok(out)
}

fn s_frames(s: &LayeredSolver, seconds: f64) -> usize {
    let frame = s.dt() * s.steps_per_frame() as f64;
    ((seconds / frame).round() as usize).max(1)
}

fn run_fig9(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let (loaded, model) = load("scenes/plante_fig9.ron", FIG9)?;
    let mut out = Vec::new();
    for (label, nu) in [("0.5", 0.5), ("50", 50.0)] {
        let mut s = solver(&loaded, &model, |l| l.viscosity = nu)?;
        let frames = s_frames(&s, FIG9_SECONDS * opts.duration_scale);
        let mut report = s.new_report();
        let mut separation: Option<f64> = None;
        let mut contact_frames = 0u32;
        for _ in 0..frames {
            for _ in 0..s.steps_per_frame() {
                s.step(&mut report);
                if separation.is_none() && !in_contact(&s.wisps) {
                    separation = Some(s.time());
                }
            }
            contact_frames += u32::from(in_contact(&s.wisps));
            sink.frame(label, &mut s, &[])?;
        }
        let mut m = Map::new();
        m.insert(
            "separation_s".into(),
            separation.map_or(Value::Null, |v| json!(v)),
        );
        m.insert(
            "contact_fraction".into(),
            json!(contact_frames as f64 / frames as f64),
        );
        out.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
    }
    Ok(out)
}
