//! The body's capsules and meshes where the pose puts them, for all three solvers: one query
//! ("signed distance and outward normal at a world point") and one push (onto the surface along
//! the normal). The spheres keep each solver's own sphere code (AWT §4.3, Plante et al. §4.3,
//! Chang et al. §3.3), which these shapes follow with the same response: a node found inside is
//! put on the surface and takes the body's velocity there, rigid with the motion.

use nalgebra::{Point3, Vector3};

pub use crate::model::body::{Collider, Probe};
use crate::motion::Pose;

/// Signed distance and outward normal of world point `x` against `colliders` posed by `pose`:
/// the deepest (or, outside, the nearest within `reach`), if any.
#[inline]
pub fn probe(colliders: &[Collider], pose: &Pose, x: &Vector3<f64>, reach: f64) -> Option<Probe> {
    if colliders.is_empty() {
        return None;
    }
    let local = pose.iso.inverse_transform_point(&Point3::from(*x)).coords;
    let p = crate::model::body::nearest(colliders, &local, reach)?;
    Some(Probe {
        distance: p.distance,
        normal: pose.iso.rotation * p.normal,
    })
}

/// `x` moved along the normal to `margin` outside the surface if it is closer than that (or
/// inside); `None` when it is already far enough out.
#[inline]
pub fn push_out(
    colliders: &[Collider],
    pose: &Pose,
    x: &Vector3<f64>,
    margin: f64,
) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let p = probe(colliders, pose, x, margin)?;
    if p.distance >= margin {
        return None;
    }
    // A hair's width past the margin, so that the f32 tree of a mesh does not find the
    // pushed point a rounding error inside again.
    Some((x + p.normal * (margin - p.distance + 1e-7), p.normal))
}

/// Whether `x` is strictly inside a posed collider.
#[inline]
pub fn inside(colliders: &[Collider], pose: &Pose, x: &Vector3<f64>) -> bool {
    probe(colliders, pose, x, 0.0).is_some_and(|p| p.distance < 0.0)
}
