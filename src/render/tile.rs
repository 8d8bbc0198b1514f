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
use super::raster::{ceil_pos, floor_pos, mn, mx, SegRec, OPAQUE};

/// Side of a culling block, samples (a power of two).
const BLOCK: usize = 4;
/// Blocks per side of a superblock, the coarse level of the culling test.
const SUPER: usize = 4;
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
    /// Blocks of BLOCK² samples per side.
    nb: usize,
    /// Per block, samples not yet opaque.
    block_alive: Vec<u32>,
    /// Per block, the view depth at and beyond which nothing shows: the farthest body depth
    /// (`INFINITY` if a sample has no body), `NEG_INFINITY` once every sample is opaque.
    block_close: Vec<f32>,
    /// Superblocks (SUPER² blocks) per side.
    ns: usize,
    /// Per superblock, the largest `block_close` of its blocks.
    super_close: Vec<f32>,
    /// Whether the body covers any sample of the tile.
    body_seen: bool,
}

impl TileBuf {
    /// Clears the buffer for a tile of `n`² samples at `(ox, oy)`.
    #[inline(always)]
    pub fn reset(&mut self, n: usize, ox: i32, oy: i32) {
        self.n = n;
        self.ox = ox;
        self.oy = oy;
        let m = n * n;
        self.px.clear();
        self.px.resize(m, Px([0.0, 0.0, 0.0, 1.0]));
        self.zb.clear();
        self.zb.resize(m, f32::INFINITY);
        // `prim` is read only where `zb` is finite, and written wherever it is set: no clear.
        self.prim.resize(m, 0);
        self.alive = m;
        self.nb = n.div_ceil(BLOCK);
        self.block_alive.clear();
        for by in 0..self.nb {
            let h = (n - by * BLOCK).min(BLOCK);
            for bx in 0..self.nb {
                let w = (n - bx * BLOCK).min(BLOCK);
                self.block_alive.push((w * h) as u32);
            }
        }
        self.block_close.clear();
        self.block_close.resize(self.nb * self.nb, f32::INFINITY);
        self.ns = self.nb.div_ceil(SUPER);
        self.super_close.clear();
        self.super_close.resize(self.ns * self.ns, f32::INFINITY);
        self.body_seen = false;
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
        for j in 0..n {
            for i in 0..n {
                let b = (j / BLOCK) * self.nb + i / BLOCK;
                self.block_close[b] = self.block_close[b].max(self.zb[j * n + i]);
            }
        }
        for b in 0..self.nb * self.nb {
            self.close_super(b);
        }
    }

