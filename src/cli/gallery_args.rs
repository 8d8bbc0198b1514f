//! `wisptree gallery` flags.

use std::path::PathBuf;

use crate::app::gallery::GalleryCommand;

/// `wisptree gallery` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct GalleryArgs {
    /// The folder the PNGs and index.html go to (created if needed; a file already there that
    /// an earlier gallery did not write is kept as NAME.bak).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Shorten every experiment to a tenth of its length and make smaller pictures (a first
    /// look, or a test): the numbers then need not show the paper's point.
    #[arg(long)]
    pub quick: bool,
    /// No progress bar.
    #[arg(long)]
    pub no_progress: bool,
}

impl GalleryArgs {
    /// The plain command.
    pub fn command(&self) -> GalleryCommand {
        GalleryCommand {
            out: self.out.clone(),
            quick: self.quick,
            progress: !self.no_progress,
        }
    }
}

/// Runs `wisptree gallery` and reports what it wrote.
pub fn gallery(a: &GalleryArgs) -> anyhow::Result<()> {
    let done = crate::app::gallery::run(&a.command())?;
    println!(
        "wrote {} pictures and {}",
        done.pictures.len(),
        done.index.display()
    );
    if !done.failed.is_empty() {
        for (name, why) in &done.failed {
            eprintln!("wisptree: experiment {name} failed: {why}");
        }
        anyhow::bail!(
            "{} experiment(s) failed (the page shows why)",
            done.failed.len()
        );
    }
    Ok(())
}
