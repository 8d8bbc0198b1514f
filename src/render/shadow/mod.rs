//! Opacity shadow maps (Kim and Neumann 2001, "Opacity Shadow Maps"; as used by Zhang and
//! Wünsche 2007, §4 and §6.1).
//!
//! [`MAPS`] = 16 maps perpendicular to the light direction, equally spaced over the hair's
//! extent along it: map i lies at depth z_i = z_0 + i·dz from the front of the hair (as seen
//! from the light) to its back. Map i holds Ω_i, the opacity of all hair in front of z_i, in
//! units of strand crossings: every strand segment deposits its projected length (in texels)
//! into the first map behind it, bilinearly over the 4 nearest texels, then the maps are summed
//! front to back. The opacity at depth z is interpolated between the two nearest maps with
//! Zhang and Wünsche's eq. 1, Ω = Σ_i Ω_i·max(0, 1 − |z − z_i|/dz) (see [`eq1_opacity`]), and
//! the light transmittance is exp(−κ·Ω).
//!
//! **Bias.** A segment lies in front of the map behind it, so a lookup at its own depth would
//! see part of its own deposit. Hair is looked up one map spacing nearer the light (at z − dz):
//! a strand then never shadows itself, and hair less than dz in front of a point shadows it
//! only in part (fully from 2·dz on). The body, which deposits nothing, is looked up unbiased.

use std::sync::Mutex;

mod jobs;

use super::camera::{cross, dot, normalize};
use crate::par::{for_each_on, split_parts};
use crate::simd::Level;
pub(crate) use jobs::{Deposit, LightFrame, Sum};
use jobs::{Splat, FRAME_CHUNKS, HALVES, SUM_BANDS};

/// Number of opacity maps (Zhang and Wünsche 2007, §6.1: sixteen, four per render target).
pub const MAPS: usize = 16;

/// Zhang and Wünsche 2007, eq. 1: the opacity at depth `z` from the maps' opacities `omega`
/// (map i at depth `z_first + i·dz`), written as in the paper with no search for the two
/// nearest maps. The renderer uses the equivalent two-map interpolation (and holds the last
/// map's value behind it, where eq. 1 would fade to zero).
pub fn eq1_opacity(omega: &[f32], z: f32, z_first: f32, dz: f32) -> f32 {
    omega
        .iter()
        .enumerate()
        .map(|(i, o)| o * (1.0 - ((z - (z_first + i as f32 * dz)) / dz).abs()).max(0.0))
        .sum()
}

/// The 16 maps of one frame and the light frame they were built in.
#[derive(Debug)]
pub struct ShadowMaps {
    size: usize,
    /// Light frame: `ax_d` is the direction the light travels (depth grows along it).
    ax_u: [f32; 3],
    ax_v: [f32; 3],
    ax_d: [f32; 3],
    u0: f32,
    v0: f32,
    inv_texel: f32,
    z0: f32,
    dz: f32,
    inv_dz: f32,
    /// Per texel (row-major), the [`MAPS`] values, front to back: one cache line per texel.
    omega: Vec<f32>,
    /// Light-space points of the frame (u, v in texels; z in metres).
    lp: Vec<[f32; 3]>,
    /// What each half of the strands deposited, before the front-to-back sum: map-major, one
    /// `size`² plane per map.
    partial: [std::sync::Mutex<Vec<f32>>; HALVES],
    /// The build of the transform and the deposits: [`crate::simd::level`], or a renderer's
    /// explicit level.
    pub(crate) level: Level,
}

impl ShadowMaps {
    /// Empty maps of `size`² texels each.
    pub fn new(size: usize) -> ShadowMaps {
        ShadowMaps {
            size,
            ax_u: [1.0, 0.0, 0.0],
            ax_v: [0.0, 0.0, 1.0],
            ax_d: [0.0, -1.0, 0.0],
            u0: 0.0,
            v0: 0.0,
            inv_texel: 1.0,
            z0: 0.0,
            dz: 1.0,
            inv_dz: 1.0,
            omega: vec![0.0; size * size * MAPS],
            lp: Vec::new(),
            partial: Default::default(),
            level: crate::simd::level(),
        }
    }

    /// Distance between two maps, metres.
    pub fn spacing(&self) -> f32 {
        self.dz
    }

    /// Builds the maps for strands `points`/`offsets` lit from direction `to_light`, on the
    /// calling thread.
    pub fn build(&mut self, points: &[[f32; 3]], offsets: &[u32], to_light: [f32; 3]) {
        self.build_with(points, offsets, to_light, None);
    }

    /// [`ShadowMaps::build`], each step's jobs run by the pool's threads. The two halves of
    /// the strands are deposited into maps of their own, summed half 0 + half 1 afterwards, so
    /// the result does not depend on the number of threads.
    pub(crate) fn build_with(
        &mut self,
        points: &[[f32; 3]],
        offsets: &[u32],
        to_light: [f32; 3],
        pool: Option<&crate::par::Pool>,
    ) {
        let frame = self.light_frame(points, to_light);
        for_each_on(pool, LightFrame::CHUNKS, &|c| frame.run(c));
        let (lo, hi) = frame.bounds();
        self.set_extent(lo, hi, points.is_empty());
        let deposits = self.deposits(offsets);
        for_each_on(pool, Deposit::HALVES, &|h| deposits.run(h));
        let sums = self.sums();
        for_each_on(pool, Sum::BANDS, &|c| sums.run(c));
    }