    /// Recomputes the superblock of block `b` from its blocks.
    fn close_super(&mut self, b: usize) {
        let (sx, sy) = ((b % self.nb) / SUPER, (b / self.nb) / SUPER);
        let mut far = f32::NEG_INFINITY;
        for by in sy * SUPER..((sy + 1) * SUPER).min(self.nb) {
            let row = by * self.nb;
            for bx in sx * SUPER..((sx + 1) * SUPER).min(self.nb) {
                far = mx(far, self.block_close[row + bx]);
            }
        }
        self.super_close[sy * self.ns + sx] = far;
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
        // Superblocks first: in dense hair most segments end here, after one or two tests.
        // (Exclusive ranges and plain indexing: `..=` loops and slice folds cost several
        // times more here, on a test made for every binned segment.)
        let mut far = f32::NEG_INFINITY;
        for sy in by0 / SUPER..by1 / SUPER + 1 {
            let row = sy * self.ns;
            for sx in bx0 / SUPER..bx1 / SUPER + 1 {
                far = mx(far, self.super_close[row + sx]);
            }
        }
        if z >= far {
            return true;
        }
        let mut far = f32::NEG_INFINITY;
        for by in by0..by1 + 1 {
            let row = by * self.nb;
            for bx in bx0..bx1 + 1 {
                far = mx(far, self.block_close[row + bx]);
            }
        }
        z >= far
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
            let [rx0, ry0, rx1, ry1] = p.rect;
            if rx1 < fx0 || rx0 > fx1 || ry1 < fy0 || ry0 > fy1 {
                continue;
            }
            let j0 = floor_pos(ry0 - fy0).min(n);
            let j1 = ceil_pos(ry1 - fy0).min(n);
            let i0 = floor_pos(rx0 - fx0).min(n);
            let i1 = ceil_pos(rx1 - fx0).min(n);
            let r = p.rays(view.eye, d00, dx, dy);
            for j in j0..j1 {
                for i in i0..i1 {
                    if let Some(t) = r.hit(i as f32, j as f32) {
                        let at = j * n + i;
                        if t < self.zb[at] {
                            self.zb[at] = t;
                            self.prim[at] = k as u16;
                            self.body_seen = true;
                        }
                    }
                }
            }
        }
    }

    /// Whether samples j0..=j1 of column (or row) i are all in opaque or body-hidden blocks
    /// at depth `z`.
    #[inline(always)]
    fn column_hidden(&self, at: Column, j0: usize, j1: usize, z: f32) -> bool {
        let mut far = f32::NEG_INFINITY;
        for jb in j0 / BLOCK..j1 / BLOCK + 1 {
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

    /// Blends segment `s` (global sample coordinates) behind what the tile holds: a line of
    /// half-width `half` samples and opacity `alpha` where it covers a whole sample, its
    /// colour interpolated between its two points' colours.
    #[inline(always)]
    pub fn segment(&mut self, s: &SegRec, half: f32, alpha: f32) {
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
        if d < 1e-6 {
            return;
        }
        let r = half * 1.5 + 1.0;
        let (zmin, lo0, hi0, lo1, hi1) = (
            mn(a.z, b.z),
            mn(ax, bx) - r,
            mx(ax, bx) + r,
            mn(ay, by) - r,
            mx(ay, by) + r,
        );
        if hi0 < 0.0 || hi1 < 0.0 || self.hidden(lo0, hi0, lo1, hi1, zmin) {
            return;
        }
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
        let (stride_maj, stride_min) = if x_major { (1, n) } else { (n, 1) };
        let i0 = floor_pos(maj0);
        let i1 = ceil_pos(maj1).min(n);
        let dz = z1 - z0;
        let dc = [c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]];
        let mut fi = i0 as f32;
        // Columns come in groups of one culling block's width. A group whose whole extent
        // (its minor range, and the segment's nearest depth over it) lies in opaque or
        // body-hidden blocks is skipped in one test: every column of it would fail its own.
        let mut group_end = i0;
        let mut i = i0;
        while i < i1 {
            if i >= group_end {
                group_end = ((i / BLOCK + 1) * BLOCK).min(i1);
                let ta = (mx(maj0, fi) - maj0) * inv;
                let tb = (mn(maj1, group_end as f32) - maj0) * inv;
                let (ca, cb) = (min0 + ta * (min1 - min0), min0 + tb * (min1 - min0));
                let zg = mn(z0 + ta * dz, z0 + tb * dz);
                let g0 = floor_pos(mn(ca, cb) - h);
                let g1 = ceil_pos(mx(ca, cb) + h).min(n);
                if g1 <= g0 || self.column_hidden(Column::new(x_major, i, self.nb), g0, g1 - 1, zg)
                {
                    fi += (group_end - i) as f32;
                    i = group_end;
                    continue;
                }
            }
            let lo = mx(maj0, fi);
            let hi = mn(maj1, fi + 1.0);
            fi += 1.0;
            let col_i = i;
            i += 1;
            let cov_maj = hi - lo;
            if cov_maj <= 0.0 {
                continue;
            }
            let t = (0.5 * (lo + hi) - maj0) * inv;
            let c = min0 + t * (min1 - min0);
            let z = z0 + t * dz;
            let (y_lo, y_hi) = (c - h, c + h);
            let j0 = floor_pos(y_lo);
            let col = Column::new(x_major, col_i, self.nb);
            let rgb = Px([
                c0[0] + t * dc[0],
                c0[1] + t * dc[1],
                c0[2] + t * dc[2],
                -1.0,
            ]);
            let w0 = alpha * cov_maj;
            if thin {
                // A fixed window (moved inside the tile at its far edge), all four samples
                // at once. No culling test per column: its group passed one, and a sample
                // that is opaque or behind the body refuses the blend anyway; the test would
                // cost as much as the blend.
                let js = j0.min(n - WINDOW);
                self.blend_window(
                    col_i * stride_maj + js * stride_min,
                    stride_min,
                    js,
                    col,
                    z,
                    w0,
                    (y_lo, y_hi),
                    &rgb,
                );
                continue;
            }
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
    /// the same arithmetic, lane by lane without branches (the rare sample that turns opaque
    /// is counted afterwards).
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
        (y_lo, y_hi): (f32, f32),
        rgb: &Px,
    ) {
        let idx: [usize; WINDOW] = std::array::from_fn(|k| at + k * stride);
        let v: [[f32; 4]; WINDOW] = idx.map(|i| self.px[i].0);
        let zb: [f32; WINDOW] = idx.map(|i| self.zb[i]);
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
            self.px[idx[k]].0 = new[k];
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
            self.close_super(b);
        }
    }
}

multiversion! {
    /// Blends `segs` (sorted front to back) into `buf`, stopping once every sample is opaque.
    pub(crate) fn draw_segments(buf: &mut TileBuf, segs: &[SegRec], half: f32, alpha: f32) {
        for s in segs {
            buf.segment(s, half, alpha);
            if buf.alive == 0 {
                break;
            }
        }
    }
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
