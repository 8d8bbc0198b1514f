//! Chang, Jin, Yu 2002, "A practical model for hair mutual interactions", §7.2 and Fig. 6: a
//! braid of two sets of guide hairs unfolding under gravity, with and without hair–hair
//! collision (§4.2). The scene is `scenes/chang_fig6.ron` (compiled in); it styles the braid,
//! which is where the straight hair starts (see [`straighten_rest`]).
//!
//! Two numbers, both computed from the simulation:
//! * `crossings`: how often a segment of one set passes through a segment of the other (see
//!   [`Crossings`]). Without collision the strands fall through each other; with it, about 0.
//! * `twist_turns`: the braid's twist at the end (3 at the start; see [`twist`]), and
//!   `end_turns`: how far its free end turned about the vertical meanwhile (the direction from
//!   set b's mean tip to set a's, unwrapped from step to step). With collision the sets cannot
//!   pass through each other, so the twist can only go by the end turning, the paper's "spiral
//!   motion": `twist_turns ≈ 3 + end_turns`; it unfolds fully (`twist_turns` near 0, the end
//!   turning nearly −3 times). Without it the twist goes to about 0 by the
//!   strands passing through, whatever the end does.

use nalgebra::{Rotation3, UnitQuaternion, Vector3};
use serde_json::{json, Map};

use super::chang::{guide_wisps, load_scene, scene_solver};
use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::solver::guides::chain::{min_rotation, Chains};
use crate::solver::guides::strips::{closest_segments, MIN_CROSSING};
use crate::solver::guides::GuideSolver;
use crate::solver::Solver;

const SCENE: &str = include_str!("../../scenes/chang_fig6.ron");

/// Seconds of each run.
const SECONDS: f64 = 4.0;

/// `chang-fig6`.
pub static CHANG_FIG6: ExperimentDef = ExperimentDef {
    name: "chang-fig6",
    description: "Chang, Jin, Yu 2002, Fig. 6: a braid of two sets of guides unfolding under \
                  gravity, with and without hair-hair collision",
    expectation: "crossings (a segment of one set passing through a segment of the other \
                  between two steps: the sign of their separation along the common normal \
                  flips while the closest points are inside both segments) is large without \
                  collision and about 0 with it (pairs more aligned than the strips' 11.5° \
                  are not counted: the model gives them no repulsion); with collision the \
                  braid untwists only by its free end turning, twist_turns = 3 + end_turns \
                  (the spiral), and it unfolds fully (|twist_turns| < 0.25, end_turns about \
                  -3); without it twist_turns falls to about 0 by passing through",
    run: run_fig6,
};

/// Pairs farther apart than this at a step are not followed (their sign is forgotten).
const NEAR: f64 = 0.02;
/// Segments more parallel than this sine (the strips' own `MIN_CROSSING`, about 11.5°) are
/// not followed: the model gives aligned hair no repulsion (Eq. 3 scales it by the sine and
/// the broad phase drops such pairs, hair lying along hair being what the strips stand for),
/// and two near-parallel segments have no well-defined side of each other.
const MIN_SINE: f64 = MIN_CROSSING;

/// Counts passes of the segments of one set of guides through those of another.
///
/// For segments `a` (set 0) and `b` (set 1), with closest points `p_a`, `p_b` and common
/// normal `n = d_a × d_b / |d_a × d_b|`, the separation `σ = (p_a − p_b)·n` is the signed
/// distance of the two lines. One segment passing through the other flips the sign of `σ`. A
/// flip between two steps is a crossing when, at both steps, the closest points lie strictly
/// inside both segments, the segments are not near-parallel (sine above [`MIN_SINE`]), and
/// `|σ_before| + |σ_after|` is below [`NEAR`] (what the two can move relative to each other in a
/// step): a flip caused by the closest points jumping elsewhere, or by `n` turning over as
/// the segments pass through parallel, is not a crossing.
pub struct Crossings {
    /// Links (`g · n + i`) of the two sets.
    a: Vec<usize>,
    b: Vec<usize>,
    /// Per pair (`ia · |b| + ib`): `σ` at the last step, NaN where it was not defined.
    prev: Vec<f64>,
    /// Crossings so far.
    pub count: u32,
}

