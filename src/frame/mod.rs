//! The display snapshot: everything the logger needs to draw one frame, as plain owned data.
//!
//! A `Frame` crosses from the simulation thread to the logging thread through a channel. Its
//! buffers are cleared and refilled, never reallocated once warm, and the frames themselves are
//! recycled through a return channel.

use crate::report::{AdaptEvent, Counters, Stat};

/// Active nodes of the AWT (paper Fig. 4: spheres).
#[derive(Debug, Clone, Default)]
pub struct NodeBuf {
    /// Centres, m.
    pub positions: Vec<[f32; 3]>,
    /// Radii, m.
    pub radii: Vec<f32>,
    /// Level of detail, 0 = coarsest; the annotation class id.
    pub levels: Vec<u16>,
}

/// Active segments (paper Fig. 4: cylinders), parent → child, with the child's radius and level.
#[derive(Debug, Clone, Default)]
pub struct SegmentBuf {
    /// Parent ends, m.
    pub starts: Vec<[f32; 3]>,
    /// Child ends, m.
    pub ends: Vec<[f32; 3]>,
    /// The child's radius, m.
    pub radii: Vec<f32>,
    /// The child's level.
    pub levels: Vec<u16>,
}

/// Hair strands as polylines, already smoothed: strand `s` is
/// `points[offsets[s] as usize .. offsets[s + 1] as usize]`.
#[derive(Debug, Clone, Default)]
pub struct StrandBuf {
    /// Every strand's points, strand after strand.
    pub points: Vec<[f32; 3]>,
    /// `strands + 1` entries, starting with 0.
    pub offsets: Vec<u32>,
}

impl StrandBuf {
    /// Empties the buffer, keeping its capacity.
    pub fn clear(&mut self) {
        self.points.clear();
        self.offsets.clear();
    }

    /// Number of strands.
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// No strand.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The points of strand `s`.
    pub fn strand(&self, s: usize) -> &[[f32; 3]] {
        &self.points[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }
}

/// Head and body as posed this frame.
#[derive(Debug, Clone, Default)]
pub struct BodyBuf {
    /// Collision sphere centres, m.
    pub sphere_centers: Vec<[f32; 3]>,
    /// Collision sphere radii, m.
    pub sphere_radii: Vec<f32>,
    /// Scalp ellipsoid centre, m.
    pub scalp_center: [f32; 3],
    /// Scalp ellipsoid semi-axes, m.
    pub scalp_radii: [f32; 3],
    /// Scalp orientation as a quaternion (x, y, z, w).
    pub scalp_rotation: [f32; 4],
    /// Capsule bodies: the two ends of each axis, posed, m.
    pub capsule_ends: Vec<[[f32; 3]; 2]>,
    /// Capsule radii, m.
    pub capsule_radii: Vec<f32>,
    /// Mesh bodies in the rest frame (shared, not copied per frame); `pose_*` places them.
    pub meshes: Vec<std::sync::Arc<crate::style::obj::TriangleMesh>>,
    /// The body's pose this frame: translation, m.
    pub pose_translation: [f32; 3],
    /// The body's pose this frame: rotation as a quaternion (x, y, z, w).
    pub pose_rotation: [f32; 4],
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
    /// What the points are.
    pub kind: PrimitiveKind,
    /// Points, strip points, or triangle corners.
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
    /// The solver's nodes (AWT: the active nodes).
    pub nodes: NodeBuf,
    /// The solver's segments.
    pub segments: SegmentBuf,
    /// The drawn strands, smoothed.
    pub strands: StrandBuf,
    /// Head and body as posed.
    pub body: BodyBuf,
    /// Every split and merge of the frame's steps, in order.
    pub events: Vec<AdaptEvent>,
    /// Counters of the frame's last step, except `pairs_*`/`body_contacts` which are summed.
    pub counters: Counters,
    /// Wall-clock milliseconds spent simulating the frame, per step.
    pub step_ms: f64,
    /// Splits and merges in this frame.
    pub splits: u32,
    /// Merges in this frame.
    pub merges: u32,
    /// Frames dropped so far because the logger fell behind (live only).
    pub dropped_frames: u64,
    /// Simulated over wall seconds over the last second of frames (`/stats/realtime_factor`;
    /// see [`crate::report::tempo`]). Whoever calls [`crate::pipeline::fill_stats`] measures it.
    pub realtime_factor: f64,
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
    pub stats: Vec<Stat>,
    /// The inspected node (`run --inspect`): its path under `/inspect` (`tree/level/index`)
    /// and its numbers by name; `None` when no node is inspected.
    pub inspect: Option<(String, Vec<(&'static str, f64)>)>,
    /// The solver's own stats of this frame, aggregated over its steps (part of `stats`).
    pub solver_stats: Vec<Stat>,
    /// Every strand of the model, smoothed as for display: the renderer's input (empty when
    /// rendering is off).
    pub render_strands: StrandBuf,
    /// The rendered hair of this frame, if it was rendered (live runs skip frames when the
    /// renderer falls behind).
    pub image: Option<EncodedImage>,
}

/// A rendered frame, encoded for the recording.
#[derive(Debug, Clone, Default)]
pub struct EncodedImage {
    /// JPEG bytes.
    pub jpeg: Vec<u8>,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// The frame the image shows, `(index, sim_time)`, when it is not the frame carrying it
    /// (live, an image comes a frame or more after its own frame); `None`: this frame.
    pub shows: Option<(u64, f64)>,
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

    /// The value of the measure `name` this frame (`/stats/<name>` in a recording), if present.
    pub fn stat(&self, name: &str) -> Option<f64> {
        self.stats
            .iter()
            .find(|s| s.group == crate::report::StatGroup::Stats && s.name == name)
            .map(|s| s.value)
    }
}
