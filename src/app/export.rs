//! `wisptree export`: simulate a style under a motion with any model and write the dense
//! strands of every n-th frame as `.hair` (Cem Yuksel's format) or `.tfx` (TressFX 4.0) files,
//! `frame_00000.hair` and so on, or as one USD layer (`export_usd`), for renderers and other
//! tools.
//!
//! Coordinates are written in metres, y up, as simulated. A frame is numbered as in `run`'s
//! `frame` timeline: frame 0 is the state after the first frame's steps.
//!
//! Before anything is simulated, the export checks that what it will write fits in the free
//! space of the output's disk (an export of 10⁶ s writes terabytes). Every file is written
//! under a temporary name and renamed once complete, so a failed write (a full disk) leaves no
//! half-written file under the final name.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use crate::error::BadInput;
use crate::frame::Frame;
use crate::pipeline::FrameBuilder;
use crate::scene::Scene;
use crate::solver::SolverKind;
use crate::style::{hair_file, tfx_write};

use super::export_space as space;
use super::out_dir::OutDir;
use super::{export_usd, usda};

/// Catmull-Rom points per span of the exported strands: K control points become 2K − 1.
pub(crate) const SUBDIVISIONS: usize = 2;

/// The file format of `export`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormat {
    /// Cem Yuksel's `.hair`: every strand with its own point count, exact f32 points.
    Hair,
    /// TressFX 4.0 `.tfx`: every strand resampled to 32 vertices by arc length.
    Tfx,
    /// One USD layer (`.usda`, text) of every exported frame: `--out` names the file.
    Usd,
}

impl ExportFormat {
    /// The file extension, without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            ExportFormat::Hair => "hair",
            ExportFormat::Tfx => "tfx",
            ExportFormat::Usd => "usda",
        }
    }
}

/// What to export.
#[derive(Debug, Clone)]
pub struct ExportOptions {
    /// A built-in style name or a style file.
    pub style: String,
    /// A motion preset or file.
    pub motion: String,
    /// The model that simulates.
    pub model: SolverKind,
    /// Simulated seconds (> 0).
    pub seconds: f64,
    /// File format.
    pub format: ExportFormat,
    /// Output folder, created if needed (`hair`, `tfx`); the layer's file (`usd`).
    pub out: PathBuf,
    /// Write frames 0, every, 2·every, … (≥ 1).
    pub every: u32,
    /// `usd` only: the model's active nodes and segments too (`/wisptree/structure`).
    pub debug_structure: bool,
}

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportSummary {
    /// Frames simulated.
    pub frames: u64,
    /// The files written, in frame order.
    pub files: Vec<PathBuf>,
    /// Strands per file (every strand of the model).
    pub strands: usize,
    /// Points per strand in each file.
    pub points_per_strand: usize,
    /// Bytes written in all.
    pub bytes: u64,
    /// The import's notes (skipped strands), already shown to the user.
    pub notes: Vec<String>,
}

/// Simulates and writes the frames; `progress` shows a bar when stderr is a terminal.
pub fn export(opts: &ExportOptions, progress: bool) -> anyhow::Result<ExportSummary> {
    check_options(opts)?;
    let scene = Scene::load(&opts.style, &opts.motion, opts.model)?;
    for n in &scene.model.notes {
        eprintln!("wisptree: note: {n}");
    }
    for w in scene.warnings() {
        eprintln!("warning: {w}");
    }
    let frames = scene.frames_for(opts.seconds);
    let written = frames.div_ceil(u64::from(opts.every));
    space::check(opts, &scene.model, written)?;
    // One USD layer, or a folder of frame files in which an earlier export's files are
    // replaced and any other file in the way is kept as NAME.bak.
    let mut output = match opts.format {
        ExportFormat::Usd => Output::Usd(export_usd::UsdLayer::create(
            &opts.out,
            usda::LayerMeta {
                default_prim: "wisptree".into(),
                doc: format!(
                    "wisptree {}: {} under {}, {} model",
                    env!("CARGO_PKG_VERSION"),
                    scene.style_name(),
                    opts.motion,
                    opts.model
                ),
                start: 0.0,
                end: ((written - 1) * u64::from(opts.every)) as f64,
                fps: 1.0 / scene.frame_dt(),
            },
            scene.model.clone(),
            opts.debug_structure,
        )?),
        ExportFormat::Hair | ExportFormat::Tfx => {
            let folder = OutDir::open(&opts.out, "export")?;
            let written_frames = (0..frames).step_by(opts.every as usize);
            folder.check_names(written_frames.map(|i| frame_name(opts, i)))?;
            Output::Files(folder)
        }
    };
    let bar = (progress && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new(frames);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40.cyan/blue} {pos}/{len} frames  {elapsed} elapsed, ~{eta} left",
            )
            .expect("a valid progress template"),
        );
        bar
    });

    let mut solver = scene.solver();
    let mut report = solver.new_report();
    let mut builder = FrameBuilder::new(&scene.model, usize::MAX, SUBDIVISIONS);
    let mut frame = Frame::default();
    let mut strands: Vec<Vec<[f32; 3]>> = Vec::new();
    let mut summary = ExportSummary {
        frames,
        files: Vec::new(),
        strands: scene.model.strands.len(),
        points_per_strand: match opts.format {
            ExportFormat::Hair | ExportFormat::Usd => 0, // set from the first frame written
            ExportFormat::Tfx => tfx_write::TFX_VERTICES,
        },
        bytes: 0,
        notes: scene.model.notes.clone(),
    };
    let info = format!(
        "wisptree {}: {} under {}, {} model, metres, y up",
        env!("CARGO_PKG_VERSION"),
        scene.style_name(),
        opts.motion,
        opts.model
    );
    for index in 0..frames {
        for _ in 0..solver.steps_per_frame() {
            solver.step(&mut report);
        }
        if index % u64::from(opts.every) == 0 {
            builder.fill(&mut *solver, &mut frame);
            let folder = match &mut output {
                Output::Usd(layer) => {
                    summary.points_per_strand = frame.strands.strand(0).len();
                    layer.frame(index, &frame, solver.pose())?;
                    if let Some(b) = &bar {
                        b.inc(1);
                    }
                    continue;
                }
                Output::Files(folder) => folder,
            };
            copy_strands(&frame, &mut strands);
            if opts.format == ExportFormat::Hair {
                summary.points_per_strand = strands.first().map_or(0, Vec::len);
            }
            let name = frame_name(opts, index);
            let path = folder.make_way(&name)?;
            write_frame(
                &path,
                opts.format,
                &strands,
                &format!("{info}, frame {index}"),
            )?;
            folder.written(&name)?;
            summary.bytes += std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
            summary.files.push(path);
        }
        if let Some(b) = &bar {
            b.inc(1);
        }
    }
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    match output {
        Output::Usd(layer) => {
            summary.bytes = layer.finish()?;
            summary.files.push(opts.out.clone());
        }
        Output::Files(folder) => {
            folder.finish()?;
            folder.report_moved_aside();
        }
    }
    Ok(summary)
}

