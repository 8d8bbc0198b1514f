//! `wisptree render` flags.

use std::path::PathBuf;

use crate::app::render_cmd::RenderCommand;
use crate::solver::SolverKind;

/// `wisptree render` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct RenderArgs {
    /// The hairstyle: a built-in name or a style file.
    #[arg(long, value_name = "NAME|PATH", default_value = crate::app::run::DEFAULT_STYLE)]
    pub style: String,
    /// Head and body motion: a preset or a `.ron` file.
    #[arg(long, value_name = "NAME|PATH", default_value = crate::app::run::DEFAULT_MOTION)]
    pub motion: String,
    /// The hair model.
    #[arg(long, value_name = "MODEL", default_value = "awt", value_parser = super::args::parse_model)]
    pub model: SolverKind,
    /// Simulated seconds.
    #[arg(long, value_name = "S", default_value = "1", value_parser = super::args::parse_seconds)]
    pub seconds: f64,
    /// The folder the PNG files go to (`frame_00000.png`, …; created if needed). An earlier
    /// render's files there are replaced; any other file in the way is kept as NAME.bak.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = super::args::parse_size)]
    pub size: (u32, u32),
}

impl RenderArgs {
    /// The plain command.
    pub fn command(&self) -> RenderCommand {
        RenderCommand {
            style: self.style.clone(),
            motion: self.motion.clone(),
            model: self.model,
            seconds: self.seconds,
            out: self.out.clone(),
            size: self.size,
        }
    }
}
