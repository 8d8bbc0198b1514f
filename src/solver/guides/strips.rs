//! Hair–hair collision through auxiliary triangle strips (Chang, Jin, Yu 2002, §4.2).
//!
//! A strip joins two guides with nearby roots, corresponding vertices joined, and stands for
//! the dense hair between them. Segment–segment and vertex–triangle pairs closer than a
//! threshold (a guide stands for a cluster with a thickness) get a strongly damped repulsive
//! spring, scaled by how much the hair crosses the other element (Eq. 3: zero when aligned,
//! full when perpendicular), and viscous friction on their tangential relative motion. Forces
//! on a triangle go to its vertices by barycentric weights. A triangle stretched wider than
//! `strip_break` times its rest width is broken while it stays so (reversible, unlike links).
//!
//! The broad phase is a uniform grid held as a sorted list of (cell, element) pairs, rebuilt
//! once per step into reused buffers; candidate pairs found within twice the threshold are
//! re-evaluated at every sub-step.
//!
//! Both the broad phase and a sub-step's contacts are cut into [`CHUNKS`] fixed pieces of work
//! that the threads of a [`Pool`] take in any order; each piece writes only its own lists, and
//! the lists are joined (candidates) or their forces added (contacts) piece by piece in order
//! afterwards, so the result is the same bit for bit on one thread or two, whichever thread
//! took which piece.

use std::sync::Mutex;

use nalgebra::Vector3;

use crate::par::{for_each_on, Pool};

use super::chain::Chains;
use super::params::{GuideParams, StripLayout};

/// The orientation factor of Eq. 3 for hair direction `a` against the other element's hair
/// direction `b` (both unit): `|a × b|`, the sine of their angle: 0 aligned, 1 perpendicular.
pub fn orientation_scale(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().min(1.0)
}

/// Guide pairs that get a strip, from their rest roots (§4.2, Fig. 3). `roots`: (guide,
/// root). Horizontal: each guide to its nearest neighbour counter-clockwise about the
/// vertical through `center` whose root is no more than half as far vertically as
/// horizontally. Grid: each guide to its nearest neighbour along +x and along +z.
pub fn strip_pairs(
    roots: &[(usize, Vector3<f64>)],
    layout: StripLayout,
    max_dist: f64,
    center: &Vector3<f64>,
) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    let nearest =
        |g: usize, r: &Vector3<f64>, ok: &dyn Fn(&Vector3<f64>, &Vector3<f64>) -> bool| {
            let mut best: Option<(f64, usize)> = None;
            for &(j, rj) in roots {
                let d = (rj - r).norm();
                if j == g || d > max_dist || !ok(r, &rj) {
                    continue;
                }
                if best.is_none_or(|(bd, bj)| (d, j) < (bd, bj)) {
                    best = Some((d, j));
                }
            }
            best.map(|(_, j)| j)
        };
    for &(g, r) in roots {
        match layout {
            StripLayout::Horizontal => {
                let ok = |a: &Vector3<f64>, b: &Vector3<f64>| {
                    let d = b - a;
                    let horiz = (d.x * d.x + d.z * d.z).sqrt();
                    let side = (a - center).cross(&(b - center)).y;
                    d.y.abs() <= 0.5 * horiz && side > 0.0
                };
                if let Some(j) = nearest(g, &r, &ok) {
                    out.push((g as u32, j as u32));
                }
            }
            StripLayout::Grid => {
                let along_x = |a: &Vector3<f64>, b: &Vector3<f64>| (b - a).x > 0.7 * (b - a).norm();
                let along_z = |a: &Vector3<f64>, b: &Vector3<f64>| (b - a).z > 0.7 * (b - a).norm();
                if let Some(j) = nearest(g, &r, &along_x) {
                    out.push((g as u32, j as u32));
                }
                if let Some(j) = nearest(g, &r, &along_z) {
                    out.push((g as u32, j as u32));
                }
            }
        }
    }
    out
}

/// Pieces the broad phase and the contacts are cut into for the pool's threads: enough that a
/// thread finding the other core busy takes the pieces the other would have.
pub const CHUNKS: usize = 8;

/// A vertex–triangle contact of a sub-step, kept until its forces are added in order.
#[derive(Debug, Clone, Copy)]
struct TriHit {
    t: u32,
    v: u32,
    f: Vector3<f64>,
    cd: f64,
    bary: [f64; 3],
}

/// A segment–segment contact of a sub-step: the first vertices of both links, the closest
/// points' parameters, the force on the first link and the damping coefficient.
#[derive(Debug, Clone, Copy)]
struct SegHit {
    va: u32,
    vb: u32,
    s: f64,
    t: f64,
    f: Vector3<f64>,
    cd: f64,
}

/// What one piece of work found.
#[derive(Debug, Default)]
struct Chunk {
    seg: Vec<(u32, u32)>,
    vt: Vec<(u32, u32)>,
    tri_hits: Vec<TriHit>,
    seg_hits: Vec<SegHit>,
    count: usize,
}

