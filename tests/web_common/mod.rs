//! Starting `wisptree run --web` for a test, and talking plain HTTP to it.
#![allow(dead_code)]

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// A running `wisptree run --web`, stopped (Ctrl-C) when dropped.
pub struct WebRun {
    pub child: Child,
    /// The page's port.
    pub port: u16,
    /// Every line it printed so far (stderr), gathered by a reader thread.
    lines: mpsc::Receiver<String>,
    pub seen: Vec<String>,
}

impl WebRun {
    /// Starts it with these extra arguments and waits for the page's URL.
    pub fn start(extra: &[&str]) -> WebRun {
        WebRun::start_style("short", extra)
    }

    /// [`WebRun::start`] on another style (a built-in name or a file).
    pub fn start_style(style: &str, extra: &[&str]) -> WebRun {
        let mut child = Command::new(env!("CARGO_BIN_EXE_wisptree"))
            .args([
                "run",
                "--web",
                "--no-render",
                "--style",
                style,
                "--motion",
                "lean",
            ])
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("starting wisptree run --web");
        let (tx, rx) = mpsc::channel();
        for pipe in [
            Box::new(child.stderr.take().unwrap()) as Box<dyn std::io::Read + Send>,
            Box::new(child.stdout.take().unwrap()),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                    let _ = tx.send(line);
                }
            });
        }
        let mut run = WebRun {
            child,
            port: 0,
            lines: rx,
            seen: Vec::new(),
        };
        let line = run.wait_line("control page: http://", Duration::from_secs(60));
        let url = line.split("http://").nth(1).unwrap().trim_end_matches('/');
        run.port = url
            .rsplit(':')
            .next()
            .unwrap()
            .trim_end_matches('/')
            .parse()
            .unwrap();
        run
    }

    /// Waits for a printed line containing `needle`.
    pub fn wait_line(&mut self, needle: &str, timeout: Duration) -> String {
        let start = Instant::now();
        loop {
            if let Some(l) = self.seen.iter().find(|l| l.contains(needle)) {
                return l.clone();
            }
            let left = timeout.checked_sub(start.elapsed()).unwrap_or_else(|| {
                panic!(
                    "no line with `{needle}` within {timeout:?}; printed: {:#?}",
                    self.seen
                )
            });
            if let Ok(l) = self
                .lines
                .recv_timeout(left.min(Duration::from_millis(200)))
            {
                self.seen.push(l);
            } else if let Ok(Some(st)) = self.child.try_wait() {
                panic!(
                    "wisptree exited ({st}) before `{needle}`; printed: {:#?}",
                    self.seen
                );
            }
        }
    }

    /// The page's URL.
    pub fn url(&self) -> String {
        format!("http://127.0.0.1:{}/", self.port)
    }

    /// `/api/state`, parsed.
    pub fn state(&self) -> serde_json::Value {
        let r = http(self.port, "GET", "/api/state", &[], "");
        assert_eq!(r.status, 200, "{}", r.body);
        serde_json::from_str(&r.body).expect("state is JSON")
    }

    /// Waits until `f(state)` holds.
    pub fn wait_state(
        &self,
        what: &str,
        f: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let start = Instant::now();
        loop {
            let s = self.state();
            if f(&s) {
                return s;
            }
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "{what}: last state {s}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// A same-origin control request, as the page sends it.
    pub fn control(&self, body: &str) -> Reply {
        let origin = format!("http://127.0.0.1:{}", self.port);
        http(
            self.port,
            "POST",
            "/api/control",
            &[("Origin", &origin), ("Content-Type", "application/json")],
            body,
        )
    }

    /// Ctrl-C, and the exit status.
    pub fn interrupt(&mut self) -> std::process::ExitStatus {
        unsafe_sigint(self.child.id());
        let start = Instant::now();
        loop {
            if let Ok(Some(st)) = self.child.try_wait() {
                return st;
            }
            assert!(
                start.elapsed() < Duration::from_secs(30),
                "no exit after Ctrl-C"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for WebRun {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

fn unsafe_sigint(pid: u32) {
    let _ = Command::new("kill")
        .args(["-INT", &pid.to_string()])
        .status();
}

/// An HTTP reply.
#[derive(Debug)]
pub struct Reply {
    pub status: u16,
    /// The status line and headers.
    pub head: String,
    pub body: String,
}

/// One HTTP/1.1 request with exactly these headers (and `Host: 127.0.0.1:port` unless given).
pub fn http(port: u16, method: &str, path: &str, headers: &[(&str, &str)], body: &str) -> Reply {
    try_http(port, method, path, headers, body)
        .unwrap_or_else(|e| panic!("{method} {path} on port {port}: {e}"))
}

/// [`http`], with the failure as a value (for destructors).
pub fn try_http(
    port: u16,
    method: &str,
    path: &str,
    headers: &[(&str, &str)],
    body: &str,
) -> Result<Reply, String> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).map_err(|e| e.to_string())?;
    // Long: a browser session may take a while to start on a busy 2-core machine.
    s.set_read_timeout(Some(Duration::from_secs(120))).unwrap();
    let mut req = format!("{method} {path} HTTP/1.1\r\nConnection: close\r\n");
    if !headers.iter().any(|(k, _)| k.eq_ignore_ascii_case("host")) {
        req += &format!("Host: 127.0.0.1:{port}\r\n");
    }
    for (k, v) in headers {
        req += &format!("{k}: {v}\r\n");
    }
    req += &format!("Content-Length: {}\r\n\r\n{body}", body.len());
    s.write_all(req.as_bytes()).map_err(|e| e.to_string())?;
    // Read until the reply is complete: servers may keep the connection open (chromedriver
    // does, whatever `Connection: close` says).
    let mut raw = Vec::new();
    let mut buf = [0u8; 65536];
    let split = loop {
        if let Some(p) = raw.windows(4).position(|w| w == b"\r\n\r\n") {
            let head = String::from_utf8_lossy(&raw[..p]).to_ascii_lowercase();
            let length = head
                .lines()
                .find_map(|l| l.strip_prefix("content-length:"))
                .and_then(|v| v.trim().parse::<usize>().ok());
            let chunked = head.contains("transfer-encoding: chunked");
            let body = &raw[p + 4..];
            let complete = match length {
                Some(n) => body.len() >= n,
                None if chunked => body.ends_with(b"0\r\n\r\n"),
                None => false,
            };
            if complete {
                break p;
            }
        }
        match s.read(&mut buf) {
            Ok(0) => {
                break raw
                    .windows(4)
                    .position(|w| w == b"\r\n\r\n")
                    .ok_or_else(|| {
                        format!("not an HTTP reply: {:?}", String::from_utf8_lossy(&raw))
                    })?
            }
            Ok(n) => raw.extend_from_slice(&buf[..n]),
            Err(e) => return Err(format!("reading the reply: {e}")),
        }
    };
    let head = String::from_utf8_lossy(&raw[..split]).to_string();
    let body = &raw[split + 4..];
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| format!("no status in {head:?}"))?;
    let chunked = head.lines().any(|l| {
        l.to_ascii_lowercase()
            .starts_with("transfer-encoding: chunked")
    });
    let body = if chunked {
        dechunk(body)
    } else {
        body.to_vec()
    };
    Ok(Reply {
        status,
        head,
        body: String::from_utf8_lossy(&body).to_string(),
    })
}

/// The body of a chunked reply.
fn dechunk(mut rest: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = rest.windows(2).position(|w| w == b"\r\n") {
        let size = String::from_utf8_lossy(&rest[..eol]).to_string();
        let n = usize::from_str_radix(size.trim(), 16).unwrap_or(0);
        let after = &rest[eol + 2..];
        if n == 0 || after.len() < n {
            break;
        }
        out.extend_from_slice(&after[..n]);
        rest = after[n..].strip_prefix(b"\r\n").unwrap_or(&after[n..]);
    }
    out
}

/// The addresses a process listens on (TCP, IPv4 and IPv6), from /proc.
pub fn listening_addresses(pid: u32) -> Vec<String> {
    let mut inodes = Vec::new();
    if let Ok(fds) = std::fs::read_dir(format!("/proc/{pid}/fd")) {
        for fd in fds.flatten() {
            if let Ok(t) = std::fs::read_link(fd.path()) {
                let t = t.to_string_lossy().to_string();
                if let Some(i) = t.strip_prefix("socket:[").and_then(|r| r.strip_suffix(']')) {
                    inodes.push(i.to_owned());
                }
            }
        }
    }
    let mut out = Vec::new();
    for (file, v6) in [("tcp", false), ("tcp6", true)] {
        let text = std::fs::read_to_string(format!("/proc/{pid}/net/{file}")).unwrap_or_default();
        for line in text.lines().skip(1) {
            let f: Vec<&str> = line.split_whitespace().collect();
            // local_address, rem_address, st (0A = LISTEN), …, inode at index 9.
            if f.len() > 9 && f[3] == "0A" && inodes.iter().any(|i| i == f[9]) {
                out.push(decode_addr(f[1], v6));
            }
        }
    }
    out
}

fn decode_addr(hex: &str, v6: bool) -> String {
    let (ip, port) = hex.split_once(':').unwrap();
    let port = u16::from_str_radix(port, 16).unwrap();
    if v6 {
        // Four little-endian 32-bit words.
        let mut bytes = Vec::new();
        for w in 0..4 {
            let word = u32::from_str_radix(&ip[w * 8..w * 8 + 8], 16).unwrap();
            bytes.extend_from_slice(&word.to_le_bytes());
        }
        let a: [u8; 16] = bytes.try_into().unwrap();
        format!("[{}]:{port}", std::net::Ipv6Addr::from(a))
    } else {
        let v = u32::from_str_radix(ip, 16).unwrap();
        format!("{}:{port}", std::net::Ipv4Addr::from(v.to_le_bytes()))
    }
}
