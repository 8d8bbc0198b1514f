//! `wisptree inspect` end to end: its output, and every kind of bad input exiting with code 2
//! and a message that names the file, the position and the field.

mod common;

use std::path::Path;
use std::process::Command;

use common::*;

fn wisptree(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(args)
        .output()
        .expect("the binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A valid small generated style, as text, to break in various ways.
fn good_style() -> String {
    r#"Style(
    name: "small",
    hair: Generated((
        density: 5,
        wisps: [(
            name: "left",
            region: (azimuth: (60, 120), elevation: (10, 50)),
            key_strand: [(0.05, 0.01, 0.0), (0.15, 0.0, 0.0)],
        )],
        copies: [(source: "left", name: "right", mirror: true)],
    )),
    hierarchy: (levels: 2, cross_sections: 6, branching: [3]),
    sim: (total_mass: 0.5),
)
"#
    .to_string()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn inspect_prints_levels_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "good.ron", &good_style());
    let (code, out, err) = wisptree(&["inspect", &p]);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("strands") && out.contains("link         rigid"),
        "{out}"
    );
    let (code, out, err) = wisptree(&["inspect", &p, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["levels"], 2);
    assert_eq!(v["cross_sections"], 6);
    assert_eq!(v["link"], "rigid");
    let nodes = v["nodes_per_level"].as_array().unwrap();
    let gcs = v["gcs_per_level"].as_array().unwrap();
    assert_eq!(nodes.len(), 2);
    // Two wisps (left and its mirror), each split in 3.
    assert_eq!(gcs[0], 2);
    assert_eq!(gcs[1], 6);
    assert_eq!(nodes[1].as_u64().unwrap(), 6 * 6);
    assert!((v["total_mass_kg"].as_f64().unwrap() - 0.5).abs() < 1e-12);
    assert!(v["strands"].as_u64().unwrap() >= 6);
}

