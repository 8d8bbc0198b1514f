//! The Adaptive Wisp Tree's Fig. 5 (Bertails, Kim, Cani, Neumann 2003, §3.1): one two-level
//! wisp swung until it splits; the split travels from the tip to the root. The scene is
//! `scenes/awt_fig5.ron` (compiled in); it runs the AWT through [`Scene`].

use std::path::{Path, PathBuf};

use serde_json::{json, Map};

use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameExtras, FrameSink};
use crate::model::HairModel;
use crate::report::{Counters, StageTimes};
use crate::scene::Scene;
use crate::solver::{EventKind, SolverKind};
use crate::style::builtin::StyleSource;

const SCENE: &str = include_str!("../../scenes/awt_fig5.ron");

/// Seconds of the run.
const SECONDS: f64 = 3.0;

/// `awt-fig5`.
pub static AWT_FIG5: ExperimentDef = ExperimentDef {
    name: "awt-fig5",
    description: "Bertails et al. 2003 (AWT), Fig. 5: a two-level wisp swung until it splits; \
                  the split travels from tip to root",
    expectation: "split_cross_sections never increases (tip to root)",
    run: run_fig5,
};

fn run_fig5(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let path = Path::new("scenes/awt_fig5.ron");
    let loaded = crate::scene::parse_style(path, SCENE)?;
    let model = HairModel::from_style(&loaded)?;
    let scene = Scene::from_model(
        StyleSource::File(PathBuf::from(path)),
        loaded,
        model,
        "shake",
        SolverKind::Awt,
    )?;
    let mut s = scene.solver();
    let frames = scene.frames_for(SECONDS * opts.duration_scale);
    let mut report = s.new_report();
    let mut splits: Vec<u16> = Vec::new();
    let mut merged = false;
    let mut events = Vec::new();
    // The frame's counters for the recording's plots: the last step's, with the stage times
    // of all the frame's steps (as `run` reports them).
    let mut counters = Counters::default();
    for _ in 0..frames {
        events.clear();
        let mut times = StageTimes::default();
        for _ in 0..s.steps_per_frame() {
            s.step(&mut report);
            times.add(&report.counters.times);
            for e in &report.events {
                if e.level != 0 {
                    continue;
                }
                // The first splitting process only: after a level-0 merge a later split starts
                // from the tip again.
                match e.kind {
                    EventKind::Split if !merged => splits.push(e.cross_section),
                    EventKind::Merge => merged = true,
                    _ => {}
                }
            }
            events.extend_from_slice(&report.events);
        }
        counters.clone_from(&report.counters);
        counters.times = times;
        let extras = FrameExtras {
            counters: Some(&counters),
            ..FrameExtras::default()
        };
        sink.frame_with("swing", s.as_mut(), &events, extras)?;
    }
    let mut m = Map::new();
    m.insert("split_cross_sections".into(), json!(splits));
    Ok(vec![ExperimentRun {
        label: "swing".into(),
        metrics: m,
    }])
}
