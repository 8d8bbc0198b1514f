//! The narrow phase of the hair–hair collisions (AWT §4.1–§4.2), four pairs at a time: closest
//! points of the two segment axes, the distance test, viscous friction (eq. 1) and repulsion
//! (eq. 2) at the closest points.
//!
//! It is the general case of `solver::awt::collide::narrow::contact`, operation for operation
//! (same formulas, same order, same roundings: see [`crate::simd`]), so a lane's results are
//! that routine's bit for bit. Lanes outside the general case are flagged `rare` for the caller
//! to redo with the scalar routine: a segment too short to have a direction (the closest-point
//! routine's early returns), a zero product of squared lengths, axes that intersect (the
//! repulsion normal then comes from the cross product), and anything not finite. Parallel axes
//! (the middle of the overlap) are computed in the lanes: sibling wisps are often nearly so.
//!
//! The caller fills a [`PairBatch`] (structure of arrays, one lane per candidate pair), calls
//! [`narrow`], and reads [`PairOut`].

use super::lanes::{F64x4Portable, Lanes};
use super::Level;

/// Pairs in a batch (a multiple of 4): enough to amortise the call, few enough for the lanes
/// (about 25 kB) to stay in the L1 cache.
pub const BATCH: usize = 64;

/// One segment as the narrow phase reads it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Segment {
    /// The parent node's position, m.
    pub x: [f64; 3],
    /// Child minus parent position, m.
    pub d: [f64; 3],
    /// `|d|²`, computed as `(d.x·d.x + d.y·d.y) + d.z·d.z`.
    pub len2: f64,
    /// The parent node's velocity, m/s.
    pub vp: [f64; 3],
    /// The child node's velocity, m/s.
    pub vc: [f64; 3],
    /// The cylinder's radius, m.
    pub radius: f64,
    /// The child node's mass, kg.
    pub mass: f64,
}

/// One side (first or second segment) of a batch of pairs, lane by lane.
#[derive(Clone, Debug)]
pub struct Side {
    /// [`Segment::x`], per coordinate.
    pub x: [[f64; BATCH]; 3],
    /// [`Segment::d`].
    pub d: [[f64; BATCH]; 3],
    /// [`Segment::len2`].
    pub len2: [f64; BATCH],
    /// [`Segment::vp`].
    pub vp: [[f64; BATCH]; 3],
    /// [`Segment::vc`].
    pub vc: [[f64; BATCH]; 3],
    /// [`Segment::radius`].
    pub radius: [f64; BATCH],
    /// [`Segment::mass`].
    pub mass: [f64; BATCH],
}

impl Default for Side {
    fn default() -> Self {
        Side {
            x: [[0.0; BATCH]; 3],
            d: [[0.0; BATCH]; 3],
            len2: [0.0; BATCH],
            vp: [[0.0; BATCH]; 3],
            vc: [[0.0; BATCH]; 3],
            radius: [0.0; BATCH],
            mass: [0.0; BATCH],
        }
    }
}

impl Side {
    #[inline(always)]
    fn set(&mut self, i: usize, s: &Segment) {
        for k in 0..3 {
            self.x[k][i] = s.x[k];
            self.d[k][i] = s.d[k];
            self.vp[k][i] = s.vp[k];
            self.vc[k][i] = s.vc[k];
        }
        self.len2[i] = s.len2;
        self.radius[i] = s.radius;
        self.mass[i] = s.mass;
    }
}

/// Candidate pairs in structure-of-arrays form: lane `i` is the pair `(a[i], b[i])`.
#[derive(Clone, Debug, Default)]
pub struct PairBatch {
    /// The first segment of each pair.
    pub a: Side,
    /// The second segment.
    pub b: Side,
    len: usize,
}

impl PairBatch {
    /// Adds the pair `(a, b)` in the next lane; returns whether the batch is now full.
    #[inline(always)]
    pub fn push(&mut self, a: &Segment, b: &Segment) -> bool {
        let i = self.len;
        self.a.set(i, a);
        self.b.set(i, b);
        self.len = i + 1;
        self.len == BATCH
    }

