//! Where a recording goes: a spawned or running viewer (live), a `.rrd` file, standard output,
//! or memory (tests). Opening one is the only place, with the [`crate::stream::Logger`], that
//! names Rerun types.

use std::net::{SocketAddr, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use rerun::sink::{GrpcSink, GrpcSinkConnectionState, LogSink, SinkFlushError};
use rerun::RecordingStream;

/// The file written when no viewer can be spawned and no sink is asked for (or the first free
/// one of `wisptree-2.rrd`, `wisptree-3.rrd`, …: see [`default_rrd_path`]).
pub const DEFAULT_RRD: &str = "wisptree.rrd";
/// The URL `--connect` uses without one.
pub const DEFAULT_CONNECT_URL: &str = rerun::DEFAULT_CONNECT_URL;
/// The application id of every recording.
pub const APP_ID: &str = "wisptree";
/// The port a spawned viewer listens on (Rerun's default), unless [`VIEWER_PORT_ENV`] says
/// another.
const VIEWER_PORT: u16 = 9876;
/// The environment variable that moves the spawned viewer to another port (the tests use a
/// free one, so that a viewer already running on 9876 does not change what they see).
pub const VIEWER_PORT_ENV: &str = "WISPTREE_VIEWER_PORT";
/// How long a spawned viewer may take to listen before it is given up and the run records to
/// a file instead (a viewer that cannot open a window dies within a second or two).
pub const VIEWER_START_TIMEOUT: Duration = Duration::from_secs(5);

/// Which sink the user asked for (at most one; `Auto` is none).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum SinkChoice {
    /// A spawned viewer if `rerun` is on PATH and starts, else [`DEFAULT_RRD`].
    #[default]
    Auto,
    /// A spawned viewer, or an error.
    Spawn,
    /// A running viewer at this URL.
    Connect(String),
    /// A `.rrd` file.
    Save(PathBuf),
    /// Standard output (`wisptree -o | rerun -`).
    Stdout,
    /// A gRPC server and the Rerun web viewer, both on this address (`run --web`).
    Web(std::net::IpAddr),
}

/// Whether a live viewer is still there.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ViewerStatus {
    /// Not a live sink, or connected.
    Fine,
    /// Still connecting, for this long.
    Connecting(Duration),
    /// Gone, and why.
    Gone(String),
}

/// A gRPC sink whose connection state stays observable after the recording stream took it: the
/// stream gets one handle, the run keeps another to notice a viewer that went away.
struct WatchedGrpcSink(Arc<GrpcSink>);

impl LogSink for WatchedGrpcSink {
    fn send(&self, msg: rerun::log::LogMsg) {
        self.0.send(msg);
    }
    fn flush_blocking(&self, timeout: Duration) -> Result<(), SinkFlushError> {
        self.0.flush_blocking(timeout)
    }
    fn default_batcher_config(&self) -> rerun::log::ChunkBatcherConfig {
        self.0.default_batcher_config()
    }
}

/// An opened recording and what kind of destination it is.
pub struct OpenSink {
    /// The stream the logger writes to.
    pub rec: Recording,
    /// A viewer is watching: pace to wall-clock time, drop frames rather than fall behind.
    pub live: bool,
    /// The file recorded to, if any.
    pub file: Option<PathBuf>,
    /// For the terminal: "viewer at …", "file …", "standard output".
    pub description: String,
    /// No sink was asked for and no viewer could be started: the default file was chosen.
    pub fell_back: bool,
    /// Connection state of a live viewer.
    grpc: Option<Arc<GrpcSink>>,
    /// The web viewer and gRPC server of [`SinkChoice::Web`].
    pub web: Option<WebViewer>,
}

/// The servers of [`SinkChoice::Web`]: the gRPC server the recording streams to and the web
/// viewer that reads it. The web viewer stops when this is dropped; the gRPC server when the
/// recording is.
pub struct WebViewer {
    /// The address both listen on.
    pub bind: std::net::IpAddr,
    /// The gRPC server's port.
    pub grpc_port: u16,
    /// The web viewer's port.
    pub viewer_port: u16,
    /// (Rerun's `WebViewerServer`, which the SDK does not re-export by name.)
    _server: Box<dyn std::any::Any + Send>,
}

impl WebViewer {
    /// The web viewer's page, connected to the gRPC server.
    pub fn url(&self) -> String {
        let host = loopback_for(self.bind);
        let source = format!("rerun+http://{host}:{}/proxy", self.grpc_port);
        let encoded: String = source
            .bytes()
            .map(|b| {
                if b.is_ascii_alphanumeric() {
                    (b as char).to_string()
                } else {
                    format!("%{b:02X}")
                }
            })
            .collect();
        format!("http://{host}:{}/?url={encoded}", self.viewer_port)
    }
}

