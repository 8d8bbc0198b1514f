//! Four f64 lanes: the AVX2 type and its portable twin, with the same methods.
//!
//! An operation is written once as a generic function over [`Lanes`] and instantiated twice:
//! with [`F64x4Portable`] (plain Rust, always compiled) and, on x86-64, with [`F64x4`] inside a
//! function compiled with `#[target_feature(enable = "avx2")]` (every method here is
//! `#[inline(always)]`, so the intrinsics end up in that function). Each method does what its
//! scalar Rust counterpart does lane by lane, bit for bit (see the module docs of
//! [`crate::simd`]).

/// Four f64 lanes and their comparison masks.
pub trait Lanes: Copy {
    /// A per-lane boolean.
    type Mask: Copy;
    /// Every lane `x`.
    fn splat(x: f64) -> Self;
    /// Lanes `s[0..4]`.
    fn load(s: &[f64; 4]) -> Self;
    /// Writes the lanes to `out[0..4]`.
    fn store(self, out: &mut [f64; 4]);
    /// Four rows in, four columns out: lane `i` of column `j` is `rows[i][j]` (data movement
    /// only, so the twins agree trivially).
    fn transpose(rows: [&[f64; 4]; 4]) -> [Self; 4];
    /// `self + o`.
    fn add(self, o: Self) -> Self;
    /// `self - o`.
    fn sub(self, o: Self) -> Self;
    /// `self * o` (never fused with a neighbouring addition).
    fn mul(self, o: Self) -> Self;
    /// `self / o`.
    fn div(self, o: Self) -> Self;
    /// `self.sqrt()`.
    fn sqrt(self) -> Self;
    /// `-self` (the sign bit flipped).
    fn neg(self) -> Self;
    /// `self < o` (false on NaN).
    fn lt(self, o: Self) -> Self::Mask;
    /// `self > o` (false on NaN).
    fn gt(self, o: Self) -> Self::Mask;
    /// `self <= o` (false on NaN).
    fn le(self, o: Self) -> Self::Mask;
    /// `self >= o` (false on NaN).
    fn ge(self, o: Self) -> Self::Mask;
    /// `if m { a } else { b }`, lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// Both.
    fn and(m: Self::Mask, n: Self::Mask) -> Self::Mask;
    /// Either.
    fn or(m: Self::Mask, n: Self::Mask) -> Self::Mask;
    /// Not.
    fn not(m: Self::Mask) -> Self::Mask;
    /// The mask as bits, lane 0 in bit 0.
    fn bits(m: Self::Mask) -> u32;

    /// `x.clamp(0.0, 1.0)` as std defines it: `if x < 0 { 0 } if x > 1 { 1 }` (NaN and -0.0
    /// pass through).
    #[inline(always)]
    fn clamp01(self) -> Self {
        let x = Self::select(self.lt(Self::splat(0.0)), Self::splat(0.0), self);
        Self::select(x.gt(Self::splat(1.0)), Self::splat(1.0), x)
    }

    /// `if o < self { o } else { self }`.
    #[inline(always)]
    fn min_sel(self, o: Self) -> Self {
        Self::select(o.lt(self), o, self)
    }

    /// `if o > self { o } else { self }`.
    #[inline(always)]
    fn max_sel(self, o: Self) -> Self {
        Self::select(o.gt(self), o, self)
    }
}

/// The portable twin: four f64 in an array, each method the scalar operation lane by lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F64x4Portable(pub [f64; 4]);

#[inline(always)]
fn map2(a: [f64; 4], b: [f64; 4], f: impl Fn(f64, f64) -> f64) -> [f64; 4] {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
}

#[inline(always)]
fn cmp(a: [f64; 4], b: [f64; 4], f: impl Fn(f64, f64) -> bool) -> [bool; 4] {
    [f(a[0], b[0]), f(a[1], b[1]), f(a[2], b[2]), f(a[3], b[3])]
}

