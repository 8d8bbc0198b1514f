//! `wisptree bench`: the AWT paper's §5.2 timing table on this machine.
//!
//! Every model runs the `lean` motion twice for the same simulated duration, once in
//! single-level mode (every finest node active, no adaptation) and once as an Adaptive Wisp
//! Tree, with the same dynamics and collision code, on one core; then the AWT again with the
//! hair–hair pair search shared with the collider's helper thread (the same result bit for bit;
//! `wisptree run` does so on machines with 3 or more cores). Only `Simulation::step` is timed (wall
//! clock around each call); loading the style, building the model and the settling that
//! `Simulation::from_style` does before t = 0 are excluded. Then the whole recording pipeline
//! is timed on Long curly: `wisptree run --save` itself, end to end ([`time_run_pipeline`]),
//! and the same work done sequentially, by part ([`time_pipeline`]).
//!
//! Nothing here asserts a time: numbers are printed (and written as JSON) for people to read.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use nalgebra::Point3;

use crate::frame::{Frame, FrameBuilder};
use crate::sim::report::StageTimes;
use crate::sim::{EventKind, Simulation, StepReport};

/// The four §5.2 styles, in the paper's order.
pub const PAPER_MODELS: [&str; 4] = ["short", "short_curly", "long", "long_curly"];

/// The paper's §5.2 numbers (1.7 GHz Pentium): model, finest nodes, levels, single-level s/step,
/// AWT s/step, ratio as printed in the paper.
pub const PAPER_TABLE: [(&str, usize, usize, f64, f64, f64); 4] = [
    ("short", 5149, 2, 3.1, 0.32, 9.7),
    ("short_curly", 4909, 2, 2.7, 0.27, 10.0),
    ("long", 6065, 3, 3.8, 0.09, 42.0),
    ("long_curly", 9853, 3, 7.9, 0.29, 27.0),
];

/// Motion used for every run (the paper's Fig. 6 "lean" sequence).
pub const MOTION: &str = "lean";
/// Integration steps per displayed frame in the pipeline (paper: 4 steps of 10 ms, 25 fps).
pub const STEPS_PER_FRAME: usize = 4;
/// Strands drawn by the timed pipeline: `wisptree run`'s default.
pub const PIPELINE_STRANDS: usize = crate::run::DEFAULT_STRANDS;
/// Catmull-Rom points per span of a drawn strand: `wisptree run`'s.
pub const PIPELINE_SUBDIVISIONS: usize = crate::run::STRAND_SUBDIVISIONS;

/// `wisptree bench` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Short run (0.5 s simulated per model and mode) for smoke tests.
    #[arg(long)]
    pub quick: bool,
    /// Also write the numbers as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Simulated seconds per model and mode (default 10, or 0.5 with --quick).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Comma-separated models: names of `<styles>/<name>.ron`, or paths to `.ron` files.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "short,short_curly,long,long_curly"
    )]
    pub models: Vec<String>,
    /// Directory holding the style files (default `styles`, else the crate's own `styles/`).
    #[arg(long, value_name = "DIR")]
    pub styles: Option<PathBuf>,
    /// Skip the pipeline timings (simulation + strands + logging to a .rrd on Long curly).
    #[arg(long)]
    pub no_pipeline: bool,
    /// Strands drawn in the timed pipelines (default: `wisptree run`'s).
    #[arg(long, value_name = "N", default_value_t = PIPELINE_STRANDS)]
    pub strands: usize,
    /// Keep the recording of the `wisptree run` pipeline at FILE instead of a deleted
    /// temporary file.
    #[arg(long, value_name = "FILE")]
    pub rrd: Option<PathBuf>,
}

/// Mean milliseconds per step spent in each stage of `Simulation::step` (`StageTimes`), and
/// the rest of the step's wall time (`other`: bookkeeping between the stage clocks).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct StageMs {
    pub forces: f64,
    pub interactions: f64,
    pub integrate: f64,
    pub links: f64,
    pub obstacles: f64,
    pub adapt: f64,
    pub follow: f64,
    pub other: f64,
}

