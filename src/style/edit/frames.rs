//! Where a wisp's key strand lies in the world, and the local frame a control point is moved
//! in (Zhang & Wünsche 2007, §3.1 "Key Strand Control"): "the curve tangent at that point, the
//! surface normal at the scalp point closest to the control point and the vector perpendicular
//! to these two vectors".
//!
//! A key strand is stored in the styling frame at its wisp's root (see
//! [`Wisp::key_strand`]): the editor converts a control point to the world, moves it there
//! along the local frame, and converts it back, so that every other point keeps its bits.
//! The root is implicit (the region's centre on the scalp), so it stays on the scalp.

use crate::style::generate::{catmull_rom, implicit, scalp_point, styling_frame, Frame};
use crate::style::{Ellipsoid, Vec3, Wisp};

/// The styling frame a wisp's key strand is drawn in: the one at its region's centre (a wisp
/// of several tiles grows each tile from the same key strand in the tile's own frame; the
/// region's centre is where the page shows it).
pub fn wisp_frame(scalp: &Ellipsoid, w: &Wisp) -> Frame {
    let az = 0.5 * (w.region.azimuth.0 + w.region.azimuth.1);
    let el = 0.5 * (w.region.elevation.0 + w.region.elevation.1);
    styling_frame(scalp, az.to_radians(), el.to_radians())
}

/// A styling-frame point `(tangent, normal, binormal)` in the world.
pub fn to_world(f: &Frame, c: Vec3) -> Vec3 {
    let mut p = f.origin;
    for (k, v) in p.iter_mut().enumerate() {
        *v += c[0] * f.t[k] + c[1] * f.n[k] + c[2] * f.b[k];
    }
    p
}

/// A world point in the styling frame (the frame is orthonormal: a projection on its axes).
pub fn to_styling(f: &Frame, p: Vec3) -> Vec3 {
    let d = sub(p, f.origin);
    [dot(d, f.t), dot(d, f.n), dot(d, f.b)]
}

/// The key strand in the world, root first.
pub fn world_points(scalp: &Ellipsoid, w: &Wisp) -> Vec<Vec3> {
    let f = wisp_frame(scalp, w);
    std::iter::once(f.origin)
        .chain(w.key_strand.iter().map(|c| to_world(&f, *c)))
        .collect()
}

/// The key strand as the spline the generator grows (Catmull-Rom through root and points).
pub fn world_curve(scalp: &Ellipsoid, w: &Wisp) -> Vec<Vec3> {
    let p = world_points(scalp, w);
    if p.len() < 2 || p.windows(2).any(|q| q[0] == q[1]) {
        return p;
    }
    // Every 8th sample is plenty to draw (the generator takes 64 per segment).
    catmull_rom(&p)
        .into_iter()
        .step_by(8)
        .chain(p.last().copied())
        .collect()
}

/// The local frame at control point `i` of `points` (world, root first): the curve's tangent,
/// the scalp normal at the nearest scalp point made perpendicular to it, and their cross
/// product (§3.1). The nearest scalp point is taken along the ray from the scalp's centre: on
/// a near-spherical scalp it is the nearest point, and it is always defined.
pub fn local_frame(scalp: &Ellipsoid, points: &[Vec3], i: usize) -> [Vec3; 3] {
    let n = points.len();
    let (a, b) = (points[i.saturating_sub(1)], points[(i + 1).min(n - 1)]);
    let mut t = normalize(sub(b, a));
    let normal = scalp_normal_near(scalp, points[i]);
    if t == [0.0; 3] {
        t = tangent_fallback(normal);
    }
    let mut nn = sub(normal, scale(t, dot(normal, t)));
    if norm(nn) < 1e-6 {
        // The strand runs along the normal: any perpendicular will do.
        nn = tangent_fallback(t);
    }
    let nn = normalize(nn);
    [t, nn, cross(t, nn)]
}

/// The outward scalp normal at the scalp point on the ray from the centre through `p`.
fn scalp_normal_near(scalp: &Ellipsoid, p: Vec3) -> Vec3 {
    let d = sub(p, scalp.center);
    let (az, el) = if norm(d) < 1e-12 {
        (0.0, std::f64::consts::FRAC_PI_2)
    } else {
        let d = normalize(d);
        (d[0].atan2(d[2]), d[1].clamp(-1.0, 1.0).asin())
    };
    let s = scalp_point(scalp, az, el);
    crate::style::generate::scalp_normal(scalp, s)
}

