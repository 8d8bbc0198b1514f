//! Strand–body collision (Chang, Jin, Yu 2002, §3.3).
//!
//! After a sub-step, a guide whose vertices came within the body (spheres, plus a margin) is
//! corrected by iterative local displacements: starting from the first penetrating vertex,
//! each vertex is moved by its predecessor's displacement, put back at its segment length from
//! it, and pushed out to the surface if it is still inside, so the tip outside is disturbed as
//! little as possible. A vertex pushed out takes the body's normal velocity if it was moving
//! into it (it cannot accelerate into the body), keeps an outward one (it may leave), and loses
//! part of its tangential velocity relative to the body (friction). The corrected positions
//! become joint angles again by the chain's inverse kinematics, and the corrected velocities
//! become joint rates through the same map (the angles of the positions advanced by a tiny
//! time, differenced).

use nalgebra::Vector3;

/// A sphere of the body or an obstacle, posed: centre, radius, and the velocity of its
/// material (`v + ω × (x − c)` is approximated by its centre's velocity plus the head's spin).
#[derive(Debug, Clone, Copy)]
pub struct PosedSphere {
    /// Centre, m.
    pub center: Vector3<f64>,
    /// Radius, m.
    pub radius: f64,
    /// Velocity of the centre, m/s.
    pub velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub spin: Vector3<f64>,
}

impl PosedSphere {
    /// Velocity of the sphere's material at `x`.
    pub fn velocity_at(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.velocity + self.spin.cross(&(x - self.center))
    }
}

/// The body's capsules and meshes and the pose that places them (see
/// [`crate::solver::body`]): corrected against after the spheres, with the same response.
#[derive(Clone, Copy)]
pub struct Shapes<'a> {
    /// The shapes, in the rest frame.
    pub colliders: &'a [crate::solver::body::Collider],
    /// Where they are.
    pub pose: crate::motion::Pose,
}

impl Shapes<'_> {
    fn within(&self, x: &Vector3<f64>, margin: f64) -> bool {
        crate::solver::body::probe(self.colliders, &self.pose, x, margin)
            .is_some_and(|p| p.distance < margin)
    }
}

/// Most rounds of pushing a vertex out of the body's spheres, one sphere per round.
const SPHERE_ROUNDS: usize = 6;

/// Whether `x` is within `margin` of a sphere: the index of the deepest one.
pub fn inside(spheres: &[PosedSphere], x: &Vector3<f64>, margin: f64) -> Option<usize> {
    let mut best: Option<(f64, usize)> = None;
    for (k, s) in spheres.iter().enumerate() {
        let depth = s.radius + margin - (x - s.center).norm();
        if depth > 0.0 && best.is_none_or(|(d, _)| depth > d) {
            best = Some((depth, k));
        }
    }
    best.map(|(_, k)| k)
}

/// Whether a vertex of `x` after the root lies deeper than `depth` within the body's `margin`
/// (`depth` ≤ `margin`): whether another pass of [`correct`] is worth its cost.
pub fn any_deeper(
    x: &[Vector3<f64>],
    spheres: &[PosedSphere],
    shapes: &Shapes,
    margin: f64,
    depth: f64,
) -> bool {
    let m = margin - depth;
    x.iter()
        .skip(1)
        .any(|p| inside(spheres, p, m).is_some() || shapes.within(p, m))
}

/// Corrects one guide's vertices `x` (root first, `lens[i]` the length of segment `i`) and
/// their velocities `v` in place. A pushed-out vertex keeps its velocity relative to the body only where it
/// leaves the body (the normal part, if outwards) and loses the fraction `friction` of its
/// tangential part; the push itself is not turned into velocity (a vertex resting inside the
/// margin would otherwise be shot out). Returns the number of vertices pushed out.
pub fn correct(
    x: &mut [Vector3<f64>],
    v: &mut [Vector3<f64>],
    lens: &[f64],
    spheres: &[PosedSphere],
    shapes: &Shapes,
    margin: f64,
    friction: f64,
) -> usize {
    let hit = |p: &Vector3<f64>| inside(spheres, p, margin).is_some() || shapes.within(p, margin);
    let Some(first) = (1..x.len()).find(|&i| hit(&x[i])) else {
        return 0;
    };
    let mut pushed = 0;
    let mut shift = Vector3::zeros();
    for i in first..x.len() {
        let moved = x[i] + shift;
        let dir = (moved - x[i - 1])
            .try_normalize(1e-12)
            .unwrap_or_else(|| (x[i] - x[i - 1]).normalize());
        let mut p = x[i - 1] + dir * lens[i - 1];
        // Out of the deepest sphere, then out of any other it was pushed into: the body's
        // spheres overlap (neck, shoulders, torso), and a vertex pushed out of one along its
        // normal can land inside its neighbour. Pushing out of each in turn ends outside all of
        // them within a few rounds, in the crease between them.
        let mut touched = false;
        for _ in 0..SPHERE_ROUNDS {
            let Some(k) = inside(spheres, &p, margin) else {
                break;
            };
            let s = &spheres[k];
            let nrm = (p - s.center)
                .try_normalize(1e-12)
                .unwrap_or_else(Vector3::y);
            p = s.center + nrm * (s.radius + margin);
            let vb = s.velocity_at(&p);
            let rel = v[i] - vb;
            let vn = rel.dot(&nrm);
            let vt = rel - nrm * vn;
            // Friction once per vertex and sub-step, whatever the number of rounds.
            let keep = if touched { 1.0 } else { 1.0 - friction };
            v[i] = vb + nrm * vn.max(0.0) + vt * keep;
            touched = true;
        }
        pushed += touched as usize;
        if let Some((q, nrm)) =
            crate::solver::body::push_out(shapes.colliders, &shapes.pose, &p, margin)
        {
            p = q;
            let vb = shapes.pose.velocity_at(&nalgebra::Point3::from(p));
            let rel = v[i] - vb;
            let vn = rel.dot(&nrm);
            let vt = rel - nrm * vn;
            v[i] = vb + nrm * vn.max(0.0) + vt * (1.0 - friction);
            pushed += 1;
        }
        shift = p - x[i];
        x[i] = p;
    }
    pushed
}