/// A recording stream, opaque outside `stream`.
#[derive(Clone)]
pub struct Recording(pub RecordingStream);

impl Recording {
    /// A recording kept in memory (tests decode the bytes of its [`MemoryRecording`]).
    pub fn memory() -> anyhow::Result<(Recording, MemoryRecording)> {
        let (rec, storage) = rerun::RecordingStreamBuilder::new(APP_ID)
            .memory()
            .context("creating an in-memory recording")?;
        Ok((Recording(rec), MemoryRecording(storage)))
    }

    /// The Rerun stream itself (for tests and tools that log more).
    pub fn stream(&self) -> &RecordingStream {
        &self.0
    }
}

/// The contents of an in-memory recording.
pub struct MemoryRecording(pub rerun::sink::MemorySinkStorage);

impl OpenSink {
    /// A sink of an already opened recording (no viewer to watch, no file to report).
    pub fn recording(rec: Recording) -> OpenSink {
        OpenSink {
            rec,
            live: false,
            file: None,
            description: "recording".to_owned(),
            fell_back: false,
            grpc: None,
            web: None,
        }
    }

    /// The live viewer's state (always `Fine` for a file or standard output).
    pub fn viewer_status(&self) -> ViewerStatus {
        match self.grpc.as_ref().map(|g| g.status()) {
            None | Some(GrpcSinkConnectionState::Connected) => ViewerStatus::Fine,
            Some(GrpcSinkConnectionState::Connecting { started }) => {
                ViewerStatus::Connecting(started.elapsed())
            }
            Some(GrpcSinkConnectionState::Disconnected(r)) => ViewerStatus::Gone(match r {
                Ok(()) => "the viewer closed the connection".to_owned(),
                Err(e) => format!("the viewer went away (connection lost: {e:?})"),
            }),
        }
    }

    /// A handle that tells the viewer's state from another place than the sink's owner.
    pub fn watcher(&self) -> SinkWatcher {
        SinkWatcher(self.grpc.clone())
    }
}

/// Tells whether a live viewer is still there (see [`OpenSink::watcher`]).
#[derive(Clone)]
pub struct SinkWatcher(Option<Arc<GrpcSink>>);

impl SinkWatcher {
    /// As [`OpenSink::viewer_status`].
    pub fn status(&self) -> ViewerStatus {
        OpenSink {
            rec: Recording(RecordingStream::disabled()),
            live: false,
            file: None,
            description: String::new(),
            fell_back: false,
            grpc: self.0.clone(),
            web: None,
        }
        .viewer_status()
    }
}

fn connect(url: &str) -> anyhow::Result<(RecordingStream, Arc<GrpcSink>)> {
    let uri: rerun::external::re_uri::ProxyUri = url.parse().map_err(|e| {
        crate::error::BadInput(format!(
            "--connect {url}: not a Rerun proxy URL ({e}); expected e.g. {DEFAULT_CONNECT_URL}"
        ))
    })?;
    let sink = Arc::new(GrpcSink::new(uri));
    let (enabled, store_info, recording_info, batcher_config, hooks, _blueprint) =
        rerun::RecordingStreamBuilder::new(APP_ID).into_args();
    let rec = if enabled {
        RecordingStream::new(
            store_info,
            recording_info,
            batcher_config,
            hooks,
            Box::new(WatchedGrpcSink(sink.clone())),
        )
        .context("creating the recording stream")?
    } else {
        RecordingStream::disabled()
    };
    Ok((rec, sink))
}

/// Refuses a `--save` path no recording can be written to (a folder, a path under a regular
/// file, a place the user may not write) with one line naming it (exit 2), rather than the
/// Rerun SDK's error, which repeats the system's three times. Leaves the file system as it was.
pub fn check_save_path(path: &Path) -> Result<(), crate::error::BadInput> {
    let existed = path.symlink_metadata().is_ok();
    match std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(path)
    {
        Ok(_) => {
            if !existed {
                let _ = std::fs::remove_file(path);
            }
            Ok(())
        }
        Err(e) => Err(crate::error::BadInput(format!(
            "--save {}: cannot write: {e}",
            path.display()
        ))),
    }
}

/// Checks `path` as [`check_save_path`] does, then moves a file already there aside to
/// `NAME.bak` (the SDK's file sink truncates: an earlier recording would be lost), saying so on
/// standard error; refuses, naming both, when that backup exists too.
pub fn prepare_save_path(path: &Path) -> anyhow::Result<()> {
    check_save_path(path)?;
    if let Some(bak) = crate::files::move_aside(path).context("--save")? {
        eprintln!("kept the earlier {} as {}", path.display(), bak.display());
    }
    Ok(())
}

