//! `wisptree run`: simulate a style under a motion and stream the AWT paper's Figure 4 display to
//! Rerun, live in a viewer or into a `.rrd` recording.
//!
//! Three threads, each owning its side:
//!
//! ```text
//!  main thread ─ keys, style-file watcher, Ctrl-C, viewer status, progress bar
//!      │ Control (params, rebuild, keys)                       │ warnings
//!      ▼                                                       ▼
//!  simulation thread ── Frame (bounded channel) ──▶ logging thread ──▶ Rerun (viewer / .rrd)
//!      ▲                                                       │
//!      └──────────────── empty Frames (return channel) ◀───────┘
//! ```
//!
//! * Recording (file, stdout): every frame is sent with a blocking send, none is lost, and the
//!   simulation runs as fast as it can.
//! * Live (viewer): the simulation keeps to wall-clock time; when the logger falls behind, whole
//!   frames are dropped (`try_send`) and counted in `Frame::dropped_frames`.
//! * Frames come back through a return channel and are refilled in place, so once the few frames
//!   in flight exist, building and sending a frame allocates nothing new.
//! * Stopping (Ctrl-C, `q`, the end of `--seconds`, a lost viewer) goes through one
//!   [`StopSignal`]: the simulation thread stops and drops its sender, the logger logs what is
//!   queued, flushes and ends. A recording stopped this way is a complete, valid `.rrd`.

use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use crossbeam_channel::{Receiver, Sender, TrySendError};
use nalgebra::Point3;
use rerun::sink::{GrpcSink, GrpcSinkConnectionState, LogSink, SinkFlushError};
use rerun::RecordingStream;

use crate::frame::{Frame, FrameBuilder};
use crate::model::HairModel;
use crate::motion::Motion;
use crate::sim::report::{EventKind, StepReport};
use crate::sim::{Simulation, Tunables};
use crate::stream::{Logger, MessageLevel};
use crate::style::{LoadedStyle, SimParams};
use crate::tune::{self, KeyAction, StyleChange};

/// The style used when `--style` is not given (relative to the current directory).
pub const DEFAULT_STYLE: &str = "styles/long.ron";
/// The motion used when `--motion` is not given.
pub const DEFAULT_MOTION: &str = "lean";
/// Simulated seconds recorded when writing a file and `--seconds` is not given.
pub const DEFAULT_RECORD_SECONDS: f64 = 10.0;
/// The file written when no viewer can be spawned and no sink flag is given.
pub const DEFAULT_RRD: &str = "wisptree.rrd";
/// Strands drawn per frame by default. Measured (see the report of issue 4): a 10 s recording
/// of `styles/long.ron` under `lean` stays well under 100 MB with this many, and so does
/// `long_curly`, the heaviest paper style.
pub const DEFAULT_STRANDS: usize = 600;
/// Catmull-Rom points per span between two cross-sections of a drawn strand.
pub const STRAND_SUBDIVISIONS: usize = 2;
/// Frames queued between the simulation and the logger. Small: live, a long queue is latency.
const QUEUE_FRAMES: usize = 3;
/// How long a viewer may take to accept the connection before the run gives up on it.
const VIEWER_CONNECT_TIMEOUT: Duration = Duration::from_secs(15);
/// How long, after stopping, the logger may take to hand over what is queued before the run
/// returns anyway (a viewer that stopped reading must not hang the process).
const LOGGER_FINISH_TIMEOUT: Duration = Duration::from_secs(20);
/// The same, once the viewer is known to be gone.
const LOST_VIEWER_FINISH_TIMEOUT: Duration = Duration::from_secs(2);
/// Flush timeout for live sinks at the end.
const LIVE_FLUSH_TIMEOUT: Duration = Duration::from_secs(5);
/// Poll period of the main thread (keys, watcher, viewer status).
const POLL: Duration = Duration::from_millis(25);

// ---------------------------------------------------------------------------------------------
// Command line

/// `wisptree run` and plain `wisptree`.
#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    /// The hairstyle file (see `styles/`).
    #[arg(long, value_name = "PATH", default_value = DEFAULT_STYLE)]
    pub style: PathBuf,

    /// Head and body motion: a preset (still, lean, run, jump, shake, stop) or a keyframed
    /// `.ron` motion file (see `motions/`).
    #[arg(long, value_name = "NAME|PATH", default_value = DEFAULT_MOTION)]
    pub motion: String,

    /// Simulated seconds to run. Default: 10 when recording to a file; until Ctrl-C (or `q`)
    /// when streaming live to a viewer.
    #[arg(long, value_name = "S", value_parser = parse_seconds)]
    pub seconds: Option<f64>,

    /// Hair strands drawn per frame (an evenly spread, fixed subset; all of them if the style has
    /// fewer). The default keeps a 10 s recording under 100 MB.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_STRANDS, value_parser = parse_strands)]
    pub strands: usize,

    /// Keep every finest node active and never split or merge (the AWT paper's single-level
    /// comparison).
    #[arg(long)]
    pub single_level: bool,

    /// Watch the style file and apply saved edits while running: new simulation parameters at
    /// once, a new model by restarting. Default: on when live, off when recording.
    #[arg(long, overrides_with = "no_watch")]
    pub watch: bool,

    /// Do not watch the style file.
    #[arg(long, overrides_with = "watch")]
    pub no_watch: bool,

    #[command(flatten)]
    pub sink: SinkArgs,
}