/// The strips' triangles and the contact machinery.
#[derive(Debug, Default)]
pub struct Strips {
    /// Guide pairs joined by a strip.
    pub pairs: Vec<(u32, u32)>,
    /// Per triangle: its three vertices (chain vertex indices).
    pub tri: Vec<[u32; 3]>,
    /// Per triangle: the two vertices (one per guide) whose distance is its width.
    pub width_edge: Vec<[u32; 2]>,
    /// Per triangle: rest width, m.
    pub rest_width: Vec<f64>,
    /// Per triangle: broken at the last check.
    pub broken: Vec<bool>,
    entries: Vec<(u64, u32)>,
    tri_entries: Vec<(u64, u32)>,
    /// Candidate segment–segment pairs (links, lower first).
    seg_pairs: Vec<(u32, u32)>,
    /// Candidate vertex–triangle pairs as found (vertex-major), then grouped by triangle:
    /// the vertices of triangle `t` are `tri_verts[tri_start[t]..tri_start[t + 1]]`.
    vt_pairs: Vec<(u32, u32)>,
    tri_start: Vec<u32>,
    tri_verts: Vec<u32>,
    cursor: Vec<u32>,
    /// Per chain vertex: hair direction ([`tangent`]), refreshed by `detect` and `apply`.
    tangents: Vec<Vector3<f64>>,
    /// Per link: box grown by half the reach, its low corner's cell, and unit direction
    /// (`detect`).
    seg_box: Vec<(Vector3<f64>, Vector3<f64>)>,
    seg_cell: Vec<[i64; 3]>,
    seg_dir: Vec<Vector3<f64>>,
    /// Per triangle: box grown by the reach, and hair direction (`detect`).
    tri_box: Vec<(Vector3<f64>, Vector3<f64>)>,
    tri_dir: Vec<Vector3<f64>>,
    /// Per triangle: its slab and edge planes (`detect`).
    tri_prism: Vec<Prism>,
    /// Per triangle: the guides of its two sides.
    tri_guides: Vec<[u32; 2]>,
    /// Per entry of `tri_entries`: its triangle's box grown by the reach, as `f32` rounded
    /// outwards (low x, y, z, high x, y, z), side by side for a vertex to test eight at once.
    ebox: [Vec<f32>; 6],
    /// The alive guides' vertices (roots left out) by grid cell (`detect`).
    vkeys: Vec<(u64, u32)>,
    /// The pieces' findings.
    chunks: Vec<Mutex<Chunk>>,
}

const BIAS: i64 = 1 << 20;

/// Pairs more aligned than this orientation factor (about 11°) are not candidates: their
/// repulsion would be almost zero (Eq. 3), and hair lying along hair is what the strips'
/// interpolation already stands for. This keeps the contact count to the crossings.
pub const MIN_CROSSING: f64 = 0.2;

fn cell_key(c: [i64; 3]) -> u64 {
    let m = (1u64 << 21) - 1;
    (((c[0] + BIAS) as u64 & m) << 42)
        | (((c[1] + BIAS) as u64 & m) << 21)
        | ((c[2] + BIAS) as u64 & m)
}

fn cell_of(p: &Vector3<f64>, h: f64) -> [i64; 3] {
    [floor(p.x / h), floor(p.y / h), floor(p.z / h)]
}

/// `t.floor() as i64` (saturating, NaN to 0) without a call into the maths library, which a
/// baseline x86-64 build makes of `floor`.
#[inline]
fn floor(t: f64) -> i64 {
    let i = t as i64;
    if (i as f64) > t {
        i.saturating_sub(1)
    } else {
        i
    }
}

impl Strips {
    /// Rebuilds the triangles of `pairs` (each strip: two triangles per segment); rest widths
    /// from `rest` (chain vertex → rest position), at least `min_width`.
    pub fn rebuild(
        &mut self,
        n: usize,
        pairs: &[(u32, u32)],
        rest: &[Vector3<f64>],
        min_width: f64,
    ) {
        self.pairs.clear();
        self.pairs.extend_from_slice(pairs);
        self.tri.clear();
        self.width_edge.clear();
        self.rest_width.clear();
        self.broken.clear();
        self.tri_guides.clear();
        for &(a, b) in pairs {
            let (va, vb) = (a as usize * (n + 1), b as usize * (n + 1));
            for i in 0..n {
                let (a0, a1, b0, b1) = (va + i, va + i + 1, vb + i, vb + i + 1);
                for (t, e) in [([a0, b0, a1], [a0, b0]), ([b0, b1, a1], [b1, a1])] {
                    self.tri.push(t.map(|v| v as u32));
                    self.width_edge.push(e.map(|v| v as u32));
                    self.rest_width
                        .push((rest[e[0]] - rest[e[1]]).norm().max(min_width));
                    self.broken.push(false);
                    self.tri_guides.push([a, b]);
                }
            }
        }
    }

    /// Marks triangles wider than `ratio` times their rest width as broken, the others as
    /// intact (§4.2: reversible). Returns the number broken.
    pub fn update_broken(&mut self, chains: &Chains, ratio: f64) -> usize {
        let mut count = 0;
        for t in 0..self.tri.len() {
            let [a, b] = self.width_edge[t];
            let w = (chains.x[a as usize] - chains.x[b as usize]).norm();
            self.broken[t] = w > ratio * self.rest_width[t];
            count += self.broken[t] as usize;
        }
        count
    }

    /// Broad phase: finds segment–segment pairs of different guides whose boxes, each grown
    /// by `reach / 2`, overlap, and vertex–triangle pairs (vertex not on the triangle's guides,
    /// triangle intact) that may be closer than `reach`; both only if they cross by at least
    /// [`MIN_CROSSING`]. `alive`: the guide slots simulated. On the calling thread.
    pub fn detect(&mut self, chains: &Chains, alive: &[usize], reach: f64) {
        self.detect_on(None, chains, alive, reach);
    }

