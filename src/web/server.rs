//! The control page's HTTP server: the page itself, the Rerun viewer's script and wasm (which
//! the page runs), the live state as JSON, and one control endpoint that accepts only the page's own requests from the page's own origin.
//!
//! Why so strict: anything on the user's machine (any web page in any tab) can send requests to
//! a port on 127.0.0.1. A request is taken only when its `Host` names this server (no DNS
//! rebinding) and, for the control endpoint, its `Origin` is this page and its body is JSON
//! (a cross-origin page cannot send that without a CORS preflight, which is never answered).

use std::io::Read as _;
use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::thread::JoinHandle;

use anyhow::Context as _;
use crossbeam_channel::Sender;
use tiny_http::{Header, Method, Request, Response, Server};

use super::protocol::{self, SetTunable, SharedState, WebCommand};
use super::style_panel::StylePanel;

/// The largest request body taken (the page's requests are under 100 bytes).
const MAX_BODY: usize = 4096;

/// The page, with `__VIEWER_PORT__` and `__GRPC_PORT__` filled in when served (its sliders
/// come with the state: the running model's tunables).
const PAGE: &str = include_str!("page.html");

/// Where the control page listens and what it embeds.
#[derive(Clone)]
pub struct PageConfig {
    /// The address to bind (127.0.0.1 unless the user asked otherwise).
    pub bind: IpAddr,
    /// The page's port; 0 picks a free one.
    pub port: u16,
    /// The port of the Rerun web viewer the page embeds.
    pub viewer_port: u16,
    /// The port of the gRPC server the viewer reads from.
    pub grpc_port: u16,
    /// The Style panel's editor (`None`: no panel, as for a page without a style).
    pub style: Option<Arc<StylePanel>>,
}

/// A running control page; stops when dropped.
pub struct ControlPage {
    server: Arc<Server>,
    thread: Option<JoinHandle<()>>,
    addr: SocketAddr,
}