impl StageMs {
    /// Per-step means from stage sums over `steps` steps whose wall times summed to `wall`.
    pub fn from_sums(sum: &StageTimes, wall: Duration, steps: usize) -> StageMs {
        let per = |d: Duration| d.as_secs_f64() * 1e3 / steps.max(1) as f64;
        StageMs {
            forces: per(sum.forces),
            interactions: per(sum.interactions),
            integrate: per(sum.integrate),
            links: per(sum.links),
            obstacles: per(sum.obstacles),
            adapt: per(sum.adapt),
            follow: per(sum.follow),
            other: per(wall.saturating_sub(sum.total())),
        }
    }

    /// `(name, ms)` in step order.
    pub fn entries(&self) -> [(&'static str, f64); 8] {
        [
            ("forces", self.forces),
            ("interactions", self.interactions),
            ("integrate", self.integrate),
            ("links", self.links),
            ("obstacles", self.obstacles),
            ("adapt", self.adapt),
            ("follow", self.follow),
            ("other", self.other),
        ]
    }
}

/// What timing one simulation for a number of steps measured.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RunStats {
    pub steps: usize,
    /// Sum of the wall time of the `step` calls, s.
    pub wall_s: f64,
    pub mean_ms_per_step: f64,
    pub max_ms_per_step: f64,
    pub stages_ms: StageMs,
    /// Active nodes after each step (root nodes included).
    pub mean_active_nodes: f64,
    pub max_active_nodes: usize,
    pub splits: u64,
    pub merges: u64,
    pub mean_pairs_tested: f64,
    pub mean_pairs_in_contact: f64,
    pub mean_body_contacts: f64,
}

/// Steps `sim` `steps` times, timing each `step` call alone; `after_step` runs outside the
/// timed region (progress display).
pub fn time_steps(sim: &mut Simulation, steps: usize, mut after_step: impl FnMut()) -> RunStats {
    let mut report = StepReport::default();
    let mut wall = Duration::ZERO;
    let mut max = Duration::ZERO;
    let mut stages = StageTimes::default();
    let (mut active_sum, mut active_max) = (0u64, 0usize);
    let (mut splits, mut merges) = (0u64, 0u64);
    let (mut tested, mut contact, mut body) = (0u64, 0u64, 0u64);
    for _ in 0..steps {
        let t0 = Instant::now();
        sim.step(&mut report);
        let dt = t0.elapsed();
        wall += dt;
        max = max.max(dt);
        stages.add(&report.counters.times);
        let active = sim.active_count();
        active_sum += active as u64;
        active_max = active_max.max(active);
        for e in &report.events {
            match e.kind {
                EventKind::Split => splits += 1,
                EventKind::Merge => merges += 1,
                _ => {}
            }
        }
        tested += u64::from(report.counters.pairs_tested);
        contact += u64::from(report.counters.pairs_in_contact);
        body += u64::from(report.counters.body_contacts);
        after_step();
    }
    let n = steps.max(1) as f64;
    RunStats {
        steps,
        wall_s: wall.as_secs_f64(),
        mean_ms_per_step: wall.as_secs_f64() * 1e3 / n,
        max_ms_per_step: max.as_secs_f64() * 1e3,
        stages_ms: StageMs::from_sums(&stages, wall, steps),
        mean_active_nodes: active_sum as f64 / n,
        max_active_nodes: active_max,
        splits,
        merges,
        mean_pairs_tested: tested as f64 / n,
        mean_pairs_in_contact: contact as f64 / n,
        mean_body_contacts: body as f64 / n,
    }
}

