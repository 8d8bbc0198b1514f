//! The command line: `wisptree [run] …`, `wisptree inspect`, `wisptree styles`,
//! `wisptree bench`, `wisptree experiment`, `wisptree gallery`, …. Turns arguments into plain option structs, runs the command, and maps
//! errors to exit codes (2 for bad input). Nothing else in the crate uses this module.

mod args;
mod bench_args;
mod experiment_args;
mod export_args;
mod gallery_args;
mod inspect;
mod render_args;
mod styles;
mod sweep_args;

use clap::{CommandFactory as _, FromArgMatches as _, Parser, Subcommand};

pub use args::{RunArgs, SinkArgs};
pub use bench_args::BenchArgs;
pub use experiment_args::ExperimentArgs;
pub use export_args::ExportArgs;
pub use gallery_args::GalleryArgs;
pub use inspect::{summarize, InspectArgs, ModelSummary};
pub use render_args::RenderArgs;
pub use styles::StylesArgs;
pub use sweep_args::SweepArgs;

pub use crate::error::{BadInput, EXIT_BAD_INPUT};

/// The whole command line.
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
    /// The subcommand (default: run).
    #[command(subcommand)]
    pub command: Option<Command>,
    /// `wisptree` with no subcommand runs `wisptree run` with these arguments.
    #[command(flatten)]
    pub run: RunArgs,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Simulate a style under a motion and stream it to Rerun (the default command).
    Run(RunArgs),
    /// Build a style's multiresolution model and print its levels, nodes, strands and mass.
    Inspect(InspectArgs),
    /// List the built-in styles, or write one to a file to edit.
    Styles(StylesArgs),
    /// Reproduce the AWT paper's §5.2 timing table (single-level against AWT on the four paper
    /// styles under the `lean` motion), and time other solvers with --solvers.
    Bench(BenchArgs),
    /// Simulate and write every n-th frame's strands as `.hair` or `.tfx` files, or as one USD
    /// layer (`.usda`).
    Export(ExportArgs),
    /// Simulate and write the rendered hair of every frame as PNG files.
    Render(RenderArgs),
    /// Run one of the papers' experiments, record it and print the number it demonstrates.
    Experiment(ExperimentArgs),
    /// Run several configurations (split and merge thresholds, models, or named variants) side
    /// by side into one recording, one subtree `/runs/<label>` each, and print their numbers.
    Sweep(SweepArgs),
    /// Render every built-in style and every experiment's key frames into PNGs, with an
    /// index.html showing each experiment's numbers beside the paper's claim.
    Gallery(GalleryArgs),
}

/// The command line as clap parses it: [`Cli`], where every option that takes a value also
/// takes a negative number, so that `--seconds -1` gets the option's own range check instead of
/// clap's "unexpected argument '-1'".
pub fn command() -> clap::Command {
    negative_numbers_are_values(Cli::command())
        .mut_subcommand("sweep", |c| c.after_help(tunables_help()))
}

/// Every model's table of tunables, for `sweep --help` (`--set NAME=…`).
fn tunables_help() -> String {
    let mut s = String::from(
        "Tunables for --set, by model (name: range and unit, as on the control page):\n",
    );
    for kind in crate::solver::SolverKind::ALL {
        s.push_str(&format!("  {kind}:\n"));
        for t in kind.tunables() {
            s.push_str(&format!(
                "    {}: {} – {} {}{}\n",
                t.name,
                t.min,
                t.max,
                t.unit,
                if t.log { ", log scale" } else { "" }
            ));
        }
    }
    s
}

/// `cmd` and its subcommands with `allow_negative_numbers` on every option that takes a value.
fn negative_numbers_are_values(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| {
        if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(negative_numbers_are_values)
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    let result = match cli.command {
        Some(Command::Inspect(a)) => inspect::inspect(&a),
        Some(Command::Styles(a)) => styles::styles(&a),
        Some(Command::Run(a)) => crate::app::run(a.options()),
        Some(Command::Bench(a)) => a.options().and_then(|o| crate::bench::run(&o)),
        Some(Command::Render(a)) => crate::app::render_cmd::run(&a.command()).map(|_| ()),
        Some(Command::Experiment(a)) => crate::app::experiment::run(&a.command()),
        Some(Command::Sweep(a)) => crate::app::sweep::run(&a.command()),
        Some(Command::Gallery(a)) => gallery_args::gallery(&a),
        Some(Command::Export(a)) => crate::app::export::run(&a.options(), !a.no_progress),
        None => crate::app::run(cli.run.options()),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("wisptree: {e:#}");
            crate::error::exit_code(&e)
        }
    }
}
