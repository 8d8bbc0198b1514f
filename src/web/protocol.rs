//! What the control page and the program say to each other: the tunable parameters and their
//! ranges, the few requests the page may send (checked here, before anything reaches the
//! simulation), and the live state every open page shows.
//!
//! The page builds its sliders from the running solver's table of tunables, which the state
//! carries ([`LiveState::tunables`]): the ranges are written once, in the solver's table, and
//! switching model rebuilds the sliders.

use std::collections::VecDeque;
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::solver::tunable::TunableView;
use crate::solver::{NodeId, SolverKind};

/// A request as the page sends it (JSON, `type` names the kind). Anything else is refused.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum WebRequest {
    /// Set one parameter. The value stays untyped here so that a non-number is refused with its
    /// own message.
    Set {
        /// A tunable of the running model ([`LiveState::tunables`]).
        param: String,
        /// The new value.
        value: serde_json::Value,
    },
    /// Pause (`true`) or resume.
    Pause {
        /// Paused after the request.
        paused: bool,
    },
    /// Restart the simulation with the parameters in force. (A struct variant, so that extra
    /// fields are refused like everywhere else.)
    Restart {},
    /// Restart under another motion preset.
    Motion {
        /// A preset name.
        name: String,
    },
    /// Restart with another hair model.
    Model {
        /// A model name (`awt`, `single-level`, …).
        name: String,
    },
    /// Inspect one node (`TREE:LEVEL:INDEX`, as `run --inspect` takes it), or none (`""`).
    Inspect {
        /// The node, or empty to stop inspecting.
        node: String,
    },
    /// Inspect the node clicked in the viewer's 3D view: the viewer's selection event names
    /// the instance of `/hair/awt/nodes` and the point clicked.
    Pick {
        /// The instance index within the frame's active nodes.
        instance: Option<u64>,
        /// The point clicked, in world coordinates (m).
        position: Option<[f64; 3]>,
    },
}

/// A checked request: what the simulation is asked to do.
#[derive(Debug, Clone, PartialEq)]
pub enum WebCommand {
    /// Set a tunable of the running model (by its table name) to a value its entry allows.
    Set(String, f64),
    /// Pause or resume.
    Pause(bool),
    /// Restart with the parameters in force.
    Restart,
    /// Restart under this motion preset.
    Motion(String),
    /// Restart with this model.
    Model(SolverKind),
    /// Inspect this node from the next frame on (`None`: stop inspecting).
    Inspect(Option<NodeId>),
    /// Inspect the node drawn as this instance, or nearest this point (see
    /// [`crate::solver::Solver::pick_node`]).
    Pick(NodePick),
}

/// A node clicked in the viewer: its instance among the frame's active nodes and the point
/// clicked (either may be missing; one is there).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodePick {
    /// The instance index.
    pub instance: Option<usize>,
    /// The point clicked, m.
    pub position: Option<[f64; 3]>,
}

/// More instances than any frame draws: a larger index is a bad request.
const MAX_INSTANCE: u64 = 100_000_000;

/// A tunable's new value, checked against the running model's table as the page was shown it:
/// what the page server sends the simulation thread directly.
#[derive(Debug, Clone, PartialEq)]
pub struct SetTunable {
    /// The table name.
    pub name: String,
    /// The value.
    pub value: f64,
}

/// Parses and checks one request body against the state in force (the time step bounds the
/// friction). The error is the message the page shows.
pub fn parse_request(body: &str, state: &LiveState) -> Result<WebCommand, String> {
    let req: WebRequest =
        serde_json::from_str(body).map_err(|e| format!("not a request this page sends: {e}"))?;
    check_request(req, state)
}

