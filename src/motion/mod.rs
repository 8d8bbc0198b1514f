//! Head and body motion: simulated time → one rigid transform (and its velocities) that moves
//! the scalp roots and the body spheres together.
//!
//! Every motion, preset or keyframed, is written the same way: a pivot `p` (a rest-pose point),
//! Euler angles `e(t) = (α, β, γ)` (rotation about x, then y, then z, in the fixed world axes:
//! `R = Rz(γ) Ry(β) Rx(α)`) and an offset `T(t)`. A rest point `x` goes to
//! `R (x − p) + p + T`. Each channel is a scalar function given with its analytic time
//! derivative, so positions and velocities come from the same formula and agree exactly; no
//! finite difference is involved (the tests check the velocities against finite differences).
//!
//! Conventions: SI units, y up, the face looking towards +z, so leaning forward is a positive
//! rotation about +x. The presets start at rest (identity pose, zero velocity and zero
//! acceleration at t = 0) and ease in with quintic "smootherstep" ramps, so the hair is not
//! jerked on the first step.

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Point3, Vector3};

mod keyframes;
mod presets;

use keyframes::*;
use presets::*;

/// The rigid pose of the character at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Maps rest-pose points to world points.
    pub iso: Isometry3<f64>,
    /// World velocity of the point at `iso.translation` (the image of the rest origin), m/s.
    pub linear_velocity: Vector3<f64>,
    /// World-frame angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
}

impl Pose {
    /// The rest pose, not moving.
    pub fn identity() -> Pose {
        Pose {
            iso: Isometry3::identity(),
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
        }
    }

    /// World position of a rest-pose point.
    pub fn transform_point(&self, rest: &Point3<f64>) -> Point3<f64> {
        self.iso.transform_point(rest)
    }

    /// World direction of a rest-pose vector (rotation only).
    pub fn transform_vector(&self, rest: &Vector3<f64>) -> Vector3<f64> {
        self.iso.transform_vector(rest)
    }

    /// Velocity of the body's material point currently at `world`.
    pub fn velocity_at(&self, world: &Point3<f64>) -> Vector3<f64> {
        self.linear_velocity
            + self
                .angular_velocity
                .cross(&(world.coords - self.iso.translation.vector))
    }
}

/// Anything wrong with a motion spec or a keyframed motion file. Messages name the file, the
/// position where there is one, and the field.
#[derive(Debug, thiserror::Error)]
pub enum MotionError {
    #[error("unknown motion `{spec}`: expected one of the presets {} or a path to a keyframed `.ron` motion", presets.join(", "))]
    /// A motion name that is neither a preset nor a file.
    UnknownPreset {
        /// What was given.
        spec: String,
        /// The presets there are.
        presets: Vec<&'static str>,
    },
    // The reason is in the message and not a `#[source]`: the error chain would print it twice.
    #[error("{path}: cannot read motion file: {error}")]
    /// A motion file that cannot be read.
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    #[error("{path}:{line}:{col}: {msg}")]
    /// A motion file that is not valid RON.
    Parse {
        /// The file.
        path: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        col: usize,
        /// What is wrong.
        msg: String,
    },
    #[error("{path}{}: field `{field}`: {msg}", pos.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    /// A value in a motion file that is out of range.
    Invalid {
        /// The file.
        path: PathBuf,
        /// Line and column of the offending field, when it can be found in the text.
        pos: Option<(usize, usize)>,
        /// The field, as a dotted path.
        field: String,
        /// What is wrong.
        msg: String,
    },
}

/// A head/body motion: a preset or a keyframed file, ready to be sampled at any time.
#[derive(Debug, Clone)]
pub struct Motion {
    name: String,
    /// Rest-pose point the rotation is about.
    pivot: Point3<f64>,
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Still,
    Lean,
    Run,
    Jump,
    Shake,
    Stop,
    Keyframed(Box<Keyframes>),
}

