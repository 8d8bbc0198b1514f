//! The batched narrow phase: the pairs that pass the cheap filters are queued as index pairs
//! and tested [`BATCH`] at a time by `crate::simd::pairs` (eight `f32` lanes at once, read
//! straight from the [`SegPre`] records), which finds the same contacts with the same forces
//! as [`contact`], bit for bit; the few pairs outside its general case are handed back and
//! done by [`contact`] itself.

use crate::simd::pairs::{self, PairOut, PairParams, BATCH};

use super::*;

/// One segment's node slots, their `1 / mass` (see [`Broad`]) and its child's mass, for the
/// loads of its contacts.
#[derive(Clone, Copy, Default)]
pub(super) struct SegEnds {
    pub(super) parent: u32,
    pub(super) child: u32,
    pub(super) inv_parent: f64,
    pub(super) inv_child: f64,
    /// The child node's mass (the pair's mass is the lighter child's, as in [`Response`]).
    pub(super) mass: f64,
}

/// Queued pairs and the lanes' results; lives on the searching thread's stack (about 3 kB).
///
/// Each contact found also adds its shares to the per-node loads of [`Response`] at once,
/// while its data is still in the cache (a second pass over the contact list, tens of
/// thousands of 48-byte entries, used to cost a tenth of the stage).
pub(super) struct Batched<'a> {
    out: PairOut,
    /// The queued pairs, as indices into the per-segment data; `ids[..len]`.
    ids: [(u32, u32); BATCH],
    len: usize,
    params: PairParams,
    /// Per node slot: 1 / mass (see [`Broad`]).
    ends: &'a [SegEnds],
    /// Per node slot: the loads of this search's contacts.
    loads: &'a mut [f64],
}

impl<'a> Batched<'a> {
    pub(super) fn new(p: &ContactParams, ends: &'a [SegEnds], loads: &'a mut [f64]) -> Self {
        Batched {
            ends,
            loads,
            out: PairOut::default(),
            ids: [(0, 0); BATCH],
            len: 0,
            params: pair_params(p),
        }
    }

    /// Queues the pair `(a, b)` (`a` the lower index, as [`contact`] wants); when the batch is
    /// full, tests it and appends its contacts to `out`, in queue order.
    #[inline(always)]
    pub(super) fn push(&mut self, pre: &[SegPre], a: usize, b: usize, out: &mut Vec<Contact>) {
        self.ids[self.len] = (a as u32, b as u32);
        self.len += 1;
        if self.len == BATCH {
            self.flush(pre, out);
        }
    }

    /// Tests the queued pairs and appends their contacts to `out`, in queue order.
    pub(super) fn flush(&mut self, pre: &[SegPre], out: &mut Vec<Contact>) {
        let n = self.len;
        if n == 0 {
            return;
        }
        pairs::narrow(pre, &self.ids[..n], &self.params, &mut self.out);
        self.emit(n, pre, out);
        self.len = 0;
    }

    /// Adds a contact's shares to the loads of its four nodes ([`Response::record`]).
    #[inline(always)]
    fn record(&mut self, (a, b): (u32, u32), s: f32, t: f32) {
        let (ea, eb) = (self.ends[a as usize], self.ends[b as usize]);
        // The lighter child's mass, as `Response::record` takes it.
        let m = ea.mass.min(eb.mass);
        let (s, t) = (f64::from(s), f64::from(t));
        for (n, share, inv_mass) in [
            (ea.parent, 1.0 - s, ea.inv_parent),
            (ea.child, s, ea.inv_child),
            (eb.parent, 1.0 - t, eb.inv_parent),
            (eb.child, t, eb.inv_child),
        ] {
            self.loads[n as usize] += share * m * inv_mass;
        }
    }

