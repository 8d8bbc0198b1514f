//! Collisions with the character (Plante, Cani, Poulin 2002, §4.3) against the body spheres the
//! AWT uses: a sliding contact within a distance of the surface (velocity modification), then
//! a penetration reaction root to tip (position modification).

use nalgebra::{Point3, Vector3};

use super::wisp::{Wisps, ENV};
use crate::motion::Pose;

/// A body sphere where the pose puts it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Centre, m.
    pub center: Vector3<f64>,
    /// Radius, m.
    pub radius: f64,
}

/// Passes over the spheres when a reaction out of one sphere lands in another.
const PASSES: usize = 4;

/// §4.3.1: the velocity change of a point whose velocity relative to the surface is `v_rel`
/// at outward normal `n`: the approaching normal part removed (a receding one is left alone),
/// the fraction `drag` of the tangential part removed (viscous friction).
pub fn sliding_delta(v_rel: &Vector3<f64>, n: &Vector3<f64>, drag: f64) -> Vector3<f64> {
    let vn = v_rel.dot(n);
    let tangential = v_rel - n * vn;
    let normal = if vn < 0.0 { -n * vn } else { Vector3::zeros() };
    normal - tangential * drag.clamp(0.0, 1.0)
}

/// §4.3.2: where a skeleton point at `x` inside `ball` goes: at `margin` outside the surface,
/// at its current distance from the previous point `prev` (so the spring keeps its length),
/// the nearest such place to `x`. When no place is at that distance (the previous point is
/// itself too close), straight out along the normal.
pub fn reaction_position(
    prev: &Vector3<f64>,
    x: &Vector3<f64>,
    ball: &Ball,
    margin: f64,
) -> Vector3<f64> {
    let len = (x - prev).norm();
    let rho = ball.radius + margin;
    let ac = ball.center - prev;
    let d = ac.norm();
    let out = (x - ball.center)
        .try_normalize(1e-12)
        .unwrap_or_else(|| (-ac).try_normalize(1e-12).unwrap_or(Vector3::y()));
    if d < 1e-12 || len > d + rho || len < (d - rho).abs() {
        return ball.center + out * rho;
    }
    // The circle where the sphere of radius `len` about `prev` meets the inflated ball.
    let e = ac / d;
    let h = (d * d + len * len - rho * rho) / (2.0 * d);
    let rc = (len * len - h * h).max(0.0).sqrt();
    let w = (x - prev) - e * (x - prev).dot(&e);
    let wd = w
        .try_normalize(1e-12)
        .unwrap_or_else(|| super::wisp::any_perpendicular(&e));
    prev + e * h + wd * rc
}

/// Distance along unit `dir` from `x0` (outside `ball`) to the half-line's first crossing of
/// the ball's surface, if it meets the ball.
pub fn half_line_entry(x0: &Vector3<f64>, dir: &Vector3<f64>, ball: &Ball) -> Option<f64> {
    let m = x0 - ball.center;
    let b = m.dot(dir);
    let c = m.norm_squared() - ball.radius * ball.radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let t = -b - disc.sqrt();
    (t >= 0.0).then_some(t)
}

/// Places the body spheres where `pose` puts them.
pub fn pose_balls(body: &[crate::style::Sphere], pose: &Pose, out: &mut Vec<Ball>) {
    out.clear();
    for s in body {
        let c = pose.transform_point(&Point3::from(Vector3::from(s.center)));
        out.push(Ball {
            center: c.coords,
            radius: s.radius,
        });
    }
}

/// §4.3.1 on every non-root skeleton and envelope point within `threshold` of a ball; the
/// envelope's change is projected on its half-line. Returns the points in contact.
pub fn sliding_contact(
    w: &mut Wisps,
    balls: &[Ball],
    pose: &Pose,
    threshold: f64,
    drag: f64,
) -> u32 {
    let mut contacts = 0;
    for p in 0..w.point_count() {
        if w.is_root[p] {
            continue;
        }
        // The balls near enough to any point of the section (none: the usual case).
        let near = near_balls(w, p, balls, threshold);
        if near == 0 {
            continue;
        }
        let nearby = || {
            balls
                .iter()
                .enumerate()
                .filter(move |&(i, _)| is_near(near, i))
                .map(|(_, b)| b)
        };
        for b in nearby() {
            let r = w.pos[p] - b.center;
            let dist = r.norm();
            if dist - b.radius < threshold && dist > 1e-12 {
                let n = r / dist;
                let vb = pose.velocity_at(&Point3::from(w.pos[p]));
                let dv = sliding_delta(&(w.vel[p] - vb), &n, drag);
                w.vel[p] += dv;
                contacts += 1;
            }
        }
        for j in 0..ENV {
            let x = w.env_pos(p, j);
            for b in nearby() {
                let r = x - b.center;
                let dist = r.norm();
                if dist - b.radius < threshold && dist > 1e-12 {
                    let n = r / dist;
                    let vb = pose.velocity_at(&Point3::from(x));
                    let dir = w.env_dir(p, j);
                    let dv = sliding_delta(&(w.env_vel(p, j) - vb), &n, drag);
                    w.rho_rate[p * ENV + j] += dv.dot(&dir);
                    contacts += 1;
                }
            }
        }
    }
    contacts
}

