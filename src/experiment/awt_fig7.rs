//! The Adaptive Wisp Tree's Figure 7 (Bertails, Kim, Cani, Neumann 2003, §5.1): the four
//! hairstyles of the paper's §5.2 table under the character motions of the figure, rendered
//! ("from top to bottom: short, smooth hair in running motion; long, thick hair in leaning
//! motion; long, curly hair in leaning motion; short, curly hair in leaning motion").
//!
//! The figure shows pictures, not numbers; §5.1's claim beside it is that "thanks to the
//! merging process, our model stabilizes the hair motion even at high speed". So each run
//! reports its active nodes over time and its splits and merges: the wisps split as the motion
//! drives them and merge back, and the active count stays a small part of the finest nodes.
//! The rows of the contact sheet (the [`FrameSink::picture`] `awt_fig7`) are the four runs in
//! the figure's order, its columns four instants of the motion.
//!
//! The paper renders "about 10,000 individual hair strands" with opacity shadow maps and
//! Kajiya-Kay shading; so does this, every strand of the built-in styles (10,020–10,156).
//! The camera follows the head (the `run` motion leaves its starting box at 3 m/s), looking
//! from the renderer's default direction at the box the hair sweeps relative to the head.

use nalgebra::{Point3, Vector3};
use serde_json::{json, Map};

use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameExtras, FrameSink};
use crate::frame::{Frame, StrandBuf};
use crate::pipeline::{self, FrameBuilder};
use crate::render::{camera::DEFAULT_VIEW, Camera, Image, RenderInput, Renderer};
use crate::report::EventKind;
use crate::scene::Scene;
use crate::solver::{Solver, SolverKind};

/// The figure's rows: (style, motion), top to bottom.
pub const RUNS: [(&str, &str); 4] = [
    ("short", "run"),
    ("long", "lean"),
    ("long_curly", "lean"),
    ("short_curly", "lean"),
];

/// Seconds of each run: two cycles of `lean` (2.2 s each); `run` reaches its full 3 m/s after
/// its first second.
const SECONDS: f64 = 4.4;

/// The contact sheet's columns, s: `lean`'s full forward lean (35°), its full lean back, the
/// second forward lean, the end of the second cycle. Scaled with the run's duration.
pub const SHEET_TIMES: [f64; 4] = [0.8, 1.7, 3.0, 4.4];

/// The active-node counts are printed every this many seconds.
const SAMPLE_S: f64 = 0.4;

/// One cell of the contact sheet, pixels.
const TILE: (u32, u32) = (240, 180);
/// The white line between cells, pixels.
const GAP: u32 = 4;
/// Rendered frames in the recording (beside the 3D views), pixels.
const FRAME_SIZE: (u32, u32) = (480, 360);
/// Catmull-Rom points per span of a rendered strand (as `wisptree run` renders).
const SUBDIVISIONS: usize = 2;

/// `awt-fig7`.
pub static AWT_FIG7: ExperimentDef = ExperimentDef {
    name: "awt-fig7",
    description: "Bertails et al. 2003 (AWT), Fig. 7: Short under run, Long, Long curly and \
                  Short curly under lean, rendered; active nodes over time, splits and merges",
    expectation: "every style splits under its motion and merges back (splits > 0, merges > 0), \
                  and active nodes stay a small part of the finest nodes (§5.1: merging \
                  stabilizes the hair motion)",
    run: run_fig7,
};

/// The label of a row: `short_run`, `long_lean`, ….
pub fn label(style: &str, motion: &str) -> String {
    format!("{style}_{motion}")
}

fn run_fig7(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let mut sheet = ContactSheet::new(RUNS.len() as u32, SHEET_TIMES.len() as u32);
    let mut runs = Vec::new();
    for (row, (style, motion)) in RUNS.iter().enumerate() {
        let scene = Scene::load(style, motion, SolverKind::Awt)?;
        let label = label(style, motion);
        runs.push(run_one(&scene, &label, opts, sink, &mut sheet, row as u32)?);
    }
    sink.picture("awt_fig7", &sheet.image)?;
    Ok(runs)
}

