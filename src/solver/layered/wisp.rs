//! The layered wisp's structure (Plante, Cani, Poulin 2002, §3.2–3.3): a skeleton chain of point
//! masses, an envelope of 4 radial point masses per skeleton point, and the twist-free
//! cross-section frames that the envelope and the drawn strands are placed in.
//!
//! Everything is structure of arrays: skeleton point `p` (all wisps one after another, root
//! first), envelope point `p * ENV + j` with `j` = +u, +v, −u, −v of the section frame.

use nalgebra::{Point3, Vector3};

use crate::model::{HairModel, MIN_RADIUS};
use crate::motion::Pose;

/// Envelope points per cross-section (§6: "we use only four envelope point-masses").
pub const ENV: usize = 4;

/// Smallest envelope radius over its rest radius: a section may be crushed, not inverted.
pub const MIN_RHO_FRACTION: f64 = 0.25;

/// Every wisp of a model, skeleton and envelope.
#[derive(Debug, Clone, Default)]
pub struct Wisps {
    /// Per wisp: its first skeleton point; `len() + 1` entries.
    pub start: Vec<u32>,
    /// Per wisp: the GC of the chosen level it stands for.
    pub gc: Vec<u32>,
    /// Per wisp: the reference point inside the head, in the rest pose (§3.2: "the first
    /// segment of the wisp skeleton ... is set to penetrate inside the character's head").
    pub anchor_rest: Vec<Vector3<f64>>,
    /// Per wisp: the anchor where the pose puts it.
    pub anchor: Vec<Vector3<f64>>,
    /// Per wisp: the anchor's velocity, m/s.
    pub anchor_vel: Vec<Vector3<f64>>,
    /// Per wisp: the head-fixed root frame at rest (normal `t`, first axis `u`).
    pub t0_rest: Vec<Vector3<f64>>,
    /// Per wisp: see `t0_rest`.
    pub u0_rest: Vec<Vector3<f64>>,
    /// Per skeleton point: its wisp.
    pub wisp_of: Vec<u32>,
    /// Per skeleton point: rest position (rest pose), m.
    pub rest_pos: Vec<Vector3<f64>>,
    /// Per skeleton point: position, m.
    pub pos: Vec<Vector3<f64>>,
    /// Per skeleton point: velocity, m/s.
    pub vel: Vec<Vector3<f64>>,
    /// Per skeleton point: velocity at the start of the step (its acceleration drives the
    /// envelope), m/s.
    pub prev_vel: Vec<Vector3<f64>>,
    /// Per skeleton point: accumulated force, N.
    pub force: Vec<Vector3<f64>>,
    /// Per skeleton point: mass, the sum of its strands' masses (§3.2), kg.
    pub mass: Vec<f64>,
    /// Per skeleton point: rest length of the segment to the next point (0 at the tip), m.
    pub rest_len: Vec<f64>,
    /// Per skeleton point: rest direction of the segment to the next point in this point's
    /// section frame, as (t, u, v) components (the angular spring's rest state).
    pub rest_dir: Vec<Vector3<f64>>,
    /// Per skeleton point: the section plane's normal (bisector of the two segments, §3.3).
    pub t: Vec<Vector3<f64>>,
    /// Per skeleton point: the section frame's first axis (`v = t × u`).
    pub u: Vec<Vector3<f64>>,
    /// Per skeleton point: the section frame's second axis `t × u`, kept with the frame by
    /// [`Wisps::compute_frames`] (so the envelope's half-lines cost no cross product).
    pub v: Vec<Vector3<f64>>,
    /// Per skeleton point `p`: the length of segment `p → p + 1` (0 at the tip), m, and its
    /// direction (`seg_dir`, the segment over its length when that is not 0), as
    /// [`Wisps::compute_frames`] last found them.
    pub seg_len: Vec<f64>,
    /// See `seg_len`.
    pub seg_dir: Vec<Vector3<f64>>,
    /// Per skeleton point: the root of its wisp (moved by the head, not simulated).
    pub is_root: Vec<bool>,
    /// Per envelope point: distance from the skeleton point along its half-line, m.
    pub rho: Vec<f64>,
    /// Per envelope point: rate of `rho`, m/s.
    pub rho_rate: Vec<f64>,
    /// Per envelope point: rest distance, m.
    pub rho_rest: Vec<f64>,
    /// Per envelope point: force along its half-line, N.
    pub rho_force: Vec<f64>,
    /// Per envelope point `j`: the rest length of the ring spring to point `j + 1` of the same
    /// section, `sqrt(rho_rest[j]² + rho_rest[j + 1]²)`, m.
    pub ring_rest: Vec<f64>,
}

