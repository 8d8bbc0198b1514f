//! `wisptree bench`: the AWT paper's §5.2 timing table on this machine, and any solver against
//! any other.
//!
//! Every style runs the `lean` motion for the same simulated duration under each solver asked
//! for (`--solvers`, default `awt,single-level`: the §5.2 table), with the same dynamics and
//! collision code, on one core; the AWT then runs again with the hair–hair pair search shared
//! with the collider's helper thread (the same result bit for bit; `wisptree run` does so on
//! machines with 2 or more cores). Only `Solver::step` is timed (wall clock around each call);
//! loading the style, building the model and the settling before t = 0 are excluded. Then the
//! whole recording pipeline is timed on Long curly: `wisptree run --save` itself, end to end
//! ([`time_run_pipeline`]), and the same work done sequentially, by part ([`time_pipeline`]).
//!
//! Nothing here asserts a time: numbers are printed (and written as JSON) for people to read.

pub mod live;
mod pipeline;
mod print;
pub mod render;
mod steps;

use std::path::PathBuf;

use indicatif::{ProgressBar, ProgressStyle};

use crate::app::run::{RunOptions, DEFAULT_STRANDS};
use crate::frame::Frame;
use crate::pipeline::FrameBuilder;
use crate::scene::Scene;
use crate::solver::SolverKind;
use crate::stream::sink::SinkChoice;
use crate::stream::{Logger, LoggerSetup};
use crate::style::builtin::StyleSource;

pub use pipeline::{time_pipeline, time_run_pipeline};
pub use print::print_report;
pub use steps::{time_steps, RunStats, StageMs};

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
/// Integration steps per displayed frame in the AWT pipeline (paper: 4 steps of 10 ms, 25 fps).
pub const STEPS_PER_FRAME: usize = 4;
/// Strands drawn by the timed pipeline: `wisptree run`'s default.
pub const PIPELINE_STRANDS: usize = DEFAULT_STRANDS;
/// Catmull-Rom points per span of a drawn strand: `wisptree run`'s.
pub const PIPELINE_SUBDIVISIONS: usize = crate::app::STRAND_SUBDIVISIONS;

/// What `wisptree bench` is asked to do (the CLI's flags, checked).
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Simulated seconds per style and solver.
    pub seconds: f64,
    /// The hairstyles (built-in names or files).
    pub styles: Vec<StyleSource>,
    /// The solvers timed on each style.
    pub solvers: Vec<SolverKind>,
    /// Time the recording pipeline (on Long curly) too.
    pub pipeline: bool,
    /// The style of the pipeline timing.
    pub pipeline_style: StyleSource,
    /// Strands drawn in the pipeline timings.
    pub strands: usize,
    /// Keep the pipeline's recording here.
    pub rrd: Option<PathBuf>,
    /// Also write the numbers as JSON here.
    pub json: Option<PathBuf>,
    /// Time the renderer (and only that, with `render_only`).
    pub render: bool,
    /// Frames per renderer timing.
    pub render_frames: usize,
    /// Run the live matrix (only that): every solver × style × motion, the slider ends, and
    /// rendering on.
    pub live: bool,
    /// Run only the live rows whose label contains one of these texts (all when empty).
    pub live_rows: Vec<String>,
    /// Passes of the live matrix; each row reports its medians over them.
    pub live_runs: usize,
}

/// One row of the §5.2 table (a style under both `single-level` and `awt`), as written to JSON.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[allow(missing_docs)] // the JSON keys, each named for what it holds
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

/// One style under one solver, as written to JSON under `"solvers"`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SolverRow {
    /// The style's name (a built-in name, or the file stem).
    pub style: String,
    /// The solver's name (`awt`, `single-level`, …).
    pub solver: String,
    /// Wall milliseconds of stepping per simulated second.
    pub ms_per_simulated_second: f64,
    /// Segment pairs tested per simulated second.
    pub pairs_tested_per_simulated_second: f64,
    /// Mean wall milliseconds per step, and the step length, s.
    pub ms_per_step: f64,
    /// See `ms_per_step`.
    pub dt: f64,
    /// The solver's own stats, as `<name>_mean` and `<name>_max` (`guides_mean`, …).
    #[serde(flatten)]
    pub stats: std::collections::BTreeMap<String, f64>,
    /// Everything measured.
    #[serde(skip)]
    pub run: RunStats,
}

/// The sequential pipeline timing on one model, by part.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[allow(missing_docs)] // the JSON keys, each named for what it holds
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
#[allow(missing_docs)] // the JSON keys, each named for what it holds
pub struct RunPipelineResult {
    pub model: String,
    pub sim_seconds: f64,
    pub frames: u64,
    pub strands: usize,
    /// From the call to `run_with` (style loading and settling included) to its return with
    /// the file flushed, s.
    pub wall_s: f64,
    pub wall_s_per_sim_s: f64,
    pub rrd_bytes: u64,
}

