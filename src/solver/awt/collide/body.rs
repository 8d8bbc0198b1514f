//! Body spheres (AWT §4.3): segments pushed out of the spheres, nodes taking the body's velocity.

use nalgebra::Vector3;

use super::*;

/// A sphere of the body proxy (AWT §4.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodySphere {
    /// Centre, m (posed).
    pub center: Vector3<f64>,
    /// Radius, m.
    pub radius: f64,
}

/// Passes over the spheres per segment before the exit fallback (overlapping spheres can push a
/// node back and forth).
pub(super) const BODY_PASSES: usize = 4;
/// Relative tolerance on `|q − c|²` below which a segment's interior counts as inside: the
/// tangent placement is exact only up to rounding and must not re-trigger a push.
pub(super) const CHORD_TOLERANCE: f64 = 1e-9;

/// AWT §4.3: every segment that enters a sphere has its CHILD node moved out to the surface and
/// given the obstacle's velocity `obstacle_velocity(world_point)` (static friction, no bounce).
/// Returns the number of segments pushed.
///
/// Segments are handled in order, each seeing the positions already moved by earlier ones (so
/// give them root to tip). The test uses the sphere radius only, not sphere + hair radius: the
/// body proxy is meant to be drawn slightly inside the skin. For each sphere:
/// * a child strictly inside (`|x − c|² < R²`) is projected radially onto the surface;
/// * if the parent is outside but the segment's interior cuts the sphere, the child is rotated
///   about the parent, keeping the segment's length, until the segment is tangent to the sphere;
/// * a parent inside (e.g. a root planted under the proxy) is left to its own segment: moving the
///   child cannot get such a segment out, so only the child is kept out.
///
/// Afterwards no child node is strictly inside any sphere, even where spheres overlap.
pub fn resolve_body(
    segs: &SegmentsView,
    pos: &mut [Vector3<f64>],
    vel: &mut [Vector3<f64>],
    spheres: &[BodySphere],
    obstacle_velocity: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> u32 {
    let mut pushed = 0;
    for i in 0..segs.len() {
        let (pi, ci) = (segs.parent[i] as usize, segs.child[i] as usize);
        let parent = pos[pi];
        let mut child = pos[ci];
        let mut moved = false;
        for _ in 0..BODY_PASSES {
            let mut changed = false;
            for s in spheres {
                if clear_of(&parent, &child, s) {
                    continue;
                }
                if let Some(c) = push_out(&parent, &child, s) {
                    child = c;
                    changed = true;
                }
            }
            moved |= changed;
            if !changed {
                break;
            }
        }
        if let Some(c) = exit_union(&child, spheres) {
            child = c;
            moved = true;
        }
        if moved {
            pos[ci] = child;
            vel[ci] = obstacle_velocity(&child);
            pushed += 1;
        }
    }
    pushed
}

/// Whether the segment `parent → child` surely stays out of `s`: its bounding box is farther
/// than the radius from the centre, by a relative margin far above the rounding of
/// [`push_out`]'s own tests, so [`push_out`] would return `None`. Most segments are far from
/// most spheres, and this test is a few compares and no division or square root.
#[inline]
fn clear_of(parent: &Vector3<f64>, child: &Vector3<f64>, s: &BodySphere) -> bool {
    let mut d2 = 0.0;
    for k in 0..3 {
        let (lo, hi) = (parent[k].min(child[k]), parent[k].max(child[k]));
        let c = s.center[k];
        let gap = (lo - c).max(c - hi).max(0.0);
        d2 += gap * gap;
    }
    d2 > s.radius * s.radius * (1.0 + 1e-6)
}

#[inline]
pub(super) fn strictly_inside(x: &Vector3<f64>, s: &BodySphere) -> bool {
    (x - s.center).norm_squared() < s.radius * s.radius
}

/// New child position if segment `parent → child` enters sphere `s`, else `None`.
pub(super) fn push_out(
    parent: &Vector3<f64>,
    child: &Vector3<f64>,
    s: &BodySphere,
) -> Option<Vector3<f64>> {
    let r2 = s.radius * s.radius;
    let mut x = *child;
    let mut moved = false;
    if strictly_inside(&x, s) {
        let dir = (x - s.center)
            .try_normalize(1e-300)
            .or_else(|| (x - parent).try_normalize(1e-300))
            .unwrap_or_else(Vector3::y);
        x = onto_surface(s, &dir);
        moved = true;
    }
    let w = s.center - parent;
    let dd = w.norm_squared();
    if dd >= r2 {
        let seg = x - parent;
        let l2 = seg.norm_squared();
        if l2 > 0.0 {
            let t = w.dot(&seg) / l2;
            if t > 0.0 && t < 1.0 {
                let q = parent + seg * t;
                if (q - s.center).norm_squared() < r2 * (1.0 - CHORD_TOLERANCE) {
                    // Rotate about the parent onto the tangent cone: angle θ from the centre
                    // direction with sin θ = R / D, in the plane of parent, centre and child.
                    let dlen = dd.sqrt();
                    let wh = w / dlen;
                    let len = l2.sqrt();
                    let u = seg / len;
                    let across = u - wh * wh.dot(&u);
                    let eh = across
                        .try_normalize(1e-300)
                        .unwrap_or_else(|| any_perpendicular(&wh));
                    let sin = (s.radius / dlen).min(1.0);
                    let cos = (1.0 - sin * sin).max(0.0).sqrt();
                    x = parent + (wh * cos + eh * sin) * len;
                    if strictly_inside(&x, s) {
                        let dir = (x - s.center).try_normalize(1e-300).unwrap_or(eh);
                        x = onto_surface(s, &dir);
                    }
                    moved = true;
                }
            }
        }
    }
    moved.then_some(x)
}

/// The point of `s`'s surface in unit direction `dir` from the centre, nudged outwards until
/// rounding no longer leaves it strictly inside.
pub(super) fn onto_surface(s: &BodySphere, dir: &Vector3<f64>) -> Vector3<f64> {
    let mut rr = s.radius;
    let mut x = s.center + dir * rr;
    for _ in 0..64 {
        if !strictly_inside(&x, s) {
            break;
        }
        rr = rr * (1.0 + 1e-14) + f64::MIN_POSITIVE;
        x = s.center + dir * rr;
    }
    x
}

/// If `x` is strictly inside some sphere after the passes (overlapping spheres), moves it along a
/// fixed ray out of the union: the ray meets each sphere in one interval, so stepping to the far
/// end of each sphere that still contains the point leaves the union in at most one step per
/// sphere.
pub(super) fn exit_union(x: &Vector3<f64>, spheres: &[BodySphere]) -> Option<Vector3<f64>> {
    let first = spheres.iter().find(|s| strictly_inside(x, s))?;
    let dir = (x - first.center)
        .try_normalize(1e-300)
        .unwrap_or_else(Vector3::y);
    let mut p = *x;
    for _ in 0..=2 * spheres.len() {
        let Some(s) = spheres.iter().find(|s| strictly_inside(&p, s)) else {
            break;
        };
        let o = p - s.center;
        let b = o.dot(&dir);
        let disc = (b * b - (o.norm_squared() - s.radius * s.radius)).max(0.0);
        p += dir * (-b + disc.sqrt()).max(0.0);
        if strictly_inside(&p, s) {
            let d = (p - s.center).try_normalize(1e-300).unwrap_or(dir);
            p = onto_surface(s, &d);
        }
    }
    debug_assert!(
        !spheres.iter().any(|s| strictly_inside(&p, s)),
        "exit_union left {p:?} inside a sphere"
    );
    Some(p)
}

/// AWT §4.3's response against the body's capsules and meshes: a child node inside one is put
/// on its surface along the normal and given the obstacle's velocity, as for a sphere. Returns
/// the nodes pushed. (The tangent rotation about the parent is sphere geometry; for these
/// shapes the child alone is kept out, as for a parent inside a sphere.)
pub fn resolve_shapes(
    segs: &SegmentsView,
    pos: &mut [Vector3<f64>],
    vel: &mut [Vector3<f64>],
    colliders: &[crate::solver::body::Collider],
    pose: &crate::motion::Pose,
) -> u32 {
    if colliders.is_empty() {
        return 0;
    }
    let mut pushed = 0;
    for i in 0..segs.len() {
        let ci = segs.child[i] as usize;
        if let Some((x, _)) = crate::solver::body::push_out(colliders, pose, &pos[ci], 0.0) {
            pos[ci] = x;
            vel[ci] = pose.velocity_at(&nalgebra::Point3::from(x));
            pushed += 1;
        }
    }
    pushed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::common::{random_unit, uniform_stream};

    /// The cheap box test never skips a segment [`push_out`] would move: on random segments
    /// around a sphere, many of them grazing it (tangent within a relative 1e-7, either side),
    /// every segment it calls clear is one `push_out` leaves alone.
    #[test]
    fn clear_segments_are_never_pushed() {
        let mut rand = uniform_stream(0x2545_f491_4f6c_dd1d);
        let s = BodySphere {
            center: Vector3::new(0.1, 1.4, -0.02),
            radius: 0.07,
        };
        let (mut clear, mut pushed) = (0, 0);
        for k in 0..200_000 {
            let (u, w) = (random_unit(&mut rand), random_unit(&mut rand));
            let (parent, child) = if k % 2 == 0 {
                // Anywhere within three radii.
                let p = s.center + u * (3.0 * s.radius * rand());
                (p, p + w * (0.05 * rand()))
            } else {
                // Grazing, along a coordinate axis (so that the segment is its own box): its
                // point nearest the centre is the radius away within a relative 1e-7.
                let axis = Vector3::ith((k / 2) % 3, 1.0);
                let u = (u - axis * u.dot(&axis)).try_normalize(1e-9).unwrap_or(w);
                let q = s.center + u * (s.radius * (1.0 + 2e-7 * (rand() - 0.5)));
                let a = 0.03 * rand();
                (q - axis * a, q + axis * (0.03 * rand()))
            };
            let moved = push_out(&parent, &child, &s).is_some();
            if clear_of(&parent, &child, &s) {
                clear += 1;
                assert!(
                    !moved,
                    "skipped a segment push_out moves: {parent:?} → {child:?}"
                );
            }
            pushed += moved as u32;
        }
        assert!(
            clear > 50_000 && pushed > 10_000,
            "{clear} clear, {pushed} pushed"
        );
    }
}
