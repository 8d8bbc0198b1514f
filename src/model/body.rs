//! Capsule and mesh bodies in the rest frame, ready for collision queries: for a point, the
//! signed distance to the surface (negative inside) and the outward normal.
//!
//! A mesh is queried with parry3d's `TriMesh` (a bounding-volume tree of the triangles), with
//! the angle-weighted pseudo-normals of Bærentzen & Aanæs, *Signed distance computation using
//! the angle weighted pseudonormal* (2005), deciding inside from outside: this needs no closed
//! surface, so a head open at the neck works (near the opening the sign follows the nearest
//! triangle's side, which is what a hair node there needs). parry is f32: the vertices are kept
//! relative to the mesh's centre so that rounding stays below a micrometre.

use std::sync::Arc;

use nalgebra::{Point3, Vector3};
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::{TriMesh, TriMeshFlags};

use crate::style::body::Shape;
use crate::style::obj::TriangleMesh;

/// A non-sphere body, in the rest frame.
#[derive(Debug, Clone)]
pub enum Collider {
    /// The points within `radius` of the segment `a`–`b`.
    Capsule {
        /// One end of the axis, m.
        a: Vector3<f64>,
        /// The other end, m.
        b: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// A triangle mesh.
    Mesh(Arc<MeshCollider>),
}

/// A triangle mesh with its search tree.
#[derive(Debug)]
pub struct MeshCollider {
    /// The mesh as loaded (for display and reports).
    pub mesh: Arc<TriangleMesh>,
    /// Where it came from.
    pub path: std::path::PathBuf,
    /// The point the tree's coordinates are relative to, m.
    origin: Vector3<f64>,
    tree: TriMesh,
    /// A coarse grid over the mesh's box: per cell, a distance below which no point of the
    /// cell outside the mesh comes to the surface (`-1`: inside, unknown or near). Most hair
    /// nodes a centimetre or more off the skin skip the tree search with it.
    grid: Grid,
    /// The signed distance field, with [`MeshQuery::Sdf`].
    sdf: Option<super::body_sdf::Sdf>,
}

/// How a mesh body answers "how far is this point, and which way is out".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshQuery {
    /// parry3d's `TriMesh` search at every query (behind the clearance grid).
    Tree,
    /// A signed distance field sampled once at load ([`super::body_sdf`]); the tree answers
    /// where the field does not reach.
    Sdf,
}

/// The query mesh bodies use: the field. On the real head under `long` (2026-12-03,
/// `examples/body_probe`), a query at the same node positions took about 25 ns against 190 ns
/// with the tree, the obstacles stage 0.2 ms against 1.2 ms, and the two agreed within 0.09 mm
/// away from the mesh's open bottom; the field costs about 1.3 s and 13 MB at load.
pub const MESH_QUERY: MeshQuery = MeshQuery::Sdf;

/// See [`MeshCollider::grid`].
#[derive(Debug)]
struct Grid {
    lo: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    clear: Vec<f32>,
}

impl Grid {
    /// The clearance of the cell holding `x` (`None` outside the grid: there the tree decides).
    fn clearance(&self, x: &Vector3<f64>) -> Option<f64> {
        let mut idx = 0;
        for a in (0..3).rev() {
            let f = ((x[a] - self.lo[a]) / self.cell).floor();
            if !(f >= 0.0 && (f as usize) < self.dims[a]) {
                return None;
            }
            idx = idx * self.dims[a] + f as usize;
        }
        Some(self.clear[idx] as f64)
    }
}

/// The answer to "where is `x` relative to this surface".
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Probe {
    /// Signed distance to the surface, m: negative inside.
    pub distance: f64,
    /// Outward unit normal at the nearest surface point.
    pub normal: Vector3<f64>,
}

impl Collider {
    /// The collider of a loaded body shape.
    pub fn new(shape: &Shape) -> Collider {
        match shape {
            Shape::Capsule(c) => Collider::Capsule {
                a: Vector3::from(c.a),
                b: Vector3::from(c.b),
                radius: c.radius,
            },
            Shape::Mesh(m, path) => Collider::Mesh(Arc::new(MeshCollider::new(m, path))),
        }
    }

    /// This collider, a mesh rebuilt to answer with `query` (for comparing the two).
    pub fn with_mesh_query(&self, query: MeshQuery) -> Collider {
        match self {
            Collider::Mesh(m) => {
                Collider::Mesh(Arc::new(MeshCollider::with_query(&m.mesh, &m.path, query)))
            }
            other => other.clone(),
        }
    }

