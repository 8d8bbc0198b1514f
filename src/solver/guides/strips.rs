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

use nalgebra::Vector3;

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

/// The strips' triangles and the contact machinery.
#[derive(Debug, Clone, Default)]
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
    /// Per link: box grown by half the reach, and unit direction (`detect`).
    seg_box: Vec<(Vector3<f64>, Vector3<f64>)>,
    seg_dir: Vec<Vector3<f64>>,
    /// Per triangle: box grown by the reach, and hair direction (`detect`).
    tri_box: Vec<(Vector3<f64>, Vector3<f64>)>,
    tri_dir: Vec<Vector3<f64>>,
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
    [
        (p.x / h).floor() as i64,
        (p.y / h).floor() as i64,
        (p.z / h).floor() as i64,
    ]
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
    /// triangle intact) closer than `reach`; both only if they cross by at least
    /// [`MIN_CROSSING`]. `alive`: the guide slots simulated.
    ///
    /// Every element's box, direction and grid cells are computed once; a vertex is tested
    /// exactly only against the triangles whose box grown by `reach` holds it.
    pub fn detect(&mut self, chains: &Chains, alive: &[usize], reach: f64) {
        let n = chains.n;
        let h = chains.len.iter().cloned().fold(0.0, f64::max) + 2.0 * reach;
        self.entries.clear();
        self.tri_entries.clear();
        self.seg_pairs.clear();
        self.vt_pairs.clear();
        fill_tangents(chains, alive, &mut self.tangents);
        let links = chains.len.len();
        self.seg_box
            .resize(links, (Vector3::zeros(), Vector3::zeros()));
        self.seg_dir.resize(links, Vector3::zeros());
        self.tri_box
            .resize(self.tri.len(), (Vector3::zeros(), Vector3::zeros()));
        self.tri_dir.resize(self.tri.len(), Vector3::zeros());
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
                let t = q - p;
                self.seg_dir[l] = t / t.norm();
                push_cells(&mut self.entries, &lo, &hi, l as u32);
            }
        }
        let full = Vector3::repeat(reach);
        for t in 0..self.tri.len() {
            if self.broken[t] {
                continue;
            }
            let [a, b, c] = self.tri[t].map(|v| chains.x[v as usize]);
            let (lo, hi) = (a.inf(&b).inf(&c) - full, a.sup(&b).sup(&c) + full);
            self.tri_box[t] = (lo, hi);
            let mut dir = Vector3::zeros();
            for w in self.tri[t] {
                dir += self.tangents[w as usize];
            }
            self.tri_dir[t] = dir.try_normalize(1e-12).unwrap_or_else(Vector3::y);
            push_cells(&mut self.tri_entries, &lo, &hi, t as u32);
        }
        self.entries.sort_unstable();
        self.tri_entries.sort_unstable();

        // Segment pairs: tested in the one cell holding the low corner of their boxes' overlap.
        let mut s = 0;
        while s < self.entries.len() {
            let key = self.entries[s].0;
            let mut e = s;
            while e < self.entries.len() && self.entries[e].0 == key {
                e += 1;
            }
            for p in s..e {
                let la = self.entries[p].1 as usize;
                let (alo, ahi) = self.seg_box[la];
                for q in p + 1..e {
                    let lb = self.entries[q].1 as usize;
                    let (blo, bhi) = self.seg_box[lb];
                    let lo = alo.sup(&blo);
                    let hi = ahi.inf(&bhi);
                    if lo.x > hi.x || lo.y > hi.y || lo.z > hi.z || la / n == lb / n {
                        continue;
                    }
                    if cell_key(cell_of(&lo, h)) != key
                        || orientation_scale(&self.seg_dir[la], &self.seg_dir[lb]) < MIN_CROSSING
                    {
                        continue;
                    }
                    self.seg_pairs.push((la.min(lb) as u32, la.max(lb) as u32));
                }
            }
            s = e;
        }
        // Vertex–triangle: a vertex sits in one cell; each triangle is listed in every cell its
        // box grown by `reach` touches, so every triangle within `reach` is listed there.
        for &g in alive {
            for i in 1..=n {
                let v = g * (n + 1) + i;
                let x = chains.x[v];
                let key = cell_key(cell_of(&x, h));
                let start = self.tri_entries.partition_point(|e| e.0 < key);
                for e in &self.tri_entries[start..] {
                    if e.0 != key {
                        break;
                    }
                    let t = e.1 as usize;
                    let (lo, hi) = self.tri_box[t];
                    if x.x < lo.x
                        || x.y < lo.y
                        || x.z < lo.z
                        || x.x > hi.x
                        || x.y > hi.y
                        || x.z > hi.z
                    {
                        continue;
                    }
                    let tv = self.tri[t];
                    if tv.iter().any(|&w| w as usize / (n + 1) == g)
                        || orientation_scale(&self.tangents[v], &self.tri_dir[t]) < MIN_CROSSING
                    {
                        continue;
                    }
                    let (c, _) = closest_on_triangle(&x, &tv.map(|w| chains.x[w as usize]));
                    if (c - x).norm() < reach {
                        self.vt_pairs.push((v as u32, t as u32));
                    }
                }
            }
        }
        // Grouped by triangle (a counting sort, stable: each triangle's vertices in the order
        // found), so a sub-step loads and prepares each triangle once for all its vertices.
        self.tri_start.clear();
        self.tri_start.resize(self.tri.len() + 1, 0);
        for &(_, t) in &self.vt_pairs {
            self.tri_start[t as usize + 1] += 1;
        }
        for t in 0..self.tri.len() {
            self.tri_start[t + 1] += self.tri_start[t];
        }
        self.tri_verts.clear();
        self.tri_verts.resize(self.vt_pairs.len(), 0);
        let mut cursor = std::mem::take(&mut self.cursor);
        cursor.clear();
        cursor.extend_from_slice(&self.tri_start[..self.tri.len()]);
        for &(v, t) in &self.vt_pairs {
            self.tri_verts[cursor[t as usize] as usize] = v;
            cursor[t as usize] += 1;
        }
        self.cursor = cursor;
    }

    /// Adds the contact forces of the candidates closer than `p.contact_distance` to the
    /// chains' vertex forces; returns how many are in contact. Each candidate is first
    /// rejected cheaply when a bound on its distance (the triangle's box; the segments'
    /// bounding spheres) is already past the threshold.
    pub fn apply(&mut self, chains: &mut Chains, p: &GuideParams) -> usize {
        let n = chains.n;
        let dc = p.contact_distance;
        // The spheres' bound is exact to rounding; a relative slack keeps every pair the exact
        // test would accept.
        let far = dc * (1.0 + 1e-9);
        let mut count = 0;
        fill_all_tangents(chains, &mut self.tangents);
        let tangents = &self.tangents;
        for t in 0..self.tri.len() {
            let (start, end) = (self.tri_start[t] as usize, self.tri_start[t + 1] as usize);
            if start == end || self.broken[t] {
                continue;
            }
            let tv = self.tri[t].map(|w| w as usize);
            let tp = tv.map(|w| chains.x[w]);
            let pre = TrianglePre::new(&tp);
            let lo = tp[0].inf(&tp[1]).inf(&tp[2]) - Vector3::repeat(far);
            let hi = tp[0].sup(&tp[1]).sup(&tp[2]) + Vector3::repeat(far);
            let tt = tv.map(|w| tangents[w]);
            let tvel = tv.map(|w| chains.v[w]);
            let tsoft = chains.soft[tv[0]]
                .min(chains.soft[tv[1]])
                .min(chains.soft[tv[2]]);
            // The triangle's share, added to its vertices after its last contact.
            let mut tf = [Vector3::zeros(); 3];
            let mut td = [0.0; 3];
            for &v in &self.tri_verts[start..end] {
                let v = v as usize;
                let x = chains.x[v];
                if x.x < lo.x || x.y < lo.y || x.z < lo.z || x.x > hi.x || x.y > hi.y || x.z > hi.z
                {
                    continue;
                }
                let (cp, bary) = pre.closest(&x);
                let d = (x - cp).norm();
                if d >= dc || d < 1e-9 {
                    continue;
                }
                count += 1;
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
                chains.f[v] += f;
                chains.damp[v] += cd;
                for k in 0..3 {
                    tf[k] -= f * bary[k];
                    td[k] += cd * bary[k];
                }
            }
            for k in 0..3 {
                chains.f[tv[k]] += tf[k];
                chains.damp[tv[k]] += td[k];
            }
        }
        for &(la, lb) in &self.seg_pairs {
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
            count += 1;
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
            chains.f[va] += f * (1.0 - s);
            chains.f[va + 1] += f * s;
            chains.f[vb] -= f * (1.0 - t);
            chains.f[vb + 1] -= f * t;
            chains.damp[va] += cd * (1.0 - s);
            chains.damp[va + 1] += cd * s;
            chains.damp[vb] += cd * (1.0 - t);
            chains.damp[vb + 1] += cd * t;
        }
        count
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
            + (self.seg_dir.capacity() + self.tri_dir.capacity()) * 24
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
    crate::solver::awt::collide::closest_segment_params(p1, p2, q1, q2)
}

/// The point of triangle `t` closest to `p`, and its barycentric weights (Ericson, §5.1.5).
pub fn closest_on_triangle(p: &Vector3<f64>, t: &[Vector3<f64>; 3]) -> (Vector3<f64>, [f64; 3]) {
    TrianglePre::new(t).closest(p)
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
