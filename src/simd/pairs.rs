//! The narrow phase of the hair–hair collisions (AWT §4.1–§4.2), eight pairs at a time in
//! `f32`: closest points of the two segment axes, the distance test, viscous friction (eq. 1)
//! and repulsion (eq. 2) at the closest points.
//!
//! It is the general case of `solver::awt::collide::narrow::contact`, operation for operation
//! (same formulas, same order, same roundings: see [`crate::simd`]), so a lane's results are
//! that routine's bit for bit. Lanes outside the general case are flagged `rare` for the caller
//! to redo with the scalar routine: a segment too short to have a direction (the closest-point
//! routine's early returns), a zero product of squared lengths, axes that intersect or nearly
//! so (the repulsion normal then comes from the cross product), and anything not finite.
//! Parallel axes (the middle of the overlap) are computed in the lanes: sibling wisps are often
//! nearly so.
//!
//! **Why `f32`.** Eight lanes in an AVX register instead of four `f64`, and a segment in one
//! 64-byte cache line instead of two and a half: the stage is bound by the work per tested
//! pair. The positions of a head of hair are within a metre or two of the origin, so `f32`
//! places a closest point to about 0.1 µm, against wisp radii of a millimetre and more; the
//! thresholds that tell parallel and intersecting axes apart are set well above that rounding
//! (see `narrow::contact`).
//!
//! The caller keeps its segments as [`Segment`]s (or in records that hold one, through
//! `AsRef`), queues up to [`BATCH`] candidate pairs as index pairs, calls [`narrow`], and reads
//! [`PairOut`]. The lanes are filled straight from the records, eight segments at a time, by
//! 8×8 transposes in registers ([`Lanes::transpose`]): copying 34 fields per pair into a
//! structure of arrays first took about a seventh of the hair–hair stage.

use super::lanes::{F32x8Portable, Lanes};
use super::Level;

/// Pairs in a batch (a multiple of 8): enough to amortise the call, few enough for the
/// results (about 2 kB) to stay in the L1 cache.
pub const BATCH: usize = 64;

/// Lanes per group.
const W: usize = 8;

/// A segment whose squared length is at most this fraction of the largest of the pair's
/// squared lengths and squared gap is a point (the closest-point routine's early returns).
pub const TINY: f32 = 1e-12;

/// Axes whose `|d1 × d2|²` is at most this fraction of `|d1|²·|d2|²` (an angle under about
/// 0.6°) are parallel: the closest points are then the middle of the overlap. Far above the
/// `f32` rounding of the difference (about 1e-7), so the general formula is only used where
/// it is accurate to about 1e-3.
pub const PARALLEL: f32 = 1e-4;

/// Axes closer than this fraction of the sum of the radii intersect: the normal then comes
/// from their cross product (the difference of the closest points is rounding).
pub const INTERSECTING: f32 = 1e-3;

/// One segment as the narrow phase reads it: sixteen f32 in two rows of eight (one cache
/// line), so that eight segments become the lanes of their fifteen fields with two 8×8
/// transposes (no copying into a structure of arrays first).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Segment {
    /// The parent node's position, m.
    pub x: [f32; 3],
    /// `|d|²`, computed in f32 as `(d.x·d.x + d.y·d.y) + d.z·d.z` from the rounded `d`.
    pub len2: f32,
    /// Child minus parent position (the difference taken in f64, then rounded), m.
    pub d: [f32; 3],
    /// The cylinder's radius, m.
    pub radius: f32,
    /// The parent node's velocity, m/s.
    pub vp: [f32; 3],
    /// The child node's mass, kg.
    pub mass: f32,
    /// The child node's velocity, m/s.
    pub vc: [f32; 3],
    /// Fills the second row (always 0).
    pad: f32,
}

// Two rows of eight f32, nothing else: what [`Segment::rows`] relies on.
const _: () = assert!(std::mem::size_of::<Segment>() == 64);

impl Segment {
    /// A segment from its fields in f64, each rounded to the nearest f32.
    pub fn new(
        x: [f64; 3],
        d: [f64; 3],
        vp: [f64; 3],
        vc: [f64; 3],
        radius: f64,
        mass: f64,
    ) -> Self {
        let f = |v: [f64; 3]| v.map(|c| c as f32);
        let d = f(d);
        Segment {
            x: f(x),
            len2: (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2],
            d,
            radius: radius as f32,
            vp: f(vp),
            mass: mass as f32,
            vc: f(vc),
            pad: 0.0,
        }
    }

