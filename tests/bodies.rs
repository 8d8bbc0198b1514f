//! Bodies other than spheres (issue 28 §1): every form of `head.body` parses; a strand dropped
//! onto a capsule and onto a mesh sphere rests outside it in all three solvers; OBJ errors
//! name the file and the line and exit 2; an open mesh loads with a warning; the distance field
//! a mesh is queried with agrees with its triangle tree near the skin.

use std::path::Path;
use std::process::Command;

use nalgebra::{Point3, Vector3};
use wisptree::frame::Frame;
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;
use wisptree::style::{BodyItem, Up};

const BIN: &str = env!("CARGO_BIN_EXE_wisptree");

/// How far a node centre may be inside the body at rest, m.
const TOLERANCE_M: f64 = 1e-3;

#[test]
fn every_body_form_parses_and_keeps_its_kind() {
    let text = r#"Style(head: (body: [
        (center: (0, 1.6, 0), radius: 0.07),
        Sphere(center: (0, 1.4, 0), radius: 0.05),
        Capsule(a: (0.1, 1.3, 0), b: (0.3, 1.3, 0), radius: 0.04),
        Mesh(file: "a.obj", scale: 2.0, translate: (0, 1, 0), up: Y),
        Mesh(file: "/abs/b.obj", up: Z),
    ]), hair: Explicit((wisps: [])))"#;
    let style: wisptree::style::Style = ron::from_str(text).unwrap_or_else(|e| panic!("{e}"));
    let b = &style.head.body;
    assert_eq!(b.len(), 5);
    assert!(matches!(&b[0], BodyItem::Sphere(s) if s.radius == 0.07));
    assert!(matches!(&b[1], BodyItem::Sphere(s) if s.center == [0.0, 1.4, 0.0]));
    assert!(matches!(&b[2], BodyItem::Capsule(c) if c.b == [0.3, 1.3, 0.0] && c.radius == 0.04));
    assert!(
        matches!(&b[3], BodyItem::Mesh(m) if m.file == "a.obj" && m.scale == 2.0
            && m.translate == [0.0, 1.0, 0.0] && m.up == Up::Y)
    );
    assert!(
        matches!(&b[4], BodyItem::Mesh(m) if m.file == "/abs/b.obj" && m.scale == 1.0 && m.up == Up::Z)
    );
    assert_eq!(style.head.spheres().len(), 2);
    // A field of another kind is refused, naming it.
    let bad = r#"Style(head: (body: [Capsule(a: (0,0,0), b: (1,0,0), radius: 0.1, up: Y)]),
        hair: Explicit((wisps: [])))"#;
    let e = ron::from_str::<wisptree::style::Style>(bad)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`up`"), "{e}");
}

/// An icosphere of radius `r` (subdivided twice, 320 triangles) as OBJ text, and its
/// inradius (the nearest its surface comes to the centre).
fn icosphere_obj(r: f64) -> (String, f64) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<Vector3<f64>> = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ]
    .iter()
    .map(|&(x, y, z)| Vector3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..2 {
        let mut mid = std::collections::HashMap::new();
        let mut nf = Vec::new();
        for tri in &f {
            let mut m = [0; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    v.push(((v[a] + v[b]) / 2.0).normalize());
                    v.len() - 1
                });
            }
            nf.push([tri[0], m[0], m[2]]);
            nf.push([tri[1], m[1], m[0]]);
            nf.push([tri[2], m[2], m[1]]);
            nf.push(m);
        }
        f = nf;
    }
    // The distance from the centre to the nearest face plane: the mesh's surface is at least
    // that far out.
    let inradius = f
        .iter()
        .map(|t| {
            let (a, b, c) = (v[t[0]] * r, v[t[1]] * r, v[t[2]] * r);
            (b - a).cross(&(c - a)).normalize().dot(&a).abs()
        })
        .fold(f64::INFINITY, f64::min);
    let mut s = String::from("# icosphere\n");
    for p in &v {
        s += &format!("v {} {} {}\n", p.x * r, p.y * r, p.z * r);
    }
    for t in &f {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    (s, inradius)
}

