//! Plante, Cani, Poulin 2002, §4.3 against the body's capsules and meshes: the same sliding
//! contact (§4.3.1) and penetration reaction (§4.3.2) as against the spheres in `body.rs`, with
//! the surface's signed distance and normal from [`crate::solver::body`] in place of the
//! sphere's centre and radius.

use nalgebra::Point3;

use super::body::sliding_delta;
use super::wisp::{Wisps, ENV};
use crate::motion::Pose;
use crate::solver::body::{probe, Collider};

/// §4.3.1 on every non-root skeleton and envelope point within `threshold` of a shape.
/// Returns the points in contact.
pub fn sliding_contact(
    w: &mut Wisps,
    colliders: &[Collider],
    pose: &Pose,
    threshold: f64,
    drag: f64,
) -> u32 {
    let mut contacts = 0;
    for p in 0..w.point_count() {
        if w.is_root[p] {
            continue;
        }
        let reach = reach(w, p) + threshold;
        // Far from every shape: neither the point nor its envelope can be in contact.
        if probe(colliders, pose, &w.pos[p], reach).is_none() {
            continue;
        }
        if let Some(c) = probe(colliders, pose, &w.pos[p], threshold) {
            if c.distance < threshold {
                let vb = pose.velocity_at(&Point3::from(w.pos[p]));
                let dv = sliding_delta(&(w.vel[p] - vb), &c.normal, drag);
                w.vel[p] += dv;
                contacts += 1;
            }
        }
        for j in 0..ENV {
            let x = w.env_pos(p, j);
            if let Some(c) = probe(colliders, pose, &x, threshold) {
                if c.distance < threshold {
                    let vb = pose.velocity_at(&Point3::from(x));
                    let dir = w.env_dir(p, j);
                    let dv = sliding_delta(&(w.env_vel(p, j) - vb), &c.normal, drag);
                    w.rho_rate[p * ENV + j] += dv.dot(&dir);
                    contacts += 1;
                }
            }
        }
    }
    contacts
}

/// The largest envelope radius of section `p`.
fn reach(w: &Wisps, p: usize) -> f64 {
    w.rho[p * ENV..p * ENV + ENV]
        .iter()
        .fold(0.0f64, |m, &r| m.max(r))
}

/// §4.3.2, root to tip, on wisps whose frames may be stale: a skeleton point inside a shape
/// moves out to `margin` from the surface at its spring's length from the previous point (a
/// few rounds of push and length), and the rest of the wisp moves with it; then its envelope
/// points inside a shape move along their half-lines to the surface. Returns the points moved.
pub fn penetration_reaction(
    w: &mut Wisps,
    colliders: &[Collider],
    pose: &Pose,
    margin: f64,
) -> u32 {
    let mut moved = 0;
    for wi in 0..w.len() {
        let r = w.points(wi);
        let near = (r.start + 1..r.end)
            .any(|p| probe(colliders, pose, &w.pos[p], reach(w, p) + margin).is_some());
        if !near {
            continue;
        }
        w.compute_wisp_frames(wi, pose);
        let moved_before = moved;
        for p in r.start + 1..r.end {
            let before = w.pos[p];
            let prev = w.pos[p - 1];
            let len = (before - prev).norm();
            let mut x = before;
            for round in 0..4 {
                let Some(c) = probe(colliders, pose, &x, 0.0) else {
                    break;
                };
                if c.distance >= 0.0 {
                    break;
                }
                x += c.normal * (margin - c.distance);
                let d = x - prev;
                let n = d.norm();
                if round < 3 && n > 1e-12 {
                    x = prev + d * (len / n);
                }
            }
            if x != before {
                let delta = x - before;
                for q in p..r.end {
                    w.pos[q] += delta;
                }
                // Completely inelastic: no velocity towards the body is kept.
                if let Some(c) = probe(colliders, pose, &x, 2.0 * margin.max(1e-4)) {
                    let vb = pose.velocity_at(&Point3::from(x));
                    let dv = sliding_delta(&(w.vel[p] - vb), &c.normal, 0.0);
                    w.vel[p] += dv;
                }
                moved += 1;
            }
        }
        if moved > moved_before {
            w.compute_wisp_frames(wi, pose);
        }
        for p in r.start + 1..r.end {
            for j in 0..ENV {
                let e = p * ENV + j;
                let x = w.env_pos(p, j);
                if !probe(colliders, pose, &x, 0.0).is_some_and(|c| c.distance < 0.0) {
                    continue;
                }
                // The half-line's entry into the shape, by bisection between the skeleton
                // point (outside after the reaction) and the envelope point (inside).
                let dir = w.env_dir(p, j);
                let (mut lo, mut hi) = (0.0, w.rho[e]);
                if probe(colliders, pose, &w.pos[p], 0.0).is_some_and(|c| c.distance < 0.0) {
                    continue;
                }
                for _ in 0..24 {
                    let mid = 0.5 * (lo + hi);
                    let y = w.pos[p] + dir * mid;
                    if probe(colliders, pose, &y, 0.0).is_some_and(|c| c.distance < 0.0) {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                w.rho[e] = lo.min(w.rho[e]);
                let y = w.env_pos(p, j);
                if let Some(c) = probe(colliders, pose, &y, margin.max(1e-4)) {
                    let vb = pose.velocity_at(&Point3::from(y));
                    let dv = sliding_delta(&(w.env_vel(p, j) - vb), &c.normal, 0.0);
                    w.rho_rate[e] += dv.dot(&dir);
                }
                moved += 1;
            }
        }
    }
    moved
}
