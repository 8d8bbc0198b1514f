//! A pinhole camera: right-handed, y up, looking from `eye` towards `target`.

use crate::style::RenderParams;

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Position, metres.
    pub eye: [f32; 3],
    /// The point at the image centre, metres.
    pub target: [f32; 3],
    /// Approximate up direction (made orthogonal to the view direction).
    pub up: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

/// Default vertical field of view, degrees.
pub const DEFAULT_FOV_Y: f32 = 30.0;

pub(crate) fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(crate) fn normalize(a: [f32; 3]) -> [f32; 3] {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        [0.0, 0.0, 1.0]
    }
}
pub(crate) fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(crate) fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// A camera set up for one image: orthonormal basis and the pixel scale, in sample units.
#[derive(Debug, Clone, Copy)]
pub(crate) struct View {
    pub eye: [f32; 3],
    pub right: [f32; 3],
    pub up: [f32; 3],
    pub fwd: [f32; 3],
    /// Samples per unit of x/z (and y/z) at the image plane.
    pub focal: f32,
    /// Image centre, in samples.
    pub cx: f32,
    pub cy: f32,
}

/// Nearest view depth drawn, metres.
pub(crate) const NEAR: f32 = 1e-3;

impl View {
    pub fn new(c: &Camera, width_samples: u32, height_samples: u32) -> View {
        let fwd = normalize(sub(c.target, c.eye));
        let mut right = cross(fwd, c.up);
        if dot(right, right) < 1e-12 {
            // Looking straight along `up`: any perpendicular will do.
            right = cross(fwd, [1.0, 0.0, 0.0]);
            if dot(right, right) < 1e-12 {
                right = cross(fwd, [0.0, 0.0, 1.0]);
            }
        }
        let right = normalize(right);
        let up = cross(right, fwd);
        let half = (c.fov_y_deg.clamp(1.0, 170.0).to_radians() * 0.5).tan();
        View {
            eye: c.eye,
            right,
            up,
            fwd,
            focal: height_samples as f32 * 0.5 / half,
            cx: width_samples as f32 * 0.5,
            cy: height_samples as f32 * 0.5,
        }
    }

    /// Sample coordinates (x right, y down) and view depth of `p`.
    #[inline(always)]
    pub fn project(&self, p: [f32; 3]) -> [f32; 3] {
        let v = sub(p, self.eye);
        let z = dot(v, self.fwd);
        let inv = if z > NEAR { self.focal / z } else { 0.0 };
        [
            self.cx + dot(v, self.right) * inv,
            self.cy - dot(v, self.up) * inv,
            z,
        ]
    }

    /// The ray through sample position (x, y), scaled so that its view depth grows by 1 per
    /// unit of the ray parameter: a hit at parameter t has view depth t.
    #[inline]
    pub fn ray(&self, x: f32, y: f32) -> [f32; 3] {
        let a = (x - self.cx) / self.focal;
        let b = (self.cy - y) / self.focal;
        add(self.fwd, add(scale(self.right, a), scale(self.up, b)))
    }
}

impl Camera {
    /// A camera looking along `view_dir` (from the eye towards the scene) at the centre of the
    /// box `lo`–`hi`, far enough that the box's bounding sphere fits the default vertical field
    /// of view with a 10% margin (images are at least as wide as tall, so it fits horizontally
    /// too).
    pub fn framing(hair_lo: [f32; 3], hair_hi: [f32; 3], view_dir: [f32; 3]) -> Camera {
        let target = scale(add(hair_lo, hair_hi), 0.5);
        let r = (dot(sub(hair_hi, hair_lo), sub(hair_hi, hair_lo)).sqrt() * 0.5).max(1e-3);
        let half = (DEFAULT_FOV_Y.to_radians() * 0.5).sin();
        let dist = r * 1.1 / half;
        let dir = normalize(view_dir);
        Camera {
            eye: sub(target, scale(dir, dist)),
            target,
            up: [0.0, 1.0, 0.0],
            fov_y_deg: DEFAULT_FOV_Y,
        }
    }

    /// [`Camera::framing`] of the box, then the `eye`, `target` and `fov_y` overrides of
    /// `params` where given.
    pub fn from_params(
        params: &RenderParams,
        hair_lo: [f32; 3],
        hair_hi: [f32; 3],
        view_dir: [f32; 3],
    ) -> Camera {
        let mut c = Camera::framing(hair_lo, hair_hi, view_dir);
        if let Some(t) = params.target {
            c.target = t;
        }
        if let Some(e) = params.eye {
            c.eye = e;
        }
        if let Some(f) = params.fov_y {
            c.fov_y_deg = f;
        }
        c
    }
}

/// The axis-aligned bounding box of `points`, or a unit box at the origin if there are none.
pub fn bounds(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    if points.is_empty() {
        return ([-0.5; 3], [0.5; 3]);
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}

/// The default viewing direction (eye → scene): a three-quarter view of the face from its
/// left and a little above, so that the face, the side and the hair over the shoulder show.
pub const DEFAULT_VIEW: [f32; 3] = [-0.55, -0.2, -1.0];

/// A strand point on screen: sample coordinates and view depth.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ScreenVertex {
    pub x: f32,
    pub y: f32,
    pub z: f32,
}