/// The file of frame `index` in the `--out` folder.
fn frame_name(opts: &ExportOptions, index: u64) -> String {
    format!("frame_{index:05}.{}", opts.format.extension())
}

/// Where an export's frames go.
enum Output {
    /// One USD layer, a frame per time sample.
    Usd(export_usd::UsdLayer),
    /// A file per frame in the `--out` folder.
    Files(OutDir),
}

/// Refuses options no export can run with.
fn check_options(opts: &ExportOptions) -> Result<(), BadInput> {
    if !(opts.seconds.is_finite() && opts.seconds > 0.0) {
        return Err(BadInput(format!(
            "--seconds must be a positive number, got {:?}",
            opts.seconds
        )));
    }
    if opts.every == 0 {
        return Err(BadInput("--every must be at least 1".into()));
    }
    let out = opts.out.display();
    if opts.format == ExportFormat::Usd {
        if opts.out.is_dir() {
            return Err(BadInput(format!(
                "--out {out}: is a folder; --format usd writes one file, such as {}",
                opts.out.join("hair.usda").display()
            )));
        }
        let ext = opts.out.extension().and_then(|e| e.to_str());
        if !matches!(ext, Some("usda" | "usd")) {
            return Err(BadInput(format!(
                "--out {out}: a USD layer written as text is named .usda (or .usd)"
            )));
        }
        // An earlier layer there is kept as NAME.bak when this one is renamed into place:
        // refused now, before the run, if that backup exists too.
        crate::files::check_move_aside(&opts.out).map_err(|e| BadInput(format!("--out: {e}")))?;
    } else {
        if opts.debug_structure {
            return Err(BadInput(
                "--debug-structure is for --format usd (the .hair and .tfx formats hold \
                 strands only)"
                    .into(),
            ));
        }
        if opts.out.exists() && !opts.out.is_dir() {
            return Err(BadInput(format!("--out {out}: exists and is not a folder")));
        }
    }
    Ok(())
}

/// The frame's strands as one vector per strand, reusing `out`'s buffers.
fn copy_strands(frame: &Frame, out: &mut Vec<Vec<[f32; 3]>>) {
    let n = frame.strands.len();
    out.resize_with(n, Vec::new);
    for (s, dst) in out.iter_mut().enumerate() {
        dst.clear();
        dst.extend_from_slice(frame.strands.strand(s));
    }
}

/// Writes one frame's file under a temporary name beside `path`, then renames it: a failed
/// write (a full disk) leaves nothing under `path`, and exits 2 naming it.
fn write_frame(
    path: &Path,
    format: ExportFormat,
    strands: &[Vec<[f32; 3]>],
    info: &str,
) -> Result<(), BadInput> {
    let tmp = path.with_extension(format!("{}.tmp", format.extension()));
    let written = match format {
        ExportFormat::Hair => hair_file::write_hair(&tmp, strands, info),
        ExportFormat::Tfx => tfx_write::write_tfx(&tmp, strands),
        ExportFormat::Usd => unreachable!("one USD layer is written by export_usd"),
    }
    .and_then(|()| std::fs::rename(&tmp, path));
    written.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        BadInput(format!("{}: cannot write: {e}", path.display()))
    })
}

/// `wisptree export`: runs and prints one summary line.
pub fn run(opts: &ExportOptions, progress: bool) -> anyhow::Result<()> {
    let s = export(opts, progress)?;
    if opts.format == ExportFormat::Usd {
        println!(
            "wrote {} frames ({} strands × {} points, {:.1} MB) of {} to {}",
            s.frames.div_ceil(u64::from(opts.every)),
            s.strands,
            s.points_per_strand,
            s.bytes as f64 / 1e6,
            s.frames,
            opts.out.display()
        );
        return Ok(());
    }
    println!(
        "wrote {} {} files ({} strands × {} points, {:.1} MB) of {} frames to {}",
        s.files.len(),
        opts.format.extension(),
        s.strands,
        s.points_per_strand,
        s.bytes as f64 / 1e6,
        s.frames,
        opts.out.display()
    );
    Ok(())
}
