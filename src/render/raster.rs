//! Strand segments on screen: depth sorting, binning into tiles, and the per-tile rasteriser
//! that blends them front to back.
//!
//! Every segment is drawn as a line of the strand's width, box-filtered over the sample grid:
//! along the major axis each sample column gets the length of the segment inside it, across it
//! each sample the overlap of its cell with the line's cross-section. A strand's coverage of
//! the image is then its length × its width, however it lies on the grid (no crawling as it
//! moves by a fraction of a sample). Segments are sorted by the view depth of their midpoint
//! once per frame (the visibility ordering of line segments the AWT paper uses for
//! antialiasing, Bertails et al. 2003, §5.1) and composited front to back with the "under"
//! operator; a sample whose transmittance drops below [`OPAQUE`] takes nothing more.

use super::camera::View;

/// Pixels per tile side (plus a one-pixel apron on each side for the postfilter).
pub(crate) const TILE: usize = 32;
/// Apron, pixels.
pub(crate) const APRON: usize = 1;
/// Transmittance below which a sample counts as opaque (less than a 1/512 change in 8 bits).
pub(crate) const OPAQUE: f32 = 1.0 / 512.0;

/// A strand point on screen: sample coordinates, view depth, and its shaded linear colour.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ScreenVertex {
    pub x: f32,
    pub y: f32,
    pub z: f32,
    pub c: [f32; 3],
}

/// The frame's visible segments, sorted front to back and binned into tiles.
#[derive(Debug, Default)]
pub(crate) struct Bins {
    /// First vertex of each visible segment (the second is the next one).
    segs: Vec<u32>,
    keys: Vec<u32>,
    /// Radix sort scratch.
    tmp_keys: Vec<u32>,
    tmp_segs: Vec<u32>,
    counts: Vec<u32>,
    /// Per tile, `start[t]..start[t + 1]` in `items`.
    pub start: Vec<u32>,
    /// Segment first-vertex indices, per tile, front to back.
    pub items: Vec<u32>,
}

/// Tile grid of an image.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    pub tiles_x: usize,
    pub tiles_y: usize,
    pub ss: usize,
}

impl Grid {
    pub fn new(width: usize, height: usize, ss: usize) -> Grid {
        Grid {
            tiles_x: width.div_ceil(TILE),
            tiles_y: height.div_ceil(TILE),
            ss,
        }
    }
    pub fn tiles(&self) -> usize {
        self.tiles_x * self.tiles_y
    }
    /// Samples per side of a tile buffer, apron included.
    pub fn tile_samples(&self) -> usize {
        (TILE + 2 * APRON) * self.ss
    }
    /// Global sample coordinates of tile `t`'s buffer origin.
    pub fn origin(&self, t: usize) -> (i32, i32) {
        let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
        (
            ((tx * TILE) as i32 - APRON as i32) * self.ss as i32,
            ((ty * TILE) as i32 - APRON as i32) * self.ss as i32,
        )
    }
    /// Inclusive tile range [lo, hi] whose buffers overlap samples [a, b] along one axis.
    fn range(&self, a: f32, b: f32, n: usize) -> Option<(usize, usize)> {
        let span = (TILE * self.ss) as f32;
        let apron = (APRON * self.ss) as f32;
        let lo = ((a - apron) / span).floor();
        let hi = ((b + apron) / span).floor();
        if hi < 0.0 || lo > (n - 1) as f32 {
            return None;
        }
        Some((lo.max(0.0) as usize, (hi as usize).min(n - 1)))
    }
}

impl Bins {
    /// Sorts the visible segments of `verts` (strand `s` spans `offsets[s]..offsets[s+1]`)
    /// front to back and bins them into the tiles of `grid`. `reach` is how far (samples) a
    /// line reaches beyond its centre line.
    pub fn build(&mut self, verts: &[ScreenVertex], offsets: &[u32], grid: &Grid, reach: f32) {
        self.segs.clear();
        let (mut zlo, mut zhi) = (f32::INFINITY, f32::NEG_INFINITY);
        for s in 0..offsets.len().saturating_sub(1) {
            let (a, b) = (offsets[s] as usize, offsets[s + 1] as usize);
            for i in a..b.saturating_sub(1) {
                let (p, q) = (&verts[i], &verts[i + 1]);
                if p.z <= super::camera::NEAR || q.z <= super::camera::NEAR {
                    continue;
                }
                let x0 = p.x.min(q.x) - reach;
                let x1 = p.x.max(q.x) + reach;
                let y0 = p.y.min(q.y) - reach;
                let y1 = p.y.max(q.y) + reach;
                if grid.range(x0, x1, grid.tiles_x).is_none()
                    || grid.range(y0, y1, grid.tiles_y).is_none()
                {
                    continue;
                }
                let z = 0.5 * (p.z + q.z);
                zlo = zlo.min(z);
                zhi = zhi.max(z);
                self.segs.push(i as u32);
            }
        }
        // 24-bit depth keys, sorted by two stable 12-bit counting passes: equal keys keep
        // strand order, so the order is the same on every run.
        let scale = if zhi > zlo {
            ((1u32 << 24) - 1) as f32 / (zhi - zlo)
        } else {
            0.0
        };
        self.keys.clear();
        self.keys.extend(self.segs.iter().map(|&i| {
            let v = &verts[i as usize];
            let z = 0.5 * (v.z + verts[i as usize + 1].z);
            (((z - zlo) * scale) as u32).min((1 << 24) - 1)
        }));
        self.radix_pass(0);
        self.radix_pass(12);
        self.bin(verts, grid, reach);
    }

