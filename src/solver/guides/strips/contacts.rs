//! Each sub-step's contact forces of the strips' candidates (Chang, Jin, Yu 2002, §4.2, Eq. 3):
//! a strongly damped repulsive spring scaled by the crossing, and viscous friction.

use super::*;
use crate::simd::dispatch::multiversion;

impl Strips {
    /// Evaluates the contacts of the candidates closer than `p.contact_distance` and adds their
    /// damping coefficients to the chains' `damp`; returns how many are in contact. Their
    /// forces wait for [`Strips::add_forces`], once the sub-step's damping is all known. On
    /// the calling thread.
    pub fn evaluate(&mut self, chains: &mut Chains, p: &GuideParams) -> usize {
        self.evaluate_on(None, chains, p)
    }

    /// [`Strips::evaluate`] on the threads of `pool` (the same contacts, in the same order).
    /// Each candidate is first rejected cheaply when a bound on its distance (the triangle's
    /// box, then its prism; the segments' bounding spheres) is already past the threshold.
    pub fn evaluate_on(
        &mut self,
        pool: Option<&Pool>,
        chains: &mut Chains,
        p: &GuideParams,
    ) -> usize {
        if self.chunks.len() != CHUNKS {
            self.chunks = (0..CHUNKS).map(|_| Mutex::default()).collect();
        }
        self.pieces_on(pool, chains, p, contacts_piece)
    }

    /// Runs `piece` on each of the [`CHUNKS`] pieces (on the threads of `pool`), with the
    /// tangents refreshed first, then adds their damping in piece order; returns the contacts.
    fn pieces_on(
        &mut self,
        pool: Option<&Pool>,
        chains: &mut Chains,
        p: &GuideParams,
        piece: fn(Level, &Strips, usize, &Chains, &GuideParams, &mut Chunk),
    ) -> usize {
        fill_all_tangents(chains, &mut self.tangents);
        let this = &*self;
        let ch = &*chains;
        let level = self.level();
        for_each_on(pool, CHUNKS, &|c| {
            let mut guard = this.chunks[c].lock().unwrap_or_else(|e| e.into_inner());
            piece(level, this, c, ch, p, &mut guard);
        });
        self.add_damping(chains)
    }

    /// The broad phase and the contacts of a step of one sub-step at once: the candidates are
    /// searched within the contact distance (with a rounding slack) on the very positions the
    /// contacts are evaluated on, so each piece evaluates its candidates as it finds them
    /// instead of listing them for [`Strips::evaluate_on`]: the same contacts in the same
    /// order, bit for bit, as [`Strips::detect_on`] then [`Strips::evaluate_on`] with that
    /// reach. Adds their damping; returns how many are in contact.
    pub fn detect_evaluate_on(
        &mut self,
        pool: Option<&Pool>,
        chains: &mut Chains,
        alive: &[usize],
        p: &GuideParams,
    ) -> usize {
        let reach = p.contact_distance * (1.0 + 1e-6);
        let n = chains.n;
        fill_all_tangents(chains, &mut self.tangents);
        self.prepare(pool, chains, alive, reach);
        self.seg_pairs.clear();
        self.vt_pairs.clear();
        self.tri_verts.clear();
        self.tri_start.clear();
        let this = &*self;
        let ch = &*chains;
        let level = self.level();
        for_each_on(pool, CHUNKS, &|c| {
            let mut guard = this.chunks[c].lock().unwrap_or_else(|e| e.into_inner());
            search_contacts_piece(level, this, c, n, ch, p, reach, &mut guard);
        });
        self.found = self
            .chunks
            .iter_mut()
            .map(|m| {
                let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
                chunk.vt.len() + chunk.seg.len()
            })
            .sum();
        self.add_damping(chains)
    }