/// One row of the table, as written to JSON.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ModelResult {
    pub model: String,
    pub finest_nodes: usize,
    pub levels: usize,
    pub single_level_ms_per_step: f64,
    pub awt_ms_per_step: f64,
    /// Single-level / AWT.
    pub ratio: f64,
    /// AWT with the hair–hair search shared by two threads (not part of the one-core table).
    pub awt_two_threads_ms_per_step: Option<f64>,
    /// AWT run: active nodes per step (root nodes included).
    pub mean_active_nodes: f64,
    pub max_active_nodes: usize,
    pub splits: u64,
    pub merges: u64,
    pub steps: usize,
    pub dt: f64,
    /// Everything measured, per mode.
    pub single_level: RunStats,
    pub awt: RunStats,
}

/// The sequential pipeline timing on one model, by part.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PipelineResult {
    pub model: String,
    pub sim_seconds: f64,
    pub frames: usize,
    pub strands: usize,
    /// End to end: style loading, model, settling, stepping, frames, logging, final flush, s.
    pub wall_s: f64,
    pub wall_s_per_sim_s: f64,
    /// The parts of `wall_s`, s.
    pub setup_s: f64,
    pub step_s: f64,
    pub frame_build_s: f64,
    pub log_s: f64,
    pub flush_s: f64,
    pub rrd_bytes: u64,
}

/// `wisptree run --save FILE` itself (simulation and logging threads), timed end to end.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunPipelineResult {
    pub model: String,
    pub sim_seconds: f64,
    pub frames: u64,
    pub strands: usize,
    /// From the call to `run::run_with` (style loading and settling included) to its return
    /// with the file flushed, s.
    pub wall_s: f64,
    pub wall_s_per_sim_s: f64,
    pub rrd_bytes: u64,
}

/// Everything `wisptree bench` measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BenchReport {
    pub machine: String,
    /// Threads of the hair–hair search in `wisptree run` (the pipeline timings).
    pub run_threads: usize,
    pub sim_seconds: f64,
    pub motion: String,
    pub models: Vec<ModelResult>,
    /// `wisptree run` on Long curly to a `.rrd`: wall seconds per simulated second.
    pub pipeline_wall_s_per_sim_s: Option<f64>,
    pub pipeline: Option<RunPipelineResult>,
    /// The same work done sequentially in one thread, timed by part.
    pub pipeline_sequential: Option<PipelineResult>,
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// CPU model name and logical core count, from `/proc/cpuinfo` where there is one.
pub fn machine_description() -> String {
    let cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let name = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
        .unwrap_or_else(|| format!("unknown {} CPU", std::env::consts::ARCH));
    let listed = cpuinfo
        .lines()
        .filter(|l| l.starts_with("processor"))
        .count();
    let cores = if listed > 0 { listed.min(cores) } else { cores };
    format!("{name}, {cores} cores")
}

/// Resolves a `--models` entry: a path to a `.ron` file, or a name in the styles directory.
pub fn style_path(styles: &Path, model: &str) -> PathBuf {
    if model.ends_with(".ron") {
        PathBuf::from(model)
    } else {
        styles.join(format!("{model}.ron"))
    }
}

/// The name a model is reported under: the file stem.
fn model_name(model: &str) -> String {
    Path::new(model)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| model.to_string())
}

fn default_styles_dir() -> PathBuf {
    let here = PathBuf::from("styles");
    if here.is_dir() {
        here
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("styles")
    }
}

/// A simulation of `path` under `lean`, settled, ready for step 1, its hair–hair search on
/// `threads` threads.
pub fn simulation(path: &Path, single_level: bool, threads: usize) -> anyhow::Result<Simulation> {
    let (loaded, model) = crate::cli::load_model(path)?;
    let model = Arc::new(model);
    let motion = crate::motion::Motion::parse(MOTION, Point3::from(model.scalp_center))?;
    let mut sim = Simulation::from_style(model, &loaded.style, motion, single_level);
    sim.set_threads(threads);
    Ok(sim)
}

