//! The default layout: the 3D view of the AWT paper's Figure 4 beside the plots and the log.

use std::fmt::Write as _;

use anyhow::Context as _;
use rerun::components::Name;
use rerun::datatypes::Uuid;
use rerun::external::re_log_types::{BlueprintActivationCommand, LogMsg, RecordingId};
use rerun::external::re_sdk_types::blueprint::archetypes::{
    ContainerBlueprint, EyeControls3D, PanelBlueprint, TimePanelBlueprint, ViewBlueprint,
    ViewContents, ViewportBlueprint,
};
use rerun::external::re_sdk_types::blueprint::components::{
    AutoLayout, AutoViews, ColumnShare, ContainerKind, Eye3DKind, IncludedContent, PanelState,
    QueryExpression, RootContainer, RowShare, ViewClass,
};
use rerun::{RecordingStream, RecordingStreamBuilder};

/// Camera offset from the head centre, m: in front (+z), to the side (+x), a bit above; about
/// 1.1 m away, which with the viewer's field of view frames about 1.2 m: the head and hair hanging
/// 0.6 m below it (checked on a rendered screenshot; at 1.4 m a head was a small blob).
const EYE_OFFSET: [f32; 3] = [0.65, 0.25, 0.85];
/// Look below the head centre: long hair hangs down.
const LOOK_DROP: f32 = 0.25;
// ---------------------------------------------------------------------------------------------
// Blueprint

/// What one view of the default layout shows.
struct ViewSpec {
    /// Rerun view class identifier ("3D", "TimeSeries", "TextLog").
    class: &'static str,
    name: String,
    contents: Vec<String>,
}

pub(super) const SPATIAL_CONTENTS: &[&str] = &[
    "+ /hair/**",
    "+ /body/**",
    "+ /head/**",
    "+ /events/**",
    "+ /style/**",
];
/// Time series are grouped by magnitude, so that no series flattens another: node counts
/// (hundreds to thousands) with the adaptation events per frame, collision work (pairs tested
/// run to 10⁵–10⁶) apart from them, the small real-valued quantities together, and the
/// timing apart.
const NODE_CONTENTS: &[&str] = &[
    "+ /stats/active_nodes/**",
    "+ /stats/splits",
    "+ /stats/merges",
];
/// Collision work, and every solver's own counts (interpenetrating pairs, links, guides, …):
/// everything under `/stats` that no other plot shows.
const COLLISION_CONTENTS: &[&str] = &[
    "+ /stats/**",
    "- /stats/active_nodes/**",
    "- /stats/splits",
    "- /stats/merges",
    "- /stats/kinetic_energy",
    "- /stats/step_ms",
    "- /stats/dropped_frames",
    "- /stats/realtime_factor",
];
/// The tunables of every solver's table whose range stays below this share the energy's small
/// scale (the thresholds, the wind strength); friction (≈ 30), repulsion (≈ 2000) and the
/// stiffnesses would flatten them, so they stay out of the plots (still in the recording, under
/// `/params`).
const SMALL_PARAM: f64 = 10.0;

/// The kinetic energy and the small-ranged tunables of every solver (`/params/<name>`).
fn energy_contents() -> Vec<String> {
    use crate::solver::SolverKind;
    let all = || SolverKind::ALL.iter().flat_map(|k| k.tunables());
    let mut out = vec!["+ /stats/kinetic_energy".to_owned()];
    for t in all() {
        // A name in two tables (`body_friction`) is one path: small only if small in both.
        let small = all()
            .filter(|o| o.name == t.name)
            .all(|o| o.max <= SMALL_PARAM);
        let line = format!("+ {}", super::paths::param(t.name));
        if small && !out.contains(&line) {
            out.push(line);
        }
    }
    out
}

