//! The box test of the hair–hair broad phase (AWT §4.1), eight pairs at a time: of the
//! segments of one voxel, which later ones may touch a given one. A pair passes when it is
//! tested in this voxel (the cell lists' "min corner" rule: the two masks share no bit), its
//! boxes overlap on every axis (each box already inflated by its own radius), and the two
//! segments share no node and no chain.
//!
//! The AVX2 twin makes the same `>` comparisons of the same f32 values (ordered: false on NaN,
//! as Rust's `>` is) and the same integer equalities as the portable one, so both give the same
//! bits; a test compares them on random voxels with NaNs, infinities and shared nodes.

use super::dispatch::{Avx2, Isa, Portable};

/// Segments a [`VoxelLanes`] holds: the longer cell lists are tested by the caller's own loop.
pub const VOXEL: usize = 4096;

/// Lanes read past the last segment by the eight-wide loads (never counted: masked off).
const PAD: usize = 8;

/// The segments of one voxel, in structure-of-arrays form (about 160 kB: keep it on the heap).
#[derive(Clone, Debug)]
pub struct VoxelLanes {
    /// Min corner of each inflated box, per axis.
    pub lo: [[f32; VOXEL + PAD]; 3],
    /// Max corner of each inflated box, per axis.
    pub hi: [[f32; VOXEL + PAD]; 3],
    /// Parent node slot.
    pub parent: [u32; VOXEL + PAD],
    /// Child node slot.
    pub child: [u32; VOXEL + PAD],
    /// The chain (generalized cylinder): two segments of one chain never collide.
    pub chain: [u32; VOXEL + PAD],
    /// The voxel mask of the cell lists (bit k: the segment's cells start below along axis k).
    pub mask: [u32; VOXEL + PAD],
    len: usize,
}

impl Default for VoxelLanes {
    fn default() -> Self {
        VoxelLanes {
            lo: [[0.0; VOXEL + PAD]; 3],
            hi: [[0.0; VOXEL + PAD]; 3],
            parent: [0; VOXEL + PAD],
            child: [0; VOXEL + PAD],
            chain: [0; VOXEL + PAD],
            mask: [0; VOXEL + PAD],
            len: 0,
        }
    }
}

/// A voxel's lanes and the output of [`row`]: a search's reused scratch.
#[derive(Clone, Debug)]
pub struct VoxelScratch {
    /// The voxel's segments.
    pub lanes: VoxelLanes,
    /// The indices [`row`] writes.
    pub near: [u16; VOXEL],
    /// The voxel's segments as the narrow phase reads them (room for [`VOXEL`]): the pairs of
    /// a dense voxel read them from this copy, near at hand, instead of from all over the
    /// scene's array.
    pub segs: Vec<super::pairs::Segment>,
}

impl Default for VoxelScratch {
    fn default() -> Self {
        VoxelScratch {
            lanes: VoxelLanes::default(),
            near: [0; VOXEL],
            segs: Vec::with_capacity(VOXEL),
        }
    }
}

/// One segment as [`VoxelLanes`] stores it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoxelBox {
    /// Min corner of the inflated box.
    pub lo: [f32; 3],
    /// Max corner.
    pub hi: [f32; 3],
    /// Parent node slot.
    pub parent: u32,
    /// Child node slot.
    pub child: u32,
    /// Chain.
    pub chain: u32,
    /// Voxel mask (3 bits).
    pub mask: u32,
}

impl VoxelLanes {
    /// Empties the voxel.
    #[inline(always)]
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Segments held.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.len
    }

    /// No segment.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Appends a segment (at most [`VOXEL`]).
    #[inline(always)]
    pub fn push(&mut self, b: &VoxelBox) {
        let i = self.len;
        assert!(i < VOXEL, "a voxel holds at most {VOXEL} segments");
        for k in 0..3 {
            self.lo[k][i] = b.lo[k];
            self.hi[k][i] = b.hi[k];
        }
        self.parent[i] = b.parent;
        self.child[i] = b.child;
        self.chain[i] = b.chain;
        self.mask[i] = b.mask;
        self.len = i + 1;
    }

    #[inline(always)]
    fn get(&self, i: usize) -> VoxelBox {
        VoxelBox {
            lo: [self.lo[0][i], self.lo[1][i], self.lo[2][i]],
            hi: [self.hi[0][i], self.hi[1][i], self.hi[2][i]],
            parent: self.parent[i],
            child: self.child[i],
            chain: self.chain[i],
            mask: self.mask[i],
        }
    }
}

