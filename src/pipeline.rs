//! The stages between a solver and the threads: stepping one displayed frame
//! ([`step_frame`]) and filling a [`Frame`] from the solver ([`FrameBuilder`]). `wisptree run`,
//! the bench, the experiments and the tests all go through these.

use std::time::Instant;

use crate::frame::{BodyBuf, Frame};
use crate::report::{EventKind, StageTimes, StepReport};
use crate::solver::Solver;

/// Fills `Frame`s from a simulation. Owns the strand subset and scratch buffers, so building a
/// frame allocates nothing once warm.
pub struct FrameBuilder {
    /// The strands drawn, a deterministic evenly spread subset.
    strands: Vec<u32>,
    /// Points per strand segment after Catmull-Rom smoothing (1 = the K nodes only).
    subdivisions: usize,
    scratch: Vec<nalgebra::Vector3<f64>>,
}

impl FrameBuilder {
    /// Draws `n` strands (all of them if `n` is larger), smoothed with `subdivisions` points per
    /// span.
    pub fn new(model: &crate::model::HairModel, n: usize, subdivisions: usize) -> FrameBuilder {
        let total = model.strands.len();
        let n = n.min(total);
        // Evenly spaced over the strands, which are grouped by finest GC: every wisp shows.
        let strands = (0..n).map(|j| ((j * total) / n.max(1)) as u32).collect();
        FrameBuilder {
            strands,
            subdivisions: subdivisions.max(1),
            scratch: Vec::new(),
        }
    }

    /// Strands drawn per frame.
    pub fn strand_count(&self) -> usize {
        self.strands.len()
    }

    /// The strands drawn (model strand indices).
    pub fn strands(&self) -> &[u32] {
        &self.strands
    }

    /// Overwrites `f`'s geometry with the solver's current state: its primitives, the drawn
    /// strands (smoothed) and the body. Counters, events and messages are the caller's.
    pub fn fill(&mut self, solver: &mut dyn crate::solver::Solver, f: &mut Frame) {
        solver.sync_display();
        f.sim_time = solver.time();
        f.solver = solver.kind().path_segment();
        f.levels = solver.model().level_count() as u16;
        f.clear_primitives();
        solver.draw(f);

        f.strands.points.clear();
        f.strands.offsets.clear();
        f.strands.offsets.push(0);
        for &st in &self.strands {
            self.scratch.clear();
            solver.strand_points(st as usize, &mut self.scratch);
            catmull_rom(&self.scratch, self.subdivisions, &mut f.strands.points);
            f.strands.offsets.push(f.strands.points.len() as u32);
        }
        fill_body(solver.model(), solver.pose(), &mut f.body);
    }
}

impl FrameBuilder {
    /// Writes the builder's strands (smoothed) into `out`, after [`FrameBuilder::fill`] (or
    /// [`Solver::sync_display`]) brought the solver's display state up to date.
    pub fn fill_strands(&mut self, solver: &dyn Solver, out: &mut crate::frame::StrandBuf) {
        out.points.clear();
        out.offsets.clear();
        out.offsets.push(0);
        for &st in &self.strands {
            self.scratch.clear();
            solver.strand_points(st as usize, &mut self.scratch);
            catmull_rom(&self.scratch, self.subdivisions, &mut out.points);
            out.offsets.push(out.points.len() as u32);
        }
    }
}

/// Poses the model's body spheres and scalp into `body`.
pub fn fill_body(m: &crate::model::HairModel, pose: &crate::motion::Pose, body: &mut BodyBuf) {
    use nalgebra::{Point3, Vector3};
    let to32 = |v: &Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    body.sphere_centers.clear();
    body.sphere_radii.clear();
    for sp in &m.body {
        let c = pose.transform_point(&Point3::from(Vector3::from(sp.center)));
        body.sphere_centers.push(to32(&c.coords));
        body.sphere_radii.push(sp.radius as f32);
    }
    let c = pose.transform_point(&Point3::from(m.scalp_center));
    body.scalp_center = to32(&c.coords);
    body.scalp_radii = to32(&m.scalp_radii);
    let q = pose.iso.rotation;
    body.scalp_rotation = [q.i as f32, q.j as f32, q.k as f32, q.w as f32];
    body.pose_rotation = body.scalp_rotation;
    body.pose_translation = to32(&pose.iso.translation.vector);
    body.capsule_ends.clear();
    body.capsule_radii.clear();
    body.meshes.clear();
    for c in &m.colliders {
        match c {
            crate::model::body::Collider::Capsule { a, b, radius } => {
                let end = |p: &Vector3<f64>| to32(&pose.transform_point(&Point3::from(*p)).coords);
                body.capsule_ends.push([end(a), end(b)]);
                body.capsule_radii.push(*radius as f32);
            }
            crate::model::body::Collider::Mesh(mc) => body.meshes.push(mc.mesh.clone()),
        }
    }
}

