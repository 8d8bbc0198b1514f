//! Keyframed motion files (`motions/*.ron`): parsing with file:line:column errors, and
//! interpolation.

use nalgebra::Vector3;
use serde::Deserialize;

use super::*;

/// The `.ron` schema of a keyframed motion.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, rename = "KeyframedMotion")]
pub(super) struct KeyframedMotion {
    /// Default (empty): the file stem.
    #[serde(default)]
    pub(super) name: String,
    /// Rotation centre, relative to the scalp centre (anchor), metres. Default (0, 0, 0).
    #[serde(default)]
    pub(super) pivot: [f64; 3],
    /// Repeat from the first key after the last; the last key must then equal the first.
    #[serde(default)]
    pub(super) looping: bool,
    pub(super) keys: Vec<Key>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Key {
    /// Seconds, ≥ 0, strictly increasing.
    pub(super) time: f64,
    /// Pivot offset in world axes, metres. Default (0, 0, 0).
    #[serde(default)]
    pub(super) translation: [f64; 3],
    /// Euler angles in degrees about x, then y, then z (fixed axes), default (0, 0, 0).
    #[serde(default)]
    pub(super) rotation: [f64; 3],
}

/// Validated keys with precomputed Catmull-Rom tangents.
///
/// Interpolation: each of the six channels (translation xyz, Euler angles xyz) is a cubic
/// Hermite spline through the keys with Catmull-Rom tangents for uneven spacing,
/// `m_i = (p_{i+1} − p_{i−1}) / (t_{i+1} − t_{i−1})`. Euler angles rather than quaternion
/// squad: the angular velocity then has a closed form and head motions stay far from gimbal
/// lock. A non-looping motion has zero tangents at both ends and holds the end keys outside
/// them. A looping motion uses periodic tangents, except on the first pass where the first key
/// has a zero tangent, so it starts at rest.
#[derive(Debug, Clone)]
pub(super) struct Keyframes {
    pub(super) looping: bool,
    pub(super) times: Vec<f64>,
    /// Per key: translation (metres) then Euler angles (radians).
    pub(super) values: Vec<[f64; 6]>,
    pub(super) tangents: Vec<[f64; 6]>,
}

pub(super) type KeyError = (String, Option<usize>, String);

impl Keyframes {
    pub(super) fn new(file: &KeyframedMotion) -> Result<Keyframes, KeyError> {
        let keys = &file.keys;
        let err = |field: &str, key: Option<usize>, msg: String| Err((field.to_string(), key, msg));
        if file.pivot.iter().any(|v| !v.is_finite()) {
            return err("pivot", None, "must be finite".into());
        }
        if keys.len() < 2 {
            return err(
                "keys",
                None,
                format!("a motion needs at least 2 keys, found {}", keys.len()),
            );
        }
        for (i, k) in keys.iter().enumerate() {
            if !k.time.is_finite() || k.time < 0.0 {
                return err(
                    "time",
                    Some(i),
                    format!("must be a finite time ≥ 0 s, found {:?}", k.time),
                );
            }
            if i > 0 && k.time <= keys[i - 1].time {
                return err(
                    "time",
                    Some(i),
                    format!(
                        "key times must be strictly increasing: {:?} s follows {:?} s",
                        k.time,
                        keys[i - 1].time
                    ),
                );
            }
            if k.translation.iter().any(|v| !v.is_finite()) {
                return err("translation", Some(i), "must be finite".into());
            }
            if k.rotation.iter().any(|v| !v.is_finite()) {
                return err("rotation", Some(i), "must be finite".into());
            }
        }
        let n = keys.len();
        if file.looping {
            let (first, last) = (&keys[0], &keys[n - 1]);
            let close =
                |a: &[f64; 3], b: &[f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-9);
            if !close(&first.translation, &last.translation) {
                return err(
                    "translation",
                    Some(n - 1),
                    "a looping motion must end where it starts: the last key's translation must equal the first key's".into(),
                );
            }
            if !close(&first.rotation, &last.rotation) {
                return err(
                    "rotation",
                    Some(n - 1),
                    "a looping motion must end where it starts: the last key's rotation must equal the first key's".into(),
                );
            }
        }
        let times: Vec<f64> = keys.iter().map(|k| k.time).collect();
        let values: Vec<[f64; 6]> = keys
            .iter()
            .map(|k| {
                let (t, r) = (k.translation, k.rotation);
                [
                    t[0],
                    t[1],
                    t[2],
                    r[0].to_radians(),
                    r[1].to_radians(),
                    r[2].to_radians(),
                ]
            })
            .collect();
        let tangent = |prev: usize, next: usize, dt: f64| -> [f64; 6] {
            std::array::from_fn(|c| (values[next][c] - values[prev][c]) / dt)
        };
        let mut tangents = vec![[0.0; 6]; n];
        for i in 1..n - 1 {
            tangents[i] = tangent(i - 1, i + 1, times[i + 1] - times[i - 1]);
        }
        if file.looping {
            // The first and last keys are the same instant of the cycle.
            let dt = (times[1] - times[0]) + (times[n - 1] - times[n - 2]);
            let m = tangent(n - 2, 1, dt);
            tangents[0] = m;
            tangents[n - 1] = m;
        }
        Ok(Keyframes {
            looping: file.looping,
            times,
            values,
            tangents,
        })
    }

