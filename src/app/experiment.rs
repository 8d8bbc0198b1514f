//! `wisptree experiment NAME`: runs one of the papers' experiments, records every run under
//! `/runs/<label>/…` of one recording, prints the numbers it demonstrates, and writes them as
//! JSON.

use std::path::PathBuf;

use anyhow::Context as _;

use super::runs_log::RunLog;
use crate::error::BadInput;
use crate::experiment::{self, ExperimentOptions, ExperimentReport, FrameExtras, FrameSink};
use crate::frame::StrandBuf;
use crate::render::Image;
use crate::report::AdaptEvent;
use crate::solver::Solver;
use crate::stream::sink::{open_sink, Recording, SinkChoice};
use crate::stream::{BlueprintCamera, RunView};

/// Strands drawn per frame of an experiment (small scenes: all of them, up to this).
const EXPERIMENT_STRANDS: usize = 2000;

/// What `wisptree experiment` is asked to do.
#[derive(Debug, Clone, Default)]
pub struct ExperimentCommand {
    /// The experiment's name; `None` with `list`.
    pub name: Option<String>,
    /// List the experiments instead.
    pub list: bool,
    /// Record the runs here.
    pub save: Option<PathBuf>,
    /// Write the numbers as JSON here.
    pub json: Option<PathBuf>,
    /// Write the experiment's pictures here; `None`: [`DEFAULT_OUT`]`/<name>`.
    pub out: Option<PathBuf>,
}

/// Where an experiment's pictures go without `--out`.
pub const DEFAULT_OUT: &str = "wisptree-experiments";

/// Logs every run's frames into one recording, each under `/runs/<label>`.
struct RecordingSink {
    rec: Recording,
    /// The runs that step a solver, in order.
    runs: Vec<RunLog>,
    /// The labels of the solver runs that logged a rendered frame (their cells show it).
    rendered: Vec<String>,
    /// The labels of the runs whose 3D view follows the head.
    followed: Vec<String>,
    /// Labels of the runs whose frames carry a step's counters (active nodes, stage times):
    /// only those are plotted (a guide or layered experiment that drives its solver itself
    /// has none, and its plots were flat zeros).
    counted: Vec<String>,
    /// The runs of a rendering experiment (no solver), in order.
    render_runs: Vec<RunView>,
}

impl RecordingSink {
    /// The layout's view of solver run `l`.
    fn view(&self, l: &RunLog) -> RunView {
        let mut v = l.view(self.rendered.contains(&l.label));
        v.stats = self.counted.contains(&l.label);
        if self.followed.contains(&l.label) {
            v.track = Some(format!("/runs/{}{}", l.label, crate::stream::paths::SCALP));
        }
        v
    }

    /// The views of every run so far (an experiment's runs either all step a solver or all
    /// render without one).
    fn views(&self) -> Vec<RunView> {
        let mut views: Vec<_> = self.runs.iter().map(|l| self.view(l)).collect();
        views.extend(self.render_runs.iter().cloned());
        views
    }

    /// The layout's view of run `label`, if it logged a frame.
    fn view_of(&self, label: &str) -> Option<RunView> {
        match self.runs.iter().find(|l| l.label == label) {
            Some(l) => Some(self.view(l)),
            None => self.render_runs.iter().find(|v| v.label == label).cloned(),
        }
    }

