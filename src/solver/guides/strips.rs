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

/// One candidate contact: segment–segment (links `a`, `b`) or vertex `a` – triangle `b`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    tri: bool,
    a: u32,
    b: u32,
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
    candidates: Vec<Candidate>,
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

    /// Broad phase: finds segment–segment pairs of different guides and vertex–triangle pairs
    /// (vertex not on the triangle's guides, triangle intact) closer than `reach`. `alive`:
    /// the guide slots simulated.
    pub fn detect(&mut self, chains: &Chains, alive: &[usize], reach: f64) {
        let n = chains.n;
        let h = chains.len.iter().cloned().fold(0.0, f64::max) + 2.0 * reach;
        self.entries.clear();
        self.tri_entries.clear();
        self.candidates.clear();
        let boxes = |pts: &[Vector3<f64>]| {
            let mut lo = pts[0];
            let mut hi = pts[0];
            for p in &pts[1..] {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let r = Vector3::repeat(reach * 0.5);
            (lo - r, hi + r)
        };
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
                let v = g * (n + 1) + i;
                let (lo, hi) = boxes(&[chains.x[v], chains.x[v + 1]]);
                push_cells(&mut self.entries, &lo, &hi, (g * n + i) as u32);
            }
        }
        for t in 0..self.tri.len() {
            if self.broken[t] {
                continue;
            }
            let [a, b, c] = self.tri[t].map(|v| chains.x[v as usize]);
            let (lo, hi) = boxes(&[a, b, c]);
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
                for q in p + 1..e {
                    let (la, lb) = (self.entries[p].1 as usize, self.entries[q].1 as usize);
                    if la / n == lb / n {
                        continue;
                    }
                    let va = (la / n) * (n + 1) + la % n;
                    let vb = (lb / n) * (n + 1) + lb % n;
                    let (alo, ahi) = boxes(&[chains.x[va], chains.x[va + 1]]);
                    let (blo, bhi) = boxes(&[chains.x[vb], chains.x[vb + 1]]);
                    let lo = alo.sup(&blo);
                    let hi = ahi.inf(&bhi);
                    if lo.x > hi.x || lo.y > hi.y || lo.z > hi.z || cell_key(cell_of(&lo, h)) != key
                    {
                        continue;
                    }
                    let ta = chains.x[va + 1] - chains.x[va];
                    let tb = chains.x[vb + 1] - chains.x[vb];
                    if orientation_scale(&(ta / ta.norm()), &(tb / tb.norm())) < MIN_CROSSING {
                        continue;
                    }
                    self.candidates.push(Candidate {
                        tri: false,
                        a: la.min(lb) as u32,
                        b: la.max(lb) as u32,
                    });
                }
            }
            s = e;
        }
        // Vertex–triangle: a vertex sits in one cell; each triangle is listed once per cell.
        for &g in alive {
            for i in 1..=n {
                let v = g * (n + 1) + i;
                let key = cell_key(cell_of(&chains.x[v], h));
                let start = self.tri_entries.partition_point(|e| e.0 < key);
                for e in &self.tri_entries[start..] {
                    if e.0 != key {
                        break;
                    }
                    let t = e.1 as usize;
                    let tv = self.tri[t];
                    if tv.iter().any(|&w| w as usize / (n + 1) == g) {
                        continue;
                    }
                    let (c, _) =
                        closest_on_triangle(&chains.x[v], &tv.map(|w| chains.x[w as usize]));
                    let mut dir = Vector3::zeros();
                    for w in tv {
                        dir += tangent(chains, w as usize);
                    }
                    let dir = dir.try_normalize(1e-12).unwrap_or_else(Vector3::y);
                    if (c - chains.x[v]).norm() < reach
                        && orientation_scale(&tangent(chains, v), &dir) >= MIN_CROSSING
                    {
                        self.candidates.push(Candidate {
                            tri: true,
                            a: v as u32,
                            b: t as u32,
                        });
                    }
                }
            }
        }
    }

    /// Adds the contact forces of the candidates closer than `p.contact_distance` to the
    /// chains' vertex forces; returns how many are in contact.
    pub fn apply(&self, chains: &mut Chains, p: &GuideParams) -> usize {
        let n = chains.n;
        let dc = p.contact_distance;
        let mut count = 0;
        for c in &self.candidates {
            if c.tri {
                let v = c.a as usize;
                let t = c.b as usize;
                if self.broken[t] {
                    continue;
                }
                let tv = self.tri[t].map(|w| w as usize);
                let (cp, bary) = closest_on_triangle(&chains.x[v], &tv.map(|w| chains.x[w]));
                let d = (chains.x[v] - cp).norm();
                if d >= dc || d < 1e-9 {
                    continue;
                }
                count += 1;
                let nrm = (chains.x[v] - cp) / d;
                let hair = tangent(chains, v);
                let mut dir = Vector3::zeros();
                let mut vt = Vector3::zeros();
                for k in 0..3 {
                    dir += tangent(chains, tv[k]) * bary[k];
                    vt += chains.v[tv[k]] * bary[k];
                }
                let scale = orientation_scale(&hair, &dir.try_normalize(1e-12).unwrap_or(hair));
                let m = chains.m[link_of(v, n)];
                let soft = tv
                    .iter()
                    .fold(chains.soft[v], |a, &w| a.min(chains.soft[w]));
                let f = contact_force(chains.v[v] - vt, nrm, d, scale, m, p) * soft;
                let cd = damping_of(scale, m, p);
                chains.f[v] += f;
                chains.damp[v] += cd;
                for k in 0..3 {
                    chains.f[tv[k]] -= f * bary[k];
                    chains.damp[tv[k]] += cd * bary[k];
                }
            } else {
                let (la, lb) = (c.a as usize, c.b as usize);
                let va = (la / n) * (n + 1) + la % n;
                let vb = (lb / n) * (n + 1) + lb % n;
                let (s, t) = closest_segments(
                    &chains.x[va],
                    &chains.x[va + 1],
                    &chains.x[vb],
                    &chains.x[vb + 1],
                );
                let pa = chains.x[va].lerp(&chains.x[va + 1], s);
                let pb = chains.x[vb].lerp(&chains.x[vb + 1], t);
                let d = (pa - pb).norm();
                if d >= dc || d < 1e-9 {
                    continue;
                }
                count += 1;
                let nrm = (pa - pb) / d;
                let ta = (chains.x[va + 1] - chains.x[va]) / chains.len[la];
                let tb = (chains.x[vb + 1] - chains.x[vb]) / chains.len[lb];
                let rel = chains.v[va].lerp(&chains.v[va + 1], s)
                    - chains.v[vb].lerp(&chains.v[vb + 1], t);
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
        }
        count
    }

    /// Number of candidate pairs of the last broad phase.
    pub fn candidates(&self) -> usize {
        self.candidates.len()
    }

    /// Bytes held by the reused buffers.
    pub fn reserved_bytes(&self) -> usize {
        (self.entries.capacity() + self.tri_entries.capacity()) * 16
            + self.candidates.capacity() * 12
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
    let (a, b, c) = (t[0], t[1], t[2]);
    let ab = b - a;
    let ac = c - a;
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