    /// [`Strips::detect`] on the threads of `pool` (the same candidates in the same order).
    ///
    /// Every element's box, direction and grid cells are computed once. A vertex is tested
    /// only against the triangles whose box grown by `reach` holds it, and kept when it is
    /// within `reach` of the triangle's plane and of each edge's line on the triangle's outer
    /// side (the triangle's prism grown by `reach`): a test of four dot products that keeps
    /// every vertex closer than `reach` (the closest point lies on the triangle, inside every
    /// one of those planes) and a few more near the corners, which the sub-steps' exact test
    /// then turns down.
    pub fn detect_on(&mut self, pool: Option<&Pool>, chains: &Chains, alive: &[usize], reach: f64) {
        let n = chains.n;
        let h = chains.len.iter().cloned().fold(0.0, f64::max) + 2.0 * reach;
        self.entries.clear();
        self.tri_entries.clear();
        self.seg_pairs.clear();
        self.vt_pairs.clear();
        self.vkeys.clear();
        fill_tangents(chains, alive, &mut self.tangents);
        let links = chains.len.len();
        self.seg_box
            .resize(links, (Vector3::zeros(), Vector3::zeros()));
        self.seg_dir.resize(links, Vector3::zeros());
        self.seg_cell.resize(links, [0; 3]);
        self.tri_box
            .resize(self.tri.len(), (Vector3::zeros(), Vector3::zeros()));
        self.tri_dir.resize(self.tri.len(), Vector3::zeros());
        self.tri_prism.resize(self.tri.len(), Prism::default());
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
        for &g in alive {
            for i in 0..n {
                let l = g * n + i;
                let v = g * (n + 1) + i;
                let (p, q) = (chains.x[v], chains.x[v + 1]);
                let (lo, hi) = (p.inf(&q) - half, p.sup(&q) + half);
                self.seg_box[l] = (lo, hi);
                self.seg_cell[l] = cell_of(&lo, h);
                let t = q - p;
                self.seg_dir[l] = t / t.norm();
                push_cells(&mut self.entries, &lo, &hi, l as u32);
                let x = chains.x[v + 1];
                self.vkeys.push((cell_key(cell_of(&x, h)), (v + 1) as u32));
            }
        }
        let full = Vector3::repeat(reach);
        for t in 0..self.tri.len() {
            if self.broken[t] {
                continue;
            }
            let tp = self.tri[t].map(|v| chains.x[v as usize]);
            let [a, b, c] = tp;
            let (lo, hi) = (a.inf(&b).inf(&c) - full, a.sup(&b).sup(&c) + full);
            self.tri_box[t] = (lo, hi);
            let mut dir = Vector3::zeros();
            for w in self.tri[t] {
                dir += self.tangents[w as usize];
            }
            self.tri_dir[t] = dir.try_normalize(1e-12).unwrap_or_else(Vector3::y);
            self.tri_prism[t] = Prism::new(&tp);
            push_cells(&mut self.tri_entries, &lo, &hi, t as u32);
        }
        self.entries.sort_unstable();
        self.tri_entries.sort_unstable();
        self.vkeys.sort_unstable();
        for b in &mut self.ebox {
            b.clear();
        }
        for &(_, t) in &self.tri_entries {
            let (lo, hi) = self.tri_box[t as usize];
            for k in 0..3 {
                self.ebox[k].push(f32_down(lo[k]));
                self.ebox[k + 3].push(f32_up(hi[k]));
            }
        }
        if self.chunks.len() != CHUNKS {
            self.chunks = (0..CHUNKS).map(|_| Mutex::default()).collect();
        }
        let this = &*self;
        for_each_on(pool, CHUNKS, &|c| {
            let mut guard = this.chunks[c].lock().unwrap_or_else(|e| e.into_inner());
            let chunk = &mut *guard;
            chunk.seg.clear();
            chunk.vt.clear();
            this.seg_piece(c, n, &mut chunk.seg);
            this.vt_piece(c, chains, reach, &mut chunk.vt);
        });
        let mut chunks = std::mem::take(&mut self.chunks);
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            self.seg_pairs.extend_from_slice(&chunk.seg);
        }
        // Grouped by triangle (a counting sort), so a sub-step loads and prepares each triangle
        // once for all its vertices.
        self.tri_start.clear();
        self.tri_start.resize(self.tri.len() + 1, 0);
        let mut found = 0;
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            for &(_, t) in &chunk.vt {
                self.tri_start[t as usize + 1] += 1;
            }
            found += chunk.vt.len();
        }
        for t in 0..self.tri.len() {
            self.tri_start[t + 1] += self.tri_start[t];
        }
        self.tri_verts.clear();
        self.tri_verts.resize(found, 0);
        let mut cursor = std::mem::take(&mut self.cursor);
        cursor.clear();
        cursor.extend_from_slice(&self.tri_start[..self.tri.len()]);
        for m in &mut chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            for &(v, t) in &chunk.vt {
                self.tri_verts[cursor[t as usize] as usize] = v;
                cursor[t as usize] += 1;
            }
        }
        self.cursor = cursor;
        self.chunks = chunks;
        // Each triangle's vertices in index order, the order of a vertex-by-vertex search: the
        // order in which a sub-step adds their forces, whatever the cells made of it.
        for t in 0..self.tri.len() {
            self.tri_verts[self.tri_start[t] as usize..self.tri_start[t + 1] as usize]
                .sort_unstable();
        }
    }

    /// Piece `c` of the segment pairs: the cells whose runs start in its share of the sorted
    /// entries. Each pair is tested in the one cell holding the low corner of their boxes'
    /// overlap.
    fn seg_piece(&self, c: usize, n: usize, out: &mut Vec<(u32, u32)>) {
        let entries = &self.entries;
        let run_start = |i: usize| {
            let mut i = i.min(entries.len());
            while i > 0 && i < entries.len() && entries[i].0 == entries[i - 1].0 {
                i += 1;
            }
            i
        };
        let len = entries.len();
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
                for &(_, lb) in &entries[p + 1..e] {
                    let lb = lb as usize;
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
                        || orientation_scale(&self.seg_dir[la], &self.seg_dir[lb]) < MIN_CROSSING
                    {
                        continue;
                    }
                    out.push((la.min(lb) as u32, la.max(lb) as u32));
                }
            }
            s = e;
        }
    }

    /// Piece `c` of the vertex–triangle pairs: its share of the vertices sorted by cell. A
    /// vertex sits in one cell; each triangle is listed in every cell its box grown by `reach`
    /// touches, so every triangle within `reach` is listed there.
    fn vt_piece(&self, c: usize, chains: &Chains, reach: f64, out: &mut Vec<(u32, u32)>) {
        let n = chains.n;
        let len = self.vkeys.len();
        let far = reach * (1.0 + 1e-9);
        let mut key = u64::MAX;
        let (mut start, mut end) = (0, 0);
        let [lx, ly, lz, hx, hy, hz] = &self.ebox;
        let min2 = MIN_CROSSING * MIN_CROSSING;
        for &(k, v) in &self.vkeys[c * len / CHUNKS..(c + 1) * len / CHUNKS] {
            if k != key {
                key = k;
                start = self.tri_entries.partition_point(|e| e.0 < key);
                end = start + self.tri_entries[start..].partition_point(|e| e.0 == key);
            }
            let v = v as usize;
            let g = (v / (n + 1)) as u32;
            let x = chains.x[v];
            // Rounding to the nearest f32 keeps the order with the boxes' f32 bounds, which
            // are rounded outwards: no vertex inside a box falls out.
            let xf = [x.x as f32, x.y as f32, x.z as f32];
            let hair = self.tangents[v];
            let mut i = start;
            while i < end {
                // The box test of up to eight entries without a branch (a bit mask), then the
                // other tests on the boxes that hold the vertex.
                let m = (end - i).min(8);
                let mut mask = 0u32;
                for j in 0..m {
                    let q = i + j;
                    let inside = (xf[0] >= lx[q])
                        & (xf[1] >= ly[q])
                        & (xf[2] >= lz[q])
                        & (xf[0] <= hx[q])
                        & (xf[1] <= hy[q])
                        & (xf[2] <= hz[q]);
                    mask |= (inside as u32) << j;
                }
                while mask != 0 {
                    let j = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let t = self.tri_entries[i + j].1 as usize;
                    let [ga, gb] = self.tri_guides[t];
                    if ga == g
                        || gb == g
                        || hair.cross(&self.tri_dir[t]).norm_squared() < min2
                        || !self.tri_prism[t].near(&x, far)
                    {
                        continue;
                    }
                    out.push((v as u32, t as u32));
                }
                i += m;
            }
        }
    }

    /// Adds the contact forces of the candidates closer than `p.contact_distance` to the
    /// chains' vertex forces; returns how many are in contact. On the calling thread.
    pub fn apply(&mut self, chains: &mut Chains, p: &GuideParams) -> usize {
        self.apply_on(None, chains, p)
    }

    /// [`Strips::apply`] on the threads of `pool` (the same forces, added in the same order).
    /// Each candidate is first rejected cheaply when a bound on its distance (the triangle's
    /// box, then its prism; the segments' bounding spheres) is already past the threshold.
    pub fn apply_on(&mut self, pool: Option<&Pool>, chains: &mut Chains, p: &GuideParams) -> usize {
        fill_all_tangents(chains, &mut self.tangents);
        if self.chunks.len() != CHUNKS {
            self.chunks = (0..CHUNKS).map(|_| Mutex::default()).collect();
        }
        let this = &*self;
        let ch = &*chains;
        for_each_on(pool, CHUNKS, &|c| {
            let mut guard = this.chunks[c].lock().unwrap_or_else(|e| e.into_inner());
            let chunk = &mut *guard;
            chunk.tri_hits.clear();
            chunk.seg_hits.clear();
            chunk.count = 0;
            this.tri_contacts(c, ch, p, chunk);
            this.seg_contacts(c, ch, p, chunk);
        });
        // The forces, contact by contact in the order of one thread: the triangles' vertices,
        // then the segments'.
        let mut count = 0;
        let mut cur = u32::MAX;
        let mut tf = [Vector3::zeros(); 3];
        let mut td = [0.0; 3];
        let flush = |chains: &mut Chains, t: u32, tf: &[Vector3<f64>; 3], td: &[f64; 3]| {
            if t != u32::MAX {
                let tv = self.tri[t as usize];
                for k in 0..3 {
                    chains.f[tv[k] as usize] += tf[k];
                    chains.damp[tv[k] as usize] += td[k];
                }
            }
        };
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            count += chunk.count;
            for hit in &chunk.tri_hits {
                if hit.t != cur {
                    flush(chains, cur, &tf, &td);
                    cur = hit.t;
                    tf = [Vector3::zeros(); 3];
                    td = [0.0; 3];
                }
                let v = hit.v as usize;
                chains.f[v] += hit.f;
                chains.damp[v] += hit.cd;
                for k in 0..3 {
                    tf[k] -= hit.f * hit.bary[k];
                    td[k] += hit.cd * hit.bary[k];
                }
            }
        }
        flush(chains, cur, &tf, &td);
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            for hit in &chunk.seg_hits {
                let (va, vb, s, t, f, cd) = (
                    hit.va as usize,
                    hit.vb as usize,
                    hit.s,
                    hit.t,
                    hit.f,
                    hit.cd,
                );
                chains.f[va] += f * (1.0 - s);
                chains.f[va + 1] += f * s;
                chains.f[vb] -= f * (1.0 - t);
                chains.f[vb + 1] -= f * t;
                chains.damp[va] += cd * (1.0 - s);
                chains.damp[va + 1] += cd * s;
                chains.damp[vb] += cd * (1.0 - t);
                chains.damp[vb + 1] += cd * t;
            }
        }
        count
    }

    /// Piece `c` of a sub-step's vertex–triangle contacts: the triangles holding its share of
    /// the candidates.
    fn tri_contacts(&self, c: usize, chains: &Chains, p: &GuideParams, out: &mut Chunk) {
        let n = chains.n;
        let dc = p.contact_distance;
        // The bounds are exact to rounding; a relative slack keeps every pair the exact test
        // would accept.
        let far = dc * (1.0 + 1e-9);
        let tangents = &self.tangents;
        let total = self.tri_verts.len() as u32;
        let first = |c: usize| {
            let k = (c * total as usize / CHUNKS) as u32;
            self.tri_start[..self.tri.len()].partition_point(|&s| s < k)
        };
        for t in first(c)..first(c + 1) {
            let (start, end) = (self.tri_start[t] as usize, self.tri_start[t + 1] as usize);
            if start == end || self.broken[t] {
                continue;
            }
            let tv = self.tri[t].map(|w| w as usize);
            let tp = tv.map(|w| chains.x[w]);
            let pre = TrianglePre::new(&tp);
            let prism = Prism::new(&tp);
            let lo = tp[0].inf(&tp[1]).inf(&tp[2]) - Vector3::repeat(far);
            let hi = tp[0].sup(&tp[1]).sup(&tp[2]) + Vector3::repeat(far);
            let tt = tv.map(|w| tangents[w]);
            let tvel = tv.map(|w| chains.v[w]);
            let tsoft = chains.soft[tv[0]]
                .min(chains.soft[tv[1]])
                .min(chains.soft[tv[2]]);
            for &v in &self.tri_verts[start..end] {
                let v = v as usize;
                let x = chains.x[v];
                if x.x < lo.x || x.y < lo.y || x.z < lo.z || x.x > hi.x || x.y > hi.y || x.z > hi.z
                {
                    continue;
                }
                if !prism.near(&x, far) {
                    continue;
                }
                let (cp, bary) = pre.closest(&x);
                let d = (x - cp).norm();
                if d >= dc || d < 1e-9 {
                    continue;
                }
                out.count += 1;
                let nrm = (x - cp) / d;
                let hair = tangents[v];
                let mut dir = Vector3::zeros();
                let mut vt = Vector3::zeros();
                for k in 0..3 {
                    dir += tt[k] * bary[k];
                    vt += tvel[k] * bary[k];
                }
                let scale = orientation_scale(&hair, &dir.try_normalize(1e-12).unwrap_or(hair));
                let m = chains.m[link_of(v, n)];
                let soft = chains.soft[v].min(tsoft);
                let f = contact_force(chains.v[v] - vt, nrm, d, scale, m, p) * soft;
                let cd = damping_of(scale, m, p);
                out.tri_hits.push(TriHit {
                    t: t as u32,
                    v: v as u32,
                    f,
                    cd,
                    bary,
                });
            }
        }
    }

    /// Piece `c` of a sub-step's segment–segment contacts: its share of the candidates.
    fn seg_contacts(&self, c: usize, chains: &Chains, p: &GuideParams, out: &mut Chunk) {
        let n = chains.n;
        let dc = p.contact_distance;
        let far = dc * (1.0 + 1e-9);
        let len = self.seg_pairs.len();
        for &(la, lb) in &self.seg_pairs[c * len / CHUNKS..(c + 1) * len / CHUNKS] {
            let (la, lb) = (la as usize, lb as usize);
            let va = (la / n) * (n + 1) + la % n;
            let vb = (lb / n) * (n + 1) + lb % n;
            let (a0, a1, b0, b1) = (
                chains.x[va],
                chains.x[va + 1],
                chains.x[vb],
                chains.x[vb + 1],
            );
            // Every point of a segment is within half its length of its midpoint.
            let gap = ((a0 + a1) - (b0 + b1)).norm() * 0.5;
            if gap - 0.5 * (chains.len[la] + chains.len[lb]) > far {
                continue;
            }
            let (s, t) = closest_segments(&a0, &a1, &b0, &b1);
            let pa = a0.lerp(&a1, s);
            let pb = b0.lerp(&b1, t);
            let d = (pa - pb).norm();
            if d >= dc || d < 1e-9 {
                continue;
            }
            out.count += 1;
            let nrm = (pa - pb) / d;
            let ta = (a1 - a0) / chains.len[la];
            let tb = (b1 - b0) / chains.len[lb];
            let rel =
                chains.v[va].lerp(&chains.v[va + 1], s) - chains.v[vb].lerp(&chains.v[vb + 1], t);
            let m = chains.m[la].min(chains.m[lb]);
            let scale = orientation_scale(&ta, &tb);
            let soft = chains.soft[va]
                .min(chains.soft[va + 1])
                .min(chains.soft[vb])
                .min(chains.soft[vb + 1]);
            let f = contact_force(rel, nrm, d, scale, m, p) * soft;
            let cd = damping_of(scale, m, p);
            out.seg_hits.push(SegHit {
                va: va as u32,
                vb: vb as u32,
                s,
                t,
                f,
                cd,
            });
        }
    }

    /// Number of candidate pairs of the last broad phase.
    pub fn candidates(&self) -> usize {
        self.seg_pairs.len() + self.tri_verts.len()
    }

    /// Bytes held by the reused buffers.
    pub fn reserved_bytes(&self) -> usize {
        (self.entries.capacity() + self.tri_entries.capacity()) * 16
            + (self.seg_pairs.capacity() + self.vt_pairs.capacity()) * 8
            + (self.tri_start.capacity() + self.tri_verts.capacity() + self.cursor.capacity()) * 4
            + self.tangents.capacity() * 24
            + (self.seg_box.capacity() + self.tri_box.capacity()) * 48
            + self.seg_cell.capacity() * 24
            + (self.seg_dir.capacity() + self.tri_dir.capacity()) * 24
            + self.tri_prism.capacity() * std::mem::size_of::<Prism>()
            + self.tri_guides.capacity() * 8
            + self.vkeys.capacity() * 16
            + self.ebox.iter().map(|b| b.capacity() * 4).sum::<usize>()
            + self
                .chunks
                .iter()
                .map(|m| {
                    let c = m.lock().unwrap_or_else(|e| e.into_inner());
                    (c.seg.capacity() + c.vt.capacity()) * 8
                        + c.tri_hits.capacity() * std::mem::size_of::<TriHit>()
                        + c.seg_hits.capacity() * std::mem::size_of::<SegHit>()
                })
                .sum::<usize>()
    }
}

