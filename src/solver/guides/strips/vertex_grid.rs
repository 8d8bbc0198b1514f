//! The strips' vertex–triangle search (Chang, Jin, Yu 2002, §4.2): the guides' vertices in a
//! dense grid, and each triangle looking up the vertices in the cells its box covers.
//!
//! Why this way round: a triangle of a strip is wide (two guides apart) and its box covers
//! about ten cells, while a vertex sits in one. Listing the triangles in every cell they touch
//! meant sorting some 60,000 entries per step on Short; listing the vertices means sorting
//! 3,000 by counting, and a triangle's cells along z are one run of the sorted vertices.
//!
//! Where the time goes, what helped a little and what did not (2026-12-06, each variant
//! alternated with the build it started from, the results the same bit for bit). This
//! search, the contacts and the articulated-body runs are built a second time for AVX2
//! (`crate::simd::dispatch::multiversion`: the eight-lane `f32` tests in one register instead
//! of two, the `f64` arithmetic in three-operand form, no fused multiply-add, so the same
//! bits): the guides' step alone on one core (`wisptree bench --solvers guides --seconds 2`,
//! under `lean`, with and without run in pairs six times) 1–5 % faster, the median after ÷
//! before 0.99 on Short, 0.95 Short curly, 0.98 Long, 0.97 Long curly; within the noise of
//! `--live`. A triangle visits 3–4 columns of cells and tests 110–160 vertices
//! in 15–21 groups of eight to keep about 5 (3–5 %; Short under `lean`, Long curly under
//! `shake`, about 7,000 triangles a step): a strip's triangle is wide, tilted and thin, so
//! its box holds far more vertices than the slab within `reach` of it. Cells half as large
//! (vertex cells a fraction of the segments') halved the vertices tested and cut the groups
//! by 20–40 %, yet the 20 guide rows' real-time factors moved by a median of 1.02 (0.89–1.14,
//! two runs each) and the step alone on one core by less than 2 % on every style: the
//! per-triangle set-up (its prism, box and direction) and the extra column look-ups take what
//! the groups gave back. It did not land.

use super::broad::{f32_box, f32_down, f32_up, tail_mask, Prism};
use super::*;

/// Cells per axis at most. A vertex or a triangle past the grid's edge is clamped into the
/// edge's cells (the same monotone clamp for both, so a vertex inside a triangle's box is still
/// in one of the triangle's cells; the box test decides): only a runaway guide, far from the
/// others, gets there.
const MAX_CELLS_PER_AXIS: i64 = 64;

/// The alive guides' vertices (roots left out) sorted by cell of a dense grid, z fastest, and
/// side by side in `f32` for a triangle to test eight at a time.
#[derive(Debug, Default)]
pub(super) struct VertexGrid {
    /// Cell size, m.
    h: f64,
    /// The grid's first cell and its size in cells per axis.
    origin: [i64; 3],
    dims: [i64; 3],
    /// Per dense cell, the index of its first vertex; one more at the end.
    start: Vec<u32>,
    /// Per sorted vertex: position (rounded to the nearest `f32`), hair direction, guide and
    /// chain vertex index; eight padding entries at the end so that eight can always be read.
    x: [Vec<f32>; 3],
    dir: [Vec<f32>; 3],
    guide: Vec<u32>,
    vertex: Vec<u32>,
    /// Per alive vertex (in `alive` order): its dense cell (scratch of the counting sort).
    cell: Vec<u32>,
}

