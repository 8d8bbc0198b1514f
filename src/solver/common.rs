//! What every solver uses, beside the solvers rather than inside one of them: the relative
//! damping of Plante et al.'s §5.2 (the layered model's interactions, and the tests of momentum),
//! the wind field of the style's `sim.wind`, and the closest points of two segments (the AWT's
//! narrow phase and the guide model's strips).

use nalgebra::Vector3;

use crate::style::SimParams;

/// Seed 002 §5.2: the velocity changes that damp the relative velocity of two bodies by the
/// fraction `min(ν·dt, 1)`, shared by their masses so momentum is conserved. The relative
/// velocity afterwards is `(1 − min(ν·dt, 1))·(v2 − v1)`: reduced, never reversed.
pub fn damp_relative(
    v1: Vector3<f64>,
    m1: f64,
    v2: Vector3<f64>,
    m2: f64,
    nu: f64,
    dt: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let f = (nu * dt).clamp(0.0, 1.0);
    let rel = v2 - v1;
    let dv1 = rel * (f * m2 / (m1 + m2));
    let dv2 = -rel * (f * m1 / (m1 + m2));
    (dv1, dv2)
}

/// The wind velocity at `x` and time `t`: steady velocity plus a travelling gust along it.
pub fn wind_at(p: &SimParams, x: &Vector3<f64>, t: f64) -> Vector3<f64> {
    let w = &p.wind;
    let base = Vector3::from(w.velocity);
    if w.gust == 0.0 {
        return base;
    }
    let dir = if base.norm() > 1e-9 {
        base.normalize()
    } else {
        Vector3::x()
    };
    let phase = 2.0 * std::f64::consts::PI * (w.frequency * t - x.dot(&dir) / w.wavelength);
    base + dir * (w.gust * phase.sin())
}
