//! The body's capsules (`/body/capsules`, `Capsules3D`) and meshes (`/body/mesh`, `Mesh3D`).
//! A mesh does not change shape: its triangles are logged once (static) in the rest frame, and
//! every frame only the body's pose, as the entity's transform.

use nalgebra::{UnitQuaternion, Vector3};
use rerun::{Capsules3D, Color, EntityPath, Mesh3D, RecordingStream, Transform3D};

use super::colors::BODY_COLOR;
use super::paths;
use crate::frame::BodyBuf;

/// What was logged of the body's shapes, so that the mesh goes out once.
pub(super) struct BodyShapes {
    mesh: EntityPath,
    capsules: EntityPath,
    /// The meshes last logged (their addresses): logged again only when the style changes.
    logged: Vec<usize>,
    /// Whether capsules were shown (then a frame without any clears them).
    had_capsules: bool,
}

impl BodyShapes {
    pub(super) fn new(prefix: &str) -> BodyShapes {
        BodyShapes {
            mesh: format!("{prefix}{}", paths::BODY_MESH).into(),
            capsules: format!("{prefix}{}", paths::BODY_CAPSULES).into(),
            logged: Vec::new(),
            had_capsules: false,
        }
    }

    pub(super) fn log(&mut self, rec: &RecordingStream, b: &BodyBuf) -> anyhow::Result<()> {
        if !b.capsule_radii.is_empty() || self.had_capsules {
            let z = Vector3::z();
            let mut lengths = Vec::with_capacity(b.capsule_radii.len());
            let mut at = Vec::with_capacity(b.capsule_radii.len());
            let mut rot = Vec::with_capacity(b.capsule_radii.len());
            for [p, q] in &b.capsule_ends {
                let d = Vector3::new(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
                let r = UnitQuaternion::rotation_between(&z, &d).unwrap_or_else(|| {
                    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f32::consts::PI)
                });
                lengths.push(d.norm());
                at.push(*p);
                rot.push(rerun::Quaternion::from_xyzw([r.i, r.j, r.k, r.w]));
            }
            let (r, g, bl, a) = BODY_COLOR;
            rec.log(
                self.capsules.clone(),
                &Capsules3D::from_lengths_and_radii(lengths, b.capsule_radii.iter().copied())
                    .with_translations(at)
                    .with_quaternions(rot)
                    .with_colors([Color::from_unmultiplied_rgba(r, g, bl, a)]),
            )?;
            self.had_capsules = !b.capsule_radii.is_empty();
        }
        if b.meshes.is_empty() {
            return Ok(());
        }
        let ids: Vec<usize> = b
            .meshes
            .iter()
            .map(|m| std::sync::Arc::as_ptr(m) as usize)
            .collect();
        if ids != self.logged {
            let mut pos: Vec<[f32; 3]> = Vec::new();
            let mut tri: Vec<[u32; 3]> = Vec::new();
            for m in &b.meshes {
                let base = pos.len() as u32;
                pos.extend(m.vertices.iter().map(|v| v.map(|c| c as f32)));
                tri.extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
            }
            let normals = vertex_normals(&pos, &tri);
            // The body's grey, opaque: the skin colour of the scalp is too near the hair's.
            let (r, g, bl, _) = BODY_COLOR;
            rec.log_static(
                self.mesh.clone(),
                &Mesh3D::new(pos)
                    .with_triangle_indices(tri)
                    .with_vertex_normals(normals)
                    .with_albedo_factor(rerun::datatypes::Rgba32::from_rgb(r, g, bl)),
            )?;
            self.logged = ids;
        }
        rec.log(
            self.mesh.clone(),
            &Transform3D::from_translation_rotation(
                b.pose_translation,
                rerun::Quaternion::from_xyzw(b.pose_rotation),
            ),
        )?;
        Ok(())
    }
}

/// Area-weighted vertex normals, for smooth shading in the viewer.
fn vertex_normals(pos: &[[f32; 3]], tri: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut n = vec![Vector3::<f32>::zeros(); pos.len()];
    for t in tri {
        let [a, b, c] = t.map(|i| Vector3::from(pos[i as usize]));
        let f = (b - a).cross(&(c - a));
        for &i in t {
            n[i as usize] += f;
        }
    }
    n.iter()
        .map(|v| v.try_normalize(1e-20).unwrap_or_else(Vector3::y).into())
        .collect()
}
