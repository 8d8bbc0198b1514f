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

//!
//! The files: this one holds the tile's buffer, its resets and the body cast into it, and the
//! bucket loop ([`draw_buckets`]); `hidden.rs` the culling tests against the blocks, `line.rs`
//! the line rasteriser. The processor-specific operations (the window blend, the block depth
//! compares) are in [`crate::simd`], each with its portable twin; the hot functions take the
//! [`Level`] that chooses them.

mod hidden;
mod line;
#[cfg(test)]
mod tests;

use super::camera::View;
use super::cull::BodyLayer;
use super::num::{ceil_pos, floor_pos, mx};
use super::raster::SegRec;
use crate::simd::blend::Blend;
use crate::simd::cull::{Cull, CHUNK};
use crate::simd::dispatch::multiversion;
#[cfg(doc)]
use crate::simd::Level;

pub(crate) use crate::simd::blend::Px;

/// Transmittance below which a sample counts as opaque (less than a 1/512 change in 8 bits).
pub(crate) const OPAQUE: f32 = 1.0 / 512.0;

/// Side of a culling block, samples (a power of two).
const BLOCK: usize = 4;
/// Lanes of one comparison of a row of culling depths: rows of blocks are padded to a
/// multiple of this, so that a row is tested in whole vectors and yields a bit mask.
const LANES: usize = CHUNK;
/// Block rows of a narrow box that [`TileBuf::hidden`] tests without a loop.
const NARROW_ROWS: usize = 8;
/// Entries past the last row of the per-block arrays, so that 4 blocks can be read from any
/// block of a row.
const TAIL: usize = 3;
/// Samples of the fixed per-column window of thin lines.
const WINDOW: usize = crate::simd::blend::WINDOW;

/// The operations of the tile pass that have an intrinsics version and a portable twin: the
/// instruction set a [`draw_buckets`] build is instantiated with.
pub(crate) trait Kernels: Cull + Blend {}

impl<T: Cull + Blend> Kernels for T {}

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
    /// Which body primitive is there (a sphere or the scalp, or a mesh triangle from
    /// [`super::mesh::Meshes::base`] on).
    pub prim: Vec<u32>,
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
    /// Lines are point-sampled (a sample takes a line whose centre line passes within its
    /// half-width of the sample's centre, fully, else not at all), as OpenGL draws lines
    /// without antialiasing: the "aliasing" image of Zhang and Wünsche 2007, Fig. 14. Only
    /// for that comparison ([`super::Sampling`]); the default is box-filtered coverage.
    pub point_sampled: bool,
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
            let k_prim = k as u32;
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
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn draw_buckets<I: Kernels>(
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
                kept += !buf.culls::<I>(seg, half) as usize;
            }
            let order = &mut order[..kept];
            order.sort_unstable();
            for &o in order.iter() {
                buf.segment::<I>(&segs[s + (o as u32) as usize], half, alpha);
                if buf.alive == 0 {
                    return;
                }
            }
        }
    }
}

/// What a tile's body cast draws: the ray-cast primitives (spheres, capsules, the scalp), and
/// the mesh triangles that reach the tile.
#[derive(Clone, Copy)]
pub(crate) struct BodyParts<'a> {
    pub prims: &'a [super::body::Prim],
    pub mesh: &'a super::mesh::Meshes,
    pub tris: &'a [u32],
}

multiversion! {
    /// [`TileBuf::cast_layer`], compiled for AVX2 too (eight samples at a time).
    pub(crate) fn cast_layer(
        buf: &mut TileBuf,
        n: usize,
        origin: (i32, i32),
        view: &View,
        parts: BodyParts,
        layer: &mut BodyLayer,
    ) {
        buf.cast_layer(n, origin, view, parts, layer);
    }
}

impl TileBuf {
    /// Casts the body of the `n`² samples at `(ox, oy)` into `layer` (this buffer is scratch):
    /// the spheres and scalp `prims`, then the mesh triangles `tris` of `mesh` that reach the
    /// tile.
    #[inline(always)]
    pub fn cast_layer(
        &mut self,
        n: usize,
        (ox, oy): (i32, i32),
        view: &View,
        BodyParts { prims, mesh, tris }: BodyParts,
        layer: &mut BodyLayer,
    ) {
        // Only the body part of the buffer: its samples are not used here.
        (self.n, self.ox, self.oy) = (n, ox, oy);
        self.set_blocks(n);
        self.reset_body();
        self.cast_body(view, prims);
        if !tris.is_empty() {
            self.body_seen |=
                super::mesh::cast(mesh, tris, (n, ox, oy), &mut self.zb, &mut self.prim);
        }
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
