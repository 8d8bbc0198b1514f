//! `wisptree sweep` flags.

use std::path::PathBuf;

use clap::builder::TypedValueParser as _;

use super::args::{parse_seconds, parse_size, parse_strands, SinkArgs};
use crate::app::run::{DEFAULT_MOTION, DEFAULT_STYLE};
use crate::app::sweep::{SweepCommand, DEFAULT_SWEEP_STRANDS};
use crate::app::sweep_plan::{SweepLists, SweepSource};
use crate::stream::sink::SinkChoice;

/// `wisptree sweep` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// The hairstyle every run simulates (as `wisptree run --style`).
    #[arg(long, value_name = "NAME|PATH", default_value = DEFAULT_STYLE)]
    pub style: String,

    /// The head and body motion of every run (as `wisptree run --motion`).
    #[arg(long, value_name = "NAME|PATH", default_value = DEFAULT_MOTION)]
    pub motion: String,

    /// Simulated seconds of every run.
    #[arg(long, value_name = "S", default_value_t = 10.0, value_parser = parse_seconds)]
    pub seconds: f64,

    /// Split thresholds to sweep (`sim.split_threshold`, N·m·kg⁻¹, ≥ 0), comma-separated:
    /// `--split 0.1,0.2,0.3` (the same as `--set split_threshold=0.1,0.2,0.3`).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub split: Option<String>,

    /// Merge velocity thresholds to sweep (`sim.merge_velocity`, m/s, ≥ 0), comma-separated
    /// (the same as `--set merge_velocity=…`).
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub merge: Option<String>,

    /// A tunable of the swept model to sweep, by the name in its table, with its values:
    /// `--set viscosity=0.5,50` (layered), `--set link_strength=100,300,900` (guides),
    /// `--set split_threshold=0.1,0.2` (awt). Repeatable: every combination runs. The names
    /// and ranges are the control page's sliders (`wisptree sweep --help` lists them below).
    #[arg(long, value_name = "NAME=LIST", allow_hyphen_values = true)]
    pub set: Vec<String>,

    /// Models to sweep, comma-separated: awt, single-level, layered, guides (default: awt).
    #[arg(long, value_name = "LIST")]
    pub model: Option<String>,

    /// Named variants instead of the lists: a RON file
    /// `[(label: "soft", split: 0.1, merge: 0.05, model: "awt"), …]` (every field optional).
    #[arg(long, value_name = "FILE.ron", conflicts_with_all = ["split", "merge", "model", "set"])]
    pub variants: Option<PathBuf>,

    /// Run configuration K alone (from 0, in the order --list prints), for a batch scheduler:
    /// every part of one sweep has the same recording id, so `rerun rrd merge` joins them.
    #[arg(long, value_name = "K")]
    pub only: Option<usize>,

    /// Print the configurations, numbered as --only counts them, and stop.
    #[arg(long)]
    pub list: bool,

    /// Render the hair of every frame of every run (off in sweeps: it costs more than the
    /// simulation).
    #[arg(long)]
    pub render: bool,

    /// Size of the rendered images with --render, WIDTHxHEIGHT pixels.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)]
    pub render_size: (u32, u32),

    /// Hair strands drawn per frame of each run.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_SWEEP_STRANDS, value_parser = parse_strands)]
    pub strands: usize,

    /// Runs at once (default: one per core). The results do not depend on it.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(i64).range(1..1025).map(|v| v as usize))]
    pub jobs: Option<usize>,

    /// No progress bar.
    #[arg(long)]
    pub no_progress: bool,

    /// Where the recording goes.
    #[command(flatten)]
    pub sink: SinkArgs,

    /// Serve the sweep in the Rerun web viewer (a gRPC server and the viewer, on free ports of
    /// --bind), and keep serving it after the runs end, until Ctrl-C.
    #[arg(long, conflicts_with_all = ["spawn", "connect", "save", "stdout"])]
    pub web: bool,

    /// The address --web listens on (only this machine by default).
    #[arg(long, value_name = "IP", default_value = "127.0.0.1", requires = "web")]
    pub bind: std::net::IpAddr,
}

impl SweepArgs {
    /// The plain command.
    pub fn command(&self) -> SweepCommand {
        let source = match &self.variants {
            Some(p) => SweepSource::Variants(p.clone()),
            None => SweepSource::Lists(SweepLists {
                model: self.model.clone(),
                split: self.split.clone(),
                merge: self.merge.clone(),
                set: self.set.clone(),
            }),
        };
        SweepCommand {
            style: self.style.clone(),
            motion: self.motion.clone(),
            seconds: self.seconds,
            source,
            only: self.only,
            list: self.list,
            render: self.render.then_some(self.render_size),
            strands: self.strands,
            jobs: self.jobs,
            progress: !self.no_progress,
            sink: if self.web {
                SinkChoice::Web(self.bind)
            } else {
                self.sink.choice()
            },
        }
    }
}