    /// The sixteen f32 as two rows: `[x, len2, d, radius]`, `[vp, mass, vc, 0]`.
    #[inline(always)]
    pub fn rows(&self) -> &[[f32; 8]; 2] {
        // SAFETY: `Segment` is `repr(C)`, sixteen f32 fields and no padding (asserted above), so
        // it has the layout of `[[f32; 8]; 2]`, whose alignment (4) it exceeds.
        #[allow(unsafe_code)]
        unsafe {
            &*(self as *const Segment).cast::<[[f32; 8]; 2]>()
        }
    }
}

/// Eight segments' fields, lane by lane.
struct SegLanes<V> {
    x: [V; 3],
    len2: V,
    d: [V; 3],
    radius: V,
    vp: [V; 3],
    mass: V,
    vc: [V; 3],
}

impl<V: Lanes> SegLanes<V> {
    /// Lane `k` is `segs[k]`.
    #[inline(always)]
    fn load<T: AsRef<Segment>>(segs: [&T; W]) -> Self {
        let rows: [&[[f32; 8]; 2]; W] = std::array::from_fn(|k| segs[k].as_ref().rows());
        let [x0, x1, x2, len2, d0, d1, d2, radius] =
            V::transpose(std::array::from_fn(|k| &rows[k][0]));
        let [v0, v1, v2, mass, c0, c1, c2, _] = V::transpose(std::array::from_fn(|k| &rows[k][1]));
        SegLanes {
            x: [x0, x1, x2],
            len2,
            d: [d0, d1, d2],
            radius,
            vp: [v0, v1, v2],
            mass,
            vc: [c0, c1, c2],
        }
    }
}

/// The response parameters, as the scalar routine combines them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// α, s⁻¹ (k_f = α·m).
    pub friction: f32,
    /// k_r per kilogram, s⁻².
    pub repulsion: f32,
    /// The square of the cosine threshold of the repulsion, `thr · thr`.
    pub cos2_threshold: f32,
    /// The step, floored: `dt.max(1e-12)`, s.
    pub dt_floor: f32,
}

/// What [`narrow`] finds, lane by lane (lanes at and beyond the number of pairs are garbage).
#[derive(Clone, Debug)]
pub struct PairOut {
    /// Closest point on the first axis, as a fraction from parent (0) to child (1).
    pub s: [f32; BATCH],
    /// Closest point on the second axis.
    pub t: [f32; BATCH],
    /// Friction (eq. 1) on the first segment, N, per coordinate.
    pub friction: [[f32; BATCH]; 3],
    /// Repulsion (eq. 2) on the first segment, N.
    pub repulsion: [[f32; BATCH]; 3],
    /// Bit `i`: the cylinders of pair `i` intersect (valid where `rare` is clear).
    pub hit: u64,
    /// Bit `i`: pair `i` is outside the general case; redo it with the scalar routine.
    pub rare: u64,
}

impl Default for PairOut {
    fn default() -> Self {
        PairOut {
            s: [0.0; BATCH],
            t: [0.0; BATCH],
            friction: [[0.0; BATCH]; 3],
            repulsion: [[0.0; BATCH]; 3],
            hit: 0,
            rare: 0,
        }
    }
}

/// The narrow phase of the pairs `pairs` (at most [`BATCH`]; lane `i` is the pair of segments
/// `segs[pairs[i].0]`, `segs[pairs[i].1]`), on the process's [`super::level`].
#[inline]
pub fn narrow<T: AsRef<Segment>>(
    segs: &[T],
    pairs: &[(u32, u32)],
    p: &PairParams,
    out: &mut PairOut,
) {
    narrow_on(super::level(), segs, pairs, p, out);
}

/// The narrow phase on a given level (tests compare the twins); a level the processor lacks
/// falls back to the portable twin.
pub fn narrow_on<T: AsRef<Segment>>(
    level: Level,
    segs: &[T],
    pairs: &[(u32, u32)],
    p: &PairParams,
    out: &mut PairOut,
) {
    assert!(pairs.len() <= BATCH, "at most {BATCH} pairs a call");
    match level {
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 if super::best_available() == Level::Avx2 => {
            // SAFETY: the processor has AVX2 (checked just above, once per process).
            #[allow(unsafe_code)]
            unsafe {
                narrow_avx2(segs, pairs, p, out)
            }
        }
        _ => kernel::<F32x8Portable, T>(segs, pairs, p, out),
    }
}

