//! The Rerun logging side, without a viewer: synthetic frames go through `Logger` into an
//! in-memory sink (decoded back into chunks) or a `.rrd` file (checked by the real CLI).

#[path = "common/rrd.rs"]
mod rrd;
#[path = "common/shared.rs"]
mod shared;

use std::collections::BTreeMap;

use rerun::external::re_log_types::LogMsg;
use rerun::log::Chunk;
use rerun::{
    AnnotationContext, Capsules3D, ComponentIdentifier, Ellipsoids3D, LineStrips3D, Points3D,
    Scalars, SeriesLines, TextLog, ViewCoordinates,
};
use rrd::rows;
use wisptree::frame::Frame;
use wisptree::report::{AdaptEvent, Counters, EventKind};
use wisptree::stream::{self, paths, Logger, MessageLevel};

const LEVELS: u16 = 3;
const HEAD: [f32; 3] = [0.0, 1.6, 0.0];
const EVENT_FRAME: u64 = 2;

/// Frame `index`: a different number of nodes per frame (so row counts can be told apart), a few
/// segments and strands, two body spheres, and events in frame `EVENT_FRAME` only.
fn synthetic_frame(index: u64) -> Frame {
    let mut f = Frame {
        index,
        sim_time: index as f64 * 0.04,
        levels: LEVELS,
        step_ms: 1.5 + index as f64,
        ..Frame::default()
    };
    let n_nodes = 4 + index as usize;
    for k in 0..n_nodes {
        let y = 1.6 - 0.05 * k as f32;
        f.nodes.positions.push([0.02 * k as f32, y, 0.1]);
        f.nodes.levels.push((k % LEVELS as usize) as u16);
        f.nodes.radii.push(0.03 / (1 + k % LEVELS as usize) as f32);
    }
    for k in 1..n_nodes {
        f.segments.starts.push(f.nodes.positions[k - 1]);
        f.segments.ends.push(f.nodes.positions[k]);
        f.segments.radii.push(f.nodes.radii[k]);
        f.segments.levels.push(f.nodes.levels[k]);
    }
    f.strands.offsets.push(0);
    for s in 0..3 {
        for p in 0..6 {
            f.strands
                .points
                .push([0.01 * s as f32, 1.6 - 0.06 * p as f32, 0.1]);
        }
        f.strands.offsets.push(f.strands.points.len() as u32);
    }
    f.body.sphere_centers = vec![[0.0, 1.2, 0.0], [0.0, 0.9, 0.0]];
    f.body.sphere_radii = vec![0.15, 0.2];
    f.body.scalp_center = HEAD;
    f.body.scalp_radii = [0.08, 0.11, 0.1];
    f.body.scalp_rotation = [0.0, 0.0, 0.0, 1.0];
    f.counters = Counters {
        active_per_level: vec![2, 1, 1 + index as u32],
        segments: (n_nodes - 1) as u32,
        pairs_tested: 10,
        pairs_in_contact: 2,
        body_contacts: 1,
        kinetic_energy: 0.01 * index as f64,
        ..Counters::default()
    };
    if index == EVENT_FRAME {
        let event = |kind, gc: u32| AdaptEvent {
            kind,
            time: f.sim_time,
            tree: 0,
            level: 1,
            gc,
            cross_section: 3,
            sub_gcs: 2 * gc..2 * gc + 2,
            position: [0.0, 1.4, 0.1 * gc as f64],
            accel_radius: 0.35,
            rel_velocity: 0.01,
        };
        f.events = vec![
            event(EventKind::Split, 1),
            event(EventKind::Merge, 2),
            event(EventKind::Split, 3),
        ];
        f.splits = 2;
        f.merges = 1;
        f.messages.push("split threshold changed to 0.2".to_owned());
    }
    let mut tuning = wisptree::solver::tunable::Tuning::default();
    tuning.sim.split_threshold = 0.2;
    tuning.sim.merge_velocity = 0.05;
    let awt = wisptree::solver::SolverKind::Awt.tunables();
    wisptree::pipeline::fill_stats(&mut f, awt, &tuning);
    f
}

