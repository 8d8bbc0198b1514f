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
//! The broad phase is a uniform grid, held for the segments as a sorted list of (cell, element)
//! pairs and for the vertices as a dense counting sort, rebuilt once per search into reused
//! buffers; candidate pairs found within twice the threshold are re-evaluated at every
//! sub-step. When a step has one sub-step, the search runs within the threshold itself on that
//! sub-step's positions and each candidate is evaluated as it is found
//! ([`Strips::detect_evaluate_on`]).
//!
//! **A search every second step** (`guides.contact_search_every`, default 2). The paper does
//! not say how often its strips are searched. Between searches, [`Strips::reevaluate_on`]
//! evaluates the pairs the last search found in contact again, on the current positions and
//! velocities: a lasting contact (most of them: at rest, and within a moving wisp) gets the
//! same forces as from a fresh search, bit for bit when nothing moved (tests), and only a pair
//! that has just come into contact waits one step. A strip rebuilt by an adaptive guide
//! (§4.3; about twice a step on Long and Long curly under `shake`) renumbers the last
//! contacts' triangles rather than forcing a search ([`Strips::rebuild`]). Measured
//! (2026-12-07, `examples/layered_probe STYLE MOTION 6 guides` against the same style with
//! `guides: (contact_search_every: 1)`): the guides' step alone on two threads 1.2× (Short)
//! and 1.3× (Long curly) as fast under `shake`; the kinetic energy, read once a second, within
//! 3 % at rest under `stop`, within 1–10 % under `jump` (36 % once on Long curly at 5 s, a
//! quiet moment: 5.5e-2 against 4.1e-2 J), and 0–14 % higher under `shake` (Short 0.25–0.28
//! against 0.24–0.25 J). `wisptree bench --live --rows guides` against the build before,
//! alternated three times: after ÷ before median 1.28 over the 60 pairs of rows. The price
//! is in the contacts that start between searches: the contacts acting per step, averaged
//! over 5 s, are 1–4 % fewer under `lean`, `run`, `jump` and `stop`, but 12–20 % fewer under
//! `shake` (Short 54k → 45k, Long 26k → 21k, Long curly 34k → 30k), where hair sweeps fast
//! through hair and a third or more of a step's contacts can be new. With 3 the `shake` rows
//! ran 0.90–1.10 live (0.65–0.78 with 1 in the same two runs) with 27–42 % fewer contacts:
//! too many late contacts for a default.
//! Other ways of searching less often, measured and left (the first two when the default was
//! set):
//! * **The last contacts' forces held** (added again unchanged on the step between): faster
//!   still (1.4–1.5×), but a one-step lag on a stiff, strongly damped spring feeds energy in:
//!   Short under `stop` kept 20× the kinetic energy at rest (2.2–2.9e-3 J against 1.3e-4 from
//!   3 s on), a visible jitter.
//! * **The candidates within twice the contact distance**, searched every second step and
//!   evaluated every step (as with two sub-steps): 2.5–3.6× the candidates, and slower than a
//!   search every step (1.1–1.3×).
//! * **The last search's candidates evaluated again** between searches, not only its contacts
//!   (2026-12-07, later that day): a candidate pair that comes into contact in between then acts
//!   at once. It recovers about a third of the contacts missing under `shake` (per step, 5 s
//!   of `bench --live`: Short 44.7k → 47.0k of the 54.2k of a search every step, Short curly
//!   48.8k → 51.1k of 58.4k, Long 21.1k → 23.1k of 26.4k, Long curly 30.2k → 31.6k of 34.4k):
//!   most new contacts were not candidates at all. But it evaluates about twice the pairs on
//!   the step between: the four `shake` rows alternated twice with the build before, after ÷
//!   before median 0.95 (0.92–1.07) with the box and prism tests first, 0.93 (0.87–1.06)
//!   without. The rows it slows are the ones nearest real time, so it did not land.
//!
//! Both the broad phase and a sub-step's contacts are cut into [`CHUNKS`] fixed pieces of work
//! that the threads of a [`Pool`] take in any order; each piece writes only its own lists, and
//! the lists are joined (candidates) or their forces added (contacts) piece by piece in order
//! afterwards, so the result is the same bit for bit on one thread or two, whichever thread
//! took which piece. Each piece is built for AVX2 too (`crate::simd::dispatch`), the same
//! bits; `vertex_grid.rs` says what that gave.
//!
//! Where a sub-step's time goes (2026-12-06, `examples/strips_probe.rs long_curly shake 2`,
//! one thread, one call on a frozen state: 68,612 candidates, 36,043 contacts, 13–14 ms): the
//! set-up (boxes, grid, sorted entries) 1.1 ms, the vertex–triangle search 4.0 and its contacts
//! 2.7, the segment search 2.4 and its contacts 2.8, adding the forces 0.45. No part dominates,
//! and a profile of the pieces is flat. Two things measured and left:
//! * **Reusing the candidates over a frame's steps** (a search with a margin, kept while no
//!   vertex has moved half of it) cannot pay under `shake`: relative to the head, the vertices
//!   move 1–3 cm per 10 ms step (90th percentile, Long curly), against a contact distance of
//!   6 mm, so the list would be rebuilt every step.
//! * **32 pieces instead of 8**, here and for the guides' runs (`advance.rs`), to shorten the
//!   piece one thread finishes alone: `wisptree bench --live --rows guides`, alternated with
//!   the 8-piece build three times, gave a median after ÷ before of 1.00 (0.74–1.20) over
//!   the 60 pairs of rows.
//!
//! Files: `mod.rs` (the strips, their triangles and buffers, tangents, closest points),
//! `broad.rs` (the broad phase: the segments' grid and boxes, the triangle's prism test),
//! `vertex_grid.rs` (the vertex–triangle search: the vertices in a dense grid, each triangle
//! testing those in its cells), `contacts.rs` (each sub-step's contact forces), `tests.rs`.

