//! What a new user ran into with real hair data (issue 28, section 4), each as a test of the real
//! binary: an export that would fill the disk, `run --save` to a path that cannot be written, a
//! load warning about nodes inside the body that must say what really happens, a scalp far from
//! imported hair (and README's own `salon` example), and near-zero-length strands.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use nalgebra::{Point3, Vector3};

const BIN: &str = env!("CARGO_BIN_EXE_wisptree");

fn wisptree_in(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn assert_no_panic(err: &str) {
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn export_refuses_absurd_durations_and_what_the_disk_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (code, _, err) = wisptree_in(d, &["export", "--seconds", "1e12", "--out", "o"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("1e6"), "{err}");
    // 10⁶ s of Short is 25 million frames of 2.6 MB: refused before a frame is simulated.
    for (format, out) in [
        ("hair", "frames"),
        ("tfx", "frames"),
        ("usd", "frames/s.usda"),
    ] {
        let t0 = Instant::now();
        let (code, _, err) = wisptree_in(
            d,
            &[
                "export",
                "--style",
                "short",
                "--seconds",
                "1e6",
                "--format",
                format,
                "--out",
                out,
            ],
        );
        assert_eq!(code, 2, "{format}: {err}");
        assert_no_panic(&err);
        let line = err
            .lines()
            .find(|l| l.starts_with("wisptree: "))
            .unwrap_or_else(|| panic!("{format}: no error line: {err}"));
        assert!(
            line.contains(out) && line.contains("free") && line.contains("25000000 frames"),
            "{format}: {line}"
        );
        assert!(
            !d.join("frames").exists(),
            "{format}: something was written"
        );
        // A guard against writing until the disk is full, not a timing.
        assert!(t0.elapsed() < Duration::from_secs(60));
    }
}

#[test]
fn run_save_to_a_path_that_cannot_be_written_exits_2_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("file"), b"x").unwrap();
    let folder = d.to_string_lossy().into_owned();
    let under_file = d.join("file/x.rrd").to_string_lossy().into_owned();
    for path in [folder.as_str(), under_file.as_str(), "/proc/x.rrd"] {
        let (code, _, err) = wisptree_in(
            d,
            &[
                "run",
                "--style",
                "short",
                "--seconds",
                "0.1",
                "--save",
                path,
            ],
        );
        assert_eq!(code, 2, "{path}: {err}");
        let lines: Vec<&str> = err.trim().lines().collect();
        assert_eq!(lines.len(), 1, "{path}: one line: {err}");
        assert!(lines[0].contains(path), "{path}: {err}");
        assert!(lines[0].contains("cannot write"), "{err}");
    }
    assert_eq!(std::fs::read(d.join("file")).unwrap(), b"x");
}

