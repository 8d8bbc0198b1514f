//! Strand segments on screen: binning into tiles and depth sorting per tile (the rasteriser
//! that blends them front to back is in [`super::tile`]).
//!
//! Segments are sorted by the view depth of their midpoint (the visibility ordering of line
//! segments the AWT paper uses for antialiasing, Bertails et al. 2003, §5.1), each tile's own
//! list with a stable radix sort, so the order is exact and the same on every run.

use super::camera::ScreenVertex;
use super::cull::BodyCull;
use super::num::{floor_pos, mn, mx};

/// Pixels per tile side. Tiles have no apron: the postfilter runs over the whole frame once
/// every tile is resolved, so no sample is drawn twice.
pub(crate) const TILE: usize = 32;

/// A segment as binned: its two end points and their colours (RGB9E5,
/// [`super::point_colors`]), copied so that a tile reads its segments from one contiguous run
/// of memory. 32 bytes, so that filling and sorting the tiles move little; the depth key is
/// computed from the two depths when a tile is sorted.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct SegRec {
    pub a: ScreenVertex,
    pub b: ScreenVertex,
    /// Packed linear colour at `a`, then at `b`.
    pub ca: u32,
    pub cb: u32,
}

/// The frame's visible segments binned into tiles; each tile sorts its own segments by a 16-bit
/// depth key ([`bucket_tile`], [`super::tile::draw_buckets`]) so that no pass walks the whole
/// frame in depth order (which would miss the cache at every segment). The strands are binned
/// in two halves (one per thread at most), each into its own lists: a tile's segments are half
/// 0's list then half 1's, in strand order whatever the number of threads.
#[derive(Debug, Default)]
pub(crate) struct Bins {
    pub halves: [std::sync::Mutex<HalfBins>; 2],
}

/// The bins of one half of the strands.
#[derive(Debug, Default)]
pub(crate) struct HalfBins {
    /// First vertex and tile of each segment binned, in strand order.
    pairs: Vec<(u32, u32)>,
    cursor: Vec<u32>,
    /// Midpoint depth range of the visible segments.
    zlo: f32,
    zhi: f32,
    /// Per tile, `start[t]..start[t + 1]` in `items`.
    pub start: Vec<u32>,
    pub items: Vec<SegRec>,
}

/// How the tile pass samples a pixel: `per_axis`² samples, each taking a line's coverage
/// of its cell (box-filtered, the renderer's way) or, with `point`, all of the line or none
/// by whether its centre lies inside the line (OpenGL's lines without antialiasing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampling {
    /// Samples per pixel along each axis, 1 to 4.
    pub per_axis: u32,
    /// Point samples instead of box-filtered coverage.
    pub point: bool,
}

impl Sampling {
    /// `per_axis`² box-filtered samples per pixel: how styles render.
    pub fn boxed(per_axis: u32) -> Sampling {
        Sampling {
            per_axis,
            point: false,
        }
    }
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
    /// Samples per side of a tile buffer.
    pub fn tile_samples(&self) -> usize {
        TILE * self.ss
    }
    /// Global sample coordinates of tile `t`'s buffer origin.
    pub fn origin(&self, t: usize) -> (i32, i32) {
        let (tx, ty) = (t % self.tiles_x, t / self.tiles_x);
        ((tx * TILE * self.ss) as i32, (ty * TILE * self.ss) as i32)
    }
}

