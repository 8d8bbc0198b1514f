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

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use serde::Deserialize;

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
    UnknownPreset {
        spec: String,
        presets: Vec<&'static str>,
    },
    #[error("{path}: cannot read motion file: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}:{line}:{col}: {msg}")]
    Parse {
        path: PathBuf,
        line: usize,
        col: usize,
        msg: String,
    },
    #[error("{path}{}: field `{field}`: {msg}", pos.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Invalid {
        path: PathBuf,
        /// Line and column of the offending field, when it can be found in the text.
        pos: Option<(usize, usize)>,
        field: String,
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
                let text = std::fs::read_to_string(path).map_err(|source| MotionError::Io {
                    path: path.to_path_buf(),
                    source,
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

/// The channels of a motion at one instant, with their time derivatives.
#[derive(Debug, Clone, Copy)]
struct Sample {
    /// Euler angles (x, y, z), radians, `R = Rz Ry Rx`.
    angles: Vector3<f64>,
    angle_rates: Vector3<f64>,
    /// World offset of the pivot.
    offset: Vector3<f64>,
    offset_rate: Vector3<f64>,
}

impl Sample {
    fn rest() -> Sample {
        Sample {
            angles: Vector3::zeros(),
            angle_rates: Vector3::zeros(),
            offset: Vector3::zeros(),
            offset_rate: Vector3::zeros(),
        }
    }

    fn pose(&self, pivot: &Point3<f64>) -> Pose {
        let (a, b, c) = (self.angles.x, self.angles.y, self.angles.z);
        let rz = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), c);
        let ry = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), b);
        let rx = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), a);
        let rot = rz * ry * rx;
        // ω of Rz(γ)Ry(β)Rx(α): each rate about its axis as carried by the rotations applied
        // after it.
        let rates = self.angle_rates;
        let omega = Vector3::z() * rates.z
            + rz.transform_vector(&Vector3::y()) * rates.y
            + (rz * ry).transform_vector(&Vector3::x()) * rates.x;
        // x ↦ R(x − p) + p + T  ⇒  translation τ = p + T − R p, τ̇ = Ṫ − ω × (R p).
        let rp = rot.transform_vector(&pivot.coords);
        let tau = pivot.coords + self.offset - rp;
        Pose {
            iso: Isometry3::from_parts(Translation3::from(tau), rot),
            linear_velocity: self.offset_rate - omega.cross(&rp),
            angular_velocity: omega,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Scalar building blocks, each returning (value, time derivative).

/// Quintic smootherstep on [0, 1] (clamped): zero slope and curvature at both ends.
fn smootherstep(u: f64) -> (f64, f64) {
    if u <= 0.0 {
        (0.0, 0.0)
    } else if u >= 1.0 {
        (1.0, 0.0)
    } else {
        let u2 = u * u;
        let u3 = u2 * u;
        (
            u3 * (10.0 + u * (-15.0 + 6.0 * u)),
            30.0 * u2 * (1.0 - u) * (1.0 - u),
        )
    }
}

/// Envelope rising from 0 to 1 over `[0, ramp]` seconds.
fn envelope(t: f64, ramp: f64) -> (f64, f64) {
    let (s, ds) = smootherstep(t / ramp);
    (s, ds / ramp)
}

/// Distance covered when the speed rises from 0 to `v` along a smootherstep over `ramp`
/// seconds and then stays at `v`: the integral of `v · smootherstep(t / ramp)`.
fn ramped_distance(t: f64, v: f64, ramp: f64) -> (f64, f64) {
    if t <= 0.0 {
        return (0.0, 0.0);
    }
    let u = t / ramp;
    if u >= 1.0 {
        return (v * ramp * 0.5 + v * (t - ramp), v);
    }
    let u4 = u * u * u * u;
    let x = v * ramp * u4 * (2.5 + u * (-3.0 + u));
    (x, v * smootherstep(u).0)
}

/// Progress 0 → 1 with a smooth trapezoidal speed profile: speed rises over `[0, a]`, holds
/// over `[a, b]`, falls to zero over `[b, c]`; exactly 1 with zero speed from `c` on.
fn trapezoid(t: f64, a: f64, b: f64, c: f64) -> (f64, f64) {
    if t >= c {
        return (1.0, 0.0);
    }
    // Speed v·smootherstep ramps; the ramps cover half their duration on average.
    let v = 1.0 / (0.5 * a + (b - a) + 0.5 * (c - b));
    if t <= b {
        return ramped_distance(t, v, a);
    }
    // Mirror of a rise: distance left to cover = ramped_distance of the time left.
    let (left, speed) = ramped_distance(c - t, v, c - b);
    (1.0 - left, speed)
}

/// Cubic Hermite on `[0, dur]` from value `p0` (slope `m0`) to `p1` (slope `m1`).
fn hermite(p0: f64, m0: f64, p1: f64, m1: f64, dur: f64, t: f64) -> (f64, f64) {
    let s = t / dur;
    let s2 = s * s;
    let s3 = s2 * s;
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    let d00 = 6.0 * s2 - 6.0 * s;
    let d10 = 3.0 * s2 - 4.0 * s + 1.0;
    let d01 = -6.0 * s2 + 6.0 * s;
    let d11 = 3.0 * s2 - 2.0 * s;
    (
        h00 * p0 + h10 * dur * m0 + h01 * p1 + h11 * dur * m1,
        (d00 * p0 + d01 * p1) / dur + d10 * m0 + d11 * m1,
    )
}

// ---------------------------------------------------------------------------------------------
// Presets.

fn lean(t: f64) -> Sample {
    let period = LEAN_KEYS[LEAN_KEYS.len() - 1].0;
    let tc = t % period;
    let i = LEAN_KEYS
        .windows(2)
        .position(|w| tc < w[1].0)
        .unwrap_or(LEAN_KEYS.len() - 2);
    let ((t0, a0), (t1, a1)) = (LEAN_KEYS[i], LEAN_KEYS[i + 1]);
    let (s, ds) = smootherstep((tc - t0) / (t1 - t0));
    let mut out = Sample::rest();
    out.angles.x = (a0 + (a1 - a0) * s).to_radians();
    out.angle_rates.x = ((a1 - a0) * ds / (t1 - t0)).to_radians();
    out
}

fn run(t: f64) -> Sample {
    let (e, de) = envelope(t, RUN_RAMP);
    let w = std::f64::consts::TAU * RUN_STEP_HZ;
    let (z, dz) = ramped_distance(t, RUN_SPEED, RUN_RAMP);
    // Lowest at each mid-stance, back to standing height in between.
    let (bob, dbob) = ((w * t).cos() - 1.0, -w * (w * t).sin());
    // One full left-right sway per stride (two steps).
    let (sway, dsway) = ((0.5 * w * t).sin(), 0.5 * w * (0.5 * w * t).cos());
    let mut out = Sample::rest();
    out.offset = Vector3::new(RUN_SWAY * e * sway, RUN_BOB * e * bob, z);
    out.offset_rate = Vector3::new(
        RUN_SWAY * (de * sway + e * dsway),
        RUN_BOB * (de * bob + e * dbob),
        dz,
    );
    out.angles.x = RUN_LEAN_DEG.to_radians() * e;
    out.angle_rates.x = RUN_LEAN_DEG.to_radians() * de;
    out
}

/// Vertical hip offset of the jump: a first crouch from standing, then a periodic cycle of
/// push-off, ballistic flight (exact parabola under g), landing, and crouch hold.
fn jump_height(t: f64) -> (f64, f64) {
    let d = JUMP_CROUCH;
    if t < JUMP_FIRST_CROUCH {
        let (s, ds) = envelope(t, JUMP_FIRST_CROUCH);
        return (-d * s, -d * ds);
    }
    let v0 = (2.0 * GRAVITY * JUMP_HEIGHT).sqrt();
    let flight = 2.0 * v0 / GRAVITY;
    let tc = (t - JUMP_FIRST_CROUCH) % JUMP_PERIOD;
    if tc < JUMP_PUSH {
        return hermite(-d, 0.0, 0.0, v0, JUMP_PUSH, tc);
    }
    let tf = tc - JUMP_PUSH;
    if tf < flight {
        return (v0 * tf - 0.5 * GRAVITY * tf * tf, v0 - GRAVITY * tf);
    }
    let tl = tf - flight;
    if tl < JUMP_LAND {
        return hermite(0.0, -v0, -d, 0.0, JUMP_LAND, tl);
    }
    (-d, 0.0) // crouched, waiting for the next push-off
}

fn jump(t: f64) -> Sample {
    let (y, dy) = jump_height(t);
    let mut out = Sample::rest();
    out.offset.y = y;
    out.offset_rate.y = dy;
    out
}

fn shake(t: f64) -> Sample {
    let (e, de) = envelope(t, SHAKE_RAMP);
    let w = std::f64::consts::TAU * SHAKE_HZ;
    let amp = SHAKE_DEG.to_radians();
    let mut out = Sample::rest();
    out.angles.y = amp * e * (w * t).sin();
    out.angle_rates.y = amp * (de * (w * t).sin() + e * w * (w * t).cos());
    out
}

fn stop(t: f64) -> Sample {
    let (s, ds) = trapezoid(t, STOP_RISE, STOP_CRUISE_END, STOP_END);
    let pi = std::f64::consts::PI;
    let mut out = Sample::rest();
    // Lean forward and back upright during the move, so the end pose is upright.
    out.angles.x = STOP_LEAN_DEG.to_radians() * (pi * s).sin();
    out.angle_rates.x = STOP_LEAN_DEG.to_radians() * pi * (pi * s).cos() * ds;
    out.angles.y = STOP_YAW_DEG.to_radians() * s;
    out.angle_rates.y = STOP_YAW_DEG.to_radians() * ds;
    out.offset.z = STOP_STEP * s;
    out.offset_rate.z = STOP_STEP * ds;
    out
}

// ---------------------------------------------------------------------------------------------
// Keyframed motions.

/// The `.ron` schema of a keyframed motion.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "KeyframedMotion")]
struct KeyframedMotion {
    /// Default (empty): the file stem.
    #[serde(default)]
    name: String,
    /// Rotation centre, relative to the scalp centre (anchor), metres. Default (0, 0, 0).
    #[serde(default)]
    pivot: [f64; 3],
    /// Repeat from the first key after the last; the last key must then equal the first.
    #[serde(default)]
    looping: bool,
    keys: Vec<Key>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Key {
    /// Seconds, ≥ 0, strictly increasing.
    time: f64,
    /// Pivot offset in world axes, metres. Default (0, 0, 0).
    #[serde(default)]
    translation: [f64; 3],
    /// Euler angles in degrees about x, then y, then z (fixed axes), default (0, 0, 0).
    #[serde(default)]
    rotation: [f64; 3],
}

/// Validated keys with precomputed Catmull-Rom tangents.
///
/// Interpolation: each of the six channels (translation xyz, Euler angles xyz) is a cubic
/// Hermite spline through the keys with Catmull-Rom tangents for uneven spacing,
/// `m_i = (p_{i+1} − p_{i−1}) / (t_{i+1} − t_{i−1})`. Euler angles rather than quaternion
/// squad: the angular velocity then has a closed form and head motions stay far from gimbal
/// lock. A non-looping motion has zero tangents at both ends and holds the end keys outside
/// them. A looping motion uses periodic tangents, except on the first pass where the first key
/// has a zero tangent, so it starts at rest.
#[derive(Debug, Clone)]
struct Keyframes {
    looping: bool,
    times: Vec<f64>,
    /// Per key: translation (metres) then Euler angles (radians).
    values: Vec<[f64; 6]>,
    tangents: Vec<[f64; 6]>,
}

type KeyError = (String, Option<usize>, String);

impl Keyframes {
    fn new(file: &KeyframedMotion) -> Result<Keyframes, KeyError> {
        let keys = &file.keys;
        let err = |field: &str, key: Option<usize>, msg: String| Err((field.to_string(), key, msg));
        if file.pivot.iter().any(|v| !v.is_finite()) {
            return err("pivot", None, "must be finite".into());
        }
        if keys.len() < 2 {
            return err(
                "keys",
                None,
                format!("a motion needs at least 2 keys, found {}", keys.len()),
            );
        }
        for (i, k) in keys.iter().enumerate() {
            if !k.time.is_finite() || k.time < 0.0 {
                return err(
                    "time",
                    Some(i),
                    format!("must be a finite time ≥ 0 s, found {}", k.time),
                );
            }
            if i > 0 && k.time <= keys[i - 1].time {
                return err(
                    "time",
                    Some(i),
                    format!(
                        "key times must be strictly increasing: {} s follows {} s",
                        k.time,
                        keys[i - 1].time
                    ),
                );
            }
            if k.translation.iter().any(|v| !v.is_finite()) {
                return err("translation", Some(i), "must be finite".into());
            }
            if k.rotation.iter().any(|v| !v.is_finite()) {
                return err("rotation", Some(i), "must be finite".into());
            }
        }
        let n = keys.len();
        if file.looping {
            let (first, last) = (&keys[0], &keys[n - 1]);
            let close =
                |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9);
            if !close(&first.translation, &last.translation) {
                return err(
                    "translation",
                    Some(n - 1),
                    "a looping motion must end where it starts: the last key's translation must equal the first key's".into(),
                );
            }
            if !close(&first.rotation, &last.rotation) {
                return err(
                    "rotation",
                    Some(n - 1),
                    "a looping motion must end where it starts: the last key's rotation must equal the first key's".into(),
                );
            }
        }
        let times: Vec<f64> = keys.iter().map(|k| k.time).collect();
        let values: Vec<[f64; 6]> = keys
            .iter()
            .map(|k| {
                let (t, r) = (k.translation, k.rotation);
                [
                    t[0],
                    t[1],
                    t[2],
                    r[0].to_radians(),
                    r[1].to_radians(),
                    r[2].to_radians(),
                ]
            })
            .collect();
        let tangent = |prev: usize, next: usize, dt: f64| -> [f64; 6] {
            std::array::from_fn(|c| (values[next][c] - values[prev][c]) / dt)
        };
        let mut tangents = vec![[0.0; 6]; n];
        for i in 1..n - 1 {
            tangents[i] = tangent(i - 1, i + 1, times[i + 1] - times[i - 1]);
        }
        if file.looping {
            // The first and last keys are the same instant of the cycle.
            let dt = (times[1] - times[0]) + (times[n - 1] - times[n - 2]);
            let m = tangent(n - 2, 1, dt);
            tangents[0] = m;
            tangents[n - 1] = m;
        }
        Ok(Keyframes {
            looping: file.looping,
            times,
            values,
            tangents,
        })
    }

    fn sample(&self, t: f64) -> Sample {
        let n = self.times.len();
        let (t0, tn) = (self.times[0], self.times[n - 1]);
        let hold = |i: usize| {
            let v = &self.values[i];
            Sample {
                angles: Vector3::new(v[3], v[4], v[5]),
                angle_rates: Vector3::zeros(),
                offset: Vector3::new(v[0], v[1], v[2]),
                offset_rate: Vector3::zeros(),
            }
        };
        if t <= t0 {
            return hold(0);
        }
        let (t, first_pass) = if t < tn {
            (t, true)
        } else if self.looping {
            (t0 + (t - t0) % (tn - t0), false)
        } else {
            return hold(n - 1);
        };
        // Interval i: times[i] ≤ t < times[i+1].
        let i = self
            .times
            .partition_point(|&k| k <= t)
            .saturating_sub(1)
            .min(n - 2);
        let dur = self.times[i + 1] - self.times[i];
        let local = t - self.times[i];
        let m0 = if i == 0 && first_pass {
            [0.0; 6]
        } else {
            self.tangents[i]
        };
        let m1 = self.tangents[i + 1];
        let mut v = [0.0; 6];
        let mut dv = [0.0; 6];
        for c in 0..6 {
            (v[c], dv[c]) = hermite(
                self.values[i][c],
                m0[c],
                self.values[i + 1][c],
                m1[c],
                dur,
                local,
            );
        }
        Sample {
            angles: Vector3::new(v[3], v[4], v[5]),
            angle_rates: Vector3::new(dv[3], dv[4], dv[5]),
            offset: Vector3::new(v[0], v[1], v[2]),
            offset_rate: Vector3::new(dv[0], dv[1], dv[2]),
        }
    }
}

/// Line and column (1-based) of a field in the text: the `key`-th occurrence of `field:` when a
/// key index is given (each key has at most one of each field), else the first.
fn locate_field(text: &str, field: &str, key: Option<usize>) -> Option<(usize, usize)> {
    let mut seen = 0;
    for (ln, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or_default();
        let mut from = 0;
        while let Some(off) = code[from..].find(field) {
            let at = from + off;
            from = at + field.len();
            let before_ok = code[..at]
                .chars()
                .next_back()
                .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
            let after_ok = code[from..].trim_start().starts_with(':');
            if !(before_ok && after_ok) {
                continue;
            }
            if seen == key.unwrap_or(0) {
                return Some((ln + 1, code[..at].chars().count() + 1));
            }
            seen += 1;
        }
    }
    None
}
