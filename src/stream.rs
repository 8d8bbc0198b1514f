//! The Rerun side: turns [`Frame`]s into Rerun archetypes. This is the only module that talks to
//! Rerun, and it does no physics.
//!
//! Entity paths are part of the interface (the blueprint, the tests and anyone reading a `.rrd`
//! rely on them):
//!
//! | path | archetype |
//! |---|---|
//! | `/hair/awt/nodes` | `Points3D`: active nodes as spheres of their radius, class id = level |
//! | `/hair/awt/segments` | `Capsules3D`: active segments with the child's radius, class id = child level |
//! | `/hair/strands` | `LineStrips3D`: the rendered strands |
//! | `/body/spheres` | `Ellipsoids3D`: collision spheres, wireframe |
//! | `/head/scalp` | `Ellipsoids3D`: the scalp ellipsoid, rotated |
//! | `/events/split`, `/events/merge` | `TextLog` per event + `Points3D` markers in the frame of the event |
//! | `/stats/...`, `/params/...` | `Scalars` |
//! | `/log` | `TextLog`: free-text messages |
//!
//! Every entity holds all its instances (one row per frame), never one entity per node: the
//! viewer slows down with thousands of entities.

use std::fmt::Write as _;

use anyhow::Context as _;
use rerun::components::{FillMode, Name, Radius, TextLogLevel};
use rerun::datatypes::{Rgba32, Uuid};
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, RecordingId};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, EyeControls3D, PanelBlueprint, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint,
};
use rerun::external::re_sdk_types::blueprint::components::{
    AutoLayout, AutoViews, ColumnShare, ContainerKind, Eye3DKind, IncludedContent, PanelState,
    QueryExpression, RootContainer, RowShare, ViewClass,
};
use rerun::{
    AnnotationContext, Capsules3D, Color, Ellipsoids3D, EntityPath, LineStrips3D, Points3D,
    RecordingStream, RecordingStreamBuilder, Scalars, SeriesLines, TextLog, ViewCoordinates,
};

use crate::frame::Frame;
use crate::sim::report::{AdaptEvent, EventKind};

/// Severity of a free-text message on `/log`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageLevel {
    Debug,
    Info,
    Warn,
    Error,
}

impl MessageLevel {
    fn rerun_level(self) -> &'static str {
        match self {
            MessageLevel::Debug => TextLogLevel::DEBUG,
            MessageLevel::Info => TextLogLevel::INFO,
            MessageLevel::Warn => TextLogLevel::WARN,
            MessageLevel::Error => TextLogLevel::ERROR,
        }
    }
}

/// Entity paths, as strings (the interface) — see the module docs.
pub mod paths {
    pub const NODES: &str = "/hair/awt/nodes";
    pub const SEGMENTS: &str = "/hair/awt/segments";
    pub const STRANDS: &str = "/hair/strands";
    pub const BODY_SPHERES: &str = "/body/spheres";
    pub const SCALP: &str = "/head/scalp";
    pub const SPLITS: &str = "/events/split";
    pub const MERGES: &str = "/events/merge";
    pub const LOG: &str = "/log";
    /// Per-level counts live below this: `/stats/active_nodes/level_N`.
    pub const ACTIVE_NODES: &str = "/stats/active_nodes";
    pub const STAT_SPLITS: &str = "/stats/splits";
    pub const STAT_MERGES: &str = "/stats/merges";
    pub const PAIRS_TESTED: &str = "/stats/pairs_tested";
    pub const PAIRS_IN_CONTACT: &str = "/stats/pairs_in_contact";
    pub const BODY_CONTACTS: &str = "/stats/body_contacts";
    pub const KINETIC_ENERGY: &str = "/stats/kinetic_energy";
    pub const STEP_MS: &str = "/stats/step_ms";
    pub const DROPPED_FRAMES: &str = "/stats/dropped_frames";
    pub const SPLIT_THRESHOLD: &str = "/params/split_threshold";
    pub const MERGE_VELOCITY: &str = "/params/merge_velocity";

    /// `/stats/active_nodes/level_N`.
    pub fn active_nodes_level(level: usize) -> String {
        format!("{ACTIVE_NODES}/level_{level}")
    }
}

/// Timeline names.
pub const TIMELINE_FRAME: &str = "frame";
pub const TIMELINE_SIM_TIME: &str = "sim_time";

