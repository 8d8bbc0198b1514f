//! Obstacles that move on their own path, independently of the head and of the hair roots: the
//! sphere that hits a brush whose base stays still (Chang, Jin, Yu 2002, §7.4 and Fig. 7).
//!
//! The body spheres of a style move rigidly with the head, together with the roots; an
//! obstacle of the `guides:` section instead follows its own keyframed centre path, in world
//! coordinates. The guide solver poses it at every sub-step beside the body spheres, and the
//! strand–body collision of §3.3 treats it like them (vertices take its velocity, may leave it
//! or slide with friction, penetrations are undone root to tip).

use nalgebra::Vector3;

use super::body::PosedSphere;
pub use crate::style::guides_section::{MovingSphere, PathKey};

/// Obstacle `o` posed at time `t`, as the body collision takes it.
pub fn posed(o: &MovingSphere, t: f64) -> PosedSphere {
    let (center, velocity) = o.center_at(t);
    PosedSphere {
        center,
        radius: o.radius,
        velocity,
        spin: Vector3::zeros(),
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
