//! The node inspector (`run --inspect TREE:LEVEL:INDEX`): the split test's numbers of a node
//! that splits in a scripted run, checked against the event log, and the recording's copy of
//! them.

#[path = "common/rrd.rs"]
mod rrd;

use std::process::Command;

use wisptree::model::HairModel;
use wisptree::scene::Scene;
use wisptree::solver::{AdaptEvent, EventKind, NodeId, SolverKind};

const STYLE: &str = "short";
const MOTION: &str = "shake";
const FRAMES: usize = 40;

/// The user's name of the node an event is about.
fn node_of(m: &HairModel, e: &AdaptEvent) -> NodeId {
    let l = e.level as usize;
    let lv = &m.levels[l];
    let local = (0..e.gc as usize).filter(|&g| lv.tree[g] == e.tree).count();
    NodeId {
        tree: e.tree,
        level: l,
        index: local * m.k + e.cross_section as usize,
    }
}

/// Each frame's events, stepping as `run` does.
fn events_per_frame(scene: &Scene) -> Vec<Vec<AdaptEvent>> {
    let mut s = scene.solver();
    let mut r = s.new_report();
    (0..FRAMES)
        .map(|_| {
            let mut evs = Vec::new();
            for _ in 0..s.steps_per_frame() {
                s.step(&mut r);
                evs.extend(r.events.iter().cloned());
            }
            evs
        })
        .collect()
}

/// Each frame's inspected numbers of `id`, by name.
fn inspected(scene: &Scene, id: &NodeId) -> Vec<Vec<(&'static str, f64)>> {
    let mut s = scene.solver();
    let mut r = s.new_report();
    (0..FRAMES)
        .map(|_| {
            for _ in 0..s.steps_per_frame() {
                s.step(&mut r);
            }
            let mut v = Vec::new();
            s.inspect(id, &mut v).unwrap();
            v
        })
        .collect()
}

