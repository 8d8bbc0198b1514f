//! The layout of a recording of several runs (`/runs/<label>/…`, `wisptree experiment` and
//! `wisptree sweep`): a grid of one 3D view per run, each framed on its hair, above plots
//! overlaying every run.

use anyhow::Context as _;
use rerun::components::Name;
use rerun::datatypes::Uuid;
use rerun::external::re_log_types::{LogMsg, RecordingId};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, EyeControls3D, ViewBlueprint, ViewContents, ViewportBlueprint,
};
use rerun::external::re_sdk_types::blueprint::components::{
    AutoLayout, AutoViews, ColumnShare, ContainerKind, Eye3DKind, IncludedContent, QueryExpression,
    RootContainer, RowShare, ViewClass,
};
use rerun::{RecordingStream, RecordingStreamBuilder};

use super::blueprint::{activate, log_panels, uuid_string, BlueprintCamera, SPATIAL_CONTENTS};

/// One run of a recording of several runs (`/runs/<label>/…`), as its cell of the layout shows
/// it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunView {
    /// The run's label: its subtree is `/runs/<label>`.
    pub label: String,
    /// Where its 3D view starts: framed on that run's hair (small scenes are not a head).
    pub camera: BlueprintCamera,
    /// The run has rendered frames at `/runs/<label>/render/hair`: show them beside its 3D view.
    pub render: bool,
    /// The run steps a solver and logs its stats: the overlaid plots show them (a layout of
    /// runs none of which does, a rendering experiment's, has no plots).
    pub stats: bool,
    /// An entity the 3D view follows (the scalp of a head that travels, as under `run`, which
    /// would leave a fixed view within a second).
    pub track: Option<String>,
}

/// Total active nodes of a run (the sum over levels), the stat the multi-run layout overlays:
/// the per-level curves of several runs would be a dozen lines of the same few colours.
pub const RUN_ACTIVE_TOTAL: &str = "active_total";

/// A run's eye is moved this much closer to its target than the camera it is given: cameras
/// frame the hair for the renderer's 30° vertical field of view, the viewer's 3D view has
/// about 55°, and at the renderer's distance the hair filled a third of a grid cell's height
/// (checked on a screenshot of a 4-run sweep). tan 15° / tan 27.5° ≈ 0.51.
const RUN_EYE_SCALE: f32 = 0.55;

/// Object kinds of the multi-run layout's blueprint ids (see [`runs_uuid`]).
const RUN_3D: u8 = 1;
const RUN_2D: u8 = 2;
const RUN_CELL: u8 = 3;
const RUN_PLOT: u8 = 4;
const RUN_CONTAINER: u8 = 5;

/// A fixed id for object `k` of kind `kind` of the multi-run layout: well-formed (version 4,
/// RFC 4122 variant), deterministic, and room for any number of runs.
fn runs_uuid(kind: u8, k: u32) -> Uuid {
    let mut bytes = *b"wisptree\0\0\0\0\0\0\0\0";
    bytes[6] = 0x40 | (bytes[6] & 0x0f);
    bytes[8] = 0x80 | 0x20 | (kind & 0x1f);
    bytes[12..16].copy_from_slice(&k.to_be_bytes());
    Uuid { bytes }
}

fn runs_path(prefix: &str, kind: u8, k: u32) -> String {
    format!("{prefix}/{}", uuid_string(&runs_uuid(kind, k)))
}

