//! `wisptree gallery`: it writes a picture of every built-in style and of every registered
//! experiment's runs, and a page that shows them; the page loads in headless Chromium
//! (Debian's `chromium` and `chromium-driver`, which `.ci/run` installs) with every image
//! there. A folder it may not write into exits 2, and a file the user made is kept.

mod web_common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::{json, Value};
use web_common::{http, try_http};

fn wisptree(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn fresh_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wisptree-gallery-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// The `src` of every `<img>` of the page, in order.
fn image_sources(html: &str) -> Vec<String> {
    html.split("<img src=\"")
        .skip(1)
        .map(|rest| rest.split('"').next().unwrap_or_default().to_owned())
        .collect()
}

#[test]
fn the_gallery_writes_every_picture_and_a_page_that_loads_in_chromium_with_none_missing() {
    let dir = fresh_dir("page");
    // A file of the user's where the page goes: kept, not overwritten.
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("index.html"), "my notes").unwrap();
    let out = dir.to_str().unwrap();
    let (code, stdout, stderr) = wisptree(&["gallery", "--quick", "--no-progress", "--out", out]);
    assert_eq!(code, 0, "{stdout}\n{stderr}");
    assert_eq!(
        std::fs::read_to_string(dir.join("index.html.bak")).unwrap(),
        "my notes",
        "the user's file is kept as .bak"
    );
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let sources = image_sources(&html);
    // Every built-in style, every experiment's every run, and awt-fig7's contact sheet.
    let mut expected: Vec<String> = ["short", "short_curly", "long", "long_curly"]
        .iter()
        .map(|s| format!("style_{s}.png"))
        .collect();
    expected.push("exp_awt-fig7_awt_fig7.png".into());
    for e in wisptree::experiment::all() {
        let claim = e
            .expectation
            .replace('&', "&amp;")
            .replace('<', "&lt;")
            .replace('>', "&gt;")
            .replace('"', "&quot;")
            .replace('\'', "&#39;");
        assert!(html.contains(&claim), "{}: its claim on the page", e.name);
        assert!(
            html.contains(&format!("id=\"{}\"", e.name)),
            "{}: a section",
            e.name
        );
    }
    for label in [
        "short_run",
        "long_lean",
        "long_curly_lean",
        "short_curly_lean",
    ] {
        expected.push(format!("exp_awt-fig7_{label}.png"));
    }
    // The rendering experiments' pictures (through the same `FrameSink::picture` as
    // `wisptree experiment --out`) and their runs' rendered images.
    for f in [
        "zhang_fig12",
        "zhang_fig12_layers",
        "zhang_fig13",
        "zhang_fig14",
    ] {
        let exp = f[..11].replace('_', "-");
        expected.push(format!("exp_{exp}_{f}.png"));
    }
    for label in [
        "none",
        "filter",
        "supersampling",
        "supersampling_filter",
        "wisptree",
    ] {
        expected.push(format!("exp_zhang-fig14_{label}.png"));
    }
    for f in &expected {
        assert!(sources.contains(f), "{f} on the page: {sources:?}");
    }
    for f in &sources {
        let bytes = std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f} is a PNG");
        let img = image::load_from_memory(&bytes).unwrap();
        // The gallery renders at 320x240 or more; a rendering experiment's own images are
        // its measured crops (zhang-fig14's 4x zooms of a hair: 1624x160), smaller but whole.
        let min = if f.starts_with("exp_zhang-") {
            (100, 100)
        } else {
            (320, 240)
        };
        assert!(img.width() >= min.0 && img.height() >= min.1, "{f}");
        let rgb = img.to_rgb8();
        let first = rgb.get_pixel(0, 0);
        assert!(
            rgb.pixels().any(|p| p != first),
            "{f} shows something, not a blank"
        );
    }
    // awt-fig7's numbers are printed beside its pictures.
    assert!(html.contains("splits = "), "the printed numbers");
    assert!(html.contains("active_over_time = ["));

    // The page in a browser: every image loads.
    let d = Driver::start();
    let url = format!("file://{}", dir.join("index.html").display());
    d.call("POST", "/url", Some(json!({ "url": url })));
    let start = Instant::now();
    let report = loop {
        let r = d.script(
            "return Array.from(document.images).map(i => \
             [i.getAttribute('src'), i.complete, i.naturalWidth, i.naturalHeight]);",
        );
        let all_done = r
            .as_array()
            .is_some_and(|a| a.iter().all(|i| i[1].as_bool() == Some(true)));
        if all_done || start.elapsed() > Duration::from_secs(30) {
            break r;
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let images = report.as_array().expect("a list");
    assert_eq!(images.len(), sources.len(), "{report}");
    for i in images {
        assert!(
            i[1].as_bool() == Some(true) && i[2].as_u64() > Some(0) && i[3].as_u64() > Some(0),
            "an image the browser could not show: {i}"
        );
    }
    let title = d.script("return document.title;");
    assert_eq!(title, "wisptree gallery");

    // Again into the same folder: its own files are replaced, nothing new is moved aside.
    std::fs::remove_file(dir.join("index.html.bak")).unwrap();
    let (code, _, stderr) = wisptree(&["gallery", "--quick", "--no-progress", "--out", out]);
    assert_eq!(code, 0, "{stderr}");
    assert!(!dir.join("index.html.bak").exists(), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_out_path_exits_2_naming_it() {
    let dir = fresh_dir("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("a_file");
    std::fs::write(&file, "x").unwrap();
    for out in [file.clone(), file.join("below")] {
        let (code, _, stderr) = wisptree(&["gallery", "--quick", "--out", out.to_str().unwrap()]);
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains("--out"), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A chromedriver process and one session (as tests/web_browser.rs drives it).
struct Driver {
    child: std::process::Child,
    port: u16,
    session: String,
}

impl Driver {
    fn start() -> Driver {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let child = Command::new("chromedriver")
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect(
                "chromedriver not found: install Debian's chromium and chromium-driver \
                 (`.ci/run` does)",
            );
        let mut d = Driver {
            child,
            port,
            session: String::new(),
        };
        let start = Instant::now();
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "chromedriver does not listen"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        assert!(
            Path::new("/usr/bin/chromium").exists(),
            "/usr/bin/chromium not found: install Debian's chromium and chromium-driver \
             (`.ci/run` does)"
        );
        let caps = json!({"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": "/usr/bin/chromium",
                "args": ["--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                         "--window-size=1280,800", "--allow-file-access-from-files"]
            }
        }}});
        let v = d.call("POST", "/session", Some(caps));
        d.session = v["sessionId"].as_str().expect("a session id").to_owned();
        d
    }

    fn call(&self, method: &str, path: &str, body: Option<Value>) -> Value {
        let path = if path == "/session" {
            path.to_owned()
        } else {
            format!("/session/{}{path}", self.session)
        };
        let body = body.map(|b| b.to_string()).unwrap_or_default();
        let headers: &[(&str, &str)] = if method == "POST" {
            &[("Content-Type", "application/json")]
        } else {
            &[]
        };
        let r = http(self.port, method, &path, headers, &body);
        let v: Value = serde_json::from_str(&r.body)
            .unwrap_or_else(|_| panic!("{method} {path}: not JSON: {}", r.body));
        assert_eq!(r.status, 200, "{method} {path} {body}: {v}");
        v["value"].clone()
    }

    fn script(&self, js: &str) -> Value {
        self.call(
            "POST",
            "/execute/sync",
            Some(json!({"script": js, "args": []})),
        )
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        if !self.session.is_empty() {
            let _ = try_http(
                self.port,
                "DELETE",
                &format!("/session/{}", self.session),
                &[],
                "",
            );
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
