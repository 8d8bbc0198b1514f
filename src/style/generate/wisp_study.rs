//! One large wisp on a uniformly curved key strand, its members grown two ways, for the
//! comparison of Zhang and Wünsche 2007, §3.2 and §7.1, Fig. 13:
//!
//! - **Choe and Ko's distribution** (Choe and Ko 2005, as Zhang and Wünsche describe it): "varying
//!   the position of each control point of a member strand with respect to the key strand":
//!   every control point gets its own random offset, and the member is the Catmull-Rom spline
//!   through the displaced points. Each offset is drawn in the same envelope as Zhang's below
//!   (uniform in a disc of radius `k·ε` at control point `k`, across the key strand), so the two
//!   differ only in the offsets being independent.
//! - **Zhang's function** (§3.2, as [`super::generate`] grows every style): one random offset
//!   vector per member, uniform in a disc of radius ε across the key strand at the first
//!   control point, its length growing linearly with each later control point (`k·ε` at control
//!   point `k`, zero at the root), applied in the key strand's rotation-minimising frame.
//!
//! Plain geometry, used only by `wisptree experiment zhang-fig13`; nothing here is read by a
//! style.

use super::geometry::{
    add, catmull_rom, cross, dot, norm, resample_uniform, rotation_minimising_frame, scale, sub,
    SplitMix64,
};
use std::f64::consts::TAU;

type V3 = [f64; 3];

/// The wisp: its key strand and how its members are spread.
#[derive(Debug, Clone, PartialEq)]
pub struct WispStudy {
    /// Radius of the key strand's circular arc, m.
    pub arc_radius: f64,
    /// Angle the arc turns through, radians.
    pub arc_angle: f64,
    /// Control points of the key strand, root included (at least 3).
    pub control_points: usize,
    /// Points per strand after resampling; `(samples − 1)` is a multiple of
    /// `(control_points − 1)`, so that every control point is a sample.
    pub samples: usize,
    /// Member strands.
    pub members: usize,
    /// Radius of the disc the members' roots are spread over, m.
    pub root_radius: f64,
    /// Seed of the random offsets (the same seed gives the same roots in every variant).
    pub seed: u64,
}

impl Default for WispStudy {
    /// A 40 cm strand curving through 100° (radius 23 cm), 8 control intervals, 65 samples,
    /// 60 members rooted within 5 mm.
    fn default() -> Self {
        WispStudy {
            arc_radius: 0.23,
            arc_angle: 100f64.to_radians(),
            control_points: 9,
            samples: 65,
            members: 60,
            root_radius: 0.005,
            seed: 13,
        }
    }
}

/// How the members are offset from the key strand (ε: the largest offset at the first
/// control point after the root; `k·ε` at control point `k`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Offsets {
    /// Choe and Ko: an independent random offset at every control point.
    ChoeKo {
        /// ε, m.
        epsilon: f64,
    },
    /// Zhang and Wünsche: one random offset vector, growing linearly along the strand.
    Zhang {
        /// ε, m.
        epsilon: f64,
    },
}

/// A grown wisp: `key` and each member, `samples` points each, root first.
#[derive(Debug, Clone)]
pub struct StudyWisp {
    /// The key strand, resampled.
    pub key: Vec<V3>,
    /// The member strands.
    pub members: Vec<Vec<V3>>,
}

impl WispStudy {
    /// The key strand's control points: on a circle of `arc_radius` in the x–y plane, from the
    /// origin downwards (−y), curving towards +x.
    pub fn key_control(&self) -> Vec<V3> {
        let m = self.control_points.max(3);
        (0..m)
            .map(|k| {
                let th = self.arc_angle * k as f64 / (m - 1) as f64;
                [
                    self.arc_radius * (1.0 - th.cos()),
                    -self.arc_radius * th.sin(),
                    0.0,
                ]
            })
            .collect()
    }