impl Wisps {
    /// Number of wisps.
    pub fn len(&self) -> usize {
        self.gc.len()
    }

    /// No wisp.
    pub fn is_empty(&self) -> bool {
        self.gc.is_empty()
    }

    /// Skeleton points of wisp `w`.
    pub fn points(&self, w: usize) -> std::ops::Range<usize> {
        self.start[w] as usize..self.start[w + 1] as usize
    }

    /// Total skeleton points.
    pub fn point_count(&self) -> usize {
        self.pos.len()
    }

    /// Builds one wisp per GC of level `level` at rest: the skeleton on the GC's nodes, the
    /// envelope around its strands in each section (at least 0.3 × the GC's radius).
    pub fn build(model: &HairModel, level: usize) -> Wisps {
        let k = model.k;
        let lv = &model.levels[level];
        let mut w = Wisps::default();
        for g in 0..lv.gc_count() {
            w.start.push(w.rest_pos.len() as u32);
            w.gc.push(g as u32);
            for i in 0..k {
                let x = lv.rest_pos[g * k + i];
                w.wisp_of.push(g as u32);
                w.rest_pos.push(x);
                w.mass.push(lv.mass[g * k + i]);
            }
        }
        w.start.push(w.rest_pos.len() as u32);
        let n = w.rest_pos.len();
        w.pos = w.rest_pos.clone();
        w.vel = vec![Vector3::zeros(); n];
        w.prev_vel = vec![Vector3::zeros(); n];
        w.force = vec![Vector3::zeros(); n];
        w.rest_len = vec![0.0; n];
        w.rest_dir = vec![Vector3::x(); n];
        w.t = vec![Vector3::y(); n];
        w.u = vec![Vector3::x(); n];
        w.v = vec![Vector3::z(); n];
        w.seg_len = vec![0.0; n];
        w.seg_dir = vec![Vector3::zeros(); n];
        w.is_root = vec![false; n];
        for wi in 0..w.len() {
            let first = w.start[wi] as usize;
            w.is_root[first] = true;
        }
        for wi in 0..w.len() {
            let r = w.points(wi);
            for p in r.start..r.end - 1 {
                w.rest_len[p] = (w.rest_pos[p + 1] - w.rest_pos[p]).norm();
            }
            let root = w.rest_pos[r.start];
            let d0 = (w.rest_pos[r.start + 1] - root)
                .try_normalize(1e-12)
                .unwrap_or(-Vector3::y());
            let l0 = w.rest_len[r.start].max(1e-3);
            // Into the head when the root is on it; else straight back along the first segment
            // (a scene's free-hanging wisp).
            let c = model.scalp_center;
            let near_head = (root - c).norm() < 2.0 * model.scalp_radii.max();
            let into = if near_head {
                (c - root).try_normalize(1e-12).unwrap_or(-d0)
            } else {
                -d0
            };
            let anchor = root + into * l0;
            w.anchor_rest.push(anchor);
            w.anchor.push(anchor);
            w.anchor_vel.push(Vector3::zeros());
            let t0 = bisector(&(root - anchor).normalize(), &d0);
            w.t0_rest.push(t0);
            w.u0_rest.push(any_perpendicular(&t0));
        }
        w.compute_frames(&Pose::identity());
        for p in 0..n {
            let wi = w.wisp_of[p] as usize;
            if p + 1 < w.start[wi + 1] as usize {
                let s = (w.rest_pos[p + 1] - w.rest_pos[p]) / w.rest_len[p].max(1e-12);
                let v = w.v[p];
                w.rest_dir[p] = Vector3::new(s.dot(&w.t[p]), s.dot(&w.u[p]), s.dot(&v));
            }
        }
        // Envelope rest radii: the strands' extent along each half-line.
        let mut rho = vec![0.0f64; n * ENV];
        let finest = model.level_count() - 1;
        for s in 0..model.strands.len() {
            let g = ancestor(model, finest, model.strands.finest_gc[s] as usize, level);
            let base = w.start[g] as usize;
            for i in 0..k {
                let p = base + i;
                let off = model.strands.rest[s * k + i] - w.rest_pos[p];
                for j in 0..ENV {
                    let e = off.dot(&w.env_dir(p, j));
                    rho[p * ENV + j] = rho[p * ENV + j].max(e);
                }
            }
        }
        for wi in 0..w.len() {
            for (i, p) in w.points(wi).enumerate() {
                let floor = (0.3 * lv.radius[wi * k + i]).max(MIN_RADIUS);
                for j in 0..ENV {
                    rho[p * ENV + j] = rho[p * ENV + j].max(floor);
                }
            }
        }
        // The envelope is the ellipse quadrants through the 4 points (§6, Fig. 4): widen a
        // section until it encloses every strand point of it, not only their extents along the
        // 4 half-lines.
        let mut widen = vec![1.0f64; n];
        for s in 0..model.strands.len() {
            let g = ancestor(model, finest, model.strands.finest_gc[s] as usize, level);
            for i in 0..k {
                let p = w.start[g] as usize + i;
                let off = model.strands.rest[s * k + i] - w.rest_pos[p];
                let (x, y) = (off.dot(&w.env_dir(p, 0)), off.dot(&w.env_dir(p, 1)));
                let r = &rho[p * ENV..p * ENV + ENV];
                let rx = if x >= 0.0 { r[0] } else { r[2] };
                let ry = if y >= 0.0 { r[1] } else { r[3] };
                widen[p] = widen[p].max(((x / rx).powi(2) + (y / ry).powi(2)).sqrt());
            }
        }
        for (p, f) in widen.iter().enumerate() {
            rho[p * ENV..p * ENV + ENV].iter_mut().for_each(|r| *r *= f);
        }
        w.ring_rest = (0..n * ENV)
            .map(|e| {
                let (p, j) = (e / ENV, e % ENV);
                let k = p * ENV + (j + 1) % ENV;
                (rho[e].powi(2) + rho[k].powi(2)).sqrt()
            })
            .collect();
        w.rho_rest = rho.clone();
        w.rho = rho;
        w.rho_rate = vec![0.0; n * ENV];
        w.rho_force = vec![0.0; n * ENV];
        w
    }

