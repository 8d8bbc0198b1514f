//! Strands drawn inside the deformed envelope (Plante, Cani, Poulin 2002, §6). Each strand has
//! fixed coordinates in its wisp's sections: at each section, a point of the unit disk (its rest
//! offset across the section over the envelope's rest radius on that side) and an offset along
//! the section normal. The 4 envelope points scale the disk each step (Fig. 4), so a compressed
//! section draws its strands closer and a wavy strand's amplitude follows the compression; the
//! pipeline joins the points with Catmull-Rom curves. A fixed per-strand jitter moves every
//! point towards the skeleton, so no strand leaves the envelope.

use nalgebra::Vector3;

use super::wisp::{ancestor, Wisps, ENV};
use crate::model::HairModel;

/// Every strand's place in its wisp.
#[derive(Debug, Clone, Default)]
pub struct StrandMap {
    /// Per strand: its wisp.
    pub wisp: Vec<u32>,
    /// Per strand: the jitter factor towards the skeleton, in [1 − jitter, 1].
    pub jitter: Vec<f64>,
    /// Per strand point (`s * K + i`): (disk u, disk v, offset along the normal in metres).
    pub coords: Vec<Vector3<f64>>,
}

impl StrandMap {
    /// Coordinates of the model's strands in the rest sections of `w`, whose wisps are the GCs
    /// of `level`.
    pub fn build(model: &HairModel, w: &Wisps, level: usize, jitter: f64) -> StrandMap {
        let k = model.k;
        let finest = model.level_count() - 1;
        let n = model.strands.len();
        let mut m = StrandMap {
            wisp: Vec::with_capacity(n),
            jitter: Vec::with_capacity(n),
            coords: Vec::with_capacity(n * k),
        };
        for s in 0..n {
            let wi = ancestor(model, finest, model.strands.finest_gc[s] as usize, level);
            m.wisp.push(wi as u32);
            m.jitter.push(1.0 - jitter * unit_hash(s as u64));
            let base = w.start[wi] as usize;
            for i in 0..k {
                let p = base + i;
                let off = model.strands.rest[s * k + i] - w.rest_pos[p];
                let (u, t) = (w.u[p], w.t[p]);
                let v = t.cross(&u);
                let (x, y) = (off.dot(&u), off.dot(&v));
                let r = &w.rho_rest[p * ENV..p * ENV + ENV];
                let rx = if x >= 0.0 { r[0] } else { r[2] };
                let ry = if y >= 0.0 { r[1] } else { r[3] };
                m.coords.push(Vector3::new(x / rx, y / ry, off.dot(&t)));
            }
        }
        m
    }

    /// Appends strand `s`'s points in the current envelope to `out`.
    pub fn points(&self, w: &Wisps, s: usize, k: usize, out: &mut Vec<Vector3<f64>>) {
        let wi = self.wisp[s] as usize;
        let base = w.start[wi] as usize;
        let jit = self.jitter[s];
        for i in 0..k {
            let p = base + i;
            let c = self.coords[s * k + i];
            let r = &w.rho[p * ENV..p * ENV + ENV];
            let rx = if c.x >= 0.0 { r[0] } else { r[2] };
            let ry = if c.y >= 0.0 { r[1] } else { r[3] };
            let (u, t) = (w.u[p], w.t[p]);
            let v = t.cross(&u);
            out.push(w.pos[p] + (u * (c.x * rx) + v * (c.y * ry)) * jit + t * c.z);
        }
    }
}

/// A fixed number in [0, 1) from `x` (splitmix64), so the jitter is the same every frame
/// (§6 resets its random generator every frame for the same reason).
pub fn unit_hash(x: u64) -> f64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}