fn steps_for(seconds: f64, dt: f64) -> usize {
    ((seconds / dt).round() as usize).max(1)
}

/// Times one model in both modes.
pub fn bench_model(
    path: &Path,
    name: &str,
    seconds: f64,
    progress: &ProgressBar,
) -> anyhow::Result<ModelResult> {
    let mut results = Vec::with_capacity(3);
    let mut shape = (0, 0, 0.0, 0);
    // The table is on one core: single-level and AWT with the hair–hair search on one thread;
    // then AWT again with the search shared with the helper thread (same result, bit for bit).
    let mut runs = vec![(true, 1), (false, 1)];
    if cores() > 1 {
        runs.push((false, 2));
    }
    for &(single_level, threads) in &runs {
        let mode = match (single_level, threads) {
            (true, _) => "single-level",
            (false, 1) => "AWT",
            _ => "AWT, 2 threads",
        };
        progress.set_message(format!("{name} {mode} (settling)"));
        let mut sim = simulation(path, single_level, threads)
            .with_context(|| format!("setting up model {name}"))?;
        let dt = sim.params.dt;
        let steps = steps_for(seconds, dt);
        let m = &sim.model;
        shape = (
            m.nodes_on_level(m.level_count() - 1),
            m.level_count(),
            dt,
            steps,
        );
        progress.set_message(format!("{name} {mode}"));
        results.push(time_steps(&mut sim, steps, || progress.inc(1)));
    }
    let awt_two_threads = (runs.len() > 2).then(|| results.pop().expect("three runs"));
    let awt = results.pop().expect("two runs");
    let single = results.pop().expect("two runs");
    let (finest_nodes, levels, dt, steps) = shape;
    Ok(ModelResult {
        model: name.to_string(),
        finest_nodes,
        levels,
        single_level_ms_per_step: single.mean_ms_per_step,
        awt_ms_per_step: awt.mean_ms_per_step,
        ratio: single.mean_ms_per_step / awt.mean_ms_per_step,
        awt_two_threads_ms_per_step: awt_two_threads.as_ref().map(|r| r.mean_ms_per_step),
        mean_active_nodes: awt.mean_active_nodes,
        max_active_nodes: awt.max_active_nodes,
        splits: awt.splits,
        merges: awt.merges,
        steps,
        dt,
        single_level: single,
        awt,
    })
}