/// The Short style's text with its body replaced by one sphere of radius `r` about the head.
fn short_with_body(dir: &Path, r: f64) -> String {
    let s = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/short.ron"))
        .unwrap();
    let text = s.replacen(
        "seed: 1,",
        &format!("seed: 1,\n    head: (body: [(center: (0.0, 1.6, 0.0), radius: {r})]),"),
        1,
    );
    let p = dir.join("body.ron");
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// The number after `before` in `line` (`… 12 of them …` with `before` = "").
fn number_before(line: &str, after: &str) -> f64 {
    let at = line
        .find(after)
        .unwrap_or_else(|| panic!("`{after}` in {line}"));
    let word = line[..at].split_whitespace().last().unwrap();
    word.parse()
        .unwrap_or_else(|_| panic!("a number before `{after}`: {line}"))
}

#[test]
fn the_rest_node_warning_says_what_the_solvers_do() {
    let dir = tempfile::tempdir().unwrap();
    // A sphere a little larger than the scalp: every root and the upper nodes are inside.
    let style = short_with_body(dir.path(), 0.12);
    let (code, _, err) = wisptree_in(dir.path(), &["inspect", &style]);
    assert_eq!(code, 0, "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("rest nodes (all levels) are inside body sphere 0"))
        .unwrap_or_else(|| panic!("no rest-node warning: {err}"));
    let roots = number_before(line, "of them are wisp roots") as usize;
    let others = number_before(line, "out (the AWT at its first step");
    assert!(roots > 0 && others > 0.0, "{line}");
    assert!(line.contains("stay inside"), "{line}");
    let root_depth_mm = {
        let at = line.find("which stay inside, by up to").unwrap();
        number_before(&line[at..], "mm, for the whole run")
    };

    // What the solvers do, measured: only wisp roots stay inside, the deepest as deep as said;
    // every other active node is out after the AWT's first frame, the layered model's fifth.
    for (kind, from) in [
        (wisptree::solver::SolverKind::Awt, 0),
        (wisptree::solver::SolverKind::Layered, 5),
    ] {
        let scene = wisptree::scene::Scene::load(&style, "lean", kind).unwrap();
        let m = scene.model.clone();
        let mut solver = scene.solver();
        let mut report = solver.new_report();
        let mut builder = wisptree::pipeline::FrameBuilder::new(&m, 1, 1);
        let mut frame = wisptree::frame::Frame::default();
        let mut deepest_root = 0.0f64;
        for f in 0..25 {
            for _ in 0..solver.steps_per_frame() {
                solver.step(&mut report);
            }
            builder.fill(&mut *solver, &mut frame);
            let pose = *solver.pose();
            let c = pose.transform_point(&Point3::from(m.body[0].center)).coords;
            let wisp_roots: Vec<Vector3<f64>> = m
                .levels
                .iter()
                .flat_map(|l| l.rest_pos.iter().step_by(m.k))
                .map(|p| pose.transform_point(&Point3::from(*p)).coords)
                .collect();
            for p in &frame.nodes.positions {
                let p = Vector3::new(p[0], p[1], p[2]).cast::<f64>();
                let depth = m.body[0].radius - (p - c).norm();
                if depth <= 1e-4 {
                    continue;
                }
                let is_root = wisp_roots.iter().any(|r| (r - p).norm() < 1e-4);
                if is_root {
                    deepest_root = deepest_root.max(depth);
                } else {
                    assert!(
                        f < from,
                        "{kind} frame {f}: a node that is no wisp root is {:.1} mm inside",
                        depth * 1e3
                    );
                }
            }
        }
        // The level-0 roots are always active; the deepest root of all may be finer.
        assert!(deepest_root > 0.0, "{kind}: roots stay inside");
        assert!(
            deepest_root * 1e3 <= root_depth_mm + 0.05,
            "{kind}: {deepest_root} m vs {root_depth_mm} mm"
        );
    }
}

/// A USC-HairSalon `.data` file: `n` strands of 10 points hanging from roots on a sphere of
/// radius 0.1 m about (0, 0.1, 0), as the database's heads sit near the origin.
fn salon_data(path: &Path, short_strands: usize) {
    let n = 60;
    let mut b = Vec::new();
    b.extend_from_slice(&(n as i32).to_le_bytes());
    for s in 0..n {
        let az = (s as f64 * 137.5).to_radians();
        let el = (15.0 + 60.0 * ((s * 7) % 13) as f64 / 12.0).to_radians();
        let root = [
            0.1 * el.cos() * az.sin(),
            0.1 + 0.1 * el.sin(),
            0.1 * el.cos() * az.cos(),
        ];
        // The first `short_strands` strands are 7.5 µm long stubs.
        let step = if s < short_strands {
            7.5e-6 / 9.0
        } else {
            0.03
        };
        b.extend_from_slice(&10i32.to_le_bytes());
        for v in 0..10 {
            let p = [root[0], root[1] - step * v as f64, root[2]];
            for c in p {
                b.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
    }
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, b).unwrap();
}

#[test]
fn fit_body_puts_the_scalp_on_the_fitted_head_and_a_far_scalp_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    salon_data(&d.join("hairstyles/strands00001.data"), 0);
    // README's own `salon` example, as written there.
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let at = readme
        .find("name: \"salon\"")
        .expect("README has the salon example");
    let start = readme[..at].rfind("```ron").unwrap() + "```ron".len();
    let end = at + readme[at..].find("```").unwrap();
    std::fs::write(d.join("salon.ron"), &readme[start..end]).unwrap();
    let (code, _, err) = wisptree_in(d, &["inspect", "salon.ron"]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("from the scalp"), "{err}");
    let scene = wisptree::scene::Scene::load(
        &d.join("salon.ron").to_string_lossy(),
        "lean",
        wisptree::solver::SolverKind::Awt,
    )
    .unwrap();
    let c = scene.model.scalp_center;
    assert!(
        (c - Vector3::new(0.0, 0.1, 0.0)).norm() < 0.01,
        "the scalp sits on the fitted head, not at the default (0, 1.6, 0): {c:?}"
    );
    // The motion turns about the hair's own head: under `lean` the roots stay within the
    // lean's sweep of the head (a third of a metre), not 1.5 m away.
    let camera = scene.camera_target();
    assert!(camera[1] < 0.5, "the render frames the hair: {camera:?}");

    // With the default scalp, 1.5 m above the hair, a warning says so and what to do.
    let far = "Style(head: (scalp: (center: (0, 1.6, 0), radii: (0.08, 0.1, 0.09))), \
               hair: HairSalon((file: \"hairstyles/strands00001.data\")), \
               hierarchy: (levels: 2, cross_sections: 6, branching: [2], top_level: 8))";
    std::fs::write(d.join("far.ron"), far).unwrap();
    let (code, _, err) = wisptree_in(d, &["inspect", "far.ron"]);
    assert_eq!(code, 0, "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("from the scalp"))
        .unwrap_or_else(|| panic!("no warning about the far scalp: {err}"));
    assert!(
        line.contains("head.scalp") && line.contains("fit_body"),
        "{line}"
    );
    let metres = number_before(line, "m from the scalp");
    assert!((1.3..1.6).contains(&metres), "{line}");
}

#[test]
fn near_zero_length_strands_are_counted_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    salon_data(&d.join("h.data"), 3);
    std::fs::write(
        d.join("stubs.ron"),
        "Style(head: (fit_body: true), hair: HairSalon((file: \"h.data\")), \
         hierarchy: (levels: 2, cross_sections: 6, branching: [2], top_level: 8))",
    )
    .unwrap();
    for args in [
        &["inspect", "stubs.ron"][..],
        &[
            "export",
            "--style",
            "stubs.ron",
            "--seconds",
            "0.04",
            "--out",
            "x",
        ],
    ] {
        let (code, _, err) = wisptree_in(d, args);
        assert_eq!(code, 0, "{args:?}: {err}");
        let line = err
            .lines()
            .find(|l| l.contains("shorter than 1 mm"))
            .unwrap_or_else(|| panic!("{args:?}: no note about short strands: {err}"));
        assert!(line.contains("3 of 60 strands"), "{line}");
        assert!(line.contains("7.5 µm"), "{line}");
    }
}
