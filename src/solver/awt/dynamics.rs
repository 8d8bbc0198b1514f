//! Forces, integration and links of the active nodes (AWT §2.3).
//!
//! Straight hair: symplectic Euler followed by rigid links projected iteratively (Van Overveld
//! style, mass-weighted Gauss–Seidel sweeps) and a last root-to-tip pass that makes every link
//! exactly its rest length; velocities are then the position change over the step.
//! Curly hair: viscous springs integrated with one implicit Euler step. The AWT is a tree, so the
//! linear system is solved exactly in O(n) by eliminating nodes from the tips to the roots.
//! Damping is always a velocity modification that can bring a relative velocity to zero but
//! never reverse it (Plante et al. 2002 §5.2).

use nalgebra::{Matrix3, Point3, Vector3};

use crate::model::HairModel;
use crate::motion::Pose;
use crate::style::{Link, SimParams};

use super::collide::BodySphere;
use super::{Slots, NO_SLOT};

/// Scratch buffers of the implicit spring solve, kept between steps.
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    a: Vec<Matrix3<f64>>,
    a_inv: Vec<Matrix3<f64>>,
    coupling: Vec<Matrix3<f64>>,
    b: Vec<Vector3<f64>>,
    dv: Vec<Vector3<f64>>,
}

/// Remembers the start-of-step positions and velocities.
pub fn begin_step(s: &mut Slots) {
    s.prev_pos.copy_from_slice(&s.pos);
    s.vel_start.copy_from_slice(&s.vel);
}

/// Roots are attached to the scalp: they take the pose's position and velocity.
pub fn pose_roots(m: &HairModel, pose: &Pose, s: &mut Slots) {
    for c in 0..s.len() {
        if s.parent[c] != NO_SLOT {
            continue;
        }
        let rest = m.levels[s.level[c] as usize].rest_pos[s.node[c] as usize];
        let x = pose.transform_point(&Point3::from(rest)).coords;
        s.pos[c] = x;
        s.prev_pos[c] = x;
        s.vel[c] = pose.velocity_at(&Point3::from(x));
    }
}

/// Gravity and the styling pull (`bending`) into `s.force`.
pub fn external_forces(m: &HairModel, p: &SimParams, pose: &Pose, _t: f64, s: &mut Slots) {
    let g = Vector3::from(p.gravity);
    let k_last = (m.k - 1).max(1) as f64;
    for c in 0..s.len() {
        s.force[c] = g * s.mass[c];
    }
    if p.bending > 0.0 {
        for c in 0..s.len() {
            let pa = s.parent[c];
            if pa == NO_SLOT {
                continue;
            }
            let pa = pa as usize;
            // Styled direction of this link in the head frame, pulled towards with a stiffness
            // that fades from the root to nothing at the tip.
            let fade = 1.0 - s.cs[c] as f64 / k_last;
            let k = p.bending * fade * s.mass[c];
            let target = pose.transform_vector(&s.rest_vec[c]);
            let f = (target - (s.pos[c] - s.pos[pa])) * k;
            s.force[c] += f;
            s.force[pa] -= f;
        }
    }
}

/// Advances velocities and positions of the non-root nodes by one step.
pub fn integrate(
    link: &Link,
    p: &SimParams,
    t: f64,
    dt: f64,
    s: &mut Slots,
    scratch: &mut Scratch,
) {
    match *link {
        Link::Rigid { .. } => {
            for c in 0..s.len() {
                if s.parent[c] == NO_SLOT {
                    continue;
                }
                s.vel[c] += s.force[c] * (dt / s.mass[c]);
            }
        }
        Link::Spring { stiffness, damping } => {
            implicit_springs(stiffness, damping, dt, s, scratch);
        }
    }
    // Air drag towards the wind: the air is an infinitely heavy partner.
    let f = (p.air_drag * dt).clamp(0.0, 1.0);
    for c in 0..s.len() {
        if s.parent[c] == NO_SLOT {
            continue;
        }
        if f > 0.0 {
            let w = crate::solver::common::wind_at(p, &s.pos[c], t);
            let v = s.vel[c];
            s.vel[c] = v + (w - v) * f;
        }
        s.pos[c] += s.vel[c] * dt;
    }
}

