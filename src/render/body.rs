//! The head and body: the `BodyBuf` spheres and the scalp ellipsoid, ray cast per sample as
//! opaque surfaces (they hide the hair behind them and receive its shadow).

use super::camera::{add, dot, normalize, scale, sub, View, NEAR};
use crate::frame::BodyBuf;

/// One body primitive of the frame: an ellipsoid (a sphere has equal radii), in the world.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Prim {
    center: [f32; 3],
    /// Rows of the world → local rotation (the local axes in world coordinates).
    axes: [[f32; 3]; 3],
    inv_radii: [f32; 3],
    /// Screen bounds in samples: x0, y0, x1, y1.
    pub rect: [f32; 4],
}

/// `v` turned by the unit quaternion `q` (x, y, z, w).
pub(crate) fn rotate(q: [f32; 4], v: [f32; 3]) -> [f32; 3] {
    // v' = v + 2w(u × v) + 2u × (u × v), with q = (u, w).
    let u = [q[0], q[1], q[2]];
    let t = scale(super::camera::cross(u, v), 2.0);
    add(add(v, scale(t, q[3])), super::camera::cross(u, t))
}

impl Prim {
    fn new(center: [f32; 3], radii: [f32; 3], rot: [f32; 4], view: &View, w: f32, h: f32) -> Prim {
        let n = rot.iter().map(|x| x * x).sum::<f32>().sqrt();
        let q = if n > 0.0 {
            [rot[0] / n, rot[1] / n, rot[2] / n, rot[3] / n]
        } else {
            [0.0, 0.0, 0.0, 1.0]
        };
        let axes = [
            rotate(q, [1.0, 0.0, 0.0]),
            rotate(q, [0.0, 1.0, 0.0]),
            rotate(q, [0.0, 0.0, 1.0]),
        ];
        let r = radii[0].max(radii[1]).max(radii[2]);
        // The projection of the bounding cube's corners bounds the projection of the surface.
        let mut rect = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        let mut behind = false;
        for c in 0..8 {
            let s = |b: usize| if c & (1 << b) != 0 { r } else { -r };
            let p = add(center, [s(0), s(1), s(2)]);
            let q = view.project(p);
            if q[2] <= NEAR {
                behind = true;
            }
            rect = [
                rect[0].min(q[0]),
                rect[1].min(q[1]),
                rect[2].max(q[0]),
                rect[3].max(q[1]),
            ];
        }
        if behind {
            rect = [0.0, 0.0, w, h];
        }
        Prim {
            center,
            axes,
            inv_radii: radii.map(|x| 1.0 / x.max(1e-6)),
            rect,
        }
    }

    fn local(&self, v: [f32; 3]) -> [f32; 3] {
        [
            dot(self.axes[0], v) * self.inv_radii[0],
            dot(self.axes[1], v) * self.inv_radii[1],
            dot(self.axes[2], v) * self.inv_radii[2],
        ]
    }

    /// The rays of a tile, in this primitive's local frame: ray (i, j) has direction
    /// `d00 + i·dx + j·dy` from `eye`.
    pub fn rays(&self, eye: [f32; 3], d00: [f32; 3], dx: [f32; 3], dy: [f32; 3]) -> TileRays {
        let o = self.local(sub(eye, self.center));
        TileRays {
            o,
            c: dot(o, o) - 1.0,
            d00: self.local(d00),
            dx: self.local(dx),
            dy: self.local(dy),
        }
    }

    /// The unit outward normal at surface point `p`.
    pub fn normal(&self, p: [f32; 3]) -> [f32; 3] {
        let l = self.local(sub(p, self.center));
        // Gradient of |local|²: axes_i · l_i / r_i.
        let g = [
            l[0] * self.inv_radii[0],
            l[1] * self.inv_radii[1],
            l[2] * self.inv_radii[2],
        ];
        normalize(add(
            add(scale(self.axes[0], g[0]), scale(self.axes[1], g[1])),
            scale(self.axes[2], g[2]),
        ))
    }
}

/// The scalp is drawn at this fraction of its radii: roots sit on the ellipsoid and the hair
/// near them dips into it (the simulation keeps hair out of the collision spheres, not out of
/// the scalp), so a full-size scalp would hide the roots and the hair lying on the head.
pub const SCALP_DRAWN: f32 = 0.9;

/// Fills `out` with the frame's primitives: the body spheres, the capsules, then the scalp
/// ellipsoid.
pub(crate) fn prims(body: &BodyBuf, view: &View, w: f32, h: f32, out: &mut Vec<Prim>) {
    out.clear();
    let id = [0.0, 0.0, 0.0, 1.0];
    for (c, r) in body.sphere_centers.iter().zip(&body.sphere_radii) {
        if *r > 0.0 {
            out.push(Prim::new(*c, [*r; 3], id, view, w, h));
        }
    }
    // A capsule is drawn as the spheres along its axis, 0.08 radius apart: the normals at
    // the ridges between them turn by 2.3° (a quarter radius showed rings in the shading),
    // and the spheres' shading and shadows serve as they are. (Meshes are rasterised
    // instead: [`super::mesh`].)
    for ([a, b], r) in body.capsule_ends.iter().zip(&body.capsule_radii) {
        if *r <= 0.0 {
            continue;
        }
        let d = sub(*b, *a);
        let len = dot(d, d).sqrt();
        let n = ((len / (0.08 * r)).ceil() as usize).clamp(1, 256);
        for k in 0..=n {
            let c = add(*a, scale(d, k as f32 / n as f32));
            out.push(Prim::new(c, [*r; 3], id, view, w, h));
        }
    }
    if body.scalp_radii.iter().all(|r| *r > 0.0) {
        out.push(Prim::new(
            body.scalp_center,
            body.scalp_radii.map(|r| r * SCALP_DRAWN),
            body.scalp_rotation,
            view,
            w,
            h,
        ));
    }
}