/// Everything `wisptree bench` measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BenchReport {
    /// CPU and cores.
    pub machine: String,
    /// Threads of the hair–hair search in `wisptree run` (the pipeline timings).
    pub run_threads: usize,
    /// Simulated seconds per style and solver.
    pub sim_seconds: f64,
    /// The motion.
    pub motion: String,
    /// The §5.2 table, one row per style; present when both `awt` and `single-level` ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub models: Option<Vec<ModelResult>>,
    /// Every style under every solver.
    pub solvers: Vec<SolverRow>,
    /// `wisptree run` on Long curly to a `.rrd`: wall seconds per simulated second.
    pub pipeline_wall_s_per_sim_s: Option<f64>,
    /// See `pipeline_wall_s_per_sim_s`.
    pub pipeline: Option<RunPipelineResult>,
    /// The same work done sequentially in one thread, timed by part.
    pub pipeline_sequential: Option<PipelineResult>,
    /// The renderer on three scenes (with `--render`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub render: Vec<render::RenderRow>,
    /// The live matrix (with `--live`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub live: Vec<live::LiveRow>,
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// CPU model name and logical core count, from `/proc/cpuinfo` where there is one.
pub fn machine_description() -> String {
    let cores = cores();
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

/// The name a style is reported under: its built-in name, or the file stem.
pub fn style_label(s: &StyleSource) -> String {
    match s {
        StyleSource::Builtin(n) => (*n).to_owned(),
        StyleSource::File(p) => p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| p.display().to_string()),
    }
}

/// The `--style` argument that names `s`.
fn style_spec(s: &StyleSource) -> String {
    match s {
        StyleSource::Builtin(n) => (*n).to_owned(),
        StyleSource::File(p) => p.display().to_string(),
    }
}

fn steps_for(seconds: f64, dt: f64) -> usize {
    ((seconds / dt).round() as usize).max(1)
}

/// Times `style` under `solver` on `threads` threads of the pair search.
pub fn bench_solver(
    style: &StyleSource,
    solver: SolverKind,
    threads: usize,
    seconds: f64,
    progress: &ProgressBar,
) -> anyhow::Result<(Scene, RunStats)> {
    let name = style_label(style);
    progress.set_message(format!("{name} {solver} (settling)"));
    let scene = Scene::load_source(style.clone(), MOTION, solver)
        .map_err(|e| e.context(format!("setting up style {name}")))?;
    let mut s = scene.solver();
    s.set_threads(threads);
    let steps = steps_for(seconds, s.dt());
    progress.set_message(format!("{name} {solver}"));
    let per_step = (0.01 / s.dt()).round().max(1.0) as u64;
    let mut k = 0u64;
    let stats = time_steps(&mut *s, steps, || {
        // The bar counts 10 ms steps, whatever the solver's step.
        k += 1;
        if k.is_multiple_of(per_step) {
            progress.inc(1)
        }
    });
    Ok((scene, stats))
}

/// The `"solvers"` row of one run.
fn solver_row(style: &str, solver: SolverKind, dt: f64, r: &RunStats) -> SolverRow {
    let sim_s = r.steps as f64 * dt;
    let mut stats = std::collections::BTreeMap::new();
    for (name, (mean, max)) in &r.solver_stats {
        stats.insert(format!("{name}_mean"), *mean);
        stats.insert(format!("{name}_max"), *max);
    }
    SolverRow {
        style: style.to_owned(),
        solver: solver.name().to_owned(),
        ms_per_simulated_second: r.wall_s * 1e3 / sim_s,
        pairs_tested_per_simulated_second: r.mean_pairs_tested * r.steps as f64 / sim_s,
        ms_per_step: r.mean_ms_per_step,
        dt,
        stats,
        run: r.clone(),
    }
}

/// The §5.2 row of a style timed under single-level and AWT (and the AWT on 2 threads).
fn model_row(
    style: &str,
    scene: &Scene,
    single: &SolverRow,
    awt: &SolverRow,
    awt2: Option<&RunStats>,
) -> ModelResult {
    let m = &scene.model;
    ModelResult {
        model: style.to_owned(),
        finest_nodes: m.nodes_on_level(m.level_count() - 1),
        levels: m.level_count(),
        single_level_ms_per_step: single.ms_per_step,
        awt_ms_per_step: awt.ms_per_step,
        ratio: single.ms_per_step / awt.ms_per_step,
        awt_two_threads_ms_per_step: awt2.map(|r| r.mean_ms_per_step),
        mean_active_nodes: awt.run.mean_active_nodes,
        max_active_nodes: awt.run.max_active_nodes,
        splits: awt.run.splits,
        merges: awt.run.merges,
        steps: awt.run.steps,
        dt: awt.dt,
        single_level: single.run.clone(),
        awt: awt.run.clone(),
    }
}

