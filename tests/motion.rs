//! Head and body motion: presets start at rest, velocities are the derivatives of the poses,
//! the named features of each preset happen, keyframed files load and fail with useful errors.

use std::io::Write;

use nalgebra::{Point3, UnitQuaternion, Vector3};
use wisptree::motion::{Motion, MotionError, Pose};

fn anchor() -> Point3<f64> {
    Point3::new(0.0, 1.65, 0.0)
}

/// A point on the scalp, off every axis so all rotations move it.
fn head_point() -> Point3<f64> {
    anchor() + Vector3::new(0.05, 0.08, 0.09)
}

fn preset(name: &str) -> Motion {
    Motion::parse(name, anchor()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

const H: f64 = 1e-5;

fn rotation_angle_between(a: &Pose, b: &Pose) -> f64 {
    (b.iso.rotation * a.iso.rotation.inverse()).angle()
}

/// Forward lean angle about +x of a pose: how far the rest up axis tips towards +z.
fn forward_lean_deg(p: &Pose) -> f64 {
    let up = p.transform_vector(&Vector3::y());
    up.z.atan2(up.y).to_degrees()
}

#[test]
fn presets_start_at_rest() {
    for name in Motion::preset_names() {
        let m = preset(name);
        assert_eq!(m.name(), *name);
        for t in [0.0, -1.0] {
            let p = m.pose(t);
            let moved = (p.transform_point(&head_point()) - head_point()).norm();
            assert!(moved < 1e-12, "{name}: head moved {moved} m at t={t}");
            assert!(p.iso.rotation.angle() < 1e-12, "{name}: rotated at t={t}");
            assert!(
                p.linear_velocity.norm() < 1e-6,
                "{name}: v = {}",
                p.linear_velocity
            );
            assert!(
                p.angular_velocity.norm() < 1e-6,
                "{name}: ω = {}",
                p.angular_velocity
            );
        }
        // Easing in: after 50 ms the head has barely moved, so the first steps do not jerk the
        // hair (a jump to full speed would move it ≥ 0.05 · v).
        let early = (m.pose(0.05).transform_point(&head_point()) - head_point()).norm();
        assert!(
            early < 2e-3,
            "{name}: head moved {early} m in the first 50 ms"
        );
    }
}

/// Checks every velocity of a motion against central differences of the positions.
fn check_velocities(m: &Motion, times: &[f64]) {
    for &t in times {
        let p = m.pose(t);
        let (a, b) = (m.pose(t - H), m.pose(t + H));
        let scale = 1.0_f64.max(p.velocity_at(&p.transform_point(&head_point())).norm());
        // A head point and a far point (the rotation lever matters there).
        for rest in [head_point(), Point3::new(-0.3, 0.2, 0.4)] {
            let fd = (b.transform_point(&rest) - a.transform_point(&rest)) / (2.0 * H);
            let v = p.velocity_at(&p.transform_point(&rest));
            assert!(
                (v - fd).norm() < 1e-3 * scale,
                "{}: t={t}: velocity_at {v} vs finite difference {fd}",
                m.name()
            );
        }
        let fd_lin = (b.iso.translation.vector - a.iso.translation.vector) / (2.0 * H);
        assert!(
            (p.linear_velocity - fd_lin).norm() < 1e-3 * scale,
            "{}: t={t}: linear velocity {} vs d/dt translation {fd_lin}",
            m.name(),
            p.linear_velocity
        );
        let dq: UnitQuaternion<f64> = b.iso.rotation * a.iso.rotation.inverse();
        let fd_omega = dq.scaled_axis() / (2.0 * H);
        assert!(
            (p.angular_velocity - fd_omega).norm() < 1e-3 * scale,
            "{}: t={t}: ω {} vs finite difference {fd_omega}",
            m.name(),
            p.angular_velocity
        );
    }
}

#[test]
fn preset_velocities_are_derivatives_of_poses() {
    let times: Vec<f64> = (0..60).map(|i| 0.013 + i as f64 * 0.0917).collect();
    for name in Motion::preset_names() {
        check_velocities(&preset(name), &times);
    }
}

#[test]
fn presets_are_continuous() {
    // C0 and C1 across every phase boundary: no step in position or velocity between samples
    // 1 ms apart larger than a smooth motion at these speeds and accelerations allows.
    for name in Motion::preset_names() {
        let m = preset(name);
        let dt = 1e-3;
        let mut prev = m.pose(0.0);
        for i in 1..6000 {
            let p = m.pose(i as f64 * dt);
            let x0 = prev.transform_point(&head_point());
            let x1 = p.transform_point(&head_point());
            let (v0, v1) = (prev.velocity_at(&x0), p.velocity_at(&x1));
            assert!(
                (x1 - x0).norm() < 10.0 * dt,
                "{name}: position jump at {}",
                i as f64 * dt
            );
            assert!(
                (v1 - v0).norm() < 100.0 * dt,
                "{name}: velocity jump at {}",
                i as f64 * dt
            );
            prev = p;
        }
    }
}

#[test]
fn poses_are_deterministic() {
    for name in Motion::preset_names() {
        let (a, b) = (preset(name), preset(name));
        for t in [0.3, 1.7, 4.2] {
            assert_eq!(a.pose(t), b.pose(t), "{name} at {t}");
        }
    }
}

#[test]
fn still_never_moves() {
    let m = preset("still");
    for t in [0.0, 0.5, 3.0, 100.0] {
        assert_eq!(m.pose(t), Pose::identity());
    }
}

#[test]
fn stop_is_exactly_at_rest_after_1_2_s() {
    let m = preset("stop");
    // It does move first, and fast.
    let peak = (0..120)
        .map(|i| {
            let p = m.pose(i as f64 * 0.01);
            p.velocity_at(&p.transform_point(&head_point())).norm()
        })
        .fold(0.0, f64::max);
    assert!(
        peak > 0.8,
        "stop: peak head speed {peak} m/s is not a fast move"
    );
    let rest = m.pose(1.2);
    assert!(
        rotation_angle_between(&Pose::identity(), &rest) > 0.5,
        "stop ends turned"
    );
    for t in [1.2, 1.25, 2.0, 7.5, 100.0] {
        let p = m.pose(t);
        assert_eq!(p.iso, rest.iso, "stop moved at t={t}");
        assert_eq!(p.linear_velocity, Vector3::zeros(), "t={t}");
        assert_eq!(p.angular_velocity, Vector3::zeros(), "t={t}");
    }
}

#[test]
fn lean_leans_forward_then_back_and_repeats() {
    let m = preset("lean");
    let angles: Vec<f64> = (0..=500)
        .map(|i| forward_lean_deg(&m.pose(i as f64 * 0.01)))
        .collect();
    let max = angles.iter().cloned().fold(f64::MIN, f64::max);
    let min = angles.iter().cloned().fold(f64::MAX, f64::min);
    assert!(max >= 25.0, "lean: max forward angle {max}°");
    assert!(
        max <= 45.0,
        "lean: max forward angle {max}° is not a person"
    );
    assert!(min < -3.0 && min > -20.0, "lean: max backward angle {min}°");
    let first_peak = angles.iter().position(|&a| a >= 25.0).unwrap();
    let back = angles[first_peak..].iter().position(|&a| a.abs() < 1.0);
    assert!(back.is_some(), "lean: never returned upright");
    // Rotation about x only: the x axis is unmoved, and the hips are the fixed point.
    let p = m.pose(0.8);
    assert!((p.transform_vector(&Vector3::x()) - Vector3::x()).norm() < 1e-12);
    let hips = anchor() - Vector3::new(0.0, 0.6, 0.0);
    assert!((p.transform_point(&hips) - hips).norm() < 1e-12);
    // The forward lean moves the head towards +z (the face) and down.
    let head = p.transform_point(&anchor());
    assert!(head.z > 0.25 && head.y < anchor().y);
    // Periodic: it leans forward again in the next cycles.
    assert!(angles[250..].iter().any(|&a| a >= 25.0));
}

#[test]
fn shake_rotates_about_the_vertical_axis_through_the_neck() {
    let m = preset("shake");
    let neck = anchor() - Vector3::new(0.0, 0.12, 0.0);
    let mut max_yaw: f64 = 0.0;
    for i in 1..400 {
        let p = m.pose(i as f64 * 0.01);
        // Up stays up, the neck stays put, ω is vertical.
        assert!((p.transform_vector(&Vector3::y()) - Vector3::y()).norm() < 1e-12);
        assert!((p.transform_point(&neck) - neck).norm() < 1e-12);
        let w = p.angular_velocity;
        assert!(w.x.abs() < 1e-12 && w.z.abs() < 1e-12, "ω = {w}");
        assert!(p.velocity_at(&neck).norm() < 1e-12);
        let f = p.transform_vector(&Vector3::z());
        max_yaw = max_yaw.max(f.x.atan2(f.z).to_degrees().abs());
    }
    assert!(
        (35.0..=45.0).contains(&max_yaw),
        "shake amplitude {max_yaw}°"
    );
    // About 2 Hz: count sign changes of the yaw rate over 2 s once eased in.
    let rates: Vec<f64> = (0..200)
        .map(|i| m.pose(1.0 + i as f64 * 0.01).angular_velocity.y)
        .collect();
    let turns = rates
        .windows(2)
        .filter(|w| w[0].signum() != w[1].signum())
        .count();
    assert!((7..=9).contains(&turns), "{turns} direction changes in 2 s");
}

#[test]
fn run_moves_forward_bobbing() {
    let m = preset("run");
    let p = m.pose(5.0);
    assert!(
        (p.linear_velocity.z - 3.0).abs() < 0.3,
        "speed {}",
        p.linear_velocity
    );
    assert!(p.transform_point(&anchor()).z > 10.0);
    let ys: Vec<f64> = (0..200)
        .map(|i| m.pose(3.0 + i as f64 * 0.005).transform_point(&anchor()).y)
        .collect();
    let bob =
        ys.iter().cloned().fold(f64::MIN, f64::max) - ys.iter().cloned().fold(f64::MAX, f64::min);
    assert!((0.025..0.06).contains(&bob), "bob {bob} m");
    let lean = forward_lean_deg(&m.pose(3.0));
    assert!((5.0..15.0).contains(&lean), "lean {lean}°");
}

#[test]
fn jump_flies_on_a_parabola() {
    let m = preset("jump");
    let ys: Vec<(f64, f64, f64)> = (0..500)
        .map(|i| {
            let t = i as f64 * 0.01;
            let p = m.pose(t);
            (
                t,
                p.transform_point(&anchor()).y - anchor().y,
                p.linear_velocity.y,
            )
        })
        .collect();
    let top = ys.iter().map(|y| y.1).fold(f64::MIN, f64::max);
    assert!((0.2..0.3).contains(&top), "jump apex {top} m");
    let low = ys.iter().map(|y| y.1).fold(f64::MAX, f64::min);
    assert!(low < -0.05 && low > -0.3, "crouch {low} m");
    // In flight (well above the ground) the acceleration is -g.
    for w in ys.windows(3) {
        if w.iter().all(|y| y.1 > 0.05) {
            let acc = (w[2].2 - w[0].2) / (w[2].0 - w[0].0);
            assert!((acc + 9.81).abs() < 1e-6, "flight acceleration {acc}");
        }
    }
    // Several jumps in 5 s.
    let takeoffs = ys
        .windows(2)
        .filter(|w| w[0].1 <= 0.1 && w[1].1 > 0.1)
        .count();
    assert!((3..=5).contains(&takeoffs), "{takeoffs} jumps");
}

fn write_temp(text: &str) -> tempfile::NamedTempFile {
    let mut f = tempfile::Builder::new().suffix(".ron").tempfile().unwrap();
    f.write_all(text.as_bytes()).unwrap();
    f
}

fn load(text: &str) -> Result<Motion, MotionError> {
    let f = write_temp(text);
    Motion::parse(f.path().to_str().unwrap(), anchor())
}

fn manifest_path(rel: &str) -> String {
    format!("{}/{rel}", env!("CARGO_MANIFEST_DIR"))
}

const SWAY: &str = r#"
KeyframedMotion(
    name: "sway",
    pivot: (0.0, -0.6, 0.0),
    looping: true,
    keys: [
        (time: 0.0, translation: (0, 0, 0), rotation: (0, 0, 0)),
        (time: 0.4, translation: (0.1, 0, 0.05), rotation: (10, 20, 0)),
        (time: 1.0, translation: (-0.05, 0.02, 0), rotation: (-5, -10, 8)),
        (time: 1.5, translation: (0, 0, 0), rotation: (0, 0, 0)),
    ],
)
"#;

fn expected_pose_at_key(
    anchor: Point3<f64>,
    pivot: Vector3<f64>,
    tr: [f64; 3],
    rot_deg: [f64; 3],
) -> nalgebra::Isometry3<f64> {
    let r = UnitQuaternion::from_euler_angles(
        rot_deg[0].to_radians(),
        rot_deg[1].to_radians(),
        rot_deg[2].to_radians(),
    );
    let p = anchor + pivot;
    let t = p.coords + Vector3::from(tr) - r * p.coords;
    nalgebra::Isometry3::from_parts(t.into(), r)
}

#[test]
fn keyframed_interpolates_keys_and_loops() {
    let m = load(SWAY).unwrap();
    assert_eq!(m.name(), "sway");
    assert!(m.describe().contains("sway") && m.describe().contains("looping"));
    let pivot = Vector3::new(0.0, -0.6, 0.0);
    let keys = [
        (0.4, [0.1, 0.0, 0.05], [10.0, 20.0, 0.0]),
        (1.0, [-0.05, 0.02, 0.0], [-5.0, -10.0, 8.0]),
    ];
    for (t, tr, rot) in keys {
        let want = expected_pose_at_key(anchor(), pivot, tr, rot);
        let got = m.pose(t).iso;
        for rest in [head_point(), Point3::origin()] {
            let d = (want.transform_point(&rest) - got.transform_point(&rest)).norm();
            assert!(d < 1e-12, "key at {t}: off by {d}");
            // Looping: the same pose one and three periods later.
            for k in [1.0, 3.0] {
                let again = m.pose(t + k * 1.5).iso;
                let d = (again.transform_point(&rest) - got.transform_point(&rest)).norm();
                assert!(d < 1e-9, "loop {k} at {t}: off by {d}");
            }
        }
    }
    // Starts at rest, and at the loop point it is back at the start pose, moving smoothly.
    let p0 = m.pose(0.0);
    assert!(p0.linear_velocity.norm() < 1e-12 && p0.angular_velocity.norm() < 1e-12);
    let end = m.pose(1.5);
    assert!((end.transform_point(&head_point()) - head_point()).norm() < 1e-12);
    let (before, after) = (m.pose(1.5 - 1e-7), m.pose(1.5 + 1e-7));
    let (vb, va) = (
        before.velocity_at(&before.transform_point(&head_point())),
        after.velocity_at(&after.transform_point(&head_point())),
    );
    assert!(
        (vb - va).norm() < 1e-4,
        "velocity jumps at the loop: {vb} vs {va}"
    );
    // Between keys it actually moves along a curve, not a straight hold.
    assert!(m.pose(0.7).linear_velocity.norm() > 1e-3);
    let times: Vec<f64> = (0..50).map(|i| 0.011 + i as f64 * 0.09).collect();
    check_velocities(&m, &times);
}

#[test]
fn keyframed_non_looping_holds_the_last_key() {
    let text = SWAY.replace("looping: true", "looping: false");
    let m = load(&text).unwrap();
    let last = m.pose(1.5);
    for t in [1.5, 2.0, 9.0] {
        let p = m.pose(t);
        assert_eq!(p.iso, last.iso);
        assert_eq!(p.linear_velocity, Vector3::zeros());
    }
    check_velocities(&m, &[0.2, 0.4, 0.77, 1.0, 1.3, 1.49]);
}

#[test]
fn shipped_motions_load() {
    for file in ["motions/nod.ron", "motions/look_around.ron"] {
        let m = Motion::parse(&manifest_path(file), anchor()).unwrap_or_else(|e| panic!("{e}"));
        let p0 = m.pose(0.0);
        assert!(p0.iso.rotation.angle() < 1e-12 && p0.linear_velocity.norm() < 1e-12);
        assert!(
            (0..40).any(|i| m.pose(i as f64 * 0.05).iso.rotation.angle() > 0.2),
            "{file} moves"
        );
        check_velocities(&m, &[0.1, 0.33, 0.6, 0.9, 1.7, 2.2]);
    }
    let nod = Motion::parse(&manifest_path("motions/nod.ron"), anchor()).unwrap();
    assert_eq!(nod.name(), "nod");
    assert!(forward_lean_deg(&nod.pose(0.25)) > 20.0);
}

fn err_text(text: &str) -> String {
    match load(text) {
        Ok(m) => panic!("expected an error, loaded {}", m.name()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_keyframe_files_name_the_problem() {
    // Not RON: path:line:col.
    let e = err_text("KeyframedMotion(\n    name: \"x\",\n    keys: [ (time: 0.0, ]\n)");
    assert!(e.contains(".ron:3:"), "{e}");
    // Unknown field, at its line.
    let e = err_text(&SWAY.replace("looping: true,", "looping: true,\n    speed: 2.0,"));
    assert!(e.contains("speed") && e.contains(".ron:6:"), "{e}");
    let e = err_text(&SWAY.replace("(time: 0.4,", "(time: 0.4, scale: 1.0,"));
    assert!(e.contains("scale"), "{e}");
    // Fewer than 2 keys.
    let e = err_text(
        "KeyframedMotion(keys: [(time: 0.0, translation: (0, 0, 0), rotation: (0, 0, 0))])",
    );
    assert!(e.contains("`keys`") && e.contains("at least 2"), "{e}");
    // Times not strictly increasing: names the key and its line.
    let e = err_text(&SWAY.replace("time: 1.0,", "time: 0.4,"));
    assert!(
        e.contains("keys[2].time") && e.contains("increasing"),
        "{e}"
    );
    assert!(e.contains(".ron:9:"), "{e}");
    // A looping motion that does not come back.
    let e = err_text(&SWAY.replace(
        "(time: 1.5, translation: (0, 0, 0)",
        "(time: 1.5, translation: (0, 0.3, 0)",
    ));
    assert!(
        e.contains("keys[3].translation") && e.contains("looping"),
        "{e}"
    );
    // Missing file.
    let err = Motion::parse("/no/such/dir/motion.ron", anchor()).unwrap_err();
    assert!(matches!(err, MotionError::Io { .. }));
    assert!(err.to_string().contains("/no/such/dir/motion.ron"), "{err}");
}

#[test]
fn unknown_presets_list_the_presets() {
    let e = Motion::parse("dance", anchor()).unwrap_err().to_string();
    assert!(e.contains("dance"), "{e}");
    for name in Motion::preset_names() {
        assert!(e.contains(name), "{e} does not list {name}");
    }
}

#[test]
fn presets_follow_the_anchor() {
    // The same preset at another head height moves the head the same way relative to it.
    let low = Point3::new(0.1, 1.2, -0.2);
    for name in Motion::preset_names() {
        let (a, b) = (preset(name), Motion::parse(name, low).unwrap());
        for t in [0.6, 1.3, 2.9] {
            let da = a.pose(t).transform_point(&anchor()) - anchor();
            let db = b.pose(t).transform_point(&low) - low;
            assert!((da - db).norm() < 1e-9, "{name} at {t}: {da} vs {db}");
        }
    }
}

#[test]
fn describe_is_one_line() {
    for name in Motion::preset_names() {
        let d = preset(name).describe();
        assert!(d.starts_with(name) && !d.contains('\n'), "{d}");
    }
}