    fn frame_with(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
        extras: FrameExtras<'_>,
    ) -> anyhow::Result<()> {
        let new_render = extras.image.is_some() && !self.rendered.iter().any(|l| l == label);
        let new_follow = extras.follow_head && !self.followed.iter().any(|l| l == label);
        let new_counted = extras.counters.is_some() && !self.counted.iter().any(|l| l == label);
        if new_counted {
            self.counted.push(label.to_owned());
        }
        if new_render || new_follow || (new_counted && self.runs.iter().any(|r| r.label == label)) {
            if new_render {
                self.rendered.push(label.to_owned());
            }
            if new_follow {
                self.followed.push(label.to_owned());
            }
            super::runs_log::send_layout(&self.rec, &self.views(), None)?;
        }
        let i = match self.runs.iter().position(|r| r.label == label) {
            Some(i) => i,
            None => {
                // Framed on this run's own hair: an experiment scene is not a head.
                let camera = super::runs_log::solver_camera(solver);
                let model = solver.model().clone();
                let slot = self.runs.len();
                // A whole head of hair (awt-fig7's styles) is drawn as `wisptree run` draws
                // it: 2000 of its 10,000 strands in four runs made a recording of 300 MB.
                let strands = if model.strands.len() > EXPERIMENT_STRANDS {
                    super::run::DEFAULT_STRANDS
                } else {
                    EXPERIMENT_STRANDS
                };
                self.runs.push(RunLog::new(
                    &self.rec, label, slot, &model, strands, camera,
                )?);
                // The layout so far, at once: a viewer opening the file (or still loading it)
                // shows the runs' views rather than its own guess; the last one sent, after
                // the last run, has them all.
                super::runs_log::send_layout(&self.rec, &self.views(), None)?;
                slot
            }
        };
        let r = &mut self.runs[i];
        r.frame.events.clear();
        r.frame.events.extend_from_slice(events);
        if let Some(c) = extras.counters {
            r.frame.counters.clone_from(c);
            // The layout's "ms per step" plot: the frame's stage times, per step.
            r.frame.step_ms =
                c.times.total().as_secs_f64() * 1e3 / solver.steps_per_frame().max(1) as f64;
        }
        r.frame.image = extras.image.map(|img| crate::frame::EncodedImage {
            jpeg: crate::render::encode_jpeg(img, super::render_thread::JPEG_QUALITY),
            width: img.width,
            height: img.height,
            shows: None,
        });
        r.log(solver)
    }

    fn rendered(
        &mut self,
        label: &str,
        index: u64,
        strands: &StrandBuf,
        image: &Image,
    ) -> anyhow::Result<()> {
        if !self.render_runs.iter().any(|v| v.label == label) {
            let (lo, hi) = crate::render::bounds(&strands.points);
            let c = crate::render::Camera::framing(lo, hi, crate::render::camera::DEFAULT_VIEW);
            self.render_runs.push(RunView {
                label: label.to_owned(),
                camera: BlueprintCamera {
                    eye: c.eye,
                    target: c.target,
                },
                render: true,
                stats: false,
                track: None,
            });
            super::runs_log::send_layout(&self.rec, &self.views(), None)?;
        }
        crate::stream::log_rendered(&self.rec, label, index, strands, EXPERIMENT_STRANDS, image)
    }
}

/// Writes an experiment's pictures as `<folder>/<name>.png`; a file already there is first
/// moved aside to `<name>.png.bak` ([`crate::files::move_aside`]: never overwrites a file
/// wisptree did not write).
pub struct PictureSink {
    /// The folder (`--out`, or [`DEFAULT_OUT`]`/<name>`).
    pub folder: PathBuf,
    /// The files written.
    pub written: Vec<PathBuf>,
    /// The folders [`PictureSink::open`] created, deepest first: removed again if the
    /// experiment makes no picture (most experiments make none).
    created: Vec<PathBuf>,
}

impl PictureSink {
    /// Pictures into `folder`, created now: a folder that cannot be made is refused (bad
    /// input) before the runs start, not after minutes of simulation.
    pub fn open(folder: PathBuf) -> anyhow::Result<PictureSink> {
        let mut created = Vec::new();
        let mut p = folder.as_path();
        while !p.as_os_str().is_empty() && std::fs::symlink_metadata(p).is_err() {
            created.push(p.to_path_buf());
            p = p.parent().unwrap_or(std::path::Path::new(""));
        }
        std::fs::create_dir_all(&folder).map_err(|e| {
            BadInput(format!(
                "--out {}: cannot create the folder: {e}",
                folder.display()
            ))
        })?;
        Ok(PictureSink {
            folder,
            written: Vec::new(),
            created,
        })
    }

    /// Writes `image` as `name.png`.
    pub fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        let path = self.folder.join(format!("{name}.png"));
        if let Some(bak) = crate::files::move_aside(&path).context("--out")? {
            eprintln!("kept the earlier {} as {}", path.display(), bak.display());
        }
        crate::render::write_png(image, &path)
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())))?;
        eprintln!("wrote {}", path.display());
        self.written.push(path);
        Ok(())
    }
}

impl Drop for PictureSink {
    /// Removes the folders [`PictureSink::open`] made if no picture went into them (also when
    /// the experiment failed).
    fn drop(&mut self) {
        if self.written.is_empty() {
            for dir in &self.created {
                // Only an empty folder goes; one the user filled meanwhile stays.
                let _ = std::fs::remove_dir(dir);
            }
        }
    }
}

