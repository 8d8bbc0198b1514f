//! The renderer's depth tests of culling blocks: which of several blocks' depths a depth `z`
//! lies at or behind, as a bit mask, in SSE compares and in their portable twins.
//!
//! Both are Rust's `z >= c` lane by lane (false on NaN, as `cmpge` is), so the twins give the
//! same bits.

use super::dispatch::{Avx2, Portable};

/// Lanes of [`Cull::chunk_hidden`].
pub const CHUNK: usize = 16;

/// The depth tests, per instruction set.
pub trait Cull {
    /// Bit k set where `z >= four[k]`.
    fn four_hidden(four: &[f32; 4], z: f32) -> u32;
    /// Bit k set where `z >= chunk[k]`.
    fn chunk_hidden(chunk: &[f32; CHUNK], z: f32) -> u32;
}

impl Cull for Portable {
    #[inline(always)]
    fn four_hidden(four: &[f32; 4], z: f32) -> u32 {
        let mut bits = 0;
        for (l, &c) in four.iter().enumerate() {
            bits |= ((z >= c) as u32) << l;
        }
        bits
    }

    #[inline(always)]
    fn chunk_hidden(chunk: &[f32; CHUNK], z: f32) -> u32 {
        let mut bits = 0;
        for (l, &c) in chunk.iter().enumerate() {
            bits |= ((z >= c) as u32) << l;
        }
        bits
    }
}

impl Cull for Avx2 {
    /// One SSE compare (SSE is part of every x86-64).
    #[inline(always)]
    fn four_hidden(four: &[f32; 4], z: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_cmpge_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps};
            // SAFETY: SSE is in the x86-64 baseline; the load reads the 4 floats of `four`.
            unsafe {
                _mm_movemask_ps(_mm_cmpge_ps(_mm_set1_ps(z), _mm_loadu_ps(four.as_ptr()))) as u32
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::four_hidden(four, z)
        }
    }

    /// Four compares and mask moves (written lane by lane, the compiler made a long chain of
    /// scalar compares and shifts).
    #[inline(always)]
    fn chunk_hidden(chunk: &[f32; CHUNK], z: f32) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_cmpge_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps};
            let mut bits = 0;
            for q in 0..CHUNK / 4 {
                // SAFETY: SSE is in the x86-64 baseline; the load reads lanes 4q..4q+4 of
                // `chunk` (unaligned loads allowed).
                let m = unsafe {
                    let c = _mm_loadu_ps(chunk.as_ptr().add(4 * q));
                    _mm_movemask_ps(_mm_cmpge_ps(_mm_set1_ps(z), c))
                };
                bits |= (m as u32) << (4 * q);
            }
            bits
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::chunk_hidden(chunk, z)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sse_depth_tests_give_the_portable_bits_nan_and_infinities_included() {
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            0.0,
            -0.0,
            0.5,
            1.0,
        ];
        let mut chunk = [0.0f32; CHUNK];
        for (i, c) in chunk.iter_mut().enumerate() {
            *c = specials[(i * 5 + 3) % specials.len()];
        }
        for &z in &specials {
            for s in 0..CHUNK - 4 {
                let four: &[f32; 4] = chunk[s..s + 4].try_into().unwrap();
                assert_eq!(
                    Portable::four_hidden(four, z),
                    Avx2::four_hidden(four, z),
                    "z {z}, lanes {s}.."
                );
            }
            assert_eq!(
                Portable::chunk_hidden(&chunk, z),
                Avx2::chunk_hidden(&chunk, z),
                "z {z}"
            );
            chunk.rotate_left(1);
        }
        assert_eq!(
            Portable::four_hidden(&[0.5, 1.0, f32::NAN, -1.0], 0.75),
            0b1001
        );
    }
}