const FRAMES: u64 = 5;

fn log_frames(rec: rerun::RecordingStream) -> Logger {
    let mut logger = Logger::new(
        wisptree::stream::sink::Recording(rec),
        &wisptree::stream::LoggerSetup::new(LEVELS, "synthetic", HEAD),
    )
    .expect("logger");
    for i in 0..FRAMES {
        logger.log_frame(&synthetic_frame(i)).expect("log frame");
    }
    logger
        .log_message(MessageLevel::Warn, "a warning")
        .expect("message");
    logger.flush().expect("flush");
    logger
}

struct Decoded {
    recording: Vec<Chunk>,
    blueprint: Vec<Chunk>,
    activations: usize,
}

fn decode(msgs: Vec<LogMsg>) -> Decoded {
    let mut d = Decoded {
        recording: Vec::new(),
        blueprint: Vec::new(),
        activations: 0,
    };
    for m in msgs {
        match m {
            LogMsg::ArrowMsg(store, arrow) => {
                let chunk = Chunk::from_arrow_msg(&arrow).expect("decode chunk");
                if store.is_blueprint() {
                    d.blueprint.push(chunk);
                } else {
                    d.recording.push(chunk);
                }
            }
            LogMsg::BlueprintActivationCommand(_) => d.activations += 1,
            LogMsg::SetStoreInfo(_) => {}
        }
    }
    d
}

fn memory_run() -> Decoded {
    let (rec, storage) = rerun::RecordingStreamBuilder::new("wisptree-test")
        .memory()
        .expect("memory recording");
    let logger = log_frames(rec);
    let msgs = storage.take();
    drop(logger);
    decode(msgs)
}

fn entity_paths(chunks: &[Chunk]) -> BTreeMap<String, usize> {
    let mut m = BTreeMap::new();
    for c in chunks {
        *m.entry(c.entity_path().to_string()).or_insert(0) += c.num_rows();
    }
    m
}