/// The layout of a recording of several runs, as blueprint messages: a grid of 3D views, one
/// per run (`origin` = `/runs/<label>`, the eye at the run's camera; with `render`, its
/// rendered hair beside it), above two plots overlaying every run: total active nodes and ms
/// per step (apart, since milliseconds would flatten against thousands of nodes).
///
/// `blueprint_id` fixes the blueprint's store id (every part of one sweep sends the same
/// layout, so a merge of the parts holds one blueprint); `None`: a fresh one, as the SDK does.
/// Built from blueprint archetypes, as [`super::blueprint::send_blueprint_with`], to set each
/// view's eye.
pub fn runs_blueprint(
    app_id: &str,
    runs: &[RunView],
    blueprint_id: Option<&str>,
) -> anyhow::Result<Vec<LogMsg>> {
    let id = blueprint_id.map_or_else(RecordingId::random, RecordingId::from);
    let app_id = rerun::external::re_log_types::ApplicationId::new_or_unknown(app_id);
    let (bp, storage) = RecordingStreamBuilder::new(app_id)
        .recording_id(id)
        .blueprint()
        .memory()
        .context("creating the blueprint stream")?;
    bp.set_time_sequence("blueprint", 0);
    let mut cells = Vec::with_capacity(runs.len());
    for (k, r) in runs.iter().enumerate() {
        cells.push(log_run_cell(&bp, k as u32, r)?);
    }
    let container = |k: u32, kind, contents: &[String], shares: &[f32]| {
        let path = runs_path("container", RUN_CONTAINER, k);
        let mut c = ContainerBlueprint::new(kind)
            .with_contents(contents.iter().map(|p| IncludedContent::from(p.as_str())));
        c = match kind {
            ContainerKind::Vertical => c.with_row_shares(shares.iter().map(|&s| RowShare::from(s))),
            ContainerKind::Horizontal => {
                c.with_col_shares(shares.iter().map(|&s| ColumnShare::from(s)))
            }
            _ => c.with_grid_columns((runs.len() as f64).sqrt().ceil().max(1.0) as u32),
        };
        bp.log(path.as_str(), &c).map(|()| path)
    };
    let grid = container(0, ContainerKind::Grid, &cells, &[])?;
    if !runs.iter().any(|r| r.stats) {
        container(2, ContainerKind::Vertical, &[grid], &[1.0])?;
        return finish_blueprint(&bp, storage);
    }
    let (active, step_ms) = (
        super::paths::stat(RUN_ACTIVE_TOTAL),
        super::paths::stat(crate::report::names::STEP_MS),
    );
    let plots = [
        log_overlay(&bp, 0, "active nodes, every run", runs, &active)?,
        log_overlay(&bp, 1, "ms per step, every run", runs, &step_ms)?,
    ];
    let plots = container(1, ContainerKind::Horizontal, &plots, &[1.0, 1.0])?;
    container(2, ContainerKind::Vertical, &[grid, plots], &[3.0, 1.0])?;
    finish_blueprint(&bp, storage)
}

/// The viewport (the layout's root container, nothing automatic) and the panels, then the
/// blueprint's messages.
fn finish_blueprint(
    bp: &RecordingStream,
    storage: rerun::sink::MemorySinkStorage,
) -> anyhow::Result<Vec<LogMsg>> {
    bp.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(runs_uuid(RUN_CONTAINER, 2)))
            .with_auto_layout(AutoLayout::from(false))
            .with_auto_views(AutoViews::from(false)),
    )?;
    log_panels(bp)?;
    bp.flush_blocking()
        .map_err(|e| anyhow::anyhow!("flushing the blueprint stream: {e}"))?;
    Ok(storage.take())
}

/// Run `k`'s cell of the grid: its 3D view, or with `render` its 3D view beside its rendered
/// hair. Returns the cell's blueprint path.
fn log_run_cell(bp: &RecordingStream, k: u32, run: &RunView) -> anyhow::Result<String> {
    let origin = format!("/runs/{}", run.label);
    let view = runs_path("view", RUN_3D, k);
    bp.log(
        format!("{view}/ViewContents"),
        &ViewContents::new(
            SPATIAL_CONTENTS
                .iter()
                .map(|q| QueryExpression::from(format!("+ {origin}{}", &q[2..]))),
        ),
    )?;
    bp.log(
        view.as_str(),
        &ViewBlueprint::new(ViewClass::from("3D"))
            .with_display_name(Name::from(run.label.as_str()))
            .with_space_origin(origin.as_str()),
    )?;
    let (e, t) = (run.camera.eye, run.camera.target);
    let eye: [f32; 3] = std::array::from_fn(|a| t[a] + (e[a] - t[a]) * RUN_EYE_SCALE);
    let mut eye = EyeControls3D::new()
        .with_kind(Eye3DKind::Orbital)
        .with_position(eye)
        .with_look_target(t)
        .with_eye_up([0.0f32, 1.0, 0.0]);
    if let Some(entity) = &run.track {
        eye = eye.with_tracking_entity(entity.as_str());
    }
    bp.log(format!("{view}/EyeControls3D"), &eye)?;
    if !run.render {
        return Ok(view);
    }
    let image = runs_path("view", RUN_2D, k);
    bp.log(
        format!("{image}/ViewContents"),
        &ViewContents::new([QueryExpression::from(format!("+ {origin}/render/**"))]),
    )?;
    bp.log(
        image.as_str(),
        &ViewBlueprint::new(ViewClass::from("2D"))
            .with_display_name(Name::from(format!("{} rendered", run.label)))
            .with_space_origin(format!("{origin}/render")),
    )?;
    let cell = runs_path("container", RUN_CELL, k);
    bp.log(
        cell.as_str(),
        &ContainerBlueprint::new(ContainerKind::Horizontal).with_contents([
            IncludedContent::from(view.as_str()),
            IncludedContent::from(image.as_str()),
        ]),
    )?;
    Ok(cell)
}

