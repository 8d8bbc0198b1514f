//! The hair–hair candidate loop's filter, eight cell entries at a time: which entries of a run
//! are found in this cell (their flag bits and the probe's share none) and, of those, whose box
//! overlaps the probe's on every axis. AVX compares on structure-of-arrays bounds
//! (`solver::awt::collide::grid` keeps them in cell-list order), and their portable twin.
//!
//! Both compute, per entry, `!(probe.lo > hi) && !(lo > probe.hi)` on each axis with Rust's
//! `>` (false on NaN, as the ordered quiet `_CMP_GT_OQ` is), so the twins agree bit for bit,
//! NaN and infinite bounds included.

use super::dispatch::{Avx2, Portable};

/// Entries a call looks at.
pub const RUN: usize = 8;

/// The box compared with a run of entries, and the flag bits an entry must not share with it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Probe {
    /// Its box's lower corner.
    pub lo: [f32; 3],
    /// Its box's upper corner.
    pub hi: [f32; 3],
    /// Compared with each entry's word: the entry is found when `word & flags == 0`.
    pub flags: u32,
}

/// Boxes and words in structure-of-arrays form: entry `j` is `lo[k][j]`, `hi[k][j]`, `word[j]`.
/// A run reads entries `at..at + RUN`, so the arrays hold [`RUN`] entries of padding past the
/// last real one (the caller masks off the entries past its own range).
#[derive(Clone, Copy, Debug)]
pub struct Entries<'a> {
    /// Per axis, the entries' lower bounds.
    pub lo: [&'a [f32]; 3],
    /// Per axis, the entries' upper bounds.
    pub hi: [&'a [f32]; 3],
    /// The entries' words (flag bits the probe's must not share, and whatever else).
    pub word: &'a [u32],
}

/// The filter, per instruction set.
pub trait BoxTest {
    /// For entries `at..at + RUN`: `(found, near)`, bit `j` of `found` when
    /// `word[at + j] & probe.flags == 0`, bit `j` of `near` when that holds and the two boxes
    /// overlap (touching counts) on all three axes. Panics if an array is shorter than
    /// `at + RUN`.
    fn run8(probe: &Probe, e: &Entries, at: usize) -> (u32, u32);
}

impl BoxTest for Portable {
    #[inline(always)]
    fn run8(probe: &Probe, e: &Entries, at: usize) -> (u32, u32) {
        let word = &e.word[at..at + RUN];
        let lo = e.lo.map(|s| &s[at..at + RUN]);
        let hi = e.hi.map(|s| &s[at..at + RUN]);
        let (mut found, mut near) = (0u32, 0u32);
        for j in 0..RUN {
            let f = word[j] & probe.flags == 0;
            // Non-short-circuit `|`: the six comparisons are independent.
            let mut apart = false;
            for k in 0..3 {
                apart |= (probe.lo[k] > hi[k][j]) | (lo[k][j] > probe.hi[k]);
            }
            found |= (f as u32) << j;
            near |= ((f & !apart) as u32) << j;
        }
        (found, near)
    }
}

impl BoxTest for Avx2 {
    /// One 8-lane integer test of the words and six 8-lane compares of the bounds. Only to be
    /// inlined into functions compiled with `#[target_feature(enable = "avx2")]` on a
    /// processor that has it (`crate::simd::dispatch::multiversion!` does both).
    #[inline(always)]
    fn run8(probe: &Probe, e: &Entries, at: usize) -> (u32, u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            let word = &e.word[at..at + RUN];
            let lo = e.lo.map(|s| &s[at..at + RUN]);
            let hi = e.hi.map(|s| &s[at..at + RUN]);
            // SAFETY: AVX2 is there (see above); every load reads eight elements of a slice
            // just checked to hold eight.
            #[allow(unsafe_code)]
            unsafe {
                let w = _mm256_loadu_si256(word.as_ptr().cast());
                let shared = _mm256_and_si256(w, _mm256_set1_epi32(probe.flags as i32));
                let found = _mm256_cmpeq_epi32(shared, _mm256_setzero_si256());
                let mut apart = _mm256_setzero_ps();
                for k in 0..3 {
                    let (l, h) = (
                        _mm256_loadu_ps(lo[k].as_ptr()),
                        _mm256_loadu_ps(hi[k].as_ptr()),
                    );
                    let below = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_set1_ps(probe.lo[k]), h);
                    let above = _mm256_cmp_ps::<_CMP_GT_OQ>(l, _mm256_set1_ps(probe.hi[k]));
                    apart = _mm256_or_ps(apart, _mm256_or_ps(below, above));
                }
                let found = _mm256_castsi256_ps(found);
                (
                    _mm256_movemask_ps(found) as u32,
                    _mm256_movemask_ps(_mm256_andnot_ps(apart, found)) as u32,
                )
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::run8(probe, e, at)
        }
    }
}

