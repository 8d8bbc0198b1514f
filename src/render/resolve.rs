//! From a tile's samples to 8-bit pixels: the body shaded where it shows through the hair, the
//! background elsewhere, a box filter over each pixel's samples (supersampling), then the 3×3
//! postfilter (Zhang and Wünsche 2007, §5 and §6.2: supersampling followed by a Gaussian-like
//! kernel gave them the best antialiasing) and sRGB encoding.

use super::body::Prim;
use super::camera::{add, dot, scale, View};
use super::mesh::Meshes;
use super::raster::TILE;
use super::shading::LUT_SIZE;
use super::shadow::ShadowMaps;
use super::tile::TileBuf;
use super::tile::OPAQUE;

/// No primitive (no body has this many).
const NONE: u32 = u32::MAX;

/// What the resolve needs of the frame.
pub(crate) struct Resolve<'a> {
    pub view: &'a View,
    pub prims: &'a [Prim],
    /// The meshes' triangles, primitives from `mesh.base` on.
    pub mesh: &'a Meshes,
    pub maps: &'a ShadowMaps,
    pub map_size: f32,
    /// Linear colours.
    pub background: [f32; 3],
    pub body: [f32; 3],
    pub ambient: f32,
    pub kappa: f32,
    /// Unit, towards the light.
    pub light: [f32; 3],
}

impl Resolve<'_> {
    /// The lit colour of the body at sample (x, y) (global), hit at view depth `t` on prim `k`.
    /// Not inlined: it runs once per body pixel, and [`Resolve::tile`] has a copy of its loop
    /// per supersampling factor.
    #[inline(never)]
    fn body_at(&self, x: f32, y: f32, t: f32, k: usize) -> [f32; 3] {
        let d = self.view.ray(x, y);
        // The same shading and shadow lookup for every kind of body: only the surface point and
        // its normal are found differently.
        let (p, n) = match self.prims.get(k) {
            Some(prim) => {
                let p = add(self.view.eye, scale(d, t));
                (p, prim.normal(p))
            }
            None => self
                .mesh
                .surface(k as u32 - self.mesh.base, self.view.eye, d, t),
        };
        let lambert = dot(n, self.light).max(0.0);
        let trans = if lambert > 0.0 {
            let q = self.maps.light_space(p);
            let inside = q[0] >= 0.0 && q[1] >= 0.0 && q[0] < self.map_size && q[1] < self.map_size;
            if inside {
                super::shading::exp(-self.kappa * self.maps.opacity(q, 0.0))
            } else {
                1.0
            }
        } else {
            0.0
        };
        let k = self.ambient + (1.0 - self.ambient) * lambert * trans;
        scale(self.body, k)
    }

    /// Resolves `buf` into `out`, the tile's TILE² linear pixels (row-major, 3 floats each):
    /// the body or background behind the hair, box-filtered over each pixel's samples.
    pub fn tile(&self, buf: &TileBuf, ss: usize, out: &mut [f32]) {
        // The supersampling factor as a constant where it can be, so that each pixel's
        // samples are visited by unrolled code, without loop counters.
        // Likewise whether there is hair: a tile without reads no sample.
        match (ss, buf.hairless) {
            (2, false) => self.tile_ss::<true>(buf, out, || 2),
            (3, false) => self.tile_ss::<true>(buf, out, || 3),
            (4, false) => self.tile_ss::<true>(buf, out, || 4),
            (_, false) => self.tile_ss::<true>(buf, out, || ss),
            (2, true) => self.tile_ss::<false>(buf, out, || 2),
            (_, true) => self.tile_ss::<false>(buf, out, || ss),
        }
    }

    /// [`Resolve::tile`] at supersampling factor `ss()`, of a tile with hair drawn or not
    /// (`HAIR`; without, every sample is clear, which gives the same arithmetic the same
    /// values).
    #[inline(always)]
    fn tile_ss<const HAIR: bool>(&self, buf: &TileBuf, out: &mut [f32], ss: impl Fn() -> usize) {
        let ss = ss();
        let n = buf.n;
        let norm = 1.0 / (ss * ss) as f32;
        if !HAIR && !buf.body_seen() {
            // Background alone: every pixel is the sum below of the same samples.
            let mut acc = [0.0f32; 3];
            let (tr, bg) = (1.0f32, self.background);
            for _ in 0..ss * ss {
                let c = [0.0 + tr * bg[0], 0.0 + tr * bg[1], 0.0 + tr * bg[2]];
                acc = [acc[0] + c[0], acc[1] + c[1], acc[2] + c[2]];
            }
            let pixel = [acc[0] * norm, acc[1] * norm, acc[2] * norm];
            for o in out[..TILE * TILE * 3].chunks_exact_mut(3) {
                o.copy_from_slice(&pixel);
            }
            return;
        }
        for py in 0..TILE {
            for px in 0..TILE {
                let mut acc = [0.0f32; 3];
                // The body is shaded once per pixel and primitive (its first visible sample):
                // its edges keep every sample's coverage, its shading varies slowly. (A plain
                // primitive number and colour, not an `Option` of both: the compiler spilled
                // that in pieces and reloaded it whole, a stall at every sample.)
                let (mut shaded_prim, mut shaded) = (NONE, [0.0f32; 3]);
                for sy in 0..ss {
                    let j = py * ss + sy;
                    for sx in 0..ss {
                        let i = px * ss + sx;
                        let at = j * n + i;
                        let [r, g, b, tr] = if HAIR {
                            buf.px[at].0
                        } else {
                            [0.0, 0.0, 0.0, 1.0]
                        };
                        let mut c = [r, g, b];
                        if tr >= OPAQUE {
                            let base = if buf.zb[at].is_finite() {
                                let k = buf.prim[at];
                                if k != shaded_prim {
                                    shaded = self.body_at(
                                        (buf.ox + i as i32) as f32 + 0.5,
                                        (buf.oy + j as i32) as f32 + 0.5,
                                        buf.zb[at],
                                        k as usize,
                                    );
                                    shaded_prim = k;
                                }
                                shaded
                            } else {
                                self.background
                            };
                            c = [
                                c[0] + tr * base[0],
                                c[1] + tr * base[1],
                                c[2] + tr * base[2],
                            ];
                        }
                        acc = [acc[0] + c[0], acc[1] + c[1], acc[2] + c[2]];
                    }
                }
                let o = (py * TILE + px) * 3;
                out[o] = acc[0] * norm;
                out[o + 1] = acc[1] * norm;
                out[o + 2] = acc[2] * norm;
            }
        }
    }
}

