//! `wisptree sweep`: several configurations of one style and motion side by side in one
//! recording, each run under `/runs/<label>/…`, on one shared timeline (frame index and
//! simulated time), spread over the cores. Prints a table of what each run did.
//!
//! A run is one solver stepped frame by frame on one worker thread, start to end: its result
//! depends on nothing but its configuration (no state is shared between runs), so a run of a
//! sweep equals the same configuration run alone (`--only K`) bit for bit.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use anyhow::Context as _;

use super::runs_log::{self, RunLog};
use super::stop::StopSignal;
use super::sweep_plan::{self, SweepConfig, SweepSource};
use crate::error::BadInput;
use crate::pipeline;
use crate::scene::Scene;
use crate::solver::tunable::Tuning;
use crate::stream::sink::{Recording, SinkChoice};
use crate::stream::BlueprintCamera;

/// Strands drawn per frame of each run by default: half of `wisptree run`'s, since a sweep
/// records several runs into one file.
pub const DEFAULT_SWEEP_STRANDS: usize = 300;

/// What `wisptree sweep` is asked to do.
#[derive(Debug, Clone)]
pub struct SweepCommand {
    /// The style (built-in name or file).
    pub style: String,
    /// The motion (preset or file).
    pub motion: String,
    /// Simulated seconds of every run.
    pub seconds: f64,
    /// The configurations: lists to combine, or a variants file.
    pub source: SweepSource,
    /// Run only configuration K (from 0, in printed order).
    pub only: Option<usize>,
    /// Print the configurations and stop.
    pub list: bool,
    /// Render every frame of every run at this size (off by default).
    pub render: Option<(u32, u32)>,
    /// Strands drawn per frame of each run.
    pub strands: usize,
    /// Runs at once; `None`: one per core.
    pub jobs: Option<usize>,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Where the recording goes.
    pub sink: SinkChoice,
}

impl SweepCommand {
    /// The text the recording id is made from: everything that decides what the runs log
    /// (style, motion, duration, strands, rendering, every configuration), nothing that decides
    /// which part runs or where it goes (`--only`, `--jobs`, the sink).
    pub fn identity(&self, configs: &[SweepConfig]) -> String {
        let mut s = format!(
            "wisptree sweep v1;style={};motion={};seconds={:?};strands={};render={:?};runs=",
            self.style, self.motion, self.seconds, self.strands, self.render
        );
        for c in configs {
            s.push_str(&format!(
                "[{}:{}:{:?}:{:?}{}]",
                c.label,
                c.model.name(),
                c.split,
                c.merge,
                c.sets
                    .iter()
                    .map(|(n, v)| format!(":{n}={v:?}"))
                    .collect::<String>()
            ));
        }
        s
    }
}

/// What one run did, from its frames' counters and step times.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunStats {
    /// Its position in the sweep (K of `--only K`).
    pub index: usize,
    /// Its label.
    pub label: String,
    /// Frames simulated.
    pub frames: u64,
    /// Sum over frames of the active nodes (all levels).
    pub active_sum: u64,
    /// Most active nodes in one frame.
    pub active_max: u32,
    /// Splits over the run.
    pub splits: u64,
    /// Merges over the run.
    pub merges: u64,
    /// Sum over frames of the wall time per step, ms (timing: not part of the result).
    pub step_ms_sum: f64,
}

impl RunStats {
    /// Mean active nodes per frame.
    pub fn mean_active(&self) -> f64 {
        self.active_sum as f64 / self.frames.max(1) as f64
    }

    /// Mean wall time per step, ms.
    pub fn ms_per_step(&self) -> f64 {
        self.step_ms_sum / self.frames.max(1) as f64
    }

    fn add(&mut self, f: &crate::frame::Frame) {
        let active: u32 = f.counters.active_per_level.iter().sum();
        self.frames += 1;
        self.active_sum += u64::from(active);
        self.active_max = self.active_max.max(active);
        self.splits += u64::from(f.splits);
        self.merges += u64::from(f.merges);
        self.step_ms_sum += f.step_ms;
    }
}