/// Times the recording pipeline on `path`, sequentially in this thread: load and settle an AWT
/// simulation, then per displayed frame 4 steps, `FrameBuilder::fill` (followers and
/// Catmull-Rom strands) and `Logger::log_frame` into a `.rrd` file, and finally flush the file.
/// `wisptree run` does the same work with the simulation and the logger on two threads, so its
/// wall time can only be lower (at best the larger of the two parts).
pub fn time_pipeline(
    path: &Path,
    seconds: f64,
    strands: usize,
    rrd: &Path,
    progress: &ProgressBar,
) -> anyhow::Result<PipelineResult> {
    let t_start = Instant::now();
    let mut sim = simulation(path, false, 1)?;
    let name = model_name(&path.to_string_lossy());
    let levels = sim.model.level_count() as u16;
    let head = sim.model.scalp_center;
    let rec = rerun::RecordingStreamBuilder::new("wisptree-bench")
        .save(rrd)
        .with_context(|| format!("creating {}", rrd.display()))?;
    let mut logger = crate::stream::Logger::new(
        rec,
        levels,
        &name,
        [head.x as f32, head.y as f32, head.z as f32],
    )?;
    let mut builder = FrameBuilder::new(&sim.model, strands, PIPELINE_SUBDIVISIONS);
    let mut frame = Frame::default();
    let mut report = StepReport::default();
    let setup = t_start.elapsed();

    let steps = steps_for(seconds, sim.params.dt);
    let frames = steps.div_ceil(STEPS_PER_FRAME);
    let (mut step_t, mut build_t, mut log_t) = (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    let mut done = 0;
    progress.set_message(format!("pipeline {name}"));
    for index in 0..frames {
        let t0 = Instant::now();
        frame.events.clear();
        frame.splits = 0;
        frame.merges = 0;
        let (mut tested, mut contact, mut body) = (0, 0, 0);
        let n = STEPS_PER_FRAME.min(steps - done);
        for _ in 0..n {
            sim.step(&mut report);
            frame.events.extend_from_slice(&report.events);
            tested += report.counters.pairs_tested;
            contact += report.counters.pairs_in_contact;
            body += report.counters.body_contacts;
        }
        done += n;
        let t1 = Instant::now();
        step_t += t1 - t0;
        builder.fill(&mut sim, &mut frame);
        frame.index = index as u64;
        frame.counters.clone_from(&report.counters);
        frame.counters.pairs_tested = tested;
        frame.counters.pairs_in_contact = contact;
        frame.counters.body_contacts = body;
        frame.step_ms = (t1 - t0).as_secs_f64() * 1e3 / n as f64;
        for e in &frame.events {
            match e.kind {
                EventKind::Split => frame.splits += 1,
                EventKind::Merge => frame.merges += 1,
                _ => {}
            }
        }
        frame.split_threshold = sim.params.split_threshold;
        frame.merge_velocity = sim.params.merge_velocity;
        let t2 = Instant::now();
        build_t += t2 - t1;
        logger.log_frame(&frame)?;
        log_t += t2.elapsed();
        progress.inc(n as u64);
    }
    let t_flush = Instant::now();
    logger.flush()?;
    drop(logger);
    let flush = t_flush.elapsed();
    let wall = t_start.elapsed();
    let sim_seconds = steps as f64 * sim.params.dt;
    let rrd_bytes = std::fs::metadata(rrd).map(|m| m.len()).unwrap_or(0);
    Ok(PipelineResult {
        model: name,
        sim_seconds,
        frames,
        strands: builder.strand_count(),
        wall_s: wall.as_secs_f64(),
        wall_s_per_sim_s: wall.as_secs_f64() / sim_seconds,
        setup_s: setup.as_secs_f64(),
        step_s: step_t.as_secs_f64(),
        frame_build_s: build_t.as_secs_f64(),
        log_s: log_t.as_secs_f64(),
        flush_s: flush.as_secs_f64(),
        rrd_bytes,
    })
}

/// Times `wisptree run --style PATH --motion lean --seconds S --strands N --no-watch --save RRD`
/// through [`crate::run::run_with`], end to end, as a user would wait for it.
pub fn time_run_pipeline(
    path: &Path,
    seconds: f64,
    strands: usize,
    rrd: &Path,
) -> anyhow::Result<RunPipelineResult> {
    let args = crate::run::RunArgs {
        style: path.to_path_buf(),
        motion: MOTION.to_string(),
        seconds: Some(seconds),
        strands,
        single_level: false,
        watch: false,
        no_watch: true,
        sink: crate::run::SinkArgs {
            save: Some(rrd.to_path_buf()),
            ..Default::default()
        },
    };
    let t0 = Instant::now();
    let summary = crate::run::run_with(args, crate::run::StopSignal::new())?;
    let wall = t0.elapsed().as_secs_f64();
    if summary.interrupted {
        anyhow::bail!("the timed `wisptree run` stopped early");
    }
    Ok(RunPipelineResult {
        model: model_name(&path.to_string_lossy()),
        sim_seconds: summary.sim_time,
        frames: summary.frames_logged,
        strands,
        wall_s: wall,
        wall_s_per_sim_s: wall / summary.sim_time.max(1e-9),
        rrd_bytes: std::fs::metadata(rrd).map(|m| m.len()).unwrap_or(0),
    })
}

/// Prints the §5.2 table, the paper's, and the per-stage breakdowns.
pub fn print_report(r: &BenchReport) {
    println!(
        "wisptree bench: motion `{}`, {} s simulated per model and mode, only `step` timed",
        r.motion, r.sim_seconds
    );
    println!(
        "machine: {}; single-level and AWT on one core; `AWT 2 thr`: the hair-hair search shared \
         with a helper thread (same result; `wisptree run` uses {} thread(s) here)",
        r.machine, r.run_threads
    );
    println!();
    println!(
        "{:<12} {:>6} {:>2} {:>12} {:>10} {:>7} {:>10} {:>8} {:>7} {:>7} {:>7}",
        "model",
        "N",
        "L",
        "single ms",
        "AWT ms",
        "ratio",
        "AWT 2 thr",
        "active",
        "max",
        "splits",
        "merges"
    );
    for m in &r.models {
        let two = m
            .awt_two_threads_ms_per_step
            .map_or_else(|| "-".to_string(), |t| format!("{t:.4}"));
        println!(
            "{:<12} {:>6} {:>2} {:>12.3} {:>10.4} {:>7.1} {:>10} {:>8.1} {:>7} {:>7} {:>7}",
            m.model,
            m.finest_nodes,
            m.levels,
            m.single_level_ms_per_step,
            m.awt_ms_per_step,
            m.ratio,
            two,
            m.mean_active_nodes,
            m.max_active_nodes,
            m.splits,
            m.merges
        );
    }
    println!();
    println!("paper (AWT §5.2, 1.7 GHz Pentium, s per step):");
    println!(
        "{:<12} {:>6} {:>2} {:>12} {:>10} {:>7}",
        "model", "N", "L", "single s", "AWT s", "ratio"
    );
    for (name, n, l, single, awt, ratio) in PAPER_TABLE {
        println!("{name:<12} {n:>6} {l:>2} {single:>12.1} {awt:>10.2} {ratio:>7.1}");
    }
    for (mode, pick) in [
        (
            "AWT",
            (|m: &ModelResult| &m.awt) as fn(&ModelResult) -> &RunStats,
        ),
        ("single-level", |m: &ModelResult| &m.single_level),
    ] {
        println!();
        println!("{mode} mean step by stage, ms (other = wall time outside the stage clocks):");
        print!("{:<12}", "model");
        for (stage, _) in StageMs::default().entries() {
            print!(" {stage:>12}");
        }
        println!(" {:>9} {:>9} {:>9}", "pairs", "contacts", "max ms");
        for m in &r.models {
            let s = pick(m);
            print!("{:<12}", m.model);
            for (_, ms) in s.stages_ms.entries() {
                print!(" {ms:>12.4}");
            }
            println!(
                " {:>9.0} {:>9.0} {:>9.3}",
                s.mean_pairs_tested, s.mean_pairs_in_contact, s.max_ms_per_step
            );
        }
    }
    if let Some(p) = &r.pipeline {
        println!();
        println!(
            "pipeline: `wisptree run --style {}.ron --motion lean --seconds {} --strands {} --save FILE`",
            p.model, r.sim_seconds, p.strands
        );
        println!(
            "  {:.2} s wall for {:.2} s simulated ({} frames, .rrd {:.1} MB) = {:.3} wall s per simulated s",
            p.wall_s,
            p.sim_seconds,
            p.frames,
            p.rrd_bytes as f64 / 1e6,
            p.wall_s_per_sim_s
        );
    }
    if let Some(p) = &r.pipeline_sequential {
        println!();
        println!(
            "the same work sequentially in one thread ({}, {} frames of {} steps, {} strands, .rrd {:.1} MB):",
            p.model,
            p.frames,
            STEPS_PER_FRAME,
            p.strands,
            p.rrd_bytes as f64 / 1e6
        );
        println!(
            "  {:.2} s wall for {:.1} s simulated = {:.3} wall s per simulated s",
            p.wall_s, p.sim_seconds, p.wall_s_per_sim_s
        );
        println!(
            "  load+settle {:.2} s, steps {:.2} s, frames {:.2} s, logging {:.2} s, flush {:.2} s",
            p.setup_s, p.step_s, p.frame_build_s, p.log_s, p.flush_s
        );
    }
}

/// `wisptree bench`.
pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    use crate::cli::BadInput;
    let seconds = match args.seconds {
        Some(s) if !(s.is_finite() && s > 0.0 && s <= 3600.0) => {
            return Err(BadInput(format!(
                "--seconds must be a positive number of seconds up to 3600, got {s}"
            ))
            .into());
        }
        Some(s) => s,
        None if args.quick => 0.5,
        None => 10.0,
    };
    if args.models.is_empty() {
        return Err(BadInput("--models lists no model".into()).into());
    }
    let styles = args.styles.clone().unwrap_or_else(default_styles_dir);
    let paths: Vec<(String, PathBuf)> = args
        .models
        .iter()
        .map(|m| (model_name(m), style_path(&styles, m)))
        .collect();
    for (name, p) in &paths {
        if !p.is_file() {
            return Err(BadInput(format!(
                "--models: no style file for `{name}` at {} (known: {}; or give a path to a .ron)",
                p.display(),
                PAPER_MODELS.join(", ")
            ))
            .into());
        }
    }
    let pipeline_path = style_path(&styles, "long_curly");
    let pipeline = !args.no_pipeline;
    if pipeline && !pipeline_path.is_file() {
        return Err(BadInput(format!(
            "the pipeline timing needs {} (or pass --no-pipeline)",
            pipeline_path.display()
        ))
        .into());
    }

    // Progress in steps, assuming the paper's 10 ms step (only the bar's length depends on it).
    let per_run = steps_for(seconds, 0.01) as u64;
    let runs_per_model = if cores() > 1 { 3 } else { 2 };
    let total =
        per_run * runs_per_model * paths.len() as u64 + if pipeline { 2 * per_run } else { 0 };
    let progress = ProgressBar::new(total);
    progress.set_style(
        ProgressStyle::with_template(
            "{msg:28} [{bar:30}] {pos}/{len} steps {elapsed_precise} (eta {eta})",
        )
        .expect("a valid progress template")
        .progress_chars("=> "),
    );

    let mut models = Vec::with_capacity(paths.len());
    for (name, p) in &paths {
        models.push(bench_model(p, name, seconds, &progress)?);
    }
    let (pipeline, pipeline_sequential) = if pipeline {
        let temp = |what: &str| {
            std::env::temp_dir().join(format!("wisptree-bench-{}-{what}.rrd", std::process::id()))
        };
        let seq_rrd = temp("sequential");
        let seq = time_pipeline(&pipeline_path, seconds, args.strands, &seq_rrd, &progress);
        let _ = std::fs::remove_file(&seq_rrd);
        let (rrd, temporary) = match &args.rrd {
            Some(p) => (p.clone(), false),
            None => (temp("run"), true),
        };
        progress.set_message("pipeline: wisptree run");
        // `run` draws its own progress bar.
        let real =
            progress.suspend(|| time_run_pipeline(&pipeline_path, seconds, args.strands, &rrd));
        progress.inc(per_run);
        if temporary {
            let _ = std::fs::remove_file(&rrd);
        }
        (Some(real?), Some(seq?))
    } else {
        (None, None)
    };
    progress.finish_and_clear();

    let report = BenchReport {
        machine: machine_description(),
        run_threads: crate::sim::default_threads(),
        sim_seconds: seconds,
        motion: MOTION.to_string(),
        models,
        pipeline_wall_s_per_sim_s: pipeline.as_ref().map(|p| p.wall_s_per_sim_s),
        pipeline,
        pipeline_sequential,
    };
    print_report(&report);
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        std::fs::write(path, text + "\n")
            .with_context(|| format!("writing --json {}", path.display()))?;
    }
    Ok(())
}
