//! The renderer's blend of one line into a window of four samples, in SSE registers and in its
//! portable twin.
//!
//! A sample is a [`Px`]: premultiplied linear r, g, b accumulated front to back, then the
//! transmittance of what lies in front; 16-byte aligned, so it is one vector load and store.
//! [`Blend::window`] adds `w · rgb` to each of four samples (`k · stride` apart), with
//! `w = tr · w0 · cov` where the sample is live (transmittance at least `opaque` and the line
//! in front of the body depth) and `+0` elsewhere, `cov` being the overlap of the sample's
//! cell `[fj, fj + 1)` with the line's cross-section `[y_lo, y_hi]`. Both twins do the same
//! operations in the same order (no fused multiply-add; `min`/`max` as compare-and-select), so
//! they give the same bits.

use super::dispatch::{Avx2, Portable};

/// One sample: linear r, g, b accumulated front to back (premultiplied), then the
/// transmittance; aligned so that a sample is one vector load and store.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct Px(pub [f32; 4]);

/// Samples of one window.
pub const WINDOW: usize = 4;

/// The line blended into a window: where it crosses the samples, its depth, weight and colour.
#[derive(Debug, Clone, Copy)]
pub struct WindowLine {
    /// Where the line's cross-section starts across the column, in samples of the column.
    pub y_lo: f32,
    /// Where it ends.
    pub y_hi: f32,
    /// Position, along the column, of the window's first sample.
    pub fj0: f32,
    /// The line's view depth.
    pub z: f32,
    /// Its opacity times its coverage along the column.
    pub w0: f32,
    /// Its colour; lane 3 is −1 (so the transmittance drops by the weight).
    pub rgb: Px,
    /// The transmittance below which a sample is opaque and takes nothing more.
    pub opaque: f32,
}

/// The window blend, per instruction set.
pub trait Blend {
    /// Blends `line` into samples `px[k · stride]`, k = 0..WINDOW, whose body depths are
    /// `zb[k · stride]` (both slices hold at least `3 · stride + 1` entries). Returns bit k
    /// set where sample k was live and turned opaque.
    fn window(px: &mut [Px], zb: &[f32], stride: usize, line: &WindowLine) -> u32;
}

