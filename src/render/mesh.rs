//! The body's triangle meshes: posed, projected and binned into tiles once a frame, then
//! rasterised into each tile's body depth buffer beside the ray-cast spheres ([`super::body`]),
//! so that a mesh hides the hair behind it, culls it before binning, and is shaded and
//! receives the hair's shadow in the resolve exactly as a sphere does (the opacity maps of
//! Zhang and Wünsche 2007, §4, looked up at the surface point).
//!
//! The renderer does no physics: it gets the mesh in the body's rest frame and the pose of
//! the frame ([`BodyBuf`]), and only moves the vertices rigidly, as the 3D view's transform
//! does.
//!
//! A triangle covers a sample when the sample's centre is inside or on its three edges in
//! screen space. Each edge's function is computed from its two end vertices taken in index
//! order, so two triangles sharing an edge compute the same number there and no sample
//! between them is missed (a watertight rule: on the edge, both take it and the depth test
//! chooses). The view depth is interpolated as 1/z, linear on screen. Triangles with a vertex
//! at or behind the near plane are not drawn (a camera inside the body sees nothing of it).
//! Both sides are drawn and shaded (an open mesh, a head open at the neck, shows its inside).

use super::body::rotate;
use super::camera::{add, cross, dot, normalize, scale, sub, View, NEAR};
use super::num::{ceil_pos, floor_pos};
use super::raster::{Grid, TILE};
use crate::frame::BodyBuf;

/// The frame's meshes, ready for the tiles and the resolve. Every buffer is reused.
#[derive(Debug, Default)]
pub(crate) struct Meshes {
    /// Posed vertices of all meshes, world, m.
    verts: Vec<[f32; 3]>,
    /// Per vertex, the unit normal (the area-weighted mean of its triangles' normals), world.
    normals: Vec<[f32; 3]>,
    /// Per vertex, sample coordinates and view depth ([`View::project`]).
    screen: Vec<[f32; 3]>,
    /// Triangles, indices into `verts`, all meshes in order.
    tris: Vec<[u32; 3]>,
    /// Per triangle, the view depth added to it in the depth buffer ([`SLACK`]).
    slack: Vec<f32>,
    /// The primitive number of triangle 0: triangle `i` is primitive `base + i` in a tile's
    /// `prim` buffer (the spheres and the scalp come first).
    pub base: u32,
    /// Per tile, `start[t]..start[t + 1]` in `items`: the triangles whose screen box reaches
    /// the tile, in order.
    start: Vec<u32>,
    items: Vec<u32>,
    cursor: Vec<u32>,
}

/// How far under a mesh's surface, along its normal, hair still shows, m. The AWT keeps the
/// nodes' centres out of the body (Bertails et al. 2003, §4.3), not the strands around them,
/// and a strand drawn between nodes lying on the skin is a chord of a curved surface: hair lying
/// on a real head runs up to a few millimetres under it, and drawn as it is, a head looked bald
/// with stubble where the hair lay. (The scalp ellipsoid is drawn smaller for the same reason,
/// [`super::body::SCALP_DRAWN`].) Only the depth test against the hair takes this slack: the
/// mesh is drawn and shaded where it is, and its parts hide each other as they are (an inset
/// of the vertices instead turned the eyelids of the real head inside out).
pub(crate) const SLACK: f32 = 0.002;

/// The slack as view depth is SLACK / |cos| of the angle between the normal and the view ray,
/// with the cosine at least this (at most 4 × SLACK, on the silhouette).
const MIN_COS: f32 = 0.25;

/// A triangle's tiles: its screen box in tile units, clipped to the grid; `None` if it is not
/// drawn (a vertex at or behind the near plane, or the box off the image).
fn tile_box(s: [[f32; 3]; 3], grid: &Grid) -> Option<[usize; 4]> {
    if !s.iter().all(|v| v[2] > NEAR) {
        return None;
    }
    let span = (TILE * grid.ss) as f32;
    let (mut x0, mut y0, mut x1, mut y1) = (s[0][0], s[0][1], s[0][0], s[0][1]);
    for v in &s[1..] {
        x0 = x0.min(v[0]);
        y0 = y0.min(v[1]);
        x1 = x1.max(v[0]);
        y1 = y1.max(v[1]);
    }
    let (w, h) = (grid.tiles_x as f32 * span, grid.tiles_y as f32 * span);
    if !(x1 >= 0.0 && y1 >= 0.0 && x0 < w && y0 < h) {
        return None;
    }
    Some([
        floor_pos(x0 / span).min(grid.tiles_x - 1),
        floor_pos(y0 / span).min(grid.tiles_y - 1),
        floor_pos(x1 / span).min(grid.tiles_x - 1),
        floor_pos(y1 / span).min(grid.tiles_y - 1),
    ])
}