/// Where the frames go: the recording (with `--save`), and the pictures to `--out`.
struct AppSink {
    rec: Option<RecordingSink>,
    pictures: PictureSink,
}

impl FrameSink for AppSink {
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
    ) -> anyhow::Result<()> {
        self.frame_with(label, solver, events, FrameExtras::default())
    }

    fn frame_with(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
        extras: FrameExtras<'_>,
    ) -> anyhow::Result<()> {
        match &mut self.rec {
            Some(r) => r.frame_with(label, solver, events, extras),
            None => Ok(()),
        }
    }

    fn rendered(
        &mut self,
        label: &str,
        index: u64,
        strands: &StrandBuf,
        image: &Image,
    ) -> anyhow::Result<()> {
        match &mut self.rec {
            Some(r) => r.rendered(label, index, strands, image),
            None => Ok(()),
        }
    }

    /// Rendered frames are shown only in a recording.
    fn wants_images(&self) -> bool {
        self.rec.is_some()
    }

    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        self.pictures.picture(name, image)
    }
}

/// `wisptree experiment`.
pub fn run(cmd: &ExperimentCommand) -> anyhow::Result<()> {
    let all = experiment::all();
    if cmd.list || cmd.name.is_none() {
        println!("experiments (wisptree experiment NAME [--save FILE] [--json FILE] [--out DIR]):");
        for e in &all {
            println!("  {:<14} {}", e.name, e.description);
        }
        if all.is_empty() {
            println!("  (none yet)");
        }
        return Ok(());
    }
    let name = cmd.name.as_deref().unwrap_or_default();
    let def = experiment::find(name).ok_or_else(|| {
        BadInput(format!(
            "no experiment `{name}` (known: {})",
            all.iter().map(|e| e.name).collect::<Vec<_>>().join(", ")
        ))
    })?;
    // Said before the experiment rather than after it.
    if let Some(path) = &cmd.json {
        crate::files::check_move_aside(path).context("--json")?;
    }
    if let Some(path) = &cmd.save {
        crate::files::check_move_aside(path).context("--save")?;
    }
    let opts = ExperimentOptions::default();
    let out = cmd
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(DEFAULT_OUT).join(def.name));
    let pictures = PictureSink::open(out)?;
    let runs = match &cmd.save {
        Some(path) => {
            let rec = open_sink(&SinkChoice::Save(path.clone()))?.rec;
            let mut sink = AppSink {
                rec: Some(RecordingSink {
                    rec: rec.clone(),
                    runs: Vec::new(),
                    rendered: Vec::new(),
                    followed: Vec::new(),
                    counted: Vec::new(),
                    render_runs: Vec::new(),
                }),
                pictures,
            };
            let runs = (def.run)(&opts, &mut sink)?;
            let rec_sink = sink.rec.expect("set above");
            // In the experiment's order; a run that logged no frame has no view.
            let views: Vec<_> = runs
                .iter()
                .filter_map(|r| rec_sink.view_of(&r.label))
                .collect();
            super::runs_log::send_layout(&rec, &views, None)?;
            for r in &rec_sink.runs {
                r.flush()?;
            }
            rec.stream()
                .flush_blocking()
                .map_err(|e| anyhow::anyhow!("flushing {}: {e}", path.display()))?;
            eprintln!("wrote {}", path.display());
            runs
        }
        None => (def.run)(
            &opts,
            &mut AppSink {
                rec: None,
                pictures,
            },
        )?,
    };
    let report = ExperimentReport {
        experiment: def.name.to_owned(),
        runs,
    };
    println!("{}: {}", def.name, def.description);
    for r in &report.runs {
        let metrics: Vec<String> = r
            .metrics
            .iter()
            .map(|(k, v)| format!("{k} = {v}"))
            .collect();
        println!("  {:<14} {}", r.label, metrics.join(", "));
    }
    println!("expected: {}", def.expectation);
    if let Some(path) = &cmd.json {
        let text = serde_json::to_string_pretty(&report)?;
        if let Some(bak) = crate::files::move_aside(path).context("--json")? {
            eprintln!("kept the earlier {} as {}", path.display(), bak.display());
        }
        std::fs::write(path, text + "\n")
            .with_context(|| format!("writing --json {}", path.display()))?;
    }
    Ok(())
}
