//! The flags of `wisptree run` (and plain `wisptree`), as clap structs that become plain
//! option structs.

use std::path::PathBuf;

use crate::app::run::{RunOptions, WebOptions, DEFAULT_MOTION, DEFAULT_STRANDS, DEFAULT_STYLE};
use crate::solver::SolverKind;
use crate::stream::sink::{SinkChoice, DEFAULT_CONNECT_URL};

/// `wisptree run` and plain `wisptree`.
#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    /// The hairstyle: a built-in name (short, short_curly, long, long_curly; see `wisptree
    /// styles`) or a style file (`.ron`).
    #[arg(long, value_name = "NAME|PATH", default_value = DEFAULT_STYLE)]
    pub style: String,

    /// Head and body motion: a preset (still, lean, run, jump, shake, stop) or a keyframed
    /// `.ron` motion file (see `motions/`).
    #[arg(long, value_name = "NAME|PATH", default_value = DEFAULT_MOTION)]
    pub motion: String,

    /// The hair model: `awt` (Adaptive Wisp Tree), `single-level` (the AWT with every finest
    /// node active, no adaptation), `layered` (Plante et al.'s layered wisps) or `guides`
    /// (Chang et al.'s guide strands).
    #[arg(long, value_name = "MODEL", default_value = "awt", value_parser = parse_model)]
    pub model: SolverKind,

    /// Simulated seconds to run. Default: 10 when recording to a file; until Ctrl-C (or `q`)
    /// when streaming live to a viewer.
    #[arg(long, value_name = "S", value_parser = parse_seconds)]
    pub seconds: Option<f64>,

    /// Hair strands drawn per frame (an evenly spread, fixed subset; all of them if the style has
    /// fewer). The default keeps a 10 s recording under 100 MB.
    #[arg(long, value_name = "N", default_value_t = DEFAULT_STRANDS, value_parser = parse_strands)]
    pub strands: usize,

    /// Same as `--model single-level` (kept from earlier versions).
    #[arg(long)]
    pub single_level: bool,

    /// Watch the style file and apply saved edits while running: new simulation parameters at
    /// once, a new model by restarting. Default: on when live, off when recording. A built-in
    /// style is not a file and is never watched.
    #[arg(long, overrides_with = "no_watch")]
    pub watch: bool,

    /// Do not watch the style file.
    #[arg(long, overrides_with = "watch")]
    pub no_watch: bool,

    /// Do not render the hair (the right half of the AWT paper's Figure 4).
    #[arg(long)]
    pub no_render: bool,

    /// Size of the rendered image, WIDTHxHEIGHT pixels.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)]
    pub render_size: (u32, u32),

    /// Ask one AWT node why it split or has not merged: log, every frame, its split test
    /// (|a|·r against the threshold, whether it may split) and its merge test against its
    /// siblings under `/inspect/TREE/LEVEL/INDEX/<name>`. INDEX counts the tree's nodes of that
    /// level, GC by GC, root to tip (`0:1:12`). The layered model names a skeleton point
    /// `WISP:0:POINT`, the guide strands a vertex `GUIDE:0:VERTEX` (its contacts, static links
    /// and strip triangles)
    #[arg(long, value_name = "TREE:LEVEL:INDEX", value_parser = crate::solver::NodeId::parse)]
    pub inspect: Option<crate::solver::NodeId>,

    /// Where the recording goes.
    #[command(flatten)]
    pub sink: SinkArgs,

    /// The control page (`--web`).
    #[command(flatten)]
    pub web: WebArgs,
}

/// `--web` and its options: a page of controls beside the Rerun web viewer.
#[derive(Debug, Clone, clap::Args)]
pub struct WebArgs {
    /// Serve a control page (sliders for the thresholds, friction, repulsion and wind, motion
    /// and model choices, pause and restart) beside the Rerun web viewer, which shows the run
    /// live. Prints the page's URL. Instead of a native viewer or a file.
    #[arg(long, conflicts_with_all = ["spawn", "connect", "save", "stdout"])]
    pub web: bool,

    /// The control page's port (0: a free one). The web viewer and gRPC server always take
    /// free ports, printed at start.
    #[arg(long, value_name = "P", default_value_t = 0, requires = "web")]
    pub port: u16,