/// Appends a uniform Catmull-Rom spline through `p` with `sub` points per span (the control
/// points themselves included, the last one once).
pub fn catmull_rom(p: &[nalgebra::Vector3<f64>], sub: usize, out: &mut Vec<[f32; 3]>) {
    let n = p.len();
    let to32 = |v: nalgebra::Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
    if n < 3 || sub <= 1 {
        out.extend(p.iter().map(|v| to32(*v)));
        return;
    }
    // The powers of t for each point of a span, the same for every span (computed as below,
    // so the same values): no division per point.
    const MAX_SUB: usize = 16;
    let mut powers = [(0.0f64, 0.0f64, 0.0f64); MAX_SUB];
    let tabled = sub <= MAX_SUB;
    if tabled {
        for (j, w) in powers[..sub].iter_mut().enumerate() {
            let t = j as f64 / sub as f64;
            *w = (t, t * t, t * t * t);
        }
    }
    for i in 0..n - 1 {
        let p0 = if i == 0 { p[0] * 2.0 - p[1] } else { p[i - 1] };
        let (p1, p2) = (p[i], p[i + 1]);
        let p3 = if i + 2 < n {
            p[i + 2]
        } else {
            p[n - 1] * 2.0 - p[n - 2]
        };
        // The span's polynomial coefficients, computed once per span (the same expressions,
        // so the same values, as written inline in the sum below).
        let (c0, c1) = (p1 * 2.0, p2 - p0);
        let c2 = p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3;
        let c3 = p1 * 3.0 - p0 - p2 * 3.0 + p3;
        for j in 0..sub {
            let (t, t2, t3) = match powers.get(j) {
                Some(&w) if tabled => w,
                _ => {
                    let t = j as f64 / sub as f64;
                    (t, t * t, t * t * t)
                }
            };
            let v = (c0 + c1 * t + c2 * t2 + c3 * t3) * 0.5;
            out.push(to32(v));
        }
    }
    out.push(to32(p[n - 1]));
}

/// Steps one displayed frame: `steps_per_frame` steps, with the frame's events in order, its
/// counters (those of the last step, except contact counts and stage times, summed) and the
/// solver's own stats aggregated as each says. Returns the wall time per step in ms.
pub fn step_frame(solver: &mut dyn Solver, report: &mut StepReport, frame: &mut Frame) -> f64 {
    let spf = solver.steps_per_frame().max(1);
    let t0 = Instant::now();
    frame.events.clear();
    frame.solver_stats.clear();
    let (mut tested, mut contact, mut body) = (0u32, 0u32, 0u32);
    let mut times = StageTimes::default();
    for k in 0..spf {
        solver.step(report);
        frame.events.append(&mut report.events);
        tested = tested.saturating_add(report.counters.pairs_tested);
        contact = contact.saturating_add(report.counters.pairs_in_contact);
        body = body.saturating_add(report.counters.body_contacts);
        times.add(&report.counters.times);
        aggregate_stats(&mut frame.solver_stats, &report.stats, k == 0);
    }
    // Reuse the frame's per-level vector rather than cloning one.
    let c = &report.counters;
    let f = &mut frame.counters;
    f.active_per_level.clear();
    f.active_per_level.extend_from_slice(&c.active_per_level);
    f.segments = c.segments;
    f.kinetic_energy = c.kinetic_energy;
    f.pairs_tested = tested;
    f.pairs_in_contact = contact;
    f.body_contacts = body;
    f.times = times;
    frame.splits = frame
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Split)
        .count() as u32;
    frame.merges = frame
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Merge)
        .count() as u32;
    t0.elapsed().as_secs_f64() * 1e3 / spf as f64
}

/// Folds one step's solver stats into the frame's.
fn aggregate_stats(into: &mut Vec<crate::report::Stat>, step: &[crate::report::Stat], first: bool) {
    use crate::report::Aggregate;
    for s in step {
        match into
            .iter_mut()
            .find(|t| t.name == s.name && t.group == s.group)
        {
            Some(t) if !first => {
                t.value = match s.aggregate {
                    Aggregate::Last => s.value,
                    Aggregate::Sum => t.value + s.value,
                    Aggregate::Max => t.value.max(s.value),
                }
            }
            Some(t) => *t = *s,
            None => into.push(*s),
        }
    }
}

