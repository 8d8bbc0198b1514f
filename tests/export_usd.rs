//! `wisptree export --format usd`, read back with Pixar's own USD library (`usd-core` from
//! PyPI, `from pxr import Usd, UsdGeom`; `.ci/usd-core` installs it): the stage opens with the
//! units, axis and time range said; every strand is a curve with its points at every exported
//! frame, equal to what `--format hair` writes for that frame; the body follows the motion; the
//! structure is the frame's. Bad outputs and a disk that fills exit 2 naming the path and leave
//! no file under the final name.

use std::path::{Path, PathBuf};
use std::process::Command;

use wisptree::style::hair_file::{encode_hair, parse_hair};

const STRANDS: usize = 30;
const K: usize = 6;
const BIN: &str = env!("CARGO_BIN_EXE_wisptree");

fn wisptree(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(BIN)
        .args(args)
        .output()
        .expect("the binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The python of the usd-core environment `.ci/usd-core` makes; a failure (not a skip) that
/// says how to install it when it is not there.
fn usd_python() -> PathBuf {
    let venv = std::env::var_os("WISPTREE_USD_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var_os("HOME").expect("HOME is set"))
                .join(".cache/wisptree-usd-core-26.11")
        });
    let py = venv.join("bin/python");
    let ok = Command::new(&py)
        .args(["-c", "from pxr import Usd, UsdGeom"])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "Pixar's USD reader (usd-core) is not installed at {}: run `bash .ci/usd-core` in the \
         repository (python3 -m venv {} && {}/bin/pip install usd-core==26.11), as .ci/run does",
        venv.display(),
        venv.display(),
        venv.display()
    );
    py
}

/// Runs `script` (which reads `sys.argv[1]`) on `layer` with pxr; its stdout as JSON.
fn pxr(script: &str, layer: &Path) -> serde_json::Value {
    let out = Command::new(usd_python())
        .args(["-c", script])
        .arg(layer)
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "pxr failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("the script prints JSON")
}

/// A small imported style (30 hanging strands of 10 points, K = 6, short settling) in `dir`.
fn small_style(dir: &Path) -> String {
    let strands: Vec<Vec<[f32; 3]>> = (0..STRANDS)
        .map(|s| {
            let az = (s as f64 * 137.5).to_radians();
            let el = (20.0 + 50.0 * ((s * 7) % 11) as f64 / 10.0).to_radians();
            let d = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
            let r = [0.1 * d[0], 1.6 + 0.1 * d[1], 0.1 * d[2]].map(|c| c as f32);
            (0..10)
                .map(|v| [r[0], r[1] - 0.03 * v as f32, r[2]])
                .collect()
        })
        .collect();
    std::fs::write(dir.join("small.hair"), encode_hair(&strands, "").unwrap()).unwrap();
    let style = dir.join("small.ron");
    std::fs::write(
        &style,
        format!(
            "Style(hair: Hair((file: \"small.hair\")), \
             hierarchy: (levels: 2, cross_sections: {K}, branching: [2], top_level: 4), \
             sim: (settle: 0.2))"
        ),
    )
    .unwrap();
    style.to_string_lossy().into_owned()
}

const READ_STAGE: &str = r#"
import json, sys
from pxr import Usd, UsdGeom
st = Usd.Stage.Open(sys.argv[1])
curves = UsdGeom.BasisCurves(st.GetPrimAtPath("/wisptree/hair"))
pts = curves.GetPointsAttr()
times = pts.GetTimeSamples()
body = {}
for prim in st.GetPrimAtPath("/wisptree/body").GetChildren():
    x = UsdGeom.Xformable(prim)
    body[prim.GetName()] = [list(x.ComputeLocalToWorldTransform(t).ExtractTranslation()) for t in times]
