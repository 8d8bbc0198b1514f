//! Per-point hair colours: Kajiya-Kay under the opacity maps' transmittance, for every strand
//! point, once per frame, in strand order.
//!
//! Zhang and Wünsche shade per vertex and let the rasteriser interpolate the colours along
//! each segment (2007, §6.1); so does this renderer. The points are shaded in the projection
//! stage, strand by strand: a point's neighbours, its light-space position and the shadow
//! texels around it are all next to the previous point's in memory, so the pass streams. (An
//! earlier version shaded a point only when a segment at it was first drawn; the 70 % of
//! points it skipped did not pay for the cache misses of reaching the others in depth order.)
//!
//! A colour is packed in 32 bits as RGB9E5, three 9-bit mantissas with a shared 5-bit
//! exponent (the shared-exponent format of OpenGL's `EXT_texture_shared_exponent`), so that
//! a binned segment carries both of its colours and stays 32 bytes. The rounding is at most
//! 1/512 of the brightest channel, below one step of the 8-bit output.

use super::shading::HairShader;
use super::shadow::ShadowMaps;

/// Mantissa bits of the packed format.
const MANTISSA: i32 = 9;
/// Exponent bias of the packed format.
const BIAS: i32 = 15;
/// Largest exponent field.
const EXP_MAX: i32 = 31;

/// Packs a linear colour as RGB9E5. Negative values and NaN become 0; values above 65,408
/// (the format's largest) are clamped. A pure function: the same colour always gives the
/// same word. The scalar reference of [`pack_lanes`], which the renderer uses.
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) fn pack(c: [f32; 3]) -> u32 {
    let max_value = ((1 << MANTISSA) - 1) as f32 / (1 << MANTISSA) as f32
        * f32::from_bits(((EXP_MAX - BIAS + 127) as u32) << 23);
    // `x > 0.0` is false for NaN: NaN and negatives become 0.
    let cl = |x: f32| if x > 0.0 { x.min(max_value) } else { 0.0 };
    let (r, g, b) = (cl(c[0]), cl(c[1]), cl(c[2]));
    let m = r.max(g).max(b);
    // ⌊log2 m⌋ from the float's exponent field (m is finite and ≥ 0; 0 and denormals give
    // the smallest exponent).
    let log2 = ((m.to_bits() >> 23) as i32 - 127).max(-BIAS - 1);
    let mut e = log2 + 1 + BIAS;
    let pow2 = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    // 2^(e − BIAS − MANTISSA) is one mantissa step; rounding m may need the next exponent.
    if (m * pow2(-(e - BIAS - MANTISSA)) + 0.5) as u32 >= 1 << MANTISSA {
        e += 1;
    }
    let inv = pow2(-(e - BIAS - MANTISSA));
    let q = |x: f32| ((x * inv + 0.5) as u32).min((1 << MANTISSA) - 1);
    q(r) | (q(g) << MANTISSA) | (q(b) << (2 * MANTISSA)) | ((e as u32) << (3 * MANTISSA))
}

