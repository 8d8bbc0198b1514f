//! The simulation thread: steps the solver frame by frame, fills frames and hands them to the
//! logger, applies parameter changes, pauses and restarts.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender, TrySendError};

use super::console::Console;
use super::keys::{self, KeyAction};
use super::render_thread::DrawGate;
use super::stop::StopSignal;
use crate::frame::Frame;
use crate::pipeline::{self, FrameBuilder};
use crate::report::tempo::{RealtimeMeter, Tempo, SLOW_BELOW};
use crate::report::StageTimes;
use crate::scene::Scene;
use crate::solver::tunable::{self, Tuning};
use crate::solver::Solver;
use crate::web::protocol::InspectedNode;
use crate::web::{Controls, SetTunable, SharedState};

/// Poll period while paused.
const PAUSE_POLL: Duration = Duration::from_millis(25);
/// A live simulation more than this late gives up catching up (no debt piles up).
const MAX_LATENESS: Duration = Duration::from_millis(250);

/// What the main thread sends to the simulation thread.
pub enum Control {
    /// New parameters from a style reload (the `sim:` section, and the other models' tunable
    /// values), with the message describing them.
    Params(Box<Tuning>, String),
    /// A new model (geometry changed): restart on it.
    Rebuild(Box<Scene>, String),
    /// A key the main thread does not handle itself.
    Key(KeyAction),
    /// Pause (`true`) or resume, from the control page.
    Pause(bool),
    /// Restart on another scene (motion or model chosen on the page) with the parameters in
    /// force.
    Switch(Box<Scene>, String),
    /// Inspect this node from the next frame on, or none (the control page's inspector).
    Inspect(Option<crate::solver::NodeId>),
    /// Inspect the node clicked in the page's viewer.
    Pick(crate::web::protocol::NodePick),
}

/// What the simulation thread did.
#[derive(Debug, Default)]
pub struct SimOutcome {
    /// Frames produced (logged or dropped).
    pub frames: u64,
    /// Frames dropped because the logger was full (live only).
    pub dropped: u64,
    /// Simulated time at the last frame, across restarts.
    pub sim_time: f64,
    /// Splits and merges over the run.
    pub splits: u64,
    /// See `splits`.
    pub merges: u64,
    /// Restarts (reloaded model, restart key).
    pub restarts: u32,
    /// How fast the frames came: real-time factor, frame wall times.
    pub tempo: Tempo,
    /// What the solver carried: active nodes (or guides, or wisp points) and contacts.
    pub load: Load,
}

/// What the solver carried over a run, frame by frame (the `bench --live` columns).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Load {
    /// Frames counted.
    pub frames: u64,
    /// Sum over frames of the active nodes (guides, wisp points) after the frame's last step.
    pub active_sum: f64,
    /// The most active nodes after any frame.
    pub active_max: u32,
    /// Sum over frames of the segment pairs in contact per step.
    pub contacts_per_step_sum: f64,
    /// Steps taken, and the wall time of their `step` calls (what the stage times divide).
    pub steps: u64,
    /// See `steps`.
    pub step_wall: Duration,
    /// The steps' time in each stage (zero for solvers that do not time their stages).
    pub stages: StageTimes,
}

impl Load {
    fn add(&mut self, f: &Frame, steps_per_frame: usize) {
        let active: u32 = f.counters.active_per_level.iter().sum();
        self.frames += 1;
        self.active_sum += f64::from(active);
        self.active_max = self.active_max.max(active);
        self.contacts_per_step_sum +=
            f64::from(f.counters.pairs_in_contact) / steps_per_frame.max(1) as f64;
        let steps = steps_per_frame.max(1) as u64;
        self.steps += steps;
        self.step_wall += Duration::from_secs_f64(f.step_ms.max(0.0) * 1e-3 * steps as f64);
        self.stages.add(&f.counters.times);
    }

    /// Mean active nodes (guides, wisp points) per frame.
    pub fn mean_active(&self) -> f64 {
        self.active_sum / self.frames.max(1) as f64
    }

    /// Mean segment pairs in contact per step.
    pub fn contacts_per_step(&self) -> f64 {
        self.contacts_per_step_sum / self.frames.max(1) as f64
    }
}