/// Checks a parsed request (see [`parse_request`]).
pub fn check_request(req: WebRequest, state: &LiveState) -> Result<WebCommand, String> {
    match req {
        WebRequest::Set { param, value } => {
            let spec = state
                .tunables
                .iter()
                .find(|s| s.name == param)
                .ok_or_else(|| {
                    let names: Vec<&str> = state.tunables.iter().map(|t| t.name).collect();
                    format!(
                        "no parameter `{param}` for model {} (its tunables: {})",
                        state.model,
                        names.join(", ")
                    )
                })?;
            let v = value
                .as_f64()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("{}: `{value}` is not a number", spec.label))?;
            spec.check(v)?;
            Ok(WebCommand::Set(spec.name.to_owned(), v))
        }
        WebRequest::Pause { paused } => Ok(WebCommand::Pause(paused)),
        WebRequest::Restart {} => Ok(WebCommand::Restart),
        WebRequest::Motion { name } => {
            if state.motions.contains(&name) {
                Ok(WebCommand::Motion(name))
            } else {
                Err(format!(
                    "no motion `{name}` (known: {})",
                    state.motions.join(", ")
                ))
            }
        }
        WebRequest::Model { name } => SolverKind::parse(&name).map(WebCommand::Model),
        WebRequest::Pick { instance, position } => {
            if instance.is_none() && position.is_none() {
                return Err("pick: neither an instance nor a position".to_owned());
            }
            if instance.is_some_and(|i| i >= MAX_INSTANCE) {
                return Err(format!(
                    "pick: instance {} is out of range",
                    instance.unwrap()
                ));
            }
            if position.is_some_and(|p| p.iter().any(|c| !c.is_finite() || c.abs() > 1e6)) {
                return Err("pick: the position is not a point in the scene".to_owned());
            }
            Ok(WebCommand::Pick(NodePick {
                instance: instance.map(|i| i as usize),
                position,
            }))
        }
        WebRequest::Inspect { node } => {
            let node = node.trim();
            if node.is_empty() {
                return Ok(WebCommand::Inspect(None));
            }
            if node.len() > 40 {
                return Err("inspect: a node is TREE:LEVEL:INDEX (0:1:12)".to_owned());
            }
            // Whether the node exists is the simulation's to say: it holds the model.
            NodeId::parse(node)
                .map(|n| WebCommand::Inspect(Some(n)))
                .map_err(|e| format!("inspect {e}"))
        }
    }
}

/// One line of the run's log, as the page lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LogLine {
    /// Counts up over the run (the page shows each line once).
    pub seq: u64,
    /// The text, as logged to `/log`.
    pub text: String,
}

/// Lines kept for pages that open late.
const LOG_LINES: usize = 50;

/// What every open page shows, published by the simulation thread.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LiveState {
    /// Counts changes of anything but the time, so a page knows when to refresh its controls.
    pub version: u64,
    /// Simulated time, s.
    pub sim_time: f64,
    /// Paused.
    pub paused: bool,
    /// The model in force (`awt`, …).
    pub model: String,
    /// The motion in force.
    pub motion: String,
    /// The running model's tunables (its table) and their values in force.
    pub tunables: Vec<TunableView>,
    /// The same values by name (`params.split_threshold`), for scripts reading the state.
    pub params: std::collections::BTreeMap<&'static str, f64>,
    /// Simulated over wall seconds over the last second (1: live).
    pub realtime_factor: f64,
    /// The real-time factor when the running simulation cannot keep up (the page's state line
    /// says "slow motion"); `null` when it keeps up or is paused.
    pub slow_motion: Option<f64>,
    /// The models the page offers.
    pub models: Vec<String>,
    /// The motion presets the page offers.
    pub motions: Vec<String>,
    /// The latest lines of the run's log.
    pub log: VecDeque<LogLine>,
    /// The inspected node's numbers at the latest frame (`None`: no node inspected).
    pub inspect: Option<InspectedNode>,
}

/// One node's numbers as the page's inspector shows them (the same names and values a
/// recording holds under `/inspect/<tree>/<level>/<index>/<name>`).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct InspectedNode {
    /// `TREE:LEVEL:INDEX`.
    pub node: String,
    /// Simulated time of these numbers.
    pub sim_time: f64,
    /// The numbers by name, in the solver's order.
    pub values: Vec<(&'static str, f64)>,
}

/// The state shared by the simulation thread (writer) and the page server (reader).
#[derive(Debug, Default)]
pub struct SharedState {
    state: Mutex<LiveState>,
}

impl SharedState {
    /// A state with these choices on offer.
    pub fn new(models: Vec<String>, motions: Vec<String>) -> SharedState {
        SharedState {
            state: Mutex::new(LiveState {
                models,
                motions,
                ..LiveState::default()
            }),
        }
    }

    /// A copy of the state now.
    pub fn snapshot(&self) -> LiveState {
        self.lock().clone()
    }

    /// Publishes the controls' values; the version moves only if one changed.
    pub fn publish(&self, controls: &Controls<'_>, sim_time: f64, realtime_factor: f64) {
        let mut s = self.lock();
        s.sim_time = sim_time;
        s.realtime_factor = realtime_factor;
        s.slow_motion = (!controls.paused && realtime_factor < crate::report::tempo::SLOW_BELOW)
            .then_some(realtime_factor);
        let changed = s.paused != controls.paused
            || s.model != controls.model
            || s.motion != controls.motion
            || s.tunables != controls.tunables;
        if changed {
            s.paused = controls.paused;
            s.model = controls.model.to_owned();
            s.motion = controls.motion.to_owned();
            s.tunables.clone_from(&controls.tunables);
            s.params = controls
                .tunables
                .iter()
                .map(|t| (t.name, t.value))
                .collect();
            s.version += 1;
        }
    }