use std::sync::Mutex;

use nalgebra::Vector3;

use crate::par::{for_each_on, Pool};
use crate::simd::Level;

use super::chain::Chains;
use super::params::{GuideParams, StripLayout};

mod broad;
mod contacts;
#[cfg(test)]
mod tests;
mod vertex_grid;

use broad::Prism;
use contacts::TrianglePre;
use vertex_grid::VertexGrid;

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

/// A vertex–triangle contact of a sub-step, kept until its forces are added in order: the
/// triangle, the vertex, the force on the vertex before the implicit damping's factor
/// (`Chains::soft`), the damping coefficient and the closest point's barycentric weights.
#[derive(Debug, Clone, Copy)]
struct TriHit {
    t: u32,
    v: u32,
    f: Vector3<f64>,
    cd: f64,
    bary: [f64; 3],
}

/// A segment–segment contact of a sub-step: the first vertices of both links, the closest
/// points' parameters, the force on the first link before the implicit damping's factor
/// (`Chains::soft`) and the damping coefficient.
#[derive(Debug, Clone, Copy)]
struct SegHit {
    va: u32,
    vb: u32,
    s: f64,
    t: f64,
    f: Vector3<f64>,
    cd: f64,
}

/// Reused buffers of [`Strips::rebuild`]: the strips before it, the strips after it sorted
/// (with their index), and per strip before it its index after it.
#[derive(Debug, Default)]
struct RebuildScratch {
    old_pairs: Vec<(u32, u32)>,
    sorted: Vec<((u32, u32), u32)>,
    strip_now: Vec<Option<u32>>,
}

/// What one piece of work found.
#[derive(Debug, Default)]
struct Chunk {
    seg: Vec<(u32, u32)>,
    vt: Vec<(u32, u32)>,
    /// A triangle's candidate vertices, sorted (the fused search of one sub-step).
    verts: Vec<u32>,
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
    /// Candidate segment–segment pairs (links, lower first).
    seg_pairs: Vec<(u32, u32)>,
    /// Candidate vertex–triangle pairs as found (vertex-major), then grouped by triangle:
    /// the vertices of triangle `t` are `tri_verts[tri_start[t]..tri_start[t + 1]]`.
    vt_pairs: Vec<(u32, u32)>,
    tri_start: Vec<u32>,
    tri_verts: Vec<u32>,
    /// Candidate pairs of the last broad phase, listed or evaluated as found.
    found: usize,
    cursor: Vec<u32>,
    /// Per chain vertex: hair direction ([`tangent`]), refreshed by `detect` and `apply`.
    tangents: Vec<Vector3<f64>>,
    /// Per link: box grown by half the reach, its low corner's cell, and unit direction
    /// (`detect`).
    seg_box: Vec<(Vector3<f64>, Vector3<f64>)>,
    /// Per link: that box in `f32` rounded outwards (low x, y, z, high x, y, z).
    seg_box32: Vec<[f32; 6]>,
    seg_cell: Vec<[i64; 3]>,
    seg_dir: Vec<Vector3<f64>>,
    /// Per triangle: the guides of its two sides.
    tri_guides: Vec<[u32; 2]>,
    /// The segments' boxes per entry of `entries`, as `f32` rounded outwards (low x, y, z,
    /// high x, y, z), side by side for a segment to test eight at once.
    sbox: [Vec<f32>; 6],
    /// The alive guides' vertices (roots left out) by grid cell (`detect`).
    grid: VertexGrid,
    /// The pieces' findings.
    chunks: Vec<Mutex<Chunk>>,
    /// Scratch of [`Strips::rebuild`] carrying the last contacts over.
    rebuild_scratch: RebuildScratch,
    /// The instruction set the pieces run on, and the guides' runs too (the solver's one
    /// setting): `None` for the process's ([`crate::simd::level`]); tests pin one to compare
    /// the AVX2 build with the portable one.
    simd_level: Option<Level>,
}