/// [`pack`] of N colours (`c[channel][lane]`), lane by lane in 32-bit integer and float
/// operations only, so that it compiles to vector code. The same words as [`pack`].
#[inline(always)]
fn pack_lanes<const N: usize>(c: [[f32; N]; 3]) -> [u32; N] {
    use super::num::{mn, mx};
    let max_value = ((1 << MANTISSA) - 1) as f32 / (1 << MANTISSA) as f32
        * f32::from_bits(((EXP_MAX - BIAS + 127) as u32) << 23);
    let cl = |x: [f32; N]| x.map(|v| mn(mx(v, 0.0), max_value));
    let (r, g, b) = (cl(c[0]), cl(c[1]), cl(c[2]));
    let m: [f32; N] = std::array::from_fn(|l| mx(mx(r[l], g[l]), b[l]));
    let pow2 = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    let mut out = [0u32; N];
    let mut e = [0i32; N];
    for l in 0..N {
        let log2 = ((m[l].to_bits() >> 23) as i32 - 127).max(-BIAS - 1);
        let e0 = log2 + 1 + BIAS;
        // SAFETY: m ≤ max_value, so m / step + 0.5 < 2^(MANTISSA + 1), in range.
        let top = unsafe { (m[l] * pow2(-(e0 - BIAS - MANTISSA)) + 0.5).to_int_unchecked::<i32>() };
        e[l] = e0 + (top >= 1 << MANTISSA) as i32;
    }
    for l in 0..N {
        let inv = pow2(-(e[l] - BIAS - MANTISSA));
        // SAFETY: every channel ≤ m, so each quotient is below 2^(MANTISSA + 1).
        let q = |x: f32| {
            unsafe { (x * inv + 0.5).to_int_unchecked::<i32>() }.min((1 << MANTISSA) - 1) as u32
        };
        out[l] = q(r[l])
            | (q(g[l]) << MANTISSA)
            | (q(b[l]) << (2 * MANTISSA))
            | ((e[l] as u32) << (3 * MANTISSA));
    }
    out
}

/// The linear colour of an RGB9E5 word.
#[inline(always)]
pub(crate) fn unpack(w: u32) -> [f32; 3] {
    let e = (w >> (3 * MANTISSA)) as i32;
    let step = f32::from_bits(((e - BIAS - MANTISSA + 127) as u32) << 23);
    let mask = (1 << MANTISSA) - 1;
    [
        (w & mask) as f32 * step,
        ((w >> MANTISSA) & mask) as f32 * step,
        ((w >> (2 * MANTISSA)) & mask) as f32 * step,
    ]
}

/// What shading a strand point needs.
pub(crate) struct PointShader<'a> {
    /// The frame's opacity maps, already built (they hold every point in light space).
    pub maps: &'a ShadowMaps,
    /// The camera's position.
    pub eye: [f32; 3],
    pub shader: HairShader,
    /// Per-strand linear colours (strands beyond the list have `shader.color`).
    pub strand_colors: &'a [[f32; 3]],
    /// Opacity to optical depth (transmittance `exp(−κ·Ω)`).
    pub kappa: f32,
}

/// Points shaded together, one per vector lane (eight: one AVX register of floats).
const LANES: usize = 8;

/// LANES lanes of a value, shaded together: written lane by lane, without branches or calls,
/// so that the compiler turns each line into one vector instruction.
type V = [f32; LANES];

#[inline(always)]
fn lanes(f: impl Fn(usize) -> f32) -> V {
    std::array::from_fn(f)
}