fn save(path: &Path) -> anyhow::Result<RecordingStream> {
    prepare_save_path(path)?;
    rerun::RecordingStreamBuilder::new(APP_ID)
        .save(path)
        .with_context(|| format!("{}: cannot create the recording", path.display()))
}

/// The file a run records to when no viewer starts and no sink was asked for: [`DEFAULT_RRD`]
/// in `dir`, or, when that exists, the first of `wisptree-2.rrd`, `wisptree-3.rrd`, … that does
/// not, so that running again never replaces (nor backs up, nor refuses) an earlier run's.
pub fn default_rrd_path(dir: &Path) -> PathBuf {
    let stem = DEFAULT_RRD.trim_end_matches(".rrd");
    (1..=100_000u32)
        .map(|k| match k {
            1 => dir.join(DEFAULT_RRD),
            k => dir.join(format!("{stem}-{k}.rrd")),
        })
        .find(|p| p.symlink_metadata().is_err())
        // A hundred thousand earlier recordings: the last name, moved aside by `save`.
        .unwrap_or_else(|| dir.join(format!("{stem}-100000.rrd")))
}

/// The version of the Rerun SDK (the viewer should match it).
pub fn rerun_version() -> String {
    rerun::build_info().version.to_string()
}

/// Opens the sink asked for; with [`SinkChoice::Auto`], a spawned viewer or else the default
/// file [`DEFAULT_RRD`] in the current directory.
pub fn open_sink(choice: &SinkChoice) -> anyhow::Result<OpenSink> {
    let plain = |rec, file: Option<PathBuf>, description| OpenSink {
        rec: Recording(rec),
        live: false,
        file,
        description,
        fell_back: false,
        grpc: None,
        web: None,
    };
    let live = |rec, grpc, description| OpenSink {
        rec: Recording(rec),
        live: true,
        file: None,
        description,
        fell_back: false,
        grpc: Some(grpc),
        web: None,
    };
    match choice {
        SinkChoice::Stdout => {
            let rec = rerun::RecordingStreamBuilder::new(APP_ID)
                .stdout()
                .context("opening standard output for the recording")?;
            Ok(plain(rec, None, "standard output".to_owned()))
        }
        SinkChoice::Save(path) => Ok(plain(
            save(path)?,
            Some(path.clone()),
            format!("file {}", path.display()),
        )),
        SinkChoice::Web(bind) => serve_web(*bind),
        SinkChoice::Connect(url) => {
            let (rec, grpc) = connect(url)?;
            Ok(live(rec, grpc, format!("viewer at {url}")))
        }
        SinkChoice::Spawn | SinkChoice::Auto => match start_viewer() {
            Ok((url, what)) => {
                let (rec, grpc) = connect(&url)?;
                Ok(live(rec, grpc, format!("{what} at {url}")))
            }
            Err(why) if *choice == SinkChoice::Spawn => Err(anyhow::anyhow!("--spawn: {why}")),
            Err(why) => {
                let path = default_rrd_path(Path::new(""));
                let mut s = plain(
                    save(&path)?,
                    Some(path.clone()),
                    format!("file {} ({why})", path.display()),
                );
                s.fell_back = true;
                Ok(s)
            }
        },
    }
}

/// How long the gRPC server may take to listen.
const GRPC_START_TIMEOUT: Duration = Duration::from_secs(5);

/// [`SinkChoice::Web`]: a gRPC server on a free port of `bind` that keeps the recording for
/// viewers that connect late, and the Rerun web viewer on another free port. Both would bind
/// 0.0.0.0 by default; here they bind what the user chose (127.0.0.1 unless `--bind`).
fn serve_web(bind: std::net::IpAddr) -> anyhow::Result<OpenSink> {
    let grpc_port = free_port(bind)?;
    let mut options = rerun::ServerOptions {
        memory_limit: rerun::MemoryLimit::from_fraction_of_total(0.25),
        ..Default::default()
    };
    if !bind.is_loopback() {
        // The viewer's page is then reached by another name than localhost / 127.0.0.1.
        options.cors_allowed_origins.push("http://*".to_owned());
    }
    let rec = rerun::RecordingStreamBuilder::new(APP_ID)
        .serve_grpc_opts(bind.to_string(), grpc_port, options)
        .with_context(|| format!("starting the gRPC server on {bind}:{grpc_port}"))?;
    wait_listening(
        SocketAddr::new(loopback_for(bind), grpc_port),
        GRPC_START_TIMEOUT,
    )
    .with_context(|| format!("the gRPC server on {bind}:{grpc_port} did not start"))?;
    let server = rerun::serve_web_viewer(rerun::web_viewer::WebViewerConfig {
        bind_ip: bind.to_string(),
        open_browser: false,
        ..Default::default()
    })
    .with_context(|| format!("starting the Rerun web viewer on {bind}"))?;
    let viewer_port = server
        .server_url()
        .rsplit(':')
        .next()
        .and_then(|p| p.trim_end_matches('/').parse().ok())
        .context("the web viewer did not say its port")?;
    Ok(OpenSink {
        rec: Recording(rec),
        live: true,
        file: None,
        description: format!("web viewer on {bind}:{viewer_port} (gRPC {bind}:{grpc_port})"),
        fell_back: false,
        grpc: None,
        web: Some(WebViewer {
            bind,
            grpc_port,
            viewer_port,
            _server: Box::new(server),
        }),
    })
}