/// One implicit Euler step of the viscous springs plus the forces in `s.force`, solved exactly on
/// the tree: `(M − dt·∂f/∂v − dt²·∂f/∂x) Δv = dt·(f + dt·∂f/∂x·v)`.
fn implicit_springs(stiffness: f64, damping: f64, dt: f64, s: &mut Slots, sc: &mut Scratch) {
    let n = s.len();
    sc.a.clear();
    sc.a_inv.clear();
    sc.coupling.clear();
    sc.b.clear();
    sc.dv.clear();
    sc.a.extend((0..n).map(|c| Matrix3::identity() * s.mass[c]));
    sc.a_inv.resize(n, Matrix3::zeros());
    sc.coupling.resize(n, Matrix3::zeros());
    sc.b.extend((0..n).map(|c| s.force[c] * dt));
    sc.dv.resize(n, Vector3::zeros());
    let id = Matrix3::identity();
    for c in 0..n {
        let pa = s.parent[c];
        if pa == NO_SLOT {
            continue;
        }
        let pa = pa as usize;
        let d = s.pos[c] - s.pos[pa];
        let len = d.norm().max(1e-9);
        let u = d / len;
        let rest = s.rest_len[c];
        // Per kilogram carried, so every link of a hanging strand stretches alike.
        let k = stiffness * s.mass_below[c];
        let kd = damping * s.mass_below[c];
        let vrel = s.vel[c] - s.vel[pa];
        let uu = u * u.transpose();
        let f_s = -u * (k * (len - rest)) - u * (kd * vrel.dot(&u));
        // ∂f_c/∂x_c; the transverse term is dropped when compressed to keep the matrix definite.
        let kmat = -(uu + (id - uu) * (1.0 - rest / len).max(0.0)) * k;
        let dmat = -uu * kd;
        let coupling = -dmat * dt - kmat * (dt * dt);
        let rhs = (f_s + kmat * vrel * dt) * dt;
        sc.a[c] += coupling;
        sc.b[c] += rhs;
        if s.parent[pa] != NO_SLOT {
            sc.a[pa] += coupling;
            sc.b[pa] -= rhs;
        }
        sc.coupling[c] = coupling;
    }
    // Eliminate from the tips: slots are topologically ordered, so children come after parents.
    for c in (0..n).rev() {
        let pa = s.parent[c];
        if pa == NO_SLOT {
            continue;
        }
        let inv = sc.a[c].try_inverse().unwrap_or_else(|| id / s.mass[c]);
        sc.a_inv[c] = inv;
        let pa = pa as usize;
        if s.parent[pa] != NO_SLOT {
            let bc = sc.coupling[c];
            let t = bc * inv;
            sc.a[pa] -= t * bc;
            let add = t * sc.b[c];
            sc.b[pa] += add;
        }
    }
    for c in 0..n {
        let pa = s.parent[c];
        if pa == NO_SLOT {
            continue;
        }
        let dvp = if s.parent[pa as usize] == NO_SLOT {
            Vector3::zeros()
        } else {
            sc.dv[pa as usize]
        };
        sc.dv[c] = sc.a_inv[c] * (sc.b[c] + sc.coupling[c] * dvp);
        s.vel[c] += sc.dv[c];
    }
}

