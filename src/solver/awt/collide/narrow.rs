//! The narrow phase: per-segment data, the cheap filters and the exact closest-point test of two segments (AWT §4.2).

use nalgebra::Vector3;

use super::*;
use crate::simd::pairs::{PairParams, Segment, INTERSECTING, PARALLEL, TINY};

#[inline]
pub(super) fn widen(v: [f32; 3]) -> Vector3<f64> {
    Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

#[inline]
pub(super) fn narrow(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// One segment's broad-phase data: the box of its nodes inflated by its radius, in f32 rounded
/// outwards (so it always contains the f64 box), and its node slots for the adjacency test.
/// Two inflated boxes overlap exactly when the plain boxes are within `r1 + r2` on every axis.
#[derive(Clone, Copy, Default)]
pub(super) struct SegBox {
    pub(super) lo: [f32; 3],
    pub(super) hi: [f32; 3],
    pub(super) parent: u32,
    pub(super) child: u32,
    pub(super) chain: u32,
}

impl SegBox {
    #[inline]
    pub(super) fn new(segs: &SegmentsView, pos: &[Vector3<f64>], i: usize) -> Self {
        let (parent, child) = (segs.parent[i], segs.child[i]);
        let (xp, xc) = (pos[parent as usize], pos[child as usize]);
        let r = segs.radius[i];
        let (lo, hi) = (xp.inf(&xc).add_scalar(-r), xp.sup(&xc).add_scalar(r));
        SegBox {
            lo: [0, 1, 2].map(|k| (lo[k] as f32).next_down()),
            hi: [0, 1, 2].map(|k| (hi[k] as f32).next_up()),
            parent,
            child,
            chain: segs.chain[i],
        }
    }

    pub(super) fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        (
            Vector3::from(self.lo.map(f64::from)),
            Vector3::from(self.hi.map(f64::from)),
        )
    }
}

/// Whether a pair may touch: inflated boxes overlapping on every axis, not adjacent, not on one
/// chain.
#[inline(always)]
pub(super) fn near(a: &SegBox, b: &SegBox) -> bool {
    // Non-short-circuit `|`: the six comparisons are independent, one branch instead of six.
    let apart = (a.lo[0] > b.hi[0])
        | (b.lo[0] > a.hi[0])
        | (a.lo[1] > b.hi[1])
        | (b.lo[1] > a.hi[1])
        | (a.lo[2] > b.hi[2])
        | (b.lo[2] > a.hi[2]);
    !(apart | adjacent(a, b))
}

/// Adjacent segments (a chain, or siblings on one parent) always touch, and the segments of one
/// GC are pieces of one wisp: never test them.
#[inline(always)]
pub(super) fn adjacent(a: &SegBox, b: &SegBox) -> bool {
    (a.parent == b.parent)
        | (a.parent == b.child)
        | (a.child == b.parent)
        | (a.child == b.child)
        | (a.chain == b.chain)
}

/// One segment's data for the relative-motion test and the closest points, gathered once per
/// step: the narrow phase's [`Segment`] in `f32`, one cache line (what the batched lanes read;
/// `crate::simd::pairs` says why `f32`).
#[derive(Clone, Copy)]
pub(super) struct SegPre {
    /// Parent position `xp`, `d = xc − xp` and its squared length, the node velocities `vp`,
    /// `vc`, the radius and the child's mass.
    pub(super) lane: Segment,
}

/// The batched narrow phase reads the [`Segment`] inside the record.
impl AsRef<Segment> for SegPre {
    #[inline(always)]
    fn as_ref(&self) -> &Segment {
        &self.lane
    }
}

impl SegPre {
    #[inline]
    pub(super) fn new(
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        i: usize,
    ) -> Self {
        let (parent, child) = (segs.parent[i] as usize, segs.child[i] as usize);
        let (xp, xc) = (pos[parent], pos[child]);
        SegPre {
            lane: Segment::new(
                xp.into(),
                (xc - xp).into(),
                vel[parent].into(),
                vel[child].into(),
                segs.radius[i],
                segs.child_mass[i],
            ),
        }
    }
}

/// The narrow phase's parameters in `f32`, as the lanes and [`contact`] combine them.
pub(super) fn pair_params(p: &ContactParams) -> PairParams {
    PairParams {
        friction: p.friction as f32,
        repulsion: p.repulsion as f32,
        cos2_threshold: (p.cos_angle_threshold * p.cos_angle_threshold) as f32,
        dt_floor: p.dt.max(1e-12) as f32,
    }
}

/// `(u.x·v.x + u.y·v.y) + u.z·v.z`, as the lanes compute it.
#[inline(always)]
fn dot(u: &[f32; 3], v: &[f32; 3]) -> f32 {
    (u[0] * v[0] + u[1] * v[1]) + u[2] * v[2]
}

/// `|u − v|²`.
#[inline(always)]
fn dist2(u: &[f32; 3], v: &[f32; 3]) -> f32 {
    let w = [u[0] - v[0], u[1] - v[1], u[2] - v[2]];
    dot(&w, &w)
}

/// `if y < x { y } else { x }` (the lanes' minimum; `f32::min` leaves the sign of a zero to
/// the platform).
#[inline(always)]
fn min_sel(x: f32, y: f32) -> f32 {
    if y < x {
        y
    } else {
        x
    }
}

/// `if y > x { y } else { x }`.
#[inline(always)]
fn max_sel(x: f32, y: f32) -> f32 {
    if y > x {
        y
    } else {
        x
    }
}

/// Whether the two segments move relative to each other: a bound on every point-to-point
/// relative speed (see the module docs) at or above `epsilon` (`eps2 = ε²`).
#[inline(always)]
pub(super) fn moving(a: &SegPre, b: &SegPre, eps2: f32) -> bool {
    // One difference at a time: whenever the hair moves the first difference already decides,
    // so the other three are skipped. With the four always computed (non-short-circuit `|`)
    // the whole `interactions long short --motion shake` process took 1.04× as long (before ÷
    // after wall, median of 5 alternations, 2026-12-07; `long_curly --split 0.05`: 1.05×), and
    // `lean`, where more pairs are at rest relative to each other, was unchanged (1.00×).
    let (a, b) = (&a.lane, &b.lane);
    dist2(&a.vp, &b.vp) >= eps2
        || dist2(&a.vp, &b.vc) >= eps2
        || dist2(&a.vc, &b.vp) >= eps2
        || dist2(&a.vc, &b.vc) >= eps2
}

/// The closest points of two segment axes (Ericson, *Real-Time Collision Detection* §5.1.9),
/// in `f32`, as the lanes compute them: `x` the first points, `d` the directions, `la`, `le`
/// their squared lengths. For (near-)parallel axes (see [`PARALLEL`]) `s` is the middle of the
/// overlap.
#[inline]
pub(super) fn closest_params32(
    xa: &[f32; 3],
    da: &[f32; 3],
    la: f32,
    xb: &[f32; 3],
    db: &[f32; 3],
    le: f32,
) -> (f32, f32) {
    let r = [xa[0] - xb[0], xa[1] - xb[1], xa[2] - xb[2]];
    let f = dot(db, &r);
    // Relative to the pair: a segment shorter than 1e-6 of the other or of the gap is a point.
    let scale = max_sel(max_sel(la, le), dot(&r, &r));
    let tiny = TINY * scale;
    if la <= tiny && le <= tiny {
        return (0.0, 0.0);
    }
    if la <= tiny {
        return (0.0, (f / le).clamp(0.0, 1.0));
    }
    let c = dot(da, &r);
    if le <= tiny {
        return ((-c / la).clamp(0.0, 1.0), 0.0);
    }
    let bb = dot(da, db);
    let len2 = la * le;
    // `|da × db|² ≥ 0`.
    let denom = len2 - bb * bb;
    // Parallel: seg 2's ends project on seg 1 at -c/a and (b - c)/a.
    let (pp, qq) = (-c / la, (bb - c) / la);
    let s = if denom > PARALLEL * len2 {
        ((bb * f - c * le) / denom).clamp(0.0, 1.0)
    } else {
        let (lo, hi) = (max_sel(min_sel(pp, qq), 0.0), min_sel(max_sel(pp, qq), 1.0));
        if lo <= hi {
            0.5 * (lo + hi)
        } else {
            (0.5 * (pp + qq)).clamp(0.0, 1.0)
        }
    };
    let t = (bb * s + f) / le;
    if t < 0.0 {
        (pp.clamp(0.0, 1.0), 0.0)
    } else if t > 1.0 {
        (qq.clamp(0.0, 1.0), 1.0)
    } else {
        (s, t)
    }
}

/// The contact of segments `ia` < `ib` (records `a`, `b`) that passed [`near`] and
/// [`moving`], if the cylinders intersect, in `f32` (`crate::simd::pairs` is its general case,
/// bit for bit). The lower index comes first, so that the grid and the reference compute
/// bit-identical pair forces.
#[inline]
pub(super) fn contact(
    a: &SegPre,
    b: &SegPre,
    (ia, ib): (u32, u32),
    p: &PairParams,
) -> Option<Contact> {
    let (a, b) = (&a.lane, &b.lane);
    let r = a.radius + b.radius;
    let (s, t) = closest_params32(&a.x, &a.d, a.len2, &b.x, &b.d, b.len2);
    let p1: [f32; 3] = std::array::from_fn(|k| a.x[k] + a.d[k] * s);
    let p2: [f32; 3] = std::array::from_fn(|k| b.x[k] + b.d[k] * t);
    let delta = [p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]];
    let dist2 = dot(&delta, &delta);
    if dist2 >= r * r {
        return None;
    }
    let m = min_sel(a.mass, b.mass);

    // Eq. 1: viscous friction at the closest points.
    let v1: [f32; 3] = std::array::from_fn(|k| a.vp[k] * (1.0 - s) + a.vc[k] * s);
    let v2: [f32; 3] = std::array::from_fn(|k| b.vp[k] * (1.0 - t) + b.vc[k] * t);
    let kfm = p.friction * m;
    let friction = std::array::from_fn(|k| (v2[k] - v1[k]) * kfm);
    let mut repulsion = [0.0; 3];

    // Eq. 2: repulsion only between wisps crossing at a large enough angle.
    // |cos| < threshold, compared squared (no root or division on the common parallel pair);
    // a zero-length segment counts as parallel (|cos| = 1).
    let len2 = a.len2 * b.len2;
    let bb = dot(&a.d, &b.d);
    let crossing = if len2 > 0.0 {
        bb * bb < p.cos2_threshold * len2
    } else {
        1.0 < p.cos2_threshold
    };
    if crossing {
        let d = dist2.sqrt();
        let n = if d > INTERSECTING * r {
            delta.map(|x| x / d)
        } else {
            // The difference of the closest points is rounding: the normal of the axes' plane.
            let w = |v: [f32; 3]| Vector3::from(v.map(f64::from));
            let (d1, d2) = (w(a.d), w(b.d));
            let mid = (w(a.x) + d1 * 0.5) - (w(b.x) + d2 * 0.5);
            narrow(&degenerate_normal(&d1, &d2, &mid))
        };
        // Only while the two approach: a penalty that also pushed separating wisps would, with
        // the skipping of still pairs (§4.1), chatter forever on resting hair and pump energy
        // into it. The response stays soft (§4.2) and never accelerates a separation.
        // It is also capped at the impulse that stops the approach within the step, so like
        // friction it can bring the normal relative velocity to zero but never reverse it.
        let dv = [v1[0] - v2[0], v1[1] - v2[1], v1[2] - v2[2]];
        let approach = -dot(&dv, &n);
        if approach > 0.0 {
            let push = min_sel(p.repulsion * m * (r - d), m * approach / p.dt_floor);
            repulsion = n.map(|x| x * push);
        }
    }

    Some(Contact {
        a: ia,
        b: ib,
        s,
        t,
        friction,
        repulsion,
    })
}