/// What a sweep did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// Every configuration of the sweep, in printed order.
    pub configs: Vec<SweepConfig>,
    /// The runs done (all of them, or `--only K`'s), in printed order.
    pub runs: Vec<RunStats>,
    /// The recording id shared by every part of the sweep.
    pub recording_id: String,
    /// Wall time of all runs, s.
    pub wall_s: f64,
    /// Runs at once.
    pub workers: usize,
}

/// The configurations of `cmd` and the indices to run, checked: bad lists, a bad variants file
/// and `--only` out of range are [`BadInput`].
pub fn plan(cmd: &SweepCommand) -> Result<(Vec<SweepConfig>, Vec<usize>), BadInput> {
    let configs = sweep_plan::configurations(&cmd.source)?;
    let todo = match cmd.only {
        Some(k) if k >= configs.len() => {
            let n = configs.len();
            return Err(BadInput(format!(
                "--only {k}: the sweep has {n} configuration{}, numbered 0 to {}",
                if n == 1 { "" } else { "s" },
                n - 1
            )));
        }
        Some(k) => vec![k],
        None => (0..configs.len()).collect(),
    };
    Ok((configs, todo))
}

/// `wisptree sweep`.
pub fn run(cmd: &SweepCommand) -> anyhow::Result<()> {
    let (configs, todo) = plan(cmd)?;
    if cmd.list {
        for (k, c) in configs.iter().enumerate() {
            println!("{k:>3}  {}", c.label);
        }
        return Ok(());
    }
    let scene = Scene::load(&cmd.style, &cmd.motion, crate::solver::SolverKind::Awt)?;
    let id = sweep_plan::recording_id(&cmd.identity(&configs));
    let mut sink = crate::stream::sweep_sink::open_sink_with_id(&cmd.sink, &id)?;
    let web = sink.web.take();
    eprintln!(
        "wisptree sweep: style {}, motion `{}`, {} s ({} frames), {} of {} configurations → {}",
        scene.style_name(),
        scene.motion.name(),
        cmd.seconds,
        scene.frames_for(cmd.seconds),
        todo.len(),
        configs.len(),
        sink.description
    );
    for &k in &todo {
        eprintln!("{k:>5}  {}", configs[k].label);
    }
    if let Some(w) = &web {
        eprintln!("open the sweep in a browser: {}", w.url());
    }
    let stop = StopSignal::new();
    super::stop_on_ctrl_c(&stop)?;
    let out = sweep_into(cmd, &scene, &sink.rec, &stop)?;
    print!("{}", summary_table(&out));
    eprintln!(
        "{} runs in {:.2} s on {} worker thread{}",
        out.runs.len(),
        out.wall_s,
        out.workers,
        if out.workers == 1 { "" } else { "s" }
    );
    if let Some(path) = &sink.file {
        eprintln!("wrote {} (recording id {id})", path.display());
    }
    if stop.is_stopped() {
        anyhow::bail!("stopped early (Ctrl-C)");
    }
    if let Some(w) = &web {
        // The viewer reads the recording from the gRPC server: keep both up until Ctrl-C.
        eprintln!("serving the sweep at {} until Ctrl-C", w.url());
        while !stop.is_stopped() {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
    }
    Ok(())
}

/// Runs the sweep's runs into `rec` (sent the layout of the whole sweep first, whichever part
/// runs) and flushes it. The scene is `cmd`'s style and motion, loaded by the caller.
pub fn sweep_into(
    cmd: &SweepCommand,
    scene: &Scene,
    rec: &Recording,
    stop: &StopSignal,
) -> anyhow::Result<SweepOutcome> {
    let (configs, todo) = plan(cmd)?;
    let id = sweep_plan::recording_id(&cmd.identity(&configs));
    if let Some((w, h)) = cmd.render {
        // Refuse bad render parameters before any run starts.
        crate::render::Renderer::new(scene.loaded.style.render.clone(), w, h, 1)
            .map_err(|e| BadInput(format!("rendering: {e}")))?;
    }
    let camera = runs_log::scene_camera(scene);
    let views: Vec<_> = configs
        .iter()
        .map(|c| crate::stream::RunView {
            label: c.label.clone(),
            camera,
            render: cmd.render.is_some(),
            stats: true,
            track: None,
        })
        .collect();
    // One blueprint id per sweep: the merged parts hold one layout, not one per part.
    runs_log::send_layout(rec, &views, Some(&format!("{id}-blueprint")))?;

    let frames = scene.frames_for(cmd.seconds);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let workers = cmd.jobs.unwrap_or(cores).clamp(1, todo.len());
    let bar = progress_bar(cmd.progress, frames * todo.len() as u64);
    let job = RunJob {
        scene,
        rec,
        camera,
        frames,
        strands: cmd.strands,
        render: cmd.render,
        // Runs side by side take the cores; a run alone may use the solver's own threads.
        threads: if workers > 1 {
            1
        } else {
            crate::solver::awt::default_threads()
        },
        render_threads: if workers > 1 {
            1
        } else {
            crate::render::default_threads()
        },
        bar: &bar,
        stop,
    };
    let t0 = std::time::Instant::now();
    let results = run_all(&job, &configs, &todo, workers);
    bar.finish_and_clear();
    let wall_s = t0.elapsed().as_secs_f64();
    let runs = results.into_iter().collect::<anyhow::Result<Vec<_>>>()?;
    rec.stream()
        .flush_blocking()
        .map_err(|e| anyhow::anyhow!("flushing the recording: {e}"))?;
    Ok(SweepOutcome {
        configs,
        runs,
        recording_id: id,
        wall_s,
        workers,
    })
}

fn progress_bar(show: bool, total: u64) -> indicatif::ProgressBar {
    if !show {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "{elapsed_precise} [{bar:40}] {pos}/{len} frames of every run ({eta} left)",
    ) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// What every run of a sweep shares.
struct RunJob<'a> {
    scene: &'a Scene,
    rec: &'a Recording,
    camera: BlueprintCamera,
    frames: u64,
    strands: usize,
    render: Option<(u32, u32)>,
    /// Solver threads of each run.
    threads: usize,
    /// Renderer threads of each run.
    render_threads: usize,
    bar: &'a indicatif::ProgressBar,
    stop: &'a StopSignal,
}

/// Runs `todo` on `workers` scoped threads, each taking the next run not yet started; the
/// results in `todo`'s order. After a failed run no new run starts.
fn run_all(
    job: &RunJob,
    configs: &[SweepConfig],
    todo: &[usize],
    workers: usize,
) -> Vec<anyhow::Result<RunStats>> {
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let results: Mutex<Vec<Option<anyhow::Result<RunStats>>>> =
        Mutex::new((0..todo.len()).map(|_| None).collect());
    std::thread::scope(|s| {
        for w in 0..workers {
            let body = || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= todo.len() || failed.load(Ordering::Relaxed) {
                    break;
                }
                let k = todo[i];
                let r = run_one(job, k, &configs[k])
                    .with_context(|| format!("run {k} ({})", configs[k].label));
                if r.is_err() {
                    failed.store(true, Ordering::Relaxed);
                }
                if let Ok(mut all) = results.lock() {
                    all[i] = Some(r);
                }
            };
            let spawned = std::thread::Builder::new()
                .name(format!("wisptree-sweep-{w}"))
                .spawn_scoped(s, body);
            if spawned.is_err() {
                // No more threads: the ones started take every run.
                break;
            }
        }
    });
    let all = results.into_inner().unwrap_or_else(|e| e.into_inner());
    all.into_iter()
        .enumerate()
        .filter_map(|(i, r)| match r {
            Some(r) => Some(r),
            // Not started: an earlier run failed (its error is in the list) or no thread ran.
            None if failed.load(Ordering::Relaxed) => None,
            None => Some(Err(anyhow::anyhow!("run {} was not started", todo[i]))),
        })
        .collect()
}