/// The contact force on the first element: a repulsive spring and a strong damping of the
/// approach along `nrm`, both scaled by the orientation factor and never pulling, plus viscous
/// friction on the tangential relative velocity `rel`.
fn contact_force(
    rel: Vector3<f64>,
    nrm: Vector3<f64>,
    d: f64,
    scale: f64,
    m: f64,
    p: &GuideParams,
) -> Vector3<f64> {
    let vn = rel.dot(&nrm);
    let fn_ = (scale * (p.contact_stiffness * (p.contact_distance - d) - p.contact_damping * vn))
        .max(0.0);
    let vt = rel - nrm * vn;
    (nrm * fn_ - vt * p.contact_friction) * m
}

/// The damping coefficient of a contact's force (normal damping and tangential friction),
/// N·s/m, for the implicit damping of [`Chains::integrate`].
fn damping_of(scale: f64, m: f64, p: &GuideParams) -> f64 {
    (scale * p.contact_damping + p.contact_friction) * m
}

/// The largest `f32` not above `x`.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest `f32` not below `x`.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

/// The link whose end is vertex `v` (the root's own link for a root).
fn link_of(v: usize, n: usize) -> usize {
    let g = v / (n + 1);
    let i = v % (n + 1);
    g * n + i.saturating_sub(1).min(n - 1)
}