const PRESETS: &[&str] = &["still", "lean", "run", "jump", "shake", "stop"];

/// Hips below the scalp centre (a standing adult: scalp centre ≈ 1.65 m, hips ≈ 1.05 m).
const HIPS_BELOW_SCALP: f64 = 0.6;
/// Neck pivot (atlas joint region) below the scalp centre.
const NECK_BELOW_SCALP: f64 = 0.12;

// `lean`: the AWT benchmark motion (§5.2: "same (leaning) motion of the character body").
/// (time in the cycle, s; angle about +x, degrees). Each transition is a quintic ease, so the
/// torso pauses briefly at each extreme, the way a person leans forward and back.
const LEAN_KEYS: &[(f64, f64)] = &[(0.0, 0.0), (0.8, 35.0), (1.7, -10.0), (2.2, 0.0)];

// `run`
const RUN_SPEED: f64 = 3.0;
const RUN_RAMP: f64 = 1.0;
const RUN_STEP_HZ: f64 = 2.8;
/// Half the 4 cm peak-to-peak vertical bob.
const RUN_BOB: f64 = 0.02;
/// Lateral sway at the stride frequency (half the step frequency).
const RUN_SWAY: f64 = 0.015;
const RUN_LEAN_DEG: f64 = 10.0;

// `jump`
const GRAVITY: f64 = 9.81;
const JUMP_HEIGHT: f64 = 0.25;
const JUMP_PERIOD: f64 = 1.2;
const JUMP_CROUCH: f64 = 0.15;
/// First crouch from standing, before the first take-off.
const JUMP_FIRST_CROUCH: f64 = 0.5;
/// Push-off and landing durations. Both are below 3·crouch/v₀ ≈ 0.203 s, which keeps the
/// cubic Hermite pieces monotonic (no dip under the crouch depth, no bump above ground).
const JUMP_PUSH: f64 = 0.2;
const JUMP_LAND: f64 = 0.2;

// `shake`
const SHAKE_DEG: f64 = 40.0;
const SHAKE_HZ: f64 = 2.0;
const SHAKE_RAMP: f64 = 0.5;

// `stop`: a quick body turn with a lean and a step, then rest.
const STOP_RISE: f64 = 0.25;
const STOP_CRUISE_END: f64 = 1.0;
const STOP_END: f64 = 1.2;
const STOP_YAW_DEG: f64 = 90.0;
const STOP_LEAN_DEG: f64 = 20.0;
const STOP_STEP: f64 = 0.5;

impl Motion {
    /// `spec` is a preset name (still, lean, run, jump, shake, stop) or a path to a keyframed
    /// `.ron` motion. `anchor` is the rest-pose scalp centre: presets place their pivots
    /// relative to it (hips = anchor − (0, 0.6, 0), neck = anchor − (0, 0.12, 0)), so they work
    /// for any head height; a keyframed file's `pivot` is relative to it too.
    pub fn parse(spec: &str, anchor: Point3<f64>) -> Result<Motion, MotionError> {
        let hips = anchor - Vector3::new(0.0, HIPS_BELOW_SCALP, 0.0);
        let neck = anchor - Vector3::new(0.0, NECK_BELOW_SCALP, 0.0);
        let preset = |kind, pivot| {
            Ok(Motion {
                name: spec.to_string(),
                pivot,
                kind,
            })
        };
        match spec {
            "still" => preset(Kind::Still, anchor),
            "lean" => preset(Kind::Lean, hips),
            "run" => preset(Kind::Run, hips),
            "jump" => preset(Kind::Jump, hips),
            "shake" => preset(Kind::Shake, neck),
            "stop" => preset(Kind::Stop, hips),
            _ => {
                let path = Path::new(spec);
                let looks_like_path = spec.ends_with(".ron")
                    || spec.contains('/')
                    || spec.contains(std::path::MAIN_SEPARATOR)
                    || path.exists();
                if !looks_like_path {
                    return Err(MotionError::UnknownPreset {
                        spec: spec.to_string(),
                        presets: PRESETS.to_vec(),
                    });
                }
                let text = std::fs::read_to_string(path).map_err(|error| MotionError::Io {
                    path: path.to_path_buf(),
                    error,
                })?;
                Self::from_ron(path, &text, anchor)
            }
        }
    }

