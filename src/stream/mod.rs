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
//! | `/body/capsules`, `/body/mesh` | `Capsules3D`; `Mesh3D` (static) + `Transform3D` per frame |
//! | `/head/scalp` | `Ellipsoids3D`: the scalp ellipsoid, rotated |
//! | `/events/split`, `/events/merge` | `TextLog` per event + `Points3D` markers in the frame of the event |
//! | `/stats/...`, `/params/...` | `Scalars` |
//! | `/inspect/<tree>/<level>/<index>/<name>` | `Scalars`: the inspected node's numbers |
//! | `/hair/inspected` | `Ellipsoids3D`: a ring around the inspected node |
//! | `/log` | `TextLog`: free-text messages |
//! | `/style/key_strands`, `/style/selected` | `LineStrips3D` (static) of the Style panel's key strands, the selected one with `Points3D` and `Arrows3D` below it; `Transform3D` on `/style` per frame |
//!
//! Every entity holds all its instances (one row per frame), never one entity per node: the
//! viewer slows down with thousands of entities.

mod blueprint;
mod body_shapes;
mod colors;
mod inspected;
pub mod paths;
mod runs_layout;
pub mod sink;
mod style_marks;
pub mod sweep_sink;

pub use blueprint::{
    blueprint, send_blueprint, send_blueprint_with, spatial_view_blueprint_path, BlueprintCamera,
};
pub use colors::level_color;
pub use colors::level_rgb;
use colors::*;
pub use paths::{TIMELINE_FRAME, TIMELINE_SIM_TIME};
pub use runs_layout::{
    label_run_series, log_rendered, runs_blueprint, send_runs_blueprint, RunView, RUN_ACTIVE_TOTAL,
};

use std::fmt::Write as _;

use anyhow::Context as _;
use rerun::components::{FillMode, Radius, TextLogLevel};
use rerun::datatypes::Rgba32;
use rerun::{
    AnnotationContext, Capsules3D, Color, Ellipsoids3D, EntityPath, LineStrips3D, Mesh3D, Points3D,
    RecordingStream, Scalars, SeriesLines, TextLog, ViewCoordinates,
};

use crate::frame::{Frame, PrimitiveKind};
use crate::report::{AdaptEvent, EventKind, StatGroup};

/// Severity of a free-text message on `/log`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MessageLevel {
    /// Details.
    Debug,
    /// Normal messages.
    Info,
    /// Something the user should look at.
    Warn,
    /// Something failed.
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