    /// Pairs in the batch.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No pair.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Empties the batch (the lanes keep their old values, which [`narrow`] ignores).
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

/// The response parameters, as the scalar routine combines them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairParams {
    /// α, s⁻¹ (k_f = α·m).
    pub friction: f64,
    /// k_r per kilogram, s⁻².
    pub repulsion: f64,
    /// The square of the cosine threshold of the repulsion, `thr · thr`.
    pub cos2_threshold: f64,
    /// The step, floored: `dt.max(1e-12)`, s.
    pub dt_floor: f64,
}

/// What [`narrow`] finds, lane by lane (lanes at and beyond the batch's length are garbage).
#[derive(Clone, Debug)]
pub struct PairOut {
    /// Closest point on the first axis, as a fraction from parent (0) to child (1).
    pub s: [f64; BATCH],
    /// Closest point on the second axis.
    pub t: [f64; BATCH],
    /// Friction (eq. 1) on the first segment, N, per coordinate.
    pub friction: [[f64; BATCH]; 3],
    /// Repulsion (eq. 2) on the first segment, N.
    pub repulsion: [[f64; BATCH]; 3],
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

/// The narrow phase of every pair of `batch`, on the process's [`super::level`].
#[inline]
pub fn narrow(batch: &PairBatch, p: &PairParams, out: &mut PairOut) {
    narrow_on(super::level(), batch, p, out);
}

/// The narrow phase on a given level (tests compare the twins); a level the processor lacks
/// falls back to the portable twin.
pub fn narrow_on(level: Level, batch: &PairBatch, p: &PairParams, out: &mut PairOut) {
    match level {
        #[cfg(target_arch = "x86_64")]
        Level::Avx2 if super::best_available() == Level::Avx2 => {
            // SAFETY: the processor has AVX2 (checked just above, once per process).
            #[allow(unsafe_code)]
            unsafe {
                narrow_avx2(batch, p, out)
            }
        }
        _ => kernel::<F64x4Portable>(batch, p, out),
    }
}

/// The kernel compiled for AVX2.
///
/// # Safety
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(unsafe_code)]
unsafe fn narrow_avx2(batch: &PairBatch, p: &PairParams, out: &mut PairOut) {
    kernel::<super::lanes::F64x4>(batch, p, out);
}

#[inline(always)]
fn at(a: &[f64; BATCH], i: usize) -> &[f64; 4] {
    a[i..i + 4]
        .try_into()
        .expect("a lane group inside the batch")
}

#[inline(always)]
fn at_mut(a: &mut [f64; BATCH], i: usize) -> &mut [f64; 4] {
    (&mut a[i..i + 4])
        .try_into()
        .expect("a lane group inside the batch")
}

#[inline(always)]
fn load3<V: Lanes>(a: &[[f64; BATCH]; 3], i: usize) -> [V; 3] {
    [
        V::load(at(&a[0], i)),
        V::load(at(&a[1], i)),
        V::load(at(&a[2], i)),
    ]
}

/// `(u.x·v.x + u.y·v.y) + u.z·v.z`, as nalgebra's `dot` of 3-vectors.
#[inline(always)]
fn dot<V: Lanes>(u: &[V; 3], v: &[V; 3]) -> V {
    u[0].mul(v[0]).add(u[1].mul(v[1])).add(u[2].mul(v[2]))
}

