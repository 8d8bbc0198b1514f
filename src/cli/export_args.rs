//! `wisptree export` flags.

use std::path::PathBuf;

use crate::app::export::{ExportFormat, ExportOptions};
use crate::solver::SolverKind;

/// `wisptree export` on the command line.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// The hairstyle: a built-in name or a style file.
    #[arg(long, value_name = "NAME|PATH", default_value = crate::app::run::DEFAULT_STYLE)]
    pub style: String,
    /// Head and body motion: a preset (still, lean, run, jump, shake, stop) or a `.ron` file.
    #[arg(long, value_name = "NAME|PATH", default_value = crate::app::run::DEFAULT_MOTION)]
    pub motion: String,
    /// The hair model that simulates.
    #[arg(long, value_name = "MODEL", default_value = "awt", value_parser = SolverKind::parse)]
    pub model: SolverKind,
    /// Simulated seconds.
    #[arg(long, value_name = "S", default_value = "1", value_parser = super::args::parse_seconds)]
    pub seconds: f64,
    /// File format.
    #[arg(long, value_enum, default_value_t = ExportFormat::Hair)]
    pub format: ExportFormat,
    /// The folder the files are written to (created if needed; an earlier export's files there
    /// are replaced, any other file in the way is kept as NAME.bak); for `usd`, the layer's
    /// file (FILE.usda; an existing one is kept as FILE.usda.bak).
    #[arg(long, value_name = "DIR|FILE")]
    pub out: PathBuf,
    /// Write every n-th frame only (frames 0, n, 2n, …).
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub every: u32,
    /// No progress bar.
    #[arg(long)]
    pub no_progress: bool,
    /// `usd` only: also write the model's active nodes (Points) and segments (linear
    /// BasisCurves) under /wisptree/structure, the AWT paper's Figure 4 display.
    #[arg(long)]
    pub debug_structure: bool,
}

impl ExportArgs {
    /// The plain options.
    pub fn options(&self) -> ExportOptions {
        ExportOptions {
            style: self.style.clone(),
            motion: self.motion.clone(),
            model: self.model,
            seconds: self.seconds,
            format: self.format,
            out: self.out.clone(),
            every: self.every,
            debug_structure: self.debug_structure,
        }
    }
}