#[test]
fn every_entity_path_appears() {
    let d = memory_run();
    let seen = entity_paths(&d.recording);
    let mut expected: Vec<String> = [
        paths::NODES,
        paths::SEGMENTS,
        paths::STRANDS,
        paths::BODY_SPHERES,
        paths::SCALP,
        paths::SPLITS,
        paths::MERGES,
        paths::LOG,
        "/stats/splits",
        "/stats/merges",
        "/stats/pairs_tested",
        "/stats/pairs_in_contact",
        "/stats/body_contacts",
        "/stats/kinetic_energy",
        "/stats/step_ms",
        "/stats/dropped_frames",
        "/params/split_threshold",
        "/params/merge_velocity",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for l in 0..LEVELS as usize {
        expected.push(paths::active_nodes_level(l));
    }
    for p in &expected {
        assert!(seen.contains_key(p), "entity {p} missing; seen: {seen:?}");
    }
    // Scalars: one row per frame.
    let scalar = Scalars::descriptor_scalars().component;
    for p in expected
        .iter()
        .filter(|p| p.starts_with("/stats") || p.starts_with("/params"))
    {
        let r = rows(&d.recording, p, scalar);
        let frames: Vec<i64> = r.iter().map(|(f, _)| *f).collect();
        assert_eq!(frames, (0..FRAMES as i64).collect::<Vec<_>>(), "{p}");
        assert!(r.iter().all(|(_, n)| *n == 1), "{p}: {r:?}");
    }
}

#[test]
fn nodes_segments_strands_have_one_row_per_frame_with_all_instances() {
    let d = memory_run();
    let expect_nodes: Vec<(i64, usize)> = (0..FRAMES)
        .map(|i| (i as i64, synthetic_frame(i).nodes.positions.len()))
        .collect();
    assert_eq!(
        rows(
            &d.recording,
            paths::NODES,
            Points3D::descriptor_positions().component
        ),
        expect_nodes
    );
    // Class ids (levels) go along with every node.
    assert_eq!(
        rows(
            &d.recording,
            paths::NODES,
            Points3D::descriptor_class_ids().component
        ),
        expect_nodes
    );
    let expect_segments: Vec<(i64, usize)> = (0..FRAMES)
        .map(|i| (i as i64, synthetic_frame(i).segments.starts.len()))
        .collect();
    assert_eq!(
        rows(
            &d.recording,
            paths::SEGMENTS,
            Capsules3D::descriptor_translations().component
        ),
        expect_segments
    );
    let strands: Vec<(i64, usize)> = rows(
        &d.recording,
        paths::STRANDS,
        LineStrips3D::descriptor_strips().component,
    );
    assert_eq!(
        strands,
        (0..FRAMES as i64).map(|i| (i, 3)).collect::<Vec<_>>()
    );
    // The polylines arrive whole: frame 0's strands, point for point.
    let strands_path: rerun::EntityPath = paths::STRANDS.into();
    let f0 = synthetic_frame(0);
    let mut first_row: Option<Vec<Vec<[f32; 3]>>> = None;
    for c in d
        .recording
        .iter()
        .filter(|c| *c.entity_path() == strands_path)
    {
        if let Some(item) = c
            .iter_component::<rerun::components::LineStrip3D>(
                LineStrips3D::descriptor_strips().component,
            )
            .next()
        {
            first_row = Some(
                item.iter()
                    .map(|s| s.0.iter().map(|v| v.0).collect())
                    .collect(),
            );
            break;
        }
    }
    let expected: Vec<Vec<[f32; 3]>> = (0..f0.strands.len())
        .map(|s| f0.strands.strand(s).to_vec())
        .collect();
    assert_eq!(first_row, Some(expected));
    let body = rows(
        &d.recording,
        paths::BODY_SPHERES,
        Ellipsoids3D::descriptor_centers().component,
    );
    assert_eq!(body, (0..FRAMES as i64).map(|i| (i, 2)).collect::<Vec<_>>());
    let scalp = rows(
        &d.recording,
        paths::SCALP,
        Ellipsoids3D::descriptor_quaternions().component,
    );
    assert_eq!(
        scalp,
        (0..FRAMES as i64).map(|i| (i, 1)).collect::<Vec<_>>()
    );
}

#[test]
fn events_appear_only_in_their_frame_and_markers_are_cleared_after() {
    let d = memory_run();
    let text = TextLog::descriptor_text().component;
    let positions = Points3D::descriptor_positions().component;
    let e = EVENT_FRAME as i64;

    // Two splits and one merge, each a TextLog line at the event frame.
    assert_eq!(
        rows(&d.recording, paths::SPLITS, text),
        vec![(e, 1), (e, 1)]
    );
    assert_eq!(rows(&d.recording, paths::MERGES, text), vec![(e, 1)]);

    // Markers: all of the frame's events at once, then an empty batch at the next frame so the
    // markers do not linger; nothing in the other frames.
    assert_eq!(
        rows(&d.recording, paths::SPLITS, positions),
        vec![(e, 2), (e + 1, 0)]
    );
    assert_eq!(
        rows(&d.recording, paths::MERGES, positions),
        vec![(e, 1), (e + 1, 0)]
    );

    // The line names the level, the GC, the cross-section, the tree and the trigger value.
    let path: rerun::EntityPath = paths::SPLITS.into();
    let mut lines = Vec::new();
    for c in d.recording.iter().filter(|c| *c.entity_path() == path) {
        for item in c.iter_component::<rerun::components::Text>(text) {
            for t in item.iter() {
                lines.push(t.as_str().to_owned());
            }
        }
    }
    assert_eq!(lines.len(), 2, "{lines:?}");
    for needle in [
        "split",
        "level 1",
        "gc 1",
        "cross-section 3",
        "tree 0",
        "0.3500",
    ] {
        assert!(
            lines[0].contains(needle),
            "{needle:?} not in {:?}",
            lines[0]
        );
    }

    // Frame messages and log_message both land on /log (plus the style line at start).
    let log = rows(&d.recording, paths::LOG, text);
    assert!(log.contains(&(e, 1)), "{log:?}");
    assert_eq!(log.len(), 3, "{log:?}");
}

#[test]
fn static_context_and_blueprint_are_sent() {
    let d = memory_run();
    let root: rerun::EntityPath = "/".into();
    let statics: Vec<&Chunk> = d
        .recording
        .iter()
        .filter(|c| *c.entity_path() == root && c.is_static())
        .collect();
    let has = |comp: ComponentIdentifier| {
        statics
            .iter()
            .any(|c| c.components().contains_component(comp))
    };
    assert!(has(ViewCoordinates::descriptor_xyz().component));
    assert!(has(AnnotationContext::descriptor_context().component));

    // Annotation context: one class per level, distinct colours.
    let mut classes = Vec::new();
    for c in &statics {
        for item in c.iter_component::<rerun::components::AnnotationContext>(
            AnnotationContext::descriptor_context().component,
        ) {
            for ctx in item.iter() {
                for elem in &ctx.0 {
                    classes.push((
                        elem.class_description.info.id,
                        elem.class_description.info.color,
                    ));
                }
            }
        }
    }
    assert_eq!(classes.len(), LEVELS as usize, "{classes:?}");
    for (k, (id, color)) in classes.iter().enumerate() {
        assert_eq!(*id, k as u16);
        assert!(color.is_some());
        assert_eq!(*color, Some(stream::level_color(k as u16, LEVELS)));
    }
    for a in 0..classes.len() {
        for b in a + 1..classes.len() {
            assert_ne!(
                classes[a].1, classes[b].1,
                "levels {a} and {b} share a colour"
            );
        }
    }

    // The blueprint: activated once, with the 3D camera set.
    assert_eq!(d.activations, 1);
    let bp = entity_paths(&d.blueprint);
    let eye = rerun::EntityPath::from(format!(
        "{}/EyeControls3D",
        stream::spatial_view_blueprint_path()
    ))
    .to_string();
    assert!(bp.contains_key(&eye), "{eye} not in {bp:?}");
    assert!(bp.contains_key("/viewport"), "{bp:?}");
    assert_eq!(
        bp.keys()
            .filter(|k| k.starts_with("/view/")
                && !k.contains("/ViewContents")
                && !k.contains("Eye"))
            .count(),
        6,
        "{bp:?}"
    );
    // Time series colours: each level's curve in its level's colour.
    let series = SeriesLines::descriptor_colors().component;
    for l in 0..LEVELS {
        let path: rerun::EntityPath = paths::active_nodes_level(l as usize).into();
        let colors: Vec<u32> = d
            .recording
            .iter()
            .filter(|c| *c.entity_path() == path && c.is_static())
            .flat_map(|c| {
                c.iter_component::<rerun::components::Color>(series)
                    .collect::<Vec<_>>()
            })
            .flat_map(|item| item.iter().map(|c| c.0 .0).collect::<Vec<_>>())
            .collect();
        assert_eq!(colors, vec![stream::level_color(l, LEVELS).0], "level {l}");
    }
}

#[test]
fn level_colours_run_from_warm_dark_to_cool_light() {
    for levels in 2..=5u16 {
        let first = stream::level_color(0, levels);
        let last = stream::level_color(levels - 1, levels);
        let [r0, g0, b0, _] = first.to_array();
        let [r1, g1, b1, _] = last.to_array();
        assert!(r0 > b0, "coarse level is warm");
        assert!(b1 > r1, "finest level is cool");
        let luma = |r: u8, g: u8, b: u8| 0.3 * r as f32 + 0.59 * g as f32 + 0.11 * b as f32;
        assert!(
            luma(r1, g1, b1) > luma(r0, g0, b0) + 50.0,
            "finest is lighter"
        );
        let all: Vec<_> = (0..levels)
            .map(|l| stream::level_color(l, levels))
            .collect();
        for a in 0..all.len() {
            for b in a + 1..all.len() {
                assert_ne!(
                    all[a], all[b],
                    "{levels} levels: {a} and {b} share a colour"
                );
            }
        }
    }
}

#[test]
fn high_level_blueprint_builds() {
    // The SDK's own builder must accept the layout (it panics on a bad layout only when logged).
    let (rec, storage) = rerun::RecordingStreamBuilder::new("wisptree-test")
        .memory()
        .expect("memory recording");
    stream::blueprint()
        .send(&rec, rerun::blueprint::BlueprintActivation::default())
        .expect("send");
    rec.flush_blocking().expect("flush");
    let d = decode(storage.take());
    assert_eq!(d.activations, 1);
    assert!(d.blueprint.len() >= 5);
}

#[test]
fn rrd_file_passes_the_real_cli() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("stream.rrd");
    let rec = rerun::RecordingStreamBuilder::new("wisptree-test")
        .save(&path)
        .expect("file recording");
    let logger = log_frames(rec);
    drop(logger);
    let len = std::fs::metadata(&path).expect("rrd written").len();
    assert!(len > 1000, "rrd is only {len} bytes");

    let cli = shared::rerun_cli();
    let out = std::process::Command::new(&cli)
        .args(["rrd", "verify"])
        .arg(&path)
        .output()
        .expect("run rerun-cli");
    assert!(
        out.status.success(),
        "rrd verify failed:\nstdout: {}\nstderr: {}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    if let Ok(keep) = std::env::var("WISPTREE_KEEP_RRD") {
        std::fs::copy(&path, keep).expect("copy rrd");
    }
}

