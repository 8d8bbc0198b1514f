//! The guides' own motion over one sub-step (Chang, Jin, Yu 2002, §3): each guide's
//! articulated-body step under the forces gathered before it (§3.2), split where a joint
//! would turn fast, then its strand–body correction (§3.3), guide by guide on the pool's
//! threads in runs of consecutive slots.
//!
//! Once the forces are gathered, a guide's step reads nothing of another guide: each run
//! borrows its guides' joint state alone ([`ChainRun`]), so the result is the same bit for
//! bit on one thread or two, whichever thread took which run.

use std::sync::Mutex;

use nalgebra::{Point3, Vector3, Vector6};

use super::body::{self, PosedSphere};
use super::chain::{Base, ChainRun, Chains};
use super::{spatial_velocity, CORRECTION_PASSES, CORRECTION_RESIDUAL, MAX_SPLIT, MAX_TURN};
use crate::motion::{Motion, Pose};
use crate::par::{for_each_on, Pool};
use crate::simd::dispatch::multiversion;
use crate::simd::Level;

/// Runs the alive guides are cut into, for the pool's threads: enough that a thread finding
/// the other core busy takes the runs the other would have.
const RUNS: usize = 8;

/// The head's motion at `t` for a sub-step `h`: base of the chains (gravity folded in) and
/// the pose. While `settling`, the head holds still in its first pose.
pub(super) fn head_at(
    motion: &Motion,
    gravity: &Vector3<f64>,
    settling: bool,
    t: f64,
    h: f64,
) -> (Base, Pose) {
    let (p0, p1) = if settling {
        let mut p = motion.pose(0.0);
        p.linear_velocity = Vector3::zeros();
        p.angular_velocity = Vector3::zeros();
        (p, p)
    } else {
        (motion.pose(t), motion.pose(t + h))
    };
    let v0 = spatial_velocity(&p0);
    let g = gravity;
    let acc = (spatial_velocity(&p1) - v0) / h - Vector6::new(0.0, 0.0, 0.0, g.x, g.y, g.z);
    let base = Base {
        rot: *p0.iso.rotation.to_rotation_matrix().matrix(),
        vel: v0,
        acc,
    };
    (base, p0)
}

/// What every guide's step of one sub-step shares.
pub(super) struct SubStep<'a> {
    pub motion: &'a Motion,
    pub gravity: Vector3<f64>,
    pub settling: bool,
    /// Start and length of the sub-step, s.
    pub t: f64,
    pub h: f64,
    /// The head at its start and at its end.
    pub base0: Base,
    pub pose0: Pose,
    pub base1: Base,
    pub pose1: Pose,
    /// The body and obstacles at its end.
    pub spheres: &'a [PosedSphere],
    pub shapes: body::Shapes<'a>,
    pub margin: f64,
    pub friction: f64,
}

/// A run's scratch: a guide's corrected positions and velocities.
#[derive(Debug, Default)]
pub(super) struct RunBuffers {
    x: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
}

/// Advances every guide of `alive` over the sub-step `s` under the forces in `chains`, on
/// the threads of `pool` and the build of `level` ([`advance_run`]; the same result on any).
/// Returns the vertices pushed out of the body and the split integration steps taken.
pub(super) fn advance_guides(
    level: Level,
    chains: &mut Chains,
    alive: &[usize],
    pool: Option<&Pool>,
    buffers: &mut Vec<Mutex<RunBuffers>>,
    s: &SubStep,
) -> (usize, u64) {
    let count = alive.len();
    let slots = chains.capacity();
    // Run c: the alive guides `alive[c·A/R .. (c+1)·A/R]`, in the slots up to the next
    // run's first guide.
    let ends: [usize; RUNS] = std::array::from_fn(|c| {
        let k = (c + 1) * count / RUNS;
        if k < count {
            alive[k]
        } else {
            slots
        }
    });
    let n = chains.n;
    if buffers.len() != RUNS {
        *buffers = (0..RUNS)
            .map(|_| {
                Mutex::new(RunBuffers {
                    x: vec![Vector3::zeros(); n + 1],
                    v: vec![Vector3::zeros(); n + 1],
                })
            })
            .collect();
    }
    let peak0 = chains.peak_rate;
    let runs = chains.runs(&ends).map(|r| Mutex::new((r, 0usize, 0u64)));
    let buffers = &*buffers;
    for_each_on(pool, RUNS, &|c| {
        let mut guard = runs[c].lock().unwrap_or_else(|e| e.into_inner());
        let (run, pushed, splits) = &mut *guard;
        let mut buf = buffers[c].lock().unwrap_or_else(|e| e.into_inner());
        let guides = &alive[c * count / RUNS..(c + 1) * count / RUNS];
        let (p, k) = advance_run(level, run, guides, s, &mut buf);
        *pushed += p;
        *splits += k;
    });
    let (mut pushed, mut splits, mut peak) = (0, 0, peak0);
    for m in runs {
        let (run, p, k) = m.into_inner().unwrap_or_else(|e| e.into_inner());
        pushed += p;
        splits += k;
        peak = peak.max(run.peak_rate);
    }
    chains.peak_rate = peak;
    (pushed, splits)
}