/// Level colours, from coarse (warm, dark) to fine (cool, light). A model with `L` levels takes
/// `L` entries spread over the whole ramp, so 2 levels are dark red and pale blue, not dark red
/// and orange.
const LEVEL_RAMP: [(u8, u8, u8); 6] = [
    (170, 40, 30),   // dark red
    (225, 110, 30),  // orange
    (230, 195, 60),  // gold
    (120, 200, 120), // light green
    (95, 180, 240),  // sky blue
    (205, 215, 255), // pale periwinkle
];

/// The colour of `level` in a model with `levels` levels.
pub fn level_color(level: u16, levels: u16) -> Rgba32 {
    let last = LEVEL_RAMP.len() - 1;
    let idx = if levels <= 1 {
        0
    } else {
        let l = level.min(levels - 1) as usize;
        // Round to the nearest ramp entry; exact ends for the coarsest and finest level.
        (l * last + (levels as usize - 1) / 2) / (levels as usize - 1)
    };
    let (r, g, b) = LEVEL_RAMP[idx.min(last)];
    Rgba32::from_rgb(r, g, b)
}

const HAIR_COLOR: (u8, u8, u8) = (255, 205, 120);
/// Opacity of the active nodes and segments (0–255).
const NODE_ALPHA: u8 = 255;
/// Segment opacity of the coarsest and the finest level; levels in between are interpolated.
/// Coarse capsules are large and overlap many times over (a 7 cm capsule per cross-section of
/// every top-level wisp), so they need to be the most transparent.
const SEGMENT_ALPHA_COARSE: f32 = 22.0;
const SEGMENT_ALPHA_FINE: f32 = 30.0;
/// Nodes are drawn as spheres of this fraction of their radius: at full size the coarse nodes
/// (up to 15 cm) cover the strands and all finer levels; the segment capsules around them show
/// the full radius.
const NODE_DRAW_SCALE: f32 = 0.25;
const SPLIT_COLOR: (u8, u8, u8) = (255, 90, 20);
const GUIDE_INSERT_COLOR: (u8, u8, u8) = (120, 255, 120);
const GUIDE_REMOVE_COLOR: (u8, u8, u8) = (255, 120, 255);

/// The marker colour of an event kind.
fn event_color(kind: EventKind) -> (u8, u8, u8) {
    match kind {
        EventKind::Split => SPLIT_COLOR,
        EventKind::Merge => MERGE_COLOR,
        EventKind::GuideInsert => GUIDE_INSERT_COLOR,
        EventKind::GuideRemove => GUIDE_REMOVE_COLOR,
    }
}
const MERGE_COLOR: (u8, u8, u8) = (40, 200, 230);
const BODY_COLOR: (u8, u8, u8, u8) = (170, 170, 180, 110);
const SCALP_COLOR: (u8, u8, u8) = (225, 190, 160);
/// Strand width on screen: thin and independent of zoom, so 10,000 strands stay readable.
const STRAND_RADIUS_UI: f32 = 1.0;
/// Event markers: big enough to find in a frame.
const EVENT_RADIUS_UI: f32 = 6.0;

/// Camera offset from the head centre, m: in front (+z), to the side (+x), a bit above; about
/// 1.1 m away, which with the viewer's field of view frames about 1.2 m: the head and hair hanging
/// 0.6 m below it (checked on a rendered screenshot; at 1.4 m a head was a small blob).
const EYE_OFFSET: [f32; 3] = [0.65, 0.25, 0.85];
/// Look below the head centre: long hair hangs down.
const LOOK_DROP: f32 = 0.25;

/// Prebuilt entity paths, so the per-frame loop does not parse strings.
struct Paths {
    nodes: EntityPath,
    segments: EntityPath,
    strands: EntityPath,
    body_spheres: EntityPath,
    scalp: EntityPath,
    /// `/events/<kind>`, in [`EventKind::ALL`] order.
    events: [EntityPath; 4],
    log: EntityPath,
    active_levels: Vec<EntityPath>,
    stat_splits: EntityPath,
    stat_merges: EntityPath,
    pairs_tested: EntityPath,
    pairs_in_contact: EntityPath,
    body_contacts: EntityPath,
    kinetic_energy: EntityPath,
    step_ms: EntityPath,
    dropped_frames: EntityPath,
    split_threshold: EntityPath,
    merge_velocity: EntityPath,
}

