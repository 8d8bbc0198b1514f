//! The strips' broad phase (Chang, Jin, Yu 2002, §4.2): candidate segment–segment and
//! vertex–triangle pairs from a uniform grid, cut into fixed pieces for the pool's threads.

use super::*;
use crate::simd::dispatch::multiversion;

impl Strips {
    /// Broad phase: finds segment–segment pairs of different guides whose boxes, each grown
    /// by `reach / 2`, overlap, and vertex–triangle pairs (vertex not on the triangle's guides,
    /// triangle intact) that may be closer than `reach`; both only if they cross by at least
    /// [`MIN_CROSSING`]. `alive`: the guide slots simulated. On the calling thread.
    pub fn detect(&mut self, chains: &Chains, alive: &[usize], reach: f64) {
        self.detect_on(None, chains, alive, reach);
    }

    /// [`Strips::detect`] on the threads of `pool` (the same candidates in the same order).
    ///
    /// Every segment's box, direction and grid cells are computed once, and the vertices are
    /// sorted into a grid of the same cells ([`VertexGrid`]). A triangle tests only the
    /// vertices its box grown by `reach` holds, and keeps those within `reach` of its plane
    /// and of each edge's line on its outer side (its prism grown by `reach`): a test of four
    /// dot products that keeps every vertex closer than `reach` (the closest point lies on
    /// the triangle, inside every one of those planes) and a few more near the corners, which
    /// the sub-steps' exact test then turns down.
    pub fn detect_on(&mut self, pool: Option<&Pool>, chains: &Chains, alive: &[usize], reach: f64) {
        let n = chains.n;
        self.seg_pairs.clear();
        self.vt_pairs.clear();
        fill_tangents(chains, alive, &mut self.tangents);
        self.prepare(pool, chains, alive, reach);
        let this = &*self;
        let level = self.level();
        for_each_on(pool, CHUNKS, &|c| {
            let mut guard = this.chunks[c].lock().unwrap_or_else(|e| e.into_inner());
            search_piece(level, this, c, n, chains, reach, &mut guard);
        });
        self.gather(chains.x.len());
    }

    /// The broad phase's set-up on the threads of `pool`: every segment's box, direction and
    /// grid cells, and the vertices' grid (the tangents already filled).
    pub(super) fn prepare(
        &mut self,
        pool: Option<&Pool>,
        chains: &Chains,
        alive: &[usize],
        reach: f64,
    ) {
        let n = chains.n;
        let h = chains.len.iter().cloned().fold(0.0, f64::max) + 2.0 * reach;
        self.entries.clear();
        let links = chains.len.len();
        self.seg_box
            .resize(links, (Vector3::zeros(), Vector3::zeros()));
        self.seg_box32.resize(links, [0.0; 6]);
        self.seg_dir.resize(links, Vector3::zeros());
        self.seg_cell.resize(links, [0; 3]);
        let half = Vector3::repeat(reach * 0.5);
        let push_cells =
            |out: &mut Vec<(u64, u32)>, lo: &Vector3<f64>, hi: &Vector3<f64>, id: u32| {
                let (a, b) = (cell_of(lo, h), cell_of(hi, h));
                if (b[0] - a[0] + 1) * (b[1] - a[1] + 1) * (b[2] - a[2] + 1) > 64 {
                    return; // a degenerate, huge element: no contact rather than a flood of cells
                }
                for x in a[0]..=b[0] {
                    for y in a[1]..=b[1] {
                        for z in a[2]..=b[2] {
                            out.push((cell_key([x, y, z]), id));
                        }
                    }
                }
            };
        // The segments' boxes, cells and sorted entries and the vertices' grid touch different
        // buffers: one thread each.
        let segs = Mutex::new((
            &mut self.seg_box,
            &mut self.seg_box32,
            &mut self.seg_cell,
            &mut self.seg_dir,
            &mut self.entries,
            &mut self.sbox,
        ));
        let grid = Mutex::new(&mut self.grid);
        let tangents = &self.tangents;
        for_each_on(pool, 2, &|part| {
            if part == 0 {
                let mut guard = grid.lock().unwrap_or_else(|e| e.into_inner());
                guard.build(chains, alive, tangents, h);
            } else {
                let mut guard = segs.lock().unwrap_or_else(|e| e.into_inner());
                let (seg_box, seg_box32, seg_cell, seg_dir, entries, sbox) = &mut *guard;
                for &g in alive {
                    for i in 0..n {
                        let l = g * n + i;
                        let v = g * (n + 1) + i;
                        let (p, q) = (chains.x[v], chains.x[v + 1]);
                        let (lo, hi) = (p.inf(&q) - half, p.sup(&q) + half);
                        seg_box[l] = (lo, hi);
                        seg_box32[l] = f32_box(&lo, &hi);
                        seg_cell[l] = cell_of(&lo, h);
                        let t = q - p;
                        seg_dir[l] = t / t.norm();
                        push_cells(entries, &lo, &hi, l as u32);
                    }
                }
                entries.sort_unstable();
                fill_boxes(sbox, entries, seg_box32);
            }
        });
        if self.chunks.len() != CHUNKS {
            self.chunks = (0..CHUNKS).map(|_| Mutex::default()).collect();
        }
    }