/// The operation, once for both twins. Every line mirrors a line of the scalar routines
/// (`closest_params` and `contact` in `solver::awt::collide::narrow`).
#[inline(always)]
fn kernel<V: Lanes>(batch: &PairBatch, p: &PairParams, out: &mut PairOut) {
    let (zero, one, half) = (V::splat(0.0), V::splat(1.0), V::splat(0.5));
    let kf = V::splat(p.friction);
    let kr = V::splat(p.repulsion);
    let thr2 = V::splat(p.cos2_threshold);
    let dtf = V::splat(p.dt_floor);
    let (mut hit_all, mut rare_all) = (0u64, 0u64);
    let (a, b) = (&batch.a, &batch.b);
    let mut i = 0;
    while i < batch.len {
        let xa = load3::<V>(&a.x, i);
        let da = load3::<V>(&a.d, i);
        let xb = load3::<V>(&b.x, i);
        let db = load3::<V>(&b.d, i);
        let la = V::load(at(&a.len2, i));
        let le = V::load(at(&b.len2, i));

        // closest_params(xpa, da, la, xpb, db, le)
        let r = [xa[0].sub(xb[0]), xa[1].sub(xb[1]), xa[2].sub(xb[2])];
        let f = dot(&db, &r);
        let rr = dot(&r, &r);
        let scale = la.max_sel(le).max_sel(rr);
        let tiny = V::splat(1e-24).mul(scale);
        // The early returns of a segment shorter than `tiny` (and NaN anywhere in them).
        let mut rare = V::or(V::not(la.gt(tiny)), V::not(le.gt(tiny)));
        let c = dot(&da, &r);
        let bb = dot(&da, &db);
        let denom = la.mul(le).sub(bb.mul(bb));
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
        let s0 = V::select(denom.gt(V::splat(1e-12).mul(la).mul(le)), general, parallel);
        let t0 = bb.mul(s0).add(f).div(le);
        let below = t0.lt(zero);
        let above = t0.gt(one);
        let s = V::select(below, pp.clamp01(), V::select(above, qq.clamp01(), s0));
        let t = V::select(below, zero, V::select(above, one, t0));

        // contact(a, b, p)
        let rsum = V::load(at(&a.radius, i)).add(V::load(at(&b.radius, i)));
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
        let (ma, mb) = (V::load(at(&a.mass, i)), V::load(at(&b.mass, i)));
        rare = V::or(rare, V::not(V::or(ma.le(mb), ma.gt(mb))));
        let m = ma.min_sel(mb);

        // Eq. 1: viscous friction at the closest points.
        let (vpa, vca) = (load3::<V>(&a.vp, i), load3::<V>(&a.vc, i));
        let (vpb, vcb) = (load3::<V>(&b.vp, i), load3::<V>(&b.vc, i));
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
        let len2 = la.mul(le);
        rare = V::or(rare, V::not(len2.gt(zero)));
        let crossing = bb.mul(bb).lt(thr2.mul(len2));
        let d = dist2.sqrt();
        // Intersecting axes: the normal is the cross product's (scalar routine).
        rare = V::or(
            rare,
            V::and(crossing, V::not(d.gt(V::splat(1e-9).mul(rsum)))),
        );
        let n = [delta[0].div(d), delta[1].div(d), delta[2].div(d)];
        let dv = [v1[0].sub(v2[0]), v1[1].sub(v2[1]), v1[2].sub(v2[2])];
        let approach = dot(&dv, &n).neg();
        let push = kr.mul(m).mul(rsum.sub(d)).min_sel(m.mul(approach).div(dtf));
        let on = V::and(crossing, approach.gt(zero));
        for (nk, rep) in n.iter().zip(out.repulsion.iter_mut()) {
            V::select(on, nk.mul(push), zero).store(at_mut(rep, i));
        }
        s.store(at_mut(&mut out.s, i));
        t.store(at_mut(&mut out.t, i));
        hit_all |= u64::from(V::bits(hit)) << i;
        rare_all |= u64::from(V::bits(rare)) << i;
        i += 4;
    }
    // Lanes past the end are garbage: clear their bits.
    let live = if batch.len >= 64 {
        u64::MAX
    } else {
        (1u64 << batch.len) - 1
    };
    out.hit = hit_all & live;
    out.rare = rare_all & live;
}
