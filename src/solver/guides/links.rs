//! Static links (Chang, Jin, Yu 2002, §4.1): breakable zero-rest-length springs that keep each
//! segment's neighbourhood where the hairstyle put it.
//!
//! For every segment, a few closest points on nearby guides are found at rest (with a uniform
//! grid) and stored in the segment's local frame. A link pulls its point back to where the
//! frame says it should be: `F = −k(s)·Δ − k_d·Δ̇`, `Δ` the point's displacement from its rest
//! place. The stretch `s = |Δ| / reference` sets the spring constant (the paper's Fig. 2): full
//! up to 1, falling gradually beyond, zero at 2, where the link breaks for good.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::chain::Chains;

/// The stretch at which a link breaks for good (Fig. 2: its spring constant has fallen to 0).
pub const BREAK_STRETCH: f64 = 2.0;

/// The spring-constant factor of a link at stretch `s` (Fig. 2): 1 up to 1, a smooth
/// (cosine) fall between 1 and 2, 0 from 2 on. The paper's curve is drawn, not written; a
/// cosine fall is "gradual" at both ends.
pub fn stiffness_factor(s: f64) -> f64 {
    if s <= 1.0 {
        1.0
    } else if s >= 2.0 {
        0.0
    } else {
        0.5 * (1.0 + (std::f64::consts::PI * (s - 1.0)).cos())
    }
}

/// Every static link, structure of arrays.
#[derive(Debug, Clone, Default)]
pub struct Links {
    /// Owner link (segment) `g · n + i`: the link's rest point lives in its frame.
    pub owner: Vec<u32>,
    /// The linked segment on another guide, and the parameter of the point along it.
    pub other: Vec<u32>,
    /// Parameter in [0, 1] of the linked point along `other`.
    pub t: Vec<f64>,
    /// Rest point in the owner's frame, relative to the owner's first vertex.
    pub p0: Vec<Vector3<f64>>,
    /// Reference length of the stretch, m.
    pub reference: Vec<f64>,
    /// Broken for good.
    pub broken: Vec<bool>,
    /// Stretch at the last force evaluation.
    pub stretch: Vec<f64>,
    /// Per link, the force on its point per kilogram at the last [`Links::evaluate`], before
    /// the mass and the implicit damping's factor (`Chains::soft`) of [`Links::add_forces`]
    /// (zero if broken).
    force: Vec<Vector3<f64>>,
}

impl Links {
    /// Number of links.
    pub fn len(&self) -> usize {
        self.owner.len()
    }

    /// No link.
    pub fn is_empty(&self) -> bool {
        self.owner.is_empty()
    }

    /// Links intact.
    pub fn intact(&self) -> usize {
        self.broken.iter().filter(|b| !**b).count()
    }

    /// Finds, for every segment of the alive guides in `guides`, up to `per_segment` closest
    /// points within `radius` on other guides (one per guide, the nearest), in the chains'
    /// current (rest) configuration. `reference`: the stretch's reference length, else the
    /// owner segment's length.
    pub fn build(
        chains: &Chains,
        guides: &[usize],
        per_segment: usize,
        radius: f64,
        reference: Option<f64>,
    ) -> Links {
        let mut out = Links::default();
        if per_segment == 0 {
            return out;
        }
        let n = chains.n;
        let cell = radius.max(1e-4);
        let key = |p: &Vector3<f64>| {
            [
                (p.x / cell).floor() as i64,
                (p.y / cell).floor() as i64,
                (p.z / cell).floor() as i64,
            ]
        };
        // Segments by the cell of their midpoint; segments are shorter than a few cells, so
        // the search looks at the 5×5×5 block around a segment.
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for &g in guides {
            for i in 0..n {
                let v = g * (n + 1) + i;
                let mid = (chains.x[v] + chains.x[v + 1]) * 0.5;
                grid.entry(key(&mid)).or_default().push((g * n + i) as u32);
            }
        }
        let reach =
            ((chains.len.iter().cloned().fold(0.0, f64::max) / cell).ceil() as i64 + 1).min(4);
        let mut best: Vec<(f64, u32, u32, f64)> = Vec::new(); // (dist, guide, link, t)
        for &g in guides {
            for i in 0..n {
                let l = g * n + i;
                let v = g * (n + 1) + i;
                let mid = (chains.x[v] + chains.x[v + 1]) * 0.5;
                let c = key(&mid);
                best.clear();
                for dx in -reach..=reach {
                    for dy in -reach..=reach {
                        for dz in -reach..=reach {
                            let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else {
                                continue;
                            };
                            for &o in list {
                                let og = o as usize / n;
                                if og == g {
                                    continue;
                                }
                                let ov = og * (n + 1) + o as usize % n;
                                let (a, b) = (chains.x[ov], chains.x[ov + 1]);
                                let t = closest_t(&a, &b, &mid);
                                let d = (a + (b - a) * t - mid).norm();
                                if d > radius {
                                    continue;
                                }
                                match best.iter_mut().find(|e| e.1 == og as u32) {
                                    Some(e) => {
                                        if (d, o) < (e.0, e.2) {
                                            *e = (d, og as u32, o, t);
                                        }
                                    }
                                    None => best.push((d, og as u32, o, t)),
                                }
                            }
                        }
                    }
                }
                best.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                for &(_, _, o, t) in best.iter().take(per_segment) {
                    let ov = (o as usize / n) * (n + 1) + o as usize % n;
                    let p = chains.x[ov] + (chains.x[ov + 1] - chains.x[ov]) * t;
                    out.owner.push(l as u32);
                    out.other.push(o);
                    out.t.push(t);
                    out.p0.push(chains.rot[l].transpose() * (p - chains.x[v]));
                    out.reference.push(reference.unwrap_or(chains.len[l]));
                    out.broken.push(false);
                    out.stretch.push(0.0);
                }
            }
        }
        out
    }

