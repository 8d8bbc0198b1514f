//! `wisptree bench` flags, checked into [`BenchOptions`].

use std::path::PathBuf;

use crate::bench::{BenchOptions, PAPER_MODELS, PIPELINE_STRANDS};
use crate::error::BadInput;
use crate::solver::SolverKind;
use crate::style::builtin::StyleSource;

/// Most passes `--runs` takes (each is the whole matrix: minutes).
const MAX_LIVE_RUNS: u32 = 20;

/// `wisptree bench` arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {
    /// Short run (0.5 s simulated per style and solver) for smoke tests.
    #[arg(long)]
    pub quick: bool,
    /// Also write the numbers as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Simulated seconds per style and solver (default 10, or 0.5 with --quick).
    #[arg(long, value_name = "S")]
    pub seconds: Option<f64>,
    /// Comma-separated hairstyles: built-in names (see `wisptree styles`), names of
    /// `<--styles DIR>/<name>.ron`, or paths to `.ron` files.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "short,short_curly,long,long_curly"
    )]
    pub models: Vec<String>,
    /// Comma-separated solvers timed on every style (awt, single-level). The default is the
    /// AWT paper's §5.2 table.
    #[arg(long, value_delimiter = ',', default_value = "awt,single-level")]
    pub solvers: Vec<String>,
    /// Directory of style files that `--models` names refer to (default: the built-in styles).
    #[arg(long, value_name = "DIR")]
    pub styles: Option<PathBuf>,
    /// Skip the pipeline timings (simulation + strands + logging to a .rrd on Long curly).
    #[arg(long)]
    pub no_pipeline: bool,
    /// Strands drawn in the timed pipelines (default: `wisptree run`'s).
    #[arg(long, value_name = "N", default_value_t = PIPELINE_STRANDS)]
    pub strands: usize,
    /// Keep the recording of the `wisptree run` pipeline at FILE instead of a deleted
    /// temporary file.
    #[arg(long, value_name = "FILE")]
    pub rrd: Option<PathBuf>,
    /// Time the renderer (only) at 640x480 on Long, Long curly and a 16,215-strand head, on 1
    /// and 2 threads, 30 frames each, 3 with --quick (JSON key "render"). Frames per second are
    /// given at the median frame time, and over all frames in brackets (a shared machine's
    /// bursts of other work slow a few frames a lot: the median is the renderer's own speed).
    #[arg(long)]
    pub render: bool,
    /// Can every model keep up live? Runs the whole `run` pipeline (simulation, strands,
    /// logging into memory; unpaced) for awt, layered and guides (whatever --solvers says) on
    /// every --models style under every motion preset, the AWT at the page's slider ends under
    /// `shake`, and the AWT with rendering on. Prints each row's real-time factor (simulated ÷
    /// wall seconds: under 1 is slow motion), 95th-percentile frame time, active nodes and
    /// contacts, then where a step's time goes in the slowest AWT row (ms per stage; every AWT
    /// row's in the JSON), the worst row last (JSON key "live"). 5 s simulated per row, 1 with
    /// --quick.
    #[arg(long, conflicts_with = "render")]
    pub live: bool,
    /// With --live: run only the rows whose label contains one of these comma-separated texts.
    /// A row's label is `SOLVER STYLE MOTION`, then ` split X` or ` merge X` at a slider end
    /// and ` +render` with rendering on: `--rows "awt long_curly shake"` runs that style's
    /// plain, slider-end and rendering rows under `shake`, `--rows "split 0.05,+render"` every
    /// split-0.05 and rendering row. Default: every row.
    #[arg(long, value_delimiter = ',', value_name = "TEXTS", requires = "live")]
    pub rows: Vec<String>,
    /// With --live: run the whole matrix N times, one pass after the other (a drift of the
    /// machine's speed then spreads over every row instead of landing on a few), and report each
    /// row's median real-time factor and median 95th-percentile frame time, with the range of its
    /// factors (JSON: every pass's factor under "realtime_factors"). The live targets are judged
    /// on the median of 3.
    #[arg(long, value_name = "N", default_value_t = 1, requires = "live")]
    pub runs: u32,
}

impl BenchArgs {
    /// The checked options; bad values are [`BadInput`] (exit 2).
    pub fn options(&self) -> anyhow::Result<BenchOptions> {
        let seconds = match self.seconds {
            Some(s) if !(s.is_finite() && s > 0.0 && s <= 3600.0) => {
                return Err(BadInput(format!(
                    "--seconds must be a positive number of seconds up to 3600, got {s:?}"
                ))
                .into());
            }
            Some(s) => s,
            None if self.live && self.quick => 1.0,
            None if self.live => 5.0,
            None if self.quick => 0.5,
            None => 10.0,
        };
        if !(1..=MAX_LIVE_RUNS).contains(&self.runs) {
            return Err(BadInput(format!(
                "--runs must be between 1 and {MAX_LIVE_RUNS} passes of the live matrix, got {}",
                self.runs
            ))
            .into());
        }
        if self.models.is_empty() {
            return Err(BadInput("--models lists no model".into()).into());
        }
        let styles = self
            .models
            .iter()
            .map(|m| self.style(m))
            .collect::<Result<Vec<_>, _>>()?;
        let mut solvers = Vec::new();
        for s in &self.solvers {
            let k = SolverKind::parse(s).map_err(|e| BadInput(format!("--solvers: {e}")))?;
            if !solvers.contains(&k) {
                solvers.push(k);
            }
        }
        if solvers.is_empty() {
            return Err(BadInput("--solvers lists no solver".into()).into());
        }
        // `--render` times the renderer alone.
        let styles = if self.render { Vec::new() } else { styles };
        Ok(BenchOptions {
            seconds,
            styles,
            solvers,
            pipeline: !self.no_pipeline && !self.render && !self.live,
            pipeline_style: self.style("long_curly")?,
            strands: self.strands,
            rrd: self.rrd.clone(),
            json: self.json.clone(),
            render: self.render,
            render_frames: if self.quick { 3 } else { 30 },
            live: self.live,
            live_rows: self.rows.clone(),
            live_runs: self.runs as usize,
        })
    }

    /// A `--models` entry: a name in `--styles DIR`, a built-in name, or a path.
    fn style(&self, m: &str) -> Result<StyleSource, BadInput> {
        let source = match &self.styles {
            Some(dir) if !m.ends_with(".ron") => StyleSource::File(dir.join(format!("{m}.ron"))),
            _ => StyleSource::parse(m),
        };
        if let StyleSource::File(p) = &source {
            if !p.is_file() {
                return Err(BadInput(format!(
                    "--models: no style file for `{m}` at {} (built-in: {}; or give a path to a .ron)",
                    p.display(),
                    PAPER_MODELS.join(", ")
                )));
            }
        }
        Ok(source)
    }
}
