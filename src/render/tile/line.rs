//! The line rasteriser of the tile pass: a segment drawn as a box-filtered line, column by
//! column along its major axis, thin lines through a fixed window of samples.

use super::hidden::Column;
use super::{Kernels, Px, TileBuf, BLOCK, OPAQUE, WINDOW};
use crate::render::num::{ceil_pos, floor_pos, mn, mx};
use crate::render::point_colors::unpack;
use crate::render::raster::SegRec;
use crate::simd::blend::{Blend, WindowLine};

impl TileBuf {
    /// Blends `w0 · cov` of colour `col` (its 4th lane −1) into sample `at` (block `b`) if the
    /// sample is neither opaque nor behind the body at depth `z`; `cov` may be 0.
    #[inline(always)]
    pub(super) fn blend(&mut self, at: usize, b: usize, z: f32, w0: f32, cov: f32, col: &Px) {
        let p = &mut self.px[at];
        let v = p.0;
        let tr = v[3];
        let live = tr >= OPAQUE && z < self.zb[at];
        // A refused sample gets weight 0: adding 0 leaves every channel exactly as it was.
        let w = if live { tr * w0 * cov } else { 0.0 };
        // Written out lane by lane so that it compiles to one vector multiply-add.
        let c = col.0;
        p.0 = [
            v[0] + w * c[0],
            v[1] + w * c[1],
            v[2] + w * c[2],
            v[3] + w * c[3],
        ];
        if live && p.0[3] < OPAQUE {
            self.opaque(b);
        }
    }