fn get(v: &[(&'static str, f64)], name: &str) -> f64 {
    v.iter()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("no {name}"))
        .1
}

#[test]
fn the_inspected_accel_radius_crosses_the_threshold_at_the_frame_of_the_split() {
    let scene = Scene::load(STYLE, MOTION, SolverKind::Awt).unwrap();
    let frames = events_per_frame(&scene);
    // The first split, after a few frames, of a node that is alone in its frame's events (so
    // the frame ends with it split).
    let (f, ev) = frames
        .iter()
        .enumerate()
        .skip(3)
        .flat_map(|(f, evs)| evs.iter().map(move |e| (f, e)))
        .find(|(f, e)| {
            e.kind == EventKind::Split
                && frames[*f]
                    .iter()
                    .filter(|o| o.level == e.level && o.gc == e.gc)
                    .count()
                    == 1
        })
        .expect("short under shake splits within 40 frames");
    let id = node_of(&scene.model, ev);
    let log = inspected(&scene, &id);
    let threshold = get(&log[f], "split_threshold_in_force");
    assert!(ev.accel_radius > threshold, "{ev:?}");
    // At the frame of the split the node is no longer active and shows the a·r that split it.
    assert_eq!(get(&log[f], "active"), 0.0, "{id:?} at frame {f}");
    assert_eq!(
        get(&log[f], "accel_radius"),
        ev.accel_radius,
        "{id:?} at frame {f}"
    );
    // Before it, while active, it was at or under the threshold at least once: it crossed.
    let under =
        (0..f).any(|g| get(&log[g], "active") == 1.0 && get(&log[g], "accel_radius") <= threshold);
    assert!(under, "{id:?}: never under the threshold before frame {f}");
    // The frame before the split, it was under the threshold or not allowed to split yet.
    let before = &log[f - 1];
    assert!(
        get(before, "accel_radius") <= threshold || get(before, "may_split") == 0.0,
        "{id:?} at frame {}: {before:?}",
        f - 1
    );
    // Every frame, the numbers are finite and the node's GC and cross-section are the event's.
    for v in &log {
        assert!(v.iter().all(|(_, x)| x.is_finite()), "{v:?}");
        assert_eq!(get(v, "gc"), ev.gc as f64);
        assert_eq!(get(v, "cross_section"), ev.cross_section as f64);
    }

    // The recording of `run --inspect` holds the same numbers, frame by frame.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("inspect.rrd");
    let spec = format!("{}:{}:{}", id.tree, id.level, id.index);
    let seconds = format!("{}", FRAMES as f64 * scene.frame_dt());
    let o = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["run", "--style", STYLE, "--motion", MOTION, "--no-render"])
        .args(["--seconds", &seconds, "--inspect", &spec, "--save"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let chunks = rrd::decode_file(&out);
    let path = format!("/inspect/{}/accel_radius", id.path());
    let series = rrd::scalars(&chunks, &path);
    assert_eq!(series.len(), FRAMES, "{path}");
    for (frame, v) in series {
        assert_eq!(
            v,
            get(&log[frame as usize], "accel_radius"),
            "frame {frame}"
        );
    }
    assert_eq!(
        rrd::scalars(&chunks, &format!("/inspect/{}/active", id.path())).len(),
        FRAMES
    );
    // The node is ringed in the 3D view every frame: one ellipsoid at its logged position.
    let ring = rrd::rows(
        &chunks,
        "/hair/inspected",
        rerun::Ellipsoids3D::descriptor_centers().component,
    );
    assert_eq!(
        ring.len(),
        FRAMES,
        "the inspected node's ring, frame by frame"
    );
    assert!(ring.iter().all(|&(_, n)| n == 1), "{ring:?}");
    let y = rrd::scalars(&chunks, &format!("/inspect/{}/position_y", id.path()));
    let h = rrd::scalars(&chunks, &format!("/inspect/{}/height", id.path()));
    assert_eq!(y, h, "position_y is the height");
}

#[test]
fn bad_inspect_requests_exit_2_naming_the_node() {
    let run = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_wisptree"))
            .args([
                "run",
                "--style",
                "short",
                "--seconds",
                "0.1",
                "--no-render",
                "-o",
            ])
            .args(args)
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    let (code, err) = run(&["--inspect", "0:9:0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("level 9 does not exist"), "{err}");
    let (code, err) = run(&["--inspect", "0:0:100000"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("index 100000 does not exist"), "{err}");
    let (code, err) = run(&["--inspect", "one:0:0"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("TREE"), "{err}");
    let (code, err) = run(&["--inspect", "0:1:0", "--model", "guides"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("one level (GUIDE:0:VERTEX)"), "{err}");
    let (code, err) = run(&["--inspect", "100000:0:0", "--model", "guides"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("guide 100000 does not exist"), "{err}");
    let (code, err) = run(&["--inspect", "0:0:99", "--model", "guides"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("vertex 99 does not exist"), "{err}");
    let (code, err) = run(&["--inspect", "0:1:0", "--model", "layered"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("one level of wisps"), "{err}");
    let (code, err) = run(&["--inspect", "100000:0:0", "--model", "layered"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("wisp 100000 does not exist"), "{err}");
}

#[test]
fn node_ids_parse_and_name_their_path() {
    let id = NodeId::parse("3:1:42").unwrap();
    assert_eq!(
        id,
        NodeId {
            tree: 3,
            level: 1,
            index: 42
        }
    );
    assert_eq!(id.path(), "3/1/42");
    for bad in ["", "1:2", "1:2:3:4", "-1:0:0", "a:b:c", "1.5:0:0"] {
        assert!(NodeId::parse(bad).is_err(), "{bad}");
    }
}

#[test]
fn a_node_clicked_in_the_view_is_the_one_drawn_there() {
    let scene = Scene::load(STYLE, MOTION, SolverKind::Awt).unwrap();
    let mut s = scene.solver();
    let mut r = s.new_report();
    for _ in 0..12 * s.steps_per_frame() {
        s.step(&mut r);
    }
    let mut frame = wisptree::frame::Frame::default();
    s.draw(&mut frame);
    let nodes = &frame.nodes;
    assert!(
        nodes.positions.len() > 20,
        "{} nodes drawn",
        nodes.positions.len()
    );
    let mut v = Vec::new();
    for c in (0..nodes.positions.len()).step_by(7) {
        // By instance: the node drawn as instance c, whose inspected position is c's centre.
        let id = s
            .pick_node(Some(c), None)
            .expect("a drawn instance names a node");
        assert_eq!(id.level, nodes.levels[c] as usize, "instance {c}");
        s.inspect(&id, &mut v).unwrap();
        assert_eq!(get(&v, "active"), 1.0, "{id:?}: a drawn node is active");
        let p = nodes.positions[c].map(|x| x as f64);
        for (k, axis) in ["position_x", "position_y", "position_z"]
            .iter()
            .enumerate()
        {
            assert!((get(&v, axis) - p[k]).abs() < 1e-5, "{id:?} {axis}");
        }
        // By the point clicked on its sphere (the top of it): a node whose sphere passes
        // through that point.
        let r = nodes.radii[c] as f64;
        let click = [p[0], p[1] + r, p[2]];
        let hit = s.pick_node(None, Some(click)).unwrap();
        s.inspect(&hit, &mut v).unwrap();
        let centre = [
            get(&v, "position_x"),
            get(&v, "position_y"),
            get(&v, "position_z"),
        ];
        let d = (0..3)
            .map(|k| (centre[k] - click[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            (d - get(&v, "radius")).abs() < 1e-4,
            "clicked {click:?} on {c}: picked {hit:?} whose surface is {} m away",
            (d - get(&v, "radius")).abs()
        );
    }
    assert_eq!(s.pick_node(Some(nodes.positions.len()), None), None);
}

#[test]
fn every_node_name_resolves_back_to_its_node() {
    let scene = Scene::load("long", "lean", SolverKind::Awt).unwrap();
    let m = &scene.model;
    for l in 0..m.level_count() {
        for j in 0..m.levels[l].gc_count() * m.k {
            let id = NodeId::of(m, l, j);
            let (g, i) = wisptree::solver::awt::inspect::resolve(m, &id).unwrap();
            assert_eq!(g * m.k + i, j, "{id:?}");
        }
    }
}

/// Inspects the node drawn as instance `c` of `nodes` (as a click on it names it), checks that
/// its numbers name it (`names`: the tree's and the index's) and give its drawn position, and
/// that a click on that exact position picks it too. Returns it, its numbers in `v`.
fn inspect_drawn(
    s: &dyn wisptree::solver::Solver,
    nodes: &wisptree::frame::NodeBuf,
    c: usize,
    names: [&str; 2],
    v: &mut Vec<(&'static str, f64)>,
) -> NodeId {
    let id = s.pick_node(Some(c), None).unwrap();
    s.inspect(&id, v).unwrap();
    assert_eq!(get(v, names[0]), id.tree as f64);
    assert_eq!(get(v, names[1]), id.index as f64);
    let exact = ["position_x", "position_y", "position_z"].map(|axis| get(v, axis));
    for (k, (x, drawn)) in exact.iter().zip(nodes.positions[c]).enumerate() {
        assert!((x - drawn as f64).abs() < 1e-5, "{id:?} axis {k}");
    }
    assert_eq!(s.pick_node(None, Some(exact)), Some(id));
    id
}

#[test]
fn a_layered_wisp_point_shows_its_state_and_its_wisps_contacts() {
    let scene = Scene::load(STYLE, MOTION, SolverKind::Layered).unwrap();
    let mut s = scene.solver();
    let mut r = s.new_report();
    let mut v = Vec::new();
    let mut seen_contacts = false;
    for _ in 0..30 {
        for _ in 0..s.steps_per_frame() {
            s.step(&mut r);
        }
        let mut frame = wisptree::frame::Frame::default();
        s.sync_display();
        s.draw(&mut frame);
        let nodes = &frame.nodes;
        for c in (0..nodes.positions.len()).step_by(13) {
            // The point drawn as instance c, and clicked on its centre: the same point.
            inspect_drawn(&*s, nodes, c, ["wisp", "point"], &mut v);
            assert!((get(&v, "radius") - nodes.radii[c] as f64).abs() < 1e-6);
            // The point's own contacts are among its wisp's, and a wisp with contact points
            // has contact pairs.
            let (own, all, pairs) = (
                get(&v, "point_contacts"),
                get(&v, "wisp_contacts"),
                get(&v, "wisp_contact_pairs"),
            );
            assert!(own <= all, "{v:?}");
            assert_eq!(all > 0.0, pairs > 0.0, "{v:?}");
            seen_contacts |= pairs > 0.0;
        }
    }
    assert!(
        seen_contacts,
        "no wisp inspected touched another in 30 frames of {MOTION}"
    );
    let e = s
        .inspect(
            &NodeId {
                tree: 0,
                level: 0,
                index: 100_000,
            },
            &mut v,
        )
        .unwrap_err();
    assert!(e.contains("point 100000 does not exist"), "{e}");
}

#[test]
fn a_guide_vertex_shows_its_state_contacts_links_and_strips() {
    let scene = Scene::load(STYLE, MOTION, SolverKind::Guides).unwrap();
    let mut s = scene.solver();
    let mut r = s.new_report();
    let mut v = Vec::new();
    let (mut seen_contacts, mut seen_links, mut seen_strips) = (false, false, false);
    for _ in 0..20 {
        for _ in 0..s.steps_per_frame() {
            s.step(&mut r);
        }
        let mut frame = wisptree::frame::Frame::default();
        s.sync_display();
        s.draw(&mut frame);
        let nodes = &frame.nodes;
        for c in (0..nodes.positions.len()).step_by(7) {
            // The vertex drawn as instance c, and clicked on its centre: the same vertex.
            inspect_drawn(&*s, nodes, c, ["guide", "vertex"], &mut v);
            // The vertex's own contacts are among its guide's; a link intact is below the
            // stretch that breaks it; a triangle not broken is within the strips' ratio.
            let (own, all) = (get(&v, "vertex_contacts"), get(&v, "guide_contacts"));
            assert!(own <= all, "{v:?}");
            let (links, broken) = (get(&v, "links"), get(&v, "links_broken"));
            assert!(broken <= links, "{v:?}");
            if links > broken {
                assert!(
                    get(&v, "link_stretch_max") < get(&v, "link_break_stretch"),
                    "{v:?}"
                );
            }
            let (tris, tris_broken) = (
                get(&v, "strip_triangles"),
                get(&v, "strip_triangles_broken"),
            );
            assert!(tris_broken <= tris, "{v:?}");
            // (The width is today's; the break was decided at the step's start, §4.2.)
            assert_eq!(tris > 0.0, get(&v, "strip_width_ratio_max") > 0.0, "{v:?}");
            seen_contacts |= all > 0.0;
            seen_links |= links > 0.0;
            seen_strips |= tris > 0.0;
        }
    }
    assert!(
        seen_contacts && seen_links && seen_strips,
        "in 20 frames of {MOTION} no guide inspected had contacts ({seen_contacts}), links \
         ({seen_links}) or strip triangles ({seen_strips})"
    );
    let e = s
        .inspect(
            &NodeId {
                tree: 0,
                level: 0,
                index: 100,
            },
            &mut v,
        )
        .unwrap_err();
    assert!(e.contains("vertex 100 does not exist"), "{e}");
}