/// Everything the simulation thread owns.
pub struct SimThread {
    /// The scene now simulated (replaced on a rebuild).
    pub scene: Scene,
    /// Strands drawn per frame.
    pub strands: usize,
    /// Fill every strand of the model for the renderer.
    pub render: bool,
    /// Frames to produce; `None` until stopped.
    pub frames_total: Option<u64>,
    /// Keep to wall-clock time and drop frames rather than block.
    pub live: bool,
    /// Control messages from the main thread.
    pub ctl: Receiver<Control>,
    /// Filled frames to the logger.
    pub tx: Sender<Frame>,
    /// Emptied frames back from the logger.
    pub free: Receiver<Frame>,
    /// What the control pages show (`run --web`), published every frame.
    pub shared: Option<Arc<SharedState>>,
    /// Tunable values set on the control pages (checked there against the table published
    /// in `shared`).
    pub tunes: Option<Receiver<SetTunable>>,
    /// The node whose numbers each frame carries (`run --inspect`).
    pub inspect: Option<crate::solver::NodeId>,
    /// With rendering that skips frames: open when the drawing thread will take a frame's
    /// strands (they are placed only then). `None`: every frame is rendered.
    pub draw_gate: Option<DrawGate>,
}

/// The state of the loop that a control message may change.
struct LoopState {
    solver: Box<dyn Solver>,
    builder: FrameBuilder,
    /// All strands, for the renderer (when rendering).
    render_builder: Option<FrameBuilder>,
    messages: Vec<String>,
    paused: bool,
    time_offset: f64,
    out: SimOutcome,
    /// How fast the frames come (`/stats/realtime_factor`).
    meter: RealtimeMeter,
    /// Whether this scene's run already said it fell below real time.
    said_slow: bool,
    /// The inspected node (`run --inspect`).
    inspect: Option<crate::solver::NodeId>,
    /// See [`SimThread::draw_gate`].
    draw_gate: Option<DrawGate>,
}

impl SimThread {
    /// Runs until `frames_total` frames are made, the stop signal, or the logger goes away.
    pub fn run(mut self, stop: &StopSignal, console: &Console) -> SimOutcome {
        let mut st = LoopState {
            solver: self.scene.solver(),
            builder: FrameBuilder::new(&self.scene.model, self.strands, super::STRAND_SUBDIVISIONS),
            render_builder: self.render.then(|| {
                FrameBuilder::new(&self.scene.model, usize::MAX, super::STRAND_SUBDIVISIONS)
            }),
            messages: Vec::new(),
            paused: false,
            time_offset: 0.0,
            out: SimOutcome::default(),
            meter: RealtimeMeter::new(),
            said_slow: false,
            inspect: self.inspect,
            draw_gate: self.draw_gate.clone(),
        };
        say_ignored(&*st.solver, console, &mut st.messages);
        let mut report = st.solver.new_report();
        // A frame the logger had no room for: refilled next time, its messages kept.
        let mut carry: Option<Frame> = None;
        // Wall-clock pacing (live): frame `origin_index + n` is due at `origin + n · frame_dt`.
        let mut origin = Instant::now();
        let mut origin_index = 0u64;
        let mut index = 0u64;
        // Loading and settling are not the run's frames.
        st.meter.restart_clock();

        while !stop.is_stopped() && self.frames_total.is_none_or(|n| index < n) {
            if self.apply_controls(&mut st, console) {
                origin = Instant::now();
                origin_index = index;
                report = st.solver.new_report();
            }
            self.publish(&st);
            if st.paused {
                std::thread::sleep(PAUSE_POLL);
                origin = Instant::now();
                origin_index = index;
                st.meter.restart_clock();
                continue;
            }
            let mut frame = match carry.take() {
                Some(f) => f,
                None => {
                    let mut f = self.free.try_recv().unwrap_or_default();
                    f.messages.clear();
                    f
                }
            };
            frame.messages.append(&mut st.messages);
            make_frame(&mut st, &mut report, &mut frame, index);
            self.publish_inspected(&st, &frame);
            index += 1;
            st.out.frames = index;
            if self.live {
                self.say_if_slow(&mut st, &frame, console);
            }

            if self.live {
                match self.tx.try_send(frame) {
                    Ok(()) => {}
                    Err(TrySendError::Full(mut f)) => {
                        // The whole frame goes; its messages ride on the next one.
                        st.out.dropped += 1;
                        f.events.clear();
                        if let (Some(gate), false) = (&st.draw_gate, f.render_strands.is_empty()) {
                            // Its strands never reach the drawing thread: the next frame's may.
                            gate.open();
                        }
                        carry = Some(f);
                    }
                    Err(TrySendError::Disconnected(_)) => break,
                }
                let frame_dt = st.solver.dt() * st.solver.steps_per_frame() as f64;
                pace(stop, &mut origin, &mut origin_index, index, frame_dt);
            } else if self.tx.send(frame).is_err() {
                // The logger is gone (it stops the run and reports why).
                break;
            }
        }
        st.out.tempo = st.meter.tempo().clone();
        st.out
    }