/// A port of `bind` that is free now (the OS picks it; it is released at once for the server
/// that takes it next, so another program could take it first: the start then fails clearly).
fn free_port(bind: std::net::IpAddr) -> anyhow::Result<u16> {
    let l = std::net::TcpListener::bind(SocketAddr::new(bind, 0))
        .with_context(|| format!("no free port on {bind}"))?;
    Ok(l.local_addr()?.port())
}

/// The address to reach a server bound to `bind` from this machine.
fn loopback_for(bind: std::net::IpAddr) -> std::net::IpAddr {
    if bind.is_unspecified() {
        std::net::IpAddr::from([127, 0, 0, 1])
    } else {
        bind
    }
}

/// Waits until something accepts connections at `addr`.
fn wait_listening(addr: SocketAddr, timeout: Duration) -> anyhow::Result<()> {
    let start = Instant::now();
    while start.elapsed() < timeout {
        if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    anyhow::bail!("nothing listens at {addr} after {} s", timeout.as_secs())
}

/// Starts a viewer (`rerun` on PATH) listening on the default port, or finds one already
/// there, and waits until it listens. Returns its URL and how it was found, or why there is
/// none. A viewer that exits, or does not listen within [`VIEWER_START_TIMEOUT`] (no display,
/// say), is stopped and reaped.
fn start_viewer() -> Result<(String, &'static str), String> {
    let port = viewer_port()?;
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let url = format!("rerun+http://127.0.0.1:{port}/proxy");
    if TcpStream::connect_timeout(&addr, Duration::from_millis(300)).is_ok() {
        return Ok((url, "viewer already running"));
    }
    let mut child = spawn_viewer_process(port)?;
    let started = Instant::now();
    let mut exited: Option<std::process::ExitStatus> = None;
    loop {
        if TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_ok() {
            // (The launcher may fork the viewer and exit; the port is what counts. A child
            // that is still running is the viewer itself and outlives the run.)
            return Ok((url, "spawned viewer"));
        }
        if exited.is_none() {
            exited = child.try_wait().ok().flatten();
        }
        let waited = started.elapsed();
        match exited {
            // An unsuccessful exit: it will never listen.
            Some(st) if !st.success() => {
                return Err(format!(
                    "the Rerun viewer exited at once ({st}); no display?"
                ))
            }
            _ if waited >= VIEWER_START_TIMEOUT => {
                stop_process_group(&mut child);
                return Err(format!(
                    "the Rerun viewer did not start listening within {} s; no display?",
                    VIEWER_START_TIMEOUT.as_secs()
                ));
            }
            _ => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}

/// [`VIEWER_PORT`], or the port [`VIEWER_PORT_ENV`] gives.
fn viewer_port() -> Result<u16, String> {
    match std::env::var(VIEWER_PORT_ENV) {
        Err(_) => Ok(VIEWER_PORT),
        Ok(s) => s
            .trim()
            .parse()
            .ok()
            .filter(|&p| p != 0)
            .ok_or_else(|| format!("{VIEWER_PORT_ENV}={s} is not a port (1 to 65535)")),
    }
}

/// `rerun --port 9876 …` as Rerun's own `spawn` runs it, in its own process group so that it
/// can be stopped with whatever it forked.
fn spawn_viewer_process(port: u16) -> Result<Child, String> {
    use std::os::unix::process::CommandExt as _;
    Command::new("rerun")
        .stdin(Stdio::null())
        .arg(format!("--port={port}"))
        .arg("--memory-limit=75%")
        .arg("--expect-data-soon")
        .process_group(0)
        .spawn()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => "no Rerun viewer (`rerun`) on PATH".to_owned(),
            _ => format!("could not start a Rerun viewer ({e})"),
        })
}

/// Stops a viewer that never listened, and whatever it forked, and reaps it.
fn stop_process_group(child: &mut Child) {
    // SIGKILL to the whole group: the child leads it (`process_group(0)`).
    if let Ok(pgid) = libc::pid_t::try_from(child.id()) {
        // SAFETY: killpg only sends a signal; the group is the one this process created.
        unsafe {
            libc::killpg(pgid, libc::SIGKILL);
        }
    }
    let _ = child.kill();
    let _ = child.wait();
}