/// `if a < b { a } else { b }`.
#[inline(always)]
fn mn(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `if a > b { a } else { b }`.
#[inline(always)]
fn mx(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

impl Blend for Portable {
    /// Lane by lane, without branches.
    #[inline(always)]
    fn window(px: &mut [Px], zb: &[f32], stride: usize, l: &WindowLine) -> u32 {
        // One bounds check per window: the samples are `k · stride` into these slices.
        let span = (WINDOW - 1) * stride + 1;
        let px = &mut px[..span];
        let zbs = &zb[..span];
        let v: [[f32; 4]; WINDOW] = std::array::from_fn(|k| px[k * stride].0);
        let zb: [f32; WINDOW] = std::array::from_fn(|k| zbs[k * stride]);
        let mut new = [[0.0f32; 4]; WINDOW];
        let mut live = [false; WINDOW];
        let c = l.rgb.0;
        for k in 0..WINDOW {
            let fj = l.fj0 + k as f32;
            let cov = mx(mn(l.y_hi, fj + 1.0) - mx(l.y_lo, fj), 0.0);
            let tr = v[k][3];
            // `&`, not `&&`: both tests, no branch.
            live[k] = (tr >= l.opaque) & (l.z < zb[k]);
            // A refused sample gets weight 0: adding 0 leaves every channel as it was.
            let w = if live[k] { tr * l.w0 * cov } else { 0.0 };
            new[k] = [
                v[k][0] + w * c[0],
                v[k][1] + w * c[1],
                v[k][2] + w * c[2],
                v[k][3] + w * c[3],
            ];
        }
        let mut turned = 0;
        for k in 0..WINDOW {
            px[k * stride].0 = new[k];
            turned |= ((live[k] & (new[k][3] < l.opaque)) as u32) << k;
        }
        turned
    }
}

impl Blend for Avx2 {
    /// In SSE registers, one sample's colour and transmittance per register and the four
    /// samples' transmittances, coverages and weights in one. (Written lane by lane, the
    /// compiler moved each value in and out of vector registers one lane at a time.)
    #[inline(always)]
    fn window(px: &mut [Px], zb: &[f32], stride: usize, l: &WindowLine) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            window_sse(px, zb, stride, l)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Portable::window(px, zb, stride, l)
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn window_sse(px: &mut [Px], zb: &[f32], stride: usize, l: &WindowLine) -> u32 {
    use std::arch::x86_64::*;
    // One bounds check per window: the samples are `k · stride` into these slices.
    let span = (WINDOW - 1) * stride + 1;
    let px = &mut px[..span];
    let zbs = &zb[..span];
    let (p0, p1, p2, p3) = (0, stride, 2 * stride, 3 * stride);
    let rgb = &l.rgb;
    // SAFETY: SSE and SSE2 are part of x86-64. The loads and stores are of `Px`, 16-byte
    // aligned records of four floats, at indices within `px` (bounds-checked by the
    // indexing); `_mm_min_ps(a, b)` is `a < b ? a : b` and `_mm_max_ps(a, b)`
    // `a > b ? a : b`, as `mn` and `mx`.
    unsafe {
        let v = [
            _mm_load_ps(px[p0].0.as_ptr()),
            _mm_load_ps(px[p1].0.as_ptr()),
            _mm_load_ps(px[p2].0.as_ptr()),
            _mm_load_ps(px[p3].0.as_ptr()),
        ];
        // Lane k: sample k's transmittance (lane 3 of its record).
        let tr = _mm_movehl_ps(_mm_unpackhi_ps(v[2], v[3]), _mm_unpackhi_ps(v[0], v[1]));
        let zb = _mm_setr_ps(zbs[p0], zbs[p1], zbs[p2], zbs[p3]);
        let fj = _mm_add_ps(_mm_set1_ps(l.fj0), _mm_setr_ps(0.0, 1.0, 2.0, 3.0));
        let top = _mm_min_ps(_mm_set1_ps(l.y_hi), _mm_add_ps(fj, _mm_set1_ps(1.0)));
        let cov = _mm_max_ps(
            _mm_sub_ps(top, _mm_max_ps(_mm_set1_ps(l.y_lo), fj)),
            _mm_setzero_ps(),
        );
        let opaque = _mm_set1_ps(l.opaque);
        let live = _mm_and_ps(_mm_cmpge_ps(tr, opaque), _mm_cmplt_ps(_mm_set1_ps(l.z), zb));
        // A refused sample gets weight +0: adding 0 leaves every channel as it was.
        let w = _mm_and_ps(live, _mm_mul_ps(_mm_mul_ps(tr, _mm_set1_ps(l.w0)), cov));
        let c = _mm_load_ps(rgb.0.as_ptr());
        let blend = |v: __m128, wk: __m128| _mm_add_ps(v, _mm_mul_ps(wk, c));
        _mm_store_ps(
            px[p0].0.as_mut_ptr(),
            blend(v[0], _mm_shuffle_ps::<0x00>(w, w)),
        );
        _mm_store_ps(
            px[p1].0.as_mut_ptr(),
            blend(v[1], _mm_shuffle_ps::<0x55>(w, w)),
        );
        _mm_store_ps(
            px[p2].0.as_mut_ptr(),
            blend(v[2], _mm_shuffle_ps::<0xaa>(w, w)),
        );
        _mm_store_ps(
            px[p3].0.as_mut_ptr(),
            blend(v[3], _mm_shuffle_ps::<0xff>(w, w)),
        );
        // The new transmittances, as lane 3 of each blend computed them.
        let new_tr = _mm_add_ps(tr, _mm_mul_ps(w, _mm_set1_ps(rgb.0[3])));
        _mm_movemask_ps(_mm_and_ps(live, _mm_cmplt_ps(new_tr, opaque))) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator: uniform in [0, 1).
    fn lcg(state: &mut u64) -> f32 {
        *state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn the_sse_window_blend_gives_the_portable_blend_bit_for_bit() {
        let mut rng = 7u64;
        for case in 0..2000 {
            let stride = 1 + case % 5;
            let n = 3 * stride + 1;
            let mut a: Vec<Px> = (0..n)
                .map(|_| {
                    let tr = if lcg(&mut rng) < 0.2 {
                        1.0 / 1024.0
                    } else {
                        lcg(&mut rng)
                    };
                    Px([lcg(&mut rng), lcg(&mut rng), lcg(&mut rng), tr])
                })
                .collect();
            let zb: Vec<f32> = (0..n)
                .map(|_| {
                    if lcg(&mut rng) < 0.3 {
                        f32::INFINITY
                    } else {
                        lcg(&mut rng)
                    }
                })
                .collect();
            let y_lo = 4.0 * lcg(&mut rng) - 0.5;
            let line = WindowLine {
                y_lo,
                y_hi: y_lo + 3.0 * lcg(&mut rng),
                fj0: (case % 3) as f32,
                z: lcg(&mut rng),
                w0: lcg(&mut rng),
                rgb: Px([lcg(&mut rng), lcg(&mut rng), lcg(&mut rng), -1.0]),
                opaque: 1.0 / 512.0,
            };
            let mut b = a.clone();
            let ta = Portable::window(&mut a, &zb, stride, &line);
            let tb = Avx2::window(&mut b, &zb, stride, &line);
            let bits =
                |v: &[Px]| -> Vec<u32> { v.iter().flat_map(|p| p.0.map(f32::to_bits)).collect() };
            assert_eq!(bits(&a), bits(&b), "case {case}");
            assert_eq!(ta, tb, "case {case}");
        }
    }
}
