//! Starting the simulation and logging threads, watching them from the main thread (keys, the
//! style file, the viewer, progress) and collecting what they did.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::Context as _;
use crossbeam_channel::{Receiver, Sender};

use super::console::{poll_key, Console};
use super::keys::{self, KeyAction};
use super::log_thread::LogThread;
use super::reload::handle_reload;
use super::sim_thread::{Control, Load, SimOutcome, SimThread};
use super::stop::StopSignal;
use super::style_watcher::StyleWatcher;
use super::terminal::RawTerminal;
use crate::frame::Frame;
use crate::scene::Scene;
use crate::stream::sink::{OpenSink, SinkWatcher, ViewerStatus};
use crate::stream::{LoggerSetup, MessageLevel};
use crate::web::style_panel::StyleApplied;
use crate::web::{SetTunable, SharedState, WebCommand};

/// Frames queued between the simulation and the logger. Small: live, a long queue is latency.
const QUEUE_FRAMES: usize = 3;
/// How long a viewer may take to accept the connection before the run gives up on it.
const VIEWER_CONNECT_TIMEOUT: Duration = Duration::from_secs(15);
/// How long, after stopping, the logger may take to hand over what is queued before the run
/// returns anyway (a viewer that stopped reading must not hang the process).
const LOGGER_FINISH_TIMEOUT: Duration = Duration::from_secs(20);
/// The same, once the viewer is known to be gone.
const LOST_VIEWER_FINISH_TIMEOUT: Duration = Duration::from_secs(2);
/// Poll period of the main thread (keys, watcher, viewer status).
const POLL: Duration = Duration::from_millis(25);

/// How the loop runs.
#[derive(Debug, Clone)]
pub struct LoopOptions {
    /// Simulated seconds; `None` runs until stopped.
    pub seconds: Option<f64>,
    /// Keep to wall-clock time and drop frames instead of blocking (a viewer is watching).
    pub live: bool,
    /// Watch the style file (a style given by path only).
    pub watch: bool,
    /// Read keys from the terminal (only if stdin is a terminal).
    pub keys: bool,
    /// Show a progress bar (only if stderr is a terminal and the length is known).
    pub progress: bool,
    /// Strands drawn per frame.
    pub strands: usize,
    /// Render every frame at this size (width, height) on a render thread; `None`: off.
    pub render: Option<(u32, u32)>,
    /// The renderer skips a frame's image when frames wait behind it, as live runs do
    /// (simulation frames are never skipped); `bench --live` does so unpaced.
    pub render_skips_when_behind: bool,
    /// Print nothing on the console (the run's log still goes to the recording).
    pub quiet: bool,
    /// The control page's requests and the state it shows (`run --web`).
    pub web: Option<WebLink>,
    /// The node whose numbers each frame carries (`run --inspect`).
    pub inspect: Option<crate::solver::NodeId>,
}

/// What connects a run to its control page.
#[derive(Debug, Clone)]
pub struct WebLink {
    /// The state the simulation thread publishes for the pages.
    pub shared: Arc<SharedState>,
    /// The pages' checked requests but tunable values.
    pub commands: Receiver<WebCommand>,
    /// The pages' tunable values, read by the simulation thread itself.
    pub tunes: Receiver<SetTunable>,
    /// Styles edited on the Style panel, with their regenerated models: the run restarts on
    /// them.
    pub styles: Receiver<StyleApplied>,
    /// The Style panel's key strands to draw (read by the logging thread).
    pub marks: Receiver<crate::style::edit::Marks>,
    /// The Style panel, told when the watched style file is reloaded.
    pub panel: Option<Arc<crate::web::style_panel::StylePanel>>,
}

