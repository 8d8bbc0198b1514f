//! A mesh body's signed distance field, sampled once at load on a regular grid in a narrow band
//! around the surface and looked up by trilinear interpolation (the TressFX way of colliding hair
//! with a mesh), as the alternative to searching the triangle tree at every query.
//!
//! Each sample is the tree's signed distance at the grid point (the sign from the angle-weighted
//! pseudo-normals, as for the tree's own queries). Samples farther than [`BAND`] from the
//! surface are not stored: outside they are marked far (`+∞`), and a query near them is
//! answered "beyond reach" when its reach allows, else by the tree; inside (deeper than the
//! band) they are unknown (`NaN`) and the tree answers. The normal is the gradient of the
//! interpolant.

use nalgebra::{Point3, Vector3};
use parry3d::query::PointQueryWithLocation;
use parry3d::shape::TriMesh;

/// Grid spacing, m: the interpolant follows a surface of curvature radius R to within about
/// h²/(8R), 0.05 mm where R is 1 cm.
pub const CELL: f64 = 0.002;

/// Half-width of the band of stored samples, m.
pub const BAND: f64 = 0.01;

/// The sampled field.
#[derive(Debug)]
pub struct Sdf {
    /// The first sample's point, rest frame, m.
    lo: Vector3<f64>,
    dims: [usize; 3],
    /// Signed distances, m (x fastest): `+∞` far outside, `NaN` deep inside or unknown.
    d: Vec<f32>,
}

/// What a lookup found.
pub enum Lookup {
    /// Signed distance and the (unnormalised) gradient of the interpolant.
    Value(f64, Vector3<f64>),
    /// At least `BAND − CELL·√3` outside the surface.
    Far,
    /// Not known here: ask the tree.
    Unknown,
}

impl Sdf {
    /// Samples `tree` (whose coordinates are relative to `origin`) over its box grown by the
    /// band. `clear(x)` is a cheap lower bound on the outside distance of `x` (the clearance
    /// grid), used to skip the tree where a sample is surely far out.
    pub fn build(
        tree: &TriMesh,
        origin: &Vector3<f64>,
        clear: &(dyn Fn(&Vector3<f64>) -> Option<f64> + Sync),
    ) -> Sdf {
        let aabb = tree.local_aabb();
        let pad = BAND + 2.0 * CELL;
        let lo = aabb.mins.coords.map(|c| c as f64) + origin - Vector3::repeat(pad);
        let hi = aabb.maxs.coords.map(|c| c as f64) + origin + Vector3::repeat(pad);
        let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / CELL).ceil() as usize + 1);
        let slab = dims[0] * dims[1];
        let mut d = vec![0.0f32; slab * dims[2]];
        let search = (BAND + CELL) as f32;
        // Each z slice is independent: the slices are shared out among the cores (the field is
        // the same whatever the number of threads).
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(8));
        let per = dims[2].div_ceil(threads);
        std::thread::scope(|s| {
            for (c, chunk) in d.chunks_mut(slab * per).enumerate() {
                s.spawn(move || {
                    for (m, v) in chunk.iter_mut().enumerate() {
                        let k = c * per + m / slab;
                        let (j, i) = ((m % slab) / dims[0], m % dims[0]);
                        let x = lo + Vector3::new(i as f64, j as f64, k as f64) * CELL;
                        if clear(&x).is_some_and(|c| c > BAND) {
                            *v = f32::INFINITY;
                            continue;
                        }
                        let local = Point3::from((x - origin).map(|c| c as f32));
                        *v = match tree.project_local_point_and_get_location_with_max_dist(
                            &local, false, search,
                        ) {
                            Some((p, _)) => {
                                let len = (p.point - local).norm();
                                if p.is_inside {
                                    -len
                                } else {
                                    len
                                }
                            }
                            // Beyond the band: outside (far) or inside (unknown), which only
                            // a full search would tell; the tree answers queries there.
                            None => f32::NAN,
                        };
                    }
                });
            }
        });
        Sdf { lo, dims, d }
    }

    /// The field at rest-frame point `x`.
    #[inline]
    pub fn lookup(&self, x: &Vector3<f64>) -> Lookup {
        let f = (x - self.lo) / CELL;
        let mut idx = [0usize; 3];
        let mut t = [0.0f64; 3];
        for a in 0..3 {
            let fl = f[a].floor();
            if !(fl >= 0.0 && (fl as usize) + 1 < self.dims[a]) {
                // Off the grid: farther than the band from the mesh's box.
                return Lookup::Far;
            }
            idx[a] = fl as usize;
            t[a] = f[a] - fl;
        }
        let (sx, sy) = (1, self.dims[0]);
        let sz = self.dims[0] * self.dims[1];
        let base = idx[0] + idx[1] * sy + idx[2] * sz;
        let c = |dx: usize, dy: usize, dz: usize| self.d[base + dx * sx + dy * sy + dz * sz];
        let v = [
            c(0, 0, 0),
            c(1, 0, 0),
            c(0, 1, 0),
            c(1, 1, 0),
            c(0, 0, 1),
            c(1, 0, 1),
            c(0, 1, 1),
            c(1, 1, 1),
        ];
        if v.iter().any(|x| x.is_nan()) {
            return Lookup::Unknown;
        }
        if v.iter().any(|x| x.is_infinite()) {
            return Lookup::Far;
        }
        let v = v.map(|x| x as f64);
        let [tx, ty, tz] = t;
        // Along x, then y, then z; the gradient from the same differences.
        let x00 = v[0] + (v[1] - v[0]) * tx;
        let x10 = v[2] + (v[3] - v[2]) * tx;
        let x01 = v[4] + (v[5] - v[4]) * tx;
        let x11 = v[6] + (v[7] - v[6]) * tx;
        let y0 = x00 + (x10 - x00) * ty;
        let y1 = x01 + (x11 - x01) * ty;
        let value = y0 + (y1 - y0) * tz;
        let dx0 = (v[1] - v[0]) + ((v[3] - v[2]) - (v[1] - v[0])) * ty;
        let dx1 = (v[5] - v[4]) + ((v[7] - v[6]) - (v[5] - v[4])) * ty;
        let gx = dx0 + (dx1 - dx0) * tz;
        let gy = (x10 - x00) + ((x11 - x01) - (x10 - x00)) * tz;
        let gz = y1 - y0;
        Lookup::Value(value, Vector3::new(gx, gy, gz) / CELL)
    }

    /// Samples stored, and those holding a distance (the band).
    pub fn counts(&self) -> (usize, usize) {
        (
            self.d.len(),
            self.d.iter().filter(|v| v.is_finite()).count(),
        )
    }
}