/// Whether the pair is tested in this voxel, and whether it passes the box and adjacency
/// tests there: the scalar rule both twins follow.
#[inline(always)]
pub fn pair_rule(a: &VoxelBox, b: &VoxelBox) -> (bool, bool) {
    let here = a.mask & b.mask == 0;
    let apart = (a.lo[0] > b.hi[0])
        | (b.lo[0] > a.hi[0])
        | (a.lo[1] > b.hi[1])
        | (b.lo[1] > a.hi[1])
        | (a.lo[2] > b.hi[2])
        | (b.lo[2] > a.hi[2]);
    let adjacent = (a.parent == b.parent)
        | (a.parent == b.child)
        | (a.child == b.parent)
        | (a.child == b.child)
        | (a.chain == b.chain);
    (here, here & !(apart | adjacent))
}

/// The row test, per instruction set: bits of `(here, near)` for the eight segments
/// `j..j + 8` against segment `k` (lanes at and beyond the voxel's length are garbage).
pub trait BoxRow: Isa {
    /// See the trait.
    fn eight(v: &VoxelLanes, a: &VoxelBox, j: usize) -> (u32, u32);
}

impl BoxRow for Portable {
    #[inline(always)]
    fn eight(v: &VoxelLanes, a: &VoxelBox, j: usize) -> (u32, u32) {
        let (mut here, mut near) = (0, 0);
        for l in 0..8 {
            let (h, n) = pair_rule(a, &v.get(j + l));
            here |= (h as u32) << l;
            near |= (n as u32) << l;
        }
        (here, near)
    }
}