    /// Sets up the light frame for light direction `to_light`, and returns the jobs that
    /// put `points` in it. Then: [`ShadowMaps::set_extent`], [`ShadowMaps::deposits`],
    /// [`ShadowMaps::sums`], each after the previous step's jobs have all run.
    pub(crate) fn light_frame<'a>(
        &'a mut self,
        points: &'a [[f32; 3]],
        to_light: [f32; 3],
    ) -> LightFrame<'a> {
        let d = normalize([-to_light[0], -to_light[1], -to_light[2]]);
        let helper = if d[1].abs() < 0.9 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let u = normalize(cross(helper, d));
        let v = cross(d, u);
        (self.ax_u, self.ax_v, self.ax_d) = (u, v, d);
        // Every point is written by the jobs: resized, not cleared.
        self.lp.resize(points.len(), [0.0; 3]);
        let n = points.len();
        LightFrame {
            level: self.level,
            points,
            axes: [u, v, d],
            parts: split_parts(&mut self.lp, |c| (c + 1) * n / FRAME_CHUNKS),
            bounds: std::array::from_fn(|_| {
                Mutex::new(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]))
            }),
        }
    }

    /// Spreads the maps over the light-space bounds `lo`..`hi` of the points (`empty`: there
    /// are none).
    pub(crate) fn set_extent(&mut self, mut lo: [f32; 3], mut hi: [f32; 3], empty: bool) {
        if empty {
            (lo, hi) = ([0.0; 3], [1.0; 3]);
        }
        let size = self.size as f32;
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-4);
        // One texel of margin on each side, so that bilinear splats stay inside.
        let inv_texel = (size - 3.0) / extent;
        let (u0, v0) = (lo[0] - 1.0 / inv_texel, lo[1] - 1.0 / inv_texel);
        (self.inv_texel, self.u0, self.v0) = (inv_texel, u0, v0);
        self.z0 = lo[2];
        self.dz = ((hi[2] - lo[2]) / (MAPS - 1) as f32).max(1e-5);
        self.inv_dz = 1.0 / self.dz;
    }

    /// The jobs that deposit the strands (`offsets` into the points of
    /// [`ShadowMaps::light_frame`]); each first scales its own points' u and v to texels.
    pub(crate) fn deposits<'a>(&'a mut self, offsets: &'a [u32]) -> Deposit<'a> {
        let splat = Splat {
            size: self.size,
            u0: self.u0,
            v0: self.v0,
            inv_texel: self.inv_texel,
            z0: self.z0,
            inv_dz: self.inv_dz,
        };
        let ns = offsets.len().saturating_sub(1);
        let lp = split_parts(&mut self.lp, |h| {
            if ns == 0 {
                0
            } else {
                offsets[(h + 1) * ns / HALVES] as usize
            }
        });
        Deposit {
            level: self.level,
            splat,
            offsets,
            lp,
            partial: &self.partial,
        }
    }

    /// The jobs that sum the deposits front to back into the maps.
    pub(crate) fn sums(&mut self) -> Sum<'_> {
        let [p0, p1] = &mut self.partial;
        let (p0, p1) = (
            &*p0.get_mut().unwrap_or_else(|e| e.into_inner()),
            &*p1.get_mut().unwrap_or_else(|e| e.into_inner()),
        );
        let row = self.size * MAPS;
        let rows = self.size;
        Sum {
            size: self.size,
            bands: split_parts(&mut self.omega, |c| (c + 1) * rows / SUM_BANDS * row),
            p0,
            p1,
        }
    }

    /// The light-space position of world point `p` (u, v in texels, z in metres).
    #[inline]
    pub fn light_space(&self, p: [f32; 3]) -> [f32; 3] {
        [
            (dot(p, self.ax_u) - self.u0) * self.inv_texel,
            (dot(p, self.ax_v) - self.v0) * self.inv_texel,
            dot(p, self.ax_d),
        ]
    }

    /// Light-space position of strand point `i` of the last build.
    #[inline(always)]
    pub fn point(&self, i: usize) -> [f32; 3] {
        self.lp[i]
    }

    /// The opacity Ω (strand crossings) at light-space position `q`, looked up `bias` map
    /// spacings nearer the light.
    #[inline]
    pub fn opacity(&self, q: [f32; 3], bias: f32) -> f32 {
        let f = (q[2] - self.z0) / self.dz - bias;
        let (i, w0, w1) = if f <= 0.0 {
            (0, (1.0 + f).max(0.0), 0.0)
        } else if f >= (MAPS - 1) as f32 {
            (MAPS - 2, 0.0, 1.0)
        } else {
            let i = f as i32 as usize;
            let w = f - i as i32 as f32;
            (i, 1.0 - w, w)
        };
        let s = self.size;
        let max = (s - 2) as f32;
        let x = (q[0] - 0.5).clamp(0.0, max);
        let y = (q[1] - 0.5).clamp(0.0, max);
        let (xi, yi) = (x as i32 as usize, y as i32 as usize);
        let (fx, fy) = (x - xi as i32 as f32, y - yi as i32 as f32);
        let base = (yi * s + xi) * MAPS + i;
        let o = &self.omega;
        let at = |b: usize| w0 * o[b] + w1 * o[b + 1];
        let top = at(base) * (1.0 - fx) + at(base + MAPS) * fx;
        let bottom = at(base + s * MAPS) * (1.0 - fx) + at(base + (s + 1) * MAPS) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// [`ShadowMaps::opacity`] at N light-space points (`q[axis][lane]`) at once: the
    /// same interpolation, without branches, for the per-point shading.
    #[inline(always)]
    pub fn opacity_lanes<const N: usize>(&self, q: [[f32; N]; 3], bias: f32) -> [f32; N] {
        use super::num::{mn, mx};
        use std::array::from_fn;
        let s = self.size;
        let max = (s - 2) as f32;
        // The weights and texel addresses lane by lane (vector code), then the loads lane
        // after lane, then the interpolation lane by lane again.
        // Eq. 1's two maps: f between map ⌊f⌋ and ⌊f⌋ + 1; in front of map 0, map "−1"
        // (which holds nothing) and map 0; beyond the last map, the last map alone.
        // (`mx`/`mn` send NaN to the bound, so the conversions below are in range.)
        let f: [f32; N] = from_fn(|l| {
            mn(
                mx((q[2][l] - self.z0) * self.inv_dz - bias, -1.0),
                (MAPS - 1) as f32,
            )
        });
        // SAFETY: f + 1 is in [0, MAPS], and x, y below in [0, size − 2].
        let fl: [i32; N] = from_fn(|l| {
            (unsafe { (f[l] + 1.0).to_int_unchecked::<i32>() } - 1).min(MAPS as i32 - 2)
        });
        let w1: [f32; N] = from_fn(|l| f[l] - fl[l] as f32);
        // Map ⌊f⌋ is −1 in front of map 0: it gets no weight, and reads map 0.
        let w0: [f32; N] = from_fn(|l| if fl[l] >= 0 { 1.0 - w1[l] } else { 0.0 });
        let i: [usize; N] = from_fn(|l| (fl[l].max(0) as usize) & (MAPS - 1));
        let i1: [usize; N] = from_fn(|l| (if fl[l] >= 0 { i[l] + 1 } else { 0 }) & (MAPS - 1));
        let x: [f32; N] = from_fn(|l| mn(mx(q[0][l] - 0.5, 0.0), max));
        let y: [f32; N] = from_fn(|l| mn(mx(q[1][l] - 0.5, 0.0), max));
        let xi: [i32; N] = from_fn(|l| unsafe { x[l].to_int_unchecked::<i32>() });
        let yi: [i32; N] = from_fn(|l| unsafe { y[l].to_int_unchecked::<i32>() });
        let fx: [f32; N] = from_fn(|l| x[l] - xi[l] as f32);
        let fy: [f32; N] = from_fn(|l| y[l] - yi[l] as f32);
        // The 2×2 texels, each MAPS opacities, at the two maps.
        let mut t = [[[0.0f32; N]; 2]; 4];
        for l in 0..N {
            let at = (yi[l] as usize * s + xi[l] as usize) * MAPS;
            let (top, bottom) = (
                &self.omega[at..at + 2 * MAPS],
                &self.omega[at + s * MAPS..at + (s + 2) * MAPS],
            );
            for (c, (row, k)) in [(top, 0), (top, MAPS), (bottom, 0), (bottom, MAPS)]
                .into_iter()
                .enumerate()
            {
                t[c][0][l] = row[k + i[l]];
                t[c][1][l] = row[k + i1[l]];
            }
        }
        let pair = |c: usize| -> [f32; N] { from_fn(|l| w0[l] * t[c][0][l] + w1[l] * t[c][1][l]) };
        let (p0, p1, p2, p3) = (pair(0), pair(1), pair(2), pair(3));
        from_fn(|l| {
            let upper = p0[l] * (1.0 - fx[l]) + p1[l] * fx[l];
            let lower = p2[l] * (1.0 - fx[l]) + p3[l] * fx[l];
            upper * (1.0 - fy[l]) + lower * fy[l]
        })
    }

    /// The 16 opacities Ω_0..Ω_15 at texel (x, y) (for tests).
    pub fn texel(&self, x: usize, y: usize) -> &[f32] {
        let b = (y * self.size + x) * MAPS;
        &self.omega[b..b + MAPS]
    }

    /// Depth of map 0 along the light direction, metres.
    pub fn first_depth(&self) -> f32 {
        self.z0
    }
}
