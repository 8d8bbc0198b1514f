//! One tile's samples and the line rasteriser that blends segments into them front to back.
//!
//! Every segment is drawn as a line of the strand's width, box-filtered over the sample grid:
//! along the major axis each sample column gets the length of the segment inside it, across it
//! each sample the overlap of its cell with the line's cross-section. A strand's coverage of
//! the image is then its length × its width, however it lies on the grid (no crawling as it
//! moves by a fraction of a sample). Segments arrive sorted front to back (the visibility
//! ordering of line segments the AWT paper uses for antialiasing, Bertails et al. 2003, §5.1)
//! and are composited with the "under" operator; a sample whose transmittance drops below
//! [`OPAQUE`] takes nothing more.
//!
//! Culling: each tile keeps, per block of 4×4 samples, the depth from which nothing more can
//! show there: minus infinity once all its samples are opaque, else the farthest body depth.
//! A segment (or one column of it) that lies at or behind that depth in every block it touches
//! is skipped; every sample it would have touched would have refused it anyway, so the image is
//! the same as without culling. In the 16k-strand benchmark this skips about 70% of the
//! segments and leaves a third of the sample visits.
//!
//! Speed: a sample is one 16-byte record (colour and transmittance together, one cache line
//! per visit), and a thin line (at most 3 samples across, the default 0.9-pixel strands at 2×2
//! supersampling) takes a fixed window of 4 samples per column with no branch per sample: the
//! samples outside its cross-section get coverage 0 and so add exactly nothing.

use super::camera::View;
use super::point_colors::unpack;
use super::pool::multiversion;
use super::raster::{ceil_pos, floor_pos, mn, mx, ScreenVertex, SegRec, OPAQUE};

/// Side of a culling block, samples (a power of two).
const BLOCK: usize = 4;
/// Lanes of one comparison of a row of culling depths: rows of blocks are padded to a
/// multiple of this, so that a row is tested in whole vectors and yields a bit mask.
const LANES: usize = 16;
/// Block rows of a narrow box that [`TileBuf::hidden`] tests without a loop.
const NARROW_ROWS: usize = 8;
/// Entries past the last row of the per-block arrays, so that 4 blocks can be read from any
/// block of a row.
const TAIL: usize = 3;
/// Samples of the fixed per-column window of thin lines.
const WINDOW: usize = 4;

/// One tile's samples; reused from tile to tile.
#[derive(Debug, Default)]
pub(crate) struct TileBuf {
    /// Side, samples.
    pub n: usize,
    /// Global sample coordinates of sample (0, 0).
    pub ox: i32,
    pub oy: i32,
    /// Per sample: the hair colour accumulated front to back (premultiplied, linear r, g, b)
    /// and the light still passing through the hair in front.
    pub px: Vec<Px>,
    /// View depth of the body, `INFINITY` where there is none.
    pub zb: Vec<f32>,
    /// Which body primitive is there.
    pub prim: Vec<u16>,
    /// Samples not yet opaque.
    pub alive: usize,
    /// No hair in the tile this frame ([`TileBuf::take_body`]): `px` is stale and every
    /// sample is clear (no colour, transmittance 1).
    pub hairless: bool,
    /// Blocks of BLOCK² samples per side.
    nb: usize,
    /// Blocks per row in `block_alive` and `block_close`: `nb` padded to whole LANES (block
    /// (bx, by) is entry `by · stride + bx`).
    stride: usize,
    /// Per block, samples not yet opaque (0 in the padding).
    block_alive: Vec<u32>,
    /// Per block, the view depth at and beyond which nothing shows: the farthest body depth
    /// (`INFINITY` if a sample has no body), `NEG_INFINITY` once every sample is opaque (and
    /// in the padding, and in the TAIL entries past the last row).
    block_close: Vec<f32>,
    /// Whether the body covers any sample of the tile.
    body_seen: bool,
}

impl TileBuf {
    /// Clears the samples (no hair yet) and sets the geometry, leaving the body as it is.
    fn reset_samples(&mut self, n: usize, ox: i32, oy: i32) {
        self.n = n;
        self.ox = ox;
        self.oy = oy;
        let m = n * n;
        self.px.clear();
        self.px.resize(m, Px([0.0, 0.0, 0.0, 1.0]));
        self.alive = m;
        self.set_blocks(n);
        self.block_alive.clear();
        for by in 0..self.nb {
            let h = (n - by * BLOCK).min(BLOCK);
            for bx in 0..self.stride {
                let w = n.saturating_sub(bx * BLOCK).min(BLOCK);
                self.block_alive.push((w * h) as u32);
            }
        }
    }

    /// Sets the block geometry of a tile of `n`² samples.
    fn set_blocks(&mut self, n: usize) {
        self.nb = n.div_ceil(BLOCK);
        self.stride = self.nb.div_ceil(LANES) * LANES;
    }

    /// Block `(bx, by)`'s entry in the per-block arrays.
    #[cfg(test)]
    fn block_at(&self, bx: usize, by: usize) -> usize {
        by * self.stride + bx
    }

    /// Removes the body (no sample has any), for the geometry set.
    fn reset_body(&mut self) {
        let m = self.n * self.n;
        self.zb.clear();
        self.zb.resize(m, f32::INFINITY);
        // `prim` is read only where `zb` is finite, and written wherever it is set: no clear.
        self.prim.resize(m, 0);
        self.block_close.clear();
        self.block_close
            .resize(self.nb * self.stride, f32::INFINITY);
        self.close_padding();
        self.block_close.extend([f32::NEG_INFINITY; TAIL]);
        self.body_seen = false;
    }