impl HalfBins {
    /// Finds the visible segments of strands `strands` of `verts` (strand `s` spans
    /// `offsets[s]..offsets[s+1]`), their tiles in `grid` except those where `cull` says the
    /// body hides them, and their depth range, and counts them per tile; marks the points of
    /// each segment kept in `needed` (`needed.1[k]` is point `needed.0 + k`). `reach` is how
    /// far (samples) a line reaches beyond its centre line.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn count(
        &mut self,
        verts: &[ScreenVertex],
        offsets: &[u32],
        strands: std::ops::Range<usize>,
        grid: &Grid,
        reach: f32,
        cull: &BodyCull,
        needed: (usize, &mut [u8]),
    ) {
        let (base, needed) = needed;
        self.pairs.clear();
        let nt = grid.tiles();
        self.start.clear();
        self.start.resize(nt + 1, 0);
        let (mut zlo, mut zhi) = (f32::INFINITY, f32::NEG_INFINITY);
        // Tile coordinates are sample coordinates times `inv_span`; a box entirely left of or
        // above the image, or beyond it, or with a NaN, touches no tile.
        let inv_span = 1.0 / (TILE * grid.ss) as f32;
        let (ntx, nty) = (grid.tiles_x as f32, grid.tiles_y as f32);
        let (lastx, lasty) = (grid.tiles_x - 1, grid.tiles_y - 1);
        for s in strands {
            let (a, b) = (offsets[s] as usize, offsets[s + 1] as usize);
            for i in a..b.saturating_sub(1) {
                let (p, q) = (&verts[i], &verts[i + 1]);
                if !(p.z > super::camera::NEAR && q.z > super::camera::NEAR) {
                    continue;
                }
                let x0 = (mn(p.x, q.x) - reach) * inv_span;
                let x1 = (mx(p.x, q.x) + reach) * inv_span;
                let y0 = (mn(p.y, q.y) - reach) * inv_span;
                let y1 = (mx(p.y, q.y) + reach) * inv_span;
                if !(x1 >= 0.0 && x0 < ntx && y1 >= 0.0 && y0 < nty) {
                    continue;
                }
                let (x0, x1) = (floor_pos(x0), floor_pos(x1).min(lastx));
                let (y0, y1) = (floor_pos(y0), floor_pos(y1).min(lasty));
                // The key range spans every segment on screen, culled or not.
                let z = 0.5 * (p.z + q.z);
                zlo = mn(zlo, z);
                zhi = mx(zhi, z);
                // The body's test in every tile ([`BodyCull::keeps`]).
                let zmin = BodyCull::depth(p, q);
                let mut kept = false;
                if x1 - x0 < 2 && y1 - y0 < 2 {
                    // Up to 2 × 2 tiles (nearly always): all four corners tried, each kept
                    // if it is a distinct tile the body does not hide, written whether kept
                    // or not, so that no branch depends on how many there are.
                    self.pairs.reserve(4);
                    let w = grid.tiles_x;
                    let tiles = [y0 * w + x0, y0 * w + x1, y1 * w + x0, y1 * w + x1];
                    let distinct = [true, x1 != x0, y1 != y0, x1 != x0 && y1 != y0];
                    for (&t, &new) in tiles.iter().zip(&distinct) {
                        let keep = new & cull.keeps(t, zmin);
                        let len = self.pairs.len();
                        // SAFETY: 4 entries were reserved above, and at most 4 are added.
                        unsafe {
                            self.pairs.as_mut_ptr().add(len).write((i as u32, t as u32));
                            self.pairs.set_len(len + keep as usize);
                        }
                        self.start[t + 1] += keep as u32;
                        kept |= keep;
                    }
                } else {
                    for ty in y0..y1 + 1 {
                        for tx in x0..x1 + 1 {
                            let t = ty * grid.tiles_x + tx;
                            if !cull.keeps(t, zmin) {
                                continue;
                            }
                            self.start[t + 1] += 1;
                            self.pairs.push((i as u32, t as u32));
                            kept = true;
                        }
                    }
                }
                needed[i - base] |= kept as u8;
                needed[i + 1 - base] |= kept as u8;
            }
        }
        for t in 1..=nt {
            self.start[t] += self.start[t - 1];
        }
        (self.zlo, self.zhi) = (zlo, zhi);
    }

    /// Fills the tile lists, each segment with the packed colours `colors` of its points.
    #[inline(always)]
    pub fn fill(&mut self, verts: &[ScreenVertex], colors: &[u32], grid: &Grid) {
        let nt = grid.tiles();
        let total = self.start[nt] as usize;
        self.items.resize(total, SegRec::default());
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.start[..nt]);
        for &(i, t) in &self.pairs {
            let i = i as usize;
            let c = &mut self.cursor[t as usize];
            self.items[*c as usize] = SegRec {
                a: verts[i],
                b: verts[i + 1],
                ca: colors[i],
                cb: colors[i + 1],
            };
            *c += 1;
        }
    }

    /// Depth range of the last count.
    pub fn depth_range(&self) -> (f32, f32) {
        (self.zlo, self.zhi)
    }

    /// Number of tile `t`'s segments (known from the count on, before the fill).
    pub fn tile_len(&self, t: usize) -> usize {
        (self.start[t + 1] - self.start[t]) as usize
    }

    /// Tile `t`'s segments.
    pub fn tile(&self, t: usize) -> &[SegRec] {
        &self.items[self.start[t] as usize..self.start[t + 1] as usize]
    }
}

/// Depth keys of segments: the view depth of the midpoint, quantised to 16 bits over the
/// frame's range of midpoint depths.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DepthKey {
    lo: f32,
    scale: f32,
}

impl DepthKey {
    /// Keys over midpoint depths `lo..=hi`.
    pub fn new(lo: f32, hi: f32) -> DepthKey {
        let scale = if hi > lo { 65535.0 / (hi - lo) } else { 0.0 };
        DepthKey { lo, scale }
    }

    /// The key of segment `r`.
    #[inline(always)]
    pub fn of(&self, r: &SegRec) -> u32 {
        let z = 0.5 * (r.a.z + r.b.z);
        (((z - self.lo) * self.scale) as u32).min(65535)
    }
}

/// Puts a tile's segments (`first` then `second`, in strand order) into 256 depth buckets by
/// the high byte of their keys, front to back, into `out[..n]` (`n` their number): bucket k is
/// `buckets[k]..buckets[k + 1]`, in strand order (one stable counting pass), and `lows[i]` is
/// the low byte of `out[i]`'s key. The tile pass finishes the sort bucket by bucket, after
/// culling ([`super::tile::draw_buckets`]). The records themselves move, so that the
/// rasteriser then reads them from memory in nearly the order it draws them.
#[inline(always)]
pub(crate) fn bucket_tile(
    first: &[SegRec],
    second: &[SegRec],
    key: DepthKey,
    out: &mut Vec<SegRec>,
    lows: &mut Vec<u8>,
    keys: &mut Vec<u16>,
    buckets: &mut [u32; 257],
) -> usize {
    let n = first.len() + second.len();
    // Grown, never shrunk: every record up to `n` is written below, so the buffers are only
    // filled with defaults when a tile needs more room than any before it.
    if out.len() < n {
        out.resize(n, SegRec::default());
    }
    if keys.len() < n {
        keys.resize(n, 0);
        lows.resize(n, 0);
    }
    let (out, keys, lows) = (&mut out[..n], &mut keys[..n], &mut lows[..n]);
    *buckets = [0; 257];
    for (r, k) in first.iter().chain(second).zip(keys.iter_mut()) {
        *k = key.of(r) as u16;
        buckets[(*k >> 8) as usize + 1] += 1;
    }
    for d in 1..257 {
        buckets[d] += buckets[d - 1];
    }
    let mut at = [0u32; 256];
    at.copy_from_slice(&buckets[..256]);
    for (r, &k) in first.iter().chain(second).zip(keys.iter()) {
        let a = &mut at[(k >> 8) as usize];
        out[*a as usize] = *r;
        lows[*a as usize] = k as u8;
        *a += 1;
    }
    n
}
