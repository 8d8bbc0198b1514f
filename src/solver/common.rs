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

/// Closest points between segments `[a1, b1]` and `[a2, b2]` (Ericson, *Real-Time Collision
/// Detection* §5.1.9, as in parry), in f64. Returns `(s, t)` with the closest points
/// `a1 + s·(b1 − a1)` and `a2 + t·(b2 − a2)`, both in `[0, 1]`. For parallel overlapping segments
/// `s` is the middle of the overlap. Always inlined, as [`closest_params`].
#[inline(always)]
pub fn closest_segment_params(
    a1: &Vector3<f64>,
    b1: &Vector3<f64>,
    a2: &Vector3<f64>,
    b2: &Vector3<f64>,
) -> (f64, f64) {
    let d1 = b1 - a1;
    let d2 = b2 - a2;
    closest_params(a1, &d1, d1.norm_squared(), a2, &d2, d2.norm_squared())
}

/// [`closest_segment_params`] from the first points, the directions `d = b − a` and their squared
/// lengths (computed once per segment by the caller). Always inlined, so that callers built for
/// AVX2 (`crate::simd::dispatch`) compile it with them instead of calling the baseline copy.
#[inline(always)]
pub fn closest_params(
    a1: &Vector3<f64>,
    d1: &Vector3<f64>,
    a: f64,
    a2: &Vector3<f64>,
    d2: &Vector3<f64>,
    e: f64,
) -> (f64, f64) {
    let r = a1 - a2;
    let f = d2.dot(&r);
    // Relative to the scene: a segment shorter than 1e-12 of the other or of the gap is a point.
    let scale = a.max(e).max(r.norm_squared());
    let tiny = 1e-24 * scale;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b; // = |d1 × d2|² ≥ 0
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        // Parallel: seg 2's ends project on seg 1 at -c/a and (b - c)/a.
        // The minima and maxima are written as comparisons (`f64::min` leaves the sign of a
        // zero to the platform) so that the batched lanes (`crate::simd::pairs`) agree bit
        // for bit.
        let (p, q) = (-c / a, (b - c) / a);
        let min_sel = |x: f64, y: f64| if y < x { y } else { x };
        let max_sel = |x: f64, y: f64| if y > x { y } else { x };
        let (lo, hi) = (max_sel(min_sel(p, q), 0.0), min_sel(max_sel(p, q), 1.0));
        if lo <= hi {
            0.5 * (lo + hi)
        } else {
            (0.5 * (p + q)).clamp(0.0, 1.0)
        }
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// For tests: a seeded xorshift64 stream of uniform numbers in [0, 1) (no dependency, the same
/// numbers on every machine).
#[cfg(test)]
pub(crate) fn uniform_stream(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// For tests: a random direction from a [`uniform_stream`] (uniform in a cube, normalised).
#[cfg(test)]
pub(crate) fn random_unit(rand: &mut impl FnMut() -> f64) -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5)
        .try_normalize(1e-9)
        .unwrap_or_else(nalgebra::Vector3::x)
}