impl Crossings {
    /// Follows the segments of the guides whose wisp is `wisps[g] == 0` against those of
    /// wisp 1.
    pub fn new(s: &GuideSolver, wisps: &[u32]) -> Crossings {
        let n = s.guide_params().segments;
        let links = |w: u32| -> Vec<usize> {
            s.alive()
                .iter()
                .filter(|&&g| wisps[g] == w)
                .flat_map(|&g| (0..n).map(move |i| g * n + i))
                .collect()
        };
        let (a, b) = (links(0), links(1));
        let prev = vec![f64::NAN; a.len() * b.len()];
        let mut c = Crossings {
            a,
            b,
            prev,
            count: 0,
        };
        c.update(&s.chains);
        c.count = 0;
        c
    }

    /// The separation of links `la` and `lb` now, if defined (see [`Crossings`]).
    fn separation(c: &Chains, la: usize, lb: usize) -> Option<f64> {
        let n = c.n;
        let va = (la / n) * (n + 1) + la % n;
        let vb = (lb / n) * (n + 1) + lb % n;
        let (a0, a1, b0, b1) = (c.x[va], c.x[va + 1], c.x[vb], c.x[vb + 1]);
        let mid = (a0 + a1 - b0 - b1) * 0.5;
        if mid.norm() > NEAR + 0.5 * (c.len[la] + c.len[lb]) {
            return None;
        }
        let (s, t) = closest_segments(&a0, &a1, &b0, &b1);
        const IN: f64 = 1e-6;
        if !(IN..1.0 - IN).contains(&s) || !(IN..1.0 - IN).contains(&t) {
            return None;
        }
        let (da, db) = (a1 - a0, b1 - b0);
        let nrm: Vector3<f64> = da.cross(&db);
        if nrm.norm() < MIN_SINE * da.norm() * db.norm() {
            return None;
        }
        let d = a0.lerp(&a1, s) - b0.lerp(&b1, t);
        Some(d.dot(&nrm) / nrm.norm())
    }

    /// Compares every pair with the last step; returns the crossings found in this step.
    pub fn update(&mut self, c: &Chains) -> u32 {
        let mut found = 0;
        let nb = self.b.len();
        for (ia, &la) in self.a.iter().enumerate() {
            for (ib, &lb) in self.b.iter().enumerate() {
                let now = Self::separation(c, la, lb).unwrap_or(f64::NAN);
                let before = self.prev[ia * nb + ib];
                if now.is_finite()
                    && before.is_finite()
                    && (now > 0.0) != (before > 0.0)
                    && now.abs() + before.abs() < NEAR
                {
                    found += 1;
                }
                self.prev[ia * nb + ib] = now;
            }
        }
        self.count += found;
        found
    }
}

/// Mean vertex `i` of the guides of wisp `w`.
fn mean_vertex(s: &GuideSolver, wisps: &[u32], w: u32, i: usize) -> Vector3<f64> {
    let n = s.guide_params().segments;
    let (mut sum, mut k) = (Vector3::zeros(), 0.0);
    for &g in s.alive() {
        if wisps[g] == w {
            sum += s.chains.x[g * (n + 1) + i];
            k += 1.0;
        }
    }
    sum / k
}

/// Angle about the vertical of the direction from set b's mean tip to set a's, rad.
fn tip_angle(s: &GuideSolver, wisps: &[u32]) -> f64 {
    let n = s.guide_params().segments;
    let d = mean_vertex(s, wisps, 0, n) - mean_vertex(s, wisps, 1, n);
    d.z.atan2(d.x)
}