/// Times every style under every solver; the §5.2 rows where both AWT modes ran.
fn bench_styles(
    o: &BenchOptions,
    progress: &ProgressBar,
) -> anyhow::Result<(Option<Vec<ModelResult>>, Vec<SolverRow>)> {
    let table =
        o.solvers.contains(&SolverKind::Awt) && o.solvers.contains(&SolverKind::SingleLevel);
    let mut rows = Vec::new();
    let mut models = Vec::new();
    for style in &o.styles {
        let name = style_label(style);
        let mut scene = None;
        let first = rows.len();
        for &solver in &o.solvers {
            let (sc, r) = bench_solver(style, solver, 1, o.seconds, progress)?;
            let dt = sc.loaded.style.sim.dt;
            let dt = if solver == SolverKind::Awt || solver == SolverKind::SingleLevel {
                dt
            } else {
                sc.solver().dt()
            };
            rows.push(solver_row(&name, solver, dt, &r));
            scene = Some(sc);
        }
        if table {
            let mine = &rows[first..];
            let find = |k: SolverKind| mine.iter().find(|r| r.solver == k.name());
            let (single, awt) = (find(SolverKind::SingleLevel), find(SolverKind::Awt));
            if let (Some(single), Some(awt), Some(scene)) = (single, awt, scene.as_ref()) {
                // The AWT again with the pair search on two threads (same result).
                let awt2 = if cores() > 1 {
                    Some(bench_solver(style, SolverKind::Awt, 2, o.seconds, progress)?.1)
                } else {
                    None
                };
                models.push(model_row(&name, scene, single, awt, awt2.as_ref()));
            }
        }
    }
    Ok((table.then_some(models), rows))
}

/// `wisptree bench`.
pub fn run(o: &BenchOptions) -> anyhow::Result<()> {
    use anyhow::Context as _;
    // Said before the benchmarks rather than after them: a --json or --rrd file that could not
    // be moved aside.
    if let Some(path) = &o.json {
        crate::files::check_move_aside(path).context("--json")?;
    }
    if let Some(path) = &o.rrd {
        crate::files::check_move_aside(path).context("--rrd")?;
    }
    // Progress in 10 ms steps (only the bar's length depends on it).
    let per_run = steps_for(o.seconds, 0.01) as u64;
    let runs = if o.live {
        0
    } else {
        o.styles.len() as u64 * (o.solvers.len() as u64 + u64::from(cores() > 1))
    };
    let total = per_run * runs + if o.pipeline { 2 * per_run } else { 0 };
    let progress = ProgressBar::new(total);
    progress.set_style(
        ProgressStyle::with_template(
            "{msg:28} [{bar:30}] {pos}/{len} steps {elapsed_precise} (eta {eta})",
        )
        .expect("a valid progress template")
        .progress_chars("=> "),
    );
    let (models, solvers) = if o.live {
        // The live matrix runs alone, with its own progress bar.
        progress.finish_and_clear();
        (None, Vec::new())
    } else {
        bench_styles(o, &progress)?
    };
    let (pipeline, pipeline_sequential) = if o.pipeline {
        let temp = |what: &str| {
            std::env::temp_dir().join(format!("wisptree-bench-{}-{what}.rrd", std::process::id()))
        };
        let seq_rrd = temp("sequential");
        let seq = time_pipeline(&o.pipeline_style, o.seconds, o.strands, &seq_rrd, &progress);
        let _ = std::fs::remove_file(&seq_rrd);
        let (rrd, temporary) = match &o.rrd {
            Some(p) => (p.clone(), false),
            None => (temp("run"), true),
        };
        progress.set_message("pipeline: wisptree run");
        // `run` draws its own progress bar.
        let real =
            progress.suspend(|| time_run_pipeline(&o.pipeline_style, o.seconds, o.strands, &rrd));
        progress.inc(per_run);
        if temporary {
            let _ = std::fs::remove_file(&rrd);
        }
        (Some(real?), Some(seq?))
    } else {
        (None, None)
    };
    progress.finish_and_clear();
    let render_rows = if o.render {
        render::bench_render_scenes(o.render_frames)?
    } else {
        Vec::new()
    };
    let live_rows = if o.live {
        live::bench_live(&o.styles, o.seconds, o.strands, &o.live_rows, o.live_runs)?
    } else {
        Vec::new()
    };

    let report = BenchReport {
        machine: machine_description(),
        run_threads: crate::solver::awt::default_threads(),
        sim_seconds: o.seconds,
        motion: MOTION.to_string(),
        models,
        solvers,
        pipeline_wall_s_per_sim_s: pipeline.as_ref().map(|p| p.wall_s_per_sim_s),
        pipeline,
        pipeline_sequential,
        render: render_rows,
        live: live_rows,
    };
    print_report(&report);
    if !report.live.is_empty() {
        live::print_live(&report.live, o.seconds);
    }
    if !report.render.is_empty() {
        render::print_render(&report.render);
    }
    if let Some(path) = &o.json {
        let text = serde_json::to_string_pretty(&report)?;
        if let Some(bak) = crate::files::move_aside(path).context("--json")? {
            eprintln!("kept the earlier {} as {}", path.display(), bak.display());
        }
        std::fs::write(path, text + "\n")
            .with_context(|| format!("writing --json {}", path.display()))?;
    }
    Ok(())
}