#[test]
fn inspect_json_on_the_paper_styles() {
    for (name, levels) in [("short.ron", 2), ("long_curly.ron", 3)] {
        let p = root().join("styles").join(name);
        let (code, out, err) = wisptree(&["inspect", p.to_str().unwrap(), "--json"]);
        assert_eq!(code, 0, "{err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v["levels"], levels);
    }
}

/// `inspect --json`'s `model_hash` fingerprints the hair built: a copy of a built-in style's
/// file gives the built-in's hash, a copy with one key-strand coordinate nudged does not, and
/// the hash is the same run after run.
#[test]
fn inspect_model_hash_follows_the_strand_points() {
    let hash = |style: &str| {
        let (code, out, err) = wisptree(&["inspect", style, "--json"]);
        assert_eq!(code, 0, "{style}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        let h = v["model_hash"].as_str().unwrap().to_owned();
        assert_eq!(h.len(), 16, "{h}");
        h
    };
    let builtin = hash("short");
    assert_eq!(builtin, hash("short"), "the same style twice");
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("styles/short.ron")).unwrap();
    let copy = write(dir.path(), "copy.ron", &text);
    assert_eq!(
        hash(&copy),
        builtin,
        "a copy of the file builds the same hair"
    );
    let first = text
        .find("key_strand: [(")
        .expect("short.ron has key strands")
        + 14;
    let end = first + text[first..].find(',').unwrap();
    let x: f64 = text[first..end].trim().parse().unwrap();
    let nudged = format!("{}{}{}", &text[..first], x + 0.001, &text[end..]);
    let moved = write(dir.path(), "moved.ron", &nudged);
    assert_ne!(
        hash(&moved),
        builtin,
        "one key-strand coordinate moved by 1 mm"
    );
}

/// `inspect --coverage` prints one line per view, and those four percentages are the only
/// numbers followed by `%`; `--json` gives the same numbers; `--images` writes the four maps.
#[test]
fn inspect_coverage_prints_four_views() {
    let dir = tempfile::tempdir().unwrap();
    let imgs = dir.path().join("maps");
    let (code, out, err) = wisptree(&[
        "inspect",
        "--coverage",
        "short",
        "--size",
        "320x240",
        "--images",
        imgs.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let percents: Vec<(String, f64)> = out
        .lines()
        .filter(|l| l.contains('%'))
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(w.len(), 3, "{l}");
            assert_eq!(w[2], "%", "{l}");
            (w[0].to_string(), w[1].parse().unwrap())
        })
        .collect();
    let views: Vec<&str> = percents.iter().map(|(v, _)| v.as_str()).collect();
    assert_eq!(views, ["top", "behind", "left", "right"], "{out}");
    assert_eq!(out.matches('%').count(), 4, "{out}");
    for (v, p) in &percents {
        assert!((0.0..=100.0).contains(p) && *p > 20.0, "{v} {p}");
        assert!(imgs.join(format!("coverage_{v}.png")).is_file());
    }
    let (code, json, err) = wisptree(&[
        "inspect",
        "--coverage",
        "short",
        "--size",
        "320x240",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    for (k, (_, p)) in percents.iter().enumerate() {
        let j = v[k]["hidden_percent"].as_f64().unwrap();
        assert!((j - p).abs() < 0.051, "{j} vs {p}");
    }
    let (code, _, err) = wisptree(&["inspect", "short", "--images", "x"]);
    assert_eq!(code, 2, "{err}");
}

/// Each case: (file name, text or None for a missing file, what the message must contain).
#[test]
fn bad_styles_exit_2_with_file_position_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = good_style();
    let cases: Vec<(&str, Option<String>, Vec<&str>)> =
        vec![
        ("missing.ron", None, vec!["missing.ron", "no such file", "built-in"]),
        ("empty.ron", Some(String::new()), vec!["empty.ron", "empty"]),
        (
            "notron.ron",
            Some("this is not RON at all {".into()),
            vec!["notron.ron:1:"],
        ),
        (
            "syntax.ron",
            Some(good.replace("name: \"left\",", "name: \"left\" ,,")),
            vec!["syntax.ron:6:"],
        ),
        (
            "unknown.ron",
            Some(good.replace(
                "sim: (total_mass: 0.5)",
                "sim: (total_mass: 0.5, splt_threshold: 1)",
            )),
            vec!["unknown.ron:13:", "splt_threshold"],
        ),
        (
            "wrongtype.ron",
            Some(good.replace("total_mass: 0.5", "total_mass: \"heavy\"")),
            vec!["wrongtype.ron:13:"],
        ),
        (
            "nolevels.ron",
            Some(good.replace(
                "levels: 2, cross_sections: 6, branching: [3]",
                "levels: 0, branching: []",
            )),
            vec!["nolevels.ron", "hierarchy.levels"],
        ),
        (
            "k1.ron",
            Some(good.replace("cross_sections: 6", "cross_sections: 1")),
            vec!["k1.ron:12", "hierarchy.cross_sections"],
        ),
        (
            "radius.ron",
            Some(good.replace(
                "    name: \"small\",",
                "    name: \"small\",\n    head: (body: [(center: (0, 1.6, 0), radius: -0.1)]),",
            )),
            vec!["radius.ron", "head.body[0].radius"],
        ),
        (
            "mass.ron",
            Some(good.replace("total_mass: 0.5", "total_mass: -1")),
            vec!["mass.ron:13", "sim.total_mass"],
        ),
        (
            "alpha.ron",
            Some(good.replace(
                "sim: (total_mass: 0.5)",
                "sim: (total_mass: 0.5, friction: 150, dt: 0.01)",
            )),
            vec!["alpha.ron:13", "sim.friction", "α·dt"],
        ),
        (
            "mirror.ron",
            Some(good.replace("source: \"left\"", "source: \"lefty\"")),
            vec!["mirror.ron:10", "hair.copies[0].source", "lefty"],
        ),
    ];
    for (name, text, needles) in cases {
        let path = match &text {
            Some(t) => write(dir.path(), name, t),
            None => dir.path().join(name).to_string_lossy().into_owned(),
        };
        let (code, _, err) = wisptree(&["inspect", &path]);
        assert_eq!(code, 2, "{name}: exit {code}, stderr: {err}");
        assert!(
            !err.contains("panicked") && !err.contains("backtrace"),
            "{name}: {err}"
        );
        assert!(err.lines().count() <= 3, "{name}: message too long: {err}");
        for n in needles {
            assert!(err.contains(n), "{name}: `{n}` not in: {err}");
        }
    }
}

#[test]
fn bad_tfx_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let style = |file: &str| {
        format!("Style(hair: TressFx((files: [\"{file}\"])), hierarchy: (levels: 2, cross_sections: 4, branching: [2], top_level: 2))")
    };
    // A valid v4 file to corrupt.
    let strands: Vec<Vec<[f32; 3]>> = (0..8)
        .map(|s| (0..4).map(|v| [s as f32, 100.0 - v as f32, 0.0]).collect())
        .collect();
    let bytes = wisptree::style::tfx::write_tfx_v4(&strands);
    std::fs::write(dir.path().join("ok.tfx"), &bytes).unwrap();
    std::fs::write(dir.path().join("short.tfx"), &bytes[..bytes.len() - 10]).unwrap();
    let mut bad_header = bytes.clone();
    bad_header[0..4].copy_from_slice(&7.5f32.to_le_bytes());
    std::fs::write(dir.path().join("header.tfx"), &bad_header).unwrap();
    let mut sizes = bytes.clone();
    sizes[4..8].copy_from_slice(&1000u32.to_le_bytes());
    std::fs::write(dir.path().join("sizes.tfx"), &sizes).unwrap();

    let p = write(dir.path(), "ok.ron", &style("ok.tfx"));
    let (code, out, err) = wisptree(&["inspect", &p, "--json"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("\"strands\": 8"), "{out}");

    for (file, needle) in [
        ("nothere.tfx", "nothere.tfx"),
        ("short.tfx", "truncated"),
        ("header.tfx", "version"),
        ("sizes.tfx", "1000"),
    ] {
        let p = write(dir.path(), &format!("{file}.ron"), &style(file));
        let (code, _, err) = wisptree(&["inspect", &p]);
        assert_eq!(code, 2, "{file}: {err}");
        assert!(err.contains(file) && err.contains(needle), "{file}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn ponytail_style_loads_from_the_shared_data() {
    shared::shared_path("data/tressfx/ponytail");
    let p = root().join("styles/ponytail.ron");
    let (code, out, err) = wisptree(&["inspect", p.to_str().unwrap(), "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["strands"], 4714);
    assert_eq!(v["levels"], 3);
    // The head spheres come from the project file, in metres.
    let (loaded, _) = shipped("ponytail.ron");
    assert_eq!(loaded.body.len(), 3);
    assert!((loaded.body[0].radius - 0.265).abs() < 1e-9);
}

#[test]
fn a_wrong_flag_exits_2() {
    let (code, _, err) = wisptree(&["inspect", "--jsn", "x.ron"]);
    assert_eq!(code, 2);
    assert!(err.contains("--jsn"));
}

/// `wisptree bench` end to end on a small style: the table prints, and the JSON has the
/// fields the issue names, with a ratio that is single-level / AWT.
#[test]
fn bench_writes_the_table_and_json() {
    let dir = tempfile::tempdir().unwrap();
    let style = write(dir.path(), "small.ron", &good_style());
    let json = dir.path().join("bench.json");
    let (code, out, err) = wisptree(&[
        "bench",
        "--models",
        &style,
        "--seconds",
        "0.2",
        "--no-pipeline",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{out}\n{err}");
    assert!(out.contains("single ms") && out.contains("paper"), "{out}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).expect("valid JSON");
    assert!(v["machine"].as_str().is_some_and(|m| !m.is_empty()));
    assert!(v["pipeline_wall_s_per_sim_s"].is_null());
    let m = &v["models"][0];
    assert_eq!(m["model"], "small");
    assert_eq!(m["levels"], 2);
    assert!(m["finest_nodes"].as_u64().unwrap() > 0);
    let (single, awt) = (
        m["single_level_ms_per_step"].as_f64().unwrap(),
        m["awt_ms_per_step"].as_f64().unwrap(),
    );
    assert!(single > 0.0 && awt > 0.0);
    assert!((m["ratio"].as_f64().unwrap() - single / awt).abs() < 1e-9 * single / awt);
    for key in ["mean_active_nodes", "splits", "merges"] {
        assert!(m[key].is_number(), "{key} missing: {m}");
    }
}

#[test]
fn bench_with_a_missing_model_exits_2() {
    let (code, _, err) = wisptree(&["bench", "--models", "no/such/style.ron", "--quick"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("no/such/style.ron"), "{err}");
}

// What a new user tripped on (issue 26, "Also").

#[test]
fn a_negative_number_gets_the_options_own_check_not_an_unexpected_argument() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["--seconds", "-1"],
            "expected a positive number of simulated seconds",
        ),
        (
            vec!["run", "--seconds", "-1"],
            "expected a positive number of simulated seconds",
        ),
        (
            vec!["render", "--seconds", "-1", "--out", out],
            "expected a positive number of simulated seconds",
        ),
        (
            vec!["export", "--seconds", "-1", "--out", out],
            "expected a positive number of simulated seconds",
        ),
        (
            vec!["sweep", "--seconds", "-1"],
            "expected a positive number of simulated seconds",
        ),
        (
            vec!["bench", "--seconds", "-1"],
            "--seconds must be a positive number",
        ),
        (vec!["--strands", "-5"], "at least one strand"),
        (vec!["run", "--strands", "-5"], "at least one strand"),
        (vec!["sweep", "--strands", "-5"], "at least one strand"),
        (vec!["sweep", "--jobs", "-2"], "-2"),
    ] {
        let (code, _, err) = wisptree(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!err.contains("unexpected argument"), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[test]
fn a_motion_file_that_is_not_utf8_says_so_once() {
    let dir = tempfile::tempdir().unwrap();
    let motion = dir.path().join("bad.ron");
    std::fs::write(&motion, b"(keys: [\xff\xfe])").unwrap();
    let rrd = dir.path().join("x.rrd");
    let (code, _, err) = wisptree(&[
        "run",
        "--motion",
        motion.to_str().unwrap(),
        "--seconds",
        "0.1",
        "--save",
        rrd.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("bad.ron"), "{err}");
    assert_eq!(err.matches("valid UTF-8").count(), 1, "{err}");
}

#[test]
fn a_huge_value_is_echoed_in_a_few_characters() {
    let dir = tempfile::tempdir().unwrap();
    // A motion file whose second key is at 1e308 s.
    let motion = write(
        dir.path(),
        "m.ron",
        "(keys: [(time: 0.0), (time: 1e308), (time: 1.0)])",
    );
    let rrd = dir.path().join("x.rrd");
    let (code, _, err) = wisptree(&[
        "run",
        "--motion",
        &motion,
        "--seconds",
        "0.1",
        "--save",
        rrd.to_str().unwrap(),
    ]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("1e308") && !err.contains("00000000"), "{err}");
    // A style value.
    let style = write(
        dir.path(),
        "s.ron",
        &good_style().replace(
            "sim: (total_mass: 0.5)",
            "sim: (total_mass: 0.5, accel_smoothing: 1e308)",
        ),
    );
    let (code, _, err) = wisptree(&["inspect", &style]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("accel_smoothing"), "{err}");
    assert!(err.contains("1e308") && !err.contains("00000000"), "{err}");
}

/// The `[default: …]` of `--flag` in `wisptree CMD --help`, if it has one.
fn help_default(cmd: &str, flag: &str) -> Option<String> {
    let (code, out, err) = wisptree(&[cmd, "--help"]);
    assert_eq!(code, 0, "{err}");
    // The flag's entry: its line and the lines of its description, up to the next flag.
    let mut lines = out
        .lines()
        .skip_while(|l| !l.trim_start().starts_with(&format!("{flag} <")));
    let first = lines.next()?;
    let entry: Vec<&str> = std::iter::once(first)
        .chain(lines.take_while(|l| !l.trim_start().starts_with('-')))
        .collect();
    let entry = entry.join(" ");
    let (_, rest) = entry.split_once("[default: ")?;
    Some(rest.split_once(']')?.0.to_owned())
}

#[test]
fn export_has_the_defaults_of_render() {
    for flag in ["--style", "--motion", "--seconds", "--model"] {
        let render = help_default("render", flag);
        assert!(render.is_some(), "render {flag} has a default");
        assert_eq!(help_default("export", flag), render, "{flag}");
    }
    // Without --style and --seconds, export gets past the flags to its own checks.
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), "not_a_folder", "");
    let (code, _, err) = wisptree(&["export", "--out", &file]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("is not a folder"), "{err}");
}

#[test]
fn experiment_help_shows_the_name_as_required_and_list_still_lists() {
    let (code, out, err) = wisptree(&["experiment", "--help"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("<NAME>") && !out.contains("[NAME]"), "{out}");
    let (code, _, err) = wisptree(&["experiment"]);
    assert_eq!(code, 2);
    assert!(err.contains("<NAME>"), "{err}");
    let (code, out, err) = wisptree(&["experiment", "--list"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("plante-fig8"), "{out}");
}

#[test]
fn sweep_help_gives_the_split_threshold_in_newton_metres_per_kilogram() {
    let (code, out, err) = wisptree(&["sweep", "--help"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("N·m·kg⁻¹") && !out.contains("m²/s²"), "{out}");
}