    /// Joins the pieces' candidates: the segment pairs in piece order, the vertex–triangle
    /// pairs grouped by triangle. `verts`: the chains' vertex count.
    fn gather(&mut self, verts: usize) {
        let mut chunks = std::mem::take(&mut self.chunks);
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            self.seg_pairs.extend_from_slice(&chunk.seg);
        }
        // Grouped by triangle, each triangle's vertices in index order (the order of a
        // vertex-by-vertex search, in which a sub-step adds their forces, whatever the cells
        // made of it): two counting sorts, by vertex and then, keeping that order, by triangle
        // (6,000 small sorts of each triangle's vertices cost a tenth of the broad phase).
        let mut by_vertex = std::mem::take(&mut self.vt_pairs);
        let mut cursor = std::mem::take(&mut self.cursor);
        cursor.clear();
        cursor.resize(verts.max(self.tri.len()) + 1, 0);
        let mut found = 0;
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            for &(v, _) in &chunk.vt {
                cursor[v as usize + 1] += 1;
            }
            found += chunk.vt.len();
        }
        for v in 0..verts {
            cursor[v + 1] += cursor[v];
        }
        by_vertex.clear();
        by_vertex.resize(found, (0, 0));
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            for &(v, t) in &chunk.vt {
                by_vertex[cursor[v as usize] as usize] = (v, t);
                cursor[v as usize] += 1;
            }
        }
        self.tri_start.clear();
        self.tri_start.resize(self.tri.len() + 1, 0);
        for &(_, t) in &by_vertex {
            self.tri_start[t as usize + 1] += 1;
        }
        for t in 0..self.tri.len() {
            self.tri_start[t + 1] += self.tri_start[t];
        }
        self.tri_verts.clear();
        self.tri_verts.resize(found, 0);
        cursor.clear();
        cursor.extend_from_slice(&self.tri_start[..self.tri.len()]);
        for &(v, t) in &by_vertex {
            self.tri_verts[cursor[t as usize] as usize] = v;
            cursor[t as usize] += 1;
        }
        self.found = self.seg_pairs.len() + found;
        self.vt_pairs = by_vertex;
        self.cursor = cursor;
        self.chunks = chunks;
    }

    /// Piece `c` of the segment pairs: the cells whose runs start in its share of the sorted
    /// entries. Each pair is tested in the one cell holding the low corner of their boxes'
    /// overlap.
    #[inline(always)]
    pub(super) fn seg_piece(&self, c: usize, n: usize, out: &mut Vec<(u32, u32)>) {
        let entries = &self.entries;
        let run_start = |i: usize| {
            let mut i = i.min(entries.len());
            while i > 0 && i < entries.len() && entries[i].0 == entries[i - 1].0 {
                i += 1;
            }
            i
        };
        let len = entries.len();
        let [lx, ly, lz, hx, hy, hz] = &self.sbox;
        let (mut s, end) = (
            run_start(c * len / CHUNKS),
            run_start((c + 1) * len / CHUNKS),
        );
        while s < end {
            let key = entries[s].0;
            let mut e = s;
            while e < len && entries[e].0 == key {
                e += 1;
            }
            for p in s..e {
                let la = entries[p].1 as usize;
                let (alo, ahi) = self.seg_box[la];
                let ca = self.seg_cell[la];
                let a = [lx[p], ly[p], lz[p], hx[p], hy[p], hz[p]];
                let mut q = p + 1;
                while q < e {
                    // Eight boxes at once in `f32` (rounded outwards, so no overlap is lost),
                    // then the exact tests on the few that overlap.
                    let mut mask = overlap8(&a, &self.sbox, q) & tail_mask(e - q);
                    let base = q;
                    q += 8;
                    while mask != 0 {
                        let j = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let lb = entries[base + j].1 as usize;
                        let (blo, bhi) = self.seg_box[lb];
                        let lo = alo.sup(&blo);
                        let hi = ahi.inf(&bhi);
                        if lo.x > hi.x || lo.y > hi.y || lo.z > hi.z || la / n == lb / n {
                            continue;
                        }
                        // The cell of the overlap's low corner, `lo = alo.sup(blo)`: the larger
                        // of the two boxes' low cells on each axis (the cell is monotone).
                        let cb = self.seg_cell[lb];
                        let cell = [ca[0].max(cb[0]), ca[1].max(cb[1]), ca[2].max(cb[2])];
                        if cell_key(cell) != key
                            || orientation_scale(&self.seg_dir[la], &self.seg_dir[lb])
                                < MIN_CROSSING
                        {
                            continue;
                        }
                        out.push((la.min(lb) as u32, la.max(lb) as u32));
                    }
                }
            }
            s = e;
        }
    }
}