impl PointShader<'_> {
    /// Shades strand `s`, whose points `pts` are the frame's points `first..first + len`,
    /// into `out` (one word per point). The tangent at a point is the direction from its
    /// previous to its next point (one-sided at the ends). LANES points at a time; a last
    /// group of fewer repeats the strand's last point in the spare lanes and drops them.
    /// Groups of points none of which is `needed` are skipped.
    #[inline(always)]
    pub fn strand(&self, s: usize, pts: &[[f32; 3]], first: usize, needed: &[u8], out: &mut [u32]) {
        let Some(last) = pts.len().checked_sub(1) else {
            return;
        };
        let mut shader = self.shader;
        if let Some(c) = self.strand_colors.get(s) {
            shader.color = *c;
        }
        for k0 in (0..pts.len()).step_by(LANES) {
            if needed[k0..(k0 + LANES).min(pts.len())]
                .iter()
                .all(|&n| n == 0)
            {
                continue;
            }
            // Each lane's values loaded straight into its vector lane (built lane by lane in
            // a stack array, the vectors were then loaded across eight separate stores, a
            // store-forwarding stall at every group).
            let k: [usize; LANES] = std::array::from_fn(|l| (k0 + l).min(last));
            let prev: [[f32; 3]; LANES] = std::array::from_fn(|l| pts[k[l].saturating_sub(1)]);
            let next: [[f32; 3]; LANES] = std::array::from_fn(|l| pts[(k[l] + 1).min(last)]);
            let here: [[f32; 3]; LANES] = std::array::from_fn(|l| pts[k[l]]);
            let light: [[f32; 3]; LANES] = std::array::from_fn(|l| self.maps.point(first + k[l]));
            let pt: [V; 3] = std::array::from_fn(|a| lanes(|l| here[l][a]));
            let d: [V; 3] = std::array::from_fn(|a| lanes(|l| next[l][a] - prev[l][a]));
            let lq: [V; 3] = std::array::from_fn(|a| lanes(|l| light[l][a]));
            let omega = self.maps.opacity_lanes(lq, 1.0);
            let words = self.shade_lanes(&shader, pt, d, omega);
            for (o, &w) in out[k0..].iter_mut().zip(&words) {
                *o = w;
            }
        }
    }

    /// Kajiya-Kay ([`HairShader::shade`], lane by lane) at points `pt` with tangent
    /// directions `d` (not unit) and opacities `omega` in front of them, packed.
    #[inline(always)]
    fn shade_lanes(&self, shader: &HairShader, pt: [V; 3], d: [V; 3], omega: V) -> [u32; LANES] {
        use super::shading::{exp, exp2, log2};
        // Unit tangent, or +z for a zero-length one (as `normalize`).
        let len2 = lanes(|l| d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]);
        let inv = lanes(|l| 1.0 / len2[l].sqrt());
        let zero = lanes(|l| (len2[l] > 0.0) as u32 as f32);
        let t = [
            lanes(|l| d[0][l] * inv[l] * zero[l]),
            lanes(|l| d[1][l] * inv[l] * zero[l]),
            lanes(|l| d[2][l] * inv[l] * zero[l] + (1.0 - zero[l])),
        ];
        let eye = self.eye;
        let e = [
            lanes(|l| eye[0] - pt[0][l]),
            lanes(|l| eye[1] - pt[1][l]),
            lanes(|l| eye[2] - pt[2][l]),
        ];
        let elen =
            lanes(|l| 1.0 / (e[0][l] * e[0][l] + e[1][l] * e[1][l] + e[2][l] * e[2][l]).sqrt());
        let te = lanes(|l| (t[0][l] * e[0][l] + t[1][l] * e[1][l] + t[2][l] * e[2][l]) * elen[l]);
        let li = shader.light;
        let tl = lanes(|l| t[0][l] * li[0] + t[1][l] * li[1] + t[2][l] * li[2]);
        let sin = |c: V| lanes(|l| (1.0 - c[l] * c[l]).max(0.0).sqrt());
        let (sl, se) = (sin(tl), sin(te));
        let c = lanes(|l| sl[l] * se[l] - tl[l] * te[l]);
        let spec = lanes(|l| {
            let v = exp2(shader.exponent * log2(c[l]));
            if c[l] > 0.0 {
                v
            } else {
                0.0
            }
        });
        let trans = lanes(|l| exp(-self.kappa * omega[l]));
        let (k, col) = (shader.ambient, shader.color);
        let dif = lanes(|l| k + trans[l] * shader.diffuse * sl[l]);
        let sp = lanes(|l| trans[l] * shader.specular * spec[l]);
        let h = |ch: f32| lanes(|l| ch * dif[l] + sp[l] * (0.5 + 0.5 * ch));
        pack_lanes([h(col[0]), h(col[1]), h(col[2])])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packing_keeps_colours_to_a_512th_of_the_brightest_channel() {
        for c in [
            [0.0, 0.5, 1.0],
            [0.013, 2.5, 7.9],
            [0.3, 0.2, 0.1],
            [1e-4, 3e-5, 0.0],
            [0.999, 1.0, 1.001],
        ] {
            let back = unpack(pack(c));
            let m = c[0].max(c[1]).max(c[2]);
            for k in 0..3 {
                assert!((back[k] - c[k]).abs() <= m / 512.0, "{c:?} -> {back:?}");
            }
            // Packing a packed colour again changes nothing.
            assert_eq!(pack(back), pack(c), "{c:?}");
        }
        assert_eq!(unpack(pack([0.0; 3])), [0.0; 3]);
        // The four-lane packing gives the same words.
        let cs = [
            [0.0, 0.5, 1.0],
            [0.013, 2.5, 7.9],
            [1e-4, 3e-5, 0.0],
            [0.999, 1.0, 1.001],
        ];
        let lanes4 = [0, 1, 2].map(|k| [cs[0][k], cs[1][k], cs[2][k], cs[3][k]]);
        assert_eq!(pack_lanes(lanes4), cs.map(pack));
        assert_eq!(unpack(pack([-1.0, f32::NAN, 0.5]))[..2], [0.0, 0.0]);
        // Beyond the format's range: clamped, not wrapped.
        let big = unpack(pack([1e9, 1.0, 0.0]));
        assert!(big[0] > 65_000.0 && big[0] <= 65_408.0, "{big:?}");
    }

    #[test]
    fn four_lane_shading_matches_the_scalar_kajiya_kay_under_the_maps() {
        use super::super::camera::{normalize, sub};
        // Three wavy strands, one in front of the others as seen from the light.
        let mut points = Vec::new();
        let mut offsets = vec![0u32];
        for s in 0..3 {
            for k in 0..11 {
                let t = k as f32 * 0.03;
                points.push([
                    0.01 * s as f32 + 0.02 * (7.0 * t).sin(),
                    0.3 - t,
                    0.02 * s as f32,
                ]);
            }
            offsets.push(points.len() as u32);
        }
        let light = normalize([0.3, 1.0, 0.4]);
        let mut maps = ShadowMaps::new(64);
        maps.build(&points, &offsets, light);
        let shader = HairShader {
            color: [0.3, 0.2, 0.1],
            diffuse: 0.8,
            specular: 0.5,
            exponent: 40.0,
            ambient: 0.15,
            light,
        };
        let eye = [0.2, 0.25, 1.0];
        let ps = PointShader {
            maps: &maps,
            eye,
            shader,
            strand_colors: &[],
            kappa: 0.5,
        };
        for s in 0..3 {
            let (a, b) = (offsets[s] as usize, offsets[s + 1] as usize);
            let pts = &points[a..b];
            let mut words = vec![0u32; pts.len()];
            ps.strand(s, pts, a, &vec![1; pts.len()], &mut words);
            for (k, &w) in words.iter().enumerate() {
                let (prev, next) = (pts[k.saturating_sub(1)], pts[(k + 1).min(pts.len() - 1)]);
                let t = normalize(sub(next, prev));
                let e = normalize(sub(eye, pts[k]));
                let trans = (-0.5 * maps.opacity(maps.point(a + k), 1.0)).exp();
                let want = shader.shade(t, e, trans);
                let got = unpack(w);
                let m = want[0].max(want[1]).max(want[2]);
                for c in 0..3 {
                    assert!(
                        (got[c] - want[c]).abs() <= m / 512.0 + 1e-5,
                        "strand {s} point {k}: {got:?} vs {want:?}"
                    );
                }
            }
        }
        // The back strands are shadowed somewhere: the maps took part.
        let lit = ps.maps.opacity(ps.maps.point(0), 1.0);
        let deepest = (0..points.len())
            .map(|v| ps.maps.opacity(ps.maps.point(v), 1.0))
            .fold(0.0f32, f32::max);
        assert!(deepest > lit + 0.1, "{lit} {deepest}");
    }

    #[test]
    fn a_channel_at_a_power_of_two_boundary_rounds_up_into_the_next_exponent() {
        // 511.75 / 512 rounds to 512 mantissa steps: the exponent must grow, not wrap to 0.
        let c = [1.0 - 0.25 / 512.0, 0.0, 0.0];
        let back = unpack(pack(c));
        assert!((back[0] - c[0]).abs() <= 1.0 / 512.0, "{back:?}");
    }
}