/// Random boxes for the tests of the filter and of its callers.
#[cfg(test)]
pub(crate) mod test_boxes {
    /// A xorshift generator of boxes: apart, touching, overlapping and inside one another,
    /// with a NaN or infinite bound one time in forty.
    pub(crate) struct Boxes(pub(crate) u64);

    impl Boxes {
        /// A number in `0..n`.
        pub(crate) fn pick(&mut self, n: usize) -> usize {
            let s = &mut self.0;
            *s ^= *s << 13;
            *s ^= *s >> 7;
            *s ^= *s << 17;
            (*s % n as u64) as usize
        }

        /// The bounds `(lo, hi)` of a box.
        pub(crate) fn bounds(&mut self) -> ([f32; 3], [f32; 3]) {
            const VALS: [f32; 9] = [
                -1.0,
                0.0,
                -0.0,
                0.25,
                0.5,
                1.0,
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ];
            let lo: [f32; 3] = std::array::from_fn(|_| {
                if self.pick(40) == 0 {
                    VALS[6 + self.pick(3)]
                } else {
                    VALS[self.pick(6)]
                }
            });
            let hi: [f32; 3] = std::array::from_fn(|k| {
                if self.pick(40) == 0 {
                    VALS[6 + self.pick(3)]
                } else {
                    lo[k] + [0.0, 0.25, 0.5, 1.0][self.pick(4)]
                }
            });
            (lo, hi)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::simd::dispatch::multiversion! {
        fn runs<I: BoxTest>(probes: &[Probe], e: &Entries, n: usize) -> Vec<(u32, u32)> {
            let mut out = Vec::new();
            for p in probes {
                for at in 0..n {
                    out.push(I::run8(p, e, at));
                }
            }
            out
        }
    }

    /// The AVX2 filter gives the portable twin's bits on boxes apart, touching, overlapping and
    /// inside one another, with NaN and infinite bounds and every combination of flag bits;
    /// and the portable twin is the scalar rule written out.
    #[test]
    fn the_avx2_filter_gives_the_portable_bits_nan_and_infinities_included() {
        let mut rng = test_boxes::Boxes(0x2545_f491_4f6c_dd1d);
        let n = 3000;
        let boxes: Vec<_> = (0..n + RUN).map(|_| rng.bounds()).collect();
        let word: Vec<u32> = (0..n + RUN)
            .map(|j| (rng.pick(8) as u32) << 29 | j as u32)
            .collect();
        let lo: [Vec<f32>; 3] = std::array::from_fn(|k| boxes.iter().map(|b| b.0[k]).collect());
        let hi: [Vec<f32>; 3] = std::array::from_fn(|k| boxes.iter().map(|b| b.1[k]).collect());
        let e = Entries {
            lo: [&lo[0][..], &lo[1], &lo[2]],
            hi: [&hi[0][..], &hi[1], &hi[2]],
            word: &word,
        };
        let probes: Vec<Probe> = (0..8)
            .map(|_| {
                let (lo, hi) = rng.bounds();
                let flags = (rng.pick(8) as u32) << 29;
                Probe { lo, hi, flags }
            })
            .collect();
        let portable = runs(crate::simd::Level::Portable, &probes, &e, n);
        let best = runs(crate::simd::best_available(), &probes, &e, n);
        assert_eq!(best, portable, "on {:?}", crate::simd::best_available());
        // The portable twin against the rule, entry by entry.
        let (mut found_count, mut near_count, mut total) = (0, 0, 0);
        for (i, p) in probes.iter().enumerate() {
            for at in 0..n {
                let (found, near) = portable[i * n + at];
                for j in 0..RUN {
                    let b = &boxes[at + j];
                    let f = word[at + j] & p.flags == 0;
                    let apart = (0..3).any(|k| p.lo[k] > b.1[k] || b.0[k] > p.hi[k]);
                    assert_eq!(found >> j & 1 == 1, f);
                    assert_eq!(near >> j & 1 == 1, f && !apart, "{p:?} {b:?}");
                    found_count += usize::from(f);
                    near_count += usize::from(f && !apart);
                    total += 1;
                }
            }
        }
        assert!(found_count > total / 20 && found_count < total * 19 / 20);
        assert!(
            near_count > total / 50 && near_count < found_count,
            "{near_count}"
        );
    }
}
