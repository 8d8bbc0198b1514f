//! The `--web` page's Style panel over HTTP (`/api/style`, issue 27 §1): an edit regenerates
//! the model (by its strand-point hash and the moved point) and restarts the simulation with
//! the tuned parameters kept; mirror, copy, paste and delete; undo and redo over 50 steps;
//! save, `.bak` and `inspect --json`; bad and cross-origin edits refused with nothing changed.
//! (The panel in a real browser: `tests/web_browser.rs`.)

mod web_common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use serde_json::Value;
use web_common::{http, WebRun};

/// `GET /api/style`.
fn style(run: &WebRun) -> Value {
    let r = http(run.port, "GET", "/api/style", &[], "");
    assert_eq!(r.status, 200, "{}", r.body);
    serde_json::from_str(&r.body).expect("the panel's state is JSON")
}

/// A same-origin `POST /api/style`, as the page sends it.
fn edit(run: &WebRun, body: &str) -> web_common::Reply {
    let origin = format!("http://127.0.0.1:{}", run.port);
    http(
        run.port,
        "POST",
        "/api/style",
        &[("Origin", &origin), ("Content-Type", "application/json")],
        body,
    )
}

/// An edit that must be accepted; its reply.
fn ok(run: &WebRun, body: &str) -> Value {
    let r = edit(run, body);
    assert_eq!(r.status, 200, "{body}: {}", r.body);
    serde_json::from_str(&r.body).unwrap()
}

fn wisp<'a>(s: &'a Value, name: &str) -> &'a Value {
    s["wisps"]
        .as_array()
        .unwrap()
        .iter()
        .find(|w| w["name"] == name)
        .unwrap_or_else(|| panic!("no wisp {name} in {s}"))
}

fn vec3(v: &Value) -> [f64; 3] {
    [0, 1, 2].map(|k| v[k].as_f64().unwrap())
}

fn count(s: &Value) -> usize {
    s["wisps"].as_array().unwrap().len()
}

/// The log lines of the live state that contain `needle`.
fn log_lines(run: &WebRun, needle: &str) -> Vec<String> {
    run.state()["log"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|l| l["text"].as_str())
        .filter(|t| t.contains(needle))
        .map(str::to_owned)
        .collect()
}

/// `wisptree inspect --json FILE`'s model hash.
fn inspected_hash(file: &Path) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["inspect", "--json"])
        .arg(file)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    v["model_hash"].as_str().unwrap().to_owned()
}