    /// Signed distance and outward normal at rest-frame point `x`, if `x` is within `reach`
    /// outside the surface or inside it (anywhere inside a capsule; up to [`MESH_DEPTH`] deep
    /// in a mesh, whose tree is searched no farther).
    pub fn probe(&self, x: &Vector3<f64>, reach: f64) -> Option<Probe> {
        match self {
            Collider::Capsule { a, b, radius } => {
                let ab = b - a;
                let l2 = ab.norm_squared();
                let t = if l2 > 0.0 {
                    ((x - a).dot(&ab) / l2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let d = x - (a + ab * t);
                let n = d.norm();
                let distance = n - radius;
                if distance > reach {
                    return None;
                }
                let normal = if n > 1e-12 {
                    d / n
                } else {
                    any_perpendicular(&ab)
                };
                Some(Probe { distance, normal })
            }
            Collider::Mesh(m) => m.probe(x, reach),
        }
    }
}

fn any_perpendicular(v: &Vector3<f64>) -> Vector3<f64> {
    let t = if v.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    v.cross(&t).try_normalize(1e-300).unwrap_or_else(Vector3::y)
}

impl MeshCollider {
    /// Builds the search tree of `mesh` (and what [`MESH_QUERY`] needs).
    pub fn new(mesh: &Arc<TriangleMesh>, path: &std::path::Path) -> MeshCollider {
        MeshCollider::with_query(mesh, path, MESH_QUERY)
    }

    /// Builds the search tree of `mesh`, and its distance field if `query` asks for it.
    pub fn with_query(
        mesh: &Arc<TriangleMesh>,
        path: &std::path::Path,
        query: MeshQuery,
    ) -> MeshCollider {
        let n = mesh.vertices.len().max(1) as f64;
        let origin = mesh
            .vertices
            .iter()
            .fold(Vector3::zeros(), |s, v| s + Vector3::from(*v))
            / n;
        let pts: Vec<Point3<f32>> = mesh
            .vertices
            .iter()
            .map(|v| Point3::from((Vector3::from(*v) - origin).map(|c| c as f32)))
            .collect();
        // ORIENTED: the pseudo-normals that give `is_inside`. Degenerate triangles (zero area)
        // are dropped, as they have no side.
        let flags = TriMeshFlags::ORIENTED | TriMeshFlags::DELETE_DEGENERATE_TRIANGLES;
        let tree = TriMesh::with_flags(pts, mesh.triangles.clone(), flags)
            .expect("a loaded mesh has at least one triangle");
        let grid = build_grid(&tree, &origin);
        let sdf = (query == MeshQuery::Sdf)
            .then(|| super::body_sdf::Sdf::build(&tree, &origin, &|x| grid.clearance(x)));
        MeshCollider {
            mesh: mesh.clone(),
            path: path.to_path_buf(),
            origin,
            tree,
            grid,
            sdf,
        }
    }

    /// The distance field's samples and those in its band, if it has one.
    pub fn sdf_counts(&self) -> Option<(usize, usize)> {
        self.sdf.as_ref().map(|s| s.counts())
    }

    /// See [`Collider::probe`].
    pub fn probe(&self, x: &Vector3<f64>, reach: f64) -> Option<Probe> {
        if let Some(sdf) = &self.sdf {
            use super::body_sdf::{Lookup, BAND, CELL};
            match sdf.lookup(x) {
                Lookup::Value(d, g) => {
                    if d > reach {
                        return None;
                    }
                    if let Some(normal) = g.try_normalize(1e-9) {
                        return Some(Probe {
                            distance: d,
                            normal,
                        });
                    }
                }
                Lookup::Far if reach < BAND - CELL * 3f64.sqrt() => return None,
                _ => {}
            }
        }
        // Farther out than `reach`: no answer is wanted, and the grid tells most such points
        // without the tree. (It compared with the tree's search distance, `MESH_DEPTH`, until
        // 2026-12-03, and so never skipped a point.)
        if self.grid.clearance(x).is_some_and(|c| c > reach) {
            return None;
        }
        let local = (x - self.origin).map(|c| c as f32);
        let (proj, (tri, _)) = self
            .tree
            .project_local_point_and_get_location_with_max_dist(
                &Point3::from(local),
                false,
                reach.max(MESH_DEPTH) as f32,
            )?;
        let d = local - proj.point.coords;
        let len = d.norm();
        let sign = if proj.is_inside { -1.0 } else { 1.0 };
        let normal = if len > 1e-7 {
            (d / len).map(|c| c as f64) * sign
        } else {
            self.tree
                .triangle(tri)
                .normal()
                .map(|n| n.into_inner().map(|c| c as f64))
                .unwrap_or_else(Vector3::y)
        };
        Some(Probe {
            distance: sign * len as f64,
            normal,
        })
    }
}

/// Grid cell edge, m.
const GRID_CELL: f64 = 0.01;

fn build_grid(tree: &TriMesh, origin: &Vector3<f64>) -> Grid {
    let aabb = tree.local_aabb();
    let pad = MESH_DEPTH;
    let lo = aabb.mins.coords.map(|c| c as f64) + origin - Vector3::repeat(pad);
    let hi = aabb.maxs.coords.map(|c| c as f64) + origin + Vector3::repeat(pad);
    let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / GRID_CELL).ceil().max(1.0) as usize);
    let half_diag = GRID_CELL * 3f64.sqrt() / 2.0;
    let search = (MESH_DEPTH + half_diag) as f32;
    let mut clear = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let c =
                    lo + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * GRID_CELL;
                let local = Point3::from((c - origin).map(|v| v as f32));
                // Every point of the cell is within `half_diag` of its centre: an outside
                // centre at distance d leaves the cell's points at least d − half_diag away,
                // and on the outside side as long as that is positive.
                let v = match tree
                    .project_local_point_and_get_location_with_max_dist(&local, false, search)
                {
                    Some((p, _)) if !p.is_inside => (p.point - local).norm() as f64 - half_diag,
                    Some(_) => -1.0,
                    // Farther than the search: outside or deep inside, not known cheaply.
                    None => -1.0,
                };
                clear.push(v as f32);
            }
        }
    }
    Grid {
        lo,
        cell: GRID_CELL,
        dims,
        clear,
    }
}