/// The two worker threads and the channels the main thread keeps.
struct Workers {
    sim: JoinHandle<SimOutcome>,
    logger: JoinHandle<anyhow::Result<()>>,
    logger_done: Receiver<()>,
    ctl: Sender<Control>,
    notes: Sender<(MessageLevel, String)>,
    logged: Arc<AtomicU64>,
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
    /// Splits over the run.
    pub splits: u64,
    /// Merges over the run.
    pub merges: u64,
    /// Stopped before the requested duration (Ctrl-C, `q`, a test's stop, a lost viewer).
    pub interrupted: bool,
    /// The viewer went away (or never answered).
    pub viewer_lost: bool,
    /// Parameter reloads applied.
    pub reloads: u32,
    /// Restarts done.
    pub restarts: u32,
    /// How fast the simulation's frames came, frame by frame (the real-time factor).
    pub tempo: crate::report::tempo::Tempo,
    /// What the solver carried: active nodes, contacts.
    pub load: Load,
}

/// Runs the scene into the sink until `opts.seconds` are simulated or `stop` is triggered. A
/// live viewer is watched: one that goes away stops the run.
pub fn simulate(
    scene: &Scene,
    sink: OpenSink,
    opts: &LoopOptions,
    stop: &StopSignal,
) -> anyhow::Result<RunSummary> {
    let frames_total = opts.seconds.map(|s| scene.frames_for(s));
    let mut console = if opts.progress {
        Console::with_progress(frames_total)
    } else {
        Console::default()
    };
    console.quiet = opts.quiet;
    let viewer = sink.watcher();
    let w = start_workers(scene, sink, opts, frames_total, stop, &console)?;
    let mut summary = RunSummary::default();
    let never_connected = watch_run(scene, opts, &w, &viewer, stop, &console, &mut summary);
    let asked_to_stop = stop.is_stopped();
    stop.stop();
    let Workers {
        sim,
        logger,
        logger_done,
        ctl,
        notes,
        logged,
    } = w;
    drop(ctl);
    drop(notes);
    let sim = sim
        .join()
        .map_err(|_| anyhow::anyhow!("the simulation thread panicked"))?;
    // The logger drains the queue and flushes; a viewer that stopped reading could keep it
    // waiting, so do not wait forever (and with the viewer gone, not long).
    let finish_timeout = if summary.viewer_lost {
        LOST_VIEWER_FINISH_TIMEOUT
    } else {
        LOGGER_FINISH_TIMEOUT
    };
    let logger_result = match logger_done.recv_timeout(finish_timeout) {
        Ok(()) => logger
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
    summary.tempo = sim.tempo;
    summary.load = sim.load;
    summary.interrupted = asked_to_stop && frames_total.is_none_or(|n| sim.frames < n);
    if let Some(msg) = never_connected {
        // Nothing was shown anywhere: an error, not a normal end.
        anyhow::bail!(msg);
    }
    match logger_result {
        // (With the viewer gone, a failed final flush is expected and already explained.)
        Err(e) if !summary.viewer_lost => Err(e),
        _ => Ok(summary),
    }
}

fn start_workers(
    scene: &Scene,
    sink: OpenSink,
    opts: &LoopOptions,
    frames_total: Option<u64>,
    stop: &StopSignal,
    console: &Console,
) -> anyhow::Result<Workers> {
    let (frame_tx, sim_rx) = crossbeam_channel::bounded::<Frame>(QUEUE_FRAMES);
    // Rendering that skips frames: the simulation places the strands only for frames the
    // drawing thread will take.
    let draw_gate = (opts.render.is_some() && opts.render_skips_when_behind)
        .then(super::render_thread::DrawGate::default);
    // With rendering, frames go simulation → renderer → logger; without, straight through.
    let frame_rx = match opts.render {
        Some(size) => {
            let (tx, rx) = crossbeam_channel::bounded::<Frame>(QUEUE_FRAMES);
            let setup = super::render_thread::RenderSetup {
                params: scene.loaded.style.render.clone(),
                size,
                camera: super::render_thread::scene_camera(scene),
                input: sim_rx,
                output: tx,
                live: draw_gate.clone(),
            };
            super::render_thread::start(setup)
                .map_err(|e| crate::error::BadInput(format!("rendering: {e}")))?;
            rx
        }
        None => sim_rx,
    };
    // Unbounded, but it never holds more frames than exist: QUEUE_FRAMES + 2 or so.
    let (free_tx, free_rx) = crossbeam_channel::unbounded::<Frame>();
    let (ctl_tx, ctl_rx) = crossbeam_channel::unbounded::<Control>();
    let (note_tx, note_rx) = crossbeam_channel::unbounded::<(MessageLevel, String)>();
    let (done_tx, done_rx) = crossbeam_channel::bounded::<()>(1);
    let logged = Arc::new(AtomicU64::new(0));

    let camera = super::render_thread::scene_camera(scene);
    let mut setup = LoggerSetup::new(
        scene.model.level_count() as u16,
        &scene.style_name(),
        scene.camera_target(),
    );
    setup.camera = Some(crate::stream::BlueprintCamera {
        eye: camera.eye,
        target: camera.target,
    });
    setup.render = opts.render.is_some();
    let log = LogThread {
        rec: sink.rec,
        setup,
        frames: frame_rx,
        free: free_tx,
        notes: note_rx,
        live: opts.live,
        style_marks: opts.web.as_ref().map(|w| w.marks.clone()),
    };
    let logger = {
        let logged = logged.clone();
        let stop = stop.clone();
        std::thread::Builder::new()
            .name("wisptree-logger".into())
            .spawn(move || {
                let r = log.run(&logged);
                if r.is_err() {
                    // Nobody is listening any more: stop the simulation too.
                    stop.stop();
                }
                let _ = done_tx.send(());
                r
            })
            .context("starting the logging thread")?
    };
    let sim_thread = SimThread {
        scene: scene.clone(),
        strands: opts.strands,
        render: opts.render.is_some(),
        frames_total,
        live: opts.live,
        ctl: ctl_rx,
        tx: frame_tx,
        free: free_rx,
        shared: opts.web.as_ref().map(|w| Arc::clone(&w.shared)),
        tunes: opts.web.as_ref().map(|w| w.tunes.clone()),
        inspect: opts.inspect,
        draw_gate,
    };
    let sim = {
        let stop = stop.clone();
        let console = console.clone();
        std::thread::Builder::new()
            .name("wisptree-sim".into())
            .spawn(move || sim_thread.run(&stop, &console))
            .context("starting the simulation thread")?
    };
    Ok(Workers {
        sim,
        logger,
        logger_done: done_rx,
        ctl: ctl_tx,
        notes: note_tx,
        logged,
    })
}

/// The main thread's loop while the workers run: keys, the style file, the viewer, progress.
/// Returns the error message if the viewer never connected.
fn watch_run(
    scene: &Scene,
    opts: &LoopOptions,
    w: &Workers,
    viewer: &SinkWatcher,
    stop: &StopSignal,
    console: &Console,
    summary: &mut RunSummary,
) -> Option<String> {
    let raw = if opts.keys {
        RawTerminal::enter()
    } else {
        None
    };
    if raw.is_some() {
        console.say(keys::KEY_HELP);
    }
    let mut watcher = match scene.source.file() {
        Some(path) if opts.watch => match StyleWatcher::new(path) {
            Ok(w) => {
                console.say(&format!("watching {} for changes", path.display()));
                Some(w)
            }
            Err(e) => {
                console.say(&format!("not watching the style file: {e:#}"));
                None
            }
        },
        _ => None,
    };
    let mut file_style = scene.loaded.clone();
    // The scene in force: a motion or model chosen on the control page, or a reloaded model.
    let mut current = scene.clone();
    let mut key_error_reported = false;
    let mut never_connected: Option<String> = None;
    while !stop.is_stopped() && !w.sim.is_finished() {
        if raw.is_some() {
            match poll_key(POLL) {
                Ok(Some(KeyAction::Quit)) => {
                    console.say("quitting");
                    stop.stop();
                }
                Ok(Some(KeyAction::Help)) => console.say(keys::KEY_HELP),
                Ok(Some(a)) => {
                    let _ = w.ctl.send(Control::Key(a));
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
        if let Some(path) = watcher
            .as_mut()
            .and_then(|w| w.poll().then(|| w.path().to_path_buf()))
        {
            let panel = opts.web.as_ref().and_then(|w| w.panel.as_ref());
            // The Style panel's own save: the run already has its edits (they came first).
            if !panel.is_some_and(|p| p.holds_own_text(&path)) {
                if handle_reload(&mut current, &mut file_style, &w.ctl, &w.notes, console) {
                    summary.reloads += 1;
                }
                // The Style panel edits what the file now says.
                if let Some(panel) = panel {
                    panel.file_changed(&path, &file_style);
                }
            }
        }
        if let Some(web) = &opts.web {
            while let Ok(cmd) = web.commands.try_recv() {
                web_command(cmd, &mut current, &w.ctl, &web.shared, console);
            }
            while let Ok(edit) = web.styles.try_recv() {
                style_edit(
                    edit,
                    &mut current,
                    &mut file_style,
                    &w.ctl,
                    &web.shared,
                    console,
                );
            }
        }
        let lost = match viewer.status() {
            ViewerStatus::Gone(why) => Some(why),
            ViewerStatus::Connecting(t) if t > VIEWER_CONNECT_TIMEOUT => {
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
        if let Some(b) = &console.bar {
            b.set_position(w.logged.load(Ordering::Relaxed));
        }
    }
    never_connected
}

/// A style edited on the Style panel: a new scene on its regenerated model, and a restart
/// from rest on it with the tuned parameters kept (as a motion or model switch does). The
/// watched file's style follows, so that saving the edit is not taken for another change.
fn style_edit(
    edit: StyleApplied,
    current: &mut Scene,
    file_style: &mut crate::style::LoadedStyle,
    ctl: &Sender<Control>,
    shared: &SharedState,
    console: &Console,
) {
    let StyleApplied {
        loaded,
        model,
        message,
    } = edit;
    match Scene::from_model(
        current.source.clone(),
        loaded.clone(),
        model,
        &current.motion_spec,
        current.solver,
    ) {
        Ok(scene) => {
            *current = scene;
            *file_style = loaded;
            let msg = format!(
                "style (web page): {message}; the hair regenerated, restarting the simulation \
                 from rest"
            );
            let _ = ctl.send(Control::Switch(Box::new(current.clone()), msg));
        }
        Err(e) => {
            let msg = format!("style edit not applied: {e}");
            console.say(&msg);
            shared.log(&msg);
        }
    }
}

/// Turns a control page's request into what the simulation thread does: the same [`Control`]
/// messages as the keys and the style reload. A motion or model change is a restart on a new
/// scene, which becomes the one in force.
fn web_command(
    cmd: WebCommand,
    current: &mut Scene,
    ctl: &Sender<Control>,
    shared: &SharedState,
    console: &Console,
) {
    let control = match cmd {
        // The page server sends tunable values to the simulation thread itself.
        WebCommand::Set(..) => return,
        WebCommand::Pause(paused) => Control::Pause(paused),
        WebCommand::Inspect(node) => Control::Inspect(node),
        WebCommand::Pick(pick) => Control::Pick(pick),
        WebCommand::Restart => Control::Key(KeyAction::Restart),
        WebCommand::Motion(spec) => match current.with_motion(&spec) {
            Ok(s) => {
                *current = s;
                let msg = format!("motion `{spec}` (web page); restarting the simulation");
                Control::Switch(Box::new(current.clone()), msg)
            }
            Err(e) => {
                let msg = format!("motion `{spec}` not applied: {e}");
                console.say(&msg);
                shared.log(&msg);
                return;
            }
        },
        WebCommand::Model(kind) => {
            *current = current.with_solver(kind);
            let msg = format!("model `{kind}` (web page); restarting the simulation");
            Control::Switch(Box::new(current.clone()), msg)
        }
    };
    let _ = ctl.send(control);
}