    fn radix_pass(&mut self, shift: u32) {
        let n = self.keys.len();
        self.counts.clear();
        self.counts.resize(4097, 0);
        for &k in &self.keys {
            self.counts[((k >> shift) & 0xfff) as usize + 1] += 1;
        }
        for d in 1..4097 {
            self.counts[d] += self.counts[d - 1];
        }
        self.tmp_keys.resize(n, 0);
        self.tmp_segs.resize(n, 0);
        for j in 0..n {
            let k = self.keys[j];
            let d = ((k >> shift) & 0xfff) as usize;
            let at = self.counts[d] as usize;
            self.counts[d] += 1;
            self.tmp_keys[at] = k;
            self.tmp_segs[at] = self.segs[j];
        }
        std::mem::swap(&mut self.keys, &mut self.tmp_keys);
        std::mem::swap(&mut self.segs, &mut self.tmp_segs);
    }

    fn tile_rect(v: &[ScreenVertex], i: usize, g: &Grid, reach: f32) -> [usize; 4] {
        let (p, q) = (&v[i], &v[i + 1]);
        let (x0, x1) = g
            .range(p.x.min(q.x) - reach, p.x.max(q.x) + reach, g.tiles_x)
            .unwrap_or((1, 0));
        let (y0, y1) = g
            .range(p.y.min(q.y) - reach, p.y.max(q.y) + reach, g.tiles_y)
            .unwrap_or((1, 0));
        [x0, x1, y0, y1]
    }

    fn bin(&mut self, verts: &[ScreenVertex], g: &Grid, reach: f32) {
        let nt = g.tiles();
        self.start.clear();
        self.start.resize(nt + 1, 0);
        for &i in &self.segs {
            let [x0, x1, y0, y1] = Self::tile_rect(verts, i as usize, g, reach);
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    self.start[ty * g.tiles_x + tx + 1] += 1;
                }
            }
        }
        for t in 1..=nt {
            self.start[t] += self.start[t - 1];
        }
        self.items.resize(self.start[nt] as usize, 0);
        // `counts` as the fill cursor of each tile.
        self.counts.clear();
        self.counts.extend_from_slice(&self.start[..nt]);
        for &i in &self.segs {
            let [x0, x1, y0, y1] = Self::tile_rect(verts, i as usize, g, reach);
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    let c = &mut self.counts[ty * g.tiles_x + tx];
                    self.items[*c as usize] = i;
                    *c += 1;
                }
            }
        }
    }
}

/// One tile's samples, structure of arrays; reused from tile to tile.
#[derive(Debug, Default)]
pub(crate) struct TileBuf {
    /// Side, samples.
    pub n: usize,
    /// Global sample coordinates of sample (0, 0).
    pub ox: i32,
    pub oy: i32,
    /// Light still passing through the hair in front, per sample.
    pub trans: Vec<f32>,
    /// Hair colour accumulated front to back (premultiplied), per sample.
    pub r: Vec<f32>,
    pub g: Vec<f32>,
    pub b: Vec<f32>,
    /// View depth of the body, `INFINITY` where there is none.
    pub zb: Vec<f32>,
    /// Which body primitive is there.
    pub prim: Vec<u16>,
    /// Samples not yet opaque.
    pub alive: usize,
}

impl TileBuf {
    /// Clears the buffer for a tile of `n`² samples at `(ox, oy)`.
    pub fn reset(&mut self, n: usize, ox: i32, oy: i32) {
        self.n = n;
        self.ox = ox;
        self.oy = oy;
        let m = n * n;
        for v in [&mut self.r, &mut self.g, &mut self.b] {
            v.clear();
            v.resize(m, 0.0);
        }
        self.trans.clear();
        self.trans.resize(m, 1.0);
        self.zb.clear();
        self.zb.resize(m, f32::INFINITY);
        self.prim.clear();
        self.prim.resize(m, 0);
        self.alive = m;
    }