/// One run, start to end, on the calling thread (Rerun's time cursor is per thread).
fn run_one(job: &RunJob, k: usize, cfg: &SweepConfig) -> anyhow::Result<RunStats> {
    let mut scene = job.scene.with_solver(cfg.model);
    cfg.tuning(&Tuning::of(&scene.loaded.style))
        .write_into(&mut scene.loaded.style);
    let mut solver = scene.solver();
    solver.set_threads(job.threads);
    let mut log = RunLog::new(
        job.rec,
        &cfg.label,
        k,
        &scene.model,
        job.strands,
        job.camera,
    )?;
    let swept_but_ignored: Vec<&str> = cfg
        .swept()
        .into_iter()
        .filter(|name| crate::solver::tunable::find(solver.tunables(), name).is_none())
        .collect();
    if !swept_but_ignored.is_empty() {
        let msg = format!(
            "model `{}` ignores {}: run {} differs from its neighbours in the label only",
            cfg.model,
            swept_but_ignored.join(" and "),
            cfg.label
        );
        eprintln!("wisptree: note: {msg}");
        log.frame.messages.push(msg);
    }
    let mut render = match job.render {
        Some((w, h)) => Some(RunRender::new(&scene, w, h, job.render_threads)?),
        None => None,
    };
    let mut report = solver.new_report();
    let mut stats = RunStats {
        index: k,
        label: cfg.label.clone(),
        ..RunStats::default()
    };
    for _ in 0..job.frames {
        if job.stop.is_stopped() {
            break;
        }
        log.frame.step_ms = pipeline::step_frame(&mut *solver, &mut report, &mut log.frame);
        stats.add(&log.frame);
        if let Some(r) = render.as_mut() {
            r.render(&mut *solver, &mut log.frame);
        }
        log.log(&mut *solver)?;
        log.frame.messages.clear();
        job.bar.inc(1);
    }
    Ok(stats)
}

