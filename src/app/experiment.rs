//! `wisptree experiment NAME`: runs one of the papers' experiments, records every run under
//! `/runs/<label>/…` of one recording, prints the numbers it demonstrates, and writes them as
//! JSON.

use std::path::PathBuf;

use anyhow::Context as _;

use super::runs_log::RunLog;
use crate::error::BadInput;
use crate::experiment::{self, ExperimentOptions, ExperimentReport, FrameExtras, FrameSink};
use crate::render::Image;
use crate::report::AdaptEvent;
use crate::solver::Solver;
use crate::stream::sink::{open_sink, Recording, SinkChoice};

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
    /// Write the pictures the experiment makes (`awt-fig7`'s contact sheet) into this folder.
    pub pictures: Option<PathBuf>,
}

/// Logs every run's frames into one recording, each under `/runs/<label>`.
struct RecordingSink {
    rec: Recording,
    runs: Vec<RunLog>,
    /// The labels of the runs that logged a rendered frame (their cells show it).
    rendered: Vec<String>,
    /// The labels of the runs whose 3D view follows the head.
    followed: Vec<String>,
    pictures: PictureSink,
}

impl RecordingSink {
    /// The layout's view of run `l`.
    fn view(&self, l: &RunLog) -> crate::stream::RunView {
        let mut v = l.view(self.rendered.contains(&l.label));
        if self.followed.contains(&l.label) {
            v.track = Some(format!("/runs/{}{}", l.label, crate::stream::paths::SCALP));
        }
        v
    }
}

impl FrameSink for RecordingSink {
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
    ) -> anyhow::Result<()> {
        self.frame_with(label, solver, events, FrameExtras::default())
    }

    fn wants_images(&self) -> bool {
        true
    }

    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        self.pictures.picture(name, image)
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
        if new_render || new_follow {
            if new_render {
                self.rendered.push(label.to_owned());
            }
            if new_follow {
                self.followed.push(label.to_owned());
            }
            let views: Vec<_> = self.runs.iter().map(|l| self.view(l)).collect();
            super::runs_log::send_layout(&self.rec, &views, None)?;
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
                let views: Vec<_> = self.runs.iter().map(|l| self.view(l)).collect();
                super::runs_log::send_layout(&self.rec, &views, None)?;
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
        });
        r.log(solver)
    }
}

/// Writes an experiment's pictures as `<folder>/<name>.png` (a file already there is kept as
/// `<name>.png.bak`), or, without a folder, says once how to get them.
pub struct PictureSink {
    /// The folder (`--pictures`).
    pub folder: Option<PathBuf>,
    /// The files written.
    pub written: Vec<PathBuf>,
    told: bool,
}

impl PictureSink {
    /// Pictures into `folder`, created if needed; `None`: a note on stderr instead.
    pub fn new(folder: Option<PathBuf>) -> PictureSink {
        PictureSink {
            folder,
            written: Vec::new(),
            told: false,
        }
    }

    /// Writes `image` as `name.png`.
    pub fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        let Some(dir) = &self.folder else {
            if !self.told {
                eprintln!("wisptree: this experiment makes a picture ({name}.png): --pictures DIR writes it");
                self.told = true;
            }
            return Ok(());
        };
        std::fs::create_dir_all(dir).map_err(|e| {
            BadInput(format!(
                "--pictures {}: cannot create the folder: {e}",
                dir.display()
            ))
        })?;
        let path = dir.join(format!("{name}.png"));
        if let Some(bak) = super::backup::move_aside(&path).context("--pictures")? {
            eprintln!("kept the earlier {} as {}", path.display(), bak.display());
        }
        crate::render::write_png(image, &path)
            .map_err(|e| BadInput(format!("--pictures: cannot write {}: {e}", path.display())))?;
        eprintln!("wrote {}", path.display());
        self.written.push(path);
        Ok(())
    }
}

/// A sink for runs without a recording: drops the frames, keeps the pictures.
struct PicturesOnly(PictureSink);

impl FrameSink for PicturesOnly {
    fn frame(&mut self, _: &str, _: &mut dyn Solver, _: &[AdaptEvent]) -> anyhow::Result<()> {
        Ok(())
    }

    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        self.0.picture(name, image)
    }
}

/// `wisptree experiment`.
pub fn run(cmd: &ExperimentCommand) -> anyhow::Result<()> {
    let all = experiment::all();
    if cmd.list || cmd.name.is_none() {
        println!("experiments (wisptree experiment NAME [--save FILE] [--json FILE]):");
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
    if let Some(dir) = &cmd.pictures {
        // Before the runs: a bad folder is refused at once, not after minutes of simulation.
        std::fs::create_dir_all(dir).map_err(|e| {
            BadInput(format!(
                "--pictures {}: cannot create the folder: {e}",
                dir.display()
            ))
        })?;
    }
    let opts = ExperimentOptions::default();
    let runs = match &cmd.save {
        Some(path) => {
            let rec = open_sink(&SinkChoice::Save(path.clone()))?.rec;
            let mut sink = RecordingSink {
                rec: rec.clone(),
                runs: Vec::new(),
                rendered: Vec::new(),
                followed: Vec::new(),
                pictures: PictureSink::new(cmd.pictures.clone()),
            };
            let runs = (def.run)(&opts, &mut sink)?;
            // In the experiment's order; a run that logged no frame has no view.
            let views: Vec<_> = runs
                .iter()
                .filter_map(|r| sink.runs.iter().find(|l| l.label == r.label))
                .map(|l| sink.view(l))
                .collect();
            super::runs_log::send_layout(&rec, &views, None)?;
            for r in &sink.runs {
                r.flush()?;
            }
            eprintln!("wrote {}", path.display());
            runs
        }
        None => (def.run)(
            &opts,
            &mut PicturesOnly(PictureSink::new(cmd.pictures.clone())),
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
        std::fs::write(path, text + "\n")
            .with_context(|| format!("writing --json {}", path.display()))?;
    }
    Ok(())
}
