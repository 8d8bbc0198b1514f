//! Eight f32 lanes: the AVX2 type and its portable twin, with the same methods.
//!
//! An operation is written once as a generic function over [`Lanes`] and instantiated twice:
//! with [`F32x8Portable`] (plain Rust, always compiled) and, on x86-64, with [`F32x8`] inside a
//! function compiled with `#[target_feature(enable = "avx2")]` (every method here is
//! `#[inline(always)]`, so the intrinsics end up in that function). Each method does what its
//! scalar Rust counterpart does lane by lane, bit for bit (see the module docs of
//! [`crate::simd`]).

/// Eight f32 lanes and their comparison masks.
pub trait Lanes: Copy {
    /// A per-lane boolean.
    type Mask: Copy;
    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lanes `s[0..8]`.
    fn load(s: &[f32; 8]) -> Self;
    /// Writes the lanes to `out[0..8]`.
    fn store(self, out: &mut [f32; 8]);
    /// Eight rows in, eight columns out: lane `i` of column `j` is `rows[i][j]` (data movement
    /// only, so the twins agree trivially).
    fn transpose(rows: [&[f32; 8]; 8]) -> [Self; 8];
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

/// The portable twin: eight f32 in an array, each method the scalar operation lane by lane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F32x8Portable(pub [f32; 8]);

#[inline(always)]
fn map2(a: [f32; 8], b: [f32; 8], f: impl Fn(f32, f32) -> f32) -> [f32; 8] {
    std::array::from_fn(|i| f(a[i], b[i]))
}

#[inline(always)]
fn cmp(a: [f32; 8], b: [f32; 8], f: impl Fn(f32, f32) -> bool) -> [bool; 8] {
    std::array::from_fn(|i| f(a[i], b[i]))
}

impl Lanes for F32x8Portable {
    type Mask = [bool; 8];
    #[inline(always)]
    fn splat(x: f32) -> Self {
        F32x8Portable([x; 8])
    }
    #[inline(always)]
    fn load(s: &[f32; 8]) -> Self {
        F32x8Portable(*s)
    }
    #[inline(always)]
    fn store(self, out: &mut [f32; 8]) {
        *out = self.0;
    }
    #[inline(always)]
    fn transpose(rows: [&[f32; 8]; 8]) -> [Self; 8] {
        std::array::from_fn(|j| F32x8Portable(std::array::from_fn(|i| rows[i][j])))
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        F32x8Portable(map2(self.0, o.0, |a, b| a + b))
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        F32x8Portable(map2(self.0, o.0, |a, b| a - b))
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        F32x8Portable(map2(self.0, o.0, |a, b| a * b))
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        F32x8Portable(map2(self.0, o.0, |a, b| a / b))
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        F32x8Portable(self.0.map(f32::sqrt))
    }
    #[inline(always)]
    fn neg(self) -> Self {
        F32x8Portable(self.0.map(|a| -a))
    }
    #[inline(always)]
    fn lt(self, o: Self) -> [bool; 8] {
        cmp(self.0, o.0, |a, b| a < b)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> [bool; 8] {
        cmp(self.0, o.0, |a, b| a > b)
    }
    #[inline(always)]
    fn le(self, o: Self) -> [bool; 8] {
        cmp(self.0, o.0, |a, b| a <= b)
    }
    #[inline(always)]
    fn ge(self, o: Self) -> [bool; 8] {
        cmp(self.0, o.0, |a, b| a >= b)
    }
    #[inline(always)]
    fn select(m: [bool; 8], a: Self, b: Self) -> Self {
        F32x8Portable(std::array::from_fn(|i| if m[i] { a.0[i] } else { b.0[i] }))
    }
    #[inline(always)]
    fn and(m: [bool; 8], n: [bool; 8]) -> [bool; 8] {
        std::array::from_fn(|i| m[i] & n[i])
    }
    #[inline(always)]
    fn or(m: [bool; 8], n: [bool; 8]) -> [bool; 8] {
        std::array::from_fn(|i| m[i] | n[i])
    }
    #[inline(always)]
    fn not(m: [bool; 8]) -> [bool; 8] {
        m.map(|x| !x)
    }
    #[inline(always)]
    fn bits(m: [bool; 8]) -> u32 {
        m.iter()
            .enumerate()
            .fold(0, |acc, (i, &b)| acc | (u32::from(b) << i))
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx2::F32x8;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::Lanes;

    /// Eight f32 in an AVX register. Only to be used inside functions compiled with
    /// `#[target_feature(enable = "avx2")]`, on a processor that has it (checked at run time by
    /// [`crate::simd::level`]): the methods are inlined there.
    #[derive(Clone, Copy, Debug)]
    pub struct F32x8(pub __m256);

    // SAFETY (every `unsafe` block below): the intrinsics need AVX, which the callers guarantee
    // (see the type's docs); the loads and stores go through `&[f32; 8]`, eight valid f32.
    #[allow(unsafe_code)]
    impl Lanes for F32x8 {
        type Mask = __m256;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            F32x8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn load(s: &[f32; 8]) -> Self {
            F32x8(unsafe { _mm256_loadu_ps(s.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, out: &mut [f32; 8]) {
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn transpose(rows: [&[f32; 8]; 8]) -> [Self; 8] {
            unsafe {
                let [r0, r1, r2, r3, r4, r5, r6, r7] = rows.map(|r| _mm256_loadu_ps(r.as_ptr()));
                // Per 128-bit half: (r0[0] r1[0] r0[1] r1[1]) and (r0[2] r1[2] r0[3] r1[3]).
                let t0 = _mm256_unpacklo_ps(r0, r1);
                let t1 = _mm256_unpackhi_ps(r0, r1);
                let t2 = _mm256_unpacklo_ps(r2, r3);
                let t3 = _mm256_unpackhi_ps(r2, r3);
                let t4 = _mm256_unpacklo_ps(r4, r5);
                let t5 = _mm256_unpackhi_ps(r4, r5);
                let t6 = _mm256_unpacklo_ps(r6, r7);
                let t7 = _mm256_unpackhi_ps(r6, r7);
                // Per half: column k of rows 0–3 (or 4–7), columns 0–3 low, 4–7 high.
                let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
                let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
                let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
                let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
                let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
                let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
                let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
                let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
                // Rows 0–3 and 4–7 of a column together: low halves, then high halves.
                [
                    F32x8(_mm256_permute2f128_ps::<0x20>(u0, u4)),
                    F32x8(_mm256_permute2f128_ps::<0x20>(u1, u5)),
                    F32x8(_mm256_permute2f128_ps::<0x20>(u2, u6)),
                    F32x8(_mm256_permute2f128_ps::<0x20>(u3, u7)),
                    F32x8(_mm256_permute2f128_ps::<0x31>(u0, u4)),
                    F32x8(_mm256_permute2f128_ps::<0x31>(u1, u5)),
                    F32x8(_mm256_permute2f128_ps::<0x31>(u2, u6)),
                    F32x8(_mm256_permute2f128_ps::<0x31>(u3, u7)),
                ]
            }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            F32x8(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            F32x8(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            F32x8(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            F32x8(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            F32x8(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn neg(self) -> Self {
            F32x8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
        }
        #[inline(always)]
        fn lt(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn gt(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn le(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn ge(self, o: Self) -> __m256 {
            unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0) }
        }
        #[inline(always)]
        fn select(m: __m256, a: Self, b: Self) -> Self {
            F32x8(unsafe { _mm256_blendv_ps(b.0, a.0, m) })
        }
        #[inline(always)]
        fn and(m: __m256, n: __m256) -> __m256 {
            unsafe { _mm256_and_ps(m, n) }
        }
        #[inline(always)]
        fn or(m: __m256, n: __m256) -> __m256 {
            unsafe { _mm256_or_ps(m, n) }
        }
        #[inline(always)]
        fn not(m: __m256) -> __m256 {
            unsafe { _mm256_xor_ps(m, _mm256_castsi256_ps(_mm256_set1_epi32(-1))) }
        }
        #[inline(always)]
        fn bits(m: __m256) -> u32 {
            unsafe { _mm256_movemask_ps(m) as u32 }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lane `i` of column `j` is `rows[i][j]`, on every level this processor has.
    #[test]
    fn transpose_turns_rows_into_lanes_on_both_twins() {
        let rows: [[f32; 8]; 8] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (10 * i + j) as f32 + if j == 3 { -0.0 } else { 0.5 })
        });
        let refs: [&[f32; 8]; 8] = std::array::from_fn(|i| &rows[i]);
        let want: [[f32; 8]; 8] = std::array::from_fn(|j| std::array::from_fn(|i| rows[i][j]));
        let portable = F32x8Portable::transpose(refs).map(|c| c.0);
        assert_eq!(portable, want);
        #[cfg(target_arch = "x86_64")]
        if crate::simd::best_available() == crate::simd::Level::Avx2 {
            #[target_feature(enable = "avx2")]
            #[allow(unsafe_code)]
            unsafe fn columns(refs: [&[f32; 8]; 8]) -> [[f32; 8]; 8] {
                F32x8::transpose(refs).map(|c| {
                    let mut out = [0.0; 8];
                    c.store(&mut out);
                    out
                })
            }
            // SAFETY: the processor has AVX2 (checked above).
            #[allow(unsafe_code)]
            let avx2 = unsafe { columns(refs) };
            assert_eq!(
                avx2.map(|c| c.map(f32::to_bits)),
                want.map(|c| c.map(f32::to_bits))
            );
        }
    }
}