/// A head-sized scene for looking at the colours and the camera:
/// `WISPTREE_DEMO_RRD=/tmp/demo.rrd cargo test --release --test stream demo -- --ignored`,
/// then `rrd-screenshot /tmp/demo.rrd shot.png`.
#[test]
#[ignore = "writes a demo recording for a visual check"]
fn demo_recording() {
    let path =
        std::env::var("WISPTREE_DEMO_RRD").unwrap_or_else(|_| "/tmp/wisptree-demo.rrd".into());
    let rec = rerun::RecordingStreamBuilder::new("wisptree-demo")
        .save(&path)
        .expect("file recording");
    let head = [0.0f32, 1.65, 0.0];
    // Where the camera is told the head is (to check that the camera setting takes effect).
    let cam_head = match std::env::var("WISPTREE_DEMO_CAMERA_Y") {
        Ok(y) => [
            head[0],
            y.parse().expect("WISPTREE_DEMO_CAMERA_Y: a number"),
            head[2],
        ],
        Err(_) => head,
    };
    let mut logger = Logger::new(
        wisptree::stream::sink::Recording(rec),
        &wisptree::stream::LoggerSetup::new(LEVELS, "demo", cam_head),
    )
    .expect("logger");
    for index in 0..10u64 {
        let mut f = Frame {
            index,
            sim_time: index as f64 * 0.04,
            levels: LEVELS,
            ..Frame::default()
        };
        f.body.scalp_center = head;
        f.body.scalp_radii = [0.085, 0.11, 0.1];
        f.body.scalp_rotation = [0.0, 0.0, 0.0, 1.0];
        f.body.sphere_centers = vec![[0.0, 1.45, 0.0], [0.0, 1.25, 0.0], [0.0, 1.05, 0.0]];
        f.body.sphere_radii = vec![0.06, 0.18, 0.16];
        f.strands.offsets.push(0);
        let wisps = 12;
        let k = 8;
        for w in 0..wisps {
            let phi = std::f32::consts::PI * (0.15 + 0.7 * w as f32 / (wisps - 1) as f32);
            let (s, c) = phi.sin_cos();
            let wiggle = 0.01 * (index as f32 * 0.7 + w as f32).sin();
            // Wisp axis: from the scalp, out and down the back.
            let axis: Vec<[f32; 3]> = (0..k)
                .map(|i| {
                    let t = i as f32 / (k - 1) as f32;
                    let r = 0.11 + 0.03 * t;
                    [
                        head[0] + r * c,
                        head[1] + 0.06 - 0.45 * t,
                        head[2] - r * s * 0.9,
                    ]
                })
                .collect();
            for (i, p) in axis.iter().enumerate() {
                // Coarse near the root, fine near the tip, as the AWT invariant wants.
                let level = (3 * i / k) as u16;
                let subs = 1usize << (2 * level);
                for sub in 0..subs {
                    let off = if subs == 1 {
                        0.0
                    } else {
                        0.012 * (sub as f32 - (subs - 1) as f32 / 2.0)
                    };
                    f.nodes.positions.push([p[0] + off + wiggle, p[1], p[2]]);
                    f.nodes.radii.push(0.02 / (1 + level) as f32);
                    f.nodes.levels.push(level);
                    if i > 0 {
                        let q = axis[i - 1];
                        f.segments.starts.push([q[0] + wiggle, q[1], q[2]]);
                        f.segments.ends.push([p[0] + off + wiggle, p[1], p[2]]);
                        f.segments.radii.push(0.02 / (1 + level) as f32);
                        f.segments.levels.push(level);
                    }
                }
            }
            for strand in 0..20 {
                let o = 0.004 * (strand as f32 - 10.0);
                for p in &axis {
                    f.strands
                        .points
                        .push([p[0] + o + wiggle, p[1], p[2] + o * 0.5]);
                }
                f.strands.offsets.push(f.strands.points.len() as u32);
            }
        }
        if index == 3 {
            f.events.push(AdaptEvent {
                kind: EventKind::Split,
                time: f.sim_time,
                tree: 0,
                level: 0,
                gc: 0,
                cross_section: 5,
                sub_gcs: 0..4,
                position: [0.1, 1.35, -0.05],
                accel_radius: 0.4,
                rel_velocity: 0.0,
            });
        }
        logger.log_frame(&f).expect("log");
    }
    logger.flush().expect("flush");
}