/// Rigid links (Van Overveld): `iterations` mass-weighted sweeps, then a root-to-tip pass that
/// sets every link to its rest length exactly.
pub fn project_rigid_links(s: &mut Slots, iterations: u32) {
    // The weights once per call rather than two divisions per link and iteration (the same
    // values, so the same bits).
    s.link_weight.clear();
    s.link_weight
        .extend(
            s.parent
                .iter()
                .zip(&s.mass)
                .map(|(&pa, &m)| if pa == NO_SLOT { 0.0 } else { 1.0 / m }),
        );
    for _ in 0..iterations {
        for c in 0..s.len() {
            let pa = s.parent[c];
            if pa == NO_SLOT {
                continue;
            }
            let pa = pa as usize;
            let (wc, wp) = (s.link_weight[c], s.link_weight[pa]);
            let d = s.pos[c] - s.pos[pa];
            let len = d.norm();
            if len < 1e-12 {
                continue;
            }
            let corr = d * ((len - s.rest_len[c]) / (len * (wc + wp)));
            s.pos[c] -= corr * wc;
            s.pos[pa] += corr * wp;
        }
    }
    for c in 0..s.len() {
        let pa = s.parent[c];
        if pa == NO_SLOT {
            continue;
        }
        let pa = pa as usize;
        let d = s.pos[c] - s.pos[pa];
        let len = d.norm();
        if len > 1e-12 {
            s.pos[c] = s.pos[pa] + d * (s.rest_len[c] / len);
        }
    }
}

/// Rigid links: velocities from the step's whole position change (integration, links, body),
/// except for nodes in contact with the body, which keep the obstacle's velocity (static
/// friction, §4.3). Computing them after every correction keeps the corrections from feeding
/// energy back into the hair.
pub fn rigid_velocities(s: &mut Slots, dt: f64) {
    let inv_dt = 1.0 / dt;
    for c in 0..s.len() {
        if s.parent[c] != NO_SLOT && !s.contact[c] {
            s.vel[c] = (s.pos[c] - s.prev_pos[c]) * inv_dt;
        }
    }
}

/// After the body pushed nodes out: a root-to-tip pass that restores rigid lengths while staying
/// out of the spheres (the nearest point at link length from the parent on the sphere surface).
/// A node that had to be moved takes the obstacle's velocity (static friction, §4.3).
/// The body's capsules and meshes (`colliders`) get the same treatment, by a push along their
/// normal and the length put back, a few rounds.
pub fn restore_lengths_outside(
    s: &mut Slots,
    spheres: &[BodySphere],
    colliders: &[crate::solver::body::Collider],
    pose: &Pose,
) {
    for c in 0..s.len() {
        let pa = s.parent[c];
        if pa == NO_SLOT {
            continue;
        }
        let p = s.pos[pa as usize];
        let len = s.rest_len[c];
        let d = s.pos[c] - p;
        let n = d.norm();
        let mut x = if n > 1e-12 {
            p + d * (len / n)
        } else {
            s.pos[c]
        };
        let mut touched = false;
        // Overlapping spheres can push a node into each other: a few rounds settle it.
        for _ in 0..4 {
            let mut moved = false;
            for sp in spheres {
                if surely_outside(&x, sp) || (x - sp.center).norm() >= sp.radius {
                    continue;
                }
                moved = true;
                x = nearest_on_circle(&p, len, &sp.center, sp.radius, &x);
            }
            touched |= moved;
            if !moved {
                break;
            }
        }
        // In the crease between two spheres the circle may not leave both: staying outside
        // wins over the exact length there.
        for _ in 0..4 {
            let mut moved = false;
            for sp in spheres {
                if surely_outside(&x, sp) {
                    continue;
                }
                let d = x - sp.center;
                let n = d.norm();
                if n >= sp.radius {
                    continue;
                }
                moved = true;
                let dir = if n > 1e-12 { d / n } else { Vector3::y() };
                x = sp.center + dir * (sp.radius * (1.0 + 1e-7));
            }
            if !moved {
                break;
            }
        }
        if !colliders.is_empty() {
            for round in 0..4 {
                let Some((y, _)) = crate::solver::body::push_out(colliders, pose, &x, 0.0) else {
                    break;
                };
                touched = true;
                x = y;
                // Back to link length from the parent, unless this is the last round (outside
                // wins over the exact length, as in the crease between spheres).
                let d = x - p;
                let n = d.norm();
                if round < 3 && n > 1e-12 {
                    x = p + d * (len / n);
                }
            }
        }
        s.pos[c] = x;
        if touched {
            s.vel[c] = pose.velocity_at(&Point3::from(x));
            s.contact[c] = true;
        }
    }
}

