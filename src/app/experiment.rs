//! `wisptree experiment NAME`: runs one of the papers' experiments, records every run under
//! `/runs/<label>/…` of one recording, prints the numbers it demonstrates, and writes them as
//! JSON.

use std::path::PathBuf;

use anyhow::Context as _;

use crate::error::BadInput;
use crate::experiment::{self, ExperimentOptions, ExperimentReport, FrameSink};
use crate::frame::Frame;
use crate::pipeline::{self, FrameBuilder};
use crate::report::AdaptEvent;
use crate::solver::Solver;
use crate::stream::sink::{open_sink, Recording, SinkChoice};
use crate::stream::{Logger, LoggerSetup};

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
}

/// One run's logger and frame state in the recording.
struct RunLog {
    label: String,
    logger: Logger,
    builder: FrameBuilder,
    frame: Frame,
    index: u64,
}

/// Logs every run's frames into one recording, each under `/runs/<label>`.
struct RecordingSink {
    rec: Recording,
    runs: Vec<RunLog>,
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
                let model = solver.model().clone();
                let mut setup = LoggerSetup::new(model.level_count() as u16, label, [0.0; 3]);
                setup.prefix = format!("/runs/{label}");
                setup.send_blueprint = false;
                self.runs.push(RunLog {
                    label: label.to_owned(),
                    logger: Logger::new(self.rec.clone(), &setup)?,
                    builder: FrameBuilder::new(
                        &model,
                        EXPERIMENT_STRANDS,
                        super::STRAND_SUBDIVISIONS,
                    ),
                    frame: Frame::default(),
                    index: 0,
                });
                self.runs.len() - 1
            }
        };
        let r = &mut self.runs[i];
        r.frame.events.clear();
        r.frame.events.extend_from_slice(events);
        r.builder.fill(solver, &mut r.frame);
        r.frame.index = r.index;
        pipeline::fill_stats(&mut r.frame, solver.params());
        r.logger.log_frame(&r.frame)?;
        r.index += 1;
        Ok(())
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
    let opts = ExperimentOptions::default();
    let runs = match &cmd.save {
        Some(path) => {
            let rec = open_sink(&SinkChoice::Save(path.clone()))?.rec;
            let mut sink = RecordingSink {
                rec: rec.clone(),
                runs: Vec::new(),
            };
            let runs = (def.run)(&opts, &mut sink)?;
            let labels: Vec<String> = runs.iter().map(|r| r.label.clone()).collect();
            crate::stream::send_runs_blueprint(&rec, &labels)?;
            for r in &sink.runs {
                r.logger.flush()?;
            }
            eprintln!("wrote {}", path.display());
            runs
        }
        None => (def.run)(&opts, &mut experiment::NoFrames)?,
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