/// Writes the frame's whole stats list ([`Frame::stats`]) from its counters, the solver's own
/// stats, the step time, the dropped-frame count and the solver's tunables in force (each at
/// `/params/<name>`, from its table): the one list the logger plots and the bench reads.
pub fn fill_stats(
    frame: &mut Frame,
    tunables: &[crate::solver::tunable::Tunable],
    tuning: &crate::solver::tunable::Tuning,
) {
    use crate::report::names as n;
    use crate::report::{Aggregate, Stat, StatGroup};
    let c = &frame.counters;
    let st = &mut frame.stats;
    st.clear();
    let mut push =
        |name: &'static str, value: f64| st.push(Stat::new(name, value, Aggregate::Last));
    for l in 0..(frame.levels as usize).min(n::ACTIVE_LEVELS.len()) {
        let v = c.active_per_level.get(l).copied().unwrap_or(0);
        push(n::ACTIVE_LEVELS[l], v as f64);
    }
    push(n::SPLITS, frame.splits as f64);
    push(n::MERGES, frame.merges as f64);
    push(n::PAIRS_TESTED, c.pairs_tested as f64);
    push(n::PAIRS_IN_CONTACT, c.pairs_in_contact as f64);
    push(n::BODY_CONTACTS, c.body_contacts as f64);
    push(n::KINETIC_ENERGY, c.kinetic_energy);
    for s in &frame.solver_stats {
        // A solver stat of a common name replaces the common value.
        match st
            .iter_mut()
            .find(|t| t.name == s.name && t.group == s.group)
        {
            Some(t) => t.value = s.value,
            None => st.push(*s),
        }
    }
    let mut push =
        |name: &'static str, value: f64| st.push(Stat::new(name, value, Aggregate::Last));
    push(n::STEP_MS, frame.step_ms);
    push(n::DROPPED_FRAMES, frame.dropped_frames as f64);
    push(n::REALTIME_FACTOR, frame.realtime_factor);
    for t in tunables {
        st.push(Stat {
            name: t.name,
            group: StatGroup::Params,
            value: t.value(tuning),
            aggregate: Aggregate::Last,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn catmull_rom_is_the_textbook_polynomial_bit_for_bit() {
        // The coefficients are hoisted out of the per-point loop; every point must still be
        // ½(2p1 + (p2 − p0)t + (2p0 − 5p1 + 4p2 − p3)t² + (3p1 − p0 − 3p2 + p3)t³) exactly.
        let p: Vec<Vector3<f64>> = (0..7)
            .map(|i| {
                let x = i as f64;
                Vector3::new(0.31 * x, (1.7 * x).sin() * 0.2, (0.9 * x).cos() * 0.05)
            })
            .collect();
        // A span's powers of t come from a table up to 16 points per span, beyond from the
        // division itself: both paths.
        for sub in [5, 23] {
            let mut out = Vec::new();
            catmull_rom(&p, sub, &mut out);
            let n = p.len();
            for i in 0..n - 1 {
                let p0 = if i == 0 { p[0] * 2.0 - p[1] } else { p[i - 1] };
                let (p1, p2) = (p[i], p[i + 1]);
                let p3 = if i + 2 < n {
                    p[i + 2]
                } else {
                    p[n - 1] * 2.0 - p[n - 2]
                };
                for j in 0..sub {
                    let t = j as f64 / sub as f64;
                    let (t2, t3) = (t * t, t * t * t);
                    let v = (p1 * 2.0
                        + (p2 - p0) * t
                        + (p0 * 2.0 - p1 * 5.0 + p2 * 4.0 - p3) * t2
                        + (p1 * 3.0 - p0 - p2 * 3.0 + p3) * t3)
                        * 0.5;
                    assert_eq!(out[i * sub + j], [v.x as f32, v.y as f32, v.z as f32]);
                }
            }
        }
    }

    #[test]
    fn catmull_rom_interpolates_its_control_points() {
        let p: Vec<Vector3<f64>> = (0..5)
            .map(|i| Vector3::new(i as f64, (i as f64).sin(), 0.0))
            .collect();
        let mut out = Vec::new();
        catmull_rom(&p, 4, &mut out);
        assert_eq!(out.len(), 4 * 4 + 1);
        for (i, q) in p.iter().enumerate() {
            let o = out[i * 4];
            assert!((o[0] as f64 - q.x).abs() < 1e-6 && (o[1] as f64 - q.y).abs() < 1e-6);
        }
        // Between control points it is smooth, not the chord: the midpoint bulges.
        let mid = out[2];
        let chord = (p[0] + p[1]) * 0.5;
        assert!((mid[1] as f64 - chord.y).abs() > 1e-3);
    }
}