impl Paths {
    fn new(levels: u16) -> Paths {
        Paths {
            nodes: paths::NODES.into(),
            segments: paths::SEGMENTS.into(),
            strands: paths::STRANDS.into(),
            body_spheres: paths::BODY_SPHERES.into(),
            scalp: paths::SCALP.into(),
            events: EventKind::ALL.map(|k| format!("/events/{}", k.name()).into()),
            log: paths::LOG.into(),
            active_levels: (0..levels as usize)
                .map(|l| paths::active_nodes_level(l).into())
                .collect(),
            stat_splits: paths::STAT_SPLITS.into(),
            stat_merges: paths::STAT_MERGES.into(),
            pairs_tested: paths::PAIRS_TESTED.into(),
            pairs_in_contact: paths::PAIRS_IN_CONTACT.into(),
            body_contacts: paths::BODY_CONTACTS.into(),
            kinetic_energy: paths::KINETIC_ENERGY.into(),
            step_ms: paths::STEP_MS.into(),
            dropped_frames: paths::DROPPED_FRAMES.into(),
            split_threshold: paths::SPLIT_THRESHOLD.into(),
            merge_velocity: paths::MERGE_VELOCITY.into(),
        }
    }
}

/// Logs frames to one recording stream. Lives on the logging thread: Rerun's time cursor is
/// per thread, so `log_frame` and `log_message` must be called from the same thread.
pub struct Logger {
    rec: RecordingStream,
    paths: Paths,
    /// Strand polylines, reused: the inner Vecs keep their capacity between frames.
    strands: Vec<rerun::components::LineStrip3D>,
    event_positions: Vec<[f32; 3]>,
    event_labels: Vec<String>,
    text: String,
    /// Whether the last frame logged markers of that kind (then an eventless frame clears them).
    events_shown: [bool; 4],
    /// Per-instance translucent level colours, reused.
    node_colors: Vec<Color>,
    seg_colors: Vec<Color>,
}

impl Logger {
    /// Logs the static parts once: `ViewCoordinates::RIGHT_HAND_Y_UP` on `/`, the annotation
    /// context with one class per level ("level 0", …), and sends the default blueprint with the
    /// 3D camera about 1.1 m in front and to the side of `head_center` (world, m).
    pub fn new(
        rec: RecordingStream,
        levels: u16,
        style_name: &str,
        head_center: [f32; 3],
    ) -> anyhow::Result<Logger> {
        rec.log_static("/", &ViewCoordinates::RIGHT_HAND_Y_UP())
            .context("logging the view coordinates")?;
        let classes: Vec<(u16, String, Rgba32)> = (0..levels.max(1))
            .map(|l| (l, format!("level {l}"), level_color(l, levels)))
            .collect();
        rec.log_static(
            "/",
            &AnnotationContext::new(
                classes
                    .iter()
                    .map(|(id, label, color)| (*id, label.as_str(), *color)),
            ),
        )
        .context("logging the annotation context")?;
        send_blueprint(&rec, style_name, head_center)?;
        log_series_styles(&rec, levels)?;

        let mut logger = Logger {
            rec,
            paths: Paths::new(levels),
            strands: Vec::new(),
            event_positions: Vec::new(),
            event_labels: Vec::new(),
            text: String::new(),
            events_shown: [false; 4],
            node_colors: Vec::new(),
            seg_colors: Vec::new(),
        };
        logger.set_time(0, 0.0);
        logger.log_message(
            MessageLevel::Info,
            &format!("style {style_name}: {levels} levels of detail"),
        )?;
        Ok(logger)
    }

    pub fn recording(&self) -> &RecordingStream {
        &self.rec
    }

    fn set_time(&self, index: u64, sim_time: f64) {
        // Frame counts never come near i64::MAX; saturate rather than wrap if they ever do.
        self.rec
            .set_time_sequence(TIMELINE_FRAME, i64::try_from(index).unwrap_or(i64::MAX));
        self.rec.set_duration_secs(TIMELINE_SIM_TIME, sim_time);
    }

    /// Logs one frame on timelines `frame` (sequence = `frame.index`) and `sim_time` (seconds).
    pub fn log_frame(&mut self, frame: &Frame) -> anyhow::Result<()> {
        self.set_time(frame.index, frame.sim_time);
        self.log_hair(frame)?;
        self.log_body(frame)?;
        self.log_events(frame)?;
        self.log_stats(frame)?;
        for m in &frame.messages {
            self.rec
                .log(self.paths.log.clone(), &TextLog::new(m.as_str()))?;
        }
        Ok(())
    }