    /// Blends segment `s` (global sample coordinates) behind what the tile holds: a line of
    /// half-width `half` samples and opacity `alpha` where it covers a whole sample, its
    /// colour interpolated between its two points' colours.
    /// No segment-level culling test here: the caller has made [`TileBuf::culls`] (culling
    /// is exact, so drawing a hidden segment changes no sample; the group tests below still
    /// skip most of its work).
    #[inline(always)]
    pub(super) fn segment<I: Kernels>(&mut self, s: &SegRec, half: f32, alpha: f32) {
        let (a, b) = (&s.a, &s.b);
        let (ox, oy) = (self.ox as f32, self.oy as f32);
        let (ax, ay, bx, by) = (a.x - ox, a.y - oy, b.x - ox, b.y - oy);
        let n = self.n;
        // Major axis: the one along which the segment is longer; one sample step per column.
        let x_major = (bx - ax).abs() >= (by - ay).abs();
        let (maj_a, min_a, maj_b, min_b) = if x_major {
            (ax, ay, bx, by)
        } else {
            (ay, ax, by, bx)
        };
        let d = (maj_b - maj_a).abs();
        let (ca, cb) = (unpack(s.ca), unpack(s.cb));
        // Walk the major axis upwards.
        let (maj0, min0, z0, c0, maj1, min1, z1, c1) = if maj_b < maj_a {
            (maj_b, min_b, b.z, cb, maj_a, min_a, a.z, ca)
        } else {
            (maj_a, min_a, a.z, ca, maj_b, min_b, b.z, cb)
        };
        let inv = 1.0 / d;
        let slope = (min1 - min0) * inv;
        // The line's cross-section along the minor axis widens as 1/cos of its angle.
        let h = half * (1.0 + slope * slope).sqrt();
        // At most 3 samples across: any placement touches at most WINDOW samples.
        let thin = 2.0 * h <= (WINDOW - 1) as f32 && n >= WINDOW;
        let i0 = floor_pos(maj0);
        let i1 = ceil_pos(maj1).min(n);
        let dz = z1 - z0;
        let dc = [c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]];
        // Columns come in groups of one culling block's width. A group whose whole extent
        // (its minor range, and the segment's nearest depth over it) lies in opaque or
        // body-hidden blocks is skipped in one test: every column of it would fail its own.
        // The groups' extents are computed four groups at a time, in vector lanes.
        let first_block = i0 / BLOCK;
        let groups = if i1 > i0 {
            (i1 - 1) / BLOCK + 1 - first_block
        } else {
            0
        };
        let line = Line {
            x_major,
            maj0,
            maj1,
            min0,
            min1,
            inv,
            h,
            z0,
            dz,
            c0,
            dc,
        };
        for q in (0..groups).step_by(4) {
            let start = ilanes(|k| (((first_block + q + k) * BLOCK).max(i0)) as i32);
            let end = ilanes(|k| (((first_block + q + k + 1) * BLOCK).min(i1)) as i32);
            let ta = lanes(|k| (mx(maj0, start[k] as f32) - maj0) * inv);
            let tb = lanes(|k| (mn(maj1, end[k] as f32) - maj0) * inv);
            let ca = lanes(|k| min0 + ta[k] * (min1 - min0));
            let cb = lanes(|k| min0 + tb[k] * (min1 - min0));
            let zg = lanes(|k| mn(z0 + ta[k] * dz, z0 + tb[k] * dz));
            let g0 = lanes(|k| mn(ca[k], cb[k]) - h).map(floor_pos);
            let g1 = lanes(|k| mx(ca[k], cb[k]) + h).map(|x| ceil_pos(x).min(n));
            for k in 0..(groups - q).min(4) {
                let (gs, ge) = (start[k] as usize, end[k] as usize);
                if g1[k] <= g0[k]
                    || self.column_hidden(
                        Column::new(x_major, gs, self.stride),
                        g0[k],
                        g1[k] - 1,
                        zg[k],
                    )
                {
                    continue;
                }
                if self.point_sampled {
                    self.point_group(&line, gs, ge, alpha);
                } else if thin {
                    self.thin_group::<I>(&line, gs, ge, alpha);
                } else {
                    self.wide_group(&line, gs, ge, alpha);
                }
            }
        }
    }

    /// Draws columns `gs..ge` (at most BLOCK) of thin line `l`: the columns' parameters
    /// computed four lanes at once by the same arithmetic as [`TileBuf::wide_group`], then each
    /// column's fixed window (moved inside the tile at its far edge), all four samples at once.
    /// No culling test per column: the group passed one, and a sample that is opaque or behind
    /// the body refuses the blend anyway; the test would cost as much as the blend.
    #[inline(always)]
    fn thin_group<I: Blend>(&mut self, l: &Line, gs: usize, ge: usize, alpha: f32) {
        let n = self.n;
        let (stride_maj, stride_min) = if l.x_major { (1, n) } else { (n, 1) };
        let fi = gs as f32;
        let fk = lanes(|k| fi + k as f32);
        let lo = lanes(|k| mx(l.maj0, fk[k]));
        let hi = lanes(|k| mn(l.maj1, fk[k] + 1.0));
        let cov_maj = lanes(|k| hi[k] - lo[k]);
        let t = lanes(|k| (0.5 * (lo[k] + hi[k]) - l.maj0) * l.inv);
        let c = lanes(|k| l.min0 + t[k] * (l.min1 - l.min0));
        let z = lanes(|k| l.z0 + t[k] * l.dz);
        // Channel by channel (`[0, 1, 2].map(..)` left a call to `array::map` here).
        let rgb = [
            lanes(|k| l.c0[0] + t[k] * l.dc[0]),
            lanes(|k| l.c0[1] + t[k] * l.dc[1]),
            lanes(|k| l.c0[2] + t[k] * l.dc[2]),
        ];
        for k in 0..ge - gs {
            if cov_maj[k] <= 0.0 {
                continue;
            }
            let col_i = gs + k;
            let (y_lo, y_hi) = (c[k] - l.h, c[k] + l.h);
            let js = floor_pos(y_lo).min(n - WINDOW);
            self.blend_window::<I>(
                col_i * stride_maj + js * stride_min,
                stride_min,
                js,
                Column::new(l.x_major, col_i, self.stride),
                z[k],
                alpha * cov_maj[k],
                (y_lo, y_hi),
                &Px([rgb[0][k], rgb[1][k], rgb[2][k], -1.0]),
            );
        }
    }

    /// Draws columns `gs..ge` of line `l`, however wide, column by column, each tested for
    /// culling first, sample by sample.
    #[inline(always)]
    fn wide_group(&mut self, l: &Line, gs: usize, ge: usize, alpha: f32) {
        let n = self.n;
        let (stride_maj, stride_min) = if l.x_major { (1, n) } else { (n, 1) };
        for col_i in gs..ge {
            let fi = col_i as f32;
            let lo = mx(l.maj0, fi);
            let hi = mn(l.maj1, fi + 1.0);
            let cov_maj = hi - lo;
            if cov_maj <= 0.0 {
                continue;
            }
            let t = (0.5 * (lo + hi) - l.maj0) * l.inv;
            let c = l.min0 + t * (l.min1 - l.min0);
            let z = l.z0 + t * l.dz;
            let (y_lo, y_hi) = (c - l.h, c + l.h);
            let j0 = floor_pos(y_lo);
            let col = Column::new(l.x_major, col_i, self.stride);
            let rgb = Px([
                l.c0[0] + t * l.dc[0],
                l.c0[1] + t * l.dc[1],
                l.c0[2] + t * l.dc[2],
                -1.0,
            ]);
            let w0 = alpha * cov_maj;
            let j1 = ceil_pos(y_hi).min(n);
            if j1 <= j0 || self.column_hidden(col, j0, j1 - 1, z) {
                continue;
            }
            let mut fj = j0 as f32;
            for j in j0..j1 {
                let cov = mx(mn(y_hi, fj + 1.0) - mx(y_lo, fj), 0.0);
                fj += 1.0;
                let at = col_i * stride_maj + j * stride_min;
                self.blend(at, col.block(j), z, w0, cov, &rgb);
            }
        }
    }

    /// Draws columns `gs..ge` of line `l` point-sampled ([`TileBuf::point_sampled`]): a column
    /// whose centre the segment spans (half-open, so joined segments share no column) takes
    /// the line at its centre, and each sample of it whose centre lies within the line's
    /// cross-section gets the line's full opacity.
    fn point_group(&mut self, l: &Line, gs: usize, ge: usize, alpha: f32) {
        let n = self.n;
        let (stride_maj, stride_min) = if l.x_major { (1, n) } else { (n, 1) };
        for col_i in gs..ge {
            let m = col_i as f32 + 0.5;
            if m < l.maj0 || m >= l.maj1 {
                continue;
            }
            let t = (m - l.maj0) * l.inv;
            let c = l.min0 + t * (l.min1 - l.min0);
            let z = l.z0 + t * l.dz;
            let rgb = Px([
                l.c0[0] + t * l.dc[0],
                l.c0[1] + t * l.dc[1],
                l.c0[2] + t * l.dc[2],
                -1.0,
            ]);
            // Samples j with centre j + 0.5 in [c − h, c + h).
            let j0 = ceil_pos(c - l.h - 0.5);
            let j1 = ceil_pos(c + l.h - 0.5).min(n);
            let col = Column::new(l.x_major, col_i, self.stride);
            for j in j0..j1 {
                let at = col_i * stride_maj + j * stride_min;
                self.blend(at, col.block(j), z, alpha, 1.0, &rgb);
            }
        }
    }

    /// [`TileBuf::blend`] into the WINDOW samples `at + k·stride` (`k` = 0..WINDOW), which are
    /// samples `js + k` of column `col`, of a line covering `y_lo..y_hi` across the column:
    /// the same arithmetic, all four samples at once without branches ([`Blend::window`], in
    /// SSE registers or its portable twin), then the rare sample that turned opaque counted.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn blend_window<I: Blend>(
        &mut self,
        at: usize,
        stride: usize,
        js: usize,
        col: Column,
        z: f32,
        w0: f32,
        (y_lo, y_hi): (f32, f32),
        rgb: &Px,
    ) {
        let line = WindowLine {
            y_lo,
            y_hi,
            fj0: js as i32 as f32,
            z,
            w0,
            rgb: *rgb,
            opaque: OPAQUE,
        };
        // One bounds check per window: the samples are `k · stride` into these slices.
        let span = (WINDOW - 1) * stride + 1;
        let turned = I::window(
            &mut self.px[at..at + span],
            &self.zb[at..at + span],
            stride,
            &line,
        );
        if turned != 0 {
            for k in 0..WINDOW {
                if turned & (1 << k) != 0 {
                    self.opaque(col.block(js + k));
                }
            }
        }
    }
}

/// A segment as the tile pass draws it: walked along its major axis from `maj0` to `maj1`
/// (tile-relative samples; `inv` = 1 / (maj1 − maj0)), its centre line going from `min0` to
/// `min1` across, half-width `h` across the columns, depth `z0 + t·dz` and colour
/// `c0 + t·dc` at parameter t.
struct Line {
    x_major: bool,
    maj0: f32,
    maj1: f32,
    min0: f32,
    min1: f32,
    inv: f32,
    h: f32,
    z0: f32,
    dz: f32,
    c0: [f32; 3],
    dc: [f32; 3],
}

/// [`lanes`] of integers.
#[inline(always)]
fn ilanes(f: impl Fn(usize) -> i32) -> [i32; 4] {
    [f(0), f(1), f(2), f(3)]
}

/// Four lanes of a value, computed together: written lane by lane without branches, so that
/// the compiler makes each line one vector instruction.
#[inline(always)]
fn lanes(f: impl Fn(usize) -> f32) -> [f32; 4] {
    [f(0), f(1), f(2), f(3)]
}