    /// The contacts of the last search ([`Strips::detect_evaluate_on`]), evaluated again on the
    /// chains' current positions and velocities without a search: each piece takes the pairs
    /// it found in contact last time (a triangle's vertices, a pair of links) and keeps those
    /// still within the contact distance, with forces from the current state, in the same
    /// order. A pair that has come into contact since waits for the next search (and one whose
    /// elements no longer cross by `MIN_CROSSING`, which the search asks of a new pair, keeps
    /// its contact until then); a pair whose triangle was rebuilt away ([`Strips::rebuild`]
    /// carries the others over) or whose guide was removed is dropped, and a broken triangle is
    /// skipped as the search skips it. Before any search there is nothing to evaluate. Adds
    /// their damping; returns how many are in contact.
    pub fn reevaluate_on(
        &mut self,
        pool: Option<&Pool>,
        chains: &mut Chains,
        p: &GuideParams,
    ) -> usize {
        if self.chunks.len() != CHUNKS {
            return 0;
        }
        self.pieces_on(pool, chains, p, reapply_piece)
    }

    /// Adds the damping coefficients of the pieces' contacts to the chains' `damp`, contact by
    /// contact in the order of one thread: the triangles' vertices, then the segments'.
    /// Returns the contacts.
    fn add_damping(&self, chains: &mut Chains) -> usize {
        let mut count = 0;
        // A triangle's share is summed over its contacts, then added to its vertices.
        let mut cur = u32::MAX;
        let mut td = [0.0; 3];
        let flush = |chains: &mut Chains, t: u32, td: &[f64; 3]| {
            if t != u32::MAX {
                let tv = self.tri[t as usize];
                for k in 0..3 {
                    chains.damp[tv[k] as usize] += td[k];
                }
            }
        };
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            count += chunk.count;
            for hit in &chunk.tri_hits {
                if hit.t != cur {
                    flush(chains, cur, &td);
                    cur = hit.t;
                    td = [0.0; 3];
                }
                chains.damp[hit.v as usize] += hit.cd;
                for (d, b) in td.iter_mut().zip(hit.bary) {
                    *d += hit.cd * b;
                }
            }
        }
        flush(chains, cur, &td);
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            for hit in &chunk.seg_hits {
                let (va, vb, s, t, cd) = (hit.va as usize, hit.vb as usize, hit.s, hit.t, hit.cd);
                chains.damp[va] += cd * (1.0 - s);
                chains.damp[va + 1] += cd * s;
                chains.damp[vb] += cd * (1.0 - t);
                chains.damp[vb + 1] += cd * t;
            }
        }
        count
    }

    /// Adds the forces of the contacts last evaluated to the chains' vertex forces, each
    /// scaled by the smallest backward-Euler factor (`Chains::soft`, from this sub-step's
    /// damping) of the vertices it acts on, so that action and reaction stay equal; contact by
    /// contact in the order of one thread: the triangles' vertices, then the segments'.
    pub fn add_forces(&self, chains: &mut Chains) {
        let mut cur = u32::MAX;
        let mut tf = [Vector3::zeros(); 3];
        let flush = |chains: &mut Chains, t: u32, tf: &[Vector3<f64>; 3]| {
            if t != u32::MAX {
                let tv = self.tri[t as usize];
                for k in 0..3 {
                    chains.f[tv[k] as usize] += tf[k];
                }
            }
        };
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            for hit in &chunk.tri_hits {
                let tv = self.tri[hit.t as usize].map(|w| w as usize);
                if hit.t != cur {
                    flush(chains, cur, &tf);
                    cur = hit.t;
                    tf = [Vector3::zeros(); 3];
                }
                let v = hit.v as usize;
                let soft = chains.soft[v]
                    .min(chains.soft[tv[0]])
                    .min(chains.soft[tv[1]])
                    .min(chains.soft[tv[2]]);
                let f = hit.f * soft;
                chains.f[v] += f;
                for (t, b) in tf.iter_mut().zip(hit.bary) {
                    *t -= f * b;
                }
            }
        }
        flush(chains, cur, &tf);
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            for hit in &chunk.seg_hits {
                let (va, vb, s, t) = (hit.va as usize, hit.vb as usize, hit.s, hit.t);
                let soft = chains.soft[va]
                    .min(chains.soft[va + 1])
                    .min(chains.soft[vb])
                    .min(chains.soft[vb + 1]);
                let f = hit.f * soft;
                chains.f[va] += f * (1.0 - s);
                chains.f[va + 1] += f * s;
                chains.f[vb] -= f * (1.0 - t);
                chains.f[vb + 1] -= f * t;
            }
        }
    }

    /// Piece `c` of a sub-step's vertex–triangle contacts: the triangles holding its share of
    /// the candidates.
    #[inline(always)]
    fn tri_contacts(&self, c: usize, chains: &Chains, p: &GuideParams, out: &mut Chunk) {
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
            let verts = &self.tri_verts[start..end];
            self.triangle_hits(t, verts, chains, p, Bounds::Test, out);
        }
    }

    /// The contacts of triangle `t` with its candidate vertices `verts` (in index order).
    /// With [`Bounds::Test`] each vertex is first turned down cheaply when the triangle's box
    /// or prism already puts it past the contact distance; [`Bounds::Passed`] skips that for
    /// candidates the search has just kept within it (the same contacts either way: the bounds
    /// only turn down vertices the exact distance turns down too).
    #[inline(always)]
    pub(super) fn triangle_hits(
        &self,
        t: usize,
        verts: &[u32],
        chains: &Chains,
        p: &GuideParams,
        bounds: Bounds,
        out: &mut Chunk,
    ) {
        let n = chains.n;
        let dc = p.contact_distance;
        // The bounds are exact to rounding; a relative slack keeps every pair the exact test
        // would accept.
        let far = dc * (1.0 + 1e-9);
        let tangents = &self.tangents;
        let tv = self.tri[t].map(|w| w as usize);
        let tp = tv.map(|w| chains.x[w]);
        let pre = TrianglePre::new(&tp);
        let tt = tv.map(|w| tangents[w]);
        let tvel = tv.map(|w| chains.v[w]);
        // The box and prism bounds of up to 32 vertices at a time without a branch (a bit
        // mask: about half the candidates pass, which a branch per test mispredicts), then
        // the exact test and the force of those that pass, in the same order.
        let (prism, lo, hi) = match bounds {
            Bounds::Test => (
                Prism::new(&tp),
                tp[0].inf(&tp[1]).inf(&tp[2]) - Vector3::repeat(far),
                tp[0].sup(&tp[1]).sup(&tp[2]) + Vector3::repeat(far),
            ),
            Bounds::Passed => Default::default(),
        };
        for group in verts.chunks(32) {
            let mut mask = 0u32;
            if bounds == Bounds::Passed {
                mask = tail_mask32(group.len());
            } else {
                for (j, &v) in group.iter().enumerate() {
                    let x = chains.x[v as usize];
                    let inside = (x.x >= lo.x)
                        & (x.y >= lo.y)
                        & (x.z >= lo.z)
                        & (x.x <= hi.x)
                        & (x.y <= hi.y)
                        & (x.z <= hi.z)
                        & prism.near_all(&x, far);
                    mask |= (inside as u32) << j;
                }
            }
            while mask != 0 {
                let j = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let v = group[j] as usize;
                let x = chains.x[v];
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
                let f = contact_force(chains.v[v] - vt, nrm, d, scale, m, p);
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
    #[inline(always)]
    fn seg_contacts(&self, c: usize, chains: &Chains, p: &GuideParams, out: &mut Chunk) {
        let len = self.seg_pairs.len();
        for &(la, lb) in &self.seg_pairs[c * len / CHUNKS..(c + 1) * len / CHUNKS] {
            self.segment_hit(la, lb, chains, p, out);
        }
    }

    /// The contact of links `la` and `lb`, if they are in contact.
    #[inline(always)]
    pub(super) fn segment_hit(
        &self,
        la: u32,
        lb: u32,
        chains: &Chains,
        p: &GuideParams,
        out: &mut Chunk,
    ) {
        let n = chains.n;
        let dc = p.contact_distance;
        let far = dc * (1.0 + 1e-9);
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
            return;
        }
        // Nor are they closer than their lines, `|(a0 − b0)·c| / |c|` with `c = da × db`: a
        // dot product that turns down about three candidates in five before the closest
        // points. Only where the lines cross by a tenth or more (the candidates of the step's
        // search cross by twice that), so that rounding moves the bound by far less than the
        // slack, which keeps every pair the closest points accept.
        let (da, db) = (a1 - a0, b1 - b0);
        let c = da.cross(&db);
        let c2 = c.norm_squared();
        if c2 >= 0.01 * da.norm_squared() * db.norm_squared()
            && (a0 - b0).dot(&c).abs() > (far + 1e-12) * c2.sqrt()
        {
            return;
        }
        let (s, t) = closest_segments(&a0, &a1, &b0, &b1);
        let pa = a0.lerp(&a1, s);
        let pb = b0.lerp(&b1, t);
        let d = (pa - pb).norm();
        if d >= dc || d < 1e-9 {
            return;
        }
        out.count += 1;
        let nrm = (pa - pb) / d;
        let ta = (a1 - a0) / chains.len[la];
        let tb = (b1 - b0) / chains.len[lb];
        let rel = chains.v[va].lerp(&chains.v[va + 1], s) - chains.v[vb].lerp(&chains.v[vb + 1], t);
        let m = chains.m[la].min(chains.m[lb]);
        let scale = orientation_scale(&ta, &tb);
        let f = contact_force(rel, nrm, d, scale, m, p);
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

multiversion! {
    /// Piece `c` of [`Strips::evaluate_on`], built for AVX2 too (see `crate::simd::dispatch`):
    /// the same forces bit for bit, the scalar `f64` arithmetic in three-operand encoding and
    /// the bounds eight lanes wide.
    fn contacts_piece(
        this: &Strips,
        c: usize,
        ch: &Chains,
        p: &GuideParams,
        chunk: &mut Chunk,
    ) {
        chunk.tri_hits.clear();
        chunk.seg_hits.clear();
        chunk.count = 0;
        this.tri_contacts(c, ch, p, chunk);
        this.seg_contacts(c, ch, p, chunk);
    }
}

multiversion! {
    /// Piece `c` of [`Strips::detect_evaluate_on`], built for AVX2 too (see
    /// `crate::simd::dispatch`): the search's box, crossing and prism tests eight at a time in
    /// `f32` in one register instead of two, the same candidates and forces bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn search_contacts_piece(
        this: &Strips,
        c: usize,
        n: usize,
        ch: &Chains,
        p: &GuideParams,
        reach: f64,
        chunk: &mut Chunk,
    ) {
        chunk.tri_hits.clear();
        chunk.seg_hits.clear();
        chunk.count = 0;
        // The triangles of the piece in order, each with its vertices in index order (as
        // the listed candidates are grouped).
        let mut vt = std::mem::take(&mut chunk.vt);
        let mut verts = std::mem::take(&mut chunk.verts);
        vt.clear();
        this.tri_piece(c, ch, reach, &mut vt);
        for group in vt.chunk_by(|a, b| a.1 == b.1) {
            verts.clear();
            verts.extend(group.iter().map(|&(v, _)| v));
            verts.sort_unstable();
            // `tri_piece` kept only vertices within `reach` of the triangle's prism and box,
            // at these very positions: the bounds would turn none of them down.
            this.triangle_hits(group[0].1 as usize, &verts, ch, p, Bounds::Passed, chunk);
        }
        let mut seg = std::mem::take(&mut chunk.seg);
        seg.clear();
        this.seg_piece(c, n, &mut seg);
        for &(la, lb) in &seg {
            this.segment_hit(la, lb, ch, p, chunk);
        }
        (chunk.vt, chunk.verts, chunk.seg) = (vt, verts, seg);
    }
}

multiversion! {
    /// Piece `c` of [`Strips::reevaluate_on`]: the piece's contacts of the last search (their
    /// triangles in order, each with its vertices in index order; then its pairs of links),
    /// evaluated again in the same order, those of removed guides and broken triangles left
    /// out.
    fn reapply_piece(
        this: &Strips,
        _c: usize,
        ch: &Chains,
        p: &GuideParams,
        chunk: &mut Chunk,
    ) {
        let n = ch.n;
        let alive = |v: u32| ch.alive[v as usize / (n + 1)];
        let mut vt = std::mem::take(&mut chunk.vt);
        let mut verts = std::mem::take(&mut chunk.verts);
        let mut seg = std::mem::take(&mut chunk.seg);
        vt.clear();
        vt.extend(
            chunk
                .tri_hits
                .iter()
                .filter(|h| alive(h.v) && !this.broken[h.t as usize])
                .map(|h| (h.v, h.t)),
        );
        // A link's first vertex `g·(n + 1) + i` is link `g·n + i`.
        let link = |v: u32| (v as usize / (n + 1) * n + v as usize % (n + 1)) as u32;
        seg.clear();
        seg.extend(
            chunk
                .seg_hits
                .iter()
                .filter(|h| alive(h.va) && alive(h.vb))
                .map(|h| (link(h.va), link(h.vb))),
        );
        chunk.tri_hits.clear();
        chunk.seg_hits.clear();
        chunk.count = 0;
        for group in vt.chunk_by(|a, b| a.1 == b.1) {
            verts.clear();
            verts.extend(group.iter().map(|&(v, _)| v));
            // Pairs in contact last time mostly still are: the bounds would turn few down and
            // cost a prism per triangle (the exact test decides alike either way).
            this.triangle_hits(group[0].1 as usize, &verts, ch, p, Bounds::Passed, chunk);
        }
        for &(la, lb) in &seg {
            this.segment_hit(la, lb, ch, p, chunk);
        }
        (chunk.vt, chunk.verts, chunk.seg) = (vt, verts, seg);
    }
}

/// Whether [`Strips::triangle_hits`] tests its candidates against the triangle's box and
/// prism first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Bounds {
    /// Test them: candidates listed for a whole step, at a larger reach.
    Test,
    /// The search has just kept them within the contact distance, at these positions, or
    /// they were in contact at the last evaluation ([`Strips::reevaluate_on`]): the exact test
    /// alone decides.
    Passed,
}

/// Bits `0..m` set, `m ≤ 32`.
#[inline]
fn tail_mask32(m: usize) -> u32 {
    if m >= 32 {
        u32::MAX
    } else {
        (1u32 << m) - 1
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

/// A triangle's corners and edges from its first corner, for many closest-point queries.
pub(super) struct TrianglePre {
    a: Vector3<f64>,
    b: Vector3<f64>,
    c: Vector3<f64>,
    ab: Vector3<f64>,
    ac: Vector3<f64>,
}

impl TrianglePre {
    #[inline(always)]
    pub(super) fn new(t: &[Vector3<f64>; 3]) -> TrianglePre {
        let (a, b, c) = (t[0], t[1], t[2]);
        TrianglePre {
            a,
            b,
            c,
            ab: b - a,
            ac: c - a,
        }
    }

    /// [`closest_on_triangle`]. Always inlined, so that the pieces built for AVX2
    /// (`crate::simd::dispatch`) compile it with them instead of calling the baseline copy.
    #[inline(always)]
    pub(super) fn closest(&self, p: &Vector3<f64>) -> (Vector3<f64>, [f64; 3]) {
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