nodes = UsdGeom.Points(st.GetPrimAtPath("/wisptree/structure/nodes"))
segs = UsdGeom.BasisCurves(st.GetPrimAtPath("/wisptree/structure/segments"))
print(json.dumps({
    "up": UsdGeom.GetStageUpAxis(st),
    "meters_per_unit": UsdGeom.GetStageMetersPerUnit(st),
    "tcps": st.GetTimeCodesPerSecond(),
    "start": st.GetStartTimeCode(),
    "end": st.GetEndTimeCode(),
    "type": curves.GetTypeAttr().Get(),
    "counts": list(curves.GetCurveVertexCountsAttr().Get()),
    "widths": list(curves.GetWidthsAttr().Get()),
    "times": list(times),
    "points": {str(int(t)): [list(p) for p in pts.Get(t)] for t in times},
    "extent_times": list(curves.GetExtentAttr().GetTimeSamples()),
    "body": body,
    "nodes": [len(nodes.GetPointsAttr().Get(t)) for t in times],
    "node_widths": [len(nodes.GetWidthsAttr().Get(t)) for t in times],
    "segments": [len(segs.GetCurveVertexCountsAttr().Get(t)) for t in times],
    "segment_points": [len(segs.GetPointsAttr().Get(t)) for t in times],
}))
"#;

#[test]
fn the_usd_layer_reads_in_pixars_library_with_the_hair_exports_points() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    let layer = dir.path().join("out/hair.usda");
    let layer_s = layer.to_string_lossy().into_owned();
    let hair = dir.path().join("hair");
    let hair_s = hair.to_string_lossy().into_owned();
    let common = [
        "export",
        "--style",
        &style,
        "--motion",
        "lean",
        "--seconds",
        "0.28",
        "--every",
        "3",
        "--no-progress",
    ];
    let (code, stdout, err) = wisptree(
        &[
            &common[..],
            &["--format", "usd", "--out", &layer_s, "--debug-structure"],
        ]
        .concat(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("wrote 3 frames"), "{stdout}");
    let (code, _, err) = wisptree(&[&common[..], &["--format", "hair", "--out", &hair_s]].concat());
    assert_eq!(code, 0, "{err}");
    // Only the layer is left in its folder: the temporary file was renamed.
    let names: Vec<_> = std::fs::read_dir(layer.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["hair.usda"]);

    let v = pxr(READ_STAGE, &layer);
    assert_eq!(v["up"], "Y");
    assert_eq!(v["meters_per_unit"], 1.0);
    assert_eq!(v["tcps"], 25.0, "0.01 s steps, 4 per frame");
    // 0.28 s is 7 frames, every third written: time codes 0, 3 and 6 (frame numbers).
    assert_eq!(v["start"], 0.0);
    assert_eq!(v["end"], 6.0);
    assert_eq!(v["times"], serde_json::json!([0.0, 3.0, 6.0]));
    assert_eq!(v["extent_times"], v["times"]);
    assert_eq!(v["type"], "linear");
    let points = 2 * (K - 1) + 1;
    assert_eq!(v["counts"], serde_json::json!(vec![points; STRANDS]));
    assert_eq!(v["widths"].as_array().unwrap().len(), 1);

    // At every time, the points are the .hair export's for that frame, to 1e-6 m.
    for t in [0, 3, 6] {
        let name = format!("frame_{t:05}.hair");
        let h = parse_hair(Path::new(&name), &std::fs::read(hair.join(&name)).unwrap()).unwrap();
        let expect: Vec<[f32; 3]> = h.strands.concat();
        let got = v["points"][t.to_string()].as_array().unwrap();
        assert_eq!(got.len(), STRANDS * points, "time {t}");
        let worst = expect
            .iter()
            .zip(got)
            .flat_map(|(e, g)| {
                (0..3).map(move |a| (f64::from(e[a]) - g[a].as_f64().unwrap()).abs())
            })
            .fold(0.0f64, f64::max);
        assert!(worst <= 1e-6, "time {t}: points differ by {worst} m");
    }
    // Frames differ (the hair moves under `lean`), so the comparison above is not trivial.
    assert_ne!(v["points"]["0"], v["points"]["6"]);

    // The body follows the motion: each sphere's world centre is where the run's own frame
    // puts it, and the structure has the frame's active nodes and segments.
    let scene =
        wisptree::scene::Scene::load(&style, "lean", wisptree::solver::SolverKind::Awt).unwrap();
    let mut solver = scene.solver();
    let mut report = solver.new_report();
    let mut builder = wisptree::pipeline::FrameBuilder::new(&scene.model, 1, 2);
    let mut frame = wisptree::frame::Frame::default();
    let mut k = 0;
    for index in 0..7 {
        for _ in 0..solver.steps_per_frame() {
            solver.step(&mut report);
        }
        if index % 3 != 0 {
            continue;
        }
        builder.fill(&mut *solver, &mut frame);
        for (i, c) in frame.body.sphere_centers.iter().enumerate() {
            let got = &v["body"][format!("sphere_{i}")][k];
            for a in 0..3 {
                let d = (f64::from(c[a]) - got[a].as_f64().unwrap()).abs();
                assert!(d < 1e-6, "frame {index} sphere {i}: {c:?} vs {got}");
            }
        }
        let s = frame.body.scalp_center;
        let got = &v["body"]["scalp"][k];
        assert!((0..3).all(|a| (f64::from(s[a]) - got[a].as_f64().unwrap()).abs() < 1e-6));
        let n = frame.nodes.positions.len();
        assert!(n > 0);
        assert_eq!(v["nodes"][k], n, "frame {index}: active nodes");
        assert_eq!(v["node_widths"][k], n);
        assert_eq!(v["segments"][k], frame.segments.starts.len());
        assert_eq!(v["segment_points"][k], 2 * frame.segments.starts.len());
        k += 1;
    }
    assert!(
        v["body"]["sphere_0"][0] != v["body"]["sphere_0"][2],
        "the head moves under lean"
    );
}