/// The kernel compiled for AVX2.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(unsafe_code)]
unsafe fn narrow_avx2<T: AsRef<Segment>>(
    segs: &[T],
    pairs: &[(u32, u32)],
    p: &PairParams,
    out: &mut PairOut,
) {
    kernel::<super::lanes::F32x8, T>(segs, pairs, p, out);
}

#[inline(always)]
fn at_mut(a: &mut [f32; BATCH], i: usize) -> &mut [f32; W] {
    (&mut a[i..i + W])
        .try_into()
        .expect("a lane group inside the batch")
}

/// `(u.x·v.x + u.y·v.y) + u.z·v.z`, as nalgebra's `dot` of 3-vectors.
#[inline(always)]
fn dot<V: Lanes>(u: &[V; 3], v: &[V; 3]) -> V {
    u[0].mul(v[0]).add(u[1].mul(v[1])).add(u[2].mul(v[2]))
}

/// The pairs of lanes `i..i + 8` as indices; lanes past the end repeat the last pair (the
/// kernel clears their bits). A function, not a closure in the kernel: a closure is not
/// compiled for AVX2 with the function it sits in unless the compiler happens to inline it.
#[inline(always)]
fn lane_pairs(pairs: &[(u32, u32)], i: usize) -> [(usize, usize); W] {
    let last = pairs.len() - 1;
    let mut out = [(0, 0); W];
    for (k, o) in out.iter_mut().enumerate() {
        let (a, b) = pairs[(i + k).min(last)];
        *o = (a as usize, b as usize);
    }
    out
}