/// Unit normal for intersecting axes: perpendicular to both, pointing to the side of `mid`
/// (first midpoint minus second).
pub(super) fn degenerate_normal(
    d1: &Vector3<f64>,
    d2: &Vector3<f64>,
    mid: &Vector3<f64>,
) -> Vector3<f64> {
    let c = d1.cross(d2);
    let cn = c.norm();
    let scale = d1.norm() * d2.norm();
    let n = if cn > 1e-9 * scale {
        c / cn
    } else {
        // Parallel axes (only reachable with a threshold above 1): the midpoint offset across d1.
        let u = d1.try_normalize(0.0).unwrap_or_else(Vector3::x);
        let across = mid - u * u.dot(mid);
        across
            .try_normalize(1e-300)
            .unwrap_or_else(|| any_perpendicular(&u))
    };
    if n.dot(mid) < 0.0 {
        -n
    } else {
        n
    }
}

/// A unit vector perpendicular to the unit vector `u`, chosen deterministically.
pub(super) fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let axis = if u.x.abs() < 0.57 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    u.cross(&axis).normalize()
}

// The closest points of two segments are shared with the guide model's strips:
// `crate::solver::common::{closest_segment_params, closest_params}`.
#[cfg(test)]
pub(super) use crate::solver::common::closest_params;
pub use crate::solver::common::closest_segment_params;