    /// The wisp's members grown with `offsets`.
    pub fn grow(&self, offsets: Offsets) -> StudyWisp {
        let control = self.key_control();
        let m = control.len();
        let n = self.samples.max(m);
        let key = resample_uniform(&catmull_rom(&control), n);
        let (r, s) = rotation_minimising_frame(&key, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]);
        // The sample nearest control point k (exact when (n − 1) is a multiple of (m − 1)).
        let at_control = |k: usize| (k * (n - 1) + (m - 1) / 2) / (m - 1);
        let mut rng = SplitMix64::new(self.seed);
        let mut disc = |radius: f64| {
            let rho = radius * rng.next_f64().sqrt();
            let ang = rng.next_f64() * TAU;
            (rho * ang.cos(), rho * ang.sin())
        };
        let mut members = Vec::with_capacity(self.members);
        for _ in 0..self.members {
            // The root: a point of the disc across the key strand's first tangent.
            let (a, b) = disc(self.root_radius);
            let root = add(scale(r[0], a), scale(s[0], b));
            let member = match offsets {
                Offsets::Zhang { epsilon } => {
                    let (o1, o2) = disc(epsilon);
                    // k·ε at control point k is (m − 1)·ε at the tip, linear in arc length.
                    let tip = (m - 1) as f64;
                    (0..n)
                        .map(|j| {
                            let f = tip * j as f64 / (n - 1) as f64;
                            add(
                                add(key[j], root),
                                add(scale(r[j], f * o1), scale(s[j], f * o2)),
                            )
                        })
                        .collect()
                }
                Offsets::ChoeKo { epsilon } => {
                    let points: Vec<V3> = (0..m)
                        .map(|k| {
                            let j = at_control(k);
                            let (o1, o2) = disc(epsilon * k as f64);
                            add(add(control[k], root), add(scale(r[j], o1), scale(s[j], o2)))
                        })
                        .collect();
                    resample_uniform(&catmull_rom(&points), n)
                }
            };
            members.push(member);
        }
        StudyWisp { key, members }
    }
}

/// Discrete curvature of polyline `p` at each interior point, 1/m: the turning angle between
/// its two segments over their mean length (0 where a segment has no length).
pub fn curvatures(p: &[V3]) -> Vec<f64> {
    p.windows(3)
        .map(|w| {
            let (u, v) = (sub(w[1], w[0]), sub(w[2], w[1]));
            let (lu, lv) = (norm(u), norm(v));
            if lu <= 0.0 || lv <= 0.0 {
                return 0.0;
            }
            let sin = norm(cross(u, v)) / (lu * lv);
            let cos = dot(u, v) / (lu * lv);
            sin.atan2(cos) / (0.5 * (lu + lv))
        })
        .collect()
}

impl StudyWisp {
    /// Waviness, 1/m: the mean over members and interior samples of |κ_member − κ_key| at the
    /// same sample. A member that follows the key strand's bend smoothly scores near 0, one
    /// that wiggles around it scores by its wiggles.
    pub fn waviness(&self) -> f64 {
        let key = curvatures(&self.key);
        let (mut sum, mut count) = (0.0, 0usize);
        for m in &self.members {
            for (a, b) in curvatures(m).iter().zip(&key) {
                sum += (a - b).abs();
                count += 1;
            }
        }
        if count == 0 {
            0.0
        } else {
            sum / count as f64
        }
    }

    /// The members' spread at sample `j`, m: the RMS distance of their points from their mean.
    pub fn spread(&self, j: usize) -> f64 {
        let pts: Vec<V3> = self
            .members
            .iter()
            .filter_map(|m| m.get(j).copied())
            .collect();
        if pts.is_empty() {
            return 0.0;
        }
        let c = scale(
            pts.iter().fold([0.0; 3], |a, &p| add(a, p)),
            1.0 / pts.len() as f64,
        );
        let ss: f64 = pts.iter().map(|&p| dot(sub(p, c), sub(p, c))).sum();
        (ss / pts.len() as f64).sqrt()
    }
}
