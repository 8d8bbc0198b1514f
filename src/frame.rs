//! The display snapshot: everything the logger needs to draw one frame, as plain owned data.
//!
//! A `Frame` crosses from the simulation thread to the logging thread through a channel. Its
//! buffers are cleared and refilled, never reallocated once warm, and the frames themselves are
//! recycled through a return channel.

use crate::sim::report::{AdaptEvent, Counters};

/// Active nodes of the AWT (paper Fig. 4: spheres).
#[derive(Debug, Clone, Default)]
pub struct NodeBuf {
    pub positions: Vec<[f32; 3]>,
    pub radii: Vec<f32>,
    /// Level of detail, 0 = coarsest; the annotation class id.
    pub levels: Vec<u16>,
}

/// Active segments (paper Fig. 4: cylinders), parent → child, with the child's radius and level.
#[derive(Debug, Clone, Default)]
pub struct SegmentBuf {
    pub starts: Vec<[f32; 3]>,
    pub ends: Vec<[f32; 3]>,
    pub radii: Vec<f32>,
    pub levels: Vec<u16>,
}

/// Hair strands as polylines, already smoothed: strand `s` is
/// `points[offsets[s] as usize .. offsets[s + 1] as usize]`.
#[derive(Debug, Clone, Default)]
pub struct StrandBuf {
    pub points: Vec<[f32; 3]>,
    /// `strands + 1` entries, starting with 0.
    pub offsets: Vec<u32>,
}

impl StrandBuf {
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn strand(&self, s: usize) -> &[[f32; 3]] {
        &self.points[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }
}

/// Head and body as posed this frame.
#[derive(Debug, Clone, Default)]
pub struct BodyBuf {
    pub sphere_centers: Vec<[f32; 3]>,
    pub sphere_radii: Vec<f32>,
    pub scalp_center: [f32; 3],
    pub scalp_radii: [f32; 3],
    /// Scalp orientation as a quaternion (x, y, z, w).
    pub scalp_rotation: [f32; 4],
}

/// What an extra primitive set holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PrimitiveKind {
    /// Points (drawn as small spheres of `radius_ui`).
    Points,
    /// Line strips: strip `s` is `points[offsets[s]..offsets[s + 1]]`.
    LineStrips,
    /// Triangles: three consecutive points each (drawn translucent).
    Triangles,
}

/// A named set of primitives that a solver adds beside its nodes and segments (a layered
/// wisp's envelope, guide strands' static links and triangle strips, …). The logger draws it at
/// `path` without knowing which solver made it.
#[derive(Debug, Clone)]
pub struct PrimitiveSet {
    /// Entity path, `/hair/<solver>/<name>` (an interface: see README).
    pub path: &'static str,
    pub kind: PrimitiveKind,
    pub points: Vec<[f32; 3]>,
    /// Line strips only: `strips + 1` entries starting with 0.
    pub offsets: Vec<u32>,
    /// One RGBA colour per primitive (point, strip or triangle); empty: all `color`.
    pub colors: Vec<[u8; 4]>,
    /// The colour of every primitive when `colors` is empty.
    pub color: [u8; 4],
    /// Point radius or line width, in UI points (independent of zoom).
    pub radius_ui: f32,
}

impl PrimitiveSet {
    /// Empties the set, keeping its buffers.
    pub fn clear(&mut self) {
        self.points.clear();
        self.offsets.clear();
        self.colors.clear();
    }

    /// Number of primitives: points, strips or triangles.
    pub fn len(&self) -> usize {
        match self.kind {
            PrimitiveKind::Points => self.points.len(),
            PrimitiveKind::LineStrips => self.offsets.len().saturating_sub(1),
            PrimitiveKind::Triangles => self.points.len() / 3,
        }
    }

    /// No primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Appends one line strip (line strips only).
    pub fn push_strip(&mut self, points: impl IntoIterator<Item = [f32; 3]>) {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        self.points.extend(points);
        self.offsets.push(self.points.len() as u32);
    }

    /// Line strip `s`.
    pub fn strip(&self, s: usize) -> &[[f32; 3]] {
        &self.points[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }
}

/// One displayed frame.
#[derive(Debug, Clone, Default)]
pub struct Frame {
    /// Frame number, from 0 (the `frame` timeline).
    pub index: u64,
    /// Simulated time at the end of the frame, s (the `sim_time` timeline).
    pub sim_time: f64,
    pub nodes: NodeBuf,
    pub segments: SegmentBuf,
    pub strands: StrandBuf,
    pub body: BodyBuf,
    /// Every split and merge of the frame's steps, in order.
    pub events: Vec<AdaptEvent>,
    /// Counters of the frame's last step, except `pairs_*`/`body_contacts` which are summed.
    pub counters: Counters,
    /// Wall-clock milliseconds spent simulating the frame, per step.
    pub step_ms: f64,
    /// Splits and merges in this frame.
    pub splits: u32,
    pub merges: u32,
    /// Frames dropped so far because the logger fell behind (live only).
    pub dropped_frames: u64,
    /// Parameters in force.
    pub split_threshold: f64,
    pub merge_velocity: f64,
    /// Messages for the text log (parameter changes, reloads, warnings), in order.
    pub messages: Vec<String>,
    /// Number of levels of detail of the model (for the annotation context).
    pub levels: u16,
    /// The solver's entity path segment: nodes go to `/hair/<solver>/nodes`.
    pub solver: &'static str,
    /// Extra primitive sets the solver drew (see [`Frame::primitives`]).
    pub extras: Vec<PrimitiveSet>,
    /// Every stat of the frame as (entity path, value): the common counters, the solver's own
    /// stats, and the pipeline's (step time, dropped frames, parameters). The logger, the bench
    /// and the JSON all read this list.
    pub stats: Vec<crate::sim::report::Stat>,
}

impl Frame {
    /// The extra primitive set at `path`, created empty on first use (its buffers are kept
    /// from frame to frame, so drawing into it allocates nothing once warm). Sets are emptied
    /// by [`Frame::clear_primitives`] before the solver draws.
    pub fn primitives(&mut self, path: &'static str, kind: PrimitiveKind) -> &mut PrimitiveSet {
        let i = match self.extras.iter().position(|e| e.path == path) {
            Some(i) => i,
            None => {
                self.extras.push(PrimitiveSet {
                    path,
                    kind,
                    points: Vec::new(),
                    offsets: Vec::new(),
                    colors: Vec::new(),
                    color: [255, 255, 255, 255],
                    radius_ui: 1.0,
                });
                self.extras.len() - 1
            }
        };
        let set = &mut self.extras[i];
        set.kind = kind;
        set
    }

    /// Empties nodes, segments and every extra set, keeping their buffers.
    pub fn clear_primitives(&mut self) {
        self.nodes.positions.clear();
        self.nodes.radii.clear();
        self.nodes.levels.clear();
        self.segments.starts.clear();
        self.segments.ends.clear();
        self.segments.radii.clear();
        self.segments.levels.clear();
        for e in &mut self.extras {
            e.clear();
        }
    }

    /// The value of stat `path` this frame, if present.
    pub fn stat(&self, path: &str) -> Option<f64> {
        self.stats.iter().find(|s| s.path == path).map(|s| s.value)
    }
}

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

    pub fn strand_count(&self) -> usize {
        self.strands.len()
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
            out.push(to32(v));
        }
    }
    out.push(to32(p[n - 1]));
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

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
