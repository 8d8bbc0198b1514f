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
}
