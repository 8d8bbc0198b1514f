//! Anisotropic interactions between wisps (Plante, Cani, Poulin 2002, §4.2): two segments in
//! contact whose relative velocity lies near their common plane interpenetrate (the
//! out-of-plane relative velocity is removed and a viscous drag acts in the plane, §4.2.1);
//! otherwise they collide, very dissipatively (§4.2.2). Every change is a velocity
//! modification on a pair of masses that conserves momentum.
//!
//! The paper writes the interpenetration change for one point as Δv_p = −½((v_p − v_s)·n) n,
//! n = σ_p × σ_s: that is the equal-mass case. With masses m_p and m_s the impulse
//! J = −μ((v_p − v_s)·n) n, μ = m_p m_s / (m_p + m_s), gives Δv_p = J/m_p and Δv_s = −J/m_s:
//! the same out-of-plane relative velocity removed, and no momentum made when an envelope point
//! (1/100 of the mass) meets a skeleton point.

use nalgebra::Vector3;

use super::detect::{Contact, PairContacts};
use super::wisp::{Wisps, ENV, MIN_RHO_FRACTION};
use crate::solver::common::damp_relative;

/// Below this |σ_p × σ_s| (sine of the angle between the axes, ≈ 2°) the two axes are taken
/// as parallel and the plane is the one through the second axis and the separation.
pub const PARALLEL_SINE: f64 = 0.035;

/// Reduced mass of two bodies.
#[inline]
pub fn reduced_mass(m1: f64, m2: f64) -> f64 {
    m1 * m2 / (m1 + m2)
}

/// The unit normal of the plane of two segments with unit directions `sigma_p`, `sigma_s`:
/// σ_p × σ_s normalised; when it vanishes (parallel wisps), the normal of the plane through
/// the second axis and `separation` (the vector from that axis to the point); when that
/// vanishes too (the point is on the axis), any direction across the axis. The flag says the
/// axes were parallel.
pub fn plane_normal(
    sigma_p: &Vector3<f64>,
    sigma_s: &Vector3<f64>,
    separation: &Vector3<f64>,
) -> (Vector3<f64>, bool) {
    let n = sigma_p.cross(sigma_s);
    let s = n.norm();
    if s >= PARALLEL_SINE {
        return (n / s, false);
    }
    let m = sigma_s.cross(separation);
    match m.try_normalize(1e-12) {
        Some(m) => (m, true),
        None => (super::wisp::any_perpendicular(sigma_s), true),
    }
}

/// §4.2.1 and §7.1: the pair interpenetrates when its relative velocity lies within the angle
/// whose sine is `sin_threshold` of the plane of normal `n` (no relative velocity: in the plane).
pub fn interpenetrates(v_rel: &Vector3<f64>, n: &Vector3<f64>, sin_threshold: f64) -> bool {
    v_rel.dot(n).abs() <= sin_threshold * v_rel.norm()
}

/// §4.2.1: the impulse on `p` (the other body gets its opposite) that removes the relative
/// velocity along unit `n`, shared by mass.
pub fn interpenetration_impulse(
    vp: &Vector3<f64>,
    mp: f64,
    vs: &Vector3<f64>,
    ms: f64,
    n: &Vector3<f64>,
) -> Vector3<f64> {
    n * (-reduced_mass(mp, ms) * (vp - vs).dot(n))
}

/// §4.2.1: the impulse on `p` of the viscous drag on the relative velocity in the plane of
/// normal `n`: the fraction `min(ν·Δt_c, 1)` of it removed (§5.2's clamp, with the Δt_c/Δt
/// scaling of §5.1 folded in), never reversed.
pub fn drag_impulse(
    vp: &Vector3<f64>,
    mp: f64,
    vs: &Vector3<f64>,
    ms: f64,
    n: &Vector3<f64>,
    nu: f64,
    dt_c: f64,
) -> Vector3<f64> {
    let (vp_in, vs_in) = (vp - n * vp.dot(n), vs - n * vs.dot(n));
    let (dvp, _) = damp_relative(vp_in, mp, vs_in, ms, nu, dt_c);
    dvp * mp
}

/// §4.2.2: the impulse on `p` that sets both velocities to their mass-weighted average.
pub fn collision_impulse(vp: &Vector3<f64>, mp: f64, vs: &Vector3<f64>, ms: f64) -> Vector3<f64> {
    (vs - vp) * reduced_mass(mp, ms)
}

/// §5.1: a velocity modification computed for the main step Δt but applied once per
/// interaction step Δt_c is scaled by Δt_c/Δt; a damping fraction ν·Δt becomes ν·Δt_c, clamped
/// to 1 so that it never reverses the relative velocity (§5.2).
pub fn scaled_fraction(nu: f64, dt: f64, dt_c: f64) -> f64 {
    (nu * dt * (dt_c / dt)).clamp(0.0, 1.0)
}