    pub(super) fn sample(&self, t: f64) -> Sample {
        let n = self.times.len();
        let (t0, tn) = (self.times[0], self.times[n - 1]);
        let hold = |i: usize| {
            let v = &self.values[i];
            Sample {
                angles: Vector3::new(v[3], v[4], v[5]),
                angle_rates: Vector3::zeros(),
                offset: Vector3::new(v[0], v[1], v[2]),
                offset_rate: Vector3::zeros(),
            }
        };
        if t <= t0 {
            return hold(0);
        }
        let (t, first_pass) = if t < tn {
            (t, true)
        } else if self.looping {
            (t0 + (t - t0) % (tn - t0), false)
        } else {
            return hold(n - 1);
        };
        // Interval i: times[i] ≤ t < times[i+1].
        let i = self
            .times
            .partition_point(|&k| k <= t)
            .saturating_sub(1)
            .min(n - 2);
        let dur = self.times[i + 1] - self.times[i];
        let local = t - self.times[i];
        let m0 = if i == 0 && first_pass {
            [0.0; 6]
        } else {
            self.tangents[i]
        };
        let m1 = self.tangents[i + 1];
        let mut v = [0.0; 6];
        let mut dv = [0.0; 6];
        for c in 0..6 {
            (v[c], dv[c]) = hermite(
                self.values[i][c],
                m0[c],
                self.values[i + 1][c],
                m1[c],
                dur,
                local,
            );
        }
        Sample {
            angles: Vector3::new(v[3], v[4], v[5]),
            angle_rates: Vector3::new(dv[3], dv[4], dv[5]),
            offset: Vector3::new(v[0], v[1], v[2]),
            offset_rate: Vector3::new(dv[0], dv[1], dv[2]),
        }
    }
}

/// Line and column (1-based) of a field in the text: the `key`-th occurrence of `field:` when a
/// key index is given (each key has at most one of each field), else the first.
pub(super) fn locate_field(text: &str, field: &str, key: Option<usize>) -> Option<(usize, usize)> {
    let mut seen = 0;
    for (ln, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or_default();
        let mut from = 0;
        while let Some(off) = code[from..].find(field) {
            let at = from + off;
            from = at + field.len();
            let before_ok = code[..at]
                .chars()
                .next_back()
                .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
            let after_ok = code[from..].trim_start().starts_with(':');
            if !(before_ok && after_ok) {
                continue;
            }
            if seen == key.unwrap_or(0) {
                return Some((ln + 1, code[..at].chars().count() + 1));
            }
            seen += 1;
        }
    }
    None
}
