//! Kajiya-Kay shading on demand: a strand point is shaded the first time a segment that ends at
//! it is drawn, and never if every segment at it is culled.
//!
//! In dense hair most points are hidden (behind the head, or under hair that is already opaque
//! in front of them): in the 16k-strand benchmark about 70 % of the binned segments are culled
//! whole. Shading every point up front (tangent, shadow-map lookup, `exp`, `powf`) cost more
//! than the rasteriser's sort; shading only what shows saves most of that.
//!
//! Each point has one 64-bit word. Before the tile pass it holds the point's strand and whether
//! the point starts or ends it (what its tangent needs); once shaded it holds the colour, each
//! channel as a 21-bit fixed-point number over [0, 8) (steps of 4·10⁻⁶ in linear light, far
//! below one step of the 8-bit output), with the top bit set. The colour is a pure function of
//! the point, so two threads that shade the same point at once write the same word, and every
//! reader gets the same value whichever thread wrote it: the image stays the same bit for bit
//! whatever the number of threads. Relaxed atomics suffice for that (a word is read or written
//! whole, and no other memory is published through it).

use std::sync::atomic::{AtomicU64, Ordering};

use super::camera::{normalize, sub, View};
use super::shading::HairShader;
use super::shadow::ShadowMaps;

/// Set in a word that holds a colour.
const SHADED: u64 = 1 << 63;
/// Set (in an unshaded word) on a strand's first point.
const FIRST: u64 = 1 << 32;
/// Set (in an unshaded word) on a strand's last point.
const LAST: u64 = 1 << 33;
/// Bits per colour channel.
const BITS: u32 = 21;
/// Largest channel value kept, linear.
const RANGE: f32 = 8.0;

/// The word of an unshaded point of strand `strand` (its first and/or last point as told).
#[inline]
pub(crate) fn unshaded(strand: usize, first: bool, last: bool) -> u64 {
    strand as u32 as u64 | if first { FIRST } else { 0 } | if last { LAST } else { 0 }
}

/// A colour as a shaded word.
#[inline]
fn pack(c: [f32; 3]) -> u64 {
    let scale = ((1u32 << BITS) - 1) as f32 / RANGE;
    let q = |x: f32| ((x.clamp(0.0, RANGE) * scale + 0.5) as u64).min((1 << BITS) - 1);
    SHADED | q(c[0]) | (q(c[1]) << BITS) | (q(c[2]) << (2 * BITS))
}

/// The colour of a shaded word.
#[inline]
fn unpack(w: u64) -> [f32; 3] {
    let inv = RANGE / ((1u32 << BITS) - 1) as f32;
    let mask = (1u64 << BITS) - 1;
    [
        (w & mask) as f32 * inv,
        ((w >> BITS) & mask) as f32 * inv,
        ((w >> (2 * BITS)) & mask) as f32 * inv,
    ]
}

/// What shading a point needs: the frame's points, maps, eye and shader, and the words.
pub(crate) struct LazyShade<'a> {
    pub points: &'a [[f32; 3]],
    pub maps: &'a ShadowMaps,
    pub view: &'a View,
    pub shader: HairShader,
    /// Per strand, its linear colour (strands beyond the list take `shader.color`).
    pub strand_colors: &'a [[f32; 3]],
    pub kappa: f32,
    pub words: &'a [AtomicU64],
}

impl LazyShade<'_> {
    /// The linear colour of point `v`, shaded now if no one has yet.
    #[inline]
    pub fn color(&self, v: usize) -> [f32; 3] {
        let w = self.words[v].load(Ordering::Relaxed);
        if w & SHADED != 0 {
            return unpack(w);
        }
        let packed = pack(self.shade(v, w));
        self.words[v].store(packed, Ordering::Relaxed);
        // The rounded value, as any later reader will get it.
        unpack(packed)
    }

    /// Kajiya-Kay under the maps' transmittance, for point `v` with unshaded word `w`.
    #[cold]
    fn shade(&self, v: usize, w: u64) -> [f32; 3] {
        let pt = self.points[v];
        let prev = if w & FIRST != 0 {
            pt
        } else {
            self.points[v - 1]
        };
        let next = if w & LAST != 0 {
            pt
        } else {
            self.points[v + 1]
        };
        let t = normalize(sub(next, prev));
        let e = normalize(sub(self.view.eye, pt));
        let trans = (-self.kappa * self.maps.opacity(self.maps.point(v), 1.0)).exp();
        let mut shader = self.shader;
        if let Some(c) = self.strand_colors.get((w & 0xffff_ffff) as usize) {
            shader.color = *c;
        }
        shader.shade(t, e, trans)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_keeps_colours_to_a_few_millionths_and_marks_them_shaded() {
        for c in [[0.0, 0.5, 1.0], [0.013, 2.5, 7.9], [0.3, 0.2, 0.1]] {
            let w = pack(c);
            assert_ne!(w & SHADED, 0);
            let back = unpack(w);
            for k in 0..3 {
                assert!((back[k] - c[k]).abs() < 3e-6, "{c:?} -> {back:?}");
            }
            // Packing what came out gives the same word: a re-shaded point reads the same.
            assert_eq!(pack(back), w);
        }
        // Out of range: clamped, never wrapped into another channel.
        assert_eq!(unpack(pack([-1.0, 100.0, f32::NAN]))[0], 0.0);
        assert!((unpack(pack([-1.0, 100.0, 0.0]))[1] - RANGE).abs() < 1e-5);
    }

    #[test]
    fn unshaded_words_hold_the_strand_and_its_ends() {
        let w = unshaded(70_000, true, false);
        assert_eq!(w & SHADED, 0);
        assert_eq!(w & 0xffff_ffff, 70_000);
        assert_ne!(w & FIRST, 0);
        assert_eq!(w & LAST, 0);
        assert_ne!(unshaded(3, false, true) & LAST, 0);
    }
}
