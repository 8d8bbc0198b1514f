//! Forces and explicit Euler integration of the wisps (Plante, Cani, Poulin 2002, §3.2–3.4,
//! §5.1–5.2): gravity, skeleton springs (linear and angular), the envelope's radial and ring
//! springs; velocities then velocity modifications (spring damping, air drag), then positions.
//! Each wisp is processed root to tip, the skeleton point before its envelope points, so an
//! envelope point reacts to its skeleton point's new acceleration (§3.4).

use nalgebra::Vector3;

use super::wisp::{Wisps, ENV, MIN_RHO_FRACTION};

/// Mass standing for "kinematic" (the root, which the head moves) in the §5.2 mass shares.
pub const KINEMATIC_MASS: f64 = 1e30;

/// The coefficients the integration needs, resolved from the style once.
#[derive(Debug, Clone, Copy)]
pub struct Coeffs {
    /// Gravity, m/s².
    pub gravity: Vector3<f64>,
    /// Air drag rate, s⁻¹.
    pub air_drag: f64,
    /// Wind velocity (steady part), m/s.
    pub wind: Vector3<f64>,
    /// Linear spring stiffness per kilogram, s⁻².
    pub stiffness: f64,
    /// Linear spring damping ν, s⁻¹.
    pub damping: f64,
    /// Angular spring stiffness per kilogram, s⁻².
    pub bending: f64,
    /// Angular damping ν, s⁻¹.
    pub bending_damping: f64,
    /// Envelope point mass over its skeleton point's.
    pub envelope_mass: f64,
    /// Radial spring per kilogram, s⁻².
    pub envelope_stiffness: f64,
    /// Ring spring per kilogram, s⁻².
    pub ring_stiffness: f64,
    /// Envelope damping ν, s⁻¹.
    pub envelope_damping: f64,
}

/// The mass shares of the §5.2 dampings, per skeleton point: `min(ν·dt, 1)·m₂/(m₁ + m₂)` and
/// `min(ν·dt, 1)·m₁/(m₁ + m₂)` for the linear and the angular damper of the segment that ends
/// at the point (m₁ the previous point's mass, kinematic for a root), and for the envelope's
/// radial dampers (m₁ the point's, m₂ an envelope point's). Masses and rates do not change
/// during a run, so they are computed once.
#[derive(Debug, Clone, Default)]
pub struct Shares {
    /// Per point: linear (to previous, to this), angular (to previous, to this).
    skeleton: Vec<[f64; 4]>,
    /// Per point: envelope damping (to the skeleton point, to the envelope point).
    envelope: Vec<[f64; 2]>,
}

impl Shares {
    /// The shares of `w`'s points under `c` at step `dt`.
    pub fn new(w: &Wisps, c: &Coeffs, dt: f64) -> Shares {
        let mut s = Shares::default();
        s.update(w, c, dt);
        s
    }

    /// Recomputes them in place (same point count).
    pub fn update(&mut self, w: &Wisps, c: &Coeffs, dt: f64) {
        let n = w.point_count();
        let pair = |nu: f64, m1: f64, m2: f64| {
            let f = (nu * dt).clamp(0.0, 1.0);
            [f * m2 / (m1 + m2), f * m1 / (m1 + m2)]
        };
        self.skeleton.resize(n, [0.0; 4]);
        self.envelope.resize(n, [0.0; 2]);
        for p in 0..n {
            let m = w.mass[p];
            if !w.is_root[p] {
                let mq = if w.is_root[p - 1] {
                    KINEMATIC_MASS
                } else {
                    w.mass[p - 1]
                };
                let [a, b] = pair(c.damping, mq, m);
                let [e, f] = pair(c.bending_damping, mq, m);
                self.skeleton[p] = [a, b, e, f];
            }
            let ms = if w.is_root[p] { KINEMATIC_MASS } else { m };
            self.envelope[p] = pair(c.envelope_damping, ms, c.envelope_mass * m);
        }
    }
}

/// §5.1 item 1: every force, from the current positions and frames.
pub fn accumulate_forces(w: &mut Wisps, c: &Coeffs) {
    let n = w.point_count();
    let Wisps {
        start,
        pos,
        force,
        mass,
        rest_len,
        rest_dir,
        t,
        u,
        v,
        rho,
        rho_rest,
        rho_force,
        ring_rest,
        seg_len,
        seg_dir,
        ..
    } = w;
    for (f, m) in force.iter_mut().zip(mass.iter()) {
        *f = c.gravity * *m;
    }
    for r in start.windows(2) {
        let (a, b) = (r[0] as usize, r[1] as usize);
        for p in a..b.saturating_sub(1) {
            let q = p + 1;
            let s = pos[q] - pos[p];
            let len = seg_len[p];
            if len < 1e-12 {
                continue;
            }
            let d = seg_dir[p];
            let m = mass[p].min(mass[q]);
            // Linear spring (§3.2).
            let f = d * (-c.stiffness * m * (len - rest_len[p]));
            // Angular spring (§3.2): the segment is pulled towards its rest direction expressed
            // in its start's twist-free section frame; only the part across the segment bends it.
            let rd = rest_dir[p];
            let target = (t[p] * rd.x + u[p] * rd.y + v[p] * rd.z) * len;
            let diff = target - s;
            let bend = (diff - d * diff.dot(&d)) * (c.bending * mass[q]);
            force[q] += f + bend;
            force[p] -= f + bend;
        }
    }
    // Envelope (§3.3): radial springs to the skeleton point, ring springs between neighbours
    // of a section. The part of a ring force across an envelope point's half-line is the
    // constraint's reaction: it goes to the skeleton point.
    let rho = &rho[..n * ENV];
    let rho_rest = &rho_rest[..n * ENV];
    let ring_rest = &ring_rest[..n * ENV];
    let rho_force = &mut rho_force[..n * ENV];
    for p in 0..n {
        let me = c.envelope_mass * mass[p];
        let mut skel = Vector3::zeros();
        let dirs = [u[p], v[p], -u[p], -v[p]];
        let e0 = p * ENV;
        let r: &[f64; ENV] = rho[e0..e0 + ENV].try_into().unwrap();
        let r0: &[f64; ENV] = rho_rest[e0..e0 + ENV].try_into().unwrap();
        let d0s: &[f64; ENV] = ring_rest[e0..e0 + ENV].try_into().unwrap();
        let rf: &mut [f64; ENV] = (&mut rho_force[e0..e0 + ENV]).try_into().unwrap();
        for j in 0..ENV {
            let radial = -c.envelope_stiffness * me * (r[j] - r0[j]);
            rf[j] = radial;
            skel -= dirs[j] * radial;
        }
        for j in 0..ENV {
            let k = (j + 1) % ENV;
            let (rj, rk) = (r[j], r[k]);
            let d = (rj * rj + rk * rk).sqrt();
            if d < 1e-12 {
                continue;
            }
            let cc = c.ring_stiffness * me * (d - d0s[j]) / d;
            rf[j] -= cc * rj;
            rf[k] -= cc * rk;
            skel += (dirs[j] * rj + dirs[k] * rk) * cc;
        }
        force[p] += skel;
    }
}