/// A unit vector perpendicular to `v`.
fn tangent_fallback(v: Vec3) -> Vec3 {
    let other = if v[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    normalize(cross(v, other))
}

/// Whether a world point lies under (inside) the scalp.
pub fn under_scalp(scalp: &Ellipsoid, p: Vec3) -> bool {
    implicit(scalp, p) < 1.0
}

/// A key strand mirrored across the head's sagittal plane (Fig. 6): with the region's azimuth
/// negated, the styling frame's tangent and normal are the mirror images of the old ones and
/// its binormal (`t × n`) is minus the mirror image, so a point `(t, n, b)` becomes
/// `(t, n, −b)`.
pub fn mirrored_key(key: &[Vec3]) -> Vec<Vec3> {
    key.iter().map(|c| [c[0], c[1], -c[2]]).collect()
}

/// The key strand a new wisp starts from: it leaves the scalp, lies along it for a few
/// centimetres down the tangent (towards the ears and nape), then falls, 20 cm in all.
pub const TEMPLATE_KEY: [Vec3; 5] = [
    [0.02, 0.006, 0.0],
    [0.05, 0.006, 0.0],
    [0.09, -0.004, 0.0],
    [0.14, -0.03, 0.0],
    [0.19, -0.06, 0.0],
];

pub(crate) fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}
fn normalize(a: Vec3) -> Vec3 {
    let n = norm(a);
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::style::Region;

    fn scalp() -> Ellipsoid {
        Ellipsoid {
            center: [0.0, 1.6, 0.0],
            radii: [0.075, 0.095, 0.09],
        }
    }

    fn wisp(az: (f64, f64)) -> Wisp {
        Wisp {
            name: "w".into(),
            region: Region {
                azimuth: az,
                elevation: (20.0, 50.0),
            },
            tiles: (1, 1),
            key_strand: vec![[0.03, 0.01, 0.02], [0.08, -0.02, 0.05], [0.15, -0.1, 0.04]],
            tip_spread: 0.01,
            curl: None,
            density: None,
        }
    }

    #[test]
    fn the_local_frame_is_orthonormal_and_follows_the_strand() {
        let s = scalp();
        let p = world_points(&s, &wisp((30.0, 60.0)));
        for i in 1..p.len() {
            let [t, n, b] = local_frame(&s, &p, i);
            for (u, v) in [(t, n), (n, b), (t, b)] {
                assert!(dot(u, v).abs() < 1e-12);
            }
            for u in [t, n, b] {
                assert!((norm(u) - 1.0).abs() < 1e-12);
            }
            // The tangent points along the strand, the normal away from the head.
            let along = sub(p[(i + 1).min(p.len() - 1)], p[i - 1]);
            assert!(dot(t, along) > 0.0);
            assert!(dot(n, sub(p[i], s.center)) > 0.0);
        }
    }

    #[test]
    fn world_and_styling_coordinates_round_trip() {
        let s = scalp();
        let w = wisp((10.0, 40.0));
        let f = wisp_frame(&s, &w);
        for c in &w.key_strand {
            let back = to_styling(&f, to_world(&f, *c));
            for k in 0..3 {
                assert!((back[k] - c[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_mirrored_key_strand_is_the_mirror_image_in_the_world() {
        let s = scalp();
        let w = wisp((20.0, 70.0));
        let mut m = w.clone();
        m.region.azimuth = (-70.0, -20.0);
        m.key_strand = mirrored_key(&w.key_strand);
        for (a, b) in world_points(&s, &w).iter().zip(world_points(&s, &m)) {
            assert!((a[0] + b[0]).abs() < 1e-12, "{a:?} {b:?}");
            assert!((a[1] - b[1]).abs() < 1e-12 && (a[2] - b[2]).abs() < 1e-12);
        }
    }

    #[test]
    fn the_template_stays_outside_the_scalp_everywhere_on_it() {
        let s = scalp();
        for az in (-180..180).step_by(30) {
            for el in (-40..=80).step_by(20) {
                let mut w = wisp((az as f64 - 5.0, az as f64 + 5.0));
                w.region.elevation = (el as f64 - 5.0, el as f64 + 5.0);
                w.key_strand = TEMPLATE_KEY.to_vec();
                for p in world_points(&s, &w).iter().skip(1) {
                    assert!(!under_scalp(&s, *p), "az {az} el {el}: {p:?}");
                }
            }
        }
    }
}