#[cfg(test)]
mod tests {
    use super::*;

    /// The candidate loop's split test (the box half of [`BoxTest::run8`], then `adjacent`)
    /// is `near`, on both twins, for boxes apart, touching, overlapping, inside one another,
    /// and with NaN or infinite bounds.
    #[test]
    fn the_lanes_box_test_and_adjacency_are_near_on_both_twins() {
        use crate::simd::boxes::{BoxTest, Entries, Probe, RUN};
        use crate::simd::dispatch::Portable;
        crate::simd::dispatch::multiversion! {
            fn first<I: BoxTest>(probe: &Probe, e: &Entries) -> u32 {
                I::run8(probe, e, 0).1 & 1
            }
        }
        let mut rng = crate::simd::boxes::test_boxes::Boxes(0x2545_f491_4f6c_dd1d);
        let (mut near_count, mut total) = (0, 0);
        for _ in 0..20_000 {
            let mut bx = || {
                let (lo, hi) = rng.bounds();
                SegBox {
                    lo,
                    hi,
                    parent: rng.pick(6) as u32,
                    child: 6 + rng.pick(6) as u32,
                    chain: rng.pick(8) as u32,
                }
            };
            let (a, b) = (bx(), bx());
            let want = near(&a, &b);
            let probe = Probe {
                lo: a.lo,
                hi: a.hi,
                flags: 0,
            };
            let (lo, hi) = (b.lo.map(|x| [x; RUN]), b.hi.map(|x| [x; RUN]));
            let e = Entries {
                lo: [&lo[0], &lo[1], &lo[2]],
                hi: [&hi[0], &hi[1], &hi[2]],
                word: &[0; RUN],
            };
            let portable = Portable::run8(&probe, &e, 0).1 & 1 == 1 && !adjacent(&a, &b);
            let best = first(crate::simd::best_available(), &probe, &e) == 1 && !adjacent(&a, &b);
            assert_eq!(portable, want, "{:?} {:?}", a.lo, b.lo);
            assert_eq!(best, want, "{:?} {:?}", a.lo, b.lo);
            near_count += usize::from(want);
            total += 1;
        }
        assert!(
            near_count > total / 20 && near_count < total * 19 / 20,
            "{near_count} of {total}"
        );
    }

    #[test]
    pub(super) fn closest_params_cross() {
        let (s, t) = closest_segment_params(
            &Vector3::new(-1.0, 0.0, 0.0),
            &Vector3::new(3.0, 0.0, 0.0),
            &Vector3::new(0.0, -1.0, 1.0),
            &Vector3::new(0.0, 1.0, 1.0),
        );
        assert!(
            (s - 0.25).abs() < 1e-15 && (t - 0.5).abs() < 1e-15,
            "{s} {t}"
        );
    }

    #[test]
    pub(super) fn closest_params_parallel_overlap_takes_middle() {
        // Seg 2 covers x ∈ [1, 3] above seg 1 (x ∈ [0, 2]): overlap [1, 2], middle x = 1.5.
        let (s, t) = closest_segment_params(
            &Vector3::new(0.0, 0.0, 0.0),
            &Vector3::new(2.0, 0.0, 0.0),
            &Vector3::new(1.0, 0.1, 0.0),
            &Vector3::new(3.0, 0.1, 0.0),
        );
        assert!(
            (s - 0.75).abs() < 1e-15 && (t - 0.25).abs() < 1e-15,
            "{s} {t}"
        );
    }
}
