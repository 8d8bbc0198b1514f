//! `wisptree run` without a viewer: short recordings into files (decoded with the SDK's own
//! `.rrd` decoder and checked with the real CLI when it is there), style hot-reload, stopping
//! mid-run the way Ctrl-C does, and the binary's exit code on bad input.

#[path = "common/rrd.rs"]
mod rrd;
#[path = "common/shared.rs"]
mod shared;
#[path = "common/tiny_style.rs"]
mod tiny_style;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use tiny_style::tiny_style;

use rerun::log::Chunk;
use rerun::{LineStrips3D, Points3D, TextLog};
use rrd::{decode_file, rows, scalars};
use wisptree::app::reload::{self, StyleChange};
use wisptree::app::{self as run, RunOptions, StopSignal};
use wisptree::frame::Frame;
use wisptree::report::{EventKind, StepReport};
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;
use wisptree::stream::paths;
use wisptree::stream::sink::SinkChoice;

// The style: `tiny_style` (tests/common/tiny_style.rs), which splits under `shake`.
const MOTION: &str = "shake";
const STRANDS: usize = 20;

fn write_style(dir: &Path, split: &str) -> PathBuf {
    let p = dir.join("tiny.ron");
    std::fs::write(&p, tiny_style(split)).unwrap();
    p
}

fn args(style: &Path, out: &Path, seconds: f64, watch: bool) -> RunOptions {
    RunOptions {
        style: style.display().to_string(),
        motion: MOTION.to_owned(),
        model: SolverKind::Awt,
        seconds: Some(seconds),
        strands: STRANDS,
        watch: Some(watch),
        sink: SinkChoice::Save(out.to_path_buf()),
        render: None,
        web: None,
        inspect: None,
    }
}

fn load(style: &Path) -> Scene {
    Scene::load(&style.display().to_string(), MOTION, SolverKind::Awt).unwrap()
}

fn texts(chunks: &[Chunk], path: &str) -> Vec<String> {
    let path: rerun::EntityPath = path.into();
    let component = TextLog::descriptor_text().component;
    let mut out = Vec::new();
    for c in chunks.iter().filter(|c| *c.entity_path() == path) {
        for item in c.iter_component::<rerun::components::Text>(component) {
            out.extend(item.iter().map(|t| t.as_str().to_owned()));
        }
    }
    out
}