/// How deep a point may be inside a mesh and still be found (the tree is searched no farther
/// from the surface): hair nodes move millimetres per step, so a few centimetres is ample.
pub const MESH_DEPTH: f64 = 0.05;

/// The deepest penetration of `x` among `colliders` (or the nearest within `reach` outside).
pub fn nearest(colliders: &[Collider], x: &Vector3<f64>, reach: f64) -> Option<Probe> {
    let mut best: Option<Probe> = None;
    for c in colliders {
        if let Some(p) = c.probe(x, reach) {
            if p.distance <= reach && best.is_none_or(|b| p.distance < b.distance) {
                best = Some(p);
            }
        }
    }
    best
}

/// `head.push_roots_out`: every strand whose root lies inside a mesh is moved rigidly, along
/// the mesh's normal at the nearest surface point, until its root is on the surface (a hair
/// grows from the skin; moving the whole strand keeps its styled shape). Says how many in the
/// notes.
pub fn push_roots_out(
    hair: &crate::style::RawHair,
    colliders: &[Collider],
) -> crate::style::RawHair {
    let mut out = hair.clone();
    let meshes: Vec<Collider> = colliders
        .iter()
        .filter(|c| matches!(c, Collider::Mesh(_)))
        .cloned()
        .collect();
    let (mut moved, mut deepest) = (0usize, 0.0f64);
    for st in &mut out.strands {
        let Some(root) = st.points.first() else {
            continue;
        };
        let mut x = Vector3::from(*root);
        let mut shift = Vector3::zeros();
        // 10 µm past the surface: on it, without the f32 tree finding the root inside again. A
        // second look, as the distance field's normal is its interpolant's, not the exact
        // one: what one push leaves under the skin (micrometres), the next takes out.
        for _ in 0..4 {
            let Some(p) = nearest(&meshes, &x, 0.0).filter(|p| p.distance < 0.0) else {
                break;
            };
            if shift == Vector3::zeros() {
                deepest = deepest.max(-p.distance);
                moved += 1;
            }
            let step = p.normal * (1e-5 - p.distance);
            shift += step;
            x += step;
        }
        if shift != Vector3::zeros() {
            for q in &mut st.points {
                *q = (Vector3::from(*q) + shift).into();
            }
        }
    }
    let what = if moved == 0 {
        "push_roots_out: no strand root was inside a mesh body".to_string()
    } else {
        format!(
            "push_roots_out: moved {moved} of {} strand roots from inside a mesh body onto its \
             surface (by up to {:.1} mm)",
            out.strands.len(),
            deepest * 1e3
        )
    };
    out.notes.push(what);
    out
}

/// What the user should know about the capsules and meshes before a run: an open mesh (one
/// line), and strand roots and rest nodes inside a capsule or mesh, as for the spheres.
pub fn warnings(model: &crate::model::HairModel) -> Vec<String> {
    let mut out = Vec::new();
    for c in &model.colliders {
        let Collider::Mesh(m) = c else { continue };
        if m.mesh.boundary_edges > 0 {
            out.push(format!(
                "{}: the mesh is open ({} boundary edges); inside and outside are told by its \
                 normals (fine for a head open at the neck)",
                m.path.display(),
                m.mesh.boundary_edges
            ));
        }
    }
    if model.colliders.is_empty() {
        return out;
    }
    let k = model.k;
    let depth = |p: &Vector3<f64>| {
        nearest(&model.colliders, p, 0.0)
            .map(|q| -q.distance)
            // Below a micrometre is the f32 tree's rounding, not a node inside.
            .filter(|&d| d > 1e-6)
    };
    let (mut roots, mut root_depth) = (0usize, 0.0f64);
    for s in 0..model.strands.len() {
        if let Some(d) = depth(&model.strands.rest[s * k]) {
            roots += 1;
            root_depth = root_depth.max(d);
        }
    }
    let (mut nodes, mut node_depth) = (0usize, 0.0f64);
    for lv in &model.levels {
        for p in &lv.rest_pos {
            if let Some(d) = depth(p) {
                nodes += 1;
                node_depth = node_depth.max(d);
            }
        }
    }
    if roots > 0 {
        out.push(format!(
            "{roots} of {} strand roots are inside a capsule or mesh body, by up to {:.1} mm \
             (head: (push_roots_out: true) moves them onto a mesh's surface)",
            model.strands.len(),
            root_depth * 1e3
        ));
    }
    if nodes > 0 {
        out.push(format!(
            "{nodes} rest nodes (all levels) are inside a capsule or mesh body, by up to {:.1} mm",
            node_depth * 1e3
        ));
    }
    out
}
