//! `wisptree run`: simulate a style under a motion and stream the AWT paper's Figure 4 display
//! to Rerun, live in a viewer or into a `.rrd` recording.
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

use anyhow::Context as _;

use crate::error::BadInput;
use crate::scene::Scene;
use crate::solver::SolverKind;
use crate::stream::sink::{self, SinkChoice};
use crate::style::builtin::StyleSource;

use super::console::Console;
use super::stop::{stop_on_ctrl_c, StopSignal};
use super::threads::{simulate, LoopOptions, RunSummary, WebLink};
use crate::web::{ControlPage, PageConfig, SharedState};
use std::sync::Arc;

/// The style used when `--style` is not given: the built-in Long style.
pub const DEFAULT_STYLE: &str = "long";
/// The motion used when `--motion` is not given.
pub const DEFAULT_MOTION: &str = "lean";
/// Simulated seconds recorded when writing a file and `--seconds` is not given.
pub const DEFAULT_RECORD_SECONDS: f64 = 10.0;
/// Strands drawn per frame by default. Measured (see the report of issue 4): a 10 s recording
/// of the Long style under `lean` stays well under 100 MB with this many, and so does
/// `long_curly`, the heaviest paper style.
pub const DEFAULT_STRANDS: usize = 600;

/// What `wisptree run` is asked to do (the CLI's flags, as plain values).
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// A built-in style name or a style file.
    pub style: String,
    /// A motion preset or a keyframed `.ron` motion file.
    pub motion: String,
    /// The hair model.
    pub model: SolverKind,
    /// Simulated seconds; `None`: 10 when recording, until stopped when live.
    pub seconds: Option<f64>,
    /// Strands drawn per frame.
    pub strands: usize,
    /// Watch the style file: `None` = when live.
    pub watch: Option<bool>,
    /// Where the recording goes.
    pub sink: SinkChoice,
    /// Render the hair beside the debug view at this size; `None`: off (`--no-render`).
    pub render: Option<(u32, u32)>,
    /// Serve the control page and the web viewer (`--web`); the sink is then
    /// [`SinkChoice::Web`].
    pub web: Option<WebOptions>,
    /// The node whose numbers are logged every frame (`--inspect`).
    pub inspect: Option<crate::solver::NodeId>,
}

/// `--web [--port P] [--bind IP] [--open]`.
#[derive(Debug, Clone, PartialEq)]
pub struct WebOptions {
    /// The address the page, the web viewer and the gRPC server bind.
    pub bind: std::net::IpAddr,
    /// The page's port (0: a free one).
    pub port: u16,
    /// Open the page in the default browser.
    pub open: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions {
            style: DEFAULT_STYLE.to_owned(),
            motion: DEFAULT_MOTION.to_owned(),
            model: SolverKind::Awt,
            seconds: None,
            strands: DEFAULT_STRANDS,
            watch: None,
            sink: SinkChoice::Auto,
            render: Some(super::render_thread::DEFAULT_RENDER_SIZE),
            web: None,
            inspect: None,
        }
    }
}

/// `wisptree run`: installs the Ctrl-C handler and runs [`run_with`].
pub fn run(opts: RunOptions) -> anyhow::Result<()> {
    let stop = StopSignal::new();
    stop_on_ctrl_c(&stop)?;
    let result = run_with(opts, stop);
    super::terminal::restore_terminal();
    result.map(|_| ())
}

/// The whole command with an explicit stop signal (what Ctrl-C triggers in [`run`]).
pub fn run_with(opts: RunOptions, stop: StopSignal) -> anyhow::Result<RunSummary> {
    // A path no recording can be written to is refused before the style loads (one line).
    if let sink::SinkChoice::Save(path) = &opts.sink {
        sink::check_save_path(path)?;
        crate::files::check_move_aside(path).context("--save")?;
    }
    // Load first: a bad style must not leave an empty recording or a spawned viewer behind.
    let scene = Scene::load(&opts.style, &opts.motion, opts.model)?;
    if let Some(node) = &opts.inspect {
        let checked = match opts.model {
            SolverKind::Awt | SolverKind::SingleLevel => {
                crate::solver::awt::inspect::resolve(&scene.model, node).map(|_| ())
            }
            SolverKind::Layered => crate::solver::layered::inspect::resolve(
                &scene.model,
                &scene.loaded.style.layered,
                node,
            ),
            SolverKind::Guides => crate::solver::guides::inspect::resolve(
                &scene.model,
                &scene.loaded.style.guides,
                node,
            ),
        };
        checked
            .map_err(|e| BadInput(format!("--inspect {}: {e}", node.path().replace('/', ":"))))?;
    }
    let console = Console::default();
    for n in &scene.model.notes {
        console.say(&format!("wisptree: note: {n}"));
    }
    for w in scene.warnings() {
        console.say(&format!("warning: {w}"));
    }
    let mut sink = sink::open_sink(&opts.sink)?;
    // The page's servers live until the run returns (the viewer's with `_page`).
    let (_page, web) = match (sink.web.take(), &opts.web) {
        (Some(viewer), Some(w)) => {
            let (page, link) = start_page(&scene, viewer, w, &console)?;
            (Some(page), Some(link))
        }
        _ => (None, None),
    };
    let seconds = match (opts.seconds, sink.live) {
        (Some(s), _) => Some(s),
        (None, true) => None,
        (None, false) => Some(DEFAULT_RECORD_SECONDS),
    };
    let mut watch = opts.watch.unwrap_or(sink.live);
    if let (true, StyleSource::Builtin(name)) = (watch, &scene.source) {
        console.say(&format!(
            "the built-in style `{name}` is compiled in, so it is not watched; for a file to \
             edit while it runs: `wisptree styles --write {name}`, then `--style {name}.ron`"
        ));
        watch = false;
    }
    announce(&console, &scene, &opts, &sink, seconds);
    let loop_opts = LoopOptions {
        seconds,
        live: sink.live,
        watch,
        keys: sink.live,
        progress: sink.file.is_some(),
        strands: opts.strands,
        render: opts.render,
        render_skips_when_behind: sink.live,
        quiet: false,
        web,
        inspect: opts.inspect,
    };
    let file = sink.file.clone();
    let summary = simulate(&scene, sink, &loop_opts, &stop)?;
    report_end(&console, &summary, file.as_deref());
    Ok(summary)
}