    /// The inspected node's numbers at the latest frame. Not a new version: like the time,
    /// they change every frame and the page shows them at each poll.
    pub fn inspect(&self, node: Option<InspectedNode>) {
        self.lock().inspect = node;
    }

    /// Adds a line to the log every page lists.
    pub fn log(&self, text: &str) {
        let mut s = self.lock();
        let seq = s.log.back().map_or(1, |l| l.seq + 1);
        s.log.push_back(LogLine {
            seq,
            text: text.to_owned(),
        });
        while s.log.len() > LOG_LINES {
            s.log.pop_front();
        }
        s.version += 1;
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, LiveState> {
        // A panic elsewhere while holding the lock leaves plain data: keep serving it.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The values [`SharedState::publish`] takes.
#[derive(Debug, Clone)]
pub struct Controls<'a> {
    /// Paused.
    pub paused: bool,
    /// The model's name.
    pub model: &'a str,
    /// The motion's name.
    pub motion: &'a str,
    /// The running model's tunables and their values.
    pub tunables: Vec<TunableView>,
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::solver::tunable::Tuning;

    /// The state of an AWT run at the defaults (dt = 0.01 s).
    fn state() -> LiveState {
        state_of(SolverKind::Awt, &Tuning::default())
    }

    fn state_of(kind: SolverKind, t: &Tuning) -> LiveState {
        LiveState {
            model: kind.name().into(),
            tunables: kind.tunables().iter().map(|e| e.view(t)).collect(),
            motions: vec!["still".into(), "lean".into()],
            ..LiveState::default()
        }
    }

    #[test]
    fn a_value_inside_its_range_is_accepted() {
        let c = parse_request(
            r#"{"type":"set","param":"split_threshold","value":0.25}"#,
            &state(),
        );
        assert_eq!(c, Ok(WebCommand::Set("split_threshold".into(), 0.25)));
    }

    #[test]
    fn out_of_range_values_and_non_numbers_are_refused_naming_the_parameter() {
        for (body, needle) in [
            (
                r#"{"type":"set","param":"split_threshold","value":5}"#,
                "between 0.05 and 1",
            ),
            (
                r#"{"type":"set","param":"split_threshold","value":0.01}"#,
                "between",
            ),
            (
                r#"{"type":"set","param":"merge_velocity","value":"fast"}"#,
                "not a number",
            ),
            (
                r#"{"type":"set","param":"repulsion","value":null}"#,
                "not a number",
            ),
            (
                r#"{"type":"set","param":"wind","value":-1}"#,
                "wind strength",
            ),
            (
                r#"{"type":"set","param":"gravity","value":1}"#,
                "no parameter `gravity` for model awt",
            ),
            // Another model's tunable is not the AWT's.
            (
                r#"{"type":"set","param":"viscosity","value":1}"#,
                "its tunables: split_threshold",
            ),
        ] {
            let e = parse_request(body, &state()).unwrap_err();
            assert!(e.contains(needle), "{body}: {e}");
        }
    }

    #[test]
    fn friction_must_keep_alpha_dt_below_one() {
        let ok = parse_request(r#"{"type":"set","param":"friction","value":99}"#, &state());
        assert_eq!(ok, Ok(WebCommand::Set("friction".into(), 99.0)));
        let e = parse_request(r#"{"type":"set","param":"friction","value":100}"#, &state())
            .unwrap_err();
        assert!(e.contains("α·dt"), "{e}");
        let mut t = Tuning::default();
        t.sim.dt = 0.001;
        let fine_dt = state_of(SolverKind::Awt, &t);
        let ok = parse_request(r#"{"type":"set","param":"friction","value":500}"#, &fine_dt);
        assert_eq!(ok, Ok(WebCommand::Set("friction".into(), 500.0)));
    }

    #[test]
    fn the_layered_and_guide_models_take_their_own_tunables() {
        let layered = state_of(SolverKind::Layered, &Tuning::default());
        assert_eq!(
            parse_request(r#"{"type":"set","param":"viscosity","value":50}"#, &layered),
            Ok(WebCommand::Set("viscosity".into(), 50.0))
        );
        let e = parse_request(
            r#"{"type":"set","param":"split_threshold","value":0.2}"#,
            &layered,
        )
        .unwrap_err();
        assert!(e.contains("for model layered"), "{e}");
        let guides = state_of(SolverKind::Guides, &Tuning::default());
        assert_eq!(
            parse_request(
                r#"{"type":"set","param":"link_strength","value":600}"#,
                &guides
            ),
            Ok(WebCommand::Set("link_strength".into(), 600.0))
        );
        let e = parse_request(r#"{"type":"set","param":"strip_break","value":1}"#, &guides)
            .unwrap_err();
        assert!(
            e.contains("strip break ratio") && e.contains("between"),
            "{e}"
        );
    }

    #[test]
    fn the_inspector_takes_a_node_or_none() {
        assert_eq!(
            parse_request(r#"{"type":"inspect","node":" 3:1:12 "}"#, &state()),
            Ok(WebCommand::Inspect(Some(NodeId {
                tree: 3,
                level: 1,
                index: 12
            })))
        );
        assert_eq!(
            parse_request(r#"{"type":"inspect","node":""}"#, &state()),
            Ok(WebCommand::Inspect(None))
        );
        for (body, needle) in [
            (r#"{"type":"inspect","node":"3:1"}"#, "TREE:LEVEL:INDEX"),
            (r#"{"type":"inspect","node":"3:-1:2"}"#, "LEVEL `-1`"),
            (r#"{"type":"inspect","node":7}"#, "not a request"),
        ] {
            let e = parse_request(body, &state()).unwrap_err();
            assert!(e.contains(needle), "{body}: {e}");
        }
        let long = format!(r#"{{"type":"inspect","node":"{}"}}"#, "1".repeat(100));
        assert!(parse_request(&long, &state()).is_err());
    }

    #[test]
    fn only_the_pages_messages_are_taken() {
        for body in [
            r#"{"type":"shutdown"}"#,
            r#"{"type":"restart","now":true}"#,
            r#"not json"#,
            r#"{"param":"split_threshold","value":0.2}"#,
        ] {
            assert!(parse_request(body, &state()).is_err(), "{body}");
        }
        assert_eq!(
            parse_request(r#"{"type":"pause","paused":true}"#, &state()),
            Ok(WebCommand::Pause(true))
        );
        assert_eq!(
            parse_request(r#"{"type":"model","name":"single-level"}"#, &state()),
            Ok(WebCommand::Model(SolverKind::SingleLevel))
        );
        assert!(parse_request(r#"{"type":"model","name":"magic"}"#, &state()).is_err());
        assert_eq!(
            parse_request(r#"{"type":"motion","name":"lean"}"#, &state()),
            Ok(WebCommand::Motion("lean".into()))
        );
        assert!(parse_request(r#"{"type":"motion","name":"/etc/passwd"}"#, &state()).is_err());
    }

    #[test]
    fn the_version_moves_when_a_control_changes_and_not_with_time() {
        let s = SharedState::new(vec![], vec![]);
        let c = Controls {
            paused: false,
            model: "awt",
            motion: "lean",
            tunables: vec![],
        };
        s.publish(&c, 0.0, 1.0);
        let v = s.snapshot().version;
        s.publish(&c, 1.0, 0.5);
        assert_eq!(s.snapshot().version, v);
        assert_eq!(s.snapshot().sim_time, 1.0);
        s.publish(
            &Controls {
                paused: true,
                ..c.clone()
            },
            1.0,
            1.0,
        );
        assert_eq!(s.snapshot().version, v + 1);
        s.log("hello");
        assert_eq!(
            s.snapshot().log.back().map(|l| l.text.as_str()),
            Some("hello")
        );
    }

    #[test]
    fn the_state_says_slow_motion_only_while_running_below_real_time() {
        let s = SharedState::new(vec![], vec![]);
        let c = Controls {
            paused: false,
            model: "guides",
            motion: "shake",
            tunables: vec![],
        };
        s.publish(&c, 1.0, 0.4);
        assert_eq!(s.snapshot().slow_motion, Some(0.4));
        assert_eq!(s.snapshot().realtime_factor, 0.4);
        // Keeping up (a paced run reads 1 within its sleeps' jitter): no slow motion.
        s.publish(&c, 2.0, 0.995);
        assert_eq!(s.snapshot().slow_motion, None);
        // Paused: nothing moves, so nothing is slow.
        s.publish(
            &Controls {
                paused: true,
                ..c.clone()
            },
            2.0,
            0.1,
        );
        assert_eq!(s.snapshot().slow_motion, None);
    }
}
