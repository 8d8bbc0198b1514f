//! Dense hair from the guides (Chang, Jin, Yu 2002, §5.1).
//!
//! Every strand of the model follows its nearest guides through local root frames built from
//! the scalp normal and a global up vector (§5.1). Each guide's motion is taken into its own
//! root frame (the paper's `M₁`), as a displacement from its rest shape there, blended over the
//! nearest guides by inverse root distance, and carried back out through the dense strand's
//! root frame (`M₂⁻¹`). Blending displacements rather than whole guide shapes keeps each dense
//! strand's own styled shape (the paper merges transformed guide shapes; with a few guides per
//! strand the two agree where the guides share a shape). Smoothing by Hermite splines is the
//! display pipeline's Catmull-Rom spline through the returned points.

use nalgebra::{Matrix3, Vector3};

use crate::model::HairModel;
use crate::par::{for_each_on, split_parts, Pool};

/// Runs of strands the dense update is cut into for the pool's threads.
const PARTS: usize = 8;

/// The local root frame at rest-pose root `r` of a scalp ellipsoid: columns (tangent, normal,
/// binormal) from the ellipsoid normal and the global up (y).
pub fn root_frame(model: &HairModel, r: &Vector3<f64>) -> Matrix3<f64> {
    let rad = model.scalp_radii;
    let d = r - model.scalp_center;
    let nrm = Vector3::new(
        d.x / (rad.x * rad.x),
        d.y / (rad.y * rad.y),
        d.z / (rad.z * rad.z),
    )
    .try_normalize(1e-12)
    .unwrap_or_else(Vector3::y);
    let t = Vector3::y()
        .cross(&nrm)
        .try_normalize(1e-9)
        .unwrap_or_else(Vector3::x);
    let b = nrm.cross(&t);
    Matrix3::from_columns(&[t, nrm, b])
}

/// Binding of every dense strand to its guides.
#[derive(Debug, Clone, Default)]
pub struct Dense {
    /// Guides blended per strand.
    pub blend: usize,
    /// Per strand × blend: guide slot (`u32::MAX`: unused) and weight.
    pub guide: Vec<u32>,
    /// Per strand × blend: weight (they sum to 1).
    pub weight: Vec<f64>,
    /// Per strand × blend: the root distance the weight comes from.
    dist: Vec<f64>,
    /// The guides (slot, rest root) of the last binding.
    bound: Vec<(usize, Vector3<f64>)>,
    /// Per strand point: rest position in the strand's root frame, relative to its root.
    pub local: Vec<Vector3<f64>>,
    /// Per strand: root frame at rest.
    pub frame: Vec<Matrix3<f64>>,
    /// Per strand point: current world position (after [`Dense::update`]).
    pub points: Vec<Vector3<f64>>,
}

impl Dense {
    /// Binds every strand of `model`, with `blend` guides each.
    pub fn new(model: &HairModel, blend: usize) -> Dense {
        let k = model.k;
        let n = model.strands.len();
        let mut d = Dense {
            blend,
            guide: vec![u32::MAX; n * blend],
            weight: vec![0.0; n * blend],
            dist: vec![f64::INFINITY; n * blend],
            bound: Vec::new(),
            local: Vec::with_capacity(n * k),
            frame: Vec::with_capacity(n),
            points: model.strands.rest.clone(),
        };
        for s in 0..n {
            let root = model.strands.rest[s * k];
            let f = root_frame(model, &root);
            d.frame.push(f);
            for i in 0..k {
                d.local
                    .push(f.transpose() * (model.strands.rest[s * k + i] - root));
            }
        }
        d
    }