    /// Evaluates every intact link's spring and damping force, breaks the links stretched to 2,
    /// adds the damping coefficients of the intact ones to the chains' `damp`, and returns how
    /// many are intact. `strength` and `damping` are per kilogram of the owner segment's vertex
    /// mass. The forces wait for [`Links::add_forces`], once the sub-step's damping is all
    /// known.
    pub fn evaluate(&mut self, chains: &mut Chains, strength: f64, damping: f64) -> usize {
        let n = chains.n;
        let mut intact = 0;
        self.force.resize(self.owner.len(), Vector3::zeros());
        for k in 0..self.owner.len() {
            self.force[k] = Vector3::zeros();
            if self.broken[k] {
                continue;
            }
            let (l, o, v, ov) = self.segments(n, k);
            let t = self.t[k];
            let p = chains.x[ov] + (chains.x[ov + 1] - chains.x[ov]) * t;
            let vp = chains.v[ov] + (chains.v[ov + 1] - chains.v[ov]) * t;
            let arm = chains.rot[l] * self.p0[k];
            let anchor = chains.x[v] + arm;
            let w = nalgebra::Vector3::new(chains.vs[l][0], chains.vs[l][1], chains.vs[l][2]);
            let va = chains.v[v] + w.cross(&arm);
            let d = p - anchor;
            let s = d.norm() / self.reference[k];
            self.stretch[k] = s;
            if s >= BREAK_STRETCH {
                self.broken[k] = true;
                continue;
            }
            intact += 1;
            let m = chains.m[l].min(chains.m[o]);
            self.force[k] = -(d * (strength * stiffness_factor(s)) + (vp - va) * damping);
            let ta = self.owner_share(chains, k);
            let c = damping * m;
            chains.damp[ov] += c * (1.0 - t);
            chains.damp[ov + 1] += c * t;
            chains.damp[v] += c * (1.0 - ta);
            chains.damp[v + 1] += c * ta;
        }
        intact
    }

    /// Adds the forces of the last [`Links::evaluate`] to the chains' vertex forces, each
    /// scaled by the smallest backward-Euler factor (`Chains::soft`) of the four vertices it
    /// acts on, so that action and reaction stay equal.
    pub fn add_forces(&self, chains: &mut Chains) {
        let n = chains.n;
        for (k, f) in self.force.iter().enumerate() {
            if self.broken[k] {
                continue;
            }
            let (l, o, v, ov) = self.segments(n, k);
            let t = self.t[k];
            let m = chains.m[l].min(chains.m[o]);
            let soft = chains.soft[ov]
                .min(chains.soft[ov + 1])
                .min(chains.soft[v])
                .min(chains.soft[v + 1]);
            let f = f * (m * soft);
            // The point's share goes to its segment's ends; the reaction to the owner's ends,
            // split by where the rest point projects on the owner segment.
            chains.f[ov] += f * (1.0 - t);
            chains.f[ov + 1] += f * t;
            let ta = self.owner_share(chains, k);
            chains.f[v] -= f * (1.0 - ta);
            chains.f[v + 1] -= f * ta;
        }
    }

    /// Link `k`'s owner segment and linked segment (`g · n + i`, `n` segments per guide), and
    /// their first vertices (`g · (n + 1) + i`).
    fn segments(&self, n: usize, k: usize) -> (usize, usize, usize, usize) {
        let (l, o) = (self.owner[k] as usize, self.other[k] as usize);
        (l, o, (l / n) * (n + 1) + l % n, (o / n) * (n + 1) + o % n)
    }

    /// Where link `k`'s rest point projects on its owner segment, in [0, 1]: the share of the
    /// owner's second vertex.
    fn owner_share(&self, chains: &Chains, k: usize) -> f64 {
        (self.p0[k].y / chains.len[self.owner[k] as usize]).clamp(0.0, 1.0)
    }

    /// Current end points of link `k`: its rest place in the owner's frame, and the point.
    pub fn ends(&self, chains: &Chains, k: usize) -> (Vector3<f64>, Vector3<f64>) {
        let (l, _, v, ov) = self.segments(chains.n, k);
        let p = chains.x[ov] + (chains.x[ov + 1] - chains.x[ov]) * self.t[k];
        (chains.x[v] + chains.rot[l] * self.p0[k], p)
    }
}

/// Parameter of the point of segment `ab` closest to `p`.
pub fn closest_t(a: &Vector3<f64>, b: &Vector3<f64>, p: &Vector3<f64>) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    if l2 < 1e-18 {
        0.0
    } else {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    }
}
