//! Obstacles that move on their own path, independently of the head and of the hair roots: the
//! sphere that hits a brush whose base stays still (Chang, Jin, Yu 2002, §7.4 and Fig. 7).
//!
//! The body spheres of a style move rigidly with the head, together with the roots; an
//! obstacle of the `guides:` section instead follows its own keyframed centre path, in world
//! coordinates. The guide solver poses it at every sub-step beside the body spheres, and the
//! strand–body collision of §3.3 treats it like them (vertices take its velocity, may leave it
//! or slide with friction, penetrations are undone root to tip).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::body::PosedSphere;

/// One key of an obstacle's path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathKey {
    /// Seconds from the start of the run (after settling), ≥ 0, strictly increasing.
    pub time: f64,
    /// Centre of the sphere at that time, world coordinates, m.
    pub center: [f64; 3],
}

/// A sphere on a keyframed path: `(radius: 0.05, path: [(time: 0, center: (x, y, z)), …])`.
///
/// Between two keys the centre eases in and out (a cubic Hermite segment with zero end
/// tangents), so position and velocity are continuous and the velocity is the exact
/// derivative of the position; the sphere is at rest at every key, before the first and after
/// the last. A single key is a still sphere.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MovingSphere {
    /// Radius, m.
    pub radius: f64,
    /// The keys of its centre path (at least one).
    pub path: Vec<PathKey>,
}

impl MovingSphere {
    /// Centre and velocity at time `t`.
    pub fn center_at(&self, t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let p = &self.path;
        let at = |k: usize| Vector3::from(p[k].center);
        let j = p.partition_point(|k| k.time <= t);
        if j == 0 {
            return (at(0), Vector3::zeros());
        }
        if j == p.len() {
            return (at(p.len() - 1), Vector3::zeros());
        }
        let (a, b) = (&p[j - 1], &p[j]);
        let span = b.time - a.time;
        let u = (t - a.time) / span;
        let d = at(j) - at(j - 1);
        let s = u * u * (3.0 - 2.0 * u);
        let ds = 6.0 * u * (1.0 - u) / span;
        (at(j - 1) + d * s, d * ds)
    }

    /// The sphere posed at time `t`, as the body collision takes it.
    pub fn posed(&self, t: f64) -> PosedSphere {
        let (center, velocity) = self.center_at(t);
        PosedSphere {
            center,
            radius: self.radius,
            velocity,
            spin: Vector3::zeros(),
        }
    }

    /// Time of the last key: the sphere is still from then on.
    pub fn stop_time(&self) -> f64 {
        self.path.last().map_or(0.0, |k| k.time)
    }
}

/// Checks obstacle `i`; returns the field path below `guides.` and the reason.
pub fn validate(i: usize, o: &MovingSphere) -> Result<(), (String, String)> {
    let field = |f: &str| format!("obstacles[{i}].{f}");
    if !(o.radius.is_finite() && o.radius > 0.0) {
        return Err((
            field("radius"),
            format!("must be positive and finite, got {}", o.radius),
        ));
    }
    if o.path.is_empty() {
        return Err((field("path"), "needs at least one key".into()));
    }
    for (k, key) in o.path.iter().enumerate() {
        if !(key.time.is_finite() && key.time >= 0.0) {
            return Err((
                field(&format!("path[{k}].time")),
                format!("must be a finite time ≥ 0 s, got {}", key.time),
            ));
        }
        if k > 0 && key.time <= o.path[k - 1].time {
            return Err((
                field(&format!("path[{k}].time")),
                format!(
                    "key times must be strictly increasing: {} s follows {} s",
                    key.time,
                    o.path[k - 1].time
                ),
            ));
        }
        if key.center.iter().any(|c| !c.is_finite()) {
            return Err((field(&format!("path[{k}].center")), "must be finite".into()));
        }
    }
    Ok(())
}
