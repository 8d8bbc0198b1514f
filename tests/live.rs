//! Keeping up with the wall clock: every recording says how fast it went
//! (`/stats/realtime_factor`), a live run that falls behind says why, and `bench --live`
//! measures every solver × style × motion and the page's slider ends.

#[path = "common/rrd.rs"]
mod rrd;
#[path = "common/tiny_style.rs"]
mod tiny_style;

use std::collections::BTreeSet;
use std::process::Command;

use wisptree::app::{self as run, RunOptions, StopSignal};
use wisptree::frame::Frame;
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;
use wisptree::stream::sink::SinkChoice;

#[test]
fn a_recording_logs_the_realtime_factor_of_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let style = dir.path().join("tiny.ron");
    std::fs::write(&style, tiny_style::tiny_style("0.2")).unwrap();
    let out = dir.path().join("out.rrd");
    let summary = run::run_with(
        RunOptions {
            style: style.display().to_string(),
            motion: "shake".into(),
            seconds: Some(1.0),
            strands: 20,
            watch: Some(false),
            sink: SinkChoice::Save(out.clone()),
            render: None,
            ..RunOptions::default()
        },
        StopSignal::new(),
    )
    .expect("the run succeeds");
    let series = rrd::scalars(&rrd::decode_file(&out), "/stats/realtime_factor");
    assert_eq!(
        series.iter().map(|s| s.0).collect::<Vec<_>>(),
        (0..25).collect::<Vec<_>>(),
        "one realtime factor per frame"
    );
    assert!(
        series.iter().all(|s| s.1.is_finite() && s.1 > 0.0),
        "{series:?}"
    );
    // The run's own account: 25 frames of 40 ms, their wall time measured.
    let t = &summary.tempo;
    assert_eq!(t.frames, 25);
    assert!((t.sim_s - 1.0).abs() < 1e-9, "{}", t.sim_s);
    assert!(t.wall_s > 0.0);
    assert!((t.realtime_factor() - t.sim_s / t.wall_s).abs() < 1e-12);
    // The last logged value is the factor over the last second: all 25 frames.
    let last = series.last().unwrap().1;
    assert!(
        (last / t.realtime_factor() - 1.0).abs() < 1e-6,
        "last {last} vs run {}",
        t.realtime_factor()
    );
    assert!(t.frame_ms_quantile(0.95) > 0.0);
}

#[test]
fn the_slow_motion_line_names_the_factor_the_model_the_strands_and_the_threshold() {
    let dir = tempfile::tempdir().unwrap();
    let style = dir.path().join("tiny.ron");
    std::fs::write(&style, tiny_style::tiny_style("0.07")).unwrap();
    let scene = Scene::load(&style.display().to_string(), "shake", SolverKind::Awt).unwrap();
    let solver = scene.solver();
    let mut f = Frame {
        realtime_factor: 0.42,
        step_ms: 12.5,
        ..Frame::default()
    };
    f.counters.active_per_level = vec![4, 60];
    let line = run::slow_motion_message(&*solver, &f, true);
    for needle in [
        "×0.42",
        "slow motion",
        "model awt",
        &format!("{} strands", scene.model.strands.len()),
        "64 active nodes",
        "split threshold 0.07",
        "--no-render",
    ] {
        assert!(line.contains(needle), "`{needle}` missing from: {line}");
    }
    let guides = scene.with_solver(SolverKind::Guides).solver();
    let line = run::slow_motion_message(&*guides, &f, false);
    assert!(
        line.contains("model guides") && !line.contains("--no-render"),
        "{line}"
    );
    // Both levers of the guide model, with the values in force.
    let g = guides.tuning().guides;
    for needle in [
        format!("up to {} picked", g.count),
        format!("{} inserted", g.max_inserted),
        "max_inserted".to_owned(),
    ] {
        assert!(line.contains(&needle), "`{needle}` missing from: {line}");
    }
}