    fn log_hair(&mut self, frame: &Frame) -> anyhow::Result<()> {
        let n = &frame.nodes;
        // Points3D with scene-unit radii render as shaded spheres and stay cheap for thousands
        // of nodes (Ellipsoids3D would tessellate a mesh per node).
        // Translucent level colours (the class ids still label them): at their true radius the
        // coarse nodes and cylinders would otherwise hide the strands and every finer level.
        let tint = |level: u16, alpha: u8| {
            let [r, g, b, _] = level_color(level, frame.levels).to_array();
            Color::from_unmultiplied_rgba(r, g, b, alpha)
        };
        self.node_colors.clear();
        self.node_colors
            .extend(n.levels.iter().map(|&l| tint(l, NODE_ALPHA)));
        self.rec.log(
            self.paths.nodes.clone(),
            &Points3D::new(n.positions.iter().copied())
                .with_radii(
                    n.radii
                        .iter()
                        .map(|&r| Radius::new_scene_units(r * NODE_DRAW_SCALE)),
                )
                .with_class_ids(n.levels.iter().copied())
                .with_colors(self.node_colors.iter().copied()),
        )?;

        let s = &frame.segments;
        self.seg_colors.clear();
        let seg_alpha = |level: u16| {
            let t = if frame.levels <= 1 {
                0.0
            } else {
                f32::from(level.min(frame.levels - 1)) / f32::from(frame.levels - 1)
            };
            (SEGMENT_ALPHA_COARSE + t * (SEGMENT_ALPHA_FINE - SEGMENT_ALPHA_COARSE)).round() as u8
        };
        self.seg_colors
            .extend(s.levels.iter().map(|&l| tint(l, seg_alpha(l))));
        // The cylinders of paper Fig. 4 at their true radius as translucent solids: Capsules3D
        // honours alpha only in `FillMode::Solid`, and wireframes of hundreds of overlapping
        // 7 cm capsules made a dense cage over the strands (checked on rendered screenshots).
        self.rec.log(
            self.paths.segments.clone(),
            &Capsules3D::from_endpoints_and_radii(
                s.starts.iter().copied(),
                s.ends.iter().copied(),
                s.radii.iter().copied(),
            )
            .with_class_ids(s.levels.iter().copied())
            .with_colors(self.seg_colors.iter().copied())
            .with_fill_mode(FillMode::Solid),
        )?;

        // Refill the reused polylines in place; only the count of strands may grow.
        let st = &frame.strands;
        let count = st.len();
        if self.strands.len() < count {
            self.strands
                .resize_with(count, || rerun::components::LineStrip3D(Vec::new()));
        }
        for (k, strip) in self.strands.iter_mut().take(count).enumerate() {
            strip.0.clear();
            strip
                .0
                .extend(st.strand(k).iter().map(|&p| rerun::datatypes::Vec3D(p)));
        }
        // Serialize borrowed polylines: `LineStrips3D::new` would want owned ones, i.e. a clone
        // (an allocation) per strand per frame.
        let strips = <rerun::components::LineStrip3D as rerun::Loggable>::to_arrow(
            self.strands[..count].iter().map(std::borrow::Cow::Borrowed),
        )
        .context("serializing the strands")?;
        let mut arch = LineStrips3D::update_fields()
            .with_radii([Radius::new_ui_points(STRAND_RADIUS_UI)])
            .with_colors([Color::from_rgb(HAIR_COLOR.0, HAIR_COLOR.1, HAIR_COLOR.2)]);
        arch.strips = Some(rerun::SerializedComponentBatch::new(
            strips,
            LineStrips3D::descriptor_strips(),
        ));
        self.rec.log(self.paths.strands.clone(), &arch)?;
        Ok(())
    }

    fn log_body(&mut self, frame: &Frame) -> anyhow::Result<()> {
        let b = &frame.body;
        let (r, g, bl, a) = BODY_COLOR;
        self.rec.log(
            self.paths.body_spheres.clone(),
            &Ellipsoids3D::from_centers_and_radii(
                b.sphere_centers.iter().copied(),
                b.sphere_radii.iter().copied(),
            )
            .with_colors([Color::from_unmultiplied_rgba(r, g, bl, a)])
            .with_fill_mode(FillMode::MajorWireframe),
        )?;
        let (r, g, bl) = SCALP_COLOR;
        self.rec.log(
            self.paths.scalp.clone(),
            &Ellipsoids3D::from_centers_and_half_sizes([b.scalp_center], [b.scalp_radii])
                .with_quaternions([rerun::Quaternion::from_xyzw(b.scalp_rotation)])
                .with_colors([Color::from_rgb(r, g, bl)])
                .with_fill_mode(FillMode::Solid),
        )?;
        Ok(())
    }