/// Whether `x` is outside `s` by a margin far above the rounding of `|x − c| ≥ r`, so that
/// the exact test (a square root per sphere) would say so too: most nodes are far from most
/// spheres, and this pass runs over every node once or twice a step.
#[inline]
fn surely_outside(x: &Vector3<f64>, s: &BodySphere) -> bool {
    (x - s.center).norm_squared() > s.radius * s.radius * (1.0 + 1e-6)
}

/// The point at distance `len` from `p` and on the sphere `(centre, radius)` nearest to `x`;
/// if the two spheres do not meet, `x` pushed radially out of the obstacle.
fn nearest_on_circle(
    p: &Vector3<f64>,
    len: f64,
    centre: &Vector3<f64>,
    radius: f64,
    x: &Vector3<f64>,
) -> Vector3<f64> {
    let push_out = || {
        let d = x - centre;
        let n = d.norm();
        let dir = if n > 1e-12 { d / n } else { Vector3::y() };
        centre + dir * (radius * (1.0 + 1e-7))
    };
    let cp = centre - p;
    let dist = cp.norm();
    if dist < 1e-12 || dist > radius + len || dist < (radius - len).abs() {
        return push_out();
    }
    let nrm = cp / dist;
    let a = (len * len - radius * radius + dist * dist) / (2.0 * dist);
    let h = (len * len - a * a).max(0.0).sqrt();
    let q = p + nrm * a;
    let w = (x - q) - nrm * (x - q).dot(&nrm);
    let wn = w.norm();
    let dir = if wn > 1e-12 {
        w / wn
    } else {
        let any = if nrm.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        nrm.cross(&any).normalize()
    };
    // Nudge outwards by a hair so the result is not inside by rounding.
    let y = q + dir * h;
    let out = y - centre;
    centre + out * ((radius * (1.0 + 1e-7)) / out.norm())
}

/// Smoothed world-frame acceleration from the velocity change over the step: an exponential
/// moving average with weight `smoothing` on the newest value (1 = no smoothing).
pub fn update_accelerations(s: &mut Slots, dt: f64, smoothing: f64) {
    for c in 0..s.len() {
        // A node held by the body moves with it (static friction, §4.3): the velocity jump of
        // the contact is the body's doing, not hair motion, and would make resting hair that
        // touches and leaves a shoulder every other step split forever.
        let a = if s.contact[c] {
            Vector3::zeros()
        } else {
            (s.vel[c] - s.vel_start[c]) / dt
        };
        s.acc[c] = s.acc[c] * (1.0 - smoothing) + a * smoothing;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::common::{random_unit, uniform_stream};

    /// The squared-distance test says "outside" only where the exact `|x − c| ≥ r` does, on
    /// random points around a sphere and on points within a relative 1e-7 of its surface.
    #[test]
    fn surely_outside_agrees_with_the_exact_test() {
        let mut rand = uniform_stream(0x9e37_79b9_7f4a_7c15);
        let s = BodySphere {
            center: Vector3::new(0.0, 1.25, -0.02),
            radius: 0.15,
        };
        let (mut skipped, mut inside) = (0, 0);
        for k in 0..200_000 {
            let u = random_unit(&mut rand);
            let r = if k % 2 == 0 {
                3.0 * s.radius * rand()
            } else {
                s.radius * (1.0 + 2e-7 * (rand() - 0.5))
            };
            let x = s.center + u * r;
            let exact_outside = (x - s.center).norm() >= s.radius;
            if surely_outside(&x, &s) {
                skipped += 1;
                assert!(exact_outside, "{x:?} skipped but inside");
            }
            inside += !exact_outside as u32;
        }
        assert!(
            skipped > 50_000 && inside > 20_000,
            "{skipped} skipped, {inside} inside"
        );
    }
}