    /// Says once per scene, on the console, the page and in the recording's log, that a live
    /// run fell below real time, and the likely cause.
    fn say_if_slow(&self, st: &mut LoopState, f: &Frame, console: &Console) {
        if st.said_slow || !st.meter.window_settled() || f.realtime_factor >= SLOW_BELOW {
            return;
        }
        st.said_slow = true;
        let msg = slow_motion_message(&*st.solver, f, self.render);
        console.say(&msg);
        if let Some(s) = &self.shared {
            s.log(&msg);
        }
        st.messages.push(msg);
    }

    /// Applies every pending control message; true if any arrived (the clock restarts).
    fn apply_controls(&mut self, st: &mut LoopState, console: &Console) -> bool {
        let mut any = self.apply_tunes(st, console);
        while let Ok(c) = self.ctl.try_recv() {
            any = true;
            let shared = self.shared.clone();
            let say = |msg: String, st: &mut LoopState| {
                console.say(&msg);
                if let Some(s) = &shared {
                    s.log(&msg);
                }
                st.messages.push(msg);
            };
            match c {
                Control::Params(t, msg) => {
                    st.solver.set_tuning(&t);
                    say(msg, st);
                }
                Control::Pause(paused) => {
                    if st.paused != paused {
                        st.paused = paused;
                        say(
                            (if paused {
                                "paused (web page)"
                            } else {
                                "resumed (web page)"
                            })
                            .to_owned(),
                            st,
                        );
                    }
                }
                Control::Switch(s, msg) => {
                    say(msg, st);
                    let params = st.solver.params().clone();
                    self.replace_scene(st, *s);
                    st.solver = self.scene.solver_with(&params);
                    st.said_slow = false;
                    st.meter.restart_clock();
                }
                Control::Rebuild(s, msg) => {
                    say(msg, st);
                    self.replace_scene(st, *s);
                    st.solver = self.scene.solver();
                    st.said_slow = false;
                    st.meter.restart_clock();
                }
                Control::Pick(pick) => {
                    let node = st.solver.pick_node(pick.instance, pick.position);
                    match node {
                        Some(n) => {
                            let name = n.path().replace('/', ":");
                            st.inspect = Some(n);
                            say(format!("inspecting node {name} (clicked in the view)"), st);
                        }
                        None => say(
                            format!(
                                "inspect: no node of the {} model there",
                                st.solver.kind().name()
                            ),
                            st,
                        ),
                    }
                }
                Control::Inspect(node) => {
                    // A node the model does not have keeps the one inspected before.
                    let checked = match node {
                        None => Ok("inspector: no node selected".to_owned()),
                        Some(n) => {
                            let name = n.path().replace('/', ":");
                            st.solver
                                .inspect(&n, &mut Vec::new())
                                .map(|()| format!("inspecting node {name}"))
                                .map_err(|e| format!("inspect {name}: {e}"))
                        }
                    };
                    let msg = match checked {
                        Ok(msg) => {
                            st.inspect = node;
                            if let (None, Some(s)) = (node, &self.shared) {
                                s.inspect(None);
                            }
                            msg
                        }
                        Err(msg) => msg,
                    };
                    say(msg, st);
                }
                Control::Key(KeyAction::TogglePause) => {
                    st.paused = !st.paused;
                    say(
                        (if st.paused { "paused" } else { "resumed" }).to_owned(),
                        st,
                    );
                }
                Control::Key(KeyAction::Restart) => {
                    // Same model and motion, the parameters now in force (keys included).
                    st.time_offset += st.solver.time();
                    let params = st.solver.params().clone();
                    st.solver = self.scene.solver_with(&params);
                    st.meter.restart_clock();
                    say(
                        "restarted the simulation with the parameters in force".to_owned(),
                        st,
                    );
                    st.out.restarts += 1;
                }
                Control::Key(a) => {
                    if let Some(msg) = keys::apply_key(&mut *st.solver, a) {
                        say(msg, st);
                    }
                }
            }
        }
        any
    }

