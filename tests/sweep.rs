//! `wisptree sweep`: the configurations and their labels, errors in the lists (exit 2), the
//! recording (one subtree per configuration, the grid blueprint), runs equal to the same
//! configuration run alone bit for bit, and parts that merge into one recording.

#[path = "common/shared.rs"]
mod shared;
#[path = "common/sweep_rrd.rs"]
mod sweep_rrd;
#[path = "common/tiny_style.rs"]
mod tiny_style;

use std::path::{Path, PathBuf};
use std::process::Command;

use sweep_rrd::{assert_same_run, cell_text, cells, node_positions, read_rrd, run_cells};
use wisptree::app::sweep_plan::{label_ok, parse_variants, product, recording_id, SweepLists};

fn tiny(dir: &Path) -> PathBuf {
    let p = dir.join("tiny.ron");
    std::fs::write(&p, tiny_style::tiny_style("0.3")).unwrap();
    p
}

fn wisptree(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(args)
        .output()
        .expect("wisptree runs")
}

/// `wisptree sweep --style tiny.ron --motion shake --seconds 0.6 --strands 20 --no-progress
/// <more> --save out`, which must succeed.
fn sweep(style: &Path, more: &[&str], out: &Path) -> String {
    let style = style.display().to_string();
    let out_s = out.display().to_string();
    let mut args = vec![
        "sweep",
        "--style",
        &style,
        "--motion",
        "shake",
        "--seconds",
        "0.6",
        "--strands",
        "20",
        "--no-progress",
        "--save",
        &out_s,
    ];
    args.extend_from_slice(more);
    let o = wisptree(&args);
    assert!(
        o.status.success(),
        "wisptree {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

// ---------------------------------------------------------------------------------------------
// The plan

fn lists(model: Option<&str>, split: Option<&str>, merge: Option<&str>) -> SweepLists {
    SweepLists {
        model: model.map(str::to_owned),
        split: split.map(str::to_owned),
        merge: merge.map(str::to_owned),
        set: Vec::new(),
    }
}

#[test]
fn set_sweeps_any_tunable_of_the_models_table_in_every_combination() {
    let mut l = lists(Some("layered"), None, None);
    l.set = vec!["viscosity=0.5,50".into(), "bending=100,200".into()];
    let c = product(&l).unwrap();
    let labels: Vec<&str> = c.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "layered_viscosity0.5_bending100",
            "layered_viscosity0.5_bending200",
            "layered_viscosity50_bending100",
            "layered_viscosity50_bending200",
        ]
    );
    // The values reach the style's sections the solver is built from.
    let t = c[2].tuning(&wisptree::solver::tunable::Tuning::default());
    assert_eq!((t.layered.viscosity, t.layered.bending), (50.0, 100.0));
    // `--set split_threshold=` is `--split`: the same configurations and labels.
    let mut a = lists(None, None, None);
    a.set = vec!["split_threshold=0.1,0.3".into()];
    assert_eq!(
        product(&a).unwrap(),
        product(&lists(None, Some("0.1,0.3"), None)).unwrap()
    );
    let mut g = lists(Some("guides"), None, None);
    g.set = vec!["link_strength=0,900".into()];
    let t = product(&g).unwrap()[1].tuning(&wisptree::solver::tunable::Tuning::default());
    assert_eq!(t.guides.link_strength, 900.0);
}

#[test]
fn product_orders_model_split_merge_and_labels_them() {
    let c = product(&lists(
        Some("awt,single-level"),
        Some("0.2,1e-1"),
        Some("0.1"),
    ))
    .unwrap();
    let labels: Vec<&str> = c.iter().map(|c| c.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "awt_split0.2_merge0.1",
            "awt_split0.1_merge0.1",
            "single-level_split0.2_merge0.1",
            "single-level_split0.1_merge0.1"
        ]
    );
    assert!(c.iter().all(|c| label_ok(&c.label)));
    assert_eq!(c[1].split, Some(0.1));
    assert_eq!(product(&lists(None, None, None)).unwrap()[0].label, "awt");
    assert_eq!(
        product(&lists(None, Some("-0,0.25"), None)).unwrap()[0].label,
        "awt_split0"
    );
    assert!(!label_ok("a b") && !label_ok("") && !label_ok("a/b") && label_ok("A-z_0.9"));
}