#[test]
fn moving_a_point_regenerates_the_hair_and_restarts_within_a_second_keeping_the_tuned_parameters() {
    let run = WebRun::start(&[]);
    run.wait_state("first published state", |s| s["version"].as_u64() > Some(0));
    assert_eq!(
        run.control(r#"{"type":"set","param":"split_threshold","value":0.45}"#)
            .status,
        200
    );
    run.wait_state("threshold tuned", |s| {
        s["params"]["split_threshold"].as_f64() == Some(0.45)
    });
    let s0 = style(&run);
    assert_eq!(s0["editable"], true, "{s0}");
    let hash0 = s0["model_hash"].as_str().unwrap().to_owned();
    let w0 = wisp(&s0, "fringe_left");
    let (p0, normal) = (vec3(&w0["world"][2]), vec3(&w0["frames"][2][1]));

    let sent = Instant::now();
    let r = ok(
        &run,
        r#"{"type":"move","wisp":"fringe_left","point":2,"delta":[0,0.01,0]}"#,
    );
    assert_eq!(r["restart"], true, "{r}");
    // The simulation thread logs the restart once it has made it.
    while log_lines(&run, "style (web page): moved point 2").is_empty() {
        assert!(sent.elapsed() < Duration::from_secs(20), "no restart");
        std::thread::sleep(Duration::from_millis(20));
    }
    let took = sent.elapsed();
    assert!(
        took < Duration::from_secs(1),
        "regenerated and restarted in {took:?}"
    );
    let s1 = style(&run);
    let hash1 = s1["model_hash"].as_str().unwrap().to_owned();
    assert_ne!(hash1, hash0, "the model changed");
    assert_eq!(r["model_hash"].as_str(), Some(hash1.as_str()));
    // The point moved 10 mm along the scalp normal of its local frame, nothing else moved.
    let w1 = wisp(&s1, "fringe_left");
    let p1 = vec3(&w1["world"][2]);
    for k in 0..3 {
        assert!(
            (p1[k] - p0[k] - 0.01 * normal[k]).abs() < 1e-9,
            "{p0:?} → {p1:?}"
        );
    }
    assert_eq!(w1["world"][1], w0["world"][1]);
    assert_eq!(w1["world"][3], w0["world"][3]);
    // The tuned threshold survives the restart.
    let st = run.state();
    assert_eq!(st["params"]["split_threshold"].as_f64(), Some(0.45), "{st}");

    // Undo restores the model bit for bit; redo brings the edit back.
    ok(&run, r#"{"type":"undo"}"#);
    assert_eq!(style(&run)["model_hash"].as_str(), Some(hash0.as_str()));
    ok(&run, r#"{"type":"redo"}"#);
    assert_eq!(style(&run)["model_hash"].as_str(), Some(hash1.as_str()));

    // Undo goes back more than 50 steps.
    for _ in 0..52 {
        ok(
            &run,
            r#"{"type":"move","wisp":"back_upper","point":1,"delta":[0.001,0,0]}"#,
        );
    }
    assert_eq!(style(&run)["undo_steps"].as_u64(), Some(53));
    for _ in 0..53 {
        ok(&run, r#"{"type":"undo"}"#);
    }
    let back = style(&run);
    assert_eq!(back["model_hash"].as_str(), Some(hash0.as_str()), "{back}");
    assert_eq!(
        edit(&run, r#"{"type":"undo"}"#).status,
        400,
        "nothing left to undo"
    );
}

#[test]
fn mirror_copy_paste_and_delete_change_the_wisps() {
    let run = WebRun::start(&[]);
    let s0 = style(&run);
    let n0 = count(&s0);
    let src = wisp(&s0, "fringe_left").clone();

    // Mirror (Fig. 6): a new wisp whose key strand is the source's reflected across x = 0
    // (the scalp's centre), point for point.
    let r = ok(&run, r#"{"type":"mirror","wisp":"fringe_left"}"#);
    let s1 = style(&run);
    assert_eq!(count(&s1), n0 + 1);
    let name = s1["selected"].as_str().unwrap().to_owned();
    assert!(r["message"].as_str().unwrap().contains(&name), "{r}");
    let m = wisp(&s1, &name);
    let (a, b) = (
        src["world"].as_array().unwrap(),
        m["world"].as_array().unwrap(),
    );
    assert_eq!(a.len(), b.len());
    for (p, q) in a.iter().zip(b) {
        let (p, q) = (vec3(p), vec3(q));
        assert!((p[0] + q[0]).abs() < 1e-9, "{p:?} mirrored is {q:?}");
        assert!((p[1] - q[1]).abs() < 1e-9 && (p[2] - q[2]).abs() < 1e-9);
    }

    // Copy and paste at the back of the head: one more wisp, the same key strand in its new
    // root's styling frame (the shape relative to the root kept).
    ok(&run, r#"{"type":"copy","wisp":"fringe_left"}"#);
    ok(&run, r#"{"type":"paste","azimuth":175,"elevation":30}"#);
    let s2 = style(&run);
    assert_eq!(count(&s2), n0 + 2);
    let pasted = wisp(&s2, s2["selected"].as_str().unwrap());
    assert_eq!(pasted["key_strand"], src["key_strand"]);
    assert_ne!(pasted["world"][0], src["world"][0], "at a new root");
    let az = &pasted["azimuth"];
    assert!(az[0].as_f64().unwrap() < 175.0 && az[1].as_f64().unwrap() > 175.0);

    // Delete the pasted wisp and a copy; a wisp a copy is made from is refused.
    ok(
        &run,
        &format!(
            r#"{{"type":"delete","wisp":"{}"}}"#,
            pasted["name"].as_str().unwrap()
        ),
    );
    ok(&run, r#"{"type":"delete","wisp":"temple_right"}"#);
    assert_eq!(count(&style(&run)), n0);
    let r = edit(&run, r#"{"type":"delete","wisp":"fringe_left"}"#);
    assert_eq!(r.status, 400);
    assert!(r.body.contains("fringe_right"), "{}", r.body);
    // A new wisp from the template.
    ok(&run, r#"{"type":"create","azimuth":-100,"elevation":10}"#);
    assert_eq!(count(&style(&run)), n0 + 1);
    // Every page reads the same state: the restarts are in the shared log.
    run.wait_state("the edits' restarts logged", |s| {
        s["log"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|l| l["text"].as_str().unwrap().starts_with("style (web page)"))
            .count()
            >= 5
    });
}

#[test]
fn bad_and_cross_origin_edits_are_refused_and_change_nothing() {
    let run = WebRun::start(&[]);
    let before = style(&run);
    let port = run.port;
    for (body, needle) in [
        (
            r#"{"type":"move","wisp":"fringe_left","point":1,"delta":[0,-0.05,0]}"#,
            "under the scalp",
        ),
        (
            r#"{"type":"set_point","wisp":"fringe_left","point":1,"value":[0,-0.01,0]}"#,
            "under the scalp",
        ),
        (
            r#"{"type":"move","wisp":"fringe_left","point":1,"delta":[0,NaN,0]}"#,
            "not a request",
        ),
        (
            r#"{"type":"move","wisp":"fringe_left","point":1,"delta":[0,1e999,0]}"#,
            "not a request",
        ),
        (
            r#"{"type":"move","wisp":"nobody","point":1,"delta":[0,0.01,0]}"#,
            "no wisp `nobody`",
        ),
        (
            r#"{"type":"move","wisp":"fringe_left","point":0,"delta":[0,0.01,0]}"#,
            "root",
        ),
        (
            r#"{"type":"move","wisp":"fringe_left","point":9,"delta":[0,0.01,0]}"#,
            "control points 1 to",
        ),
        (
            r#"{"type":"move","wisp":"fringe_left","point":1,"delta":[0,3,0]}"#,
            "too large",
        ),
        (
            r#"{"type":"move","wisp":"fringe_right","point":1,"delta":[0,0.01,0]}"#,
            "copy of `fringe_left`",
        ),
        (
            r#"{"type":"shape","wisp":"fringe_left","density":1e9}"#,
            "density",
        ),
        (r#"{"type":"paste","azimuth":0,"elevation":0}"#, "Copy"),
        (r#"{"type":"save"}"#, "name a new .ron file"),
        (r#"{"type":"save","file":"Cargo.toml"}"#, "ends in .ron"),
        (r#"{"type":"erase_all"}"#, "not a request"),
    ] {
        let r = edit(&run, body);
        assert_eq!(r.status, 400, "{body}: {}", r.body);
        assert!(r.body.contains(needle), "{body}: {}", r.body);
    }
    // A request too large.
    let big = format!(r#"{{"type":"select","wisp":"{}"}}"#, "x".repeat(5000));
    let r = edit(&run, &big);
    assert_eq!(r.status, 400, "{}", r.body);
    assert!(r.body.contains("too large"), "{}", r.body);

    // Other origins, no origin, another Host, a form post: refused as on the Tune panel.
    let good = r#"{"type":"move","wisp":"fringe_left","point":2,"delta":[0,0.01,0]}"#;
    let origin = format!("http://127.0.0.1:{port}");
    let json = ("Content-Type", "application/json");
    for (headers, code) in [
        (vec![json], 403),
        (vec![("Origin", "http://evil.example"), json], 403),
        (
            vec![("Origin", origin.as_str()), ("Content-Type", "text/plain")],
            415,
        ),
        (
            vec![
                ("Host", "evil.example"),
                ("Origin", "http://evil.example"),
                json,
            ],
            403,
        ),
    ] {
        let r = http(port, "POST", "/api/style", &headers, good);
        assert_eq!(r.status, code, "{headers:?}: {}", r.body);
        assert!(r.body.contains("refused"), "{}", r.body);
    }
    let after = style(&run);
    assert_eq!(after["model_hash"], before["model_hash"]);
    assert_eq!(after["version"], before["version"]);
    assert_eq!(after["wisps"], before["wisps"]);
    assert!(log_lines(&run, "style (web page)").is_empty());
}

#[test]
fn save_writes_the_edited_model_keeps_the_comments_and_the_previous_text_as_bak() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("mine.ron");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("styles/short.ron")).unwrap();
    let text = format!("// my own notes on this style\n{text}");
    std::fs::write(&file, &text).unwrap();
    let run = WebRun::start_style(file.to_str().unwrap(), &[]);
    let s0 = style(&run);
    assert_eq!(s0["file"].as_str(), file.to_str());
    assert_eq!(inspected_hash(&file), s0["model_hash"].as_str().unwrap());

    ok(
        &run,
        r#"{"type":"move","wisp":"fringe_left","point":3,"delta":[0,0.004,0.002]}"#,
    );
    ok(&run, r#"{"type":"mirror","wisp":"back_upper"}"#);
    let s1 = style(&run);
    assert_eq!(s1["unsaved"], true);
    assert_eq!(s1["save_keeps_comments"], true, "{s1}");
    let r = ok(&run, r#"{"type":"save"}"#);
    assert!(
        r["message"].as_str().unwrap().contains("mine.ron.bak"),
        "{r}"
    );
    // The saved file loads to the edited model, bit for bit.
    assert_eq!(inspected_hash(&file), s1["model_hash"].as_str().unwrap());
    let saved = std::fs::read_to_string(&file).unwrap();
    let bak = dir.path().join("mine.ron.bak");
    assert_eq!(std::fs::read_to_string(&bak).unwrap(), text);
    // The comments the edit did not touch are kept.
    for comment in text.lines().filter(|l| l.trim_start().starts_with("//")) {
        assert!(saved.contains(comment), "lost {comment:?}");
    }
    assert_eq!(style(&run)["unsaved"], false);

    // An edit right after a save is not undone when the run's watcher sees that save.
    ok(&run, r#"{"type":"delete","wisp":"nape_right"}"#);
    let deleted = style(&run);
    std::thread::sleep(Duration::from_millis(700));
    assert_eq!(style(&run)["model_hash"], deleted["model_hash"]);
    // A second save keeps the first saved text as the backup.
    ok(&run, r#"{"type":"save"}"#);
    assert_eq!(std::fs::read_to_string(&bak).unwrap(), saved);
    assert_eq!(
        inspected_hash(&file),
        style(&run)["model_hash"].as_str().unwrap()
    );
    // The watched file changed under the run: saving is not taken for another edit.
    std::thread::sleep(Duration::from_millis(600));
    assert!(
        log_lines(&run, "the model changed").is_empty(),
        "{:?}",
        run.state()["log"]
    );

    // An edit made to the file in an editor becomes the panel's style (one undoable step).
    let steps = style(&run)["undo_steps"].as_u64().unwrap();
    let edited = std::fs::read_to_string(&file).unwrap().replacen(
        "tip_spread: 0.006",
        "tip_spread: 0.009",
        1,
    );
    std::fs::write(&file, &edited).unwrap();
    let want = inspected_hash(&file);
    let start = Instant::now();
    while style(&run)["model_hash"].as_str() != Some(want.as_str()) {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "the panel did not take the file"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let s = style(&run);
    assert_eq!(s["undo_steps"].as_u64(), Some(steps + 1));
    assert_eq!(s["unsaved"], false);

    // Saving as a new file: never over an existing one.
    let r = edit(
        &run,
        &format!(r#"{{"type":"save","file":"{}"}}"#, bak.display()),
    );
    assert_eq!(r.status, 400, "{}", r.body);
    let other = dir.path().join("other.ron");
    ok(
        &run,
        &format!(r#"{{"type":"save","file":"{}"}}"#, other.display()),
    );
    assert_eq!(
        inspected_hash(&other),
        style(&run)["model_hash"].as_str().unwrap()
    );
}

#[test]
fn a_built_in_style_saves_to_a_new_file_and_an_explicit_one_cannot_be_edited() {
    let dir = tempfile::tempdir().unwrap();
    let run = WebRun::start(&[]);
    ok(
        &run,
        r#"{"type":"shape","wisp":"top_left","tip_spread":0.02,"radius":[30,15]}"#,
    );
    let hash = style(&run)["model_hash"].as_str().unwrap().to_owned();
    let out = dir.path().join("short_edited.ron");
    ok(
        &run,
        &format!(r#"{{"type":"save","file":"{}"}}"#, out.display()),
    );
    assert_eq!(inspected_hash(&out), hash);
    assert!(!dir.path().join("short_edited.ron.bak").exists());
    // Its comments came along.
    let saved = std::fs::read_to_string(&out).unwrap();
    assert!(saved.starts_with("//"), "{saved}");
    drop(run);

    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let run = WebRun::start_style(root.join("scenes/awt_fig5.ron").to_str().unwrap(), &[]);
    let s = style(&run);
    assert_eq!(s["editable"], false, "{s}");
    assert!(
        s["reason"].as_str().unwrap().contains("cannot be edited"),
        "{s}"
    );
    let r = edit(&run, r#"{"type":"create","azimuth":0,"elevation":40}"#);
    assert_eq!(r.status, 400);
    assert!(r.body.contains("cannot be edited"), "{}", r.body);
}
