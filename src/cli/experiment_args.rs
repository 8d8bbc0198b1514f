//! `wisptree experiment` flags.

use std::path::PathBuf;

use crate::app::experiment::ExperimentCommand;

/// `wisptree experiment` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct ExperimentArgs {
    /// The experiment (see --list).
    #[arg(value_name = "NAME", required = true)]
    pub name: Option<String>,
    /// List the experiments with what each shows (instead of running one).
    #[arg(long, conflicts_with = "name")]
    pub list: bool,
    /// Record every run to this `.rrd` (one subtree `/runs/<label>` per run).
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    /// Write the numbers as JSON to FILE: `{"experiment": NAME, "runs": [{"label": .., ..}]}`.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the experiment's pictures (the rendering experiments' PNGs, awt-fig7's contact
    /// sheet) to this folder, created if needed (before the runs start); a picture already
    /// there is kept as `NAME.png.bak`. Default: `wisptree-experiments/<NAME>`.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
}

impl ExperimentArgs {
    /// The plain command.
    pub fn command(&self) -> ExperimentCommand {
        ExperimentCommand {
            name: self.name.clone(),
            list: self.list,
            save: self.save.clone(),
            json: self.json.clone(),
            out: self.out.clone(),
        }
    }
}
