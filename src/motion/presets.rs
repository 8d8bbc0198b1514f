//! The preset motions (still, lean, run, jump, shake, stop): closed-form poses and their
//! velocities.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::*;

/// The channels of a motion at one instant, with their time derivatives.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    /// Euler angles (x, y, z), radians, `R = Rz Ry Rx`.
    pub(super) angles: Vector3<f64>,
    pub(super) angle_rates: Vector3<f64>,
    /// World offset of the pivot.
    pub(super) offset: Vector3<f64>,
    pub(super) offset_rate: Vector3<f64>,
}

impl Sample {
    pub(super) fn rest() -> Sample {
        Sample {
            angles: Vector3::zeros(),
            angle_rates: Vector3::zeros(),
            offset: Vector3::zeros(),
            offset_rate: Vector3::zeros(),
        }
    }

    pub(super) fn pose(&self, pivot: &Point3<f64>) -> Pose {
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
pub(super) fn smootherstep(u: f64) -> (f64, f64) {
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
pub(super) fn envelope(t: f64, ramp: f64) -> (f64, f64) {
    let (s, ds) = smootherstep(t / ramp);
    (s, ds / ramp)
}

/// Distance covered when the speed rises from 0 to `v` along a smootherstep over `ramp`
/// seconds and then stays at `v`: the integral of `v · smootherstep(t / ramp)`.
pub(super) fn ramped_distance(t: f64, v: f64, ramp: f64) -> (f64, f64) {
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
pub(super) fn trapezoid(t: f64, a: f64, b: f64, c: f64) -> (f64, f64) {
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
pub(super) fn hermite(p0: f64, m0: f64, p1: f64, m1: f64, dur: f64, t: f64) -> (f64, f64) {
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

pub(super) fn lean(t: f64) -> Sample {
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

pub(super) fn run(t: f64) -> Sample {
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
pub(super) fn jump_height(t: f64) -> (f64, f64) {
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

pub(super) fn jump(t: f64) -> Sample {
    let (y, dy) = jump_height(t);
    let mut out = Sample::rest();
    out.offset.y = y;
    out.offset_rate.y = dy;
    out
}

pub(super) fn shake(t: f64) -> Sample {
    let (e, de) = envelope(t, SHAKE_RAMP);
    let w = std::f64::consts::TAU * SHAKE_HZ;
    let amp = SHAKE_DEG.to_radians();
    let mut out = Sample::rest();
    out.angles.y = amp * e * (w * t).sin();
    out.angle_rates.y = amp * (de * (w * t).sin() + e * w * (w * t).cos());
    out
}

pub(super) fn stop(t: f64) -> Sample {
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
