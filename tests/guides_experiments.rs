//! The guide-strand paper's braid and brush experiments (Chang, Jin, Yu 2002, §7.2 Fig. 6 and
//! §7.4 Fig. 7), shortened, and the moving obstacle they rely on.

#[path = "common/sweep_rrd.rs"]
#[allow(dead_code)] // the blueprint reader only
mod sweep_rrd;

use serde_json::Value;
use wisptree::experiment::{find, ExperimentOptions, ExperimentRun, NoFrames};
use wisptree::solver::guides::obstacle::{MovingSphere, PathKey};

fn run(name: &str, duration_scale: f64) -> Vec<ExperimentRun> {
    let def = find(name).unwrap();
    let runs = (def.run)(&ExperimentOptions { duration_scale }, &mut NoFrames).unwrap();
    for r in &runs {
        eprintln!("{name} {} {:?}", r.label, r.metrics);
    }
    runs
}

fn metric<'a>(runs: &'a [ExperimentRun], label: &str, m: &str) -> &'a Value {
    &runs.iter().find(|r| r.label == label).unwrap().metrics[m]
}

/// The braid's full 4 s (at half length the collision run still has half a turn left). Without
/// collision every strand of one set falls through the other set: the 3-turn twist is undone
/// by passing (about 140 crossings); 100 is far below that and far above what a leak of the
/// collision would give. With collision the sets never pass, so the twist is only undone by
/// the end turning: the braid unfolds fully in a spiral (Chang §7.2, Fig. 6), its free end
/// turning about −2.9 times, 0.1 turns left.
#[test]
fn chang_fig6_braid_unfolds_by_turning_only_with_collision() {
    let runs = run("chang-fig6", 1.0);
    let crossings = |l| metric(&runs, l, "crossings").as_u64().unwrap();
    let f = |l, m| metric(&runs, l, m).as_f64().unwrap();
    assert!(
        crossings("no_collision") >= 100,
        "{}",
        crossings("no_collision")
    );
    assert_eq!(crossings("collision"), 0);
    // No passing: the twist left is the twist undone by the free end, 3 turns at the start.
    let left = f("collision", "twist_turns");
    assert!(
        (left - (3.0 + f("collision", "end_turns"))).abs() < 0.05,
        "{left}"
    );
    assert!(
        left.abs() < 0.25,
        "the braid unfolds fully: {left} turns left"
    );
    assert!(
        f("collision", "end_turns") <= -2.75,
        "the end turns to untwist: {}",
        f("collision", "end_turns")
    );
    assert!(
        f("no_collision", "twist_turns").abs() < 0.5,
        "untwisted by passing"
    );
}

/// The full run (the sphere stops after 1 s, then 8 s): the interacting brush is still about
/// 4.6 s after the stop, later than a half-length run's end. Without interaction a few hairs
/// stay draped over the sphere's far side, stopped on it (§3.3), and the brush is still moving
/// at the end; with the default sliding friction they slide off.
#[test]
fn chang_fig7_hairs_drape_without_interaction_and_the_brush_settles_faster_with_it() {
    let runs = run("chang-fig7", 1.0);
    let settle = |l| metric(&runs, l, "settle_s").as_f64();
    let behind = |l| metric(&runs, l, "hairs_behind").as_u64().unwrap();
    let with = settle("interaction").expect("the interacting brush settles");
    assert!(with > 0.0);
    if let Some(without) = settle("no_interaction") {
        assert!(with < without, "{with} vs {without}");
    }
    assert!(behind("no_interaction") >= 1, "no hair drapes");
    assert!(
        behind("no_interaction_sliding") < behind("no_interaction"),
        "sliding on the sphere drapes fewer hairs than being stopped by it"
    );
    assert!(metric(&runs, "interaction", "hairs_behind").is_u64());
}

#[test]
fn moving_sphere_eases_between_keys_and_holds_the_ends() {
    let o = MovingSphere {
        radius: 0.1,
        path: vec![
            PathKey {
                time: 1.0,
                center: [0.0, 0.0, 0.0],
            },
            PathKey {
                time: 3.0,
                center: [0.0, 0.0, 2.0],
            },
        ],
    };
    let (c0, v0) = o.center_at(0.5);
    assert_eq!((c0.z, v0.z), (0.0, 0.0));
    let (c, v) = o.center_at(2.0);
    assert!(
        (c.z - 1.0).abs() < 1e-12 && (v.z - 1.5).abs() < 1e-12,
        "{c} {v}"
    );
    let (c1, v1) = o.center_at(5.0);
    assert_eq!((c1.z, v1.z), (2.0, 0.0));
    // The velocity is the derivative of the position.
    let h = 1e-6;
    let fd = (o.center_at(1.7 + h).0 - o.center_at(1.7 - h).0) / (2.0 * h);
    assert!((fd - o.center_at(1.7).1).norm() < 1e-6);
    assert_eq!(o.stop_time(), 3.0);
}