    fn log_events(&mut self, frame: &Frame) -> anyhow::Result<()> {
        for (k, kind) in EventKind::ALL.into_iter().enumerate() {
            self.event_positions.clear();
            self.event_labels.clear();
            let path = self.paths.events[k].clone();
            let color = event_color(kind);
            for e in frame.events.iter().filter(|e| e.kind == kind) {
                self.text.clear();
                describe_event(&mut self.text, e);
                self.rec.log(
                    path.clone(),
                    &TextLog::new(self.text.as_str())
                        .with_level(TextLogLevel::INFO)
                        .with_color(Color::from_rgb(color.0, color.1, color.2)),
                )?;
                self.event_positions.push(e.position.map(|c| c as f32));
                self.event_labels
                    .push(format!("L{} gc{} i{}", e.level, e.gc, e.cross_section));
            }
            let shown = &mut self.events_shown[k];
            if !self.event_positions.is_empty() {
                self.rec.log(
                    path,
                    &Points3D::new(self.event_positions.iter().copied())
                        .with_radii([Radius::new_ui_points(EVENT_RADIUS_UI)])
                        .with_colors([Color::from_rgb(color.0, color.1, color.2)])
                        .with_labels(self.event_labels.iter().map(String::as_str))
                        // Labels of dozens of events would bury the hair; they show on hover.
                        .with_show_labels(false),
                )?;
                *shown = true;
            } else if *shown {
                // Empty the Points3D fields only (a `Clear` would also hide the event's TextLog
                // in latest-at queries), once, at the first frame without events.
                self.rec.log(path, &Points3D::clear_fields())?;
                *shown = false;
            }
        }
        Ok(())
    }

    fn log_stats(&mut self, frame: &Frame) -> anyhow::Result<()> {
        let c = &frame.counters;
        for (l, p) in self.paths.active_levels.iter().enumerate() {
            let v = c.active_per_level.get(l).copied().unwrap_or(0);
            self.rec.log(p.clone(), &Scalars::single(v as f64))?;
        }
        let p = &self.paths;
        let scalars: [(&EntityPath, f64); 10] = [
            (&p.stat_splits, frame.splits as f64),
            (&p.stat_merges, frame.merges as f64),
            (&p.pairs_tested, c.pairs_tested as f64),
            (&p.pairs_in_contact, c.pairs_in_contact as f64),
            (&p.body_contacts, c.body_contacts as f64),
            (&p.kinetic_energy, c.kinetic_energy),
            (&p.step_ms, frame.step_ms),
            (&p.dropped_frames, frame.dropped_frames as f64),
            (&p.split_threshold, frame.split_threshold),
            (&p.merge_velocity, frame.merge_velocity),
        ];
        for (path, v) in scalars {
            self.rec.log(path.clone(), &Scalars::single(v))?;
        }
        Ok(())
    }

    /// Logs a free-text message (parameter change, reload, warning) at the current time as a
    /// `TextLog` on `/log`.
    pub fn log_message(&mut self, level: MessageLevel, text: &str) -> anyhow::Result<()> {
        self.rec.log(
            self.paths.log.clone(),
            &TextLog::new(text).with_level(level.rerun_level()),
        )?;
        Ok(())
    }

    /// Blocks until everything logged so far has reached the sink (file, viewer, memory).
    pub fn flush(&self) -> anyhow::Result<()> {
        self.rec
            .flush_blocking()
            .map_err(|e| anyhow::anyhow!("flushing the Rerun recording: {e}"))
    }
}