#[test]
fn bad_items_name_the_flag_and_the_item() {
    for (l, want) in [
        (
            lists(None, Some("0.1,,0.2"), None),
            "--split 0.1,,0.2: item 2 is empty",
        ),
        (
            lists(None, Some("0.1,x"), None),
            "--split: `x`: not a number",
        ),
        (
            lists(None, None, Some("-1")),
            "--merge: `-1`: must be zero or positive",
        ),
        (
            lists(None, None, Some("inf")),
            "--merge: `inf`: must be zero",
        ),
        (
            lists(None, None, Some("NaN")),
            "--merge: `NaN`: must be zero",
        ),
        (
            lists(None, Some("0.1,0.10"), None),
            "--split: `0.10` is listed twice",
        ),
        (
            lists(Some("awt,hairy"), None, None),
            "--model: `hairy`: unknown model",
        ),
        (
            lists(Some("awt,awt"), None, None),
            "--model: `awt` is listed twice",
        ),
        (lists(None, Some(""), None), "--split : item 1 is empty"),
    ] {
        let e = product(&l).unwrap_err().0;
        assert!(e.starts_with(want), "{e}");
    }
}

#[test]
fn variants_errors_give_file_line_column_and_field() {
    let p = Path::new("v.ron");
    let ok = parse_variants(
        p,
        "[(label: \"soft\", split: 0.1, merge: 0.05), (model: \"single-level\")]",
    )
    .unwrap();
    assert_eq!(ok[0].label, "soft");
    assert_eq!((ok[0].split, ok[0].merge), (Some(0.1), Some(0.05)));
    assert_eq!(ok[1].label, "single-level");
    let e = parse_variants(p, "[\n  (label: \"a\", split: -0.1),\n]")
        .unwrap_err()
        .0;
    assert!(
        e.starts_with("v.ron:2:") && e.contains("field `split`"),
        "{e}"
    );
    let e = parse_variants(p, "[(model: \"nope\")]").unwrap_err().0;
    assert!(
        e.starts_with("v.ron:1:") && e.contains("field `model`"),
        "{e}"
    );
    let e = parse_variants(p, "[(label: \"a b\")]").unwrap_err().0;
    assert!(
        e.starts_with("v.ron:1:") && e.contains("field `label`"),
        "{e}"
    );
    let e = parse_variants(p, "[(label: \"a\"),\n(label: \"a\")]")
        .unwrap_err()
        .0;
    assert!(e.starts_with("v.ron:2: variant 1: field `label`"), "{e}");
    let e = parse_variants(p, "[(splt: 0.1)]").unwrap_err().0;
    assert!(e.starts_with("v.ron:1:") && e.contains("splt"), "{e}");
    assert!(parse_variants(p, "[]").unwrap_err().0.contains("empty"));
}

#[test]
fn recording_id_depends_on_the_description_only() {
    assert_eq!(recording_id("a"), recording_id("a"));
    assert_ne!(recording_id("a"), recording_id("b"));
    assert!(recording_id("a").starts_with("wisptree-sweep-"));
}

// ---------------------------------------------------------------------------------------------
// The command