/// A bundle of 7 straight strands, 24 cm, rooted 5 cm above the body's top at x = 0 and lying
/// along +x: under gravity they hang through the body unless it stops them (the guides' joint
/// actuators are made weak, or they would hold the strands level).
fn draped_style(body: &str) -> String {
    let mut strands = String::new();
    for k in 0..7 {
        let z = (k as f64 - 3.0) * 0.004;
        let pts: Vec<String> = (0..=12)
            .map(|i| format!("({}, 1.08, {z})", 0.02 * i as f64))
            .collect();
        strands += &format!("[{}],", pts.join(", "));
    }
    format!(
        "Style(name: \"drop\", head: (body: [{body}]), \
         hair: Explicit((wisps: [(name: \"w\", strands: [{strands}])])), \
         hierarchy: (levels: 1, cross_sections: 13, branching: []), sim: (settle: 0.0), \
         guides: (stiffness: 1.0))"
    )
}

/// The most negative signed distance `sd` of the logged node centres (not the roots) after
/// `seconds`, and the nearest any came to the surface from outside.
fn rest_depth(
    path: &Path,
    kind: SolverKind,
    seconds: f64,
    sd: impl Fn(&Vector3<f64>) -> f64,
) -> (f64, f64) {
    let scene =
        Scene::load(path.to_str().unwrap(), "still", kind).unwrap_or_else(|e| panic!("{e:#}"));
    let mut s = scene.solver();
    let mut r = s.new_report();
    for _ in 0..(seconds / s.dt()).round() as usize {
        s.step(&mut r);
    }
    s.sync_display();
    let mut f = Frame::default();
    s.draw(&mut f);
    let pose = *s.pose();
    let mut deepest = f64::INFINITY;
    let mut nearest = f64::INFINITY;
    for p in &f.nodes.positions {
        let w = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        // Rest frame (the motion is `still`, but stay honest).
        let x = pose.iso.inverse_transform_point(&Point3::from(w)).coords;
        let d = sd(&x);
        deepest = deepest.min(d);
        nearest = nearest.min(d.abs());
    }
    (deepest, nearest)
}

fn check_rests_outside(
    name: &str,
    body: &str,
    files: &[(&str, &str)],
    sd: impl Fn(&Vector3<f64>) -> f64 + Copy,
) {
    let dir = tempfile::tempdir().unwrap();
    for (n, text) in files {
        std::fs::write(dir.path().join(n), text).unwrap();
    }
    let with = dir.path().join("with.ron");
    std::fs::write(&with, draped_style(body)).unwrap();
    let without = dir.path().join("without.ron");
    std::fs::write(&without, draped_style("")).unwrap();
    for kind in [SolverKind::Awt, SolverKind::Layered, SolverKind::Guides] {
        let (free, _) = rest_depth(&without, kind, 1.5, sd);
        assert!(
            free < -0.02,
            "{kind} {name}: without the body the strand should fall through it (deepest {:.1} mm)",
            free * 1e3
        );
        let (deepest, nearest) = rest_depth(&with, kind, 1.5, sd);
        eprintln!(
            "{kind} {name}: deepest {:.2} mm, nearest {:.2} mm (free fall {:.1} mm)",
            deepest * 1e3,
            nearest * 1e3,
            free * 1e3
        );
        assert!(
            deepest > -TOLERANCE_M,
            "{kind} {name}: a node rests {:.2} mm inside",
            -deepest * 1e3
        );
        assert!(
            nearest < 0.01,
            "{kind} {name}: the strand does not rest on the body (nearest {:.1} mm)",
            nearest * 1e3
        );
    }
}

#[test]
fn a_strand_dropped_onto_a_capsule_rests_outside_it() {
    let (a, b, r) = (
        Vector3::new(0.0, 0.98, -0.1),
        Vector3::new(0.0, 0.98, 0.1),
        0.05,
    );
    let sd = move |x: &Vector3<f64>| {
        let ab = b - a;
        let t = ((x - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
        (x - (a + ab * t)).norm() - r
    };
    check_rests_outside(
        "capsule",
        "Capsule(a: (0, 0.98, -0.1), b: (0, 0.98, 0.1), radius: 0.05)",
        &[],
        sd,
    );
}

#[test]
fn a_strand_dropped_onto_a_mesh_sphere_rests_outside_it() {
    let (obj, inradius) = icosphere_obj(0.05);
    let c = Vector3::new(0.0, 0.98, 0.0);
    // Outside the mesh implies at least the inradius from the centre.
    let sd = move |x: &Vector3<f64>| (x - c).norm() - inradius;
    check_rests_outside(
        "mesh sphere",
        "Mesh(file: \"ico.obj\", translate: (0, 0.98, 0))",
        &[("ico.obj", &obj)],
        sd,
    );
}

fn wisptree(args: &[&str]) -> (i32, String) {
    let out = Command::new(BIN).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr),
    )
}