/// §5.1 item 3: new velocities from the forces, then the velocity modifications of the springs'
/// damping and of the air drag (§5.2: each reduces a relative velocity, never reverses it).
pub fn integrate_velocities(w: &mut Wisps, c: &Coeffs, sh: &Shares, dt: f64) {
    for wi in 0..w.len() {
        let r = w.points(wi);
        // The angular damper damps the rate of change of the bend: the velocity of a segment's
        // end across it, relative to what a rigid continuation of the previous segment would
        // give (the first segment continues the head-fixed one from the anchor).
        let mut prev_rel = w.vel[r.start] - w.anchor_vel[wi];
        let mut prev_len = (w.pos[r.start] - w.anchor[wi]).norm().max(1e-9);
        for p in r.clone() {
            let root = p == r.start;
            if !root {
                let m = w.mass[p];
                w.vel[p] += w.force[p] * (dt / m);
                let q = p - 1;
                let l = w.seg_len[q];
                let len = l.max(1e-9);
                let d = if l >= 1e-9 {
                    w.seg_dir[q]
                } else {
                    (w.pos[p] - w.pos[q]) / len
                };
                let [lq, lp, bq, bp] = sh.skeleton[p];
                // Linear spring damping along the segment (§5.2).
                let (vq, vp) = (w.vel[q], w.vel[p]);
                let (dq1, dp1) = damp_shared(d * vq.dot(&d), d * vp.dot(&d), lq, lp);
                // Angular spring damping across it, about the rigid continuation.
                let rel = vp - vq;
                let expected = prev_rel * (len / prev_len);
                let dev = (rel - expected) - d * (rel - expected).dot(&d);
                let (dq2, dp2) = damp_shared(Vector3::zeros(), dev, bq, bp);
                w.vel[p] += dp1 + dp2;
                if q != r.start {
                    w.vel[q] += dq1 + dq2;
                }
                let f = (c.air_drag * dt).min(1.0);
                let drag = (w.vel[p] - c.wind) * f;
                w.vel[p] -= drag;
                prev_rel = w.vel[p] - w.vel[q];
                prev_len = len;
            }
            integrate_envelope(w, c, sh, p, root, dt);
        }
    }
}

/// The envelope of skeleton point `p`, after it: the radial equation in the frame of the
/// (accelerating) skeleton point, then the §5.2 damping of the radial springs.
fn integrate_envelope(w: &mut Wisps, c: &Coeffs, sh: &Shares, p: usize, root: bool, dt: f64) {
    let me = c.envelope_mass * w.mass[p];
    let [ks, ke] = sh.envelope[p];
    let acc = (w.vel[p] - w.prev_vel[p]) / dt;
    let dirs = w.env_dirs(p);
    for (j, &dir) in dirs.iter().enumerate() {
        let e = p * ENV + j;
        w.rho_rate[e] += (w.rho_force[e] / me + (c.gravity - acc).dot(&dir)) * dt;
        let vs = dir * w.vel[p].dot(&dir);
        let ve = vs + dir * w.rho_rate[e];
        let (dvs, dve) = damp_shared(vs, ve, ks, ke);
        w.rho_rate[e] += dve.dot(&dir) - dvs.dot(&dir);
        if !root {
            w.vel[p] += dvs;
        }
    }
}

/// `common::damp_relative` (§5.2) with its mass shares already computed
/// ([`Shares`]): the same arithmetic.
#[inline]
fn damp_shared(
    v1: Vector3<f64>,
    v2: Vector3<f64>,
    share1: f64,
    share2: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let rel = v2 - v1;
    (rel * share1, -rel * share2)
}

/// §5.1 item 4: new positions from the new velocities (the roots are placed by the pose). The
/// envelope radius stays positive: a crushed section stops at [`MIN_RHO_FRACTION`] of its rest
/// radius.
pub fn integrate_positions(w: &mut Wisps, dt: f64) {
    for ((x, v), &root) in w.pos.iter_mut().zip(&w.vel).zip(&w.is_root) {
        if !root {
            *x += v * dt;
        }
    }
    for ((r, rate), &rest) in w.rho.iter_mut().zip(w.rho_rate.iter_mut()).zip(&w.rho_rest) {
        *r += *rate * dt;
        let lo = MIN_RHO_FRACTION * rest;
        if *r < lo {
            *r = lo;
            *rate = rate.max(0.0);
        }
    }
}