/// Milliseconds per step (1–10) would flatten the energy (J, ≪ 1) and the thresholds. The
/// real-time factor sits beside the step time: a step over the frame's share of the wall clock
/// is what makes the factor fall under 1.
const TIMING_CONTENTS: &[&str] = &[
    "+ /stats/step_ms",
    "+ /stats/dropped_frames",
    "+ /stats/realtime_factor",
];
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
    let owned = |c: &[&str]| c.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let plot = |name: &str, contents| ViewSpec {
        class: "TimeSeries",
        name: name.to_owned(),
        contents,
    };
    (
        ViewSpec {
            class: "3D",
            name: title,
            contents: owned(SPATIAL_CONTENTS),
        },
        [
            plot("nodes, splits, merges", owned(NODE_CONTENTS)),
            plot("collisions and solver counts", owned(COLLISION_CONTENTS)),
            plot("energy, parameters", energy_contents()),
            plot("step time, real-time factor", owned(TIMING_CONTENTS)),
        ],
        ViewSpec {
            class: "TextLog",
            name: "events and log".to_owned(),
            contents: owned(LOG_CONTENTS),
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
/// (the Rust `Spatial3DView` of 0.36 has no eye-controls setter); [`super::Logger::new`] sends
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
                .with_contents(v.contents.iter().map(String::as_str))
                .into()
        })
        .collect();
    let right: Vec<ContainerLike> = vec![
        Grid::new(plots).with_grid_columns(PLOT_COLUMNS).into(),
        TextLogView::new(log.name)
            .with_origin("/")
            .with_contents(log.contents.iter().map(String::as_str))
            .into(),
    ];
    Blueprint::new(
        Horizontal::new([
            Spatial3DView::new(spatial.name)
                .with_origin("/")
                .with_contents(spatial.contents.iter().map(String::as_str))
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

pub(super) fn uuid_string(u: &Uuid) -> String {
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
    let [c0, c1, c2] = head_center;
    let camera = BlueprintCamera {
        eye: [c0 + EYE_OFFSET[0], c1 + EYE_OFFSET[1], c2 + EYE_OFFSET[2]],
        target: [c0, c1 - LOOK_DROP, c2],
    };
    send_blueprint_with(rec, style_name, &camera, false)
}

/// Where the 3D view starts: the renderer's camera, so both halves of Figure 4 show the hair
/// from the same place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlueprintCamera {
    /// Eye position, world m.
    pub eye: [f32; 3],
    /// Look target, world m.
    pub target: [f32; 3],
}

/// The default layout with the 3D view's eye at `camera`; with `render`, the rendered hair
/// (`/render/hair`) stands beside the 3D view, Figure 4's two halves, above the plots.
pub fn send_blueprint_with(
    rec: &RecordingStream,
    style_name: &str,
    camera: &BlueprintCamera,
    render: bool,
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
            &ViewContents::new(v.contents.iter().map(|q| QueryExpression::from(q.as_str()))),
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
    bp.log(
        format!("{spatial_path}/EyeControls3D"),
        &EyeControls3D::new()
            .with_kind(Eye3DKind::Orbital)
            .with_position(camera.eye)
            .with_look_target(camera.target)
            .with_eye_up([0.0f32, 1.0, 0.0]),
    )?;
    let render_path = format!("view/{}", uuid_string(&blueprint_uuid(13)));
    if render {
        log_render_view(&bp, &render_path)?;
    }
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
    let container =
        |k: u8, kind, contents: [&str; 2], shares: [f32; 2]| -> anyhow::Result<String> {
            let path = format!("container/{}", uuid_string(&blueprint_uuid(k)));
            let mut c =
                ContainerBlueprint::new(kind).with_contents(contents.map(IncludedContent::from));
            c = if kind == ContainerKind::Vertical {
                c.with_row_shares(shares.map(RowShare::from))
            } else {
                c.with_col_shares(shares.map(ColumnShare::from))
            };
            bp.log(path.as_str(), &c)?;
            Ok(path)
        };
    let root_id = 11;
    if render {
        // Figure 4: the AWT beside the rendered hair; the plots and the log below.
        let top = container(
            14,
            ContainerKind::Horizontal,
            [&spatial_path, &render_path],
            [1.0, 1.0],
        )?;
        let bottom = container(
            15,
            ContainerKind::Horizontal,
            [&grid_path, &log_path],
            [3.0, 2.0],
        )?;
        container(
            root_id,
            ContainerKind::Vertical,
            [&top, &bottom],
            [3.0, 2.0],
        )?;
    } else {
        let right = container(
            10,
            ContainerKind::Vertical,
            [&grid_path, &log_path],
            ROW_SHARES,
        )?;
        container(
            root_id,
            ContainerKind::Horizontal,
            [&spatial_path, &right],
            COLUMN_SHARES,
        )?;
    }
    let root = blueprint_uuid(root_id);
    bp.log(
        "viewport",
        &ViewportBlueprint::new()
            .with_root_container(RootContainer(root))
            .with_auto_layout(AutoLayout::from(false))
            .with_auto_views(AutoViews::from(false)),
    )?;
    log_panels(&bp)?;
    bp.flush_blocking()
        .map_err(|e| anyhow::anyhow!("flushing the blueprint stream: {e}"))?;
    activate(rec, storage.take())
}

/// The side panels start collapsed and the time panel as a bar: the hair and the plots get the
/// room; all of them open again from the viewer's top-right buttons.
pub(super) fn log_panels(bp: &RecordingStream) -> anyhow::Result<()> {
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
    Ok(())
}

/// Sends the blueprint messages to `rec` as its active and default blueprint.
pub(super) fn activate(rec: &RecordingStream, msgs: Vec<LogMsg>) -> anyhow::Result<()> {
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

/// The 2D view of the rendered hair (`/render/hair`).
fn log_render_view(bp: &RecordingStream, path: &str) -> anyhow::Result<()> {
    bp.log(
        format!("{path}/ViewContents"),
        &ViewContents::new([QueryExpression::from("+ /render/**")]),
    )?;
    bp.log(
        path,
        &ViewBlueprint::new(ViewClass::from("2D"))
            .with_display_name(Name::from("rendered hair"))
            .with_space_origin("/render"),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_energy_plot_holds_only_small_ranged_tunables() {
        let c = super::energy_contents();
        assert!(c.contains(&"+ /params/split_threshold".to_owned()), "{c:?}");
        assert!(c.contains(&"+ /params/wind".to_owned()), "{c:?}");
        // Layered's body friction runs to 100 s⁻¹: it would flatten the energy.
        assert!(!c.contains(&"+ /params/body_friction".to_owned()), "{c:?}");
        assert!(!c.contains(&"+ /params/friction".to_owned()), "{c:?}");
    }
}