multiversion! {
    /// The steps of `guides` (one run), built for AVX2 too (see `crate::simd::dispatch`): the
    /// articulated-body step's 6×6 and 6×2 products four lanes wide instead of two, in the
    /// same order (no fused multiply-add), so the same bits.
    fn advance_run(
        run: &mut ChainRun<'_>,
        guides: &[usize],
        s: &SubStep<'_>,
        buf: &mut RunBuffers,
    ) -> (usize, u64) {
        let (mut pushed, mut splits) = (0, 0);
        for &g in guides {
            let (p, k) = advance_guide(run, g, s, buf);
            pushed += p;
            splits += k;
        }
        (pushed, splits)
    }
}

/// One guide's step: integration (split where a joint would turn fast), forward kinematics
/// at the sub-step's end, body correction. Returns the vertices pushed out of the body by
/// the first correction pass and the split integration steps taken.
#[inline(always)]
fn advance_guide(run: &mut ChainRun, g: usize, s: &SubStep, buf: &mut RunBuffers) -> (usize, u64) {
    let h = s.h;
    let rest = Point3::from(run.root_rest(g));
    let root0 = s.pose0.transform_point(&rest).coords;
    let root1 = s.pose1.transform_point(&rest).coords;
    let mut splits = 0;
    // A guide whose fastest joint would turn more than MAX_TURN in the sub-step is
    // integrated in shorter steps (a whipped tip of a few-millimetre link turns at
    // 10³ rad/s): the velocity-product terms of the articulated-body step are explicit,
    // and they add energy once a joint turns by a sizeable angle per step.
    run.fk(g, &s.base0, &root0);
    let mut tau = 0.0;
    loop {
        let left = h - tau;
        let turn = run.max_rate(g) * left;
        if tau == 0.0 && turn <= MAX_TURN {
            run.integrate(g, &s.base0, h);
            break;
        }
        let hs = if turn <= MAX_TURN {
            left
        } else {
            (left * MAX_TURN / turn).max(h / MAX_SPLIT).min(left)
        };
        splits += 1;
        let (b, p) = head_at(s.motion, &s.gravity, s.settling, s.t + tau, hs);
        let root = p.transform_point(&rest).coords;
        run.fk(g, &b, &root);
        run.integrate(g, &b, hs);
        tau += hs;
        if tau >= h * (1.0 - 1e-9) {
            break;
        }
    }
    run.fk(g, &s.base1, &root1);
    // The correction is undone in part by the way back to joint space when the pushed
    // chain bends at a joint the way its two axes cannot follow exactly (2 mm at a tip
    // on Long under `shake`): correct again what the joints give, a few times at most.
    let mut pushed = 0;
    for pass in 0..CORRECTION_PASSES {
        let (x, v) = run.vertices(g);
        if pass > 0 && !body::any_deeper(x, s.spheres, &s.shapes, s.margin, CORRECTION_RESIDUAL) {
            break;
        }
        buf.x.copy_from_slice(x);
        buf.v.copy_from_slice(v);
        let p = body::correct(
            &mut buf.x,
            &mut buf.v,
            run.lengths(g),
            s.spheres,
            &s.shapes,
            s.margin,
            // Friction once per sub-step, as §3.3 has it: the later passes only move.
            if pass == 0 { s.friction } else { 0.0 },
        );
        if p == 0 {
            break;
        }
        if pass == 0 {
            pushed += p;
        }
        // Back to joint space (§3.3): each corrected segment direction by the smallest
        // turn of its link, each joint's rates from the corrected vertex velocities.
        run.set_state(g, &s.base1, &buf.x, &buf.v);
        run.fk(g, &s.base1, &root1);
    }
    (pushed, splits)
}