impl Lanes for F64x4Portable {
    type Mask = [bool; 4];
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F64x4Portable([x; 4])
    }
    #[inline(always)]
    fn load(s: &[f64; 4]) -> Self {
        F64x4Portable(*s)
    }
    #[inline(always)]
    fn store(self, out: &mut [f64; 4]) {
        *out = self.0;
    }
    #[inline(always)]
    fn transpose(rows: [&[f64; 4]; 4]) -> [Self; 4] {
        std::array::from_fn(|j| F64x4Portable(std::array::from_fn(|i| rows[i][j])))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        F64x4Portable(map2(self.0, o.0, |a, b| a + b))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        F64x4Portable(map2(self.0, o.0, |a, b| a - b))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        F64x4Portable(map2(self.0, o.0, |a, b| a * b))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        F64x4Portable(map2(self.0, o.0, |a, b| a / b))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F64x4Portable(self.0.map(f64::sqrt))
    }
    #[inline(always)]
    fn neg(self) -> Self {
        F64x4Portable(self.0.map(|a| -a))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> [bool; 4] {
        cmp(self.0, o.0, |a, b| a < b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> [bool; 4] {
        cmp(self.0, o.0, |a, b| a > b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> [bool; 4] {
        cmp(self.0, o.0, |a, b| a <= b)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> [bool; 4] {
        cmp(self.0, o.0, |a, b| a >= b)
    }
    #[inline(always)]
    fn select(m: [bool; 4], a: Self, b: Self) -> Self {
        F64x4Portable(std::array::from_fn(|i| if m[i] { a.0[i] } else { b.0[i] }))
    }
    #[inline(always)]
    fn and(m: [bool; 4], n: [bool; 4]) -> [bool; 4] {
        std::array::from_fn(|i| m[i] & n[i])
    }
    #[inline(always)]
    fn or(m: [bool; 4], n: [bool; 4]) -> [bool; 4] {
        std::array::from_fn(|i| m[i] | n[i])
    }
    #[inline(always)]
    fn not(m: [bool; 4]) -> [bool; 4] {
        m.map(|x| !x)
    }
    #[inline(always)]
    fn bits(m: [bool; 4]) -> u32 {
        m.iter()
            .enumerate()
            .fold(0, |acc, (i, &b)| acc | (u32::from(b) << i))
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx2::F64x4;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::Lanes;

    /// Four f64 in an AVX register. Only to be used inside functions compiled with
    /// `#[target_feature(enable = "avx2")]`, on a processor that has it (checked at run time by
    /// [`crate::simd::level`]): the methods are inlined there.
    #[derive(Clone, Copy, Debug)]
    pub struct F64x4(pub __m256d);

    // SAFETY (every `unsafe` block below): the intrinsics need AVX, which the callers guarantee
    // (see the type's docs); the loads and stores go through `&[f64; 4]`, four valid f64.
    #[allow(unsafe_code)]
    impl Lanes for F64x4 {
        type Mask = __m256d;
        #[inline(always)]
        fn splat(x: f64) -> Self {
            F64x4(unsafe { _mm256_set1_pd(x) })
        }
        #[inline(always)]
        fn load(s: &[f64; 4]) -> Self {
            F64x4(unsafe { _mm256_loadu_pd(s.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, out: &mut [f64; 4]) {
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn transpose(rows: [&[f64; 4]; 4]) -> [Self; 4] {
            unsafe {
                let [r0, r1, r2, r3] = rows.map(|r| _mm256_loadu_pd(r.as_ptr()));
                // (r0[0] r1[0] r0[2] r1[2]), (r0[1] r1[1] r0[3] r1[3]), and the same of r2, r3.
                let t0 = _mm256_unpacklo_pd(r0, r1);
                let t1 = _mm256_unpackhi_pd(r0, r1);
                let t2 = _mm256_unpacklo_pd(r2, r3);
                let t3 = _mm256_unpackhi_pd(r2, r3);
                // Low halves together, then high halves together.
                [
                    F64x4(_mm256_permute2f128_pd::<0x20>(t0, t2)),
                    F64x4(_mm256_permute2f128_pd::<0x20>(t1, t3)),
                    F64x4(_mm256_permute2f128_pd::<0x31>(t0, t2)),
                    F64x4(_mm256_permute2f128_pd::<0x31>(t1, t3)),
                ]
            }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            F64x4(unsafe { _mm256_add_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            F64x4(unsafe { _mm256_sub_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            F64x4(unsafe { _mm256_mul_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            F64x4(unsafe { _mm256_div_pd(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            F64x4(unsafe { _mm256_sqrt_pd(self.0) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            F64x4(unsafe { _mm256_xor_pd(self.0, _mm256_set1_pd(-0.0)) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_LT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn gt(self, o: Self) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_GT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn le(self, o: Self) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn ge(self, o: Self) -> __m256d {
            unsafe { _mm256_cmp_pd::<_CMP_GE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn select(m: __m256d, a: Self, b: Self) -> Self {
            F64x4(unsafe { _mm256_blendv_pd(b.0, a.0, m) })
        }
        #[inline(always)]
        fn and(m: __m256d, n: __m256d) -> __m256d {
            unsafe { _mm256_and_pd(m, n) }
        }
        #[inline(always)]
        fn or(m: __m256d, n: __m256d) -> __m256d {
            unsafe { _mm256_or_pd(m, n) }
        }
        #[inline(always)]
        fn not(m: __m256d) -> __m256d {
            unsafe { _mm256_xor_pd(m, _mm256_castsi256_pd(_mm256_set1_epi64x(-1))) }
        }
        #[inline(always)]
        fn bits(m: __m256d) -> u32 {
            unsafe { _mm256_movemask_pd(m) as u32 }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lane `i` of column `j` is `rows[i][j]`, on every level this processor has.
    #[test]
    fn transpose_turns_rows_into_lanes_on_both_twins() {
        let rows: [[f64; 4]; 4] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (10 * i + j) as f64 + if j == 3 { -0.0 } else { 0.5 })
        });
        let refs = [&rows[0], &rows[1], &rows[2], &rows[3]];
        let want: [[f64; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| rows[i][j]));
        let portable = F64x4Portable::transpose(refs).map(|c| c.0);
        assert_eq!(portable, want);
        #[cfg(target_arch = "x86_64")]
        if crate::simd::best_available() == crate::simd::Level::Avx2 {
            #[target_feature(enable = "avx2")]
            #[allow(unsafe_code)]
            unsafe fn columns(refs: [&[f64; 4]; 4]) -> [[f64; 4]; 4] {
                F64x4::transpose(refs).map(|c| {
                    let mut out = [0.0; 4];
                    c.store(&mut out);
                    out
                })
            }
            // SAFETY: the processor has AVX2 (checked above).
            #[allow(unsafe_code)]
            let avx2 = unsafe { columns(refs) };
            assert_eq!(
                avx2.map(|c| c.map(f64::to_bits)),
                want.map(|c| c.map(f64::to_bits))
            );
        }
    }
}