/// Rough cost of `log_frame` at the paper's sizes (prints, asserts nothing about time):
/// `cargo test --release --test stream cost -- --ignored --nocapture`.
#[test]
#[ignore = "measurement, not a check"]
fn log_frame_cost() {
    let (rec, storage) = rerun::RecordingStreamBuilder::new("wisptree-cost")
        .memory()
        .expect("memory recording");
    let mut logger = Logger::new(
        wisptree::stream::sink::Recording(rec),
        &wisptree::stream::LoggerSetup::new(LEVELS, "cost", HEAD),
    )
    .expect("logger");
    let mut f = synthetic_frame(0);
    let n = 6000;
    f.nodes.positions = (0..n).map(|k| [k as f32 * 1e-4, 1.0, 0.0]).collect();
    f.nodes.radii = vec![0.01; n];
    f.nodes.levels = (0..n).map(|k| (k % 3) as u16).collect();
    f.segments.starts = f.nodes.positions.clone();
    f.segments.ends = f
        .nodes
        .positions
        .iter()
        .map(|p| [p[0], p[1] - 0.05, p[2]])
        .collect();
    f.segments.radii = f.nodes.radii.clone();
    f.segments.levels = f.nodes.levels.clone();
    f.strands.points.clear();
    f.strands.offsets = vec![0];
    for s in 0..10_000 {
        for p in 0..16 {
            f.strands
                .points
                .push([s as f32 * 1e-5, 1.6 - 0.04 * p as f32, 0.0]);
        }
        f.strands.offsets.push(f.strands.points.len() as u32);
    }
    let frames = 20;
    let t0 = std::time::Instant::now();
    for i in 0..frames {
        f.index = i;
        logger.log_frame(&f).expect("log");
    }
    let logged = t0.elapsed();
    logger.flush().expect("flush");
    let total = t0.elapsed();
    drop(storage.take());
    println!(
        "log_frame: {:.2} ms/frame to log, {:.2} ms/frame including the flush",
        logged.as_secs_f64() * 1e3 / frames as f64,
        total.as_secs_f64() * 1e3 / frames as f64
    );
}
