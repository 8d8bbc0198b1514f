//! From a tile's samples to 8-bit pixels: the body shaded where it shows through the hair, the
//! background elsewhere, a box filter over each pixel's samples (supersampling), then the 3×3
//! postfilter (Zhang and Wünsche 2007, §5 and §6.2: supersampling followed by a Gaussian-like
//! kernel gave them the best antialiasing) and sRGB encoding.

use super::body::Prim;
use super::camera::{add, dot, scale, View};
use super::raster::{APRON, OPAQUE, TILE};
use super::shading::LUT_SIZE;
use super::shadow::ShadowMaps;
use super::tile::TileBuf;

/// What the resolve needs of the frame.
pub(crate) struct Resolve<'a> {
    pub view: &'a View,
    pub prims: &'a [Prim],
    pub maps: &'a ShadowMaps,
    pub map_size: f32,
    /// Linear colours.
    pub background: [f32; 3],
    pub body: [f32; 3],
    pub ambient: f32,
    pub kappa: f32,
    /// Unit, towards the light.
    pub light: [f32; 3],
    pub postfilter: f32,
    pub lut: &'a [u8],
}

impl Resolve<'_> {
    /// The lit colour of the body at sample (x, y) (global), hit at view depth `t` on prim `k`.
    fn body_at(&self, x: f32, y: f32, t: f32, k: usize) -> [f32; 3] {
        let d = self.view.ray(x, y);
        let p = add(self.view.eye, scale(d, t));
        let n = self.prims[k].normal(p);
        let lambert = dot(n, self.light).max(0.0);
        let trans = if lambert > 0.0 {
            let q = self.maps.light_space(p);
            let inside = q[0] >= 0.0 && q[1] >= 0.0 && q[0] < self.map_size && q[1] < self.map_size;
            if inside {
                (-self.kappa * self.maps.opacity(q, 0.0)).exp()
            } else {
                1.0
            }
        } else {
            0.0
        };
        let k = self.ambient + (1.0 - self.ambient) * lambert * trans;
        scale(self.body, k)
    }

    /// Resolves `buf` into `pixels` (linear scratch, (TILE + 2·APRON)² × 3) and writes the
    /// tile's TILE² sRGB pixels to `out` (row-major, TILE × TILE × 3).
    pub fn tile(&self, buf: &TileBuf, ss: usize, pixels: &mut Vec<f32>, out: &mut [u8]) {
        let np = TILE + 2 * APRON;
        pixels.clear();
        pixels.resize(np * np * 3, 0.0);
        let n = buf.n;
        let norm = 1.0 / (ss * ss) as f32;
        for py in 0..np {
            for px in 0..np {
                let mut acc = [0.0f32; 3];
                // The body is shaded once per pixel and primitive (its first visible sample):
                // its edges keep every sample's coverage, its shading varies slowly.
                let mut shaded: Option<(u16, [f32; 3])> = None;
                for sy in 0..ss {
                    let j = py * ss + sy;
                    for sx in 0..ss {
                        let i = px * ss + sx;
                        let at = j * n + i;
                        let [r, g, b, tr] = buf.px[at].0;
                        let mut c = [r, g, b];
                        if tr >= OPAQUE {
                            let base = if buf.zb[at].is_finite() {
                                let k = buf.prim[at];
                                match shaded {
                                    Some((pk, c)) if pk == k => c,
                                    _ => {
                                        let c = self.body_at(
                                            (buf.ox + i as i32) as f32 + 0.5,
                                            (buf.oy + j as i32) as f32 + 0.5,
                                            buf.zb[at],
                                            k as usize,
                                        );
                                        shaded = Some((k, c));
                                        c
                                    }
                                }
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
                let o = (py * np + px) * 3;
                pixels[o] = acc[0] * norm;
                pixels[o + 1] = acc[1] * norm;
                pixels[o + 2] = acc[2] * norm;
            }
        }
        // Postfilter: (1 − s)·p + s·([1 2 1]ᵀ[1 2 1] / 16 ∗ p), on linear values.
        let s = self.postfilter;
        let lut_max = (LUT_SIZE - 1) as f32;
        for y in 0..TILE {
            for x in 0..TILE {
                let (cy, cx) = (y + APRON, x + APRON);
                for ch in 0..3 {
                    let at = |yy: usize, xx: usize| pixels[(yy * np + xx) * 3 + ch];
                    let row = |yy: usize| at(yy, cx - 1) + 2.0 * at(yy, cx) + at(yy, cx + 1);
                    let blur = (row(cy - 1) + 2.0 * row(cy) + row(cy + 1)) * (1.0 / 16.0);
                    let v = (1.0 - s) * at(cy, cx) + s * blur;
                    let q = (v.clamp(0.0, 1.0) * lut_max + 0.5) as usize;
                    out[(y * TILE + x) * 3 + ch] = self.lut[q];
                }
            }
        }
    }
}