/// A run's renderer (`--render`): every strand of the model, the scene's camera; one thread
/// when runs go side by side, else every core.
struct RunRender {
    renderer: crate::render::Renderer,
    camera: crate::render::Camera,
    builder: pipeline::FrameBuilder,
    image: crate::render::Image,
}

impl RunRender {
    fn new(scene: &Scene, w: u32, h: u32, threads: usize) -> anyhow::Result<RunRender> {
        Ok(RunRender {
            renderer: crate::render::Renderer::new(
                scene.loaded.style.render.clone(),
                w,
                h,
                threads,
            )
            .map_err(|e| BadInput(format!("rendering: {e}")))?,
            camera: super::render_thread::scene_camera(scene),
            builder: pipeline::FrameBuilder::new(
                &scene.model,
                usize::MAX,
                super::STRAND_SUBDIVISIONS,
            ),
            image: crate::render::Image::default(),
        })
    }

    /// Renders the solver's current hair into `f.image`.
    fn render(&mut self, solver: &mut dyn crate::solver::Solver, f: &mut crate::frame::Frame) {
        solver.sync_display();
        self.builder.fill_strands(&*solver, &mut f.render_strands);
        pipeline::fill_body(solver.model(), solver.pose(), &mut f.body);
        let input = crate::render::RenderInput {
            strands: &f.render_strands,
            body: &f.body,
        };
        self.renderer.render(&input, &self.camera, &mut self.image);
        let mut encoded = f.image.take().unwrap_or_default();
        encoded.jpeg = crate::render::encode_jpeg(&self.image, super::render_thread::JPEG_QUALITY);
        encoded.width = self.image.width;
        encoded.height = self.image.height;
        f.image = Some(encoded);
    }
}

/// The closing table: per run, mean and max active nodes, splits, merges and ms per step.
pub fn summary_table(out: &SweepOutcome) -> String {
    let w = out
        .runs
        .iter()
        .map(|r| r.label.len())
        .max()
        .unwrap_or(0)
        .max("label".len());
    let mut s = format!(
        "{:>3}  {:<w$}  {:>11}  {:>10}  {:>8}  {:>8}  {:>8}\n",
        "K", "label", "mean active", "max active", "splits", "merges", "ms/step"
    );
    for r in &out.runs {
        s.push_str(&format!(
            "{:>3}  {:<w$}  {:>11.1}  {:>10}  {:>8}  {:>8}  {:>8.3}\n",
            r.index,
            r.label,
            r.mean_active(),
            r.active_max,
            r.splits,
            r.merges,
            r.ms_per_step()
        ));
    }
    s
}