/// Where the recording goes: Rerun's usual sink flags, at most one of them. Without any, a
/// viewer is spawned if `rerun` is on PATH (or one already listens on port 9876), else the run
/// is recorded to `wisptree.rrd`.
///
/// Not `rerun::clap::RerunArgs` itself: its fields are private, so whether the user chose a sink
/// cannot be told from the default, and that choice decides the fallback to a file. Its `--bind`
/// defaults to 0.0.0.0; `--serve` is not offered (this build has no gRPC server), so nothing here
/// listens on the network.
#[derive(Debug, Clone, Default, clap::Args)]
#[group(id = "sink", multiple = false)]
pub struct SinkArgs {
    /// Start a Rerun viewer (`rerun` on PATH) and stream to it live; fail if there is none.
    #[arg(long)]
    pub spawn: bool,

    /// Stream live to a running Rerun viewer; optional URL, default
    /// rerun+http://127.0.0.1:9876/proxy.
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = rerun::DEFAULT_CONNECT_URL)]
    pub connect: Option<String>,

    /// Record to this `.rrd` file (open it with `rerun FILE`).
    #[arg(long, value_name = "PATH")]
    pub save: Option<PathBuf>,

    /// Write the recording to standard output, to pipe into a viewer: `wisptree -o | rerun -`.
    #[arg(long, short = 'o')]
    pub stdout: bool,
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0e6 {
        Ok(v)
    } else {
        Err(format!(
            "{s}: expected a positive number of simulated seconds (at most 1e6)"
        ))
    }
}

fn parse_strands(s: &str) -> Result<usize, String> {
    let v: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number of strands"))?;
    if v == 0 {
        return Err("at least one strand must be drawn".to_owned());
    }
    Ok(v)
}

// ---------------------------------------------------------------------------------------------
// Stopping

/// The one way a run is told to stop. Ctrl-C, the `q` key, a lost viewer and tests all call
/// [`StopSignal::stop`].
#[derive(Debug, Clone, Default)]
pub struct StopSignal(Arc<AtomicBool>);

