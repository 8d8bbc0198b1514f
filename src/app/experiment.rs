//! `wisptree experiment NAME`: runs one of the papers' experiments, records every run under
//! `/runs/<label>/…` of one recording, prints the numbers it demonstrates, and writes them as
//! JSON.

use std::path::PathBuf;

use anyhow::Context as _;

use super::runs_log::RunLog;
use crate::error::BadInput;
use crate::experiment::{self, ExperimentOptions, ExperimentReport, FrameSink};
use crate::frame::StrandBuf;
use crate::render::{write_png, Image};
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
    runs: Vec<RunLog>,
    /// The runs of a rendering experiment (no solver), in order.
    rendered: Vec<RunView>,
}

/// Where the frames go: the recording (with `--save`), and the pictures to `out`.
struct AppSink {
    rec: Option<RecordingSink>,
    out: PathBuf,
}

impl FrameSink for AppSink {
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
    ) -> anyhow::Result<()> {
        match &mut self.rec {
            Some(r) => r.frame(label, solver, events),
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

    fn picture(&mut self, stem: &str, image: &Image) -> anyhow::Result<()> {
        std::fs::create_dir_all(&self.out).map_err(|e| {
            BadInput(format!(
                "--out {}: cannot create the folder: {e}",
                self.out.display()
            ))
        })?;
        let path = self.out.join(format!("{stem}.png"));
        // A file already there is kept as `<stem>.png.bak` (the last one only).
        if path.exists() {
            let bak = self.out.join(format!("{stem}.png.bak"));
            std::fs::rename(&path, &bak)
                .with_context(|| format!("moving {} aside", path.display()))?;
        }
        write_png(image, &path).with_context(|| format!("writing {}", path.display()))?;
        eprintln!("wrote {}", path.display());
        Ok(())
    }
}

impl FrameSink for RecordingSink {
    fn frame(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
    ) -> anyhow::Result<()> {
        let i = match self.runs.iter().position(|r| r.label == label) {
            Some(i) => i,
            None => {
                // Framed on this run's own hair: an experiment scene is not a head.
                let camera = super::runs_log::solver_camera(solver);
                let model = solver.model().clone();
                let slot = self.runs.len();
                self.runs.push(RunLog::new(
                    &self.rec,
                    label,
                    slot,
                    &model,
                    EXPERIMENT_STRANDS,
                    camera,
                )?);
                // The layout so far, at once: a viewer opening the file (or still loading it)
                // shows the runs' views rather than its own guess; the last one sent, after
                // the last run, has them all.
                let views: Vec<_> = self.runs.iter().map(|l| l.view(false)).collect();
                super::runs_log::send_layout(&self.rec, &views, None)?;
                slot
            }
        };
        let r = &mut self.runs[i];
        r.frame.events.clear();
        r.frame.events.extend_from_slice(events);
        r.log(solver)
    }

    fn rendered(
        &mut self,
        label: &str,
        index: u64,
        strands: &StrandBuf,
        image: &Image,
    ) -> anyhow::Result<()> {
        if !self.rendered.iter().any(|v| v.label == label) {
            let (lo, hi) = crate::render::bounds(&strands.points);
            let c = crate::render::Camera::framing(lo, hi, crate::render::camera::DEFAULT_VIEW);
            self.rendered.push(RunView {
                label: label.to_owned(),
                camera: BlueprintCamera {
                    eye: c.eye,
                    target: c.target,
                },
                render: true,
                stats: false,
            });
            super::runs_log::send_layout(&self.rec, &self.rendered, None)?;
        }
        crate::stream::log_rendered(&self.rec, label, index, strands, EXPERIMENT_STRANDS, image)
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
    let opts = ExperimentOptions::default();
    let out = cmd
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(DEFAULT_OUT).join(def.name));
    let runs = match &cmd.save {
        Some(path) => {
            let rec = open_sink(&SinkChoice::Save(path.clone()))?.rec;
            let mut sink = AppSink {
                rec: Some(RecordingSink {
                    rec: rec.clone(),
                    runs: Vec::new(),
                    rendered: Vec::new(),
                }),
                out,
            };
            let runs = (def.run)(&opts, &mut sink)?;
            let sink = sink.rec.expect("set above");
            // In the experiment's order; a run that logged no frame has no view.
            let views: Vec<_> = runs
                .iter()
                .filter_map(|r| {
                    let solver_run = sink.runs.iter().find(|l| l.label == r.label);
                    let rendered = sink.rendered.iter().find(|v| v.label == r.label);
                    solver_run
                        .map(|l| l.view(false))
                        .or_else(|| rendered.cloned())
                })
                .collect();
            super::runs_log::send_layout(&rec, &views, None)?;
            for r in &sink.runs {
                r.flush()?;
            }
            rec.stream()
                .flush_blocking()
                .map_err(|e| anyhow::anyhow!("flushing {}: {e}", path.display()))?;
            eprintln!("wrote {}", path.display());
            runs
        }
        None => (def.run)(&opts, &mut AppSink { rec: None, out })?,
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