    fn emit(&mut self, n: usize, pre: &[SegPre], out: &mut Vec<Contact>) {
        let mut todo = self.out.hit | self.out.rare;
        while todo != 0 {
            let o = &self.out;
            let i = todo.trailing_zeros() as usize;
            todo &= todo - 1;
            debug_assert!(i < n);
            let (a, b) = self.ids[i];
            let c = if o.rare >> i & 1 != 0 {
                match contact(&pre[a as usize], &pre[b as usize], (a, b), &self.params) {
                    Some(c) => c,
                    None => continue,
                }
            } else {
                Contact {
                    a,
                    b,
                    s: o.s[i],
                    t: o.t[i],
                    friction: [0, 1, 2].map(|k| o.friction[k][i]),
                    repulsion: [0, 1, 2].map(|k| o.repulsion[k][i]),
                }
            };
            self.record((a, b), c.s, c.t);
            out.push(c);
        }
    }

    /// The contacts of `pairs` on a given level of `crate::simd` (tests compare the levels
    /// with one another and with [`contact`]).
    #[cfg(test)]
    pub(super) fn run_on(
        &mut self,
        level: crate::simd::Level,
        pre: &[SegPre],
        pairs_ab: &[(usize, usize)],
        out: &mut Vec<Contact>,
    ) {
        for chunk in pairs_ab.chunks(BATCH) {
            for (id, &(a, b)) in self.ids.iter_mut().zip(chunk) {
                *id = (a as u32, b as u32);
            }
            let n = chunk.len();
            pairs::narrow_on(level, pre, &self.ids[..n], &self.params, &mut self.out);
            self.emit(n, pre, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::simd::pairs::Segment;
    use crate::simd::Level;

    /// SplitMix64: seeded, no dependency.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn f(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.f()
        }
        fn vec(&mut self, s: f64) -> Vector3<f64> {
            Vector3::new(self.range(-s, s), self.range(-s, s), self.range(-s, s))
        }
    }

    fn seg(rng: &mut Rng, xp: Vector3<f64>, d: Vector3<f64>, radius: f64) -> SegPre {
        SegPre {
            lane: Segment::new(
                xp.into(),
                d.into(),
                rng.vec(0.5).into(),
                rng.vec(0.5).into(),
                radius,
                rng.range(1e-5, 2e-3),
            ),
        }
    }

    /// Pairs of every kind the narrow phase meets, and the kinds it must hand back: random,
    /// parallel (and anti-parallel, overlapping or not), nearly parallel, touching (distance =
    /// r1 + r2 up to rounding), intersecting axes, identical, and zero-length or tiny segments.
    /// Positions up to a metre from the origin, as on a head.
    fn pairs(n: usize, seed: u64) -> Vec<SegPre> {
        let mut rng = Rng(seed);
        let mut out = Vec::with_capacity(2 * n);
        for k in 0..n {
            let xa = rng.vec(0.05) + rng.vec(1.0);
            let da = rng.vec(0.02);
            let (ra, rb) = (rng.range(0.001, 0.02), rng.range(0.001, 0.02));
            let mut a = seg(&mut rng, xa, da, ra);
            let (xb, db) = match k % 9 {
                // Parallel or anti-parallel, a little apart along and across.
                1 => (xa + rng.vec(0.02), da * rng.range(-2.0, 2.0)),
                // Exactly on a's axis: collinear.
                2 => (xa + da * rng.range(-1.0, 2.0), da * rng.range(-1.5, 1.5)),
                // Axes crossing at a point of both.
                3 => {
                    let db = rng.vec(0.02);
                    let (u, w) = (rng.f(), rng.f());
                    (xa + da * u - db * w, db)
                }
                // Identical.
                4 => (xa, da),
                // Zero-length or tiny second segment, or both.
                5 => (
                    xa + rng.vec(0.02),
                    [Vector3::zeros(), rng.vec(1e-9), rng.vec(0.02)][rng.next_u64() as usize % 3],
                ),
                // Nearly parallel: around the parallel threshold.
                8 => (
                    xa + rng.vec(0.01),
                    (da + rng.vec(0.02) * 10f64.powf(rng.range(-4.0, -1.0))) * rng.range(0.5, 1.5),
                ),
                _ => (xa + rng.vec(0.03), rng.vec(0.02)),
            };
            if k % 9 == 5 && rng.next_u64().is_multiple_of(2) {
                a.lane.d = [0.0; 3];
                a.lane.len2 = 0.0;
            }
            let mut b = seg(&mut rng, xb, db, rb);
            if k % 9 == 6 {
                // Touching: radii summing to the distance of the closest points.
                let (a, b) = (&mut a.lane, &mut b.lane);
                let (s, t) = closest_params32(&a.x, &a.d, a.len2, &b.x, &b.d, b.len2);
                let p1: [f32; 3] = std::array::from_fn(|k| a.x[k] + a.d[k] * s);
                let p2: [f32; 3] = std::array::from_fn(|k| b.x[k] + b.d[k] * t);
                let w = [p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]];
                let dist = ((w[0] * w[0] + w[1] * w[1]) + w[2] * w[2]).sqrt();
                a.radius = dist * 0.5;
                b.radius = dist - dist * 0.5;
            }
            if k % 16 == 7 {
                // Equal masses and velocities (no relative motion at all).
                b.lane.mass = a.lane.mass;
                b.lane.vp = a.lane.vp;
                b.lane.vc = a.lane.vc;
            }
            out.push(a);
            out.push(b);
        }
        out
    }