    /// Ray casts the body primitives `prims` into the depth buffer.
    pub fn cast_body(&mut self, view: &View, prims: &[super::body::Prim]) {
        let n = self.n;
        let (fx0, fy0) = (self.ox as f32, self.oy as f32);
        let (fx1, fy1) = (fx0 + n as f32, fy0 + n as f32);
        for (k, p) in prims.iter().enumerate() {
            let [rx0, ry0, rx1, ry1] = p.rect;
            if rx1 < fx0 || rx0 > fx1 || ry1 < fy0 || ry0 > fy1 {
                continue;
            }
            let j0 = (ry0 - fy0).floor().max(0.0) as usize;
            let j1 = ((ry1 - fy0).ceil().max(0.0) as usize).min(n);
            let i0 = (rx0 - fx0).floor().max(0.0) as usize;
            let i1 = ((rx1 - fx0).ceil().max(0.0) as usize).min(n);
            for j in j0..j1 {
                let y = fy0 + j as f32 + 0.5;
                for i in i0..i1 {
                    let d = view.ray(fx0 + i as f32 + 0.5, y);
                    if let Some(t) = p.hit(view.eye, d) {
                        let at = j * n + i;
                        if t < self.zb[at] {
                            self.zb[at] = t;
                            self.prim[at] = k as u16;
                        }
                    }
                }
            }
        }
    }

    /// Blends segment a–b (global sample coordinates) behind what the tile holds: a line of
    /// half-width `half` samples and opacity `alpha` where it covers a whole sample.
    #[inline]
    pub fn segment(&mut self, a: &ScreenVertex, b: &ScreenVertex, half: f32, alpha: f32) {
        let (ox, oy) = (self.ox as f32, self.oy as f32);
        let (ax, ay, bx, by) = (a.x - ox, a.y - oy, b.x - ox, b.y - oy);
        let n = self.n;
        // Major axis: the one along which the segment is longer; one sample step per column.
        let x_major = (bx - ax).abs() >= (by - ay).abs();
        let (mut p, mut q) = if x_major {
            ((ax, ay, a), (bx, by, b))
        } else {
            ((ay, ax, a), (by, bx, b))
        };
        if q.0 < p.0 {
            std::mem::swap(&mut p, &mut q);
        }
        let (maj0, min0, va) = p;
        let (maj1, min1, vb) = q;
        let d = maj1 - maj0;
        if d < 1e-6 {
            return;
        }
        let inv = 1.0 / d;
        let slope = (min1 - min0) * inv;
        // The line's cross-section along the minor axis widens as 1/cos of its angle.
        let h = half * (1.0 + slope * slope).sqrt();
        let (stride_maj, stride_min) = if x_major { (1, n) } else { (n, 1) };
        let i0 = maj0.floor().max(0.0) as usize;
        let i1 = (maj1.ceil().max(0.0) as usize).min(n);
        let dz = vb.z - va.z;
        let dc = [vb.c[0] - va.c[0], vb.c[1] - va.c[1], vb.c[2] - va.c[2]];
        for i in i0..i1 {
            let lo = maj0.max(i as f32);
            let hi = maj1.min(i as f32 + 1.0);
            let cov_maj = hi - lo;
            if cov_maj <= 0.0 {
                continue;
            }
            let t = (0.5 * (lo + hi) - maj0) * inv;
            let c = min0 + t * (min1 - min0);
            let z = va.z + t * dz;
            let col = [
                va.c[0] + t * dc[0],
                va.c[1] + t * dc[1],
                va.c[2] + t * dc[2],
            ];
            let (y_lo, y_hi) = (c - h, c + h);
            let j0 = y_lo.floor().max(0.0) as usize;
            let j1 = (y_hi.ceil().max(0.0) as usize).min(n);
            let a_maj = alpha * cov_maj;
            for j in j0..j1 {
                let cov = y_hi.min(j as f32 + 1.0) - y_lo.max(j as f32);
                let at = i * stride_maj + j * stride_min;
                let tr = self.trans[at];
                if tr < OPAQUE || z >= self.zb[at] {
                    continue;
                }
                let w = tr * a_maj * cov;
                self.r[at] += w * col[0];
                self.g[at] += w * col[1];
                self.b[at] += w * col[2];
                let left = tr - w;
                self.trans[at] = left;
                if left < OPAQUE {
                    self.alive -= 1;
                }
            }
        }
    }
}
