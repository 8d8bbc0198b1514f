//! The real head (issue 28 §1): `../shared/data/heads/usc_head.obj` (Digital Salon, open at the
//! neck) with a generated `.data` hairstyle grown on its crown loads, warns once that the mesh
//! is open, and keeps the hair out of the head in all three solvers; `push_roots_out` moves
//! roots planted under the skin onto it.

#[path = "common/shared.rs"]
mod shared;

use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3};
use wisptree::frame::Frame;
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

fn head() -> PathBuf {
    shared::shared_path("data/heads/usc_head.obj")
}

/// The head's vertices (the `v` lines), m.
fn vertices(obj: &Path) -> Vec<Vector3<f64>> {
    std::fs::read_to_string(obj)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|w| w.parse().unwrap()).collect();
            Vector3::new(c[0], c[1], c[2])
        })
        .collect()
}

/// Writes `dir/h.data`: a strand of 10 cm sticking straight out of every 40th crown vertex,
/// starting `lift` m outside it (negative: under the skin), and `dir/s.ron` with the head as
/// its body (`extra` goes into `head:`). Gravity lays the strands onto the head.
fn write_style(dir: &Path, lift: f64, extra: &str, with_head: bool) -> PathBuf {
    let name = format!("s{}{}.ron", with_head as u8, extra.len());
    let v = vertices(&head());
    let centre = v.iter().sum::<Vector3<f64>>() / v.len() as f64;
    let top = v.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    let mut strands: Vec<Vec<[f32; 3]>> = Vec::new();
    for p in v.iter().filter(|p| p.y > top - 0.05).step_by(40) {
        let out = (p - centre).normalize();
        strands.push(
            (0..10)
                .map(|i| {
                    let q = p + out * (lift + 0.011 * i as f64);
                    [q.x as f32, q.y as f32, q.z as f32]
                })
                .collect(),
        );
    }
    assert!(strands.len() > 20, "{} strands", strands.len());
    std::fs::write(
        dir.join("h.data"),
        wisptree::style::hairsalon::encode_hairsalon(&strands).unwrap(),
    )
    .unwrap();
    let body = if with_head {
        format!("Mesh(file: {:?})", head().to_str().unwrap())
    } else {
        String::new()
    };
    let style = format!(
        "Style(head: (scalp: (center: ({}, {}, {}), radii: (0.08, 0.1, 0.09)), body: [{body}]{extra}), \
         hair: HairSalon((file: \"h.data\")), \
         hierarchy: (levels: 2, cross_sections: 10, branching: [4]), sim: (settle: 0.0), \
         guides: (stiffness: 1.0))",
        centre.x, centre.y, centre.z
    );
    let p = dir.join(name);
    std::fs::write(&p, style).unwrap();
    p
}

/// The deepest node centre inside the head after `seconds` of `still`, m (negative: all
/// outside, by that much at the nearest).
fn deepest(style: &Path, kind: SolverKind, seconds: f64) -> f64 {
    // The head loaded as the solvers see it, to measure against.
    let dir = tempfile::tempdir().unwrap();
    let with = Scene::load(
        write_style(dir.path(), 0.001, "", true).to_str().unwrap(),
        "still",
        kind,
    )
    .unwrap();
    // Measured against the exact surface (the triangle tree), whatever query the solvers use.
    let collider: Vec<_> = with
        .model
        .colliders
        .iter()
        .map(|c| c.with_mesh_query(wisptree::model::body::MeshQuery::Tree))
        .collect();
    let scene =
        Scene::load(style.to_str().unwrap(), "still", kind).unwrap_or_else(|e| panic!("{e:#}"));
    let mut s = scene.solver();
    let mut r = s.new_report();
    for _ in 0..(seconds / s.dt()).round() as usize {
        s.step(&mut r);
    }
    s.sync_display();
    let mut f = Frame::default();
    s.draw(&mut f);
    let pose = *s.pose();
    let mut worst = f64::NEG_INFINITY;
    for p in &f.nodes.positions {
        let w = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let x = pose.iso.inverse_transform_point(&Point3::from(w)).coords;
        if let Some(q) = wisptree::model::body::nearest(&collider, &x, 0.05) {
            worst = worst.max(-q.distance);
        }
    }
    worst
}

#[test]
fn the_real_head_loads_warns_once_and_keeps_the_hair_out() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), 0.001, "", true);
    let scene = Scene::load(style.to_str().unwrap(), "still", SolverKind::Awt)
        .unwrap_or_else(|e| panic!("{e:#}"));
    let w = scene.warnings();
    let open: Vec<_> = w.iter().filter(|l| l.contains("is open")).collect();
    assert_eq!(open.len(), 1, "{w:?}");
    assert!(open[0].contains("110 boundary edges"), "{w:?}");
    assert!(
        !w.iter().any(|l| l.contains("strand roots are inside")),
        "roots 1 mm out are outside: {w:?}"
    );
    for kind in [SolverKind::Awt, SolverKind::Layered, SolverKind::Guides] {
        let free = deepest(&write_style(dir.path(), 0.001, "", false), kind, 1.0);
        let held = deepest(&write_style(dir.path(), 0.001, "", true), kind, 1.0);
        eprintln!(
            "{kind}: deepest inside the head {:.2} mm (without the head as body: {:.1} mm)",
            held * 1e3,
            free * 1e3
        );
        assert!(
            free > 0.01,
            "{kind}: without the body the hair should sink into the head"
        );
        assert!(
            held < 1e-3,
            "{kind}: a node {:.2} mm inside the head",
            held * 1e3
        );
        assert!(
            held > -0.005,
            "{kind}: the hair should rest on the head ({:.1} mm off)",
            -held * 1e3
        );
    }
}

#[test]
fn push_roots_out_moves_roots_under_the_skin_onto_it() {
    let dir = tempfile::tempdir().unwrap();
    let style = write_style(dir.path(), -0.003, "", true);
    let scene = Scene::load(style.to_str().unwrap(), "still", SolverKind::Awt).unwrap();
    let w = scene.warnings();
    assert!(
        w.iter()
            .any(|l| l.contains("strand roots are inside a capsule or mesh")),
        "roots 3 mm under the skin are reported: {w:?}"
    );
    let n = scene.model.strands.len();
    let style = write_style(dir.path(), -0.003, ", push_roots_out: true", true);
    let scene = Scene::load(style.to_str().unwrap(), "still", SolverKind::Awt).unwrap();
    let note = scene
        .model
        .notes
        .iter()
        .find(|l| l.contains("push_roots_out"))
        .expect("a note");
    assert!(note.contains(&format!("moved {n} of {n}")), "{note}");
    let w = scene.warnings();
    assert!(
        !w.iter().any(|l| l.contains("strand roots are inside")),
        "no root left inside: {w:?}"
    );
}