#[test]
fn bad_obstacles_are_errors_naming_the_field() {
    let text = include_str!("../scenes/chang_fig7.ron");
    for (from, to, field) in [
        (
            "(radius: 0.05,",
            "(radius: -1.0,",
            "guides.obstacles[0].radius",
        ),
        (
            "(time: 1.0, center",
            "(time: 0.0, center",
            "guides.obstacles[0].path[1].time",
        ),
    ] {
        let t = text.replacen(from, to, 1);
        assert_ne!(t, text);
        let err = wisptree::scene::parse_style(std::path::Path::new("x.ron"), &t).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("x.ron") && msg.contains(field), "{msg}");
    }
}

/// The brush's strips join horizontal and vertical neighbours (§4.2, Fig. 3a): every guide of
/// the 8 × 8 grid is joined to its +x and +z neighbours, 2 · 8 · 7 strips.
#[test]
fn brush_strips_join_both_grid_directions() {
    let text = include_str!("../scenes/chang_fig7.ron");
    let loaded = wisptree::style::parse(std::path::Path::new("chang_fig7.ron"), text).unwrap();
    let model = std::sync::Arc::new(wisptree::model::HairModel::from_style(&loaded).unwrap());
    let motion = wisptree::motion::Motion::parse("still", model.scalp_center.into()).unwrap();
    let s = wisptree::solver::guides::GuideSolver::new(
        model,
        motion,
        loaded.style.sim.clone(),
        loaded.style.guides.clone(),
    );
    assert_eq!(s.alive().len(), 64);
    assert_eq!(s.strips.pairs.len(), 2 * 8 * 7);
    let n = s.guide_params().segments;
    let (mut along_x, mut along_z) = (0, 0);
    for &(a, b) in &s.strips.pairs {
        let d = s.chains.x[b as usize * (n + 1)] - s.chains.x[a as usize * (n + 1)];
        along_x += (d.x > 0.009 && d.z.abs() < 1e-9) as usize;
        along_z += (d.z > 0.009 && d.x.abs() < 1e-9) as usize;
    }
    assert_eq!((along_x, along_z), (56, 56));
}

/// The gallery draws a moving obstacle as a body sphere: the solver hands out chang-fig7's
/// sphere posed where its path puts it, and it moves with the solver's time.
#[test]
fn guide_solver_hands_out_its_obstacle_posed() {
    use wisptree::solver::Solver as _;
    let text = include_str!("../scenes/chang_fig7.ron");
    let loaded = wisptree::style::parse(std::path::Path::new("chang_fig7.ron"), text).unwrap();
    let model = std::sync::Arc::new(wisptree::model::HairModel::from_style(&loaded).unwrap());
    let motion = wisptree::motion::Motion::parse("still", model.scalp_center.into()).unwrap();
    let gp = loaded.style.guides.clone();
    let o = gp.obstacles[0].clone();
    let mut s =
        wisptree::solver::guides::GuideSolver::new(model, motion, loaded.style.sim.clone(), gp);
    let mut spheres = Vec::new();
    s.obstacle_spheres(&mut spheres);
    assert_eq!(spheres.len(), 1);
    assert_eq!(spheres[0], (o.center_at(0.0).0, o.radius));
    let mut report = s.new_report();
    let steps = (o.stop_time() / s.dt()).ceil() as usize + 1;
    for _ in 0..steps {
        s.step(&mut report);
    }
    spheres.clear();
    s.obstacle_spheres(&mut spheres);
    let end = o.center_at(o.stop_time()).0;
    assert!(
        (spheres[0].0 - end).norm() < 1e-9,
        "{:?} vs {end}",
        spheres[0]
    );
    assert!((end - o.center_at(0.0).0).norm() > 0.05, "the sphere moves");
}

/// The recording's plots that overlay every run (`TimeSeries` views of its blueprint).
fn overlay_plots(experiment: &str) -> usize {
    let dir = tempfile::tempdir().unwrap();
    let rrd = dir.path().join("x.rrd");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["experiment", experiment, "--save"])
        .arg(&rrd)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Views by entity (the layout is sent again as runs start: the last send holds them all).
    let bp = sweep_rrd::cells(&sweep_rrd::read_rrd(&rrd).blueprint);
    bp.iter()
        .filter(|((e, c, _), v)| {
            e.starts_with("/view/")
                && c.contains("class_identifier")
                && v.iter()
                    .any(|a| format!("{a:?}").contains("\"TimeSeries\""))
        })
        .count()
}

#[test]
fn only_runs_that_count_their_nodes_get_the_overlaid_plots() {
    // The guides' braid drives its solver itself: no active nodes, no stage times, no plots
    // (they were flat zeros). The AWT's swing gives them: both plots.
    assert_eq!(overlay_plots("chang-fig6"), 0);
    assert_eq!(overlay_plots("awt-fig5"), 2);
}