    /// Chooses each strand's `blend` nearest guides among `roots` (slot, rest root), weights by
    /// inverse distance. Ties go to the lower slot, so the binding is deterministic.
    ///
    /// Only what changed since the last binding is searched again (the §4.3 guides come and go
    /// one at a time, and a full search of every strand against every guide took a sixth of a
    /// `shake` step on Long curly): a strand bound to no guide that left only has to weigh its
    /// nearest guides against the guides that came, since the nearest `blend` of a set with one
    /// more element are among the old nearest and the new one; a strand bound to a guide that
    /// left is searched again in full. The result is the full search's, bit for bit: the same
    /// order `(distance, slot)` decides, and the weights come from the same list.
    // (`j` indexes the nearest guides and their weights alike.)
    #[allow(clippy::needless_range_loop)]
    pub fn bind(&mut self, model: &HairModel, roots: &[(usize, Vector3<f64>)]) {
        let same = |a: &(usize, Vector3<f64>), b: &(usize, Vector3<f64>)| a.0 == b.0 && a.1 == b.1;
        let gone: Vec<u32> = self
            .bound
            .iter()
            .filter(|o| !roots.iter().any(|r| same(o, r)))
            .map(|o| o.0 as u32)
            .collect();
        let came: Vec<(usize, Vector3<f64>)> = if self.bound.is_empty() {
            Vec::new()
        } else {
            roots
                .iter()
                .filter(|r| !self.bound.iter().any(|o| same(o, r)))
                .copied()
                .collect()
        };
        let full = self.bound.is_empty();
        self.bound.clear();
        self.bound.extend_from_slice(roots);
        let k = model.k;
        let b = self.blend;
        let mut near: Vec<(f64, usize)> = Vec::with_capacity(b + 1);
        for s in 0..model.strands.len() {
            let slots = &self.guide[s * b..(s + 1) * b];
            let search = |near: &mut Vec<(f64, usize)>, from: &[(usize, Vector3<f64>)]| {
                let r = model.strands.rest[s * k];
                for &(g, rg) in from {
                    let d = (rg - r).norm();
                    if near.len() < b || (d, g) < near[near.len() - 1] {
                        let at = near.partition_point(|e| *e < (d, g));
                        near.insert(at, (d, g));
                        near.truncate(b);
                    }
                }
            };
            near.clear();
            if full || slots.iter().any(|g| gone.contains(g)) {
                search(&mut near, roots);
            } else {
                if came.is_empty() {
                    continue;
                }
                for (&g, &d) in slots.iter().zip(&self.dist[s * b..(s + 1) * b]) {
                    if g != u32::MAX {
                        near.push((d, g as usize));
                    }
                }
                search(&mut near, &came);
            }
            let w: Vec<f64> = near.iter().map(|(d, _)| 1.0 / (d + 1e-3)).collect();
            let sum: f64 = w.iter().sum();
            for j in 0..b {
                let (g, wt, d) = match near.get(j) {
                    Some(&(d, g)) => (g as u32, w[j] / sum, d),
                    None => (u32::MAX, 0.0, f64::INFINITY),
                };
                self.guide[s * b + j] = g;
                self.weight[s * b + j] = wt;
                self.dist[s * b + j] = d;
            }
        }
    }

    /// Recomputes every dense point. `disp(g, u)`: guide `g`'s displacement from rest in its
    /// root frame at fractional vertex `u ∈ [0, n]`; `rot`: the head rotation; `root_world`:
    /// the world root of a rest root. The strands are cut into [`PARTS`] runs that the threads
    /// of `pool` take in any order (each point depends only on its strand: the same points on
    /// one thread or two). With `only`, recomputes just those strands, on the calling thread
    /// (the others keep their old points).
    #[allow(clippy::too_many_arguments)]
    pub fn update(
        &mut self,
        pool: Option<&Pool>,
        only: Option<&[u32]>,
        model: &HairModel,
        rot: &Matrix3<f64>,
        root_world: impl Fn(&Vector3<f64>) -> Vector3<f64> + Sync,
        disp: impl Fn(usize, f64) -> Vector3<f64> + Sync,
        n: usize,
    ) {
        let k = model.k;
        let b = self.blend;
        let (guide, weight, frame, local) = (&self.guide, &self.weight, &self.frame, &self.local);
        let place = |s: usize, out: &mut [Vector3<f64>]| {
            let root = root_world(&model.strands.rest[s * k]);
            let f = rot * frame[s];
            for (i, p) in out.iter_mut().enumerate() {
                let u = if k > 1 {
                    i as f64 * n as f64 / (k - 1) as f64
                } else {
                    0.0
                };
                let mut dl = Vector3::zeros();
                for j in 0..b {
                    let g = guide[s * b + j];
                    if g != u32::MAX {
                        dl += disp(g as usize, u) * weight[s * b + j];
                    }
                }
                *p = root + f * (local[s * k + i] + dl);
            }
        };
        if let Some(only) = only {
            for &s in only {
                let s = s as usize;
                place(s, &mut self.points[s * k..(s + 1) * k]);
            }
            return;
        }
        let strands = model.strands.len();
        let first = |c: usize| c * strands / PARTS;
        let parts = split_parts::<_, PARTS>(&mut self.points, |c| first(c + 1) * k);
        for_each_on(pool, PARTS, &|c| {
            let mut part = parts[c].lock().unwrap_or_else(|e| e.into_inner());
            let (start, points) = &mut *part;
            let s0 = *start / k.max(1);
            for (ds, out) in points.chunks_mut(k.max(1)).enumerate() {
                place(s0 + ds, out);
            }
        });
    }
}