/// The masses and rates the pair response needs.
#[derive(Debug, Clone, Copy)]
pub struct PairParams {
    /// §4.2.2 on: pairs outside the interpenetration test collide (off: all interpenetrate).
    pub collisions: bool,
    /// Sine of the interpenetration angle.
    pub sin_threshold: f64,
    /// In-plane viscosity ν, s⁻¹ per unit relative density.
    pub viscosity: f64,
    /// Envelope point mass over its skeleton point's.
    pub envelope_mass: f64,
    /// The interaction step Δt_c, s.
    pub dt_c: f64,
}

/// What one interaction step did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairCounts {
    /// Pairs in contact that interpenetrate.
    pub interpenetrating: u32,
    /// Pairs in contact that collide.
    pub collisions: u32,
}

/// Relative density of section `p` of segment S: rest area over current area (a compressed
/// wisp is denser), bounded to [1/4, 4]. The §4.2.1 drag is proportional to it.
fn density(w: &Wisps, p: usize) -> f64 {
    let area = |r: &[f64]| (r[0] + r[2]) * (r[1] + r[3]);
    let now = area(&w.rho[p * ENV..p * ENV + ENV]);
    let rest = area(&w.rho_rest[p * ENV..p * ENV + ENV]);
    (rest / now.max(1e-18)).clamp(0.25, 4.0)
}

fn seg_dir(w: &Wisps, p: usize) -> Vector3<f64> {
    (w.pos[p + 1] - w.pos[p])
        .try_normalize(1e-12)
        .unwrap_or(w.t[p])
}

fn inv_mass(w: &Wisps, p: usize) -> f64 {
    if w.start[w.wisp_of[p] as usize] as usize == p {
        0.0
    } else {
        1.0 / w.mass[p]
    }
}

fn section_extent(w: &Wisps, p: usize) -> f64 {
    w.rho[p * ENV..p * ENV + ENV]
        .iter()
        .fold(0.0f64, |a, &b| a.max(b))
}

/// What the response reads of every section and segment, computed once per interaction step
/// (positions and radii do not change while the pairs respond, only velocities).
#[derive(Debug, Clone, Default)]
pub struct SectionCache {
    /// Per skeleton point `p`: the unit direction of segment `p → p + 1` (the tip: its `t`).
    dir: Vec<Vector3<f64>>,
    /// Per skeleton point: the largest envelope radius of its section.
    extent: Vec<f64>,
    /// Per skeleton point: its section's relative density.
    density: Vec<f64>,
    /// Per skeleton point: 1 / mass, 0 for a root (the head moves it).
    inv_mass: Vec<f64>,
}

impl SectionCache {
    /// Buffers for `w`'s points.
    pub fn new(w: &Wisps) -> SectionCache {
        let n = w.point_count();
        SectionCache {
            dir: vec![Vector3::zeros(); n],
            extent: vec![0.0; n],
            density: vec![0.0; n],
            inv_mass: vec![0.0; n],
        }
    }

    /// Bytes held.
    pub fn capacity_bytes(&self) -> usize {
        self.dir.capacity() * 24
            + (self.extent.capacity() + self.density.capacity() + self.inv_mass.capacity()) * 8
    }

    fn fill(&mut self, w: &Wisps) {
        let n = w.point_count();
        for p in 0..n {
            let tip = p + 1 == n || w.is_root[p + 1];
            self.dir[p] = if tip { w.t[p] } else { seg_dir(w, p) };
            self.extent[p] = section_extent(w, p);
            self.density[p] = density(w, p);
            self.inv_mass[p] = inv_mass(w, p);
        }
    }
}

/// §4.2: classifies each pair in contact (same plane and relative velocity within the angle:
/// interpenetration; else collision) and applies its response to each of its contacts, in
/// detection order (each contact sees the velocities the previous ones left).
pub fn respond(
    w: &mut Wisps,
    pairs: &[PairContacts],
    contacts: &[Contact],
    pp: &PairParams,
    cache: &mut SectionCache,
) -> PairCounts {
    let mut counts = PairCounts::default();
    if pairs.is_empty() {
        return counts;
    }
    cache.fill(w);
    let cache = &*cache;
    for pair in pairs {
        let (a, b) = (pair.a as usize, pair.b as usize);
        let (sa, sb) = (cache.dir[a], cache.dir[b]);
        let (ma, mb) = (
            (w.pos[a] + w.pos[a + 1]) * 0.5,
            (w.pos[b] + w.pos[b + 1]) * 0.5,
        );
        let v_rel = (w.vel[a] + w.vel[a + 1] - w.vel[b] - w.vel[b + 1]) * 0.5;
        let sep = (ma - mb) - sb * (ma - mb).dot(&sb);
        let (n, _) = plane_normal(&sa, &sb, &sep);
        // "Are the two skeletons in one plane": their offset out of it is within their
        // thicknesses (always nearly so for segments in contact).
        let ext = &cache.extent;
        let thick = ext[a + 1].max(ext[a]) + ext[b + 1].max(ext[b]);
        let coplanar = (ma - mb).dot(&n).abs() <= thick;
        let inter = !pp.collisions || (coplanar && interpenetrates(&v_rel, &n, pp.sin_threshold));
        if inter {
            counts.interpenetrating += 1;
        } else {
            counts.collisions += 1;
        }
        for c in &contacts[pair.first as usize..pair.end as usize] {
            respond_contact(w, c, inter, pp, cache);
        }
        if !inter {
            collide_segments(w, a, b, &cache.inv_mass);
        }
    }
    counts
}