    /// Sets the tunable values the pages sent, each through the solver's table (the one hop
    /// from the page's channel to the solver); true if any arrived.
    fn apply_tunes(&self, st: &mut LoopState, console: &Console) -> bool {
        let Some(tunes) = &self.tunes else {
            return false;
        };
        let mut any = false;
        while let Ok(SetTunable { name, value }) = tunes.try_recv() {
            any = true;
            let msg = match st.solver.set_tunable(&name, value) {
                Ok(old) => match tunable::find(st.solver.tunables(), &name) {
                    Some(t) => format!("{} (web page)", t.describe_change(old, value)),
                    None => format!("{name} {old} → {value} (web page)"),
                },
                // The page checked it against the table it was shown; the model changed since.
                Err(e) => format!("not applied: {e}"),
            };
            console.say(&msg);
            if let Some(s) = &self.shared {
                s.log(&msg);
            }
            st.messages.push(msg);
        }
        any
    }

    /// Moves to a new scene (the caller builds its solver): the time goes on, the frame
    /// builders follow the new model, and it counts as a restart.
    fn replace_scene(&mut self, st: &mut LoopState, scene: Scene) {
        st.time_offset += st.solver.time();
        self.scene = scene;
        st.builder = FrameBuilder::new(&self.scene.model, self.strands, super::STRAND_SUBDIVISIONS);
        if st.render_builder.is_some() {
            st.render_builder = Some(FrameBuilder::new(
                &self.scene.model,
                usize::MAX,
                super::STRAND_SUBDIVISIONS,
            ));
        }
        st.out.restarts += 1;
    }

    /// Tells the control pages what is in force.
    /// The inspected node's numbers of this frame, for the control pages' inspector.
    fn publish_inspected(&self, st: &LoopState, frame: &Frame) {
        let (Some(shared), Some(_)) = (&self.shared, &st.inspect) else {
            return;
        };
        shared.inspect(frame.inspect.as_ref().map(|(path, values)| InspectedNode {
            node: path.replace('/', ":"),
            sim_time: frame.sim_time,
            values: values.clone(),
        }));
    }

    fn publish(&self, st: &LoopState) {
        let Some(shared) = &self.shared else { return };
        let tuning = st.solver.tuning();
        shared.publish(
            &Controls {
                paused: st.paused,
                model: st.solver.kind().name(),
                motion: &self.scene.motion_spec,
                tunables: st
                    .solver
                    .tunables()
                    .iter()
                    .map(|t| t.view(&tuning))
                    .collect(),
            },
            st.time_offset + st.solver.time(),
            st.meter.window_factor(),
        );
    }
}