/// Fixed series colours and names, logged once (static): the active-node curves take their
/// level's colour and the split/merge curves their marker's, so plot and 3D view read alike;
/// the viewer's automatic colours would give level 0 and level 2 the same pink.
fn log_series_styles(rec: &RecordingStream, levels: u16) -> anyhow::Result<()> {
    let rgb = |(r, g, b): (u8, u8, u8)| Color::from_rgb(r, g, b);
    for l in 0..levels {
        rec.log_static(
            paths::active_nodes_level(l as usize),
            &SeriesLines::new()
                .with_colors([level_color(l, levels)])
                .with_names([format!("level {l}")]),
        )?;
    }
    let fixed: [(&str, (u8, u8, u8), &str); 10] = [
        (paths::STAT_SPLITS, SPLIT_COLOR, "splits"),
        (paths::STAT_MERGES, MERGE_COLOR, "merges"),
        (paths::PAIRS_TESTED, (150, 150, 255), "pairs tested"),
        (paths::PAIRS_IN_CONTACT, (255, 120, 200), "pairs in contact"),
        (paths::BODY_CONTACTS, (120, 230, 140), "body contacts"),
        (paths::KINETIC_ENERGY, (255, 210, 80), "kinetic energy (J)"),
        (
            paths::SPLIT_THRESHOLD,
            SPLIT_COLOR,
            "split threshold (m²/s²)",
        ),
        (paths::MERGE_VELOCITY, MERGE_COLOR, "merge velocity (m/s)"),
        (paths::STEP_MS, (200, 200, 210), "step (ms)"),
        (paths::DROPPED_FRAMES, (255, 80, 80), "dropped frames"),
    ];
    for (path, color, name) in fixed {
        rec.log_static(
            path,
            &SeriesLines::new()
                .with_colors([rgb(color)])
                .with_names([name]),
        )?;
    }
    Ok(())
}

/// One line per event: what, where in the hierarchy, and the value that triggered it.
fn describe_event(out: &mut String, e: &AdaptEvent) {
    let what = e.kind.name();
    if matches!(e.kind, EventKind::GuideInsert | EventKind::GuideRemove) {
        let _ = write!(out, "{what}: guide {} at t={:.3} s", e.gc, e.time);
        return;
    }
    let _ = write!(
        out,
        "{what} tree {} level {} gc {} cross-section {} → gcs {}..{} of level {} at t={:.3} s: ",
        e.tree,
        e.level,
        e.gc,
        e.cross_section,
        e.sub_gcs.start,
        e.sub_gcs.end,
        e.level as u32 + 1,
        e.time
    );
    let _ = match e.kind {
        EventKind::Split => write!(out, "|a|·r = {:.4} m²/s²", e.accel_radius),
        EventKind::Merge => write!(
            out,
            "max relative velocity = {:.4} m/s (|a|·r = {:.4} m²/s²)",
            e.rel_velocity, e.accel_radius
        ),
        EventKind::GuideInsert | EventKind::GuideRemove => Ok(()),
    };
}

// ---------------------------------------------------------------------------------------------
// Blueprint

/// What one view of the default layout shows.
struct ViewSpec {
    /// Rerun view class identifier ("3D", "TimeSeries", "TextLog").
    class: &'static str,
    name: String,
    contents: &'static [&'static str],
}

const SPATIAL_CONTENTS: &[&str] = &["+ /hair/**", "+ /body/**", "+ /head/**", "+ /events/**"];
/// Time series are grouped by magnitude, so that no series flattens another: node counts
/// (hundreds to thousands) with the adaptation events per frame, collision work (pairs tested
/// run to 10⁵–10⁶) apart from them, the small real-valued quantities together, and the
/// timing apart.
const NODE_CONTENTS: &[&str] = &[
    "+ /stats/active_nodes/**",
    "+ /stats/splits",
    "+ /stats/merges",
];
const COLLISION_CONTENTS: &[&str] = &[
    "+ /stats/pairs_tested",
    "+ /stats/pairs_in_contact",
    "+ /stats/body_contacts",
];
const ENERGY_CONTENTS: &[&str] = &["+ /stats/kinetic_energy", "+ /params/**"];
/// Milliseconds per step (1–10) would flatten the energy (J, ≪ 1) and the thresholds.
const TIMING_CONTENTS: &[&str] = &["+ /stats/step_ms", "+ /stats/dropped_frames"];
const LOG_CONTENTS: &[&str] = &["+ /events/**", "+ /log"];

/// The default layout, one table for both blueprint builders: the 3D view on the left (3/5);
/// on the right the four plots in a 2×2 grid (nodes and adaptation events, collisions, energy
/// and parameters, timing) above the text log.
fn layout(style_name: &str) -> (ViewSpec, [ViewSpec; 4], ViewSpec) {
    let title = if style_name.is_empty() {
        "hair".to_owned()
    } else {
        format!("hair: {style_name}")
    };
    let plot = |name: &str, contents| ViewSpec {
        class: "TimeSeries",
        name: name.to_owned(),
        contents,
    };
    (
        ViewSpec {
            class: "3D",
            name: title,
            contents: SPATIAL_CONTENTS,
        },
        [
            plot("nodes, splits, merges", NODE_CONTENTS),
            plot("collisions", COLLISION_CONTENTS),
            plot("energy, parameters", ENERGY_CONTENTS),
            plot("step time", TIMING_CONTENTS),
        ],
        ViewSpec {
            class: "TextLog",
            name: "events and log".to_owned(),
            contents: LOG_CONTENTS,
        },
    )
}

