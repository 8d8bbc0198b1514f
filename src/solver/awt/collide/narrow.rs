//! The narrow phase: per-segment data, the cheap filters and the exact closest-point test of two segments (AWT §4.2).

use nalgebra::Vector3;

use super::*;
use crate::simd::pairs::Segment;

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
/// step: the narrow phase's [`Segment`] (what the batched lanes read) and the rest the scalar
/// routine needs.
#[derive(Clone, Copy)]
pub(super) struct SegPre {
    /// Parent position `xp`, `d = xc − xp` and its squared length, the node velocities `vp`,
    /// `vc`, the radius and the child's mass.
    pub(super) lane: Segment,
    pub(super) xc: Vector3<f64>,
    /// Index in the [`SegmentsView`].
    pub(super) seg: u32,
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
        let d = xc - xp;
        SegPre {
            lane: Segment::new(
                xp.into(),
                d.into(),
                d.norm_squared(),
                vel[parent].into(),
                vel[child].into(),
                segs.radius[i],
                segs.child_mass[i],
            ),
            xc,
            seg: i as u32,
        }
    }

    #[inline(always)]
    pub(super) fn xp(&self) -> Vector3<f64> {
        Vector3::from(self.lane.x)
    }
    #[inline(always)]
    pub(super) fn vp(&self) -> Vector3<f64> {
        Vector3::from(self.lane.vp)
    }
    #[inline(always)]
    pub(super) fn vc(&self) -> Vector3<f64> {
        Vector3::from(self.lane.vc)
    }
}

/// Whether the two segments move relative to each other: a bound on every point-to-point
/// relative speed (see the module docs) at or above `epsilon`.
#[inline(always)]
pub(super) fn moving(a: &SegPre, b: &SegPre, eps2: f64) -> bool {
    // max(…) ≥ ε², one difference at a time (`f64::max` branches on NaN). Whenever the hair
    // moves the first difference already decides, so the other three are skipped: with the
    // four always computed (non-short-circuit `|`) the whole `interactions long short --motion
    // shake` process took 1.04× as long (before ÷ after wall, median of 5 alternations,
    // 2026-12-07; `long_curly --split 0.05`: 1.05×), and `lean`, where more pairs are at rest
    // relative to each other, was unchanged (1.00×).
    let (avp, avc, bvp, bvc) = (a.vp(), a.vc(), b.vp(), b.vc());
    ((avp - bvp).norm_squared() >= eps2)
        || ((avp - bvc).norm_squared() >= eps2)
        || ((avc - bvp).norm_squared() >= eps2)
        || ((avc - bvc).norm_squared() >= eps2)
}

/// The contact of a pair that passed [`near`] and [`moving`], if the cylinders intersect. `a`
/// must be the segment with the lower index, so that the grid and the reference compute
/// bit-identical pair forces.
#[inline]
pub(super) fn contact(a: &SegPre, b: &SegPre, p: &ContactParams) -> Option<Contact> {
    let (seg_a, seg_b) = (a.seg, b.seg);
    let (xpa, xca, xpb, xcb) = (a.xp(), a.xc, b.xp(), b.xc);
    let (vpa, vca, vpb, vcb) = (a.vp(), a.vc(), b.vp(), b.vc());
    let (a, b) = (&a.lane, &b.lane);
    let r = a.radius + b.radius;
    let (d1, d2) = (Vector3::from(a.d), Vector3::from(b.d));
    let (s, t) = closest_params(&xpa, &d1, a.len2, &xpb, &d2, b.len2);
    let p1 = xpa + d1 * s;
    let p2 = xpb + d2 * t;
    let delta = p1 - p2;
    let dist2 = delta.norm_squared();
    if dist2 >= r * r {
        return None;
    }
    let m = a.mass.min(b.mass);

    // Eq. 1: viscous friction at the closest points.
    let v1 = vpa * (1.0 - s) + vca * s;
    let v2 = vpb * (1.0 - t) + vcb * t;
    let friction = (v2 - v1) * (p.friction * m);
    let mut repulsion = Vector3::zeros();

    // Eq. 2: repulsion only between wisps crossing at a large enough angle.
    // |cos| < threshold, compared squared (no root or division on the common parallel pair);
    // a zero-length segment counts as parallel (|cos| = 1).
    let len2 = a.len2 * b.len2;
    let dot = d1.dot(&d2);
    let thr = p.cos_angle_threshold;
    let crossing = if len2 > 0.0 {
        dot * dot < thr * thr * len2
    } else {
        1.0 < thr
    };
    if crossing {
        let d = dist2.sqrt();
        let n = if d > 1e-9 * r {
            delta / d
        } else {
            let mid = (xpa + xca - xpb - xcb) * 0.5;
            degenerate_normal(&d1, &d2, &mid)
        };
        // Only while the two approach: a penalty that also pushed separating wisps would, with
        // the skipping of still pairs (§4.1), chatter forever on resting hair and pump energy
        // into it. The response stays soft (§4.2) and never accelerates a separation.
        // It is also capped at the impulse that stops the approach within the step, so like
        // friction it can bring the normal relative velocity to zero but never reverse it.
        let approach = -(v1 - v2).dot(&n);
        if approach > 0.0 {
            let push = (p.repulsion * m * (r - d)).min(m * approach / p.dt.max(1e-12));
            repulsion = n * push;
        }
    }

    Some(Contact {
        a: seg_a,
        b: seg_b,
        s,
        t,
        friction: narrow(&friction),
        repulsion: narrow(&repulsion),
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