/// `wisptree bench --live ARGS --json FILE`, which must succeed: its standard output and the
/// JSON it wrote.
fn bench_live_json(args: &[&str]) -> (String, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("live.json");
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["bench", "--live"])
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .expect("wisptree runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "bench --live {args:?} failed: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (stdout, v)
}

#[test]
fn bench_live_quick_has_every_solver_style_motion_the_slider_ends_and_rendering_rows() {
    let (stdout, v) = bench_live_json(&["--quick"]);
    // The worst row is printed last.
    assert!(
        stdout
            .trim_end()
            .lines()
            .last()
            .unwrap_or("")
            .starts_with("worst of all"),
        "{stdout}"
    );
    let rows = v["live"].as_array().expect("a `live` array");
    let styles = ["short", "short_curly", "long", "long_curly"];
    let motions = ["lean", "run", "jump", "shake", "stop"];
    for r in rows {
        for key in [
            "solver",
            "style",
            "motion",
            "split",
            "merge",
            "render",
            "realtime_factor",
            "p95_frame_ms",
            "mean_active",
            "max_active",
            "contacts_per_step",
        ] {
            assert!(r.get(key).is_some(), "row without `{key}`: {r}");
        }
        // 1 simulated second per row with --quick, measured, and positive.
        assert!(
            (r["sim_seconds"].as_f64().unwrap() - 1.0).abs() < 0.021,
            "{r}"
        );
        assert!(r["realtime_factor"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["p95_frame_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["max_active"].as_u64().unwrap() > 0, "{r}");
        let awt = r["solver"] == "awt";
        assert_eq!(r["split"].is_number(), awt, "{r}");
        assert_eq!(r["merge"].is_number(), awt, "{r}");
        // Where an AWT step's time goes: every stage timed, the hair–hair pairs by far the
        // largest under `shake` at the lowest split threshold (thousands of active segments);
        // the other models time no stages.
        let stages = &r["stages_ms"];
        assert_eq!(stages.is_object(), awt, "{r}");
        if awt {
            let ms = |k: &str| stages[k].as_f64().unwrap_or_else(|| panic!("no {k}: {r}"));
            let named = [
                "forces",
                "integrate",
                "links",
                "obstacles",
                "adapt",
                "follow",
            ];
            assert!(ms("interactions") > 0.0 && ms("other") >= 0.0, "{r}");
            if r["motion"] == "shake" && r["split"].as_f64() == Some(0.05) {
                assert!(named.iter().all(|&k| ms(k) < ms("interactions")), "{r}");
            }
        }
    }
    assert!(
        stdout.contains("where a step's") && stdout.contains("interactions"),
        "the slowest AWT row's stages: {stdout}"
    );
    let key = |r: &serde_json::Value| {
        (
            r["solver"].as_str().unwrap().to_owned(),
            r["style"].as_str().unwrap().to_owned(),
            r["motion"].as_str().unwrap().to_owned(),
            r["render"].as_bool().unwrap(),
        )
    };
    let seen: BTreeSet<_> = rows.iter().map(key).collect();
    for solver in ["awt", "layered", "guides"] {
        for style in styles {
            for motion in motions {
                assert!(
                    seen.contains(&(solver.into(), style.into(), motion.into(), false)),
                    "no row for {solver} {style} {motion}"
                );
                if solver == "awt" {
                    assert!(
                        seen.contains(&(solver.into(), style.into(), motion.into(), true)),
                        "no rendering row for {style} {motion}"
                    );
                }
            }
        }
    }
    // The slider ends under shake, on every style, with the value in force in the row.
    for style in styles {
        let shake: Vec<_> = rows
            .iter()
            .filter(|r| r["solver"] == "awt" && r["style"] == style && r["motion"] == "shake")
            .collect();
        let has = |k: &str, v: f64| shake.iter().any(|r| r[k].as_f64() == Some(v));
        assert!(
            has("split", 0.05) && has("split", 1.0),
            "{style}: split ends"
        );
        assert!(
            has("merge", 0.005) && has("merge", 1.0),
            "{style}: merge ends"
        );
    }
    assert_eq!(rows.len(), 3 * 4 * 5 + 4 * 4 + 4 * 5);
}

/// The nice value of each of this process's threads whose name starts with `prefix`.
fn nice_of_threads(prefix: &str) -> Vec<i64> {
    let mut out = Vec::new();
    for task in std::fs::read_dir("/proc/self/task").expect("Linux /proc") {
        let dir = task.unwrap().path();
        let comm = std::fs::read_to_string(dir.join("comm")).unwrap_or_default();
        if !comm.trim().starts_with(prefix) {
            continue;
        }
        let stat = std::fs::read_to_string(dir.join("stat")).unwrap_or_default();
        // Fields after the parenthesised name: state is field 3, nice is field 19.
        if let Some((_, rest)) = stat.rsplit_once(") ") {
            if let Some(n) = rest.split(' ').nth(16) {
                out.push(n.parse().unwrap());
            }
        }
    }
    out
}

#[test]
#[cfg(target_os = "linux")]
fn the_render_threads_run_at_a_lower_priority_than_the_simulation() {
    let dir = tempfile::tempdir().unwrap();
    let style = dir.path().join("tiny.ron");
    std::fs::write(&style, tiny_style::tiny_style("0.2")).unwrap();
    let out = dir.path().join("out.rrd");
    let stop = StopSignal::new();
    let opts = RunOptions {
        style: style.display().to_string(),
        motion: "shake".into(),
        seconds: Some(30.0),
        strands: 20,
        watch: Some(false),
        sink: SinkChoice::Save(out),
        render: Some((160, 120)),
        ..RunOptions::default()
    };
    let run = {
        let stop = stop.clone();
        std::thread::spawn(move || run::run_with(opts, stop))
    };
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let (mut render, mut sim) = (Vec::new(), Vec::new());
    while std::time::Instant::now() < deadline && (render.len() < 2 || sim.is_empty()) {
        std::thread::sleep(std::time::Duration::from_millis(50));
        // The render thread, its pool's workers and its JPEG encoder.
        render = nice_of_threads("wisptree-render");
        render.extend(nice_of_threads("wisptree-pool"));
        render.extend(nice_of_threads("wisptree-jpeg"));
        sim = nice_of_threads("wisptree-sim");
    }
    stop.stop();
    run.join().unwrap().expect("the run succeeds");
    assert!(!sim.is_empty(), "no simulation thread seen");
    // The render thread, its pool's workers and the encoder all run nicer.
    assert!(render.len() >= 2, "render threads seen: {render:?}");
    assert!(
        render.iter().all(|&r| r > sim[0]),
        "render nice {render:?}, simulation {sim:?}"
    );
}

/// `bench --live --runs N` runs the matrix N times and reports each row's median factor with
/// every pass's factor; a number of passes out of range is refused naming `--runs`.
#[test]
fn bench_live_runs_reports_the_median_of_the_passes() {
    let (stdout, v) = bench_live_json(&[
        "--quick",
        "--seconds",
        "0.2",
        "--runs",
        "3",
        "--rows",
        "layered short lean",
    ]);
    assert!(stdout.contains("median of 3 passes"), "{stdout}");
    let bin = env!("CARGO_BIN_EXE_wisptree");
    let rows = v["live"].as_array().expect("a `live` array");
    assert_eq!(rows.len(), 1, "one row: {v}");
    let factors: Vec<f64> = rows[0]["realtime_factors"]
        .as_array()
        .expect("every pass's factor")
        .iter()
        .map(|f| f.as_f64().unwrap())
        .collect();
    assert_eq!(factors.len(), 3);
    assert!(factors.iter().all(|&f| f > 0.0), "{factors:?}");
    let mut sorted = factors.clone();
    sorted.sort_by(f64::total_cmp);
    assert_eq!(rows[0]["realtime_factor"].as_f64().unwrap(), sorted[1]);

    for bad in ["0", "21", "-1", "two"] {
        let out = Command::new(bin)
            .args(["bench", "--live", "--quick", "--runs", bad])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "--runs {bad}: {err}");
        assert!(err.contains("--runs"), "--runs {bad}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