const COLUMN_SHARES: [f32; 2] = [3.0, 2.0];
/// Plot grid, text log.
const ROW_SHARES: [f32; 2] = [3.0, 1.0];
const PLOT_COLUMNS: u32 = 2;
/// Blueprint, selection and time panel at start.
const PANEL_STATES: (PanelState, PanelState, PanelState) = (
    PanelState::Collapsed,
    PanelState::Collapsed,
    PanelState::Collapsed,
);

/// The default layout through the SDK's high-level blueprint API. It cannot place the 3D camera
/// (the Rust `Spatial3DView` of 0.36 has no eye-controls setter); [`Logger::new`] sends
/// [`send_blueprint`]'s equivalent layout that does.
pub fn blueprint() -> rerun::blueprint::Blueprint {
    use rerun::blueprint::{
        Blueprint, BlueprintPanel, ContainerLike, Grid, Horizontal, SelectionPanel, Spatial3DView,
        TextLogView, TimePanel, TimeSeriesView, Vertical,
    };
    let (spatial, plots, log) = layout("");
    let plots: Vec<ContainerLike> = plots
        .into_iter()
        .map(|v| {
            assert_eq!(v.class, "TimeSeries", "layout(): plots are time series");
            TimeSeriesView::new(v.name)
                .with_origin("/")
                .with_contents(v.contents.iter().copied())
                .into()
        })
        .collect();
    let right: Vec<ContainerLike> = vec![
        Grid::new(plots).with_grid_columns(PLOT_COLUMNS).into(),
        TextLogView::new(log.name)
            .with_origin("/")
            .with_contents(log.contents.iter().copied())
            .into(),
    ];
    Blueprint::new(
        Horizontal::new([
            Spatial3DView::new(spatial.name)
                .with_origin("/")
                .with_contents(spatial.contents.iter().copied())
                .into(),
            Vertical::new(right).with_row_shares(ROW_SHARES).into(),
        ])
        .with_column_shares(COLUMN_SHARES),
    )
    .with_auto_layout(false)
    .with_auto_views(false)
    .with_blueprint_panel(BlueprintPanel::from_state(PANEL_STATES.0))
    .with_selection_panel(SelectionPanel::from_state(PANEL_STATES.1))
    .with_time_panel(TimePanel::new().with_state(PANEL_STATES.2))
}

/// A fixed id for blueprint object `k`: a well-formed (version 4, RFC 4122 variant) UUID so the
/// viewer parses it, deterministic so a recording's blueprint is reproducible and testable.
fn blueprint_uuid(k: u8) -> Uuid {
    let mut bytes = *b"wisptree\0\0\0\0\0\0\0\0";
    bytes[6] = 0x40 | (bytes[6] & 0x0f);
    bytes[8] = 0x80 | (k & 0x3f);
    bytes[15] = k;
    Uuid { bytes }
}

fn uuid_string(u: &Uuid) -> String {
    let b = &u.bytes;
    let mut s = String::with_capacity(36);
    for (i, byte) in b.iter().enumerate() {
        if matches!(i, 4 | 6 | 8 | 10) {
            s.push('-');
        }
        let _ = write!(s, "{byte:02x}");
    }
    s
}

/// Blueprint entity path of the 3D view (its camera lives at `<this>/EyeControls3D`).
pub fn spatial_view_blueprint_path() -> String {
    format!("view/{}", uuid_string(&blueprint_uuid(1)))
}