/// Runs the real Rerun CLI's `rrd verify` on `path` (`../shared/tools/rerun-cli`).
fn verify_with_cli(path: &Path) {
    let tool = shared::rerun_cli();
    let out = std::process::Command::new(&tool)
        .args(["rrd", "verify"])
        .arg(path)
        .output()
        .expect("running rerun-cli");
    assert!(
        out.status.success(),
        "rrd verify failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_short_recording_holds_every_path_one_row_per_frame_and_the_events_of_each_frame() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let out = dir.path().join("out.rrd");
    let seconds = 1.0;
    let summary = run::run_with(args(&style, &out, seconds, false), StopSignal::new())
        .expect("the run succeeds");
    let frames = 25; // 1 s of 4 × 10 ms frames
    assert_eq!(summary.frames_logged, frames);
    assert_eq!(summary.frames_dropped, 0);
    assert!(!summary.interrupted);
    verify_with_cli(&out);
    let chunks = decode_file(&out);

    let seen: BTreeMap<String, ()> = chunks
        .iter()
        .map(|c| (c.entity_path().to_string(), ()))
        .collect();
    for p in [
        paths::NODES,
        paths::SEGMENTS,
        paths::STRANDS,
        paths::BODY_SPHERES,
        paths::SCALP,
        paths::SPLITS,
        paths::LOG,
        "/stats/splits",
        "/stats/merges",
        "/stats/kinetic_energy",
        "/stats/step_ms",
        "/stats/dropped_frames",
        "/params/split_threshold",
        "/params/merge_velocity",
        &paths::active_nodes_level(0),
        &paths::active_nodes_level(1),
    ] {
        assert!(seen.contains_key(p), "{p} missing; seen {seen:?}");
    }

    // One row per frame, frames 0..25 in order, for the nodes and the strands; exactly STRANDS
    // strands in each.
    let node_rows = rows(
        &chunks,
        paths::NODES,
        Points3D::descriptor_positions().component,
    );
    assert_eq!(
        node_rows.iter().map(|r| r.0).collect::<Vec<_>>(),
        (0..frames as i64).collect::<Vec<_>>()
    );
    assert!(node_rows.iter().all(|r| r.1 > 0));
    let strand_rows = rows(
        &chunks,
        paths::STRANDS,
        LineStrips3D::descriptor_strips().component,
    );
    assert_eq!(
        strand_rows,
        (0..frames as i64).map(|f| (f, STRANDS)).collect::<Vec<_>>()
    );

    // The same inputs, simulated here without threads: the simulation is deterministic, so
    // every frame must show exactly the events this simulation reports in that frame's steps.
    let setup = load(&style);
    let mut sim = setup.awt();
    let mut report = StepReport::default();
    let mut expected_splits = Vec::new();
    let mut expected_merges = Vec::new();
    for f in 0..frames as i64 {
        for _ in 0..sim.params.steps_per_frame {
            sim.step(&mut report);
            for e in &report.events {
                match e.kind {
                    EventKind::Split => expected_splits.push((f, 1)),
                    EventKind::Merge => expected_merges.push((f, 1)),
                    other => panic!("the AWT reported a {other:?} event"),
                }
            }
        }
    }
    assert!(
        !expected_splits.is_empty(),
        "the fixture should split under {MOTION}"
    );
    let text = TextLog::descriptor_text().component;
    assert_eq!(rows(&chunks, paths::SPLITS, text), expected_splits);
    assert_eq!(rows(&chunks, paths::MERGES, text), expected_merges);
    assert_eq!(summary.splits as usize, expected_splits.len());
    // And the per-frame split counts agree with the /stats series.
    let stat: Vec<(i64, f64)> = scalars(&chunks, "/stats/splits");
    for (f, n) in stat {
        let want = expected_splits.iter().filter(|e| e.0 == f).count();
        assert_eq!(n as usize, want, "frame {f}");
    }
}

#[test]
fn the_simulation_loop_fills_frames_like_a_plain_simulation() {
    // The frame-stepping helper used by the simulation thread: events in order, counts right.
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let setup = load(&style);
    let mut a = setup.awt();
    let mut b = setup.awt();
    let mut ra = StepReport::default();
    let mut rb = StepReport::default();
    let mut frame = Frame::default();
    let mut total = 0;
    for _ in 0..25 {
        wisptree::pipeline::step_frame(&mut a, &mut ra, &mut frame);
        let mut events = Vec::new();
        for _ in 0..b.params.steps_per_frame {
            b.step(&mut rb);
            events.extend(rb.events.iter().cloned());
        }
        assert_eq!(frame.events, events);
        assert_eq!(frame.splits + frame.merges, events.len() as u32);
        assert_eq!(
            frame.counters.active_per_level,
            rb.counters.active_per_level
        );
        total += events.len();
    }
    assert!(total > 0);
}

#[test]
fn reloading_the_style_changes_the_split_threshold_of_the_next_steps_and_broken_edits_change_nothing(
) {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let setup = load(&style);
    let current = setup.loaded.style.clone();

    // Unchanged text: nothing to do.
    assert!(matches!(
        reload::reload(&style, &current),
        StyleChange::Unchanged
    ));

    // A threshold so high nothing can split: a parameter change, applied in place.
    std::fs::write(&style, tiny_style("1.0e6")).unwrap();
    let new = match reload::reload(&style, &current) {
        StyleChange::Params(l) => l,
        other => panic!("expected new parameters, got {other:?}"),
    };
    assert_eq!(new.style.sim.split_threshold, 1.0e6);

    let count_splits = |sim: &mut wisptree::solver::awt::Simulation| {
        let mut r = StepReport::default();
        let mut n = 0;
        for _ in 0..100 {
            sim.step(&mut r);
            n += r
                .events
                .iter()
                .filter(|e| e.kind == EventKind::Split)
                .count();
        }
        n
    };
    let mut before = setup.awt();
    assert!(count_splits(&mut before) > 0);
    let mut after = setup.awt();
    after.set_tunables(wisptree::solver::awt::Tunables {
        params: new.style.sim.clone(),
        link: new.style.link.clone(),
    });
    assert_eq!(after.params.split_threshold, 1.0e6);
    assert_eq!(count_splits(&mut after), 0);

    // Broken edits: a syntax error and an invalid value. Both are errors naming the file, and
    // the caller keeps its style.
    std::fs::write(&style, "Style(hair: ").unwrap();
    match reload::reload(&style, &current) {
        StyleChange::Invalid(e) => assert!(e.to_string().contains("tiny.ron"), "{e}"),
        other => panic!("expected an error, got {other:?}"),
    }
    std::fs::write(&style, tiny_style("-1.0")).unwrap();
    match reload::reload(&style, &current) {
        StyleChange::Invalid(e) => {
            assert!(e.to_string().contains("split_threshold"), "{e}")
        }
        other => panic!("expected an error, got {other:?}"),
    }
    assert_eq!(current.sim.split_threshold, 0.2);

    // A geometry change builds a new model.
    std::fs::write(
        &style,
        tiny_style("0.2").replace("cross_sections: 8", "cross_sections: 6"),
    )
    .unwrap();
    match reload::reload(&style, &current) {
        StyleChange::Geometry(b) => assert_eq!(b.1.k, 6),
        other => panic!("expected a new model, got {other:?}"),
    }
}

/// Waits until `cond` or the deadline; false on timeout.
fn wait_for(deadline: Duration, mut cond: impl FnMut() -> bool) -> bool {
    let t = Instant::now();
    while t.elapsed() < deadline {
        if cond() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

#[test]
fn saving_the_watched_style_changes_the_threshold_logged_in_later_frames() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let out = dir.path().join("watch.rrd");
    let stop = StopSignal::new();
    let editor = {
        let style = style.clone();
        let out = out.clone();
        let stop = stop.clone();
        std::thread::spawn(move || {
            // Once the run is under way (the file exists), save an edit the way editors that
            // replace the file do: write a new file and rename it over the old one.
            assert!(wait_for(Duration::from_secs(20), || out.exists()));
            std::thread::sleep(Duration::from_millis(300));
            let tmp = style.with_extension("ron.tmp");
            std::fs::write(&tmp, tiny_style("0.7")).unwrap();
            std::fs::rename(&tmp, &style).unwrap();
            // Then a broken edit, which must leave 0.7 in force.
            std::thread::sleep(Duration::from_millis(600));
            std::fs::write(&style, "Style(").unwrap();
            std::thread::sleep(Duration::from_millis(600));
            stop.stop();
        })
    };
    let summary = run::run_with(args(&style, &out, 1.0e5, true), stop).expect("run");
    editor.join().unwrap();
    assert!(summary.interrupted);
    assert_eq!(summary.reloads, 1, "{summary:?}");

    let chunks = decode_file(&out);
    let thresholds = scalars(&chunks, "/params/split_threshold");
    assert_eq!(thresholds.len() as u64, summary.frames_logged);
    assert_eq!(thresholds[0].1, 0.2);
    let first_new = thresholds
        .iter()
        .position(|t| t.1 == 0.7)
        .expect("the reloaded threshold shows in /params");
    // From then on, the new value only: the broken edit changed nothing.
    assert!(thresholds[..first_new].iter().all(|t| t.1 == 0.2));
    assert!(thresholds[first_new..].iter().all(|t| t.1 == 0.7));
    let log = texts(&chunks, paths::LOG).join("\n");
    assert!(
        log.contains("split_threshold 0.2 → 0.7"),
        "reload not in the log:\n{log}"
    );
    assert!(log.contains("not applied"), "no warning in the log:\n{log}");
}

#[test]
fn a_recording_stopped_mid_run_like_ctrl_c_is_complete_and_valid() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let out = dir.path().join("stopped.rrd");
    let stop = StopSignal::new();
    let stopper = {
        let stop = stop.clone();
        let out = out.clone();
        std::thread::spawn(move || {
            assert!(wait_for(Duration::from_secs(20), || out.exists()));
            std::thread::sleep(Duration::from_millis(400));
            // What the Ctrl-C handler and the `q` key do.
            stop.stop();
        })
    };
    let seconds = 1.0e5;
    let summary = run::run_with(args(&style, &out, seconds, false), stop).expect("run");
    stopper.join().unwrap();
    assert!(summary.interrupted);
    assert!(summary.frames_logged > 0);
    assert!(summary.sim_time < seconds);
    verify_with_cli(&out);
    let chunks = decode_file(&out);
    // No frame lost: every frame the run counted is in the file, in order.
    let node_rows = rows(
        &chunks,
        paths::NODES,
        Points3D::descriptor_positions().component,
    );
    assert_eq!(
        node_rows.iter().map(|r| r.0).collect::<Vec<_>>(),
        (0..summary.frames_logged as i64).collect::<Vec<_>>()
    );
}

#[test]
fn the_binary_exits_2_naming_a_missing_style_or_a_bad_motion() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never.rrd");
    let bin = env!("CARGO_BIN_EXE_wisptree");
    let missing = dir.path().join("missing.ron");
    let o = std::process::Command::new(bin)
        .arg("run")
        .arg("--style")
        .arg(&missing)
        .arg("--save")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("missing.ron"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    // Nothing was recorded for a run that never started.
    assert!(!out.exists());

    let style = write_style(dir.path(), "0.2");
    let o = std::process::Command::new(bin)
        .arg("--style")
        .arg(&style)
        .args(["--motion", "moonwalk", "--save"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("moonwalk"), "{err}");

    for (bad, says) in [
        ("--seconds=-1", "positive number"),
        ("--seconds=inf", "positive number"),
        ("--strands=0", "at least one strand"),
    ] {
        let o = std::process::Command::new(bin)
            .args(["run", bad])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad}: {err}");
        assert!(err.contains(says), "{bad}: {err}");
    }
}

#[test]
fn a_watched_geometry_edit_restarts_on_the_new_model() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let out = dir.path().join("geometry.rrd");
    let stop = StopSignal::new();
    let editor = {
        let style = style.clone();
        let out = out.clone();
        let stop = stop.clone();
        std::thread::spawn(move || {
            assert!(wait_for(Duration::from_secs(20), || out.exists()));
            std::thread::sleep(Duration::from_millis(300));
            // Fewer cross-sections per wisp: a new model, not a parameter.
            let text = tiny_style("0.2").replace("cross_sections: 8", "cross_sections: 5");
            std::fs::write(&style, text).unwrap();
            std::thread::sleep(Duration::from_millis(700));
            stop.stop();
        })
    };
    let summary = run::run_with(args(&style, &out, 1.0e5, true), stop).expect("run");
    editor.join().unwrap();
    assert_eq!(summary.restarts, 1, "{summary:?}");
    assert_eq!(summary.reloads, 0, "{summary:?}");
    let chunks = decode_file(&out);
    let log = texts(&chunks, paths::LOG).join("\n");
    assert!(log.contains("restarting"), "{log}");
    // The strands drawn have K points smoothed: fewer cross-sections, shorter polylines.
    let strips = LineStrips3D::descriptor_strips().component;
    let strands: rerun::EntityPath = paths::STRANDS.into();
    let mut lengths = Vec::new();
    for c in chunks.iter().filter(|c| *c.entity_path() == strands) {
        for item in c.iter_component::<rerun::components::LineStrip3D>(strips) {
            lengths.push(item.as_slice()[0].0.len());
        }
    }
    let (first, last) = (lengths[0], *lengths.last().unwrap());
    assert!(last < first, "strand points {first} → {last}");
    // Frames keep counting across the restart, one row each.
    let node_rows = rows(
        &chunks,
        paths::NODES,
        Points3D::descriptor_positions().component,
    );
    assert_eq!(
        node_rows.iter().map(|r| r.0).collect::<Vec<_>>(),
        (0..summary.frames_logged as i64).collect::<Vec<_>>()
    );
}