/// A time series overlaying stat `stat` of every run.
fn log_overlay(
    bp: &RecordingStream,
    k: u32,
    name: &str,
    runs: &[RunView],
    stat: &str,
) -> anyhow::Result<String> {
    let path = runs_path("view", RUN_PLOT, k);
    bp.log(
        format!("{path}/ViewContents"),
        &ViewContents::new(
            runs.iter()
                .map(|r| QueryExpression::from(format!("+ /runs/{}{stat}", r.label))),
        ),
    )?;
    bp.log(
        path.as_str(),
        &ViewBlueprint::new(ViewClass::from("TimeSeries"))
            .with_display_name(Name::from(name))
            .with_space_origin("/runs"),
    )?;
    Ok(path)
}

/// Sends [`runs_blueprint`] to `rec` as its active and default layout.
pub fn send_runs_blueprint(
    rec: &super::sink::Recording,
    runs: &[RunView],
    blueprint_id: Option<&str>,
) -> anyhow::Result<()> {
    let app_id = rec
        .stream()
        .store_info()
        .map(|info| info.application_id().to_string())
        .unwrap_or_else(|| super::sink::APP_ID.to_owned());
    let msgs = runs_blueprint(&app_id, runs, blueprint_id)?;
    activate(rec.stream(), msgs)
}

/// Names and colours the overlaid series of run `k` (total active nodes and ms per step) after
/// its label, so the overlay tells the runs apart. Static, and logged after the run's first
/// frame: the logger styles a stat it sees for the first time, and the latest static wins.
pub fn label_run_series(rec: &super::sink::Recording, k: usize, label: &str) -> anyhow::Result<()> {
    let (r, g, b) = super::colors::stat_color(k + 1);
    for name in [RUN_ACTIVE_TOTAL, crate::report::names::STEP_MS] {
        rec.stream().log_static(
            format!("/runs/{label}{}", super::paths::stat(name)),
            &rerun::SeriesLines::new()
                .with_colors([rerun::Color::from_rgb(r, g, b)])
                .with_names([label]),
        )?;
    }
    Ok(())
}

/// Frame `index` of run `label` of a rendering experiment (no solver): at most `max_strands`
/// of `strands` (evenly spread) as line strips at `/runs/<label>/hair/strands`, and `image`
/// (lossless PNG: the experiments measure its pixels) at `/runs/<label>/render/hair`, on the
/// `frame` timeline.
pub fn log_rendered(
    rec: &super::sink::Recording,
    label: &str,
    index: u64,
    strands: &crate::frame::StrandBuf,
    max_strands: usize,
    image: &crate::render::Image,
) -> anyhow::Result<()> {
    let rec = rec.stream();
    rec.set_time_sequence(
        super::paths::TIMELINE_FRAME,
        i64::try_from(index).unwrap_or(i64::MAX),
    );
    let n = strands.len();
    let shown = n.min(max_strands.max(1));
    let strips = (0..shown).map(|j| strands.strand(j * n / shown).to_vec());
    let (r, g, b) = super::colors::HAIR_COLOR;
    rec.log(
        format!("/runs/{label}{}", super::paths::STRANDS),
        &rerun::LineStrips3D::new(strips)
            .with_radii([rerun::components::Radius::new_ui_points(0.5)])
            .with_colors([rerun::Color::from_rgb(r, g, b)]),
    )?;
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &image.rgb,
        image.width,
        image.height,
        image::ExtendedColorType::Rgb8,
    )
    .context("encoding the rendered image")?;
    rec.log(
        format!("/runs/{label}{}", super::paths::RENDER),
        &rerun::EncodedImage::from_file_contents(png)
            .with_media_type(rerun::components::MediaType::PNG),
    )?;
    Ok(())
}