impl BoxRow for Avx2 {
    #[inline(always)]
    fn eight(v: &VoxelLanes, a: &VoxelBox, j: usize) -> (u32, u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: only reached inside an `avx2` target-feature function (see
            // `dispatch::multiversion!`), on a processor that has it; `j + 8 <= VOXEL + PAD`
            // (the caller's loop starts below `len <= VOXEL`), so every unaligned load reads
            // inside its array.
            unsafe {
                let ld = |x: &[f32; VOXEL + PAD]| _mm256_loadu_ps(x.as_ptr().add(j));
                let ldi = |x: &[u32; VOXEL + PAD]| {
                    _mm256_loadu_si256(x.as_ptr().add(j) as *const __m256i)
                };
                let mut apart = _mm256_setzero_ps();
                for k in 0..3 {
                    let (blo, bhi) = (ld(&v.lo[k]), ld(&v.hi[k]));
                    let (alo, ahi) = (_mm256_set1_ps(a.lo[k]), _mm256_set1_ps(a.hi[k]));
                    apart = _mm256_or_ps(apart, _mm256_cmp_ps::<_CMP_GT_OQ>(alo, bhi));
                    apart = _mm256_or_ps(apart, _mm256_cmp_ps::<_CMP_GT_OQ>(blo, ahi));
                }
                let (bp, bc, bch) = (ldi(&v.parent), ldi(&v.child), ldi(&v.chain));
                let (ap, ac) = (
                    _mm256_set1_epi32(a.parent as i32),
                    _mm256_set1_epi32(a.child as i32),
                );
                let adjacent = _mm256_or_si256(
                    _mm256_or_si256(_mm256_cmpeq_epi32(ap, bp), _mm256_cmpeq_epi32(ap, bc)),
                    _mm256_or_si256(
                        _mm256_or_si256(_mm256_cmpeq_epi32(ac, bp), _mm256_cmpeq_epi32(ac, bc)),
                        _mm256_cmpeq_epi32(_mm256_set1_epi32(a.chain as i32), bch),
                    ),
                );
                let shared = _mm256_and_si256(_mm256_set1_epi32(a.mask as i32), ldi(&v.mask));
                let here = _mm256_cmpeq_epi32(shared, _mm256_setzero_si256());
                let out = _mm256_or_si256(_mm256_castps_si256(apart), adjacent);
                let near = _mm256_andnot_si256(out, here);
                (
                    _mm256_movemask_ps(_mm256_castsi256_ps(here)) as u32,
                    _mm256_movemask_ps(_mm256_castsi256_ps(near)) as u32,
                )
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::eight(v, a, j)
        }
    }
}

crate::simd::dispatch::multiversion! {
    /// Of the segments after `k` in the voxel, writes to `near` (in order) those that pass
    /// [`pair_rule`] against segment `k`, and returns how many passed.
    pub fn row<I: BoxRow>(v: &VoxelLanes, k: usize, near: &mut [u16; VOXEL]) -> usize {
        let a = v.get(k);
        let mut n = 0usize;
        let mut j = k + 1;
        while j < v.len {
            let (_, mut hit) = I::eight(v, &a, j);
            if v.len - j < 8 {
                hit &= (1u32 << (v.len - j)) - 1;
            }
            while hit != 0 {
                near[n] = (j + hit.trailing_zeros() as usize) as u16;
                n += 1;
                hit &= hit - 1;
            }
            j += 8;
        }
        n
    }
}

/// How many pairs of segments with these voxel masks (`count[m]` segments with mask `m`)
/// are tested in the voxel: those whose masks share no bit ([`pair_rule`]'s first half).
#[inline]
pub fn pairs_here(count: &[u32; 8]) -> u32 {
    let mut n = count[0] * count[0].saturating_sub(1) / 2;
    for m1 in 0..8 {
        for m2 in m1 + 1..8 {
            if m1 & m2 == 0 {
                n += count[m1] * count[m2];
            }
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::Level;

    #[test]
    fn the_avx2_row_test_gives_the_portable_pairs_and_the_scalar_rule() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -0.0, 0.0];
        let mut v = VoxelLanes::default();
        let mut boxes = Vec::new();
        for round in 0..200 {
            let len = 1 + (next() % 80) as usize + if round % 50 == 0 { 400 } else { 0 };
            v.clear();
            boxes.clear();
            for _ in 0..len {
                let mut f = || {
                    let r = next();
                    if r % 97 == 0 {
                        specials[(r / 97 % 5) as usize]
                    } else {
                        (r % 1000) as f32 / 100.0
                    }
                };
                let (x, y, z) = (f(), f(), f());
                let (w, h, d) = (f(), f(), f());
                let b = VoxelBox {
                    lo: [x, y, z],
                    hi: [x + w, y + h, z + d],
                    parent: (next() % 40) as u32,
                    child: (next() % 40) as u32,
                    chain: (next() % 60) as u32,
                    mask: (next() % 8) as u32,
                };
                v.push(&b);
                boxes.push(b);
            }
            let mut count = [0u32; 8];
            for b in &boxes {
                count[b.mask as usize] += 1;
            }
            let mut here = 0;
            for k in 0..len {
                let (mut p, mut a) = ([0u16; VOXEL], [0u16; VOXEL]);
                let got_p = row(Level::Portable, &v, k, &mut p);
                let got_a = row(Level::Avx2, &v, k, &mut a);
                assert_eq!(got_p, got_a, "round {round}, row {k}");
                assert_eq!(p[..got_p], a[..got_a], "round {round}, row {k}");
                let mut want = Vec::new();
                for (j, b) in boxes.iter().enumerate().skip(k + 1) {
                    let (h, n) = pair_rule(&boxes[k], b);
                    here += h as u32;
                    if n {
                        want.push(j as u16);
                    }
                }
                assert_eq!(p[..got_p], want[..]);
            }
            assert_eq!(pairs_here(&count), here, "round {round}");
        }
    }
}
