//! `wisptree experiment NAME`: runs one of the papers' experiments, records every run under
//! `/runs/<label>/…` of one recording, prints the numbers it demonstrates, and writes them as
//! JSON.

use std::path::PathBuf;

use anyhow::Context as _;

use super::runs_log::RunLog;
use crate::error::BadInput;
use crate::experiment::{self, ExperimentOptions, ExperimentReport, FrameSink};
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
            // In the experiment's order; a run that logged no frame has no view.
            let views: Vec<_> = runs
                .iter()
                .filter_map(|r| sink.runs.iter().find(|l| l.label == r.label))
                .map(|l| l.view(false))
                .collect();
            super::runs_log::send_layout(&rec, &views, None)?;
            for r in &sink.runs {
                r.flush()?;
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