impl StopSignal {
    pub fn new() -> StopSignal {
        StopSignal::default()
    }
    pub fn stop(&self) {
        self.0.store(true, Ordering::SeqCst);
    }
    pub fn is_stopped(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// The signal Ctrl-C triggers. The handler can be installed once per process, so it stops
/// whichever run registered last.
static CTRL_C_TARGET: OnceLock<Mutex<Option<StopSignal>>> = OnceLock::new();

/// Makes Ctrl-C (SIGINT/SIGTERM) call `stop.stop()` instead of killing the process.
pub fn stop_on_ctrl_c(stop: &StopSignal) -> anyhow::Result<()> {
    let mut first = false;
    let target = CTRL_C_TARGET.get_or_init(|| {
        first = true;
        Mutex::new(None)
    });
    *target.lock().unwrap_or_else(|e| e.into_inner()) = Some(stop.clone());
    if first {
        ctrlc::set_handler(|| {
            if let Some(t) = CTRL_C_TARGET.get() {
                if let Some(s) = t.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                    s.stop();
                }
            }
        })
        .context("installing the Ctrl-C handler")?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Sinks

/// A gRPC sink whose connection state stays observable after the recording stream took it: the
/// stream gets one handle, the run keeps another to notice a viewer that went away.
struct WatchedGrpcSink(Arc<GrpcSink>);

impl LogSink for WatchedGrpcSink {
    fn send(&self, msg: rerun::log::LogMsg) {
        self.0.send(msg);
    }
    fn flush_blocking(&self, timeout: Duration) -> Result<(), SinkFlushError> {
        self.0.flush_blocking(timeout)
    }
    fn default_batcher_config(&self) -> rerun::log::ChunkBatcherConfig {
        self.0.default_batcher_config()
    }
}

/// An opened recording stream and what kind of destination it is.
pub struct OpenSink {
    pub rec: RecordingStream,
    /// A viewer is watching: pace to wall-clock time, drop frames rather than fall behind.
    pub live: bool,
    /// The file recorded to, if any.
    pub file: Option<PathBuf>,
    /// For the terminal: "viewer at …", "file …", "standard output".
    pub description: String,
    /// Connection state of a live viewer.
    grpc: Option<Arc<GrpcSink>>,
    /// No sink was asked for and no viewer could be spawned: the default file was chosen.
    pub fell_back: bool,
}

const APP_ID: &str = "wisptree";

fn connect(url: &str) -> anyhow::Result<(RecordingStream, Arc<GrpcSink>)> {
    let uri: rerun::external::re_uri::ProxyUri = url.parse().map_err(|e| {
        anyhow::anyhow!(
            "--connect {url}: not a Rerun proxy URL ({e}); expected e.g. {}",
            rerun::DEFAULT_CONNECT_URL
        )
    })?;
    let sink = Arc::new(GrpcSink::new(uri));
    let (enabled, store_info, recording_info, batcher_config, hooks, _blueprint) =
        rerun::RecordingStreamBuilder::new(APP_ID).into_args();
    let rec = if enabled {
        RecordingStream::new(
            store_info,
            recording_info,
            batcher_config,
            hooks,
            Box::new(WatchedGrpcSink(sink.clone())),
        )
        .context("creating the recording stream")?
    } else {
        RecordingStream::disabled()
    };
    Ok((rec, sink))
}

fn save(path: &Path) -> anyhow::Result<RecordingStream> {
    rerun::RecordingStreamBuilder::new(APP_ID)
        .save(path)
        .with_context(|| format!("{}: cannot create the recording", path.display()))
}

/// Opens the sink the flags ask for; without a sink flag, a spawned viewer or else the default
/// file [`DEFAULT_RRD`] in the current directory.
pub fn open_sink(args: &SinkArgs) -> anyhow::Result<OpenSink> {
    let live = |rec, grpc, description| OpenSink {
        rec,
        live: true,
        file: None,
        description,
        grpc: Some(grpc),
        fell_back: false,
    };
    if args.stdout {
        let rec = rerun::RecordingStreamBuilder::new(APP_ID)
            .stdout()
            .context("opening standard output for the recording")?;
        return Ok(OpenSink {
            rec,
            live: false,
            file: None,
            description: "standard output".to_owned(),
            grpc: None,
            fell_back: false,
        });
    }
    if let Some(path) = &args.save {
        return Ok(OpenSink {
            rec: save(path)?,
            live: false,
            file: Some(path.clone()),
            description: format!("file {}", path.display()),
            grpc: None,
            fell_back: false,
        });
    }
    if let Some(url) = &args.connect {
        let (rec, grpc) = connect(url)?;
        return Ok(live(rec, grpc, format!("viewer at {url}")));
    }
    match rerun::spawn(&rerun::SpawnOptions::default()) {
        Ok(info) => {
            let url = format!("rerun+http://127.0.0.1:{}/proxy", info.port);
            let (rec, grpc) = connect(&url)?;
            let what = if info.child_pid.is_some() {
                "spawned viewer"
            } else {
                "viewer already running"
            };
            Ok(live(rec, grpc, format!("{what} at {url}")))
        }
        Err(e) if args.spawn => Err(anyhow::anyhow!("--spawn: {e}")),
        Err(e) => {
            let path = PathBuf::from(DEFAULT_RRD);
            let reason = match e {
                rerun::SpawnError::ExecutableNotFoundInPath { .. } => {
                    "no Rerun viewer (`rerun`) on PATH".to_owned()
                }
                other => format!("could not start a Rerun viewer ({other})"),
            };
            Ok(OpenSink {
                rec: save(&path)?,
                live: false,
                file: Some(path.clone()),
                description: format!("file {} ({reason})", path.display()),
                grpc: None,
                fell_back: true,
            })
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The run

/// A loaded style, its model and the motion: everything the simulation is built from.
#[derive(Clone)]
pub struct Setup {
    pub loaded: LoadedStyle,
    pub model: Arc<HairModel>,
    pub motion_spec: String,
    pub motion: Motion,
    pub single_level: bool,
    /// Strands drawn per frame (before capping at the model's count).
    pub strands: usize,
}

impl Setup {
    /// Loads the style (`cli::load_model`) and the motion. The errors keep their
    /// `StyleError`/`MotionError` roots, so the command exits with code 2.
    pub fn load(
        style: &Path,
        motion: &str,
        single_level: bool,
        strands: usize,
    ) -> anyhow::Result<Setup> {
        let (loaded, model) = crate::cli::load_model(style)?;
        let motion_parsed = Motion::parse(motion, Point3::from(model.scalp_center))?;
        Ok(Setup {
            loaded,
            model: Arc::new(model),
            motion_spec: motion.to_owned(),
            motion: motion_parsed,
            single_level,
            strands,
        })
    }

    /// The display name: the style's name, else the file stem.
    pub fn style_name(&self) -> String {
        style_name(&self.loaded)
    }

    /// Frames of `seconds` simulated time (at least one).
    pub fn frames_for(&self, seconds: f64) -> u64 {
        let p = &self.loaded.style.sim;
        let frame_dt = p.dt * p.steps_per_frame.max(1) as f64;
        ((seconds / frame_dt).round() as u64).max(1)
    }

    /// A fresh simulation with the style's parameters (the same construction the run uses).
    pub fn simulation(&self) -> Simulation {
        Simulation::from_style(
            self.model.clone(),
            &self.loaded.style,
            self.motion.clone(),
            self.single_level,
        )
    }
}

fn style_name(l: &LoadedStyle) -> String {
    if l.style.name.is_empty() {
        l.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    } else {
        l.style.name.clone()
    }
}

/// Where the camera looks: the middle of the range the scalp centre sweeps during the first
/// seconds of the motion, so a motion that carries the head away (lean: 35° about the hips, a
/// third of a metre) stays in view instead of leaving the frame on one side.
pub fn camera_target(setup: &Setup) -> [f32; 3] {
    let rest = Point3::from(setup.model.scalp_center);
    let (mut lo, mut hi) = (rest.coords, rest.coords);
    for k in 0..=50 {
        let p = setup.motion.pose(k as f64 * 0.1).transform_point(&rest);
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let c = (lo + hi) * 0.5;
    [c.x as f32, c.y as f32, c.z as f32]
}

/// How the loop runs.
#[derive(Debug, Clone)]
pub struct LoopOptions {
    /// Simulated seconds; `None` runs until stopped.
    pub seconds: Option<f64>,
    /// Keep to wall-clock time and drop frames instead of blocking (a viewer is watching).
    pub live: bool,
    /// Watch the style file.
    pub watch: bool,
    /// Read keys from the terminal (only if stdin is a terminal).
    pub keys: bool,
    /// Show a progress bar (only if stderr is a terminal and the length is known).
    pub progress: bool,
}

/// What a run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunSummary {
    /// Frames handed to Rerun.
    pub frames_logged: u64,
    /// Frames the simulation produced but dropped because the logger fell behind (live only).
    pub frames_dropped: u64,
    /// Simulated time at the last frame, s (continuing across restarts).
    pub sim_time: f64,
    pub splits: u64,
    pub merges: u64,
    /// Stopped before the requested duration (Ctrl-C, `q`, a test's stop, a lost viewer).
    pub interrupted: bool,
    /// The viewer went away (or never answered).
    pub viewer_lost: bool,
    /// Parameter reloads applied and restarts done.
    pub reloads: u32,
    pub restarts: u32,
}

/// `wisptree run`: installs the Ctrl-C handler and runs [`run_with`].
pub fn run(args: RunArgs) -> anyhow::Result<()> {
    let stop = StopSignal::new();
    stop_on_ctrl_c(&stop)?;
    let result = run_with(args, stop);
    tune::restore_terminal();
    result.map(|_| ())
}

/// The whole command with an explicit stop signal (what Ctrl-C triggers in [`run`]).
pub fn run_with(args: RunArgs, stop: StopSignal) -> anyhow::Result<RunSummary> {
    // Load first: a bad style must not leave an empty recording or a spawned viewer behind.
    let setup = Setup::load(&args.style, &args.motion, args.single_level, args.strands)?;
    let sink = open_sink(&args.sink)?;
    let seconds = match (args.seconds, sink.live) {
        (Some(s), _) => Some(s),
        (None, true) => None,
        (None, false) => Some(DEFAULT_RECORD_SECONDS),
    };
    let watch = if args.watch {
        true
    } else if args.no_watch {
        false
    } else {
        sink.live
    };
    let console = Console::default();
    let drawn = setup.strands.min(setup.model.strands.len());
    console.say(&format!(
        "wisptree: style {} ({} levels, {} strands, {} drawn) under motion `{}` → {}",
        setup.style_name(),
        setup.model.level_count(),
        setup.model.strands.len(),
        drawn,
        setup.motion.name(),
        sink.description
    ));
    for n in &setup.model.notes {
        console.say(&format!("wisptree: note: {n}"));
    }
    match seconds {
        _ if sink.fell_back => {}
        Some(s) => console.say(&format!("simulating {s} s")),
        None => console.say("simulating until Ctrl-C (or q)"),
    }
    if sink.fell_back {
        console.say(&format!(
            "recording {} s of simulated time to {} in the current directory",
            seconds.unwrap_or(DEFAULT_RECORD_SECONDS),
            DEFAULT_RRD
        ));
    }
    let opts = LoopOptions {
        seconds,
        live: sink.live,
        watch,
        keys: sink.live,
        progress: sink.file.is_some(),
    };
    let summary = simulate(&setup, sink.rec, sink.grpc, &opts, &stop)?;

    let t = summary.sim_time;
    let mut line = format!(
        "{} frames ({t:.2} s simulated), {} splits, {} merges",
        summary.frames_logged, summary.splits, summary.merges
    );
    if summary.frames_dropped > 0 {
        line.push_str(&format!(
            ", {} frames dropped (the viewer fell behind)",
            summary.frames_dropped
        ));
    }
    if summary.interrupted {
        line.push_str(", stopped early");
    }
    console.say(&line);
    if let Some(path) = &sink.file {
        let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        console.say(&format!(
            "wrote {} ({:.1} MB). Open it with:\n    rerun {}\n(the viewer, if needed: pip install rerun-sdk=={})",
            path.display(),
            size as f64 / 1e6,
            path.display(),
            rerun::build_info().version
        ));
    }
    Ok(summary)
}

/// Prints lines around the progress bar and the raw terminal.
#[derive(Clone, Default)]
struct Console {
    bar: Option<indicatif::ProgressBar>,
}

impl Console {
    fn say(&self, msg: &str) {
        if let Some(b) = &self.bar {
            b.println(msg);
        } else if tune::raw_mode_active() {
            // Raw mode: a newline does not return the carriage.
            eprint!("{}\r\n", msg.replace('\n', "\r\n"));
        } else {
            eprintln!("{msg}");
        }
    }
}

/// What the main thread sends to the simulation thread.
enum Control {
    /// New tunable parameters (from a style reload), with the message describing them.
    Params(Box<SimParams>, String),
    /// A new model (geometry changed): restart on it.
    Rebuild(Box<Setup>, String),
    Key(KeyAction),
}

/// Runs the simulation into `rec` until `opts.seconds` are simulated or `stop` is triggered.
/// `grpc`, if given, is watched: a viewer that goes away stops the run.
pub fn simulate_into(
    setup: &Setup,
    rec: RecordingStream,
    opts: &LoopOptions,
    stop: &StopSignal,
) -> anyhow::Result<RunSummary> {
    simulate(setup, rec, None, opts, stop)
}

fn simulate(
    setup: &Setup,
    rec: RecordingStream,
    grpc: Option<Arc<GrpcSink>>,
    opts: &LoopOptions,
    stop: &StopSignal,
) -> anyhow::Result<RunSummary> {
    let frames_total = opts.seconds.map(|s| setup.frames_for(s));
    let mut console = Console::default();
    if opts.progress && std::io::stderr().is_terminal() {
        if let Some(n) = frames_total {
            let bar = indicatif::ProgressBar::new(n);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40.cyan/blue} {pos}/{len} frames  {elapsed} elapsed, ~{eta} left  {msg}",
                )
                .expect("a valid progress template"),
            );
            console.bar = Some(bar);
        }
    }

    let (frame_tx, frame_rx) = crossbeam_channel::bounded::<Frame>(QUEUE_FRAMES);
    // Unbounded, but it never holds more frames than exist: QUEUE_FRAMES + 2 or so.
    let (free_tx, free_rx) = crossbeam_channel::unbounded::<Frame>();
    let (ctl_tx, ctl_rx) = crossbeam_channel::unbounded::<Control>();
    let (note_tx, note_rx) = crossbeam_channel::unbounded::<(MessageLevel, String)>();
    let (logger_done_tx, logger_done_rx) = crossbeam_channel::bounded::<()>(1);
    let logged = Arc::new(AtomicU64::new(0));

    // Logging thread.
    let logger_handle: JoinHandle<anyhow::Result<()>> = {
        let logged = logged.clone();
        let stop = stop.clone();
        let name = setup.style_name();
        let levels = setup.model.level_count() as u16;
        let head = camera_target(setup);
        let live = opts.live;
        std::thread::Builder::new()
            .name("wisptree-logger".into())
            .spawn(move || {
                let r = logger_loop(
                    rec, levels, &name, head, frame_rx, free_tx, note_rx, &logged, live,
                );
                if r.is_err() {
                    // Nobody is listening any more: stop the simulation too.
                    stop.stop();
                }
                let _ = logger_done_tx.send(());
                r
            })
            .context("starting the logging thread")?
    };

    // Simulation thread.
    let sim_handle: JoinHandle<SimOutcome> = {
        let setup = setup.clone();
        let stop = stop.clone();
        let live = opts.live;
        let console = console.clone();
        std::thread::Builder::new()
            .name("wisptree-sim".into())
            .spawn(move || {
                sim_loop(
                    setup,
                    frames_total,
                    live,
                    ctl_rx,
                    frame_tx,
                    free_rx,
                    &stop,
                    &console,
                )
            })
            .context("starting the simulation thread")?
    };

    // Main thread: keys, watcher, viewer, progress.
    let raw = if opts.keys {
        tune::RawTerminal::enter()
    } else {
        None
    };
    if raw.is_some() {
        console.say(tune::KEY_HELP);
    }
    let mut watcher = if opts.watch {
        match tune::StyleWatcher::new(&setup.loaded.path) {
            Ok(w) => {
                console.say(&format!(
                    "watching {} for changes",
                    setup.loaded.path.display()
                ));
                Some(w)
            }
            Err(e) => {
                console.say(&format!("not watching the style file: {e:#}"));
                None
            }
        }
    } else {
        None
    };
    let mut file_style = setup.loaded.clone();
    let mut summary = RunSummary::default();
    let mut key_error_reported = false;
    let mut never_connected: Option<String> = None;
    while !stop.is_stopped() && !sim_handle.is_finished() {
        if raw.is_some() {
            match poll_key(POLL) {
                Ok(Some(KeyAction::Quit)) => {
                    console.say("quitting");
                    stop.stop();
                }
                Ok(Some(KeyAction::Help)) => console.say(tune::KEY_HELP),
                Ok(Some(a)) => {
                    let _ = ctl_tx.send(Control::Key(a));
                }
                Ok(None) => {}
                Err(e) => {
                    if !key_error_reported {
                        console.say(&format!("reading keys failed: {e}"));
                        key_error_reported = true;
                    }
                    std::thread::sleep(POLL);
                }
            }
        } else {
            std::thread::sleep(POLL);
        }
        if let Some(w) = watcher.as_mut() {
            if w.poll() {
                handle_reload(
                    setup,
                    &mut file_style,
                    &ctl_tx,
                    &note_tx,
                    &console,
                    &mut summary,
                );
            }
        }
        if let Some(g) = &grpc {
            let lost = match g.status() {
                GrpcSinkConnectionState::Disconnected(r) => Some(match r {
                    Ok(()) => "the viewer closed the connection".to_owned(),
                    Err(e) => format!("the viewer went away (connection lost: {e:?})"),
                }),
                GrpcSinkConnectionState::Connecting { started }
                    if started.elapsed() > VIEWER_CONNECT_TIMEOUT =>
                {
                    let msg = format!(
                        "no Rerun viewer accepted the connection within {} s \
                         (start one with `rerun`, or record with --save FILE)",
                        VIEWER_CONNECT_TIMEOUT.as_secs()
                    );
                    never_connected = Some(msg.clone());
                    Some(msg)
                }
                _ => None,
            };
            if let Some(why) = lost {
                if never_connected.is_none() {
                    // (Never connecting is returned as the run's error, printed once by main.)
                    console.say(&format!("wisptree: {why}; stopping"));
                }
                summary.viewer_lost = true;
                stop.stop();
            }
        }
        if let Some(b) = &console.bar {
            b.set_position(logged.load(Ordering::Relaxed));
        }
    }
    drop(raw);
    let asked_to_stop = stop.is_stopped();
    stop.stop();
    drop(ctl_tx);
    drop(note_tx);

    let sim = sim_handle
        .join()
        .map_err(|_| anyhow::anyhow!("the simulation thread panicked"))?;
    // The logger drains the queue and flushes; a viewer that stopped reading could keep it
    // waiting, so do not wait forever.
    // With the viewer gone there is nothing left to hand over: do not wait long.
    let finish_timeout = if summary.viewer_lost {
        LOST_VIEWER_FINISH_TIMEOUT
    } else {
        LOGGER_FINISH_TIMEOUT
    };
    let logger_result = match logger_done_rx.recv_timeout(finish_timeout) {
        Ok(()) => logger_handle
            .join()
            .map_err(|_| anyhow::anyhow!("the logging thread panicked"))?,
        Err(_) => Err(anyhow::anyhow!(
            "the logging thread did not finish within {} s; the recording may be incomplete",
            finish_timeout.as_secs()
        )),
    };
    if let Some(b) = &console.bar {
        b.set_position(logged.load(Ordering::Relaxed));
        b.finish_and_clear();
    }
    summary.frames_logged = logged.load(Ordering::Relaxed);
    summary.frames_dropped = sim.dropped;
    summary.sim_time = sim.sim_time;
    summary.splits = sim.splits;
    summary.merges = sim.merges;
    summary.restarts += sim.restarts;
    summary.interrupted = asked_to_stop && frames_total.is_none_or(|n| sim.frames < n);
    if let Some(msg) = never_connected {
        // Nothing was shown anywhere: an error, not a normal end.
        anyhow::bail!(msg);
    }
    if let Err(e) = logger_result {
        if !summary.viewer_lost {
            // (With the viewer gone, a failed final flush is expected and already explained.)
            return Err(e);
        }
    }
    Ok(summary)
}

fn poll_key(timeout: Duration) -> std::io::Result<Option<KeyAction>> {
    use crossterm::event::{poll, read, Event};
    if !poll(timeout)? {
        return Ok(None);
    }
    Ok(match read()? {
        Event::Key(k) => tune::key_action(&k),
        _ => None,
    })
}

/// Reads the watched style again and tells the simulation thread what to do.
fn handle_reload(
    setup: &Setup,
    file_style: &mut LoadedStyle,
    ctl: &Sender<Control>,
    notes: &Sender<(MessageLevel, String)>,
    console: &Console,
    summary: &mut RunSummary,
) {
    let path = file_style.path.clone();
    match tune::reload(&path, &file_style.style) {
        StyleChange::Unchanged => {}
        StyleChange::Params(new) => {
            let msg = format!(
                "{}: applied {}",
                path.display(),
                tune::describe_param_changes(&file_style.style.sim, &new.style.sim)
            );
            let _ = ctl.send(Control::Params(Box::new(new.style.sim.clone()), msg));
            *file_style = *new;
            summary.reloads += 1;
        }
        StyleChange::Geometry(b) => {
            let (loaded, model) = *b;
            match Motion::parse(&setup.motion_spec, Point3::from(model.scalp_center)) {
                Ok(motion) => {
                    let msg = format!(
                        "{}: the model changed (head, hair, hierarchy, link, seed or total mass); restarting the simulation",
                        path.display()
                    );
                    let new_setup = Setup {
                        loaded: loaded.clone(),
                        model: Arc::new(model),
                        motion_spec: setup.motion_spec.clone(),
                        motion,
                        single_level: setup.single_level,
                        strands: setup.strands,
                    };
                    let _ = ctl.send(Control::Rebuild(Box::new(new_setup), msg));
                    *file_style = loaded;
                }
                Err(e) => {
                    let msg = format!("{}: not applied, the motion failed: {e}", path.display());
                    console.say(&format!("warning: {msg}"));
                    let _ = notes.send((MessageLevel::Warn, msg));
                }
            }
        }
        StyleChange::Invalid(e) => {
            let msg = format!("style edit not applied, keeping the current parameters: {e}");
            console.say(&format!("warning: {msg}"));
            let _ = notes.send((MessageLevel::Warn, msg));
        }
    }
}

/// What the simulation thread did.
#[derive(Debug, Default)]
struct SimOutcome {
    frames: u64,
    dropped: u64,
    sim_time: f64,
    splits: u64,
    merges: u64,
    restarts: u32,
}

/// Steps one frame: `steps_per_frame` steps, with the frame's events in order and its counters
/// (those of the last step, except contact counts and stage times, summed). Returns the wall
/// time per step in ms.
pub fn step_frame(sim: &mut Simulation, report: &mut StepReport, frame: &mut Frame) -> f64 {
    let spf = sim.params.steps_per_frame.max(1);
    let t0 = Instant::now();
    frame.events.clear();
    let (mut tested, mut contact, mut body) = (0u32, 0u32, 0u32);
    let mut times = crate::sim::report::StageTimes::default();
    for _ in 0..spf {
        sim.step(report);
        frame.events.append(&mut report.events);
        tested += report.counters.pairs_tested;
        contact += report.counters.pairs_in_contact;
        body += report.counters.body_contacts;
        times.add(&report.counters.times);
    }
    // Reuse the frame's per-level vector rather than cloning one.
    let c = &report.counters;
    let f = &mut frame.counters;
    f.active_per_level.clear();
    f.active_per_level.extend_from_slice(&c.active_per_level);
    f.segments = c.segments;
    f.kinetic_energy = c.kinetic_energy;
    f.pairs_tested = tested;
    f.pairs_in_contact = contact;
    f.body_contacts = body;
    f.times = times;
    frame.splits = frame
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Split)
        .count() as u32;
    frame.merges = frame.events.len() as u32 - frame.splits;
    t0.elapsed().as_secs_f64() * 1e3 / spf as f64
}

/// Fills frame `index` after its steps: geometry, parameters, timing.
fn finish_frame(
    sim: &mut Simulation,
    builder: &mut FrameBuilder,
    frame: &mut Frame,
    index: u64,
    time_offset: f64,
) {
    builder.fill(sim, frame);
    frame.index = index;
    frame.sim_time += time_offset;
    frame.split_threshold = sim.params.split_threshold;
    frame.merge_velocity = sim.params.merge_velocity;
}

#[allow(clippy::too_many_arguments)]
fn sim_loop(
    mut setup: Setup,
    frames_total: Option<u64>,
    live: bool,
    ctl: Receiver<Control>,
    tx: Sender<Frame>,
    free: Receiver<Frame>,
    stop: &StopSignal,
    console: &Console,
) -> SimOutcome {
    let mut sim = setup.simulation();
    let mut builder = FrameBuilder::new(&setup.model, setup.strands, STRAND_SUBDIVISIONS);
    let mut report = StepReport::default();
    let mut out = SimOutcome::default();
    let mut messages: Vec<String> = Vec::new();
    // A frame the logger had no room for: refilled next time, its messages kept.
    let mut carry: Option<Frame> = None;
    let mut paused = false;
    let mut time_offset = 0.0;
    // Wall-clock pacing (live): frame `origin_index + n` is due at `origin + n · frame_dt`.
    let mut origin = Instant::now();
    let mut origin_index = 0u64;
    let mut index = 0u64;

    while !stop.is_stopped() && frames_total.is_none_or(|n| index < n) {
        let mut reset_clock = false;
        while let Ok(c) = ctl.try_recv() {
            reset_clock = true;
            match c {
                Control::Params(p, msg) => {
                    let link = sim.link.clone();
                    let p = *p;
                    sim.set_tunables(Tunables { params: p, link });
                    console.say(&msg);
                    messages.push(msg);
                }
                Control::Rebuild(s, msg) => {
                    console.say(&msg);
                    messages.push(msg);
                    time_offset += sim.time();
                    setup = *s;
                    sim = setup.simulation();
                    builder = FrameBuilder::new(&setup.model, setup.strands, STRAND_SUBDIVISIONS);
                    out.restarts += 1;
                }
                Control::Key(KeyAction::TogglePause) => {
                    paused = !paused;
                    let msg = if paused { "paused" } else { "resumed" };
                    console.say(msg);
                    messages.push(msg.to_owned());
                }
                Control::Key(KeyAction::Restart) => {
                    // Same model and motion, the parameters now in force (keys included).
                    time_offset += sim.time();
                    let t = Tunables {
                        params: sim.params.clone(),
                        link: sim.link.clone(),
                    };
                    sim = Simulation::with_params(
                        setup.model.clone(),
                        setup.motion.clone(),
                        setup.single_level,
                        Some(t),
                    );
                    let msg = "restarted the simulation (key)".to_owned();
                    console.say(&msg);
                    messages.push(msg);
                    out.restarts += 1;
                }
                Control::Key(a) => {
                    let mut p = sim.params.clone();
                    if let Some(msg) = tune::apply_key(&mut p, a) {
                        let link = sim.link.clone();
                        sim.set_tunables(Tunables { params: p, link });
                        console.say(&msg);
                        messages.push(msg);
                    }
                }
            }
        }
        if paused {
            std::thread::sleep(POLL);
            origin = Instant::now();
            origin_index = index;
            continue;
        }
        if reset_clock {
            origin = Instant::now();
            origin_index = index;
        }

        let mut frame = match carry.take() {
            Some(f) => f,
            None => {
                let mut f = free.try_recv().unwrap_or_default();
                f.messages.clear();
                f
            }
        };
        frame.messages.append(&mut messages);
        frame.step_ms = step_frame(&mut sim, &mut report, &mut frame);
        finish_frame(&mut sim, &mut builder, &mut frame, index, time_offset);
        frame.dropped_frames = out.dropped;
        out.splits += frame.splits as u64;
        out.merges += frame.merges as u64;
        out.sim_time = frame.sim_time;
        index += 1;
        out.frames = index;

        if live {
            match tx.try_send(frame) {
                Ok(()) => {}
                Err(TrySendError::Full(mut f)) => {
                    // The whole frame goes; its messages ride on the next one.
                    out.dropped += 1;
                    f.events.clear();
                    carry = Some(f);
                }
                Err(TrySendError::Disconnected(_)) => break,
            }
            // Keep to wall-clock time; do not pile up a debt when the simulation is slower.
            let frame_dt = sim.params.dt * sim.params.steps_per_frame.max(1) as f64;
            let due = origin + Duration::from_secs_f64((index - origin_index) as f64 * frame_dt);
            let now = Instant::now();
            if now > due + Duration::from_millis(250) {
                origin = now;
                origin_index = index;
            }
            while !stop.is_stopped() {
                let now = Instant::now();
                if now >= due {
                    break;
                }
                std::thread::sleep((due - now).min(POLL));
            }
        } else if tx.send(frame).is_err() {
            // The logger is gone (it stops the run and reports why).
            break;
        }
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn logger_loop(
    rec: RecordingStream,
    levels: u16,
    style_name: &str,
    head: [f32; 3],
    frames: Receiver<Frame>,
    free: Sender<Frame>,
    notes: Receiver<(MessageLevel, String)>,
    logged: &AtomicU64,
    live: bool,
) -> anyhow::Result<()> {
    let mut levels = levels;
    let mut logger = Logger::new(rec.clone(), levels, style_name, head)?;
    let mut notes = notes;
    loop {
        crossbeam_channel::select! {
            recv(frames) -> f => match f {
                Ok(frame) => {
                    if frame.levels != levels {
                        // A restart on a model with another number of levels: new annotation
                        // classes and per-level series.
                        levels = frame.levels;
                        logger = Logger::new(rec.clone(), levels, style_name, head)?;
                    }
                    logger.log_frame(&frame)?;
                    logged.fetch_add(1, Ordering::Relaxed);
                    // The simulation may have stopped; then the frame is simply freed.
                    let _ = free.send(frame);
                }
                Err(_) => break,
            },
            recv(notes) -> n => match n {
                Ok((level, text)) => logger.log_message(level, &text)?,
                // Closed: stop selecting on it (a closed channel is always ready).
                Err(_) => notes = crossbeam_channel::never(),
            },
        }
    }
    for (level, text) in notes.try_iter() {
        logger.log_message(level, &text)?;
    }
    if live {
        match rec.flush_with_timeout(LIVE_FLUSH_TIMEOUT) {
            Ok(()) => Ok(()),
            Err(e) => Err(anyhow::anyhow!("flushing to the viewer: {e}")),
        }
    } else {
        logger.flush()
    }
}