/// A tile's rays against one primitive, in its local frame (where it is the unit sphere).
pub(crate) struct TileRays {
    o: [f32; 3],
    c: f32,
    d00: [f32; 3],
    dx: [f32; 3],
    dy: [f32; 3],
}

impl TileRays {
    /// Ray (i, j) against the unit sphere: a·t² + 2b·t + c = 0 with a = |d|², b = o·d, and
    /// its discriminant b² − a·c (a hit where it is ≥ 0, at t = (−b ± √disc) / a).
    #[inline(always)]
    fn quadratic(&self, i: f32, j: f32) -> (f32, f32, f32) {
        let d = [
            self.d00[0] + i * self.dx[0] + j * self.dy[0],
            self.d00[1] + i * self.dx[1] + j * self.dy[1],
            self.d00[2] + i * self.dx[2] + j * self.dy[2],
        ];
        let b = dot(self.o, d);
        let a = dot(d, d);
        (a, b, b * b - a * self.c)
    }

    /// The nearest hit as `TileRays::hit` (the textbook form, kept for the tests) gives it,
    /// or infinity for none, computed without a branch: the same operations, so the same
    /// depth where there is a hit.
    #[inline(always)]
    pub fn hit_or_infinity(&self, i: f32, j: f32) -> f32 {
        let (a, b, disc) = self.quadratic(i, j);
        // No hit where disc < 0 (or NaN): the root of 0 there is never used.
        let sq = (if disc >= 0.0 { disc } else { 0.0 }).sqrt();
        let t0 = (-b - sq) / a;
        let t1 = (-b + sq) / a;
        let t = if t1 > NEAR { t1 } else { f32::INFINITY };
        let t = if t0 > NEAR { t0 } else { t };
        if disc >= 0.0 {
            t
        } else {
            f32::INFINITY
        }
    }

    /// The view depth of the nearest hit of ray (i, j) beyond the near plane, if any (the
    /// textbook form of [`TileRays::hit_or_infinity`], which the tests check it against).
    #[cfg(test)]
    pub fn hit(&self, i: f32, j: f32) -> Option<f32> {
        let (a, b, disc) = self.quadratic(i, j);
        if disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let t0 = (-b - sq) / a;
        if t0 > NEAR {
            return Some(t0);
        }
        let t1 = (-b + sq) / a;
        (t1 > NEAR).then_some(t1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::{Camera, DEFAULT_VIEW};

    #[test]
    fn the_branch_free_hit_gives_the_textbook_hit_bit_for_bit() {
        // A scalp-like ellipsoid and a sphere seen from a camera framing them, and a camera
        // inside the sphere (every ray starts inside: the far root only).
        let (lo, hi) = ([-0.2, 1.3, -0.2], [0.2, 1.8, 0.2]);
        let outside = Camera::framing(lo, hi, DEFAULT_VIEW);
        let mut inside = outside;
        inside.eye = [0.0, 1.6, 0.0];
        let body = BodyBuf {
            sphere_centers: vec![[0.0, 1.6, 0.0]],
            sphere_radii: vec![0.1],
            scalp_center: [0.0, 1.62, 0.01],
            scalp_radii: [0.08, 0.1, 0.09],
            scalp_rotation: [0.1, 0.2, 0.0, 0.97],
            ..Default::default()
        };
        let (mut hits, mut misses) = (0, 0);
        for cam in [&outside, &inside] {
            let view = View::new(cam, 640, 480);
            let mut ps = Vec::new();
            prims(&body, &view, 640.0, 480.0, &mut ps);
            assert_eq!(ps.len(), 2);
            let d00 = view.ray(0.5, 0.5);
            let dx = sub(view.ray(1.5, 0.5), d00);
            let dy = sub(view.ray(0.5, 1.5), d00);
            for p in &ps {
                let r = p.rays(view.eye, d00, dx, dy);
                for j in (0..480).step_by(3) {
                    for i in (0..640).step_by(3) {
                        let (i, j) = (i as f32, j as f32);
                        let want = r.hit(i, j).unwrap_or(f32::INFINITY);
                        assert_eq!(r.hit_or_infinity(i, j).to_bits(), want.to_bits());
                        if want.is_finite() {
                            hits += 1;
                        } else {
                            misses += 1;
                        }
                    }
                }
            }
        }
        // Both outcomes are exercised, from outside and from inside.
        assert!(hits > 1000 && misses > 1000, "{hits} hits, {misses} misses");
    }
}