    /// Parses keyframed motion text; `path` names it in errors and gives the default name.
    pub fn from_ron(path: &Path, text: &str, anchor: Point3<f64>) -> Result<Motion, MotionError> {
        let file: KeyframedMotion =
            ron::Options::default()
                .from_str(text)
                .map_err(|e: ron::error::SpannedError| MotionError::Parse {
                    path: path.to_path_buf(),
                    line: e.span.start.line,
                    col: e.span.start.col,
                    msg: e.code.to_string(),
                })?;
        let keys = Keyframes::new(&file).map_err(|(field, key, msg)| MotionError::Invalid {
            path: path.to_path_buf(),
            pos: locate_field(text, &field, key),
            field: match key {
                Some(i) => format!("keys[{i}].{field}"),
                None => field,
            },
            msg,
        })?;
        let name = if file.name.is_empty() {
            path.file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "keyframed".to_string())
        } else {
            file.name.clone()
        };
        Ok(Motion {
            name,
            pivot: anchor + Vector3::from(file.pivot),
            kind: Kind::Keyframed(Box::new(keys)),
        })
    }

    /// The preset names `parse` accepts.
    pub fn preset_names() -> &'static [&'static str] {
        PRESETS
    }

    /// The preset name, or the keyframed motion's `name` (default: the file stem).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Pose at simulated time `t ≥ 0` (`t < 0` behaves as 0). Deterministic and C1: positions
    /// and velocities are continuous, and the velocities are the exact derivatives of the
    /// positions.
    pub fn pose(&self, t: f64) -> Pose {
        let t = if t > 0.0 { t } else { 0.0 }; // also maps NaN to 0
        let s = match &self.kind {
            Kind::Still => Sample::rest(),
            Kind::Lean => lean(t),
            Kind::Run => run(t),
            Kind::Jump => jump(t),
            Kind::Shake => shake(t),
            Kind::Stop => stop(t),
            Kind::Keyframed(k) => k.sample(t),
        };
        s.pose(&self.pivot)
    }

    /// A one-line description for --help / logs.
    pub fn describe(&self) -> String {
        let p = self.pivot;
        match &self.kind {
            Kind::Still => "still: the head does not move".to_string(),
            Kind::Lean => format!(
                "lean: the torso leans {}° forward and {}° back about the hips, every {} s (the AWT paper's benchmark)",
                LEAN_KEYS[1].1, -LEAN_KEYS[2].1, LEAN_KEYS[3].0
            ),
            Kind::Run => format!(
                "run: forward (+z) at up to {RUN_SPEED} m/s, {} cm bob at {RUN_STEP_HZ} steps/s, {RUN_LEAN_DEG}° forward lean",
                2.0 * RUN_BOB * 100.0
            ),
            Kind::Jump => format!(
                "jump: crouch and jump {} cm high every {JUMP_PERIOD} s",
                JUMP_HEIGHT * 100.0
            ),
            Kind::Shake => format!(
                "shake: head shakes \"no\" ±{SHAKE_DEG}° about the neck at {SHAKE_HZ} Hz"
            ),
            Kind::Stop => format!(
                "stop: a quick {STOP_YAW_DEG}° turn with a lean and a {STOP_STEP} m step, then still from {STOP_END} s on"
            ),
            Kind::Keyframed(k) => format!(
                "{}: {} keys over {:.3} s{}, rotating about ({:.3}, {:.3}, {:.3}) m",
                self.name,
                k.times.len(),
                k.times[k.times.len() - 1] - k.times[0],
                if k.looping { ", looping" } else { "" },
                p.x,
                p.y,
                p.z
            ),
        }
    }
}