multiversion! {
    /// Piece `c` of [`Strips::detect_on`]'s candidates, built for AVX2 too (see
    /// `crate::simd::dispatch`): the box, crossing and prism tests run eight at a time in
    /// `f32`, which an AVX2 build does in one register instead of two, with the same bits.
    fn search_piece(
        this: &Strips,
        c: usize,
        n: usize,
        chains: &Chains,
        reach: f64,
        chunk: &mut Chunk,
    ) {
        chunk.seg.clear();
        chunk.vt.clear();
        this.seg_piece(c, n, &mut chunk.seg);
        this.tri_piece(c, chains, reach, &mut chunk.vt);
    }
}

/// The boxes of `entries` (element ids into `boxes`, each already in `f32` rounded outwards:
/// low x, y, z, high x, y, z) side by side, followed by eight empty boxes so that eight can
/// always be read. The boxes are rounded once per segment, not once per entry (a segment has
/// two or three): this copy runs on one thread beside the vertices' grid.
fn fill_boxes(out: &mut [Vec<f32>; 6], entries: &[(u64, u32)], boxes: &[[f32; 6]]) {
    let len = entries.len();
    for b in out.iter_mut() {
        b.clear();
        b.resize(len + 8, 0.0);
    }
    let [lx, ly, lz, hx, hy, hz] = out;
    for (i, &(_, id)) in entries.iter().enumerate() {
        let b = &boxes[id as usize];
        (lx[i], ly[i], lz[i]) = (b[0], b[1], b[2]);
        (hx[i], hy[i], hz[i]) = (b[3], b[4], b[5]);
    }
    for i in len..len + 8 {
        (lx[i], ly[i], lz[i]) = (f32::INFINITY, f32::INFINITY, f32::INFINITY);
        (hx[i], hy[i], hz[i]) = (f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY);
    }
}

/// Bits `0..m` set (all eight from 8 on).
#[inline]
pub(super) fn tail_mask(m: usize) -> u32 {
    if m >= 8 {
        0xff
    } else {
        (1u32 << m) - 1
    }
}

/// Which of the eight boxes `i..i + 8` of `boxes` (as [`fill_boxes`] lays them out) overlap
/// box `a` (low x, y, z, high x, y, z; a point is a box with low = high), as bits: written
/// over fixed arrays of eight without a branch so that the compiler makes vector compares of
/// it on any target.
#[inline(always)]
fn overlap8(a: &[f32; 6], boxes: &[Vec<f32>; 6], i: usize) -> u32 {
    let lane = |k: usize| -> &[f32; 8] {
        boxes[k][i..i + 8]
            .try_into()
            .expect("eight boxes past every index")
    };
    let (lx, ly, lz, hx, hy, hz) = (lane(0), lane(1), lane(2), lane(3), lane(4), lane(5));
    let mut inside = [0u32; 8];
    for j in 0..8 {
        inside[j] = ((a[3] >= lx[j])
            & (a[4] >= ly[j])
            & (a[5] >= lz[j])
            & (a[0] <= hx[j])
            & (a[1] <= hy[j])
            & (a[2] <= hz[j])) as u32;
    }
    let mut mask = 0;
    for (j, b) in inside.iter().enumerate() {
        mask |= b << j;
    }
    mask
}