/// Sends the default layout, with the 3D camera placed about 1.1 m in front of and to the side
/// of `head_center`, looking slightly below it. Built from blueprint archetypes directly because
/// the high-level Rust API of 0.36 cannot set `EyeControls3D` on a `Spatial3DView`; the paths and
/// archetypes are the ones that API itself logs (`view/<id>`, `view/<id>/ViewContents`,
/// `container/<id>`, `viewport`), plus the view property `view/<id>/EyeControls3D`.
pub fn send_blueprint(
    rec: &RecordingStream,
    style_name: &str,
    head_center: [f32; 3],
) -> anyhow::Result<()> {
    let app_id = rec
        .store_info()
        .map(|info| info.application_id().clone())
        .unwrap_or_else(|| "wisptree".into());
    let (bp, storage) = RecordingStreamBuilder::new(app_id)
        // A fresh store per send, as the SDK does: a viewer keeps blueprints by store id.
        .recording_id(RecordingId::random())
        .blueprint()
        .memory()
        .context("creating the blueprint stream")?;
    // The viewer identifies blueprint data by this timeline.
    bp.set_time_sequence("blueprint", 0);

    let (spatial, plots, log) = layout(style_name);
    let log_view = |id: &Uuid, v: &ViewSpec| -> anyhow::Result<String> {
        let path = format!("view/{}", uuid_string(id));
        bp.log(
            format!("{path}/ViewContents"),
            &ViewContents::new(v.contents.iter().map(|q| QueryExpression::from(*q))),
        )?;
        bp.log(
            path.as_str(),
            &ViewBlueprint::new(ViewClass::from(v.class))
                .with_display_name(Name::from(v.name.as_str()))
                .with_space_origin("/"),
        )?;
        Ok(path)
    };

    let spatial_path = log_view(&blueprint_uuid(1), &spatial)?;
    let [c0, c1, c2] = head_center;
    let eye = [c0 + EYE_OFFSET[0], c1 + EYE_OFFSET[1], c2 + EYE_OFFSET[2]];
    bp.log(
        format!("{spatial_path}/EyeControls3D"),
        &EyeControls3D::new()
            .with_kind(Eye3DKind::Orbital)
            .with_position(eye)
            .with_look_target([c0, c1 - LOOK_DROP, c2])
            .with_eye_up([0.0f32, 1.0, 0.0]),
    )?;

    let mut plot_paths = Vec::with_capacity(plots.len());
    for (k, v) in plots.iter().enumerate() {
        plot_paths.push(log_view(&blueprint_uuid(2 + k as u8), v)?);
    }
    let log_path = log_view(&blueprint_uuid(9), &log)?;

    let grid = blueprint_uuid(12);
    let grid_path = format!("container/{}", uuid_string(&grid));
    bp.log(
        grid_path.as_str(),
        &ContainerBlueprint::new(ContainerKind::Grid)
            .with_contents(plot_paths.iter().map(|p| IncludedContent::from(p.as_str())))
            .with_grid_columns(PLOT_COLUMNS),
    )?;
    let right_paths = [grid_path, log_path];
    let vertical = blueprint_uuid(10);
    let vertical_path = format!("container/{}", uuid_string(&vertical));
    bp.log(
        vertical_path.as_str(),
        &ContainerBlueprint::new(ContainerKind::Vertical)
            .with_contents(
                right_paths
                    .iter()
                    .map(|p| IncludedContent::from(p.as_str())),
            )
            .with_row_shares(ROW_SHARES.map(RowShare::from)),
    )?;
    let root = blueprint_uuid(11);
    bp.log(
        format!("container/{}", uuid_string(&root)),
        &ContainerBlueprint::new(ContainerKind::Horizontal)
            .with_contents([
                IncludedContent::from(spatial_path.as_str()),
                IncludedContent::from(vertical_path.as_str()),
            ])
            .with_col_shares(COLUMN_SHARES.map(ColumnShare::from)),
    )?;
    bp.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(root))
            .with_auto_layout(AutoLayout::from(false))
            .with_auto_views(AutoViews::from(false)),
    )?;
    // The side panels start collapsed and the time panel as a bar: the hair and the plots get
    // the room; all of them open again from the viewer's top-right buttons.
    bp.log(
        "blueprint_panel",
        &PanelBlueprint::new().with_state(PANEL_STATES.0),
    )?;
    bp.log(
        "selection_panel",
        &PanelBlueprint::new().with_state(PANEL_STATES.1),
    )?;
    bp.log(
        "time_panel",
        &TimePanelBlueprint::new().with_state(PANEL_STATES.2),
    )?;
    bp.flush_blocking()
        .map_err(|e| anyhow::anyhow!("flushing the blueprint stream: {e}"))?;

    let msgs: Vec<LogMsg> = storage.take();
    let blueprint_id = msgs
        .iter()
        .find_map(|m| match m {
            LogMsg::SetStoreInfo(info) => Some(info.info.store_id.clone()),
            _ => None,
        })
        .context("the blueprint stream produced no store info")?;
    rec.send_blueprint(
        msgs,
        BlueprintActivationCommand {
            blueprint_id,
            make_active: true,
            make_default: true,
        },
    );
    Ok(())
}