/// [`tangent`] of every vertex of the guides in `alive` into `out` (sized to the chains).
fn fill_tangents(chains: &Chains, alive: &[usize], out: &mut Vec<Vector3<f64>>) {
    out.resize(chains.x.len(), Vector3::y());
    for &g in alive {
        for v in chains.verts(g) {
            out[v] = tangent(chains, v);
        }
    }
}

/// [`tangent`] of every vertex of the chains into `out`: the contacts of a sub-step only touch
/// alive guides, and a dead slot's vertices cost little.
fn fill_all_tangents(chains: &Chains, out: &mut Vec<Vector3<f64>>) {
    out.resize(chains.x.len(), Vector3::y());
    for (v, o) in out.iter_mut().enumerate() {
        *o = tangent(chains, v);
    }
}

/// Hair direction at vertex `v`: its incoming segment (the first segment at the root).
fn tangent(chains: &Chains, v: usize) -> Vector3<f64> {
    let n = chains.n;
    let i = v % (n + 1);
    let (a, b) = if i == 0 { (v, v + 1) } else { (v - 1, v) };
    (chains.x[b] - chains.x[a])
        .try_normalize(1e-12)
        .unwrap_or_else(Vector3::y)
}

/// Parameters `(s, t)` of the closest points of segments `p1p2` and `q1q2`: the AWT
/// collider's exact test (Ericson, *Real-Time Collision Detection*, §5.1.9), shared.
pub fn closest_segments(
    p1: &Vector3<f64>,
    p2: &Vector3<f64>,
    q1: &Vector3<f64>,
    q2: &Vector3<f64>,
) -> (f64, f64) {
    crate::solver::common::closest_segment_params(p1, p2, q1, q2)
}