/// The postfilter and sRGB encoding of rows `rows` of a `width`-pixel-wide frame of linear
/// pixels `linear` (row-major, 3 floats each, `height` rows; the three given together) into
/// `out` (those rows' 8-bit pixels): (1 − s)·p + s·([1 2 1]ᵀ[1 2 1] / 16 ∗ p), on linear
/// values, the frame's edge pixels repeated beyond it.
///
/// The kernel is separable: each output row is the vertical [1 2 1] sum of three input rows
/// (one pass over contiguous floats, which the compiler vectorises), then the horizontal
/// [1 2 1] sum of that, three floats (one pixel) apart. `scratch` holds the vertical sum.
pub(crate) fn postfilter_rows(
    (linear, width, height): (&[f32], usize, usize),
    rows: std::ops::Range<usize>,
    s: f32,
    lut: &[u8],
    out: &mut [u8],
    scratch: &mut Vec<f32>,
) {
    let lut_max = (LUT_SIZE - 1) as f32;
    let stride = width * 3;
    let (keep, k) = (1.0 - s, s * (1.0 / 16.0));
    let first = rows.start;
    scratch.resize(stride + 6, 0.0);
    for y in rows {
        let (ym, yp) = (y.saturating_sub(1), (y + 1).min(height - 1));
        let (above, here, below) = (
            &linear[ym * stride..(ym + 1) * stride],
            &linear[y * stride..(y + 1) * stride],
            &linear[yp * stride..(yp + 1) * stride],
        );
        // Vertical sums, with the edge pixel repeated one pixel beyond each end.
        let v = &mut scratch[..stride + 6];
        for (((o, a), b), c) in v[3..stride + 3].iter_mut().zip(above).zip(here).zip(below) {
            *o = a + 2.0 * b + c;
        }
        for ch in 0..3 {
            v[ch] = v[3 + ch];
            v[stride + 3 + ch] = v[stride + ch];
        }
        let dst = &mut out[(y - first) * stride..(y - first + 1) * stride];
        // The three taps as three shifted slices (indexing `v[i + 3]` kept a bounds check
        // per value and the loop scalar).
        let taps = v[..stride]
            .iter()
            .zip(&v[3..stride + 3])
            .zip(&v[6..stride + 6]);
        for ((o, p), ((l, c), r)) in dst.iter_mut().zip(here).zip(taps) {
            let blur = l + 2.0 * c + r;
            let x = keep * p + k * blur;
            // Clamped to [0, 1] with NaN to 0 (comparisons, no `f32::clamp` NaN path), so the
            // index is in range and the unchecked conversion exact.
            let x = if x > 0.0 { x } else { 0.0 };
            let x = if x < 1.0 { x } else { 1.0 };
            // SAFETY: x · lut_max + 0.5 is finite and in [0.5, LUT_SIZE − 0.5].
            let q = unsafe { (x * lut_max + 0.5).to_int_unchecked::<u32>() };
            *o = lut[q as usize];
        }
    }
}