    /// World direction of envelope half-line `j` of skeleton point `p` (+u, +v, −u, −v).
    #[inline]
    pub fn env_dir(&self, p: usize, j: usize) -> Vector3<f64> {
        match j {
            0 => self.u[p],
            1 => self.v[p],
            2 => -self.u[p],
            _ => -self.v[p],
        }
    }

    /// The 4 half-line directions of section `p` (+u, +v, −u, −v).
    #[inline]
    pub fn env_dirs(&self, p: usize) -> [Vector3<f64>; ENV] {
        let (u, v) = (self.u[p], self.v[p]);
        [u, v, -u, -v]
    }

    /// World position of envelope point `j` of skeleton point `p`.
    #[inline]
    pub fn env_pos(&self, p: usize, j: usize) -> Vector3<f64> {
        self.pos[p] + self.env_dir(p, j) * self.rho[p * ENV + j]
    }

    /// World velocity of envelope point `j` of `p`: the skeleton's plus its radial rate (the
    /// frame's rotation is neglected: the envelope moves only radially, §3.3).
    #[inline]
    pub fn env_vel(&self, p: usize, j: usize) -> Vector3<f64> {
        self.vel[p] + self.env_dir(p, j) * self.rho_rate[p * ENV + j]
    }

    /// Places every root and anchor where `pose` puts them (the root moves with the head).
    pub fn pose_roots(&mut self, pose: &Pose) {
        for wi in 0..self.len() {
            let p = self.start[wi] as usize;
            let x = pose.transform_point(&Point3::from(self.rest_pos[p]));
            self.pos[p] = x.coords;
            self.vel[p] = pose.velocity_at(&x);
            let a = pose.transform_point(&Point3::from(self.anchor_rest[wi]));
            self.anchor[wi] = a.coords;
            self.anchor_vel[wi] = pose.velocity_at(&a);
        }
    }

