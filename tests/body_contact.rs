//! No model sinks into the body: the node centres each model logs (`/hair/<model>/nodes`) stay
//! within 1 mm of the body spheres' surface at every displayed frame, on every built-in style
//! under `lean` and `shake` (issue 29), as the AWT's do.

use nalgebra::{Point3, Vector3};
use wisptree::frame::Frame;
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

/// How far a logged centre may be inside a body sphere, m.
const TOLERANCE_M: f64 = 1e-3;
/// Simulated seconds per case.
const SECONDS: f64 = 3.0;

/// The deepest a node centre went inside a body sphere over the run, m, and where.
fn deepest(style: &str, motion: &str, kind: SolverKind) -> (f64, String) {
    let scene = Scene::load(style, motion, kind).unwrap();
    let mut s = scene.solver();
    let mut r = s.new_report();
    let mut f = Frame::default();
    let frames = (SECONDS / (s.dt() * s.steps_per_frame() as f64)).round() as usize;
    let mut worst = (0.0f64, String::new());
    for frame in 0..frames {
        for _ in 0..s.steps_per_frame() {
            s.step(&mut r);
        }
        s.sync_display();
        f.nodes.positions.clear();
        f.segments.starts.clear();
        s.draw(&mut f);
        let pose = *s.pose();
        for sp in &s.model().body {
            let c = pose
                .transform_point(&Point3::from(Vector3::from(sp.center)))
                .coords;
            for (i, p) in f.nodes.positions.iter().enumerate() {
                let p = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                let depth = sp.radius - (p - c).norm();
                if depth > worst.0 {
                    worst = (depth, format!("frame {frame}, node {i}"));
                }
            }
        }
    }
    worst
}

fn check(kind: SolverKind) {
    let mut failures = Vec::new();
    for style in ["short", "short_curly", "long", "long_curly"] {
        for motion in ["lean", "shake"] {
            let (d, at) = deepest(style, motion, kind);
            eprintln!("{kind} {style} {motion}: deepest {:.2} mm ({at})", d * 1e3);
            if d > TOLERANCE_M {
                failures.push(format!(
                    "{style} {motion}: {:.2} mm inside at {at}",
                    d * 1e3
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{kind} sinks into the body: {failures:?}"
    );
}

#[test]
fn layered_node_centres_stay_out_of_the_body() {
    check(SolverKind::Layered);
}

#[test]
fn guide_node_centres_stay_out_of_the_body() {
    check(SolverKind::Guides);
}
