//! The command line: `wisptree [run] …`, `wisptree inspect STYLE`, `wisptree bench`.

use std::path::{Path, PathBuf};

use clap::{Parser, Subcommand};

use crate::model::HairModel;
use crate::style::{self, Link};

/// Exit code for bad input (a style, a path, a flag), like clap's own usage errors.
pub const EXIT_BAD_INPUT: i32 = 2;

#[derive(Debug, Parser)]
#[command(
    name = "wisptree",
    version,
    about = "Animate long hair with the Adaptive Wisp Tree (Bertails et al., SCA 2003) and watch \
             its wisps split and merge, live in the Rerun viewer or in a .rrd recording.",
    long_about = None,
    args_conflicts_with_subcommands = true
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// `wisptree` with no subcommand runs `wisptree run` with these arguments.
    #[command(flatten)]
    pub run: crate::run::RunArgs,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a style under a motion and stream it to Rerun (the default command).
    Run(crate::run::RunArgs),
    /// Build a style's multiresolution model and print its levels, nodes, strands and mass.
    Inspect(InspectArgs),
    /// Reproduce the AWT paper's §5.2 timing table: single-level against AWT on the four paper
    /// styles under the `lean` motion.
    Bench(crate::bench::BenchArgs),
    /// Simulate and write every n-th frame's strands as `.hair` or `.tfx` files.
    Export(crate::export::ExportArgs),
}

#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The style file (`styles/*.ron`).
    pub style: PathBuf,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// A user's mistake outside a style or motion file (a flag's value, a missing path): exit 2.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct BadInput(pub String);

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Inspect(a)) => inspect(&a),
        Some(Command::Run(a)) => crate::run::run(a),
        Some(Command::Bench(a)) => crate::bench::run(a),
        Some(Command::Export(a)) => crate::export::run(a),
        None => crate::run::run(cli.run),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("wisptree: {e:#}");
            match e.downcast_ref::<style::StyleError>() {
                Some(_) => EXIT_BAD_INPUT,
                None if e.downcast_ref::<crate::motion::MotionError>().is_some() => EXIT_BAD_INPUT,
                None if e.downcast_ref::<BadInput>().is_some() => EXIT_BAD_INPUT,
                None => 1,
            }
        }
    }
}

/// Loads a style and builds its model; the one way every command reads a style.
pub fn load_model(path: &Path) -> Result<(style::LoadedStyle, HairModel), style::StyleError> {
    let loaded = style::load(path)?;
    let model = HairModel::from_style(&loaded)?;
    Ok((loaded, model))
}

/// Summary numbers of a model, as `inspect --json` prints them.
#[derive(Debug, serde::Serialize)]
pub struct ModelSummary {
    pub style: String,
    pub levels: usize,
    pub gcs_per_level: Vec<usize>,
    pub nodes_per_level: Vec<usize>,
    pub strands: usize,
    pub cross_sections: usize,
    pub total_mass_kg: f64,
    pub radius_min_m: f64,
    pub radius_max_m: f64,
    pub max_strand_length_m: f64,
    pub link: String,
    pub trees: usize,
}

pub fn summarize(loaded: &style::LoadedStyle, m: &HairModel) -> ModelSummary {
    let (rmin, rmax) = m.radius_range();
    ModelSummary {
        style: loaded.path.display().to_string(),
        levels: m.level_count(),
        gcs_per_level: m.levels.iter().map(|l| l.gc_count()).collect(),
        nodes_per_level: (0..m.level_count()).map(|l| m.nodes_on_level(l)).collect(),
        strands: m.strands.len(),
        cross_sections: m.k,
        total_mass_kg: m.levels[0].mass.iter().sum(),
        radius_min_m: rmin,
        radius_max_m: rmax,
        max_strand_length_m: m.max_strand_length(),
        link: match m.link {
            Link::Rigid { .. } => "rigid".into(),
            Link::Spring { .. } => "spring".into(),
        },
        trees: m.levels[0].gc_count(),
    }
}

fn inspect(a: &InspectArgs) -> anyhow::Result<()> {
    let (loaded, model) = load_model(&a.style)?;
    model
        .notes
        .iter()
        .for_each(|n| eprintln!("wisptree: note: {n}"));
    let s = summarize(&loaded, &model);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
        return Ok(());
    }
    println!("style        {}", s.style);
    println!("level   GCs    nodes");
    for l in 0..s.levels {
        println!(
            "{l:>5} {:>5} {:>8}",
            s.gcs_per_level[l], s.nodes_per_level[l]
        );
    }
    println!("strands      {}", s.strands);
    println!("total mass   {:.4} kg", s.total_mass_kg);
    println!(
        "radius       {:.2} – {:.1} mm",
        s.radius_min_m * 1e3,
        s.radius_max_m * 1e3
    );
    println!("K            {} cross-sections per GC", s.cross_sections);
    println!("longest      {:.3} m", s.max_strand_length_m);
    println!("link         {}", s.link);
    Ok(())
}