/// Mass of a segment's two skeleton points (a kinematic root counts as immovable) and their
/// mass-weighted velocity.
fn segment_momentum(w: &Wisps, p: usize, inv: &[f64]) -> (f64, Vector3<f64>) {
    let (ia, ib) = (inv[p], inv[p + 1]);
    if ia == 0.0 || ib == 0.0 {
        let v = if ia == 0.0 { w.vel[p] } else { w.vel[p + 1] };
        return (super::forces::KINEMATIC_MASS, v);
    }
    let (ma, mb) = (w.mass[p], w.mass[p + 1]);
    (ma + mb, (w.vel[p] * ma + w.vel[p + 1] * mb) / (ma + mb))
}

/// §4.2.2 "we simply eliminate the relative velocities of the point-masses located in the
/// contact area": besides the contact points, the two colliding segments' skeletons take the
/// mass-weighted average of their velocities (each segment keeps its internal motion).
fn collide_segments(w: &mut Wisps, a: usize, b: usize, inv: &[f64]) {
    let (ma, va) = segment_momentum(w, a, inv);
    let (mb, vb) = segment_momentum(w, b, inv);
    let j = collision_impulse(&va, ma, &vb, mb);
    for (p, m, sign) in [(a, ma, 1.0), (b, mb, -1.0)] {
        let dv = j * (sign / m);
        for q in [p, p + 1] {
            if inv[q] > 0.0 {
                w.vel[q] += dv;
            }
        }
    }
}

fn respond_contact(w: &mut Wisps, c: &Contact, inter: bool, pp: &PairParams, cache: &SectionCache) {
    let q = c.point as usize;
    let own = q - 1;
    let seg = c.seg as usize;
    let s = c.s;
    // An envelope point crushed to its smallest radius is rigid along its half-line: it
    // moves with its skeleton point, with the skeleton point's mass ("if the object moves
    // further, the entire wisp itself should move", §3.3).
    let env = (c.which as usize) < ENV && {
        let e = q * ENV + c.which as usize;
        w.rho[e] > MIN_RHO_FRACTION * w.rho_rest[e] * (1.0 + 1e-6)
    };
    let (xp, vp, mp, dir) = if env {
        let j = c.which as usize;
        (
            w.env_pos(q, j),
            w.env_vel(q, j),
            pp.envelope_mass * w.mass[q],
            w.env_dir(q, j),
        )
    } else if (c.which as usize) < ENV {
        let j = c.which as usize;
        (
            w.env_pos(q, j),
            w.env_vel(q, j),
            w.mass[q],
            Vector3::zeros(),
        )
    } else {
        (w.pos[q], w.vel[q], w.mass[q], Vector3::zeros())
    };
    let (ia, ib) = (cache.inv_mass[seg], cache.inv_mass[seg + 1]);
    let denom = (1.0 - s).powi(2) * ia + s * s * ib;
    let ms = if denom > 0.0 {
        1.0 / denom
    } else {
        super::forces::KINEMATIC_MASS
    };
    let vs = w.vel[seg] * (1.0 - s) + w.vel[seg + 1] * s;
    let axis = w.pos[seg] * (1.0 - s) + w.pos[seg + 1] * s;
    let (n, _) = plane_normal(&cache.dir[own], &cache.dir[seg], &(xp - axis));
    let j = if inter {
        let j1 = interpenetration_impulse(&vp, mp, &vs, ms, &n);
        let nu = pp.viscosity * cache.density[if s < 0.5 { seg } else { seg + 1 }];
        let (vp1, vs1) = (vp + j1 / mp, vs - j1 / ms);
        j1 + drag_impulse(&vp1, mp, &vs1, ms, &n, nu, pp.dt_c)
    } else {
        collision_impulse(&vp, mp, &vs, ms)
    };
    if env {
        // Along its half-line the envelope point takes it; across, the constraint passes it to
        // its skeleton point (§5.1: operations on envelope points are projected on the axis).
        let e = q * ENV + c.which as usize;
        let jr = j.dot(&dir);
        w.rho_rate[e] += jr / mp;
        w.vel[q] += (j - dir * jr) / w.mass[q];
    } else {
        w.vel[q] += j / mp;
    }
    w.vel[seg] -= j * ((1.0 - s) * ia);
    w.vel[seg + 1] -= j * (s * ib);
}