/// One row: simulates, samples the counters, renders the sheet's cells (and every frame if
/// the sink shows images).
fn run_one(
    scene: &Scene,
    label: &str,
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
    sheet: &mut ContactSheet,
    row: u32,
) -> anyhow::Result<ExperimentRun> {
    let scale = opts.duration_scale;
    let frames = scene.frames_for(SECONDS * scale).max(1);
    let dt = scene.frame_dt();
    let frame_at = |t: f64| ((t / dt).round() as u64).clamp(1, frames);
    let sheet_frames: Vec<u64> = SHEET_TIMES.iter().map(|t| frame_at(t * scale)).collect();
    let sample_every = ((SAMPLE_S * scale / dt).round() as u64).max(1);

    let view = HeadCamera::new(scene);
    let params = scene.loaded.style.render.clone();
    let threads = crate::render::default_threads();
    let bad = |e: String| crate::error::BadInput(format!("rendering: {e}"));
    let mut cell = Renderer::new(params.clone(), TILE.0, TILE.1, threads).map_err(bad)?;
    let mut full = match sink.wants_images() {
        true => Some(Renderer::new(params, FRAME_SIZE.0, FRAME_SIZE.1, threads).map_err(bad)?),
        false => None,
    };
    let mut builder = FrameBuilder::new(&scene.model, usize::MAX, SUBDIVISIONS);
    let mut strands = StrandBuf::default();
    let (mut image, mut cell_image) = (Image::default(), Image::default());

    let mut s = scene.solver();
    let mut report = s.new_report();
    let mut frame = Frame::default();
    let mut tally = Tally::default();
    for index in 1..=frames {
        pipeline::step_frame(&mut *s, &mut report, &mut frame);
        tally.add(index, &frame, index % sample_every == 0);
        let column = sheet_frames.iter().position(|&f| f == index);
        let rendered = if full.is_some() || column.is_some() {
            s.sync_display();
            builder.fill_strands(&*s, &mut strands);
            pipeline::fill_body(s.model(), s.pose(), &mut frame.body);
            let camera = view.at(&*s);
            let input = RenderInput {
                strands: &strands,
                body: &frame.body,
            };
            if let Some(c) = column {
                cell.render(&input, &camera, &mut cell_image);
                sheet.put(row, c as u32, &cell_image);
            }
            match full.as_mut() {
                Some(r) => {
                    r.render(&input, &camera, &mut image);
                    Some(&image)
                }
                None => None,
            }
        } else {
            None
        };
        let extras = FrameExtras {
            counters: Some(&frame.counters),
            image: rendered,
            follow_head: view.travels,
        };
        sink.frame_with(label, s.as_mut(), &frame.events, extras)?;
    }
    let finest_nodes = scene.model.nodes_on_level(scene.model.level_count() - 1);
    let mut m = Map::new();
    m.insert("style".into(), json!(RUNS[row as usize].0));
    m.insert("motion".into(), json!(scene.motion_spec));
    m.insert("splits".into(), json!(tally.splits));
    m.insert("merges".into(), json!(tally.merges));
    m.insert("active_start".into(), json!(tally.start));
    m.insert("active_end".into(), json!(tally.end));
    m.insert("active_max".into(), json!(tally.max));
    m.insert(
        "active_mean".into(),
        json!((tally.sum as f64 / frames as f64 * 10.0).round() / 10.0),
    );
    m.insert("finest_nodes".into(), json!(finest_nodes));
    m.insert("active_sample_s".into(), json!(sample_every as f64 * dt));
    m.insert("active_over_time".into(), json!(tally.samples));
    // The active set changes only by splits and merges (§3): the count's change from the first
    // frame to the last, and the same change summed over the events between them.
    m.insert("active_change".into(), json!(tally.end - tally.start));
    m.insert("active_change_by_events".into(), json!(tally.by_events));
    m.insert(
        "sheet_times_s".into(),
        json!(sheet_frames
            .iter()
            .map(|&f| (f as f64 * dt * 1e3).round() / 1e3)
            .collect::<Vec<_>>()),
    );
    Ok(ExperimentRun {
        label: label.to_owned(),
        metrics: m,
    })
}