/// The braid's twist, turns: how far the direction from set b to set a (the difference of their
/// mean vertices at each vertex index) turns about the vertical from root to tip, summed over
/// the segments (each step wrapped into half a turn).
fn twist(s: &GuideSolver, wisps: &[u32]) -> f64 {
    let n = s.guide_params().segments;
    let dir = |i: usize| {
        let d = mean_vertex(s, wisps, 0, i) - mean_vertex(s, wisps, 1, i);
        d.z.atan2(d.x)
    };
    let mut sum = 0.0;
    let mut a = dir(0);
    for i in 1..=n {
        let b = dir(i);
        sum += crate::solver::guides::chain::wrap(b - a);
        a = b;
    }
    sum / std::f64::consts::TAU
}

/// Makes straight hair the actuators' rest shape, keeping the braided configuration the scene
/// styles: the braid becomes where the hair starts, not the shape it springs back to.
///
/// Chang, Jin, Yu 2002, §3.2: a joint's actuator pulls towards its resting angles, the hair's
/// natural shape (non-zero only for curly hair); §7.2 lets "a simple braided hair model"
/// "unfold under gravity". Straight hair braided and let go has straight rest angles; a braid
/// that *is* the rest shape would be held braided by its own actuators (with the styled
/// twist as the rest shape the braid stops with about 1 of its 3 turns left). The links and
/// strips (built at construction, on the braid) are kept: they hold the sets together as
/// braided. Each joint's new rest rotation is its current one turned by the smallest rotation
/// that makes the chain straight below its root (link 0 pointing down, every other link
/// continuing its parent), so the joint rotations that keep the pose are pure swings (no
/// twist about the segment, which the joints do not have, §3.1).
fn straighten_rest(s: &mut GuideSolver) {
    let n = s.guide_params().segments;
    let down = -Vector3::y();
    for g in s.alive().to_vec() {
        let c = &mut s.chains;
        for i in 0..n {
            let l = g * n + i;
            let cur = c.rot[l];
            let parent = if i == 0 {
                cur * (c.r0[l] * c.q[l].to_rotation_matrix().into_inner()).transpose()
            } else {
                c.rot[l - 1]
            };
            let target = if i == 0 {
                down
            } else {
                parent.column(1).into_owned()
            };
            let rest = min_rotation(&cur.column(1).into_owned(), &target) * cur;
            c.r0[l] = parent.transpose() * rest;
            let j = rest.transpose() * cur;
            let mut q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(j));
            q.renormalize();
            c.q[l] = q;
        }
    }
}

fn run_fig6(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let (loaded, model) = load_scene("scenes/chang_fig6.ron", SCENE)?;
    let mut out = Vec::new();
    for (label, collision) in [("collision", true), ("no_collision", false)] {
        let mut s = scene_solver(&loaded, &model, |gp| gp.collision = collision)?;
        straighten_rest(&mut s);
        let wisps = guide_wisps(&s);
        let mut cross = Crossings::new(&s, &wisps);
        let spf = s.steps_per_frame();
        let frames =
            ((SECONDS * opts.duration_scale / (s.dt() * spf as f64)).round() as usize).max(1);
        let mut report = s.new_report();
        let mut angle = tip_angle(&s, &wisps);
        let mut turned = 0.0;
        for _ in 0..frames {
            for _ in 0..spf {
                s.step(&mut report);
                cross.update(&s.chains);
                let a = tip_angle(&s, &wisps);
                turned += crate::solver::guides::chain::wrap(a - angle);
                angle = a;
            }
            sink.frame(label, &mut s, &[])?;
        }
        let mut m = Map::new();
        m.insert("crossings".into(), json!(cross.count));
        m.insert("twist_turns".into(), json!(twist(&s, &wisps)));
        m.insert("end_turns".into(), json!(turned / std::f64::consts::TAU));
        out.push(ExperimentRun {
            label: label.into(),
            metrics: m,
        });
    }
    Ok(out)
}