    /// Node slots `2i` (parent) and `2i + 1` (child) for segment `i`.
    fn boxes_of(pre: &[SegPre]) -> Vec<SegBox> {
        (0..pre.len() as u32)
            .map(|i| SegBox {
                parent: 2 * i,
                child: 2 * i + 1,
                chain: i,
                ..SegBox::default()
            })
            .collect()
    }

    /// The boxes' node slots, every node of mass 1.
    fn ends_of(boxes: &[SegBox]) -> Vec<SegEnds> {
        boxes
            .iter()
            .map(|b| SegEnds {
                parent: b.parent,
                child: b.child,
                inv_parent: 1.0,
                inv_child: 1.0,
                mass: 1.0,
            })
            .collect()
    }

    fn bits(c: &Contact) -> [u64; 10] {
        let f = c.friction.map(|x| u64::from(x.to_bits()));
        let r = c.repulsion.map(|x| u64::from(x.to_bits()));
        [
            (u64::from(c.a) << 32) | u64::from(c.b),
            u64::from(c.s.to_bits()),
            u64::from(c.t.to_bits()),
            f[0],
            f[1],
            f[2],
            r[0],
            r[1],
            r[2],
            0,
        ]
    }

    #[test]
    fn batched_narrow_phase_matches_the_scalar_one_bit_for_bit() {
        // 10,003 pairs: the last batch (19 pairs) ends inside a group of eight lanes.
        let pre = pairs(10_003, 25);
        let idx: Vec<(usize, usize)> = (0..10_003).map(|k| (2 * k, 2 * k + 1)).collect();
        for (thr, dt) in [(0.5f64, 0.01), (0.9, 0.01), (1.5, 1e-13), (0.0, 0.004)] {
            let p = ContactParams {
                friction: 40.0,
                repulsion: 2000.0,
                cos_angle_threshold: thr,
                epsilon: 0.0,
                dt,
            };
            let scalar: Vec<Contact> = idx
                .iter()
                .filter_map(|&(a, b)| {
                    contact(&pre[a], &pre[b], (a as u32, b as u32), &pair_params(&p))
                })
                .collect();
            assert!(
                scalar.len() > 2_000 && scalar.len() < 9_000,
                "a mix of hits and misses: {}",
                scalar.len()
            );
            let mut levels = vec![Level::Portable];
            if crate::simd::best_available() != Level::Portable {
                levels.push(crate::simd::best_available());
            }
            let boxes = boxes_of(&pre);
            let ends = ends_of(&boxes);
            for level in levels {
                let mut loads = vec![0.0; 2 * pre.len()];
                let mut b = Batched::new(&p, &ends, &mut loads);
                let mut out = Vec::new();
                b.run_on(level, &pre, &idx, &mut out);
                assert_eq!(out.len(), scalar.len(), "{level:?}, thr {thr}");
                for (x, y) in out.iter().zip(&scalar) {
                    assert_eq!(bits(x), bits(y), "{level:?}, thr {thr}: {x:?} vs {y:?}");
                }
            }
        }
    }