/// The box `lo..hi` in `f32` rounded outwards (low x, y, z, high x, y, z), as the lanes test it:
/// it holds every point of the `f64` box.
#[inline(always)]
pub(super) fn f32_box(lo: &Vector3<f64>, hi: &Vector3<f64>) -> [f32; 6] {
    [
        f32_down(lo.x),
        f32_down(lo.y),
        f32_down(lo.z),
        f32_up(hi.x),
        f32_up(hi.y),
        f32_up(hi.z),
    ]
}

/// The largest `f32` not above `x`.
#[inline]
pub(super) fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` not below `x`.
#[inline]
pub(super) fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// A triangle's plane and the planes through its edges perpendicular to it, facing out: a
/// point closer than `r` to the triangle is closer than `r` to its plane and less than `r`
/// outside each edge plane (its closest point lies on the triangle, inside them all).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Prism {
    n: Vector3<f64>,
    d: f64,
    e: [Vector3<f64>; 3],
    c: [f64; 3],
    /// Too thin to have a trusted normal: every point passes.
    flat: bool,
}

impl Prism {
    /// Always inlined, so that the pieces built for AVX2 compile it with them.
    #[inline(always)]
    pub(super) fn new(t: &[Vector3<f64>; 3]) -> Prism {
        let (ab, ac) = (t[1] - t[0], t[2] - t[0]);
        let cross = ab.cross(&ac);
        let area = cross.norm();
        if area.is_nan() || area <= 1e-6 * ab.norm() * ac.norm() {
            return Prism {
                flat: true,
                ..Prism::default()
            };
        }
        let n = cross / area;
        let mut e = [Vector3::zeros(); 3];
        let mut c = [0.0; 3];
        for k in 0..3 {
            let (p, q, r) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            let mut ek = (q - p).cross(&n).try_normalize(0.0).unwrap_or_default();
            if ek.dot(&(r - p)) > 0.0 {
                ek = -ek;
            }
            e[k] = ek;
            c[k] = ek.dot(&p);
        }
        Prism {
            n,
            d: n.dot(&t[0]),
            e,
            c,
            flat: false,
        }
    }

    /// The four planes in `f32` (normal x, y, z, offset: the triangle's plane, then its three
    /// edges' planes), for tests in lanes; all zero for a flat prism, which every point passes.
    pub(super) fn planes_f32(&self) -> [[f32; 4]; 4] {
        if self.flat {
            return [[0.0; 4]; 4];
        }
        let plane = |n: &Vector3<f64>, d: f64| [n.x as f32, n.y as f32, n.z as f32, d as f32];
        [
            plane(&self.n, self.d),
            plane(&self.e[0], self.c[0]),
            plane(&self.e[1], self.c[1]),
            plane(&self.e[2], self.c[2]),
        ]
    }

    /// [`Prism::near`] with every test evaluated (no branch), the same answer.
    #[inline]
    pub(super) fn near_all(&self, x: &Vector3<f64>, r: f64) -> bool {
        self.flat
            | (((self.n.dot(x) - self.d).abs() < r)
                & (self.e[0].dot(x) - self.c[0] < r)
                & (self.e[1].dot(x) - self.c[1] < r)
                & (self.e[2].dot(x) - self.c[2] < r))
    }

    /// False only if `x` is at least `r` from the triangle.
    #[inline]
    pub(super) fn near(&self, x: &Vector3<f64>, r: f64) -> bool {
        self.flat
            || ((self.n.dot(x) - self.d).abs() < r
                && self.e[0].dot(x) - self.c[0] < r
                && self.e[1].dot(x) - self.c[1] < r
                && self.e[2].dot(x) - self.c[2] < r)
    }
}
