//! `wisptree export`: the files of every n-th frame, readable as `.hair` (checked against the
//! published layout by hand, not only by our reader) and `.tfx`, for every model; bad flags
//! exit 2; `export` and `render` never replace a file in their folder that they did not write.

use std::path::{Path, PathBuf};
use std::process::Command;
use wisptree::app::export::{export, ExportFormat, ExportOptions};
use wisptree::solver::SolverKind;
use wisptree::style::hair_file::{encode_hair, parse_hair};
use wisptree::style::tfx::load_tfx;

const STRANDS: usize = 30;
const K: usize = 6;

fn wisptree(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(args)
        .output()
        .expect("the binary runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Roots of the test hair: a cap just outside the default scalp, every root distinct.
fn roots() -> Vec<[f32; 3]> {
    (0..STRANDS)
        .map(|s| {
            let az = (s as f64 * 137.5).to_radians();
            let el = (20.0 + 50.0 * ((s * 7) % 11) as f64 / 10.0).to_radians();
            let d = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
            [0.1 * d[0], 1.6 + 0.1 * d[1], 0.1 * d[2]].map(|c| c as f32)
        })
        .collect()
}

/// A small imported style (30 hanging strands of 10 points, K = 6, short settling) in `dir`.
fn small_style(dir: &Path) -> String {
    let strands: Vec<Vec<[f32; 3]>> = roots()
        .into_iter()
        .map(|r| {
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

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3)
        .map(|i| (a[i] as f64 - b[i] as f64).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The files in `dir`, but the export's manifest (`.wisptree-export`).
fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != ".wisptree-export")
        .collect();
    v.sort();
    v
}

#[test]
fn hair_export_writes_every_frame_in_the_published_layout() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    let out = dir.path().join("out");
    let out_s = out.to_string_lossy().into_owned();
    let args = [
        "export",
        "--style",
        &style,
        "--motion",
        "still",
        "--seconds",
        "0.2",
        "--format",
        "hair",
        "--out",
        &out_s,
    ];
    let (code, stdout, err) = wisptree(&args);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("wrote 5 hair files"), "{stdout}");
    let names: Vec<String> = (0..5).map(|i| format!("frame_{i:05}.hair")).collect();
    assert_eq!(files_in(&out), names, "0.2 s at 40 ms per frame");
    let manifest = std::fs::read_to_string(out.join(".wisptree-export")).unwrap();
    assert!(
        names.iter().all(|n| manifest.contains(n.as_str())),
        "the manifest lists the frames: {manifest}"
    );
    let points = 2 * (K - 1) + 1; // Catmull-Rom, two points per span
    for name in &names {
        let bytes = std::fs::read(out.join(name)).unwrap();
        // By hand, per the format: header fields, the segments array, then the points.
        let u = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(&bytes[0..4], b"HAIR");
        assert_eq!(u(4) as usize, STRANDS, "{name}: strands");
        assert_eq!(u(8) as usize, STRANDS * points, "{name}: points");
        assert_eq!(u(12), 0b11, "{name}: segments and points arrays only");
        assert_eq!(bytes.len(), 128 + 2 * STRANDS + 12 * STRANDS * points);
        for s in 0..STRANDS {
            let seg = u16::from_le_bytes([bytes[128 + 2 * s], bytes[129 + 2 * s]]);
            assert_eq!(seg as usize, points - 1, "{name}: strand {s} segments");
        }
        let info = String::from_utf8_lossy(&bytes[40..128]);
        assert!(info.contains("metres, y up"), "{info}");
        // Our reader agrees, and under `still` every root stays by the head.
        let h = parse_hair(Path::new(name), &bytes).unwrap();
        assert!(h.strands.iter().all(|s| s.len() == points));
        // Strand points follow their wisp's frame (offsets turn with it), so after settling a
        // root may sit a few millimetres from where the file put it, never further.
        for (s, st) in h.strands.iter().enumerate() {
            let d = roots()
                .iter()
                .map(|r| dist(*r, st[0]))
                .fold(f64::INFINITY, f64::min);
            assert!(
                d < 0.01,
                "{name}: strand {s} root {:?} is {d} m from every file root",
                st[0]
            );
        }
        let first = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        assert_eq!(first(128 + 2 * STRANDS), h.strands[0][0][0]);
    }
    // Deterministic: a second export writes the same bytes.
    let again = dir.path().join("again");
    let again_s = again.to_string_lossy().into_owned();
    let mut args2 = args;
    args2[10] = &again_s;
    let (code, _, err) = wisptree(&args2);
    assert_eq!(code, 0, "{err}");
    for name in &names {
        let a = std::fs::read(out.join(name)).unwrap();
        let b = std::fs::read(again.join(name)).unwrap();
        assert!(a == b, "{name} differs between two runs");
    }
}

fn polyline_length(p: &[[f32; 3]]) -> f64 {
    p.windows(2).map(|w| dist(w[0], w[1])).sum()
}

#[test]
fn tfx_export_every_other_frame_with_any_model() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    for model in SolverKind::ALL {
        let opts = |format, every, out: PathBuf| ExportOptions {
            style: style.clone(),
            motion: "lean".into(),
            model: *model,
            seconds: 0.2,
            format,
            out,
            every,
            debug_structure: false,
        };
        let tfx_dir = dir.path().join(format!("{model}-tfx"));
        let hair_dir = dir.path().join(format!("{model}-hair"));
        let s = export(&opts(ExportFormat::Tfx, 2, tfx_dir.clone()), false).unwrap();
        let names = ["frame_00000.tfx", "frame_00002.tfx", "frame_00004.tfx"];
        assert_eq!(files_in(&tfx_dir), names, "{model}: frames 0, 2, 4");
        assert_eq!(
            (s.frames, s.files.len(), s.strands),
            (5, 3, STRANDS),
            "{model}"
        );
        assert_eq!(s.points_per_strand, 32);
        let total: u64 = s
            .files
            .iter()
            .map(|f| std::fs::metadata(f).unwrap().len())
            .sum();
        assert_eq!(s.bytes, total);
        export(&opts(ExportFormat::Hair, 1, hair_dir.clone()), false).unwrap();
        for name in names {
            let tfx = load_tfx(&tfx_dir.join(name)).unwrap();
            assert_eq!(tfx.len(), STRANDS, "{model} {name}");
            assert!(
                tfx.iter().all(|s| s.len() == 32),
                "{model} {name}: 32 vertices"
            );
            // The same simulated frame as the .hair export, resampled: root and tip exactly,
            // the length kept, the vertices evenly spread along the strand.
            let hair_name = name.replace(".tfx", ".hair");
            let hair = parse_hair(
                Path::new(&hair_name),
                &std::fs::read(hair_dir.join(&hair_name)).unwrap(),
            )
            .unwrap();
            for (t, h) in tfx.iter().zip(&hair.strands) {
                let t32: Vec<[f32; 3]> = t.iter().map(|p| p.map(|c| c as f32)).collect();
                assert_eq!(t32[0], h[0], "{model} {name}: root");
                assert_eq!(t32[31], h[h.len() - 1], "{model} {name}: tip");
                let (lt, lh) = (polyline_length(&t32), polyline_length(h));
                assert!(
                    (lt - lh).abs() <= 0.02 * lh,
                    "{model} {name}: length {lt} vs {lh}"
                );
                let steps: Vec<f64> = t32.windows(2).map(polyline_length).collect();
                let (lo, hi) = steps
                    .iter()
                    .fold((f64::MAX, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
                assert!(hi <= 1.5 * lo, "{model} {name}: spacing {lo}..{hi}");
            }
        }
    }
}

#[test]
fn bad_export_flags_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    let file = dir.path().join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let out = dir.path().join("out").to_string_lossy().into_owned();
    let file = file.to_string_lossy().into_owned();
    let missing = dir
        .path()
        .join("missing.ron")
        .to_string_lossy()
        .into_owned();
    let base = |style: &str, extra: &[&str]| -> Vec<String> {
        let mut v: Vec<String> = ["export", "--style", style, "--out", &out]
            .iter()
            .map(|s| s.to_string())
            .collect();
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            base(&style, &["--seconds", "0.2", "--every", "0"]),
            "--every",
        ),
        (base(&style, &["--seconds", "0"]), "--seconds"),
        (base(&style, &["--seconds=-1"]), "--seconds"),
        (base(&style, &["--seconds", "NaN"]), "--seconds"),
        (
            base(&style, &["--seconds", "0.2", "--format", "obj"]),
            "obj",
        ),
        (
            base(&style, &["--seconds", "0.2", "--model", "nope"]),
            "nope",
        ),
        (base(&missing, &["--seconds", "0.2"]), "missing.ron"),
    ];
    let mut cases = cases;
    let to_file = [
        "export",
        "--style",
        &style,
        "--seconds",
        "0.2",
        "--out",
        &file,
    ];
    cases.push((
        to_file.iter().map(|s| s.to_string()).collect(),
        "not a folder",
    ));
    for (args, needle) in cases {
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let (code, _, err) = wisptree(&refs);
        assert_eq!(code, 2, "{args:?}: exit {code}: {err}");
        assert!(err.contains(needle), "{args:?}: `{needle}` not in: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

/// `export --format hair` and `render` into a folder: a file the user made (or edited) where a
/// frame goes is kept as NAME.bak, the command's own earlier files are replaced without one
/// (also after a run stopped before its end), and a second backup is refused, exit 2.
#[test]
fn frame_folders_keep_a_users_file_and_replace_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let style = small_style(dir.path());
    for (command, ext, extra) in [
        ("export", "hair", ["--format", "hair"]),
        ("render", "png", ["--size", "32x24"]),
    ] {
        let out = dir.path().join(command);
        std::fs::create_dir_all(&out).unwrap();
        let out_s = out.to_string_lossy().into_owned();
        let run = || {
            let mut args = vec![
                command,
                "--style",
                &style,
                "--motion",
                "still",
                "--seconds",
                "0.08",
                "--out",
                &out_s,
            ];
            args.extend(extra);
            wisptree(&args)
        };
        let (f0, f1) = (format!("frame_00000.{ext}"), format!("frame_00001.{ext}"));
        std::fs::write(out.join(&f1), "mine").unwrap();
        std::fs::write(out.join("notes.txt"), "unrelated").unwrap();
        let (code, _, err) = run();
        assert_eq!(code, 0, "{command}: {err}");
        assert_eq!(
            std::fs::read_to_string(out.join(format!("{f1}.bak"))).unwrap(),
            "mine",
            "{command}: the user's file is kept"
        );
        assert!(
            err.contains(&format!("{f1}.bak")),
            "{command} says so: {err}"
        );
        let first = std::fs::read(out.join(&f0)).unwrap();
        assert_ne!(first, b"mine");
        // Again, and again after the manifest lost its compact form (a run stopped half-way
        // leaves only the lines it appended): its own files are replaced, no new backup.
        for _ in 0..2 {
            let (code, _, err) = run();
            assert_eq!(code, 0, "{command} again: {err}");
            assert!(
                !err.contains(".bak"),
                "{command}: nothing moved aside: {err}"
            );
            let manifest = out.join(format!(".wisptree-{command}"));
            let text = std::fs::read_to_string(&manifest).unwrap();
            let appended: String = text
                .lines()
                .filter(|l| !l.starts_with('#'))
                .map(|l| format!("{l}\n"))
                .collect();
            std::fs::write(&manifest, appended).unwrap();
        }
        assert_eq!(
            std::fs::read(out.join(&f0)).unwrap(),
            first,
            "{command}: same bytes"
        );
        assert_eq!(
            std::fs::read_to_string(out.join("notes.txt")).unwrap(),
            "unrelated"
        );
        // Edited since the last run: moved aside.
        std::fs::remove_file(out.join(format!("{f1}.bak"))).unwrap();
        std::fs::write(out.join(&f0), "edited").unwrap();
        let (code, _, err) = run();
        assert_eq!(code, 0, "{command}: {err}");
        let read = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
        assert_eq!(read(&format!("{f0}.bak")), "edited");
        // The second frame's file in the way with its backup there too: refused before the
        // run writes anything (the first frame would have been added to the manifest).
        std::fs::write(out.join(&f1), "edited f1").unwrap();
        std::fs::write(out.join(format!("{f1}.bak")), "older").unwrap();
        let manifest = format!(".wisptree-{command}");
        let before = read(&manifest);
        let (code, _, err) = run();
        assert_eq!(code, 2, "{command} refuses: {err}");
        assert!(
            err.contains(&f1) && err.contains(&format!("{f1}.bak")),
            "{err}"
        );
        assert_eq!(read(&manifest), before, "{command} wrote nothing");
        assert_eq!(read(&f1), "edited f1");
        assert_eq!(read(&format!("{f1}.bak")), "older");
    }
}