/// Bit `i` set when ball `i` may be within `threshold` of section `p`'s skeleton point or one
/// of its envelope points (a conservative test on the skeleton point alone: an envelope point
/// is no farther from it than the section's largest radius). At most 64 balls are culled;
/// beyond, every ball counts as near.
#[inline]
fn is_near(near: u64, i: usize) -> bool {
    i >= 64 || near & (1 << i) != 0
}

fn near_balls(w: &Wisps, p: usize, balls: &[Ball], threshold: f64) -> u64 {
    if balls.len() > 64 {
        return u64::MAX;
    }
    let reach = w.rho[p * ENV..p * ENV + ENV]
        .iter()
        .fold(0.0f64, |m, &r| m.max(r));
    let mut near = 0u64;
    for (i, b) in balls.iter().enumerate() {
        let lim = (b.radius + threshold.max(0.0) + reach) * (1.0 + 1e-9) + 1e-12;
        if (w.pos[p] - b.center).norm_squared() <= lim * lim {
            near |= 1 << i;
        }
    }
    near
}

/// §4.3.2, root to tip: a skeleton point inside a ball moves out (keeping its spring's length)
/// and the rest of the wisp moves with it; then its envelope points inside a ball move along
/// their half-lines to the surface and lose their approaching radial velocity. Needs frames of
/// the current positions; returns the points moved.
pub fn penetration_reaction(w: &mut Wisps, balls: &[Ball], pose: &Pose, margin: f64) -> u32 {
    reaction(w, balls, pose, margin, false)
}

/// [`penetration_reaction`] on wisps whose frames may be stale: a wisp with a section near a
/// ball gets the frames of its current positions first; the others cannot touch a ball and
/// are left as they are (their frames too).
pub fn penetration_reaction_framing(
    w: &mut Wisps,
    balls: &[Ball],
    pose: &Pose,
    margin: f64,
) -> u32 {
    reaction(w, balls, pose, margin, true)
}

fn reaction(w: &mut Wisps, balls: &[Ball], pose: &Pose, margin: f64, framing: bool) -> u32 {
    let mut moved = 0;
    for wi in 0..w.len() {
        let r = w.points(wi);
        if framing {
            if (r.start + 1..r.end).all(|p| near_balls(w, p, balls, 0.0) == 0) {
                continue;
            }
            w.compute_wisp_frames(wi, pose);
        }
        let moved_before = moved;
        for p in r.start + 1..r.end {
            let before = w.pos[p];
            let mut x = before;
            for _ in 0..PASSES {
                let mut changed = false;
                for b in balls {
                    if (x - b.center).norm_squared() < b.radius * b.radius {
                        x = reaction_position(&w.pos[p - 1], &x, b, margin);
                        changed = true;
                    }
                }
                if !changed {
                    break;
                }
            }
            if x != before {
                let delta = x - before;
                for q in p..r.end {
                    w.pos[q] += delta;
                }
                // Completely inelastic: no velocity towards the body is kept.
                for b in balls {
                    let n = (x - b.center).try_normalize(1e-12).unwrap_or(Vector3::y());
                    if (x - b.center).norm() < b.radius + 2.0 * margin.max(1e-4) {
                        let vb = pose.velocity_at(&Point3::from(x));
                        let dv = sliding_delta(&(w.vel[p] - vb), &n, 0.0);
                        w.vel[p] += dv;
                    }
                }
                moved += 1;
            }
        }
        // Envelope points after the whole skeleton, in frames of the moved skeleton.
        if moved > moved_before {
            w.compute_wisp_frames(wi, pose);
        }
        for p in r.start + 1..r.end {
            let near = near_balls(w, p, balls, 0.0);
            if near == 0 {
                continue;
            }
            for j in 0..ENV {
                let dir = w.env_dir(p, j);
                let e = p * ENV + j;
                for (_, b) in balls.iter().enumerate().filter(|&(i, _)| is_near(near, i)) {
                    let x = w.env_pos(p, j);
                    if (x - b.center).norm_squared() >= b.radius * b.radius {
                        continue;
                    }
                    if let Some(t) = half_line_entry(&w.pos[p], &dir, b) {
                        w.rho[e] = t.min(w.rho[e]);
                        let n = (w.env_pos(p, j) - b.center)
                            .try_normalize(1e-12)
                            .unwrap_or(dir);
                        let vb = pose.velocity_at(&Point3::from(w.env_pos(p, j)));
                        let dv = sliding_delta(&(w.env_vel(p, j) - vb), &n, 0.0);
                        w.rho_rate[e] += dv.dot(&dir);
                        moved += 1;
                    }
                }
            }
        }
    }
    moved
}