impl Strips {
    /// The instruction set the pieces of work run on (see `simd_level`).
    pub(crate) fn level(&self) -> Level {
        self.simd_level.unwrap_or_else(crate::simd::level)
    }

    /// Runs the pieces on the build of `level` (`None`: the process's); the same result.
    pub fn set_simd_level(&mut self, level: Option<Level>) {
        self.simd_level = level;
    }

    /// Contacts of the last sub-step touching chain vertex `v`, and touching any vertex in
    /// `guide` (a guide's vertices): a vertex–triangle contact touches its vertex and the
    /// triangle's corners, a segment pair both ends of both segments. For the inspector.
    pub fn contacts_touching(&self, v: u32, guide: std::ops::Range<u32>) -> (usize, usize) {
        let (mut own, mut of_guide) = (0, 0);
        let mut count = |touched: &[u32]| {
            own += touched.contains(&v) as usize;
            of_guide += touched.iter().any(|w| guide.contains(w)) as usize;
        };
        for m in &self.chunks {
            let chunk = m.lock().unwrap_or_else(|e| e.into_inner());
            for h in &chunk.tri_hits {
                let [a, b, c] = self.tri[h.t as usize];
                count(&[h.v, a, b, c]);
            }
            for h in &chunk.seg_hits {
                count(&[h.va, h.va + 1, h.vb, h.vb + 1]);
            }
        }
        (own, of_guide)
    }
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
        let mut old_pairs = std::mem::take(&mut self.rebuild_scratch.old_pairs);
        old_pairs.clear();
        old_pairs.extend_from_slice(&self.pairs);
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
        self.carry_hits_over(&old_pairs, n);
        self.rebuild_scratch.old_pairs = old_pairs;
    }

    /// After a rebuild from `old_pairs`: the last contacts' triangles renumbered to the new
    /// strips (a strip's triangles are numbered `2·n` per strip in strip order, so a triangle
    /// keeps its place within its strip), and those of strips that are gone dropped, so that
    /// [`Strips::reevaluate_on`] and the inspector read the triangles in force.
    fn carry_hits_over(&mut self, old_pairs: &[(u32, u32)], n: usize) {
        let per_strip = 2 * n as u32;
        let RebuildScratch {
            sorted, strip_now, ..
        } = &mut self.rebuild_scratch;
        sorted.clear();
        sorted.extend((0u32..).zip(&self.pairs).map(|(k, &pair)| (pair, k)));
        sorted.sort_unstable();
        strip_now.clear();
        strip_now.extend(old_pairs.iter().map(|pair| {
            sorted
                .binary_search_by(|(q, _)| q.cmp(pair))
                .ok()
                .map(|i| sorted[i].1)
        }));
        for m in &mut self.chunks {
            let chunk = m.get_mut().unwrap_or_else(|e| e.into_inner());
            chunk.tri_hits.retain_mut(|h| {
                let (strip, within) = (h.t / per_strip, h.t % per_strip);
                match strip_now.get(strip as usize).copied().flatten() {
                    Some(k) => {
                        h.t = k * per_strip + within;
                        true
                    }
                    None => false,
                }
            });
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

    /// Number of candidate pairs of the last broad phase.
    pub fn candidates(&self) -> usize {
        self.found
    }

    /// Bytes held by the reused buffers.
    pub fn reserved_bytes(&self) -> usize {
        self.entries.capacity() * 16
            + (self.seg_pairs.capacity() + self.vt_pairs.capacity()) * 8
            + (self.tri_start.capacity() + self.tri_verts.capacity() + self.cursor.capacity()) * 4
            + self.tangents.capacity() * 24
            + self.seg_box.capacity() * 48
            + self.seg_box32.capacity() * 24
            + self.seg_cell.capacity() * 24
            + self.seg_dir.capacity() * 24
            + self.tri_guides.capacity() * 8
            + self.grid.reserved_bytes()
            + self.sbox.iter().map(|b| b.capacity() * 4).sum::<usize>()
            + self
                .chunks
                .iter()
                .map(|m| {
                    let c = m.lock().unwrap_or_else(|e| e.into_inner());
                    (c.seg.capacity() + c.vt.capacity()) * 8
                        + c.verts.capacity() * 4
                        + c.tri_hits.capacity() * std::mem::size_of::<TriHit>()
                        + c.seg_hits.capacity() * std::mem::size_of::<SegHit>()
                })
                .sum::<usize>()
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
#[inline(always)]
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