fn style_with_mesh(dir: &Path, obj: &str) -> String {
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    let p = dir.join("s.ron");
    std::fs::write(&p, draped_style("Mesh(file: \"m.obj\")")).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn obj_errors_name_the_file_and_line_and_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "v 0 0 0\nv 1 0 0\nv 0 zz 1\nf 1 2 3\n",
            3,
            "bad vertex line",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 9\n", 5, "out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\n", 3, "no faces"),
    ];
    for (obj, line, what) in cases {
        let style = style_with_mesh(dir.path(), obj);
        let (code, out) = wisptree(&["inspect", &style]);
        assert_eq!(code, 2, "{out}");
        assert!(
            out.contains(&format!("m.obj:{line}:")),
            "names file and line {line}: {out}"
        );
        assert!(out.contains(what), "says {what}: {out}");
        assert!(!out.contains("panicked"), "{out}");
    }
}

#[test]
fn an_open_mesh_loads_with_a_one_line_warning() {
    let dir = tempfile::tempdir().unwrap();
    // A square of two triangles, far below the hair: open, 4 boundary edges; a quad face is
    // triangulated.
    let obj = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 4 3 2\n";
    let style = style_with_mesh(dir.path(), obj);
    let (code, out) = wisptree(&["inspect", &style]);
    assert_eq!(code, 0, "{out}");
    let warn: Vec<&str> = out.lines().filter(|l| l.contains("open")).collect();
    assert_eq!(warn.len(), 1, "one line about the open mesh: {out}");
    assert!(
        warn[0].contains("4 boundary edges") && warn[0].contains("m.obj"),
        "{out}"
    );
}

#[test]
fn the_distance_field_agrees_with_the_tree_near_the_skin() {
    use wisptree::model::body::{nearest, Collider, MeshQuery};
    let dir = tempfile::tempdir().unwrap();
    let (obj, _) = icosphere_obj(0.05);
    let path = dir.path().join("ico.obj");
    std::fs::write(&path, obj).unwrap();
    let m = wisptree::style::body::MeshRef {
        file: "ico.obj".into(),
        scale: 1.0,
        translate: [0.0; 3],
        up: Up::Y,
    };
    let mesh = std::sync::Arc::new(wisptree::style::obj::load_obj(&path, &m).unwrap());
    let shape = wisptree::style::body::Shape::Mesh(mesh, path);
    let tree = [Collider::new(&shape).with_mesh_query(MeshQuery::Tree)];
    let field = [Collider::new(&shape).with_mesh_query(MeshQuery::Sdf)];
    // Points from 8 mm inside to 8 mm outside the surface, in every direction.
    let mut state = 7u64;
    let mut next = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let (mut checked, mut worst) = (0, 0.0f64);
    for _ in 0..2000 {
        let dir = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
        let x = dir * (0.05 + (next() - 0.5) * 0.016);
        let (Some(a), Some(b)) = (nearest(&tree, &x, 0.01), nearest(&field, &x, 0.01)) else {
            panic!("no answer at {x:?} (within 1 cm of the skin)");
        };
        worst = worst.max((a.distance - b.distance).abs());
        if a.distance.abs() > 2e-4 {
            assert_eq!(a.distance < 0.0, b.distance < 0.0, "side of {x:?}");
        }
        assert!(
            a.normal.dot(&b.normal) > 0.95,
            "normals at {x:?}: tree {:?}, field {:?}",
            a.normal,
            b.normal
        );
        checked += 1;
    }
    // The exact distance of a coarse mesh (320 faces) kinks at its edges, which the 2 mm
    // samples smooth: a fraction of a millimetre, within the 1 mm a node may rest inside.
    assert!(
        worst < 2.5e-4,
        "distances differ by up to {:.3} mm",
        worst * 1e3
    );
    // Far out, neither answers within a small reach.
    let far = Vector3::new(0.0, 0.09, 0.0);
    assert!(nearest(&tree, &far, 0.001).is_none() && nearest(&field, &far, 0.001).is_none());
    assert_eq!(checked, 2000);
}