/// Starts the control page beside the web viewer and says where they are.
fn start_page(
    scene: &Scene,
    viewer: sink::WebViewer,
    w: &WebOptions,
    console: &Console,
) -> anyhow::Result<((ControlPage, sink::WebViewer), WebLink)> {
    let mut motions: Vec<String> = crate::motion::Motion::preset_names()
        .iter()
        .map(|m| (*m).to_owned())
        .collect();
    if !motions.contains(&scene.motion_spec) {
        motions.push(scene.motion_spec.clone());
    }
    let models = SolverKind::ALL
        .iter()
        .map(|k| k.name().to_owned())
        .collect();
    let shared = Arc::new(SharedState::new(models, motions));
    let (tx, rx) = crossbeam_channel::unbounded();
    let (tunes_tx, tunes_rx) = crossbeam_channel::unbounded();
    let (styles_tx, styles_rx) = crossbeam_channel::unbounded();
    let (marks_tx, marks_rx) = crossbeam_channel::unbounded();
    // The Style panel edits the style's own text (its comments are kept where possible).
    let text = match &scene.source {
        StyleSource::Builtin(name) => crate::style::builtin::builtin(name)
            .map(|b| b.text.to_owned())
            .unwrap_or_default(),
        StyleSource::File(p) => std::fs::read_to_string(p).unwrap_or_default(),
    };
    let style = crate::web::style_panel::StylePanel::new(
        scene.loaded.clone(),
        &scene.model,
        text,
        scene.source.file().map(std::path::Path::to_path_buf),
        styles_tx,
        marks_tx,
    );
    let style = Arc::new(style);
    let page = ControlPage::start(
        PageConfig {
            bind: w.bind,
            port: w.port,
            viewer_port: viewer.viewer_port,
            grpc_port: viewer.grpc_port,
            style: Some(Arc::clone(&style)),
        },
        Arc::clone(&shared),
        tx,
        tunes_tx,
    )?;
    let url = page.url();
    console.say(&format!(
        "control page: {url}\n    Rerun web viewer on port {}, gRPC server on port {} (all on {}); \
         the viewer alone: {}",
        viewer.viewer_port,
        viewer.grpc_port,
        w.bind,
        viewer.url()
    ));
    if w.open {
        if let Err(e) = webbrowser::open(&url) {
            console.say(&format!(
                "could not open a browser ({e}); open {url} yourself"
            ));
        }
    }
    Ok((
        (page, viewer),
        WebLink {
            shared,
            commands: rx,
            tunes: tunes_rx,
            styles: styles_rx,
            marks: marks_rx,
            panel: Some(style),
        },
    ))
}

/// Runs the simulation into `rec` (no viewer to watch) until `opts.seconds` are simulated or
/// `stop` is triggered.
pub fn simulate_into(
    scene: &Scene,
    rec: sink::Recording,
    opts: &LoopOptions,
    stop: &StopSignal,
) -> anyhow::Result<RunSummary> {
    simulate(scene, sink::OpenSink::recording(rec), opts, stop)
}

/// The opening lines: what runs where, for how long.
fn announce(
    console: &Console,
    scene: &Scene,
    opts: &RunOptions,
    sink: &sink::OpenSink,
    seconds: Option<f64>,
) {
    let drawn = opts.strands.min(scene.model.strands.len());
    console.say(&format!(
        "wisptree: style {} ({} levels, {} strands, {} drawn), model {}, under motion `{}` → {}",
        scene.style_name(),
        scene.model.level_count(),
        scene.model.strands.len(),
        drawn,
        scene.solver,
        scene.motion.name(),
        sink.description
    ));
    match seconds {
        _ if sink.fell_back => {}
        Some(s) => console.say(&format!("simulating {s} s")),
        None => console.say("simulating until Ctrl-C (or q)"),
    }
    if sink.fell_back {
        console.say(&format!(
            "recording {} s of simulated time to {} in the current directory",
            seconds.unwrap_or(DEFAULT_RECORD_SECONDS),
            sink.file
                .as_deref()
                .map_or_else(|| sink::DEFAULT_RRD.into(), |p| p.display().to_string())
        ));
    }
}

/// The closing lines: frames, events, and how to open the file.
fn report_end(console: &Console, summary: &RunSummary, file: Option<&std::path::Path>) {
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
    if let Some(path) = file {
        let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        console.say(&format!(
            "wrote {} ({:.1} MB). Open it with:\n    rerun {}\n(the viewer, if needed: pip install rerun-sdk=={})",
            path.display(),
            size as f64 / 1e6,
            path.display(),
            sink::rerun_version()
        ));
    }
}
