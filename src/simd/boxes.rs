//! The hair–hair candidate loop's box test: whether any of eight f32 lanes of one array is
//! greater than the same lane of another (`solver::awt::collide::narrow::Reach` arranges two
//! boxes so that this says "apart on some axis"), in SSE compares and in their portable twin.
//!
//! Both are Rust's `a > b` lane by lane (false on NaN, as `cmpgt` is), so the twins agree.

use super::dispatch::{Avx2, Portable};

/// The box test, per instruction set.
pub trait BoxTest {
    /// Whether `a[k] > b[k]` for some lane `k`.
    fn any_greater8(a: &[f32; 8], b: &[f32; 8]) -> bool;
}

impl BoxTest for Portable {
    #[inline(always)]
    fn any_greater8(a: &[f32; 8], b: &[f32; 8]) -> bool {
        // Non-short-circuit `|`: branch-free (the compiler still makes eight scalar compares).
        let mut any = false;
        for (x, y) in a.iter().zip(b) {
            any |= x > y;
        }
        any
    }
}

impl BoxTest for Avx2 {
    /// Two SSE compares and one mask (SSE is part of every x86-64).
    #[inline(always)]
    fn any_greater8(a: &[f32; 8], b: &[f32; 8]) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_cmpgt_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_or_ps};
            // SAFETY: SSE is in the x86-64 baseline; the loads read lanes 0..4 and 4..8 of the
            // two arrays.
            unsafe {
                let lo = _mm_cmpgt_ps(_mm_loadu_ps(a.as_ptr()), _mm_loadu_ps(b.as_ptr()));
                let hi = _mm_cmpgt_ps(
                    _mm_loadu_ps(a.as_ptr().add(4)),
                    _mm_loadu_ps(b.as_ptr().add(4)),
                );
                _mm_movemask_ps(_mm_or_ps(lo, hi)) != 0
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::any_greater8(a, b)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sse_box_test_gives_the_portable_answer_nan_and_infinities_included() {
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            0.5,
            1.0,
            -1.0,
            f32::MIN_POSITIVE,
        ];
        let (mut trues, mut falses) = (0, 0);
        for s in 0..specials.len() * specials.len() {
            let a: [f32; 8] = std::array::from_fn(|k| specials[(s + 3 * k) % specials.len()]);
            for t in 0..8 * specials.len() {
                // `a` itself but for one lane: greater exactly when that lane of `a` is.
                let mut b = a;
                b[t % 8] = specials[t / 8];
                let want = Portable::any_greater8(&a, &b);
                assert_eq!(Avx2::any_greater8(&a, &b), want, "{a:?} > {b:?}");
                if want {
                    trues += 1
                } else {
                    falses += 1
                }
            }
        }
        assert!(
            trues > 0 && falses > 0,
            "both answers met: {trues}, {falses}"
        );
        // One lane greater is enough; NaN lanes never are.
        let mut b = [1.0f32; 8];
        assert!(!Portable::any_greater8(&[1.0; 8], &b));
        b[7] = 0.5;
        assert!(Portable::any_greater8(&[1.0; 8], &b) && Avx2::any_greater8(&[1.0; 8], &b));
        assert!(!Avx2::any_greater8(&[f32::NAN; 8], &b));
    }
}