/// The operation, once for both twins. Every line mirrors a line of the scalar routines
/// (`closest_params` and `contact` in `solver::awt::collide::narrow`).
#[inline(always)]
fn kernel<V: Lanes, T: AsRef<Segment>>(
    segs: &[T],
    pairs: &[(u32, u32)],
    p: &PairParams,
    out: &mut PairOut,
) {
    let (zero, one, half) = (V::splat(0.0), V::splat(1.0), V::splat(0.5));
    let kf = V::splat(p.friction);
    let kr = V::splat(p.repulsion);
    let thr2 = V::splat(p.cos2_threshold);
    let dtf = V::splat(p.dt_floor);
    let (mut hit_all, mut rare_all) = (0u64, 0u64);
    let n = pairs.len();
    let mut i = 0;
    while i < n {
        let lp = lane_pairs(pairs, i);
        let a = SegLanes::<V>::load(std::array::from_fn(|k| &segs[lp[k].0]));
        let b = SegLanes::<V>::load(std::array::from_fn(|k| &segs[lp[k].1]));
        let (xa, da, la) = (a.x, a.d, a.len2);
        let (xb, db, le) = (b.x, b.d, b.len2);

        // closest_params(xa, da, la, xb, db, le)
        let r = [xa[0].sub(xb[0]), xa[1].sub(xb[1]), xa[2].sub(xb[2])];
        let f = dot(&db, &r);
        let rr = dot(&r, &r);
        let scale = la.max_sel(le).max_sel(rr);
        let tiny = V::splat(TINY).mul(scale);
        // The early returns of a segment shorter than `tiny` (and NaN anywhere in them).
        let mut rare = V::or(V::not(la.gt(tiny)), V::not(le.gt(tiny)));
        let c = dot(&da, &r);
        let bb = dot(&da, &db);
        let len2 = la.mul(le);
        let denom = len2.sub(bb.mul(bb));
        let general = bb.mul(f).sub(c.mul(le)).div(denom).clamp01();
        // Parallel: seg 2's ends project on seg 1 at -c/a and (b - c)/a.
        let pp = c.neg().div(la);
        let qq = bb.sub(c).div(la);
        let lo = pp.min_sel(qq).max_sel(zero);
        let hi = pp.max_sel(qq).min_sel(one);
        let parallel = V::select(
            lo.le(hi),
            half.mul(lo.add(hi)),
            half.mul(pp.add(qq)).clamp01(),
        );
        let s0 = V::select(denom.gt(V::splat(PARALLEL).mul(len2)), general, parallel);
        let t0 = bb.mul(s0).add(f).div(le);
        let below = t0.lt(zero);
        let above = t0.gt(one);
        let s = V::select(below, pp.clamp01(), V::select(above, qq.clamp01(), s0));
        let t = V::select(below, zero, V::select(above, one, t0));

        // contact(a, b, p)
        let rsum = a.radius.add(b.radius);
        let p1 = [
            xa[0].add(da[0].mul(s)),
            xa[1].add(da[1].mul(s)),
            xa[2].add(da[2].mul(s)),
        ];
        let p2 = [
            xb[0].add(db[0].mul(t)),
            xb[1].add(db[1].mul(t)),
            xb[2].add(db[2].mul(t)),
        ];
        let delta = [p1[0].sub(p2[0]), p1[1].sub(p2[1]), p1[2].sub(p2[2])];
        let dist2 = dot(&delta, &delta);
        let r2 = rsum.mul(rsum);
        let hit = dist2.lt(r2);
        // A NaN distance or radius: the scalar routine's `dist2 >= r * r` is false there.
        rare = V::or(rare, V::not(V::or(hit, dist2.ge(r2))));
        let (ma, mb) = (a.mass, b.mass);
        rare = V::or(rare, V::not(V::or(ma.le(mb), ma.gt(mb))));
        let m = ma.min_sel(mb);

        // Eq. 1: viscous friction at the closest points.
        let (vpa, vca) = (a.vp, a.vc);
        let (vpb, vcb) = (b.vp, b.vc);
        let (ws, wt) = (one.sub(s), one.sub(t));
        let v1: [V; 3] = std::array::from_fn(|k| vpa[k].mul(ws).add(vca[k].mul(s)));
        let v2: [V; 3] = std::array::from_fn(|k| vpb[k].mul(wt).add(vcb[k].mul(t)));
        let kfm = kf.mul(m);
        for k in 0..3 {
            v2[k]
                .sub(v1[k])
                .mul(kfm)
                .store(at_mut(&mut out.friction[k], i));
        }

        // Eq. 2: repulsion between wisps crossing at a large enough angle, while they approach,
        // capped at the impulse that stops the approach within the step.
        rare = V::or(rare, V::not(len2.gt(zero)));
        let crossing = bb.mul(bb).lt(thr2.mul(len2));
        // Most wisps in contact are near parallel (friction only): a group of eight with no
        // crossing pair in contact skips the normal's root and four divisions. Its repulsion
        // is zero, as the full computation stores; a crossing lane that is not in contact is
        // then not marked rare, which changes nothing: the scalar routine returns no contact
        // for it either (`dist2 >= r * r`; a NaN distance is marked rare above).
        if V::bits(V::and(crossing, hit)) == 0 {
            for rep in out.repulsion.iter_mut() {
                zero.store(at_mut(rep, i));
            }
        } else {
            let d = dist2.sqrt();
            // Intersecting axes: the normal is the cross product's (scalar routine).
            rare = V::or(
                rare,
                V::and(crossing, V::not(d.gt(V::splat(INTERSECTING).mul(rsum)))),
            );
            let n = [delta[0].div(d), delta[1].div(d), delta[2].div(d)];
            let dv = [v1[0].sub(v2[0]), v1[1].sub(v2[1]), v1[2].sub(v2[2])];
            let approach = dot(&dv, &n).neg();
            let push = kr.mul(m).mul(rsum.sub(d)).min_sel(m.mul(approach).div(dtf));
            let on = V::and(crossing, approach.gt(zero));
            for (nk, rep) in n.iter().zip(out.repulsion.iter_mut()) {
                V::select(on, nk.mul(push), zero).store(at_mut(rep, i));
            }
        }
        s.store(at_mut(&mut out.s, i));
        t.store(at_mut(&mut out.t, i));
        hit_all |= u64::from(V::bits(hit)) << i;
        rare_all |= u64::from(V::bits(rare)) << i;
        i += W;
    }
    // Lanes past the end are garbage: clear their bits.
    let live = if n >= 64 { u64::MAX } else { (1u64 << n) - 1 };
    out.hit = hit_all & live;
    out.rare = rare_all & live;
}