/// The point of triangle `t` closest to `p`, and its barycentric weights (Ericson, §5.1.5).
pub fn closest_on_triangle(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> (Vector3<f64>, [f64; 3]) {
    TrianglePre::new(t).closest(p)
}

/// A triangle's plane and the planes through its edges perpendicular to it, facing out: a
/// point closer than `r` to the triangle is closer than `r` to its plane and less than `r`
/// outside each edge plane (its closest point lies on the triangle, inside them all).
#[derive(Debug, Clone, Copy, Default)]
struct Prism {
    n: Vector3<f64>,
    d: f64,
    e: [Vector3<f64>; 3],
    c: [f64; 3],
    /// Too thin to have a trusted normal: every point passes.
    flat: bool,
}

impl Prism {
    fn new(t: &[Vector3<f64>; 3]) -> Prism {
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

    /// False only if `x` is at least `r` from the triangle.
    #[inline]
    fn near(&self, x: &Vector3<f64>, r: f64) -> bool {
        self.flat
            || ((self.n.dot(x) - self.d).abs() < r
                && self.e[0].dot(x) - self.c[0] < r
                && self.e[1].dot(x) - self.c[1] < r
                && self.e[2].dot(x) - self.c[2] < r)
    }
}

/// A triangle's corners and edges from its first corner, for many closest-point queries.
struct TrianglePre {
    a: Vector3<f64>,
    b: Vector3<f64>,
    c: Vector3<f64>,
    ab: Vector3<f64>,
    ac: Vector3<f64>,
}

impl TrianglePre {
    #[inline]
    fn new(t: &[Vector3<f64>; 3]) -> TrianglePre {
        let (a, b, c) = (t[0], t[1], t[2]);
        TrianglePre {
            a,
            b,
            c,
            ab: b - a,
            ac: c - a,
        }
    }

    /// [`closest_on_triangle`].
    #[inline]
    fn closest(&self, p: &Vector3<f64>) -> (Vector3<f64>, [f64; 3]) {
        let TrianglePre { a, b, c, ab, ac } = *self;
        let ap = p - a;
        let d1 = ab.dot(&ap);
        let d2 = ac.dot(&ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return (a, [1.0, 0.0, 0.0]);
        }
        let bp = p - b;
        let d3 = ab.dot(&bp);
        let d4 = ac.dot(&bp);
        if d3 >= 0.0 && d4 <= d3 {
            return (b, [0.0, 1.0, 0.0]);
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            return (a + ab * v, [1.0 - v, v, 0.0]);
        }
        let cp = p - c;
        let d5 = ab.dot(&cp);
        let d6 = ac.dot(&cp);
        if d6 >= 0.0 && d5 <= d6 {
            return (c, [0.0, 0.0, 1.0]);
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            return (a + ac * w, [1.0 - w, 0.0, w]);
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            return (b + (c - b) * w, [0.0, 1.0 - w, w]);
        }
        let denom = 1.0 / (va + vb + vc);
        let v = vb * denom;
        let w = vc * denom;
        (a + ab * v + ac * w, [1.0 - v - w, v, w])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (the tests need no statistics, only variety).
    struct Lcg(u64);

    impl Lcg {
        fn unit(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn vec(&mut self, scale: f64) -> Vector3<f64> {
            Vector3::new(self.unit(), self.unit(), self.unit()).map(|c| (c - 0.5) * scale)
        }
    }

    /// `guides` random zig-zag guides of `n` links crowded in a few centimetres, every pair of
    /// consecutive guides joined by a strip, moving at random velocities.
    fn tangle(seed: u64, guides: usize, n: usize) -> (Chains, Strips) {
        let mut rng = Lcg(seed);
        let mut c = Chains::new(n, guides);
        for g in 0..guides {
            let mut p = rng.vec(0.04);
            let mut pts = vec![p];
            for _ in 0..n {
                p += rng.vec(0.02);
                pts.push(p);
            }
            c.init_guide(g, &pts, 0.01, (0.0, 1.0, 0.0));
            for (i, q) in pts.iter().enumerate() {
                c.x[g * (n + 1) + i] = *q;
                c.v[g * (n + 1) + i] = rng.vec(1.0);
            }
        }
        let pairs: Vec<(u32, u32)> = (1..guides as u32).map(|g| (g - 1, g)).collect();
        let mut s = Strips::default();
        s.rebuild(n, &pairs, &c.x.clone(), 0.001);
        (c, s)
    }

    /// The vertex–triangle candidates of the last broad phase, as (vertex, triangle).
    fn vt_set(s: &Strips) -> std::collections::BTreeSet<(u32, u32)> {
        let mut out = std::collections::BTreeSet::new();
        for t in 0..s.tri.len() {
            for &v in &s.tri_verts[s.tri_start[t] as usize..s.tri_start[t + 1] as usize] {
                out.insert((v, t as u32));
            }
        }
        out
    }

    #[test]
    fn floor_is_the_library_floor() {
        for t in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999,
            -2.999,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            4.5e15,
            -4.5e15,
        ] {
            assert_eq!(floor(t), t.floor() as i64, "{t}");
        }
        let mut rng = Lcg(3);
        for _ in 0..10_000 {
            let t = (rng.unit() - 0.5) * 100.0;
            assert_eq!(floor(t), t.floor() as i64, "{t}");
        }
    }

    #[test]
    fn prism_keeps_every_point_closer_than_the_reach() {
        let mut rng = Lcg(7);
        let mut rejected = 0;
        for _ in 0..20_000 {
            let t = [rng.vec(0.03), rng.vec(0.03), rng.vec(0.03)];
            let x = rng.vec(0.06);
            let r = 0.002 + 0.01 * rng.unit();
            let (cp, _) = closest_on_triangle(&x, &t);
            let near = Prism::new(&t).near(&x, r);
            if (x - cp).norm() < r {
                assert!(near, "{x:?} is {} from {t:?}, reach {r}", (x - cp).norm());
            }
            rejected += !near as usize;
        }
        // It is a filter: most random points are turned down.
        assert!(rejected > 10_000, "{rejected}");
        // A flat (collinear) triangle lets every point through to the exact test.
        let line = [Vector3::zeros(), Vector3::x(), Vector3::x() * 2.0];
        assert!(Prism::new(&line).near(&Vector3::y(), 1e-3));
    }

    /// The broad phase keeps every vertex–triangle pair closer than the reach that the
    /// contacts could need (vertex off the triangle's guides, crossing it), and every crossing
    /// segment pair closer than the reach, whatever the grid makes of them.
    #[test]
    fn broad_phase_finds_every_pair_within_the_reach() {
        for seed in 1..6 {
            let (c, mut s) = tangle(seed, 12, 6);
            let alive: Vec<usize> = (0..12).collect();
            for reach in [0.002, 0.006, 0.012, 0.03] {
                s.detect(&c, &alive, reach);
                let found = vt_set(&s);
                let n = c.n;
                let mut tangents = Vec::new();
                fill_all_tangents(&c, &mut tangents);
                let mut exact = 0;
                for v in 0..c.x.len() {
                    if v % (n + 1) == 0 {
                        continue;
                    }
                    for (t, tv) in s.tri.iter().enumerate() {
                        let tp = tv.map(|w| c.x[w as usize]);
                        let (cp, _) = closest_on_triangle(&c.x[v], &tp);
                        let dir = tv
                            .iter()
                            .map(|&w| tangents[w as usize])
                            .sum::<Vector3<f64>>();
                        let dir = dir.normalize();
                        let own = tv.iter().any(|&w| w as usize / (n + 1) == v / (n + 1));
                        let crossing = tangents[v].cross(&dir).norm() >= MIN_CROSSING * 1.001;
                        if (c.x[v] - cp).norm() < reach && !own && crossing {
                            exact += 1;
                            assert!(
                                found.contains(&(v as u32, t as u32)),
                                "seed {seed} reach {reach}: vertex {v} triangle {t} missed"
                            );
                        }
                    }
                }
                if reach >= 0.012 {
                    assert!(exact > 20, "seed {seed} reach {reach}: only {exact} pairs");
                }
                let segs: std::collections::BTreeSet<_> = s.seg_pairs.iter().copied().collect();
                for la in 0..c.len.len() {
                    for lb in la + 1..c.len.len() {
                        if la / n == lb / n {
                            continue;
                        }
                        let va = la / n * (n + 1) + la % n;
                        let vb = lb / n * (n + 1) + lb % n;
                        let (a0, a1, b0, b1) = (c.x[va], c.x[va + 1], c.x[vb], c.x[vb + 1]);
                        let (p, q) = closest_segments(&a0, &a1, &b0, &b1);
                        let d = (a0.lerp(&a1, p) - b0.lerp(&b1, q)).norm();
                        let cross =
                            orientation_scale(&(a1 - a0).normalize(), &(b1 - b0).normalize());
                        if d < reach && cross >= MIN_CROSSING * 1.001 {
                            assert!(
                                segs.contains(&(la as u32, lb as u32)),
                                "seed {seed}: {la} {lb}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// On a pool of two threads the broad phase lists the same candidates in the same order,
    /// and a sub-step adds the same forces, bit for bit, as on the calling thread alone.
    #[test]
    fn two_threads_give_the_same_candidates_and_forces() {
        let pool = Pool::new(2).unwrap();
        let p = GuideParams {
            contact_distance: 0.008,
            ..GuideParams::default()
        };
        for seed in 1..4 {
            let (c, mut one) = tangle(seed, 16, 8);
            let (_, mut two) = tangle(seed, 16, 8);
            let alive: Vec<usize> = (0..16).collect();
            one.detect_on(None, &c, &alive, 2.0 * p.contact_distance);
            two.detect_on(Some(&pool), &c, &alive, 2.0 * p.contact_distance);
            assert_eq!(one.seg_pairs, two.seg_pairs);
            assert_eq!(one.tri_start, two.tri_start);
            assert_eq!(one.tri_verts, two.tri_verts);
            let (mut ca, mut cb) = (c.clone(), c.clone());
            let na = one.apply_on(None, &mut ca, &p);
            let nb = two.apply_on(Some(&pool), &mut cb, &p);
            assert_eq!(na, nb);
            assert!(na > 10, "seed {seed}: {na} contacts");
            let bits = |c: &Chains| {
                let f = c.f.iter().flat_map(|v| v.iter().map(|x| x.to_bits()));
                f.chain(c.damp.iter().map(|x| x.to_bits()))
                    .collect::<Vec<u64>>()
            };
            assert_eq!(bits(&ca), bits(&cb), "seed {seed}");
        }
    }
}