/// Steps and fills frame `index`.
fn make_frame(
    st: &mut LoopState,
    report: &mut crate::report::StepReport,
    f: &mut Frame,
    index: u64,
) {
    f.step_ms = pipeline::step_frame(&mut *st.solver, report, f);
    // Every strand for the renderer only when it will draw this frame (see `DrawGate`).
    let render = st.render_builder.is_some() && st.draw_gate.as_ref().is_none_or(DrawGate::claim);
    // Otherwise only the drawn strands are read: the solver may place just those.
    let read = (!render).then(|| st.builder.strands());
    st.solver.display_strands(read);
    st.builder.fill(&mut *st.solver, f);
    match st.render_builder.as_mut().filter(|_| render) {
        Some(b) => b.fill_strands(&*st.solver, &mut f.render_strands),
        None => f.render_strands.clear(),
    }
    f.index = index;
    f.sim_time += st.time_offset;
    f.dropped_frames = st.out.dropped;
    f.realtime_factor = st
        .meter
        .frame_done(st.solver.dt() * st.solver.steps_per_frame() as f64);
    st.out.load.add(f, st.solver.steps_per_frame());
    pipeline::fill_stats(f, st.solver.tunables(), &st.solver.tuning());
    if let Some(node) = &st.inspect {
        let (path, values) = f.inspect.get_or_insert_with(Default::default);
        path.clear();
        path.push_str(&node.path());
        // A node the model lost (a restart on another model) logs nothing more; `run` checked
        // the node against the model it started with.
        if st.solver.inspect(node, values).is_err() {
            f.inspect = None;
        }
    } else {
        // (Frames are reused: one inspected before must not keep its numbers.)
        f.inspect = None;
    }
    st.out.splits += f.splits as u64;
    st.out.merges += f.merges as u64;
    st.out.sim_time = f.sim_time;
}

/// Waits until frame `index` is due (live runs keep to wall-clock time).
fn pace(
    stop: &StopSignal,
    origin: &mut Instant,
    origin_index: &mut u64,
    index: u64,
    frame_dt: f64,
) {
    let due = *origin + Duration::from_secs_f64((index - *origin_index) as f64 * frame_dt);
    let now = Instant::now();
    if now > due + MAX_LATENESS {
        *origin = now;
        *origin_index = index;
    }
    while !stop.is_stopped() {
        let now = Instant::now();
        if now >= due {
            break;
        }
        std::thread::sleep((due - now).min(PAUSE_POLL));
    }
}

/// The line a live run says when it falls below real time: how slow, and what it carries
/// that a user can change (model, strands, the threshold that sets the AWT's node count).
pub fn slow_motion_message(solver: &dyn Solver, f: &Frame, rendering: bool) -> String {
    let active: u32 = f.counters.active_per_level.iter().sum();
    let strands = solver.model().strands.len();
    let p = solver.params();
    let cause = match solver.kind() {
        crate::solver::SolverKind::Awt => format!(
            "model awt, {strands} strands, {active} active nodes at split threshold {} \
             N·m·kg⁻¹ (a higher split threshold keeps fewer nodes active)",
            p.split_threshold
        ),
        crate::solver::SolverKind::SingleLevel => format!(
            "model single-level: all {active} finest nodes active, {strands} strands \
             (the AWT adapts and is faster)"
        ),
        crate::solver::SolverKind::Guides => {
            // Chang §4.3's adaptive guides gather in the fastest hair: the cap is the other
            // lever (README, "what to do when under 1", has what a lower one bought).
            let g = solver.tuning().guides;
            format!(
                "model guides, {active} guide strands for {strands} strands (up to {} picked \
                 and {} inserted where neighbours drift apart; fewer: `guides: (count: ..)` \
                 or `guides: (max_inserted: ..)` in the style)",
                g.count, g.max_inserted
            )
        }
        crate::solver::SolverKind::Layered => {
            format!("model layered, {active} skeleton points for {strands} strands")
        }
    };
    let render = if rendering {
        "; rendering shares the cores (--no-render frees them)"
    } else {
        ""
    };
    format!(
        "wisptree: the simulation runs at ×{:.2} of real time (slow motion): {cause}, {:.0} \
         segment pairs in contact per step, {:.1} ms per step{render}",
        f.realtime_factor,
        f64::from(f.counters.pairs_in_contact) / solver.steps_per_frame().max(1) as f64,
        f.step_ms,
    )
}

/// Says once which `sim:` parameters the solver ignores.
fn say_ignored(solver: &dyn Solver, console: &Console, messages: &mut Vec<String>) {
    let ignored = solver.ignored_params();
    if !ignored.is_empty() {
        let msg = format!(
            "model `{}` ignores these sim parameters: {}",
            solver.kind(),
            ignored.join(", ")
        );
        console.say(&msg);
        messages.push(msg);
    }
}

#[cfg(test)]
mod tests;