/// Prebuilt entity paths, so the per-frame loop does not parse strings. Every path is below
/// the logger's prefix (empty for a plain run; `/runs/<label>` for one run of several).
struct Paths {
    prefix: String,
    /// The solver's path segment the node and segment paths were made for.
    solver: &'static str,
    nodes: EntityPath,
    segments: EntityPath,
    strands: EntityPath,
    body_spheres: EntityPath,
    scalp: EntityPath,
    /// `/events/<kind>`, in [`EventKind::ALL`] order.
    events: [EntityPath; 4],
    log: EntityPath,
    /// Extra primitive sets by their path (filled on first sight; a few).
    by_name: Vec<(&'static str, EntityPath)>,
    /// Stats by group and name (filled on first sight; a few dozen).
    stats: Vec<((StatGroup, &'static str), EntityPath)>,
}

impl Paths {
    fn new(prefix: &str, solver: &'static str) -> Paths {
        let p = |s: &str| -> EntityPath { format!("{prefix}{s}").into() };
        Paths {
            prefix: prefix.to_owned(),
            solver,
            nodes: p(&paths::nodes(solver)),
            segments: p(&paths::segments(solver)),
            strands: p(paths::STRANDS),
            body_spheres: p(paths::BODY_SPHERES),
            scalp: p(paths::SCALP),
            events: EventKind::ALL.map(|k| p(&paths::events(k))),
            log: p(paths::LOG),
            by_name: Vec::new(),
            stats: Vec::new(),
        }
    }

    /// The entity path of a stat (`/stats/<name>`, `/params/<name>`; allocates only the first
    /// time).
    fn stat(&mut self, group: StatGroup, name: &'static str) -> &EntityPath {
        let i = match self.stats.iter().position(|(k, _)| *k == (group, name)) {
            Some(i) => i,
            None => {
                let path = format!("{}{}", self.prefix, paths::stat_path(group, name));
                self.stats.push(((group, name), path.into()));
                self.stats.len() - 1
            }
        };
        &self.stats[i].1
    }

    /// The entity path of a stat or primitive set (allocates only the first time).
    fn named(&mut self, path: &'static str) -> &EntityPath {
        let i = match self.by_name.iter().position(|(n, _)| *n == path) {
            Some(i) => i,
            None => {
                self.by_name
                    .push((path, format!("{}{path}", self.prefix).into()));
                self.by_name.len() - 1
            }
        };
        &self.by_name[i].1
    }
}

/// What a [`Logger`] is for: the static parts it logs once.
#[derive(Debug, Clone)]
pub struct LoggerSetup {
    /// Levels of detail of the model (annotation classes, per-level series).
    pub levels: u16,
    /// Shown in the 3D view's title.
    pub style_name: String,
    /// Where the 3D camera looks (world, m).
    pub camera_target: [f32; 3],
    /// Prefix of every entity path (`""`, or `/runs/<label>`).
    pub prefix: String,
    /// Send the default blueprint (a multi-run recording sends its own once).
    pub send_blueprint: bool,
    /// The 3D view's starting eye and target; `None`: in front of and beside `camera_target`.
    pub camera: Option<BlueprintCamera>,
    /// The recording has rendered frames at `/render/hair`: show them beside the 3D view.
    pub render: bool,
}

impl LoggerSetup {
    /// A plain run's logger: no prefix, the default blueprint.
    pub fn new(levels: u16, style_name: &str, camera_target: [f32; 3]) -> LoggerSetup {
        LoggerSetup {
            levels,
            style_name: style_name.to_owned(),
            camera_target,
            prefix: String::new(),
            send_blueprint: true,
            camera: None,
            render: false,
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
    /// Whether the inspected node's marker is drawn (cleared once, when inspecting stops).
    inspected_drawn: bool,
    /// Whether the Style panel's key strands are drawn (they then follow the head).
    style_drawn: bool,
    event_labels: Vec<String>,
    text: String,
    /// Whether the last frame logged markers of that kind (then an eventless frame clears them).
    events_shown: [bool; 4],
    /// Per-instance translucent level colours, reused.
    node_colors: Vec<Color>,
    seg_colors: Vec<Color>,
    /// Series styles already logged for solver-specific stats.
    styled: Vec<(StatGroup, &'static str)>,
    shapes: body_shapes::BodyShapes,
}

impl Logger {
    /// Logs the static parts once: `ViewCoordinates::RIGHT_HAND_Y_UP` on `/`, the annotation
    /// context with one class per level ("level 0", …), the series styles, and (if asked) the
    /// default blueprint with the 3D camera framing the head.
    pub fn new(rec: sink::Recording, setup: &LoggerSetup) -> anyhow::Result<Logger> {
        let rec = rec.0;
        let levels = setup.levels;
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
        if setup.send_blueprint {
            match &setup.camera {
                Some(c) => send_blueprint_with(&rec, &setup.style_name, c, setup.render)?,
                None => send_blueprint(&rec, &setup.style_name, setup.camera_target)?,
            }
        }
        log_series_styles(&rec, &setup.prefix, levels)?;

        let mut logger = Logger {
            rec,
            paths: Paths::new(&setup.prefix, "awt"),
            strands: Vec::new(),
            event_positions: Vec::new(),
            inspected_drawn: false,
            style_drawn: false,
            event_labels: Vec::new(),
            text: String::new(),
            events_shown: [false; 4],
            node_colors: Vec::new(),
            seg_colors: Vec::new(),
            styled: Vec::new(),
            shapes: body_shapes::BodyShapes::new(&setup.prefix),
        };
        logger.set_time(0, 0.0);
        logger.log_message(
            MessageLevel::Info,
            &format!("style {}: {levels} levels of detail", setup.style_name),
        )?;
        Ok(logger)
    }

    /// The recording stream logged to.
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
        if !frame.solver.is_empty() && frame.solver != self.paths.solver {
            // Another solver's frames: its nodes and segments live under its own path.
            let prefix = self.paths.prefix.clone();
            self.paths = Paths::new(&prefix, frame.solver);
        }
        self.log_hair(frame)?;
        self.log_extras(frame)?;
        self.log_body(frame)?;
        self.log_events(frame)?;
        self.log_stats(frame)?;
        self.log_inspect(frame)?;
        for m in &frame.messages {
            self.rec
                .log(self.paths.log.clone(), &TextLog::new(m.as_str()))?;
        }
        if let Some(img) = &frame.image {
            // A live image comes after its own frame: it is logged at that frame's time.
            if let Some((index, sim_time)) = img.shows {
                self.set_time(index, sim_time);
            }
            let path = self.paths.named(paths::RENDER).clone();
            self.rec.log(
                path,
                &rerun::EncodedImage::from_file_contents(img.jpeg.clone())
                    .with_media_type(rerun::components::MediaType::JPEG),
            )?;
            self.set_time(frame.index, frame.sim_time);
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
        self.log_style_pose(frame)?;
        self.shapes.log(&self.rec, b)
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

    /// Every stat of the frame's list as a scalar at its path; a solver-specific stat gets its
    /// series style (name, colour) the first time it is seen.
    fn log_stats(&mut self, frame: &Frame) -> anyhow::Result<()> {
        for st in &frame.stats {
            let common = st.group == StatGroup::Stats && colors::is_common_stat(st.name);
            let key = (st.group, st.name);
            if !common && !self.styled.contains(&key) {
                self.styled.push(key);
                let (r, g, b) = colors::stat_color(self.styled.len());
                self.rec.log_static(
                    self.paths.stat(st.group, st.name).clone(),
                    &SeriesLines::new()
                        .with_colors([Color::from_rgb(r, g, b)])
                        .with_names([series_name(self.paths.solver, st.group, st.name)]),
                )?;
            }
            let path = self.paths.stat(st.group, st.name).clone();
            self.rec.log(path, &Scalars::single(st.value))?;
        }
        Ok(())
    }

    /// The solver's extra primitive sets (envelopes, static links, triangle strips, …), each at
    /// its own path, whatever solver made them.
    fn log_extras(&mut self, frame: &Frame) -> anyhow::Result<()> {
        for set in &frame.extras {
            let path = self.paths.named(set.path).clone();
            let color = |c: [u8; 4]| Color::from_unmultiplied_rgba(c[0], c[1], c[2], c[3]);
            let colors: Vec<Color> = if set.colors.is_empty() {
                vec![color(set.color)]
            } else {
                set.colors.iter().map(|&c| color(c)).collect()
            };
            match set.kind {
                PrimitiveKind::Points => self.rec.log(
                    path,
                    &Points3D::new(set.points.iter().copied())
                        .with_radii([Radius::new_ui_points(set.radius_ui)])
                        .with_colors(colors),
                )?,
                PrimitiveKind::LineStrips => self.rec.log(
                    path,
                    &LineStrips3D::new((0..set.len()).map(|k| set.strip(k).to_vec()))
                        .with_radii([Radius::new_ui_points(set.radius_ui)])
                        .with_colors(colors),
                )?,
                PrimitiveKind::Triangles => {
                    let n = set.len();
                    // One colour per triangle becomes one per vertex.
                    let vertex_colors: Vec<Color> = if set.colors.is_empty() {
                        vec![color(set.color); 3 * n]
                    } else {
                        set.colors
                            .iter()
                            .flat_map(|&c| [color(c); 3])
                            .take(3 * n)
                            .collect()
                    };
                    self.rec.log(
                        path,
                        &Mesh3D::new(set.points[..3 * n].iter().copied())
                            .with_vertex_colors(vertex_colors),
                    )?
                }
            }
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

    /// Like [`Logger::flush`], giving up after `timeout` (a live viewer that stopped reading).
    pub fn flush_with_timeout(&self, timeout: std::time::Duration) -> anyhow::Result<()> {
        self.rec
            .flush_with_timeout(timeout)
            .map_err(|e| anyhow::anyhow!("flushing to the viewer: {e}"))
    }

    /// Blocks until everything logged so far has reached the sink (file, viewer, memory).
    pub fn flush(&self) -> anyhow::Result<()> {
        self.rec
            .flush_blocking()
            .map_err(|e| anyhow::anyhow!("flushing the Rerun recording: {e}"))
    }
}

/// Fixed series colours and names of the common stats, logged once (static): the active-node
/// curves take their level's colour and the split/merge curves their marker's, so plot and 3D
/// view read alike; the viewer's automatic colours would give level 0 and level 2 the same pink.
fn log_series_styles(rec: &RecordingStream, prefix: &str, levels: u16) -> anyhow::Result<()> {
    for l in 0..levels {
        rec.log_static(
            format!("{prefix}{}", paths::active_nodes_level(l as usize)),
            &SeriesLines::new()
                .with_colors([level_color(l, levels)])
                .with_names([format!("level {l}")]),
        )?;
    }
    for (stat, (r, g, b), name) in colors::COMMON_SERIES {
        rec.log_static(
            format!("{prefix}{}", paths::stat(stat)),
            &SeriesLines::new()
                .with_colors([Color::from_rgb(r, g, b)])
                .with_names([name]),
        )?;
    }
    Ok(())
}

/// The plot's name of a stat: a tunable (`/params/<name>`) by the label and unit of the logged
/// solver's table entry (`solver` is its path segment, `awt`, `layered`, …), any other stat by
/// its name.
fn series_name(solver: &str, group: StatGroup, name: &str) -> String {
    use crate::solver::SolverKind;
    let tunable = SolverKind::ALL
        .iter()
        .filter(|k| k.path_segment() == solver)
        .chain(SolverKind::ALL.iter())
        .flat_map(|k| k.tunables())
        .find(|t| group == StatGroup::Params && t.name == name);
    match tunable {
        Some(t) => format!("{} ({})", t.label, t.unit),
        None => name.replace('_', " "),
    }
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
        EventKind::Split => write!(out, "|a|·r = {:.4} N·m·kg⁻¹", e.accel_radius),
        EventKind::Merge => write!(
            out,
            "max relative velocity = {:.4} m/s (|a|·r = {:.4} N·m·kg⁻¹)",
            e.rel_velocity, e.accel_radius
        ),
        EventKind::GuideInsert | EventKind::GuideRemove => Ok(()),
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tunables_plot_is_named_by_the_logged_solvers_own_table() {
        // `body_friction` is in both the layered and the guide tables, in different units.
        assert_eq!(
            series_name("guides", StatGroup::Params, "body_friction"),
            "body friction (fraction)"
        );
        assert_eq!(
            series_name("layered", StatGroup::Params, "body_friction"),
            "body friction (s⁻¹)"
        );
        assert_eq!(
            series_name("awt", StatGroup::Params, "split_threshold"),
            "split threshold (N·m·kg⁻¹)"
        );
        assert_eq!(
            series_name("guides", StatGroup::Stats, "links_intact"),
            "links intact"
        );
    }
}
