//! `wisptree run --web`: what listens where, which requests the control endpoint takes, and
//! that a change reaches the simulation and every page's state. (The page in a real browser:
//! `tests/web_browser.rs`.)

mod web_common;

use std::time::Duration;

use web_common::{http, listening_addresses, WebRun};

#[test]
fn everything_listens_on_loopback_only_and_ctrl_c_stops_cleanly() {
    let mut run = WebRun::start(&[]);
    let line = run.wait_line("Rerun web viewer on port", Duration::from_secs(10));
    let mut ports: Vec<u16> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .filter(|p| *p > 1000)
        .collect();
    ports.sort_unstable();
    ports.dedup();
    assert_eq!(ports.len(), 2, "viewer and gRPC ports in {line:?}");
    // Every server is up once the page answers.
    assert_eq!(http(run.port, "GET", "/", &[], "").status, 200);
    let addrs = listening_addresses(run.child.id());
    for p in ports.iter().chain([&run.port]) {
        assert!(
            addrs.iter().any(|a| a.ends_with(&format!(":{p}"))),
            "port {p} not among the listeners {addrs:?}"
        );
    }
    assert!(addrs.len() >= 3, "{addrs:?}");
    for a in &addrs {
        assert!(
            a.starts_with("127.0.0.1:"),
            "listening outside loopback: {a} (all: {addrs:?})"
        );
    }
    let st = run.interrupt();
    assert!(st.success(), "exit after Ctrl-C: {st}");
}