    /// The lanes handle the general case themselves: only a few of the random pairs are handed
    /// back to the scalar routine.
    #[test]
    fn few_pairs_are_handed_back() {
        let pre = pairs(4_096, 7);
        let p = ContactParams {
            friction: 40.0,
            repulsion: 2000.0,
            cos_angle_threshold: 0.9,
            epsilon: 0.0,
            dt: 0.01,
        };
        let (ends, mut loads) = (ends_of(&boxes_of(&pre)), vec![0.0; 2 * pre.len()]);
        let mut b = Batched::new(&p, &ends, &mut loads);
        let (mut rare, mut total) = (0, 0);
        let idx: Vec<(u32, u32)> = (0..4_096).map(|k| (2 * k, 2 * k + 1)).collect();
        for chunk in idx.chunks(BATCH) {
            pairs::narrow_on(Level::Portable, &pre, chunk, &b.params, &mut b.out);
            rare += b.out.rare.count_ones();
            total += chunk.len();
        }
        // Kinds 3 and 5 of `pairs` (two in nine) are degenerate on purpose.
        assert!(rare as usize <= total * 3 / 8, "{rare} of {total}");
    }

    /// The `f32` closest points are those of the `f64` routine (parry's, see
    /// `narrow::tests`) to well within a wisp's radius: on random and nearly parallel pairs a
    /// metre from the origin, the distance between the axes agrees to a micrometre where they
    /// are not parallel, and where the closest points are unique (axes crossing at more than
    /// a few degrees) so do the points. Below [`pairs::PARALLEL`] both take the middle of the
    /// overlap, the `f32` routine from a wider angle (about 0.6° against 1e-6 rad), which is
    /// farther than the nearest points by at most the segment's length times the sine.
    #[test]
    fn f32_closest_points_agree_with_the_f64_routine() {
        let pre = pairs(20_000, 11);
        let (mut unique, mut total, mut parallel) = (0, 0, 0);
        for k in 0..20_000 {
            let (a, b) = (&pre[2 * k].lane, &pre[2 * k + 1].lane);
            let w = |v: [f32; 3]| Vector3::from(v.map(f64::from));
            let (xa, da, xb, db) = (w(a.x), w(a.d), w(b.x), w(b.d));
            let (la, le) = (da.norm_squared(), db.norm_squared());
            if la < 1e-8 || le < 1e-8 {
                continue; // points: the scalar routine's own branches
            }
            let (s64, t64) = closest_params(&xa, &da, la, &xb, &db, le);
            let (s, t) = closest_params32(&a.x, &a.d, a.len2, &b.x, &b.d, b.len2);
            let (s, t) = (f64::from(s), f64::from(t));
            let gap = |s: f64, t: f64| ((xa + da * s) - (xb + db * t)).norm();
            let (want, got) = (gap(s64, t64), gap(s, t));
            let sin2 = da.cross(&db).norm_squared() / (la * le);
            let slack = if sin2 > 2.0 * f64::from(pairs::PARALLEL) {
                1e-6
            } else {
                parallel += 1;
                la.max(le).sqrt() * (2.0 * f64::from(pairs::PARALLEL)).sqrt() + 1e-6
            };
            assert!(
                got >= want - 1e-6 && got - want < slack,
                "pair {k} (sin² {sin2:e}): axes {want} apart, f32 closest points {got}"
            );
            total += 1;
            if sin2 > 1e-2 {
                unique += 1;
                let (p64, p32) = (xa + da * s64, xa + da * s);
                assert!((p64 - p32).norm() < 1e-5, "pair {k}: {p64} vs {p32}");
            }
        }
        assert!(parallel > 1_000, "{parallel} nearly parallel pairs");
        assert!(total > 15_000 && unique > 5_000, "{unique} of {total}");
    }
}