    /// The address the page, the web viewer and the gRPC server listen on. Only 127.0.0.1 (this
    /// machine) by default; another address lets other machines control the run.
    #[arg(long, value_name = "IP", default_value = "127.0.0.1", requires = "web")]
    pub bind: std::net::IpAddr,

    /// Open the control page in the default browser.
    #[arg(long, requires = "web")]
    pub open: bool,
}

impl RunArgs {
    /// The plain options these flags ask for.
    pub fn options(&self) -> RunOptions {
        RunOptions {
            style: self.style.clone(),
            motion: self.motion.clone(),
            model: if self.single_level {
                SolverKind::SingleLevel
            } else {
                self.model
            },
            seconds: self.seconds,
            strands: self.strands,
            watch: match (self.watch, self.no_watch) {
                (true, _) => Some(true),
                (_, true) => Some(false),
                _ => None,
            },
            sink: if self.web.web {
                SinkChoice::Web(self.web.bind)
            } else {
                self.sink.choice()
            },
            render: (!self.no_render).then_some(self.render_size),
            inspect: self.inspect,
            web: self.web.web.then_some(WebOptions {
                bind: self.web.bind,
                port: self.web.port,
                open: self.web.open,
            }),
        }
    }
}

/// Where the recording goes: Rerun's usual sink flags, at most one of them. Without any, a
/// viewer is spawned if `rerun` is on PATH and starts (or one already listens on port 9876),
/// else the run is recorded to `wisptree.rrd`.
///
/// Not `rerun::clap::RerunArgs` itself: its fields are private, so whether the user chose a sink
/// cannot be told from the default, and that choice decides the fallback to a file. Its `--bind`
/// defaults to 0.0.0.0; `--serve` is not offered, so nothing here listens on the network.
#[derive(Debug, Clone, Default, clap::Args)]
#[group(id = "sink", multiple = false)]
pub struct SinkArgs {
    /// Start a Rerun viewer (`rerun` on PATH) and stream to it live; fail if there is none.
    #[arg(long)]
    pub spawn: bool,

    /// Stream live to a running Rerun viewer; optional URL, default
    /// rerun+http://127.0.0.1:9876/proxy.
    #[arg(long, value_name = "URL", num_args = 0..=1, default_missing_value = DEFAULT_CONNECT_URL)]
    pub connect: Option<String>,

    /// Record to this `.rrd` file (open it with `rerun FILE`).
    #[arg(long, value_name = "PATH")]
    pub save: Option<PathBuf>,

    /// Write the recording to standard output, to pipe into a viewer: `wisptree -o | rerun -`.
    #[arg(long, short = 'o')]
    pub stdout: bool,
}

impl SinkArgs {
    /// The sink these flags choose.
    pub fn choice(&self) -> SinkChoice {
        if self.stdout {
            SinkChoice::Stdout
        } else if let Some(p) = &self.save {
            SinkChoice::Save(p.clone())
        } else if let Some(u) = &self.connect {
            SinkChoice::Connect(u.clone())
        } else if self.spawn {
            SinkChoice::Spawn
        } else {
            SinkChoice::Auto
        }
    }
}

/// `--render-size WxH`: two whole numbers from 16 to 8192.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}`: expected WIDTHxHEIGHT in pixels, e.g. 640x480");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    for v in [w, h] {
        if !(16..=crate::render::MAX_SIDE).contains(&v) {
            return Err(format!(
                "`{s}`: each side must be 16 to {} pixels",
                crate::render::MAX_SIDE
            ));
        }
    }
    Ok((w, h))
}

/// `--model`.
pub fn parse_model(s: &str) -> Result<SolverKind, String> {
    SolverKind::parse(s)
}

/// `--seconds`: positive, finite, at most 10⁶.
pub fn parse_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0e6 {
        Ok(v)
    } else {
        Err(format!(
            "{s}: expected a positive number of simulated seconds (at most 1e6)"
        ))
    }
}

/// `--strands`: a whole number, at least 1.
pub fn parse_strands(s: &str) -> Result<usize, String> {
    let v: i128 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number of strands"))?;
    if v < 1 {
        return Err(format!("{s}: at least one strand must be drawn"));
    }
    usize::try_from(v).map_err(|_| format!("{s}: too many strands"))
}