impl VertexGrid {
    /// Sorts the vertices of the guides in `alive` (roots left out) into cells of size `h`;
    /// `tangents` are their hair directions.
    pub(super) fn build(
        &mut self,
        chains: &Chains,
        alive: &[usize],
        tangents: &[Vector3<f64>],
        h: f64,
    ) {
        let n = chains.n;
        self.h = h;
        let verts = || {
            alive
                .iter()
                .flat_map(move |&g| (1..=n).map(move |i| g * (n + 1) + i))
        };
        let (mut lo, mut hi) = ([i64::MAX; 3], [i64::MIN; 3]);
        for v in verts() {
            let c = cell_of(&chains.x[v], h);
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        if lo[0] > hi[0] {
            (lo, hi) = ([0; 3], [0; 3]);
        }
        for k in 0..3 {
            self.origin[k] = lo[k];
            self.dims[k] = (hi[k] - lo[k] + 1).min(MAX_CELLS_PER_AXIS);
        }
        let cells = (self.dims[0] * self.dims[1] * self.dims[2]) as usize;
        self.start.clear();
        self.start.resize(cells + 1, 0);
        self.cell.clear();
        for v in verts() {
            let d = self.dense(self.clamp(cell_of(&chains.x[v], h)));
            self.cell.push(d);
            self.start[d as usize + 1] += 1;
        }
        for d in 0..cells {
            self.start[d + 1] += self.start[d];
        }
        let total = self.cell.len();
        for x in &mut self.x {
            x.clear();
            x.resize(total + 8, 0.0);
        }
        for d in &mut self.dir {
            d.clear();
            d.resize(total + 8, 0.0);
        }
        self.guide.clear();
        self.guide.resize(total + 8, u32::MAX);
        self.vertex.clear();
        self.vertex.resize(total + 8, 0);
        // A counting sort, stable: each cell's vertices in index order.
        let mut cursor = std::mem::take(&mut self.cell);
        let mut next = self.start.clone();
        for (k, v) in verts().enumerate() {
            let d = cursor[k] as usize;
            let at = next[d] as usize;
            next[d] += 1;
            let (p, t) = (chains.x[v], tangents[v]);
            (self.x[0][at], self.x[1][at], self.x[2][at]) = (p.x as f32, p.y as f32, p.z as f32);
            (self.dir[0][at], self.dir[1][at], self.dir[2][at]) =
                (t.x as f32, t.y as f32, t.z as f32);
            self.guide[at] = (v / (n + 1)) as u32;
            self.vertex[at] = v as u32;
        }
        cursor.clear();
        self.cell = cursor;
    }

    fn clamp(&self, c: [i64; 3]) -> [i64; 3] {
        let mut out = [0; 3];
        for k in 0..3 {
            out[k] = (c[k] - self.origin[k]).clamp(0, self.dims[k] - 1);
        }
        out
    }

    fn dense(&self, c: [i64; 3]) -> u32 {
        ((c[0] * self.dims[1] + c[1]) * self.dims[2] + c[2]) as u32
    }

    /// Bytes held.
    pub(super) fn reserved_bytes(&self) -> usize {
        (self.start.capacity() + self.guide.capacity() + self.vertex.capacity()) * 4
            + self.cell.capacity() * 4
            + self
                .x
                .iter()
                .chain(self.dir.iter())
                .map(|b| b.capacity() * 4)
                .sum::<usize>()
    }
}

/// Below this squared crossing in `f32`, a pair is surely below [`MIN_CROSSING`] squared in
/// `f64`: both directions are unit vectors rounded to `f32` (a relative error of 6e-8 each),
/// which moves the squared norm of their cross product by less than 1e-6.
const MIN_CROSSING2_F32: f32 = (MIN_CROSSING * MIN_CROSSING - 1e-4) as f32;

impl Strips {
    /// Piece `c` of the vertex–triangle pairs: its share of the triangles. A triangle (intact)
    /// keeps the vertices of neither of its guides that lie in its box grown by `reach`, cross
    /// it by at least [`MIN_CROSSING`] and lie within `reach` of its prism.
    #[inline(always)]
    pub(super) fn tri_piece(
        &self,
        c: usize,
        chains: &Chains,
        reach: f64,
        out: &mut Vec<(u32, u32)>,
    ) {
        let grid = &self.grid;
        let far = reach * (1.0 + 1e-9);
        let full = Vector3::repeat(reach);
        let min2 = MIN_CROSSING * MIN_CROSSING;
        let count = self.tri.len();
        for t in c * count / CHUNKS..(c + 1) * count / CHUNKS {
            if self.broken[t] {
                continue;
            }
            let tp = self.tri[t].map(|v| chains.x[v as usize]);
            let [a, b, cc] = tp;
            let (lo, hi) = (a.inf(&b).inf(&cc) - full, a.sup(&b).sup(&cc) + full);
            let (ca, cb) = (cell_of(&lo, grid.h), cell_of(&hi, grid.h));
            if (cb[0] - ca[0] + 1) * (cb[1] - ca[1] + 1) * (cb[2] - ca[2] + 1) > 64 {
                continue; // a degenerate, huge element: no contact rather than a flood of cells
            }
            let mut dir = Vector3::zeros();
            for w in self.tri[t] {
                dir += self.tangents[w as usize];
            }
            let dir = dir.try_normalize(1e-12).unwrap_or_else(Vector3::y);
            let df = [dir.x as f32, dir.y as f32, dir.z as f32];
            let bounds = f32_box(&lo, &hi);
            let [ga, gb] = self.tri_guides[t];
            let prism = Prism::new(&tp);
            // The prism in `f32` decides in lanes the vertices clearly inside or clearly
            // outside it; those within `slack` of a plane are tested again in `f64`. The slack
            // bounds the rounding of coordinates up to `size` from the origin to `f32`.
            let size = lo.abs().max().max(hi.abs().max());
            let slack = 4e-6 * (1.0 + size);
            let lanes = Lanes {
                bounds,
                dir: df,
                guides: [ga, gb],
                planes: prism.planes_f32(),
                outside: f32_up(far + slack),
                inside: f32_down(far - slack),
            };
            let (ka, kb) = (grid.clamp(ca), grid.clamp(cb));
            for x in ka[0]..=kb[0] {
                for y in ka[1]..=kb[1] {
                    // Cells z = ka[2]..=kb[2] of this column: one run of the sorted vertices.
                    let s = grid.start[grid.dense([x, y, ka[2]]) as usize] as usize;
                    let e = grid.start[grid.dense([x, y, kb[2]]) as usize + 1] as usize;
                    let mut i = s;
                    while i < e {
                        let (maybe, sure) = keep8(grid, i, &lanes);
                        let mut mask = maybe & tail_mask(e - i);
                        while mask != 0 {
                            let j = mask.trailing_zeros() as usize;
                            mask &= mask - 1;
                            let v = grid.vertex[i + j] as usize;
                            if sure & (1 << j) == 0
                                && (self.tangents[v].cross(&dir).norm_squared() < min2
                                    || !prism.near(&chains.x[v], far))
                            {
                                continue;
                            }
                            out.push((v as u32, t as u32));
                        }
                        i += 8;
                    }
                }
            }
        }
    }
}

/// A triangle's tests in lanes: its box grown by the reach (low x, y, z, high x, y, z; `f32`
/// rounded outwards), hair direction, the guides of its sides, and its prism's planes with
/// the distances beyond which a vertex is surely outside and below which surely inside.
struct Lanes {
    bounds: [f32; 6],
    dir: [f32; 3],
    guides: [u32; 2],
    planes: [[f32; 4]; 4],
    outside: f32,
    inside: f32,
}

/// Above this squared crossing in `f32`, a pair is surely at or above [`MIN_CROSSING`] squared
/// in `f64` (see [`MIN_CROSSING2_F32`]).
const SURE_CROSSING2_F32: f32 = (MIN_CROSSING * MIN_CROSSING + 1e-4) as f32;

/// Which of the eight sorted vertices `i..i + 8` of `grid` may be candidates of the
/// triangle of `l`, and which of those surely are, as bits. A candidate lies in the box, is
/// on neither guide, may cross the triangle's direction by [`MIN_CROSSING`] or more and is
/// not surely outside the prism; it surely is one when it surely crosses and is surely inside
/// the prism. Written over fixed arrays of eight without a branch so that the compiler makes
/// vector compares of it on any target. A vertex turned down here is surely turned down by the
/// exact `f64` tests, and one surely kept is surely kept by them.
#[inline(always)]
fn keep8(grid: &VertexGrid, i: usize, l: &Lanes) -> (u32, u32) {
    fn lane(v: &[f32], i: usize) -> &[f32; 8] {
        v[i..i + 8]
            .try_into()
            .expect("eight entries past every index")
    }
    let (x, y, z) = (
        lane(&grid.x[0], i),
        lane(&grid.x[1], i),
        lane(&grid.x[2], i),
    );
    let (hx, hy, hz) = (
        lane(&grid.dir[0], i),
        lane(&grid.dir[1], i),
        lane(&grid.dir[2], i),
    );
    let g: &[u32; 8] = grid.guide[i..i + 8]
        .try_into()
        .expect("eight entries past every index");
    let (b, d, p) = (&l.bounds, &l.dir, &l.planes);
    let mut maybe = [0u32; 8];
    let mut sure = [0u32; 8];
    for j in 0..8 {
        let cx = hy[j] * d[2] - hz[j] * d[1];
        let cy = hz[j] * d[0] - hx[j] * d[2];
        let cz = hx[j] * d[1] - hy[j] * d[0];
        let c2 = cx * cx + cy * cy + cz * cz;
        let dist = |k: usize| p[k][0] * x[j] + p[k][1] * y[j] + p[k][2] * z[j] - p[k][3];
        let (d0, d1, d2, d3) = (dist(0).abs(), dist(1), dist(2), dist(3));
        let out = (d0 >= l.outside) | (d1 >= l.outside) | (d2 >= l.outside) | (d3 >= l.outside);
        let inside = (d0 < l.inside) & (d1 < l.inside) & (d2 < l.inside) & (d3 < l.inside);
        maybe[j] = ((x[j] >= b[0])
            & (y[j] >= b[1])
            & (z[j] >= b[2])
            & (x[j] <= b[3])
            & (y[j] <= b[4])
            & (z[j] <= b[5])
            & (g[j] != l.guides[0])
            & (g[j] != l.guides[1])
            & (c2 >= MIN_CROSSING2_F32)
            & !out) as u32;
        sure[j] = ((c2 >= SURE_CROSSING2_F32) & inside) as u32;
    }
    let (mut m, mut s) = (0, 0);
    for j in 0..8 {
        m |= maybe[j] << j;
        s |= sure[j] << j;
    }
    (m, s)
}