#[test]
fn a_recording_with_rendering_has_one_jpeg_per_frame_beside_the_debug_view() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let out = dir.path().join("render.rrd");
    let mut opts = args(&style, &out, 0.4, false);
    opts.render = Some((160, 120));
    let summary = run::run_with(opts, StopSignal::new()).expect("run");
    let frames = summary.frames_logged as i64;
    assert!(frames >= 10);
    let chunks = decode_file(&out);
    let blob = rerun::EncodedImage::descriptor_blob().component;
    let images = rows(&chunks, wisptree::stream::paths::RENDER, blob);
    assert_eq!(
        images,
        (0..frames).map(|f| (f, 1)).collect::<Vec<_>>(),
        "one image per frame when recording"
    );
    // Nothing is skipped when recording.
    let skipped = scalars(&chunks, "/stats/render_skipped");
    assert_eq!(skipped.len() as i64, frames);
    assert!(skipped.iter().all(|(_, v)| *v == 0.0), "{skipped:?}");
}

/// Nothing the user made is lost. `--save` onto an existing file keeps it as `NAME.bak` (the
/// SDK's file sink would truncate it) and writes a valid recording; once `NAME.bak` exists too,
/// a run is refused with exit 2 naming both, before anything runs, and neither file changes.
/// `bench --json` keeps an earlier report the same way. A run without a viewer and without
/// `--save` records to the first free one of `wisptree.rrd`, `wisptree-2.rrd`, ….
#[test]
fn an_existing_recording_or_report_is_kept_as_a_backup_never_overwritten() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), "0.2");
    let bin = env!("CARGO_BIN_EXE_wisptree");
    let out = dir.path().join("mine.rrd");
    let bak = dir.path().join("mine.rrd.bak");
    std::fs::write(&out, "an earlier recording").unwrap();
    let save = |out: &Path| {
        std::process::Command::new(bin)
            .arg("run")
            .arg("--style")
            .arg(&style)
            .args([
                "--seconds",
                "0.1",
                "--strands",
                "5",
                "--no-render",
                "--save",
            ])
            .arg(out)
            .output()
            .unwrap()
    };
    let o = save(&out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("mine.rrd.bak"), "the move is said: {err}");
    assert_eq!(
        std::fs::read_to_string(&bak).unwrap(),
        "an earlier recording"
    );
    assert!(
        !decode_file(&out).is_empty(),
        "the new recording is a valid .rrd"
    );
    let written = std::fs::read(&out).unwrap();

    let o = save(&out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("mine.rrd") && err.contains("mine.rrd.bak") && err.contains("move one"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(std::fs::read(&out).unwrap(), written);
    assert_eq!(
        std::fs::read_to_string(&bak).unwrap(),
        "an earlier recording"
    );

    let json = dir.path().join("bench.json");
    std::fs::write(&json, "{\"mine\": 1}").unwrap();
    let o = std::process::Command::new(bin)
        .args(["bench", "--models"])
        .arg(&style)
        .args([
            "--solvers",
            "awt",
            "--seconds",
            "0.05",
            "--no-pipeline",
            "--json",
        ])
        .arg(&json)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let json_bak = dir.path().join("bench.json.bak");
    assert_eq!(std::fs::read_to_string(&json_bak).unwrap(), "{\"mine\": 1}");
    assert!(std::fs::read_to_string(&json)
        .unwrap()
        .contains("\"solvers\""));

    // No viewer on PATH, no --save: fresh names in the working directory.
    let work = dir.path().join("work");
    std::fs::create_dir(&work).unwrap();
    for _ in 0..3 {
        let o = std::process::Command::new(bin)
            .current_dir(&work)
            .env("PATH", "")
            .arg("--style")
            .arg(&style)
            .args(["--seconds", "0.1", "--strands", "5", "--no-render"])
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let mut names: Vec<String> = std::fs::read_dir(&work)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["wisptree-2.rrd", "wisptree-3.rrd", "wisptree.rrd"]);
}