#[test]
fn a_usd_output_that_cannot_be_written_exits_2_naming_it_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    let file = dir.path().join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let under_file = file.join("x.usda").to_string_lossy().into_owned();
    let folder = dir.path().to_string_lossy().into_owned();
    let wrong_ext = dir.path().join("x.usdc").to_string_lossy().into_owned();
    let fine = dir.path().join("ok.usda").to_string_lossy().into_owned();
    let hair_dir = dir.path().join("h").to_string_lossy().into_owned();
    let cases: [(&[&str], &str); 5] = [
        (&["--format", "usd", "--out", &under_file], &under_file),
        (&["--format", "usd", "--out", &folder], "is a folder"),
        (&["--format", "usd", "--out", &wrong_ext], ".usda"),
        (
            &["--format", "usd", "--out", "/proc/x.usda"],
            "/proc/x.usda",
        ),
        (
            &["--format", "hair", "--out", &hair_dir, "--debug-structure"],
            "--debug-structure",
        ),
    ];
    for (extra, needle) in cases {
        let args = [&["export", "--style", &style, "--seconds", "0.08"], extra].concat();
        let (code, _, err) = wisptree(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: `{needle}` not in {err}");
        assert!(!err.contains("panicked"), "{err}");
        let errors: Vec<&str> = err
            .lines()
            .filter(|l| l.starts_with("wisptree: "))
            .collect();
        assert_eq!(errors.len(), 1, "one error line: {err}");
        assert!(errors[0].contains(needle), "{err}");
    }
    // A disk that fills up while the layer is written: the file size limit (with SIGXFSZ
    // ignored, a write past it fails with EFBIG, as a full disk fails with ENOSPC).
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -f 64; trap '' XFSZ; exec {BIN} export --style {style} --seconds 0.4 \
             --format usd --out {fine} --no-progress"
        ))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(&fine) && err.contains("cannot write"), "{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("ok.usda"))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// A layer written where one already is keeps the earlier one as `NAME.bak`; with that backup
/// there too, the export exits 2 naming both before it runs, and neither file changes.
#[test]
fn a_usd_layer_never_replaces_an_existing_file_without_a_backup() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    let out = dir.path().join("hair.usda");
    let bak = dir.path().join("hair.usda.bak");
    std::fs::write(&out, "#usda 1.0\n# the user's own layer\n").unwrap();
    let path = out.to_string_lossy().into_owned();
    let args = [
        "export",
        "--style",
        &style,
        "--seconds",
        "0.08",
        "--format",
        "usd",
        "--out",
        &path,
    ];
    let (code, _, err) = wisptree(&args);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("hair.usda.bak"), "the move is said: {err}");
    assert!(std::fs::read_to_string(&bak)
        .unwrap()
        .contains("the user's own layer"));
    let written = std::fs::read(&out).unwrap();
    assert!(written.starts_with(b"#usda 1.0"));
    assert!(written.len() > 1000, "a new layer: {} bytes", written.len());
    let (code, _, err) = wisptree(&args);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("hair.usda.bak") && err.contains("move one"),
        "{err}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), written);
    assert!(std::fs::read_to_string(&bak)
        .unwrap()
        .contains("the user's own layer"));
}