/// What a run counts, frame by frame.
#[derive(Debug, Default)]
struct Tally {
    splits: u64,
    merges: u64,
    /// Active nodes after the first frame, after the last, the most, and the sum over frames.
    start: i64,
    end: i64,
    max: i64,
    sum: i64,
    /// The active count's change by the events after the first frame: + (sub-nodes − 1) per
    /// split, − (sub-nodes − 1) per merge.
    by_events: i64,
    samples: Vec<i64>,
}

impl Tally {
    fn add(&mut self, index: u64, f: &Frame, sample: bool) {
        let active = i64::from(f.counters.active_per_level.iter().sum::<u32>());
        self.splits += u64::from(f.splits);
        self.merges += u64::from(f.merges);
        if index == 1 {
            self.start = active;
        } else {
            for e in &f.events {
                let n = i64::from(e.sub_gcs.end - e.sub_gcs.start) - 1;
                self.by_events += if e.kind == EventKind::Split { n } else { -n };
            }
        }
        self.end = active;
        self.max = self.max.max(active);
        self.sum += active;
        if sample {
            self.samples.push(active);
        }
    }
}

/// A camera that keeps the head where it was: framed on the box the hair sweeps relative to
/// the head over the motion's first seconds, then moved with the head.
struct HeadCamera {
    base: Camera,
    scalp: Point3<f64>,
    /// The head leaves its starting place (more than [`TRAVELS_M`]): a fixed view loses it.
    travels: bool,
}

/// How far the head must go for the run's 3D view to follow it, m.
const TRAVELS_M: f64 = 1.0;

impl HeadCamera {
    fn new(scene: &Scene) -> HeadCamera {
        let m = &scene.model;
        let scalp = Point3::from(m.scalp_center);
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        let mut travels = false;
        for q in 0..=20 {
            let pose = scene.motion.pose(f64::from(q) * 0.25);
            let head: Vector3<f64> = pose.transform_point(&scalp) - scalp;
            travels |= head.norm() > TRAVELS_M;
            for (j, p) in m.strands.rest.iter().enumerate() {
                if !(j / m.k).is_multiple_of(7) {
                    continue;
                }
                let w = pose.transform_point(&Point3::from(*p)).coords - head;
                for a in 0..3 {
                    lo[a] = lo[a].min(w[a] as f32);
                    hi[a] = hi[a].max(w[a] as f32);
                }
            }
        }
        if !lo[0].is_finite() {
            (lo, hi) = (scene.camera_target(), scene.camera_target());
        }
        HeadCamera {
            base: Camera::from_params(&scene.loaded.style.render, lo, hi, DEFAULT_VIEW),
            scalp,
            travels,
        }
    }

    /// The camera for the solver's pose now.
    fn at(&self, s: &dyn Solver) -> Camera {
        let d = s.pose().transform_point(&self.scalp) - self.scalp;
        let mut c = self.base;
        for (a, v) in d.iter().enumerate() {
            c.eye[a] += *v as f32;
            c.target[a] += *v as f32;
        }
        c
    }
}

/// Rows × columns of equal cells on white.
struct ContactSheet {
    image: Image,
}

impl ContactSheet {
    fn new(rows: u32, cols: u32) -> ContactSheet {
        let width = cols * TILE.0 + (cols + 1) * GAP;
        let height = rows * TILE.1 + (rows + 1) * GAP;
        ContactSheet {
            image: Image {
                width,
                height,
                rgb: vec![255; (width * height * 3) as usize],
            },
        }
    }

    /// Copies `cell` (a `TILE`-sized image) into row `r`, column `c`.
    fn put(&mut self, r: u32, c: u32, cell: &Image) {
        let (x0, y0) = (GAP + c * (TILE.0 + GAP), GAP + r * (TILE.1 + GAP));
        let w = cell.width.min(TILE.0) as usize * 3;
        for y in 0..cell.height.min(TILE.1) {
            let src = (y * cell.width) as usize * 3;
            let dst = (((y0 + y) * self.image.width + x0) * 3) as usize;
            self.image.rgb[dst..dst + w].copy_from_slice(&cell.rgb[src..src + w]);
        }
    }
}