#[test]
fn the_control_endpoint_takes_only_the_pages_requests_from_its_own_origin() {
    let run = WebRun::start(&[]);
    let port = run.port;
    let page = http(port, "GET", "/", &[], "");
    assert_eq!(page.status, 200);
    assert!(
        page.body.contains("id=\"params\"") && page.body.contains("/viewer/re_viewer.js"),
        "{}",
        page.body
    );
    let s0 = run.wait_state("first published state", |s| s["version"].as_u64() > Some(0));
    let split0 = s0["params"]["split_threshold"].as_f64().unwrap();
    let good = r#"{"type":"set","param":"split_threshold","value":0.45}"#;

    // Other origins, no origin, another Host (DNS rebinding), a form post: refused.
    let origin = format!("http://127.0.0.1:{port}");
    let json = ("Content-Type", "application/json");
    for (headers, code) in [
        (vec![json], 403),
        (vec![("Origin", "http://evil.example"), json], 403),
        (vec![("Origin", "null"), json], 403),
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
        let r = http(port, "POST", "/api/control", &headers, good);
        assert_eq!(r.status, code, "{headers:?}: {}", r.body);
        assert!(r.body.contains("refused"), "{}", r.body);
    }
    assert_eq!(
        http(
            port,
            "GET",
            "/api/state",
            &[("Host", "evil.example:80")],
            ""
        )
        .status,
        403
    );
    assert_eq!(http(port, "GET", "/api/control", &[], "").status, 405);
    assert_eq!(http(port, "GET", "/secret", &[], "").status, 404);
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(
        run.state()["params"]["split_threshold"].as_f64(),
        Some(split0)
    );

    // Bad values and unknown messages: refused with a message, the run goes on.
    for (body, needle) in [
        (
            r#"{"type":"set","param":"split_threshold","value":3}"#,
            "between",
        ),
        (
            r#"{"type":"set","param":"split_threshold","value":"x"}"#,
            "not a number",
        ),
        (r#"{"type":"set","param":"friction","value":150}"#, "α·dt"),
        (r#"{"type":"quit"}"#, "not a request"),
        (
            r#"{"type":"motion","name":"../../etc/passwd"}"#,
            "no motion",
        ),
    ] {
        let r = run.control(body);
        assert_eq!(r.status, 400, "{body}: {}", r.body);
        assert!(r.body.contains(needle), "{body}: {}", r.body);
    }

    // The page's own request is taken, and the simulation's state shows it.
    let r = run.control(good);
    assert_eq!(r.status, 200, "{}", r.body);
    let s = run.wait_state("split threshold applied", |s| {
        s["params"]["split_threshold"].as_f64() == Some(0.45)
    });
    assert!(
        s["log"]
            .as_array()
            .unwrap()
            .iter()
            .any(|l| l["text"].as_str().unwrap().contains("split threshold")),
        "the change is in the log: {s}"
    );
    let wind = run.control(r#"{"type":"set","param":"wind","value":2}"#);
    assert_eq!(wind.status, 200, "{}", wind.body);
    run.wait_state("wind applied", |s| {
        s["params"]["wind"].as_f64() == Some(2.0)
    });
    // Pause, a model switch and a motion switch keep the tuned threshold.
    assert_eq!(run.control(r#"{"type":"pause","paused":true}"#).status, 200);
    run.wait_state("paused", |s| s["paused"] == true);
    assert_eq!(
        run.control(r#"{"type":"pause","paused":false}"#).status,
        200
    );
    assert_eq!(
        run.control(r#"{"type":"model","name":"single-level"}"#)
            .status,
        200
    );
    assert_eq!(
        run.control(r#"{"type":"motion","name":"shake"}"#).status,
        200
    );
    let s = run.wait_state("model and motion switched", |s| {
        s["model"] == "single-level" && s["motion"] == "shake"
    });
    // Single-level has no thresholds: its table, and so the page, has no such slider.
    assert_eq!(s["params"]["split_threshold"].as_f64(), None, "{s}");
    assert_eq!(s["params"]["wind"].as_f64(), Some(2.0), "{s}");
    assert_eq!(run.control(r#"{"type":"model","name":"awt"}"#).status, 200);
    let s = run.wait_state("back to the AWT", |s| s["model"] == "awt");
    assert_eq!(s["params"]["split_threshold"].as_f64(), Some(0.45), "{s}");
    let t = s["sim_time"].as_f64().unwrap();
    run.wait_state("still simulating", |s| s["sim_time"].as_f64().unwrap() > t);
}

/// The page's sliders are the running model's table of tunables: the layered model's own
/// (viscosity, …), refused for a name of another model, and the guide model's after a switch.
#[test]
fn each_model_brings_its_own_tunables_to_the_page() {
    let run = WebRun::start(&["--model", "layered"]);
    let s = run.wait_state("first published state", |s| {
        s["model"].as_str() == Some("layered")
    });
    let names: Vec<&str> = s["tunables"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    let table: Vec<&str> = wisptree::solver::SolverKind::Layered
        .tunables()
        .iter()
        .map(|t| t.name)
        .collect();
    assert_eq!(
        names, table,
        "the state carries the layered table, in its order"
    );
    assert!(s["tunables"][0]["label"]
        .as_str()
        .unwrap()
        .contains("viscosity"));

    let r = run.control(r#"{"type":"set","param":"viscosity","value":50}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    run.wait_state("viscosity applied", |s| {
        s["params"]["viscosity"].as_f64() == Some(50.0)
    });
    let r = run.control(r#"{"type":"set","param":"split_threshold","value":0.2}"#);
    assert_eq!(r.status, 400, "{}", r.body);
    assert!(r.body.contains("for model layered"), "{}", r.body);
    let r = run.control(r#"{"type":"set","param":"viscosity","value":500}"#);
    assert_eq!(r.status, 400, "{}", r.body);
    assert!(r.body.contains("between 0 and 100"), "{}", r.body);

    let r = run.control(r#"{"type":"model","name":"guides"}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    run.wait_state("the guide model's table", |s| {
        s["tunables"]
            .as_array()
            .is_some_and(|t| t.iter().any(|t| t["name"] == "link_strength"))
    });
    let r = run.control(r#"{"type":"set","param":"link_strength","value":900}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    run.wait_state("link stiffness applied", |s| {
        s["params"]["link_strength"].as_f64() == Some(900.0)
    });
}

#[test]
fn the_inspector_shows_a_nodes_split_and_merge_tests_every_frame() {
    let run = WebRun::start(&[]);
    run.wait_state("first published state", |s| s["version"].as_u64() > Some(0));
    assert!(
        run.state()["inspect"].is_null(),
        "no node is inspected at the start"
    );
    let r = run.control(r#"{"type":"inspect","node":"0:1:2"}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    let s = run.wait_state("the inspected node's numbers", |s| {
        s["inspect"]["node"] == "0:1:2"
    });
    let values = |s: &serde_json::Value| -> Vec<(String, f64)> {
        s["inspect"]["values"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| (p[0].as_str().unwrap().to_owned(), p[1].as_f64().unwrap()))
            .collect()
    };
    let v = values(&s);
    let names: Vec<&str> = v.iter().map(|(n, _)| n.as_str()).collect();
    for n in [
        "accel_radius",
        "split_threshold_in_force",
        "may_split",
        "merge_relative_velocity",
        "merge_velocity_in_force",
        "last_change_s",
        "position_x",
        "velocity_z",
        "acceleration_y",
        "radius",
        "mass",
    ] {
        assert!(names.contains(&n), "{n} missing from {names:?}");
    }
    let get = |v: &[(String, f64)], n: &str| v.iter().find(|(k, _)| k == n).unwrap().1;
    // The threshold shown is the one in force: set it, and the inspector follows.
    assert_eq!(
        get(&v, "split_threshold_in_force"),
        s["params"]["split_threshold"].as_f64().unwrap()
    );
    let r = run.control(r#"{"type":"set","param":"split_threshold","value":0.33}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    let s = run.wait_state("the new threshold in the inspector", |s| {
        s["inspect"]["values"].as_array().is_some_and(|a| {
            a.iter()
                .any(|p| p[0] == "split_threshold_in_force" && p[1] == 0.33)
        })
    });
    // Updated every frame: the time of the numbers moves on.
    let t0 = s["inspect"]["sim_time"].as_f64().unwrap();
    run.wait_state("later numbers", |s| {
        s["inspect"]["sim_time"].as_f64().is_some_and(|t| t > t0)
    });

    // A node the model does not have: refused in the log, the inspected node stays.
    let r = run.control(r#"{"type":"inspect","node":"0:9:0"}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    let s = run.wait_state("the refusal in the log", |s| {
        s["log"].as_array().unwrap().iter().any(|l| {
            l["text"]
                .as_str()
                .unwrap()
                .contains("level 9 does not exist")
        })
    });
    assert_eq!(s["inspect"]["node"], "0:1:2");
    // Malformed: refused at once with 400, naming the form.
    for body in [
        r#"{"type":"inspect","node":"0:1"}"#,
        r#"{"type":"inspect","node":"a:b:c"}"#,
        r#"{"type":"inspect"}"#,
        r#"{"type":"inspect","node":"0:1:2","extra":1}"#,
    ] {
        let r = run.control(body);
        assert_eq!(r.status, 400, "{body}: {}", r.body);
    }
    let r = run.control(r#"{"type":"inspect","node":"0:1"}"#);
    assert!(r.body.contains("TREE:LEVEL:INDEX"), "{}", r.body);
    // Clear: no node.
    let r = run.control(r#"{"type":"inspect","node":""}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    run.wait_state("no node inspected", |s| s["inspect"].is_null());
}

#[test]
fn the_page_hosts_the_viewer_and_inspects_the_node_clicked_in_it() {
    let run = WebRun::start(&[]);
    // The viewer's script and wasm come from the page's own server (same origin).
    let js = http(run.port, "GET", "/viewer/re_viewer.js", &[], "");
    assert_eq!(js.status, 200);
    assert!(js.body.contains("WebHandle"), "not the viewer's script");
    let wasm = http(run.port, "GET", "/viewer/re_viewer_bg.wasm", &[], "");
    assert_eq!(wasm.status, 200);
    assert!(wasm.body.starts_with("\0asm"), "not WebAssembly");
    assert!(
        wasm.head
            .to_ascii_lowercase()
            .contains("content-type: application/wasm"),
        "{}",
        wasm.head
    );
    run.wait_state("first published state", |s| s["version"].as_u64() > Some(0));
    // What the page sends when the viewer reports a click on an instance of the nodes.
    let r = run.control(r#"{"type":"pick","instance":0,"position":null}"#);
    assert_eq!(r.status, 200, "{}", r.body);
    let s = run.wait_state("the clicked node inspected", |s| {
        s["inspect"]["node"].is_string()
    });
    assert!(
        s["log"].as_array().unwrap().iter().any(|l| l["text"]
            .as_str()
            .unwrap()
            .contains("(clicked in the view)")),
        "{s}"
    );
    for body in [
        r#"{"type":"pick","instance":null,"position":null}"#,
        r#"{"type":"pick","instance":1000000000000}"#,
        r#"{"type":"pick","position":[0,1e300,0]}"#,
        r#"{"type":"pick","position":[0,1]}"#,
    ] {
        let r = run.control(body);
        assert_eq!(r.status, 400, "{body}: {}", r.body);
    }
}