    /// Sets the padding of each row of `block_close` to `NEG_INFINITY`.
    fn close_padding(&mut self) {
        for row in self.block_close.chunks_exact_mut(self.stride) {
            row[self.nb..].fill(f32::NEG_INFINITY);
        }
    }

    /// Sets each block's farthest body depth, once the body is cast.
    #[inline(always)]
    pub fn close_blocks(&mut self) {
        let n = self.n;
        if !self.body_seen {
            // `reset` left every block open (no body anywhere in the tile).
            return;
        }
        self.block_close.fill(f32::NEG_INFINITY);
        let stride = self.stride;
        for (j, row) in self.zb.chunks_exact(n).enumerate() {
            let closes = &mut self.block_close[(j / BLOCK) * stride..][..n.div_ceil(BLOCK)];
            // Whole blocks four samples at a time (vector code), then a partial last one.
            let whole = row.chunks_exact(BLOCK);
            let rest = whole.remainder();
            for (c, four) in closes.iter_mut().zip(whole) {
                *c = c.max(four[0]).max(four[1]).max(four[2]).max(four[3]);
            }
            if !rest.is_empty() {
                let c = &mut closes[n / BLOCK];
                *c = rest.iter().fold(*c, |m, &z| m.max(z));
            }
        }
    }

    /// Whether nothing at view depth `z` or beyond can show in tile-relative box
    /// [x0, x1] × [y0, y1]: every block it touches is opaque, or hidden by the body.
    #[inline(always)]
    fn hidden(&self, x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> bool {
        let last = self.nb - 1;
        let bx0 = (floor_pos(x0) / BLOCK).min(last);
        let bx1 = (floor_pos(x1) / BLOCK).min(last);
        let by0 = (floor_pos(y0) / BLOCK).min(last);
        let by1 = (floor_pos(y1) / BLOCK).min(last);
        if bx1 - bx0 < 4 && by1 - by0 < NARROW_ROWS {
            // At most 4 blocks wide and NARROW_ROWS tall (nearly all boxes: hair hangs, so
            // most segments are steep): each row's blocks from bx0 in one unaligned 4-lane
            // compare (the array has room past its last row), every one of the NARROW_ROWS
            // rows tested (rows repeated where the box has fewer), and no loop or early
            // exit whose outcome the processor would have to guess.
            let want = (1u32 << (bx1 - bx0 + 1)) - 1;
            let mut m = want;
            // One bounds check for the eight reads: the last row's four are in the array.
            let last_at = by1 * self.stride + bx0;
            let close = &self.block_close[..last_at + 4];
            for r in 0..NARROW_ROWS {
                let at = (by0 + r).min(by1) * self.stride + bx0;
                // SAFETY: at ≤ last_at, and `close` holds last_at + 4 values.
                let four = unsafe { &*(close.as_ptr().add(at) as *const [f32; 4]) };
                m &= four_hidden(four, z);
            }
            return m == want;
        }
        // Row by row, each row's blocks compared all at once into a bit mask: no loop with a
        // data-dependent trip count per block, on a test made for every binned segment.
        let want = (u32::MAX >> (31 - bx1)) & (u32::MAX << bx0);
        let row = |by: usize| {
            let r = &self.block_close[by * self.stride..(by + 1) * self.stride];
            row_hidden(r, z)
        };
        if by1 - by0 < 3 {
            // Up to three rows (nearly always): all three tested (rows repeated when there
            // are fewer) and combined, with no loop or early exit whose outcome the processor
            // would have to guess.
            let mid = (by0 + 1).min(by1);
            return row(by0) & row(mid) & row(by1) & want == want;
        }
        (by0..by1 + 1).all(|by| row(by) & want == want)
    }

    /// Ray casts the body primitives `prims` into the depth buffer.
    #[inline(always)]
    pub fn cast_body(&mut self, view: &View, prims: &[super::body::Prim]) {
        let n = self.n;
        let (fx0, fy0) = (self.ox as f32, self.oy as f32);
        let (fx1, fy1) = (fx0 + n as f32, fy0 + n as f32);
        // Rays are linear in the sample position: d(i, j) = d00 + i·dx + j·dy.
        let d00 = view.ray(fx0 + 0.5, fy0 + 0.5);
        let dx = super::camera::sub(view.ray(fx0 + 1.5, fy0 + 0.5), d00);
        let dy = super::camera::sub(view.ray(fx0 + 0.5, fy0 + 1.5), d00);
        for (k, p) in prims.iter().enumerate() {
            let k_prim = k as u16;
            let [rx0, ry0, rx1, ry1] = p.rect;
            if rx1 < fx0 || rx0 > fx1 || ry1 < fy0 || ry0 > fy1 {
                continue;
            }
            let j0 = floor_pos(ry0 - fy0).min(n);
            let j1 = ceil_pos(ry1 - fy0).min(n);
            let i0 = floor_pos(rx0 - fx0).min(n);
            let i1 = ceil_pos(rx1 - fx0).min(n);
            let r = p.rays(view.eye, d00, dx, dy);
            let mut seen = false;
            for j in j0..j1 {
                let zb = &mut self.zb[j * n + i0..j * n + i1];
                let prim = &mut self.prim[j * n + i0..j * n + i1];
                // Every sample of the row computed and kept where nearer, without a branch
                // (vector code); the same operations as a per-sample `hit`, so the same depths.
                for (di, (z, pr)) in zb.iter_mut().zip(prim.iter_mut()).enumerate() {
                    let t = r.hit_or_infinity((i0 + di) as f32, j as f32);
                    let nearer = t < *z;
                    *z = if nearer { t } else { *z };
                    *pr = if nearer { k_prim } else { *pr };
                    seen |= nearer;
                }
            }
            self.body_seen |= seen;
        }
    }

    /// Whether samples j0..=j1 of column (or row) i are all in opaque or body-hidden blocks
    /// at depth `z`.
    #[inline(always)]
    fn column_hidden(&self, at: Column, j0: usize, j1: usize, z: f32) -> bool {
        let (b0, b1) = (j0 / BLOCK, j1 / BLOCK);
        if b1 - b0 < 2 {
            // One or two blocks (nearly always): both read, with no loop whose trip count
            // the processor would have to guess.
            let far = mx(
                self.block_close[at.base + b0 * at.step],
                self.block_close[at.base + b1 * at.step],
            );
            return z >= far;
        }
        let mut far = f32::NEG_INFINITY;
        for jb in b0..b1 + 1 {
            far = mx(far, self.block_close[at.base + jb * at.step]);
        }
        z >= far
    }

    /// Blends `w0 · cov` of colour `col` (its 4th lane −1) into sample `at` (block `b`) if the
    /// sample is neither opaque nor behind the body at depth `z`; `cov` may be 0.
    #[inline(always)]
    fn blend(&mut self, at: usize, b: usize, z: f32, w0: f32, cov: f32, col: &Px) {
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

    /// Whether the tile pass can skip segment `s` (a line of half-width `half` samples) as
    /// things stand: it draws nothing here whatever the tile holds, or every block it touches
    /// is opaque or hidden by the body at its nearest depth. Blocks only ever close, so a
    /// segment culled now would be refused by every sample later too.
    #[inline(always)]
    fn culls(&self, s: &SegRec, half: f32) -> bool {
        match cull_box(self.ox, self.oy, &s.a, &s.b, half) {
            Some([lo0, hi0, lo1, hi1, zmin]) => self.hidden(lo0, hi0, lo1, hi1, zmin),
            None => true,
        }
    }

    /// Blends segment `s` (global sample coordinates) behind what the tile holds: a line of
    /// half-width `half` samples and opacity `alpha` where it covers a whole sample, its
    /// colour interpolated between its two points' colours.
    /// No segment-level culling test here: the caller has made [`TileBuf::culls`] (culling
    /// is exact, so drawing a hidden segment changes no sample; the group tests below still
    /// skip most of its work).
    #[inline(always)]
    fn segment(&mut self, s: &SegRec, half: f32, alpha: f32) {
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
                if thin {
                    self.thin_group(&line, gs, ge, alpha);
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
    fn thin_group(&mut self, l: &Line, gs: usize, ge: usize, alpha: f32) {
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
            self.blend_window(
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

    /// [`TileBuf::blend`] into the WINDOW samples `at + k·stride` (`k` = 0..WINDOW), which are
    /// samples `js + k` of column `col`, of a line covering `y_lo..y_hi` across the column:
    /// the same arithmetic, all four samples at once without branches (the rare sample that
    /// turns opaque is counted afterwards).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn blend_window(
        &mut self,
        at: usize,
        stride: usize,
        js: usize,
        col: Column,
        z: f32,
        w0: f32,
        span: (f32, f32),
        rgb: &Px,
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            let turned = self.blend_window_sse(at, stride, js, z, w0, span, rgb);
            if turned != 0 {
                for k in 0..WINDOW {
                    if turned & (1 << k) != 0 {
                        self.opaque(col.block(js + k));
                    }
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.blend_window_portable(at, stride, js, col, z, w0, span, rgb);
    }

    /// The blend of [`TileBuf::blend_window`] in SSE registers, one sample's colour and
    /// transmittance per register and the four samples' transmittances, coverages and weights
    /// in one: the operations of [`TileBuf::blend`] in the same order (no fused multiply-add),
    /// so the same bits. Returns the mask of the samples that turned opaque. (Written lane by
    /// lane, the compiler moved each value in and out of vector registers one lane at a time.)
    #[cfg(target_arch = "x86_64")]
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn blend_window_sse(
        &mut self,
        at: usize,
        stride: usize,
        js: usize,
        z: f32,
        w0: f32,
        (y_lo, y_hi): (f32, f32),
        rgb: &Px,
    ) -> u32 {
        use std::arch::x86_64::*;
        // One bounds check per window: the samples are `k · stride` into these slices.
        let span = (WINDOW - 1) * stride + 1;
        let px = &mut self.px[at..at + span];
        let zbs = &self.zb[at..at + span];
        let (p0, p1, p2, p3) = (0, stride, 2 * stride, 3 * stride);
        let fj0 = js as i32 as f32;
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
            let fj = _mm_add_ps(_mm_set1_ps(fj0), _mm_setr_ps(0.0, 1.0, 2.0, 3.0));
            let top = _mm_min_ps(_mm_set1_ps(y_hi), _mm_add_ps(fj, _mm_set1_ps(1.0)));
            let cov = _mm_max_ps(
                _mm_sub_ps(top, _mm_max_ps(_mm_set1_ps(y_lo), fj)),
                _mm_setzero_ps(),
            );
            let opaque = _mm_set1_ps(OPAQUE);
            let live = _mm_and_ps(_mm_cmpge_ps(tr, opaque), _mm_cmplt_ps(_mm_set1_ps(z), zb));
            // A refused sample gets weight +0: adding 0 leaves every channel as it was.
            let w = _mm_and_ps(live, _mm_mul_ps(_mm_mul_ps(tr, _mm_set1_ps(w0)), cov));
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

    /// [`TileBuf::blend_window`] on processors other than x86-64: the same arithmetic written
    /// lane by lane, without branches (the rare sample that turns opaque is counted
    /// afterwards).
    #[allow(clippy::too_many_arguments)]
    #[cfg_attr(all(target_arch = "x86_64", not(test)), allow(dead_code))]
    #[inline(always)]
    fn blend_window_portable(
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
        // One bounds check per window: the samples are `k · stride` into these slices.
        let span = (WINDOW - 1) * stride + 1;
        let px = &mut self.px[at..at + span];
        let zbs = &self.zb[at..at + span];
        let v: [[f32; 4]; WINDOW] = std::array::from_fn(|k| px[k * stride].0);
        let zb: [f32; WINDOW] = std::array::from_fn(|k| zbs[k * stride]);
        let fj0 = js as f32;
        let mut new = [[0.0f32; 4]; WINDOW];
        let mut live = [false; WINDOW];
        let c = rgb.0;
        for k in 0..WINDOW {
            let fj = fj0 + k as f32;
            let cov = mx(mn(y_hi, fj + 1.0) - mx(y_lo, fj), 0.0);
            let tr = v[k][3];
            // `&`, not `&&`: both tests, no branch.
            live[k] = (tr >= OPAQUE) & (z < zb[k]);
            // A refused sample gets weight 0: adding 0 leaves every channel as it was.
            let w = if live[k] { tr * w0 * cov } else { 0.0 };
            new[k] = [
                v[k][0] + w * c[0],
                v[k][1] + w * c[1],
                v[k][2] + w * c[2],
                v[k][3] + w * c[3],
            ];
        }
        let mut turned = false;
        for k in 0..WINDOW {
            px[k * stride].0 = new[k];
            turned |= live[k] & (new[k][3] < OPAQUE);
        }
        if turned {
            for k in 0..WINDOW {
                if live[k] && new[k][3] < OPAQUE {
                    self.opaque(col.block(js + k));
                }
            }
        }
    }

    /// Counts one more opaque sample in block `b`.
    #[inline]
    fn opaque(&mut self, b: usize) {
        self.alive -= 1;
        self.block_alive[b] -= 1;
        if self.block_alive[b] == 0 {
            self.block_close[b] = f32::NEG_INFINITY;
        }
    }
}

multiversion! {
    /// Blends a tile's segments into `buf` front to back, stopping once every sample is
    /// opaque. `segs` is in depth buckets (bucket k is `buckets[k]..buckets[k + 1]`, by the
    /// high byte of the 16-bit depth key, each in strand order; `lows` holds the low bytes).
    /// Bucket by bucket, the culling test is made first, against the tile as every nearer
    /// bucket left it, and only the segments it keeps are sorted by their low byte and drawn:
    /// the order is that of a stable sort of the whole key (equal keys in strand order), and
    /// the culled majority is never sorted.
    pub(crate) fn draw_buckets(
        buf: &mut TileBuf,
        segs: &[SegRec],
        lows: &[u8],
        buckets: &[u32; 257],
        order: &mut Vec<u64>,
        half: f32,
        alpha: f32,
    ) {
        for k in 0..256 {
            let (s, e) = (buckets[k] as usize, buckets[k + 1] as usize);
            if s == e {
                continue;
            }
            // Low byte, then position in the bucket: unique, so the unstable sort gives the
            // stable order. Written at every segment and kept where not culled: no branch on
            // the test's outcome, which the processor could not guess.
            if order.len() < e - s {
                order.resize(e - s, 0);
            }
            let mut kept = 0;
            for (i, (seg, &low)) in segs[s..e].iter().zip(&lows[s..e]).enumerate() {
                order[kept] = (low as u64) << 32 | i as u64;
                kept += !buf.culls(seg, half) as usize;
            }
            let order = &mut order[..kept];
            order.sort_unstable();
            for &o in order.iter() {
                buf.segment(&segs[s + (o as u32) as usize], half, alpha);
                if buf.alive == 0 {
                    return;
                }
            }
        }
    }
}

/// The box that the culling tests use for segment a–b in the tile at `(ox, oy)`: tile-relative
/// samples [lo0, hi0] × [lo1, hi1] within the line's reach, and its nearest depth; `None` if
/// the tile pass draws nothing of it whatever the tile holds (no length along its major axis,
/// or entirely left of or above the tile).
#[inline(always)]
fn cull_box(ox: i32, oy: i32, a: &ScreenVertex, b: &ScreenVertex, half: f32) -> Option<[f32; 5]> {
    let (ox, oy) = (ox as f32, oy as f32);
    let (ax, ay, bx, by) = (a.x - ox, a.y - oy, b.x - ox, b.y - oy);
    let d = mx((bx - ax).abs(), (by - ay).abs());
    let r = half * 1.5 + 1.0;
    let (hi0, hi1) = (mx(ax, bx) + r, mx(ay, by) + r);
    // A NaN length draws nothing either.
    if d < 1e-6 || d.is_nan() || hi0 < 0.0 || hi1 < 0.0 {
        return None;
    }
    Some([mn(ax, bx) - r, hi0, mn(ay, by) - r, hi1, mn(a.z, b.z)])
}

/// Bit k set where depth `z` is at or behind `row[k]` (`row.len()` a multiple of LANES, at
/// most 32).
#[inline(always)]
fn row_hidden(row: &[f32], z: f32) -> u32 {
    let mut mask = 0;
    for (k, chunk) in row.chunks_exact(LANES).enumerate() {
        let chunk: &[f32; LANES] = chunk.try_into().expect("chunks_exact gives LANES");
        mask |= chunk_hidden(chunk, z) << (k * LANES);
    }
    mask
}

/// Bit k set where depth `z` is at or behind `four[k]` (one SSE compare, part of every
/// x86-64).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn four_hidden(four: &[f32; 4], z: f32) -> u32 {
    use std::arch::x86_64::{_mm_cmpge_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps};
    // SAFETY: SSE is in the x86-64 baseline; the load reads the 4 floats of `four`.
    // `cmpge` is false for NaN, as `z >= c` is.
    unsafe { _mm_movemask_ps(_mm_cmpge_ps(_mm_set1_ps(z), _mm_loadu_ps(four.as_ptr()))) as u32 }
}

/// Bit k set where depth `z` is at or behind `four[k]`.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn four_hidden(four: &[f32; 4], z: f32) -> u32 {
    let mut bits = 0;
    for (l, &c) in four.iter().enumerate() {
        bits |= ((z >= c) as u32) << l;
    }
    bits
}

/// [`row_hidden`] of one chunk: four compares and mask moves (SSE, part of every x86-64;
/// written lane by lane, the compiler made a long chain of scalar compares and shifts).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn chunk_hidden(chunk: &[f32; LANES], z: f32) -> u32 {
    use std::arch::x86_64::{_mm_cmpge_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps};
    let mut bits = 0;
    for q in 0..LANES / 4 {
        // SAFETY: SSE is in the x86-64 baseline; the load reads lanes 4q..4q+4 of `chunk`
        // (unaligned loads allowed). `cmpge` is false for NaN, as `z >= c` is.
        let m = unsafe {
            let c = _mm_loadu_ps(chunk.as_ptr().add(4 * q));
            _mm_movemask_ps(_mm_cmpge_ps(_mm_set1_ps(z), c))
        };
        bits |= (m as u32) << (4 * q);
    }
    bits
}

/// [`row_hidden`] of one chunk, lane by lane.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn chunk_hidden(chunk: &[f32; LANES], z: f32) -> u32 {
    let mut bits = 0;
    for (l, &c) in chunk.iter().enumerate() {
        bits |= ((z >= c) as u32) << l;
    }
    bits
}

/// A tile's body, cast before binning: its depth buffer and culling depths, the state from
/// which the tile pass starts. Binning drops a segment from a tile where it lies behind the
/// body's farthest depth over the whole tile: the tile pass's own first test would have
/// skipped it, so the image is the same, and the segment is neither shaded, copied, sorted nor
/// tested again there. In the 16k-strand head this drops 19 % of the (segment, tile) pairs,
/// the hair behind the head. (The tile pass's block-by-block test would drop 43 %, but made
/// for every pair at binning it cost more than it saved.)
#[derive(Debug, Default)]
pub(crate) struct BodyLayer {
    /// The farthest body depth over the tile (`INFINITY` where a sample has no body).
    pub far: f32,
    ox: i32,
    oy: i32,
    body_seen: bool,
    zb: Vec<f32>,
    prim: Vec<u16>,
    block_close: Vec<f32>,
}

/// Every tile's farthest body depth ([`BodyLayer`]), for binning.
pub(crate) struct BodyCull<'a> {
    pub far: &'a [f32],
}

impl BodyCull<'_> {
    /// The depth that [`BodyCull::keeps`] compares for segment a–b: its nearest, or infinity
    /// for a segment with no length, which draws nothing anywhere.
    #[inline(always)]
    pub fn depth(a: &ScreenVertex, b: &ScreenVertex) -> f32 {
        if a.x != b.x || a.y != b.y {
            mn(a.z, b.z)
        } else {
            f32::INFINITY
        }
    }

    /// Whether binning keeps a segment of [`BodyCull::depth`] `depth` in tile `t`, a tile its
    /// box reaches: it lies in front of the body's farthest depth over the tile. Only the
    /// whole tile's test: the finer ones cost more here than binning the segment (the tile
    /// pass makes them anyway), and whatever this keeps, the tile pass's own first test
    /// still culls.
    #[inline(always)]
    pub fn keeps(&self, t: usize, depth: f32) -> bool {
        depth < self.far[t]
    }
}

multiversion! {
    /// [`TileBuf::cast_layer`], compiled for AVX2 too (eight samples at a time).
    pub(crate) fn cast_layer(
        buf: &mut TileBuf,
        n: usize,
        origin: (i32, i32),
        view: &View,
        prims: &[super::body::Prim],
        layer: &mut BodyLayer,
    ) {
        buf.cast_layer(n, origin, view, prims, layer);
    }
}

impl TileBuf {
    /// Casts the body of the `n`² samples at `(ox, oy)` into `layer` (this buffer is scratch).
    #[inline(always)]
    pub fn cast_layer(
        &mut self,
        n: usize,
        (ox, oy): (i32, i32),
        view: &View,
        prims: &[super::body::Prim],
        layer: &mut BodyLayer,
    ) {
        // Only the body part of the buffer: its samples are not used here.
        (self.n, self.ox, self.oy) = (n, ox, oy);
        self.set_blocks(n);
        self.reset_body();
        self.cast_body(view, prims);
        self.close_blocks();
        (layer.ox, layer.oy) = (ox, oy);
        layer.body_seen = self.body_seen;
        // The padding is NEG_INFINITY: it never raises the maximum.
        layer.far = self
            .block_close
            .iter()
            .fold(f32::NEG_INFINITY, |m, &c| mx(m, c));
        // Handed over, not copied: this buffer gets the layer's old arrays, which the next
        // cast clears.
        self.swap_body(layer);
    }

    /// Whether the body covers any sample of the tile.
    pub fn body_seen(&self) -> bool {
        self.body_seen
    }

    /// Exchanges the body arrays of this buffer and `layer`.
    fn swap_body(&mut self, layer: &mut BodyLayer) {
        std::mem::swap(&mut self.zb, &mut layer.zb);
        std::mem::swap(&mut self.prim, &mut layer.prim);
        std::mem::swap(&mut self.block_close, &mut layer.block_close);
    }

    /// Clears the buffer for the tile of `layer` (`n`² samples, cast this frame) and takes
    /// its body: the arrays are handed over, not copied, and the layer is left with this
    /// buffer's old ones (a layer is used once a frame, and cast again before the next).
    pub fn reset_with(&mut self, n: usize, layer: &mut BodyLayer) {
        self.reset_samples(n, layer.ox, layer.oy);
        self.hairless = false;
        self.body_seen = layer.body_seen;
        self.swap_body(layer);
    }

    /// [`TileBuf::reset_with`] for a tile no hair reaches this frame: the body is taken, but
    /// the samples are not cleared (nothing is drawn, and the resolve reads none of them).
    pub fn take_body(&mut self, n: usize, layer: &mut BodyLayer) {
        (self.n, self.ox, self.oy) = (n, layer.ox, layer.oy);
        self.set_blocks(n);
        self.hairless = true;
        self.body_seen = layer.body_seen;
        self.swap_body(layer);
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

/// One sample: linear r, g, b accumulated front to back (premultiplied), then the
/// transmittance; aligned so that a sample is one vector load and store.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub(crate) struct Px(pub [f32; 4]);

/// Where one column (x-major) or row (y-major) of samples lies in the culling blocks.
#[derive(Debug, Clone, Copy)]
struct Column {
    /// Block of the column's sample 0.
    base: usize,
    /// Block step per BLOCK samples along the column.
    step: usize,
}

impl Column {
    #[inline(always)]
    fn new(x_major: bool, i: usize, nb: usize) -> Column {
        if x_major {
            Column {
                base: i / BLOCK,
                step: nb,
            }
        } else {
            Column {
                base: (i / BLOCK) * nb,
                step: 1,
            }
        }
    }

    /// The block of sample `j` of the column.
    #[inline(always)]
    fn block(self, j: usize) -> usize {
        self.base + (j / BLOCK) * self.step
    }
}

#[cfg(test)]
mod tests {
    use super::super::camera::{Camera, View};
    use super::super::raster::ScreenVertex;
    use super::*;
    use crate::frame::BodyBuf;
    use crate::render::test_rng::lcg;

    /// One 32-pixel tile (64² samples, a 3° field of view) looking at a sphere of radius
    /// 0.1 m at the origin, which fills it, from 1 m away.
    fn sphere_tile() -> (View, BodyLayer) {
        let cam = Camera {
            eye: [0.0, 0.0, 1.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 3.0,
        };
        let view = View::new(&cam, 64, 64);
        let (mut buf, mut layer) = (TileBuf::default(), BodyLayer::default());
        buf.cast_layer(64, (0, 0), &view, &sphere_prims(&view), &mut layer);
        (view, layer)
    }

    /// The body of [`sphere_tile`] as seen by `view`.
    fn sphere_prims(view: &View) -> Vec<super::super::body::Prim> {
        let body = BodyBuf {
            sphere_centers: vec![[0.0, 0.0, 0.0]],
            sphere_radii: vec![0.1],
            scalp_center: [0.0, 0.0, 0.0],
            scalp_radii: [0.0; 3],
            scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        };
        let mut prims = Vec::new();
        super::super::body::prims(&body, view, 64.0, 64.0, &mut prims);
        prims
    }

    fn at(view: &View, p: [f32; 3]) -> ScreenVertex {
        let [x, y, z] = view.project(p);
        ScreenVertex { x, y, z }
    }

    #[test]
    fn the_body_layer_hides_a_segment_behind_the_body_and_no_other() {
        let (view, layer) = sphere_tile();
        assert!(layer.body_seen);
        // The sphere's nearest point is 0.9 m away, its silhouette at 1 m.
        let behind = (at(&view, [-0.01, 0.0, -0.2]), at(&view, [0.01, 0.0, -0.2]));
        let in_front = (at(&view, [-0.01, 0.0, 0.2]), at(&view, [0.01, 0.0, 0.2]));
        // The tile sees the sphere's front between 0.9 m (centre) and about 0.907 m (corners).
        // Just behind the centre but in front of the corners: the whole-tile test keeps it
        // (the tile pass tests it block by block).
        let grazing = (
            at(&view, [-0.01, 0.0, 0.097]),
            at(&view, [0.01, 0.0, 0.097]),
        );
        let cull = BodyCull { far: &[layer.far] };
        let keeps = |(a, b): (ScreenVertex, ScreenVertex)| cull.keeps(0, BodyCull::depth(&a, &b));
        assert!(!keeps(behind));
        assert!(keeps(in_front));
        assert!(keeps(grazing));
        // A segment with no length draws nothing anywhere.
        assert!(!keeps((in_front.0, in_front.0)));
    }

    #[test]
    fn a_tile_without_hair_resolves_as_if_cleared_without_reading_its_samples() {
        let (view, _) = sphere_tile();
        let prims = sphere_prims(&view);
        let maps = super::super::shadow::ShadowMaps::new(16);
        let resolve = super::super::resolve::Resolve {
            view: &view,
            prims: &prims,
            maps: &maps,
            map_size: 16.0,
            background: [0.3, 0.5, 0.7],
            body: [0.8, 0.6, 0.5],
            ambient: 0.2,
            kappa: 0.5,
            light: [0.0, 0.6, 0.8],
        };
        // The sphere's tile, and one with no body (cast without primitives).
        for with_body in [true, false] {
            let cast = || {
                let (mut scratch, mut layer) = (TileBuf::default(), BodyLayer::default());
                let p: &[super::super::body::Prim] = if with_body { &prims } else { &[] };
                scratch.cast_layer(64, (0, 0), &view, p, &mut layer);
                layer
            };
            let mut cleared = TileBuf::default();
            cleared.reset_with(64, &mut cast());
            let mut taken = TileBuf::default();
            // Samples left from another tile, which the resolve must not read.
            taken.reset_samples(64, 64, 64);
            taken.px.fill(Px([9.0, 9.0, 9.0, 0.0]));
            taken.take_body(64, &mut cast());
            assert_eq!(taken.body_seen(), with_body);
            let (mut a, mut b) = (vec![0.0f32; 32 * 32 * 3], vec![1.0f32; 32 * 32 * 3]);
            resolve.tile(&cleared, 2, &mut a);
            resolve.tile(&taken, 2, &mut b);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "with body: {with_body}");
            if !with_body {
                assert!(a
                    .chunks(3)
                    .all(|p| (p[0] - 0.3).abs() < 1e-6 && p[2] > 0.69));
            } else {
                assert!(a.chunks(3).any(|p| (p[0] - 0.3).abs() > 0.01));
            }
        }
    }

    #[test]
    fn the_buckets_draw_in_the_stable_order_of_the_whole_key_and_culling_changes_nothing() {
        use super::super::point_colors::pack;
        use super::super::raster::{bucket_tile, DepthKey};
        let mut rng = 11u64;
        // Many short overlapping strokes in one corner of the tile (so that samples turn
        // opaque and later strokes are culled), half with depths from a small set (so that
        // many keys are equal and the strand order decides), half anywhere (so that the low
        // byte of the key orders segments within a bucket).
        let segs: Vec<SegRec> = (0..1500)
            .map(|_| {
                let (x, y) = (8.0 + 24.0 * lcg(&mut rng), 8.0 + 24.0 * lcg(&mut rng));
                let (dx, dy) = (6.0 * lcg(&mut rng) - 3.0, 6.0 * lcg(&mut rng) - 3.0);
                let z = if lcg(&mut rng) < 0.5 {
                    1.0 + (lcg(&mut rng) * 40.0).floor() * 0.01
                } else {
                    1.0 + lcg(&mut rng) * 0.4
                };
                let dz = if lcg(&mut rng) < 0.5 { 0.0 } else { 0.005 };
                let mut c = || [lcg(&mut rng), lcg(&mut rng), lcg(&mut rng)];
                SegRec {
                    a: ScreenVertex { x, y, z: z - dz },
                    b: ScreenVertex {
                        x: x + dx,
                        y: y + dy,
                        z: z + dz,
                    },
                    ca: pack(c()),
                    cb: pack(c()),
                }
            })
            .collect();
        let mid = |r: &SegRec| 0.5 * (r.a.z + r.b.z);
        let (lo, hi) = segs
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), r| {
                (l.min(mid(r)), h.max(mid(r)))
            });
        let key = DepthKey::new(lo, hi);
        let (half, alpha) = (0.9, 0.6);
        let fresh = || {
            let mut buf = TileBuf::default();
            buf.reset_samples(64, 0, 0);
            buf.reset_body();
            buf
        };
        // As the tile pass draws them: two halves, bucketed, culled, finished sorting.
        let mut bucketed = fresh();
        let (first, second) = segs.split_at(700);
        let (mut out, mut lows, mut keys, mut buckets) = (vec![], vec![], vec![], [0; 257]);
        let n = bucket_tile(
            first,
            second,
            key,
            &mut out,
            &mut lows,
            &mut keys,
            &mut buckets,
        );
        assert_eq!(n, segs.len());
        draw_buckets(
            &mut bucketed,
            &out[..n],
            &lows[..n],
            &buckets,
            &mut vec![],
            half,
            alpha,
        );
        // The reference: a stable sort of the whole key, every segment drawn, none culled.
        let draw_all = |order: &[usize]| {
            let mut buf = fresh();
            for &i in order {
                buf.segment(&segs[i], half, alpha);
            }
            buf
        };
        let mut order: Vec<usize> = (0..segs.len()).collect();
        order.sort_by_key(|&i| key.of(&segs[i]));
        let reference = draw_all(&order);
        let bits = |b: &TileBuf| {
            b.px.iter()
                .flat_map(|p| p.0.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&bucketed), bits(&reference));
        assert_eq!(bucketed.alive, reference.alive);
        // The scene tests what it should: samples turned opaque (so culling had work), and
        // the order shows in the bits.
        assert!(reference.alive < 64 * 64 - 200, "{}", reference.alive);
        order.reverse();
        assert_ne!(bits(&draw_all(&order)), bits(&reference));
    }

    #[test]
    fn a_box_is_hidden_exactly_when_every_block_it_touches_is_closed_at_its_depth() {
        // Against the plain definition, at 2×2, 3×3 and 4×4 supersampling (one and two
        // 16-block chunks per row), for boxes of one to many block rows and columns (narrow
        // and tall, wide and short, and large).
        let mut rng = 7u64;
        for n in [64usize, 96, 128] {
            let mut buf = TileBuf::default();
            buf.reset_samples(n, 0, 0);
            buf.reset_body();
            let nb = buf.nb;
            for by in 0..nb {
                for bx in 0..nb {
                    let b = buf.block_at(bx, by);
                    let r = lcg(&mut rng);
                    buf.block_close[b] = if r < 0.2 {
                        f32::NEG_INFINITY
                    } else if r < 0.3 {
                        f32::INFINITY
                    } else {
                        r
                    };
                }
            }
            let (mut shown, mut hidden) = (0, 0);
            for _ in 0..4000 {
                let x0 = lcg(&mut rng) * (n as f32 + 8.0) - 4.0;
                let y0 = lcg(&mut rng) * (n as f32 + 8.0) - 4.0;
                let x1 = x0 + lcg(&mut rng) * if lcg(&mut rng) < 0.2 { 40.0 } else { 12.0 };
                let y1 = y0 + lcg(&mut rng) * if lcg(&mut rng) < 0.2 { 40.0 } else { 12.0 };
                let z = lcg(&mut rng) * 1.2 - 0.1;
                let clamp = |v: f32| (floor_pos(v) / BLOCK).min(nb - 1);
                let mut far = f32::NEG_INFINITY;
                for by in clamp(y0)..=clamp(y1) {
                    for bx in clamp(x0)..=clamp(x1) {
                        far = far.max(buf.block_close[buf.block_at(bx, by)]);
                    }
                }
                let want = z >= far;
                assert_eq!(
                    buf.hidden(x0, x1, y0, y1, z),
                    want,
                    "n {n} box {x0} {x1} {y0} {y1} z {z}"
                );
                if want {
                    hidden += 1;
                } else {
                    shown += 1;
                }
            }
            // Both answers were exercised.
            assert!(shown > 100 && hidden > 100, "{shown} {hidden}");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_sse_window_blend_gives_the_portable_blend_bit_for_bit() {
        let n = 64;
        let mut rng = 11u64;
        let mut a = TileBuf::default();
        a.reset_samples(n, 0, 0);
        a.reset_body();
        for (p, zb) in a.px.iter_mut().zip(a.zb.iter_mut()) {
            let tr = if lcg(&mut rng) < 0.3 {
                0.0025
            } else {
                lcg(&mut rng)
            };
            *p = Px([
                lcg(&mut rng) * 0.3,
                lcg(&mut rng) * 0.2,
                lcg(&mut rng) * 0.1,
                tr,
            ]);
            *zb = if lcg(&mut rng) < 0.3 {
                lcg(&mut rng) * 2.0
            } else {
                f32::INFINITY
            };
        }
        let mut b = TileBuf::default();
        b.reset_samples(n, 0, 0);
        b.px.clone_from(&a.px);
        b.zb.clone_from(&a.zb);
        let mut turned = 0;
        for _ in 0..3000 {
            let x_major = lcg(&mut rng) < 0.5;
            let col_i = (lcg(&mut rng) * n as f32) as usize;
            let y_lo = lcg(&mut rng) * (n as f32 - 1.0);
            let y_hi = y_lo + lcg(&mut rng) * 2.9;
            let js = floor_pos(y_lo).min(n - WINDOW);
            let (stride_maj, stride_min) = if x_major { (1, n) } else { (n, 1) };
            let at = col_i * stride_maj + js * stride_min;
            let col = Column::new(x_major, col_i, a.stride);
            let z = lcg(&mut rng) * 2.0;
            let w0 = lcg(&mut rng) * 0.55;
            let rgb = Px([lcg(&mut rng), lcg(&mut rng), lcg(&mut rng), -1.0]);
            let alive = a.alive;
            a.blend_window(at, stride_min, js, col, z, w0, (y_lo, y_hi), &rgb);
            b.blend_window_portable(at, stride_min, js, col, z, w0, (y_lo, y_hi), &rgb);
            turned += alive - a.alive;
        }
        let bits =
            |t: &TileBuf| -> Vec<u32> { t.px.iter().flat_map(|p| p.0.map(f32::to_bits)).collect() };
        assert!(bits(&a) == bits(&b), "the two blends differ");
        assert_eq!((a.alive, &a.block_alive), (b.alive, &b.block_alive));
        // Samples did turn opaque along the way, and were counted alike.
        assert!(turned > 10, "{turned}");
    }

    #[test]
    fn a_tile_started_from_its_body_layer_has_the_body_cast_in_it() {
        let (view, mut layer) = sphere_tile();
        let mut direct = TileBuf::default();
        direct.reset_samples(64, 0, 0);
        direct.reset_body();
        direct.cast_body(&view, &sphere_prims(&view));
        direct.close_blocks();
        let mut from_layer = TileBuf::default();
        // A previous tile's leftovers must not survive.
        from_layer.reset_samples(64, 64, 64);
        from_layer.reset_body();
        from_layer.zb.fill(-1.0);
        from_layer.reset_with(64, &mut layer);
        assert_eq!(from_layer.zb, direct.zb);
        assert_eq!(from_layer.block_close, direct.block_close);
        assert_eq!((from_layer.ox, from_layer.oy), (0, 0));
        assert!(from_layer.px.iter().all(|p| p.0 == [0.0, 0.0, 0.0, 1.0]));
    }
}
