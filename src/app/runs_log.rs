//! Several runs in one recording, each under `/runs/<label>/…` with the usual entity layout:
//! what `wisptree experiment` and `wisptree sweep` share. A [`RunLog`] is one run's logger,
//! frame and frame builder; [`send_layout`] sends the grid of one 3D view per run.

use crate::frame::Frame;
use crate::pipeline::{self, FrameBuilder};
use crate::report::tempo::RealtimeMeter;
use crate::report::{Aggregate, Stat};
use crate::solver::Solver;
use crate::stream::sink::Recording;
use crate::stream::{BlueprintCamera, Logger, LoggerSetup, RunView, RUN_ACTIVE_TOTAL};

/// One run's logger and frame state in a recording of several runs.
pub struct RunLog {
    /// The run's label (`/runs/<label>`).
    pub label: String,
    /// Where the run's 3D view starts.
    pub camera: BlueprintCamera,
    /// Its position in the layout (series colour).
    pub slot: usize,
    rec: Recording,
    logger: Logger,
    builder: FrameBuilder,
    /// How fast this run goes: the time between two of its frames.
    meter: RealtimeMeter,
    /// The frame being built: [`pipeline::step_frame`] writes its counters and events.
    pub frame: Frame,
    index: u64,
}

impl RunLog {
    /// A run `label` of a model with `levels` levels, drawing `strands` strands of `model`.
    pub fn new(
        rec: &Recording,
        label: &str,
        slot: usize,
        model: &crate::model::HairModel,
        strands: usize,
        camera: BlueprintCamera,
    ) -> anyhow::Result<RunLog> {
        let mut setup = LoggerSetup::new(model.level_count() as u16, label, camera.target);
        setup.prefix = format!("/runs/{label}");
        setup.send_blueprint = false;
        Ok(RunLog {
            label: label.to_owned(),
            camera,
            slot,
            rec: rec.clone(),
            logger: Logger::new(rec.clone(), &setup)?,
            builder: FrameBuilder::new(model, strands, super::STRAND_SUBDIVISIONS),
            frame: Frame::default(),
            meter: RealtimeMeter::new(),
            index: 0,
        })
    }

    /// Fills the frame from `solver` (geometry, stats) and logs it as the run's next frame.
    /// Counters, events and step time are whatever the caller put in [`RunLog::frame`].
    pub fn log(&mut self, solver: &mut dyn Solver) -> anyhow::Result<()> {
        let f = &mut self.frame;
        self.builder.fill(solver, f);
        f.index = self.index;
        f.realtime_factor = self
            .meter
            .frame_done(solver.dt() * solver.steps_per_frame() as f64);
        pipeline::fill_stats(f, solver.tunables(), &solver.tuning());
        let total: u32 = f.counters.active_per_level.iter().sum();
        f.stats.push(Stat::new(
            RUN_ACTIVE_TOTAL,
            f64::from(total),
            Aggregate::Last,
        ));
        self.logger.log_frame(f)?;
        if self.index == 0 {
            crate::stream::label_run_series(&self.rec, self.slot, &self.label)?;
        }
        self.index += 1;
        Ok(())
    }

    /// The frames logged so far.
    pub fn frames(&self) -> u64 {
        self.index
    }

    /// The run as its cell of the layout shows it.
    pub fn view(&self, render: bool) -> RunView {
        RunView {
            label: self.label.clone(),
            camera: self.camera,
            render,
            stats: true,
            track: None,
        }
    }

    /// Blocks until everything logged reached the sink.
    pub fn flush(&self) -> anyhow::Result<()> {
        self.logger.flush()
    }
}

/// A camera framing `solver`'s hair as it is now (every strand's points), for scenes built
/// without a [`crate::scene::Scene`] (the experiments): from the renderer's default direction,
/// so a small scene fills its view instead of looking like a head-sized box.
pub fn solver_camera(solver: &mut dyn Solver) -> BlueprintCamera {
    solver.sync_display();
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let mut points = Vec::new();
    for s in 0..solver.model().strands.len() {
        points.clear();
        solver.strand_points(s, &mut points);
        for p in &points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a] as f32);
                hi[a] = hi[a].max(p[a] as f32);
            }
        }
    }
    if !lo[0].is_finite() {
        (lo, hi) = ([-0.5; 3], [0.5; 3]);
    }
    let c = crate::render::Camera::framing(lo, hi, crate::render::camera::DEFAULT_VIEW);
    BlueprintCamera {
        eye: c.eye,
        target: c.target,
    }
}

/// The camera the 3D view of a run of `scene` starts from: the renderer's (see
/// [`super::render_thread::scene_camera`]), as `wisptree run` uses.
pub fn scene_camera(scene: &crate::scene::Scene) -> BlueprintCamera {
    let c = super::render_thread::scene_camera(scene);
    BlueprintCamera {
        eye: c.eye,
        target: c.target,
    }
}

/// Sends the layout of `runs` (a grid of one 3D view per run, the overlaid plots) as the
/// recording's active blueprint; `blueprint_id` as in [`crate::stream::runs_blueprint`].
pub fn send_layout(
    rec: &Recording,
    runs: &[RunView],
    blueprint_id: Option<&str>,
) -> anyhow::Result<()> {
    crate::stream::send_runs_blueprint(rec, runs, blueprint_id)
}
