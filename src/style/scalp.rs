//! The scalp in force: the style's `head.scalp`, else (with `head.fit_body`) a sphere on the
//! fitted head, else the default one; and how far imported roots lie from it.
//!
//! The scalp is the motion's pivot, the viewer's head and the renderer's framing. Imported hair
//! sits wherever its file put it (a USC-HairSalon head has its roots near y = 0.1 m), so the
//! default scalp at (0, 1.6, 0) can be 1.5 m away from it: the head then swings the hair about
//! a point far above it. Placing the scalp on the fitted head avoids that, and a warning says
//! when the roots lie far from the scalp in force.

use nalgebra::Vector3;

use super::schema::{default_scalp, Ellipsoid, Head, Sphere};

/// `head.scalp` as RON writes it: a plain ellipsoid, `None` when absent.
pub(super) mod given {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::Ellipsoid;

    pub fn serialize<S: Serializer>(v: &Option<Ellipsoid>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(e) => e.serialize(s),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Ellipsoid>, D::Error> {
        Ellipsoid::deserialize(d).map(Some)
    }
}

impl Head {
    /// The scalp the style gives, else the default one (not the fitted one: see
    /// [`LoadedStyle::scalp`](super::LoadedStyle)).
    pub fn scalp(&self) -> Ellipsoid {
        self.scalp.clone().unwrap_or_else(default_scalp)
    }
}

/// The scalp of a fitted head sphere: a sphere through the nearest root (the fitted sphere is
/// shrunk to [`super::import::FIT_SHRINK`] of that distance), so no root lies inside the head.
pub fn fitted_scalp(head: &Sphere) -> Ellipsoid {
    let r = head.radius / super::import::FIT_SHRINK;
    Ellipsoid {
        center: head.center,
        radii: [r; 3],
    }
}

/// How far from the scalp's surface the median root lies, m (along the ray from the centre).
pub fn median_root_distance(
    center: &Vector3<f64>,
    radii: &Vector3<f64>,
    roots: impl Iterator<Item = Vector3<f64>>,
) -> Option<f64> {
    let mut d: Vec<f64> = roots
        .map(|p| {
            let v = p - center;
            let n = v.norm();
            if n == 0.0 {
                return radii.min();
            }
            let u = v / n;
            // The ellipsoid's radius along u: 1 / |(u_x / r_x, u_y / r_y, u_z / r_z)|.
            let along = 1.0 / u.component_div(radii).norm();
            (n - along).abs()
        })
        .collect();
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    Some(*d.select_nth_unstable_by(mid, f64::total_cmp).1)
}