    /// Section frames from the current positions (§3.3): each section lies in the plane that
    /// bisects its two segments; the root frame is head-fixed, and each next frame is the
    /// previous one turned by the minimal rotation between the two section normals, so the
    /// frames never twist whatever the way the wisp bends.
    pub fn compute_frames(&mut self, pose: &Pose) {
        for wi in 0..self.len() {
            self.compute_wisp_frames(wi, pose);
        }
    }

    /// [`Wisps::compute_frames`] for wisp `wi` only.
    pub fn compute_wisp_frames(&mut self, wi: usize, pose: &Pose) {
        let r = self.points(wi);
        let mut d_prev = (self.pos[r.start] - self.anchor[wi])
            .try_normalize(1e-12)
            .unwrap_or(-Vector3::y());
        let mut u_prev = pose.transform_vector(&self.u0_rest[wi]);
        let mut t_prev = pose.transform_vector(&self.t0_rest[wi]);
        for p in r.clone() {
            let t = if p + 1 < r.end {
                let s = self.pos[p + 1] - self.pos[p];
                let len = s.norm();
                if len > 0.0 {
                    self.seg_dir[p] = s / len;
                }
                self.seg_len[p] = len;
                let d = if len > 1e-12 { self.seg_dir[p] } else { d_prev };
                let t = bisector(&d_prev, &d);
                d_prev = d;
                t
            } else {
                d_prev
            };
            let u = transport(&u_prev, &t_prev, &t);
            let u = (u - t * u.dot(&t))
                .try_normalize(1e-12)
                .unwrap_or_else(|| any_perpendicular(&t));
            self.t[p] = t;
            self.u[p] = u;
            self.v[p] = t.cross(&u);
            t_prev = t;
            u_prev = u;
        }
    }
}

/// The GC of level `to` that contains GC `g` of level `from` (`to <= from`).
pub fn ancestor(model: &HairModel, from: usize, mut g: usize, to: usize) -> usize {
    let mut l = from;
    while l > to {
        g = model.levels[l].super_gc[g] as usize;
        l -= 1;
    }
    g
}

/// Unit normal of the plane bisecting two consecutive unit segment directions (§3.3); the
/// second direction when they fold back onto each other.
pub fn bisector(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    (a + b).try_normalize(1e-6).unwrap_or(*b)
}

/// A unit vector perpendicular to unit `t`, chosen deterministically.
pub fn any_perpendicular(t: &Vector3<f64>) -> Vector3<f64> {
    let a = if t.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::z()
    };
    (a - t * a.dot(t)).normalize()
}

/// `x` turned by the minimal rotation that takes unit `a` onto unit `b` (axis `a × b`,
/// §3.3's quaternion). Antiparallel `a`, `b` have no minimal rotation: `x` is reflected.
pub fn transport(x: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    let k = a.cross(b);
    let s2 = k.norm_squared();
    let c = a.dot(b);
    if s2 < 1e-24 {
        return if c > 0.0 {
            *x
        } else {
            x - a * (2.0 * x.dot(a))
        };
    }
    // Rodrigues with an unnormalised axis: sinθ·k̂ = k, (1 − cosθ)·k̂k̂ᵀ = (1 − c)/|k|²·kkᵀ.
    x * c + k.cross(x) + k * (k.dot(x) * (1.0 - c) / s2)
}