impl ControlPage {
    /// Binds the page's port and serves it on a thread of its own. A checked tunable value
    /// goes to `tunes` (read by the simulation thread), the other checked requests to
    /// `commands`; the page reads `state`.
    pub fn start(
        cfg: PageConfig,
        state: Arc<SharedState>,
        commands: Sender<WebCommand>,
        tunes: Sender<SetTunable>,
    ) -> anyhow::Result<ControlPage> {
        let server = Server::http(SocketAddr::new(cfg.bind, cfg.port))
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| format!("--port: cannot listen on {}:{}", cfg.bind, cfg.port))?;
        let addr = server
            .server_addr()
            .to_ip()
            .context("the control page has no IP address")?;
        let server = Arc::new(server);
        let serving = Serving {
            hosts: allowed_hosts(cfg.bind, addr.port()),
            any_host: cfg.bind.is_unspecified(),
            page: page_html(&cfg),
            style: cfg.style.clone(),
            viewer: re_web_viewer_server::WebViewerData::load(None)
                .map_err(|e| anyhow::anyhow!("{e}"))
                .context("the Rerun web viewer's files")?,
            state,
            commands,
            tunes,
        };
        let thread = {
            let server = Arc::clone(&server);
            std::thread::Builder::new()
                .name("wisptree-web".into())
                .spawn(move || {
                    for req in server.incoming_requests() {
                        serving.handle(req);
                    }
                })
                .context("starting the control page's thread")?
        };
        Ok(ControlPage {
            server,
            thread: Some(thread),
            addr,
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL.
    pub fn url(&self) -> String {
        let host = if self.addr.ip().is_unspecified() {
            IpAddr::from([127, 0, 0, 1])
        } else {
            self.addr.ip()
        };
        format!("http://{}/", SocketAddr::new(host, self.addr.port()))
    }
}

impl Drop for ControlPage {
    fn drop(&mut self) {
        self.server.unblock();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The `Host` values that name this server.
fn allowed_hosts(bind: IpAddr, port: u16) -> Vec<String> {
    let mut hosts = vec![SocketAddr::new(bind, port).to_string()];
    if bind.is_loopback() || bind.is_unspecified() {
        hosts.push(format!("127.0.0.1:{port}"));
        hosts.push(format!("localhost:{port}"));
    }
    hosts
}

/// The page with its ports and sliders filled in.
fn page_html(cfg: &PageConfig) -> String {
    PAGE.replace("__VIEWER_PORT__", &cfg.viewer_port.to_string())
        .replace("__GRPC_PORT__", &cfg.grpc_port.to_string())
}

/// What the server thread owns.
struct Serving {
    hosts: Vec<String>,
    any_host: bool,
    page: String,
    /// The Rerun web viewer's script and wasm, which the page loads to host the viewer.
    viewer: re_web_viewer_server::WebViewerData,
    state: Arc<SharedState>,
    commands: Sender<WebCommand>,
    tunes: Sender<SetTunable>,
    style: Option<Arc<StylePanel>>,
}

/// A reply: status, body and its type.
struct Reply {
    status: u16,
    body: Vec<u8>,
    content_type: &'static str,
    /// The viewer's files do not change while the program runs: the browser may keep them.
    cacheable: bool,
}

impl Reply {
    fn json(status: u16, value: serde_json::Value) -> Reply {
        Reply {
            status,
            body: value.to_string().into_bytes(),
            content_type: "application/json",
            cacheable: false,
        }
    }
    fn asset(body: &[u8], content_type: &'static str) -> Reply {
        Reply {
            status: 200,
            body: body.to_vec(),
            content_type,
            cacheable: true,
        }
    }
    fn error(status: u16, msg: impl Into<String>) -> Reply {
        Reply::json(
            status,
            serde_json::json!({ "ok": false, "error": msg.into() }),
        )
    }
}

impl Serving {
    fn handle(&self, mut req: Request) {
        let reply = self.route(&mut req);
        let cache = if reply.cacheable {
            "max-age=3600"
        } else {
            "no-store"
        };
        let mut resp = Response::from_data(reply.body).with_status_code(reply.status);
        for (k, v) in [
            ("Content-Type", reply.content_type),
            ("Cache-Control", cache),
            ("X-Content-Type-Options", "nosniff"),
            // Nobody else may frame the controls (clickjacking).
            ("Content-Security-Policy", "frame-ancestors 'none'"),
        ] {
            if let Ok(h) = Header::from_bytes(k, v) {
                resp.add_header(h);
            }
        }
        let _ = req.respond(resp);
    }

    fn route(&self, req: &mut Request) -> Reply {
        let host = header(req, "Host").unwrap_or_default();
        if !self.any_host && !self.hosts.iter().any(|h| h.eq_ignore_ascii_case(&host)) {
            return Reply::error(403, format!("refused: unknown Host `{host}`"));
        }
        let path = req.url().split('?').next().unwrap_or("").to_owned();
        match (req.method(), path.as_str()) {
            (Method::Get, "/") => Reply {
                status: 200,
                body: self.page.clone().into_bytes(),
                content_type: "text/html; charset=utf-8",
                cacheable: false,
            },
            (Method::Get, "/viewer/re_viewer.js") => {
                Reply::asset(self.viewer.viewer_js(), "text/javascript")
            }
            (Method::Get, "/viewer/re_viewer_bg.wasm") => {
                Reply::asset(self.viewer.viewer_wasm(), "application/wasm")
            }
            (Method::Get, "/api/state") => match serde_json::to_value(self.state.snapshot()) {
                Ok(v) => Reply::json(200, v),
                Err(e) => Reply::error(500, e.to_string()),
            },
            (Method::Post, "/api/control") => self.control(req, &host),
            (Method::Get, "/api/style") => match self.style.as_ref().map(|s| s.view()) {
                Some(v) => match serde_json::to_value(v) {
                    Ok(v) => Reply::json(200, v),
                    Err(e) => Reply::error(500, e.to_string()),
                },
                None => Reply::error(404, "this run has no Style panel"),
            },
            (Method::Post, "/api/style") => self.style_edit(req, &host),
            (_, "/" | "/api/state" | "/api/control" | "/api/style") => {
                Reply::error(405, "method not allowed")
            }
            _ => Reply::error(404, format!("no page `{path}`")),
        }
    }

    /// The body of a control request: same origin, JSON and small, else the refusal (a body
    /// over `MAX_BODY` gets `too_large`).
    fn checked_body(req: &mut Request, host: &str, too_large: u16) -> Result<String, Reply> {
        let origin = header(req, "Origin").unwrap_or_default();
        if origin != format!("http://{host}") {
            return Err(Reply::error(
                403,
                format!("refused: requests from other origins are not taken (Origin `{origin}`)"),
            ));
        }
        let json = header(req, "Content-Type")
            .is_some_and(|c| c.to_ascii_lowercase().starts_with("application/json"));
        if !json {
            return Err(Reply::error(
                415,
                "refused: the body must be application/json",
            ));
        }
        if req.body_length().is_some_and(|n| n > MAX_BODY) {
            return Err(Reply::error(
                too_large,
                format!("refused: request too large (at most {MAX_BODY} bytes)"),
            ));
        }
        let mut body = String::new();
        let read = req
            .as_reader()
            .take(MAX_BODY as u64 + 1)
            .read_to_string(&mut body);
        if read.is_err() || body.len() > MAX_BODY {
            return Err(Reply::error(400, "refused: unreadable or too large body"));
        }
        Ok(body)
    }

    /// The Style panel's endpoint: the same checks as the control endpoint; a bad edit (or
    /// a request too large) is a 400 and changes nothing.
    fn style_edit(&self, req: &mut Request, host: &str) -> Reply {
        let body = match Self::checked_body(req, host, 400) {
            Ok(b) => b,
            Err(r) => return r,
        };
        let Some(panel) = &self.style else {
            return Reply::error(404, "this run has no Style panel");
        };
        match panel.handle(&body) {
            Ok(r) => Reply::json(
                200,
                serde_json::json!({ "ok": true, "message": r.message, "restart": r.restart,
                    "version": r.version, "model_hash": r.model_hash }),
            ),
            Err(msg) => Reply::error(400, msg),
        }
    }

    /// The control endpoint: same origin, JSON, small, and one of the page's messages.
    fn control(&self, req: &mut Request, host: &str) -> Reply {
        let body = match Self::checked_body(req, host, 413) {
            Ok(b) => b,
            Err(r) => return r,
        };
        let sent = match protocol::parse_request(&body, &self.state.snapshot()) {
            Ok(WebCommand::Set(name, value)) => self.tunes.send(SetTunable { name, value }).is_ok(),
            Ok(cmd) => self.commands.send(cmd).is_ok(),
            Err(msg) => return Reply::error(400, msg),
        };
        if sent {
            Reply::json(200, serde_json::json!({ "ok": true }))
        } else {
            Reply::error(503, "the simulation has ended")
        }
    }
}

/// A request header's value.
fn header(req: &Request, name: &str) -> Option<String> {
    req.headers()
        .iter()
        .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
        .map(|h| h.value.as_str().to_owned())
}