impl Meshes {
    /// Poses `body`'s meshes, projects them with `view` and bins their triangles into the
    /// tiles of `grid`; triangle numbers start at primitive `base`.
    pub fn prepare(&mut self, body: &BodyBuf, view: &View, grid: &Grid, base: u32) {
        self.base = base;
        self.verts.clear();
        self.tris.clear();
        let (q, t) = (body.pose_rotation, body.pose_translation);
        for m in &body.meshes {
            let first = self.verts.len() as u32;
            self.verts.extend(
                m.vertices
                    .iter()
                    .map(|v| add(rotate(q, [v[0] as f32, v[1] as f32, v[2] as f32]), t)),
            );
            self.tris
                .extend(m.triangles.iter().map(|tri| tri.map(|i| i + first)));
        }
        // Vertex normals: the sum of the triangles' cross products weighs each by its area.
        self.normals.clear();
        self.normals.resize(self.verts.len(), [0.0; 3]);
        for tri in &self.tris {
            let [a, b, c] = tri.map(|i| self.verts[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            for &i in tri {
                self.normals[i as usize] = add(self.normals[i as usize], n);
            }
        }
        for n in &mut self.normals {
            *n = normalize(*n);
        }
        // Each triangle's depth slack: SLACK along its normal, as view depth.
        self.slack.clear();
        self.slack.extend(self.tris.iter().map(|tri| {
            let [a, b, c] = tri.map(|i| self.verts[i as usize]);
            let face = normalize(cross(sub(b, a), sub(c, a)));
            let to = normalize(sub(scale(add(add(a, b), c), 1.0 / 3.0), view.eye));
            SLACK / dot(face, to).abs().max(MIN_COS)
        }));
        self.screen.clear();
        self.screen
            .extend(self.verts.iter().map(|&v| view.project(v)));

        // Counting sort of (triangle, tile) pairs by tile: each tile's triangles in order.
        let nt = grid.tiles();
        self.start.clear();
        self.start.resize(nt + 1, 0);
        for tri in &self.tris {
            if let Some([tx0, ty0, tx1, ty1]) = tile_box(tri.map(|i| self.screen[i as usize]), grid)
            {
                for ty in ty0..=ty1 {
                    for tx in tx0..=tx1 {
                        self.start[ty * grid.tiles_x + tx + 1] += 1;
                    }
                }
            }
        }
        for t in 0..nt {
            self.start[t + 1] += self.start[t];
        }
        self.items.clear();
        self.items.resize(self.start[nt] as usize, 0);
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.start[..nt]);
        for (k, tri) in self.tris.iter().enumerate() {
            if let Some([tx0, ty0, tx1, ty1]) = tile_box(tri.map(|i| self.screen[i as usize]), grid)
            {
                for ty in ty0..=ty1 {
                    for tx in tx0..=tx1 {
                        let c = &mut self.cursor[ty * grid.tiles_x + tx];
                        self.items[*c as usize] = k as u32;
                        *c += 1;
                    }
                }
            }
        }
    }

    /// The triangles that reach tile `t`.
    pub fn tile(&self, t: usize) -> &[u32] {
        if t + 1 >= self.start.len() {
            return &[];
        }
        &self.items[self.start[t] as usize..self.start[t + 1] as usize]
    }

    /// Triangle `k`'s vertex indices and screen vertices.
    #[inline]
    pub fn screen_tri(&self, k: u32) -> ([u32; 3], [[f32; 3]; 3]) {
        let tri = self.tris[k as usize];
        (tri, tri.map(|i| self.screen[i as usize]))
    }

    /// Where the ray `eye + t·d` meets triangle `k` (whose depth buffer entry, with its
    /// slack, is `t_buf`), and the shading normal there, facing the viewer (both sides are
    /// drawn): the vertex normals interpolated with the point's barycentric coordinates
    /// (Phong's smooth shading, so the facets of a coarse mesh do not show).
    pub fn surface(&self, k: u32, eye: [f32; 3], d: [f32; 3], t_buf: f32) -> ([f32; 3], [f32; 3]) {
        let tri = self.tris[k as usize];
        let [a, b, c] = tri.map(|i| self.verts[i as usize]);
        let plane = cross(sub(b, a), sub(c, a));
        let den = dot(plane, d);
        let t = if den != 0.0 {
            dot(plane, sub(a, eye)) / den
        } else {
            t_buf - self.slack[k as usize]
        };
        let p = add(eye, scale(d, t));
        let (e1, e2, ep) = (sub(b, a), sub(c, a), sub(p, a));
        let (d11, d12, d22) = (dot(e1, e1), dot(e1, e2), dot(e2, e2));
        let (dp1, dp2) = (dot(ep, e1), dot(ep, e2));
        let den = d11 * d22 - d12 * d12;
        let face = normalize(cross(e1, e2));
        let n = if den > 0.0 {
            let v = ((d22 * dp1 - d12 * dp2) / den).clamp(0.0, 1.0);
            let w = ((d11 * dp2 - d12 * dp1) / den).clamp(0.0, 1.0 - v);
            let u = 1.0 - v - w;
            let [na, nb, nc] = tri.map(|i| self.normals[i as usize]);
            let s = add(add(scale(na, u), scale(nb, v)), scale(nc, w));
            if dot(s, s) > 1e-12 {
                normalize(s)
            } else {
                face
            }
        } else {
            face
        };
        // Seen from behind (the inside of an open mesh): its other side.
        let n = if dot(face, d) > 0.0 {
            scale(n, -1.0)
        } else {
            n
        };
        (p, n)
    }
}

/// Rasterises triangles `list` of `mesh` into the body depth buffer `zb` (and primitive
/// numbers `prim`) of the `n`² samples at global sample `(ox, oy)`; returns whether any sample
/// took a triangle.
pub(crate) fn cast(
    mesh: &Meshes,
    list: &[u32],
    (n, ox, oy): (usize, i32, i32),
    zb: &mut [f32],
    prim: &mut [u32],
) -> bool {
    let (fx0, fy0) = (ox as f32, oy as f32);
    let mut seen = false;
    for &k in list {
        let (idx, s) = mesh.screen_tri(k);
        // Each edge (opposite vertex e) from its lower-index end, and the sign that makes it
        // the edge as the triangle runs (i → j).
        let edge = |e: usize| {
            let (i, j) = ((e + 1) % 3, (e + 2) % 3);
            if idx[i] <= idx[j] {
                (s[i], s[j], 1.0f32)
            } else {
                (s[j], s[i], -1.0f32)
            }
        };
        let edges = [edge(0), edge(1), edge(2)];
        // Twice the signed area; its sign is the triangle's orientation on screen.
        let area =
            (s[1][0] - s[0][0]) * (s[2][1] - s[0][1]) - (s[1][1] - s[0][1]) * (s[2][0] - s[0][0]);
        if area.is_nan() || area.abs() <= 1e-12 {
            continue;
        }
        let orient = if area > 0.0 { 1.0f32 } else { -1.0 };
        let inv_z = s.map(|v| 1.0 / v[2]);
        // Sample i's centre is at fx0 + i + 0.5: the box's samples, clipped to the tile.
        let lo_x = s[0][0].min(s[1][0]).min(s[2][0]) - fx0 - 0.5;
        let hi_x = s[0][0].max(s[1][0]).max(s[2][0]) - fx0 - 0.5;
        let lo_y = s[0][1].min(s[1][1]).min(s[2][1]) - fy0 - 0.5;
        let hi_y = s[0][1].max(s[1][1]).max(s[2][1]) - fy0 - 0.5;
        if hi_x < 0.0 || hi_y < 0.0 {
            continue;
        }
        let (i0, i1) = (ceil_pos(lo_x).min(n), (floor_pos(hi_x) + 1).min(n));
        let (j0, j1) = (ceil_pos(lo_y).min(n), (floor_pos(hi_y) + 1).min(n));
        let id = mesh.base + k;
        let slack = mesh.slack[k as usize];
        for j in j0..j1 {
            let py = fy0 + j as f32 + 0.5;
            for i in i0..i1 {
                let px = fx0 + i as f32 + 0.5;
                let mut w = [0.0f32; 3];
                for (e, &(a, b, sign)) in edges.iter().enumerate() {
                    let f = (b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0]);
                    w[e] = f * sign * orient;
                }
                if !(w[0] >= 0.0 && w[1] >= 0.0 && w[2] >= 0.0) {
                    continue;
                }
                let sum = w[0] + w[1] + w[2];
                let iz = w[0] * inv_z[0] + w[1] * inv_z[1] + w[2] * inv_z[2];
                if iz.is_nan() || iz <= 0.0 {
                    continue;
                }
                let t = sum / iz + slack;
                let at = j * n + i;
                if t > NEAR && t < zb[at] {
                    zb[at] = t;
                    prim[at] = id;
                    seen = true;
                }
            }
        }
    }
    seen
}