#[test]
fn bad_lists_exit_2_naming_the_flag_and_the_item() {
    let dir = tempfile::tempdir().unwrap();
    let variants = dir.path().join("v.ron");
    std::fs::write(
        &variants,
        "[\n  (label: \"ok\"),\n  (label: \"x\", merge: -2),\n]",
    )
    .unwrap();
    let v = variants.display().to_string();
    let cases: &[(&[&str], &str)] = &[
        (
            &["--split", "0.1,,0.3"],
            "--split 0.1,,0.3: item 2 is empty",
        ),
        (&["--split", "0.1,abc"], "--split: `abc`: not a number"),
        (
            &["--split", "-0.5"],
            "--split: `-0.5`: must be zero or positive",
        ),
        (&["--merge", "0.1,0.1"], "--merge: `0.1` is listed twice"),
        (&["--model", "awt,curly"], "--model: `curly`: unknown model"),
        (&["--split", ""], "--split : item 1 is empty"),
        (
            &["--split", "0.1,0.2", "--only", "2"],
            "--only 2: the sweep has 2 configurations",
        ),
        (&["--variants", &v], ":3:"),
        (
            &["--variants", "/nonexistent/v.ron"],
            "--variants /nonexistent/v.ron",
        ),
        (&["--variants", &v, "--split", "0.1"], "cannot be used with"),
        (
            &["--variants", &v, "--set", "wind=1"],
            "cannot be used with",
        ),
        (
            &["--set", "gravity=1"],
            "--set: `gravity` is not a tunable of the swept model (awt: split_threshold",
        ),
        (
            &["--model", "layered", "--set", "viscosity=500"],
            "viscosity: interpenetration viscosity ν 500 refused: it must be between 0 and 100",
        ),
        (
            &["--model", "layered", "--set", "viscosity=1,x"],
            "viscosity: value 2 `x` is not a number",
        ),
        (&["--set", "viscosity"], "expected NAME=v1,v2"),
        (
            &["--set", "split_threshold=0.1", "--split", "0.2"],
            "--set split_threshold: given twice",
        ),
        (
            &["--set", "wind=1", "--set", "wind=2"],
            "--set wind: given twice",
        ),
    ];
    for (args, want) in cases {
        let mut all = vec!["sweep", "--no-progress", "--save", "/nonexistent/never.rrd"];
        all.extend_from_slice(args);
        let o = wisptree(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    // The variants file's error names the file, the line and column, and the field.
    let o = wisptree(&["sweep", "--variants", &v, "--list"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(&format!("{v}:3:")) && err.contains("field `merge`"),
        "{err}"
    );
}

#[test]
fn list_prints_the_configurations_in_only_order() {
    let o = wisptree(&[
        "sweep",
        "--model",
        "awt,single-level",
        "--split",
        "0.1,0.2",
        "--list",
    ]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    let lines: Vec<&str> = text.lines().map(str::trim).collect();
    assert_eq!(
        lines,
        [
            "0  awt_split0.1",
            "1  awt_split0.2",
            "2  single-level_split0.1",
            "3  single-level_split0.2"
        ]
    );
}

#[test]
fn a_sweep_records_one_subtree_per_configuration_and_the_grid_blueprint() {
    let dir = tempfile::tempdir().unwrap();
    let style = tiny(dir.path());
    let out = dir.path().join("all.rrd");
    let table = sweep(
        &style,
        &["--split", "0.05,0.5", "--model", "awt,single-level"],
        &out,
    );
    let labels = [
        "awt_split0.05",
        "awt_split0.5",
        "single-level_split0.05",
        "single-level_split0.5",
    ];
    // The summary: a header and one row per run, in order.
    let rows: Vec<&str> = table.lines().collect();
    assert_eq!(rows.len(), 1 + labels.len(), "{table}");
    assert!(
        rows[0].contains("mean active") && rows[0].contains("ms/step"),
        "{table}"
    );
    for (k, l) in labels.iter().enumerate() {
        assert!(
            rows[k + 1].trim_start().starts_with(&format!("{k}  {l} ")),
            "{table}"
        );
    }

    let rrd = read_rrd(&out);
    assert_eq!(rrd.recording_ids.len(), 1);
    let data = cells(&rrd.data);
    for l in labels {
        for path in [
            "/hair/awt/nodes",
            "/hair/strands",
            "/stats/step_ms",
            "/stats/active_total",
        ] {
            let p = format!("/runs/{l}{path}");
            assert!(
                data.keys().any(|(e, _, f)| *e == p && f.is_some()),
                "no {p}"
            );
        }
        // 0.6 s at 25 frames/s: frames 0..15 of every run, on the one shared timeline.
        let frames: std::collections::BTreeSet<i64> = data
            .keys()
            .filter(|(e, _, _)| *e == format!("/runs/{l}/hair/strands"))
            .filter_map(|(_, _, f)| *f)
            .collect();
        assert_eq!(frames, (0..15).collect(), "{l}");
    }
    // Nothing outside the runs' subtrees but the static root context.
    for (e, _, f) in data.keys() {
        assert!(e.starts_with("/runs/") || (e == "/" && f.is_none()), "{e}");
    }

    // The blueprint: one 3D view per run with the run as origin and its own eye, in a grid,
    // and the plots overlaying every run.
    let bp = cells(&rrd.blueprint);
    let classes = cell_text(&bp, "/view/", "class_identifier");
    assert_eq!(
        classes.iter().filter(|c| c.contains("\"3D\"")).count(),
        labels.len()
    );
    assert_eq!(
        classes
            .iter()
            .filter(|c| c.contains("\"TimeSeries\""))
            .count(),
        2
    );
    let origins = cell_text(&bp, "/view/", "space_origin");
    for l in labels {
        assert!(
            origins
                .iter()
                .any(|o| o.contains(&format!("\"/runs/{l}\""))),
            "{origins:?}"
        );
    }
    let eyes = bp
        .keys()
        .filter(|(e, _, _)| e.ends_with("/EyeControls3D"))
        .map(|(e, _, _)| e.clone())
        .collect::<std::collections::BTreeSet<_>>();
    assert_eq!(eyes.len(), labels.len());
    let kinds = cell_text(&bp, "/container/", "container_kind");
    assert_eq!(
        kinds.iter().filter(|k| k.contains("  4,")).count(),
        1,
        "{kinds:?}"
    );
    let contents = cell_text(&bp, "/view/", "query").join("\n");
    for l in labels {
        assert!(
            contents.contains(&format!("/runs/{l}/stats/active_total")),
            "{contents}"
        );
        assert!(
            contents.contains(&format!("/runs/{l}/stats/step_ms")),
            "{contents}"
        );
    }
}

#[test]
fn each_run_equals_the_same_configuration_run_alone_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let style = tiny(dir.path());
    let p = |n: &str| dir.path().join(n);
    let lists = ["--split", "0.05,0.5", "--merge", "0.02"];
    let with = |extra: &[&'static str]| {
        let mut v: Vec<&str> = lists.to_vec();
        v.extend_from_slice(extra);
        v
    };
    sweep(&style, &with(&["--jobs", "2"]), &p("all.rrd"));
    sweep(&style, &with(&["--only", "0"]), &p("part-0.rrd"));
    sweep(&style, &with(&["--only", "1"]), &p("part-1.rrd"));
    let all = read_rrd(&p("all.rrd"));
    let part = [read_rrd(&p("part-0.rrd")), read_rrd(&p("part-1.rrd"))];
    let all_cells = cells(&all.data);
    let labels = ["awt_split0.05_merge0.02", "awt_split0.5_merge0.02"];
    for (k, l) in labels.iter().enumerate() {
        assert_same_run(&all_cells, &cells(&part[k].data), l);
        // A part holds its own run only.
        let other = labels[1 - k];
        assert!(run_cells(&cells(&part[k].data), other).is_empty());
    }
    // The two runs differ (else the comparison above shows nothing).
    assert_ne!(
        node_positions(&all.data, labels[0], 14).len(),
        node_positions(&all.data, labels[1], 14).len()
    );

    // Every part of one sweep has the sweep's recording id; another sweep has another.
    assert_eq!(all.recording_ids.len(), 1);
    assert_eq!(part[0].recording_ids, all.recording_ids);
    assert_eq!(part[1].recording_ids, all.recording_ids);
    sweep(
        &style,
        &["--split", "0.05,0.6", "--merge", "0.02", "--only", "0"],
        &p("other.rrd"),
    );
    assert_ne!(read_rrd(&p("other.rrd")).recording_ids, all.recording_ids);

    // And the run equals the solver stepped by hand with the same parameters (default
    // threads, no sweep machinery): the last frame's active nodes, bit for bit.
    let scene = wisptree::scene::Scene::load(
        &style.display().to_string(),
        "shake",
        wisptree::solver::SolverKind::Awt,
    )
    .unwrap();
    let mut params = scene.loaded.style.sim.clone();
    params.split_threshold = 0.05;
    params.merge_velocity = 0.02;
    let mut solver = scene.solver_with(&params);
    let mut report = solver.new_report();
    let mut frame = wisptree::frame::Frame::default();
    let mut builder = wisptree::pipeline::FrameBuilder::new(&scene.model, 20, 2);
    for _ in 0..15 {
        wisptree::pipeline::step_frame(&mut *solver, &mut report, &mut frame);
    }
    builder.fill(&mut *solver, &mut frame);
    assert_eq!(
        node_positions(&all.data, labels[0], 14),
        frame.nodes.positions
    );
}

#[test]
fn merged_parts_are_one_recording_with_every_run() {
    let tool = shared::rerun_cli();
    let dir = tempfile::tempdir().unwrap();
    let style = tiny(dir.path());
    let p = |n: &str| dir.path().join(n);
    for k in ["0", "1"] {
        sweep(
            &style,
            &["--model", "awt,single-level", "--only", k],
            &p(&format!("part-{k}.rrd")),
        );
    }
    let o = Command::new(&tool)
        .args(["rrd", "merge"])
        .arg(p("part-0.rrd"))
        .arg(p("part-1.rrd"))
        .arg("-o")
        .arg(p("all.rrd"))
        .output()
        .expect("running rerun-cli");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let merged = read_rrd(&p("all.rrd"));
    assert_eq!(merged.recording_ids.len(), 1, "{:?}", merged.recording_ids);
    let data = cells(&merged.data);
    for l in ["awt", "single-level"] {
        assert!(!run_cells(&data, l).is_empty(), "no /runs/{l}");
    }
    // One layout: the grid of both runs.
    let bp = cells(&merged.blueprint);
    let classes = cell_text(&bp, "/view/", "class_identifier");
    assert!(classes.iter().filter(|c| c.contains("\"3D\"")).count() >= 2);
}
