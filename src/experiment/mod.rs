//! The papers' experiments (`wisptree experiment NAME`): small scenes that each demonstrate one
//! number of one paper, recorded like a run and printed as JSON.
//!
//! An experiment steps its own solvers (it measures things between steps, such as how often
//! two wisps pass through each other) and hands every displayed frame to a [`FrameSink`]: the
//! app's sink logs it to Rerun under `/runs/<label>/…`, a test's sink does nothing. Experiments
//! never name Rerun.

pub mod awt_fig5;
pub mod awt_fig7;
pub mod chang;
pub mod chang_fig6;
pub mod chang_fig7;
pub mod plante;
pub mod zhang_fig12;
pub mod zhang_fig13;
pub mod zhang_fig14;
mod zhang_images;

use crate::frame::StrandBuf;
use crate::render::Image;
use crate::report::Counters;
use crate::solver::{AdaptEvent, Solver};

/// Where an experiment's frames go.
pub trait FrameSink {
    /// One displayed frame of run `label`: the solver after the frame's steps, and the events
    /// of those steps. The sink may call `sync_display`, `draw` and `strand_points`.
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
    ) -> anyhow::Result<()>;

    /// Frame `index` of run `label` of a rendering experiment (no solver): the strands drawn
    /// (the run's 3D view shows them) and the image the renderer made of them (beside it).
    fn rendered(
        &mut self,
        _label: &str,
        _index: u64,
        _strands: &StrandBuf,
        _image: &Image,
    ) -> anyhow::Result<()> {
        Ok(())
    }

    /// [`FrameSink::frame`] with what an experiment may know besides: the counters of the
    /// frame's last step (active nodes per level, plotted per run) and the frame's rendered
    /// image (shown beside the run's 3D view). A sink that has no use for them keeps the
    /// default, which drops them.
    fn frame_with(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
        extras: FrameExtras<'_>,
    ) -> anyhow::Result<()> {
        let _ = extras;
        self.frame(label, solver, events)
    }

    /// Whether the sink shows rendered frames: an experiment that can render its runs renders
    /// every frame only when asked, since rendering costs more than its simulation.
    fn wants_images(&self) -> bool {
        false
    }

    /// A picture the experiment made of itself (a contact sheet, its runs' images side by
    /// side), to be saved as `<stem>.png` (`awt_fig7`, `zhang_fig12`). The default drops it.
    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        let _ = (name, image);
        Ok(())
    }
}

/// What [`FrameSink::frame_with`] carries besides the solver and the events.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrameExtras<'a> {
    /// The counters of the frame's last step (from [`crate::pipeline::step_frame`]).
    pub counters: Option<&'a Counters>,
    /// The frame rendered, if the experiment rendered it.
    pub image: Option<&'a Image>,
    /// The head travels (as under `run`): a view of the run should follow it.
    pub follow_head: bool,
}

/// A sink that drops every frame (tests, `--json` without `--save`).
pub struct NoFrames;

impl FrameSink for NoFrames {
    fn frame(&mut self, _: &str, _: &mut dyn Solver, _: &[AdaptEvent]) -> anyhow::Result<()> {
        Ok(())
    }
}

/// How long to run: the full experiment, or a shortened one for tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExperimentOptions {
    /// Multiplies every run's duration (1 = as designed; tests use less).
    pub duration_scale: f64,
}

impl Default for ExperimentOptions {
    fn default() -> Self {
        ExperimentOptions {
            duration_scale: 1.0,
        }
    }
}

/// One run of an experiment and what it measured.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ExperimentRun {
    /// `none`, `friction`, `collision`, … (`[A-Za-z0-9_.-]` only: it is an entity path part).
    pub label: String,
    /// The numbers it demonstrates, by name (`crossings`, `separation_s`, …); `null` where a
    /// quantity did not happen (never separated).
    #[serde(flatten)]
    pub metrics: serde_json::Map<String, serde_json::Value>,
}

/// What `wisptree experiment NAME --json FILE` writes.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ExperimentReport {
    /// The experiment's name.
    pub experiment: String,
    /// Every run, in order.
    pub runs: Vec<ExperimentRun>,
}

/// One registered experiment.
pub struct ExperimentDef {
    /// The name `wisptree experiment` takes (`plante-fig8`).
    pub name: &'static str,
    /// One line for `--list`: the paper, the figure, what it shows.
    pub description: &'static str,
    /// What the printed numbers should show (printed after them).
    pub expectation: &'static str,
    /// Runs every run of the experiment, sending frames to the sink.
    pub run: fn(&ExperimentOptions, &mut dyn FrameSink) -> anyhow::Result<Vec<ExperimentRun>>,
}

/// Every experiment, in `--list` order.
pub fn all() -> Vec<&'static ExperimentDef> {
    vec![
        &plante::PLANTE_FIG8,
        &plante::PLANTE_FIG9,
        &awt_fig5::AWT_FIG5,
        &awt_fig7::AWT_FIG7,
        &chang::CHANG_SHAKE,
        &chang_fig6::CHANG_FIG6,
        &chang_fig7::CHANG_FIG7,
        &zhang_fig12::ZHANG_FIG12,
        &zhang_fig13::ZHANG_FIG13,
        &zhang_fig14::ZHANG_FIG14,
    ]
}

/// The experiment called `name`.
pub fn find(name: &str) -> Option<&'static ExperimentDef> {
    all().into_iter().find(|e| e.name == name)
}
