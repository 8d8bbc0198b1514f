//! Timing the whole recording pipeline: `wisptree run --save` itself, and the same work done
//! sequentially, by part.

use std::path::Path;
use std::time::{Duration, Instant};

use indicatif::ProgressBar;

use super::*;

/// Times the recording pipeline on `path`, sequentially in this thread: load and settle an AWT
/// simulation, then per displayed frame 4 steps, `FrameBuilder::fill` (followers and
/// Catmull-Rom strands) and `Logger::log_frame` into a `.rrd` file, and finally flush the file.
/// `wisptree run` does the same work with the simulation and the logger on two threads, so its
/// wall time can only be lower (at best the larger of the two parts).
pub fn time_pipeline(
    style: &StyleSource,
    seconds: f64,
    strands: usize,
    rrd: &Path,
    progress: &ProgressBar,
) -> anyhow::Result<PipelineResult> {
    let t_start = Instant::now();
    let scene = Scene::load_source(style.clone(), MOTION, SolverKind::Awt)?;
    let mut solver = scene.solver();
    solver.set_threads(1);
    let name = style_label(style);
    let rec = crate::stream::sink::open_sink(&SinkChoice::Save(rrd.to_path_buf()))?.rec;
    let setup = LoggerSetup::new(
        scene.model.level_count() as u16,
        &name,
        scene.camera_target(),
    );
    let mut logger = Logger::new(rec, &setup)?;
    let mut builder = FrameBuilder::new(&scene.model, strands, PIPELINE_SUBDIVISIONS);
    let mut frame = Frame::default();
    let mut report = solver.new_report();
    let setup_time = t_start.elapsed();
    let mut meter = crate::report::tempo::RealtimeMeter::new();

    let frames = scene.frames_for(seconds) as usize;
    let (mut step_t, mut build_t, mut log_t) = (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    progress.set_message(format!("pipeline {name}"));
    for index in 0..frames {
        let t0 = Instant::now();
        frame.step_ms = crate::pipeline::step_frame(&mut *solver, &mut report, &mut frame);
        let t1 = Instant::now();
        step_t += t1 - t0;
        builder.fill(&mut *solver, &mut frame);
        frame.index = index as u64;
        frame.realtime_factor = meter.frame_done(solver.dt() * solver.steps_per_frame() as f64);
        crate::pipeline::fill_stats(&mut frame, solver.tunables(), &solver.tuning());
        let t2 = Instant::now();
        build_t += t2 - t1;
        logger.log_frame(&frame)?;
        log_t += t2.elapsed();
        progress.inc(solver.steps_per_frame() as u64);
    }
    let t_flush = Instant::now();
    logger.flush()?;
    drop(logger);
    let flush = t_flush.elapsed();
    let wall = t_start.elapsed();
    let sim_seconds = solver.time();
    let rrd_bytes = std::fs::metadata(rrd).map(|m| m.len()).unwrap_or(0);
    Ok(PipelineResult {
        model: name,
        sim_seconds,
        frames,
        strands: builder.strand_count(),
        wall_s: wall.as_secs_f64(),
        wall_s_per_sim_s: wall.as_secs_f64() / sim_seconds,
        setup_s: setup_time.as_secs_f64(),
        step_s: step_t.as_secs_f64(),
        frame_build_s: build_t.as_secs_f64(),
        log_s: log_t.as_secs_f64(),
        flush_s: flush.as_secs_f64(),
        rrd_bytes,
    })
}

/// Times `wisptree run --style STYLE --motion lean --seconds S --strands N --no-watch --save RRD`
/// through [`crate::app::run_with`], end to end, as a user would wait for it.
pub fn time_run_pipeline(
    style: &StyleSource,
    seconds: f64,
    strands: usize,
    rrd: &Path,
) -> anyhow::Result<RunPipelineResult> {
    let opts = RunOptions {
        style: style_spec(style),
        motion: MOTION.to_string(),
        seconds: Some(seconds),
        strands,
        watch: Some(false),
        sink: SinkChoice::Save(rrd.to_path_buf()),
        // The §5.2 pipeline number is the simulation's; the renderer is timed on its own.
        render: None,
        ..RunOptions::default()
    };
    let t0 = Instant::now();
    let summary = crate::app::run_with(opts, crate::app::StopSignal::new())?;
    let wall = t0.elapsed().as_secs_f64();
    if summary.interrupted {
        anyhow::bail!("the timed `wisptree run` stopped early");
    }
    Ok(RunPipelineResult {
        model: style_label(style),
        sim_seconds: summary.sim_time,
        frames: summary.frames_logged,
        strands,
        wall_s: wall,
        wall_s_per_sim_s: wall / summary.sim_time.max(1e-9),
        rrd_bytes: std::fs::metadata(rrd).map(|m| m.len()).unwrap_or(0),
    })
}
