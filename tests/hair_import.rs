//! Styles that import `.hair` and `.data` files: axes, units, resampling to K, the notes on
//! skipped strands, fitted collision spheres, validation, and corrupt files through the command
//! (exit 2, the file and the byte offset in the message).

mod hair_common;

use hair_common::*;
use std::path::Path;
use std::process::Command;
use wisptree::model::HairModel;
use wisptree::style::hair_file::encode_hair;
use wisptree::style::hairsalon::encode_hairsalon;
use wisptree::style::{self, StyleError};

// ---------------------------------------------------------------------------------------------
// Styles that import the files.

/// Hanging strands of `lens[s]` points (y-up, metres) rooted on a cap of the sphere
/// (`center`, `radius`), every root distinct.
fn hanging(lens: &[usize], center: [f64; 3], radius: f64) -> Vec<Vec<[f64; 3]>> {
    lens.iter()
        .enumerate()
        .map(|(s, &n)| {
            let az = (s as f64 * 137.5).to_radians();
            let el = (15.0 + 60.0 * ((s * 7) % 11) as f64 / 10.0).to_radians();
            let dir = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
            let root = [0, 1, 2].map(|a| center[a] + radius * dir[a]);
            (0..n)
                .map(|v| {
                    let t = v as f64 * 0.03;
                    [
                        root[0] + dir[0] * t * 0.3,
                        root[1] - t,
                        root[2] + dir[2] * t * 0.3,
                    ]
                })
                .collect()
        })
        .collect()
}

/// Points in metres (y-up) as stored in a z-up centimetre file translated by `t`: the inverse
/// of the style's `scale: 0.01, translate: t, up: Z`, written independently of the crate.
fn to_z_up_cm(strands: &[Vec<[f64; 3]>], t: [f64; 3]) -> Vec<Vec<[f32; 3]>> {
    strands
        .iter()
        .map(|s| {
            s.iter()
                .map(|p| {
                    let q = [0, 1, 2].map(|a| (p[a] - t[a]) / 0.01);
                    [q[0] as f32, -q[2] as f32, q[1] as f32]
                })
                .collect()
        })
        .collect()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p.to_string_lossy().into_owned()
}

fn style_text(hair: &str, head: &str) -> String {
    format!(
        "Style(head: ({head}), hair: {hair}, \
         hierarchy: (levels: 2, cross_sections: 5, branching: [2], top_level: 3))"
    )
}

fn near(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= tol)
}

#[test]
fn hair_style_turns_z_up_scales_translates_and_resamples_to_k() {
    let truth = hanging(&[4, 9, 2, 13, 6, 1, 7, 3], [0.0, 1.6, 0.0], 0.09);
    let t = [0.05, 0.5, -0.02];
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "h.hair",
        &encode_hair(&to_z_up_cm(&truth, t), "").unwrap(),
    );
    let hair = format!("Hair((file: \"{file}\", scale: 0.01, translate: {t:?}, up: Z))")
        .replace('[', "(")
        .replace(']', ")");
    let loaded = style::parse(&dir.path().join("s.ron"), &style_text(&hair, "")).unwrap();
    let raw = loaded.strands().unwrap();
    let kept: Vec<_> = truth.iter().filter(|s| s.len() > 1).collect();
    assert_eq!(
        raw.strands.len(),
        kept.len(),
        "the one-point strand is skipped"
    );
    assert_eq!(raw.notes.len(), 1, "{:?}", raw.notes);
    assert!(
        raw.notes[0].contains("skipped 1 one-point"),
        "{:?}",
        raw.notes
    );
    for (got, want) in raw.strands.iter().zip(&kept) {
        assert_eq!(
            got.points.len(),
            want.len(),
            "points kept before resampling"
        );
        for (g, w) in got.points.iter().zip(want.iter()) {
            assert!(near(*g, *w, 1e-6), "{g:?} vs {w:?}");
        }
    }
    // The model resamples every strand, whatever its length, to K = 5 points, keeping the root
    // and the tip (strands are reordered by wisp, so compare sorted sets).
    let model = HairModel::from_style(&loaded).unwrap();
    let k = model.k;
    assert_eq!(k, 5);
    assert_eq!(model.strands.len(), kept.len());
    assert_eq!(model.strands.rest.len(), kept.len() * k);
    assert_eq!(model.notes, raw.notes, "the note reaches the model");
    let key = |p: [f64; 3]| [p[0], p[1], p[2]].map(|c| (c * 1e5).round() as i64);
    let mut want: Vec<_> = kept
        .iter()
        .map(|s| (key(s[0]), key(s[s.len() - 1])))
        .collect();
    let mut got: Vec<_> = (0..kept.len())
        .map(|s| {
            let r = model.strands.rest[s * k];
            let tip = model.strands.rest[s * k + k - 1];
            (key([r.x, r.y, r.z]), key([tip.x, tip.y, tip.z]))
        })
        .collect();
    want.sort();
    got.sort();
    assert_eq!(got, want, "roots and tips survive resampling");
}

#[test]
fn hairsalon_style_tells_how_many_strands_were_skipped() {
    let truth = hanging(&[1, 8, 1, 5, 6, 1, 4, 9, 3], [0.0, 1.6, 0.0], 0.09);
    let f32s: Vec<Vec<[f32; 3]>> = truth
        .iter()
        .map(|s| s.iter().map(|p| p.map(|c| c as f32)).collect())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "s.data", &encode_hairsalon(&f32s).unwrap());
    // Relative to the style file; y-up metres are the defaults.
    let text = style_text("HairSalon((file: \"s.data\"))", "");
    let loaded = style::parse(&dir.path().join("s.ron"), &text).unwrap();
    let model = HairModel::from_style(&loaded).unwrap();
    assert_eq!(model.strands.len(), 6);
    assert_eq!(model.notes.len(), 1);
    let note = &model.notes[0];
    assert!(
        note.contains("skipped 3 one-point") && note.contains("of 9"),
        "{note}"
    );
    assert_eq!(
        loaded.body,
        loaded.style.head.spheres(),
        "head.body by default"
    );
}

#[test]
fn fit_body_finds_the_head_sphere_under_the_roots() {
    let (c, r) = ([0.02, 1.55, -0.01], 0.1);
    let truth = hanging(&[5; 40], c, r);
    let dir = tempfile::tempdir().unwrap();
    let f32s: Vec<Vec<[f32; 3]>> = truth
        .iter()
        .map(|s| s.iter().map(|p| p.map(|c| c as f32)).collect())
        .collect();
    write(dir.path(), "fit.hair", &encode_hair(&f32s, "").unwrap());
    let text = style_text("Hair((file: \"fit.hair\"))", "fit_body: true");
    let loaded = style::parse(&dir.path().join("s.ron"), &text).unwrap();
    assert_eq!(loaded.body.len(), 1, "{:?}", loaded.body);
    let s = &loaded.body[0];
    assert!(near(s.center, c, 1e-5), "centre {:?} vs {c:?}", s.center);
    assert!(
        (s.radius - 0.98 * r).abs() < 1e-5,
        "radius {} vs 0.98 × {r}",
        s.radius
    );
    // Every root lies outside the fitted sphere.
    for st in &truth {
        let d = (0..3)
            .map(|a| (st[0][a] - s.center[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d > s.radius, "root at {d} inside radius {}", s.radius);
    }
    // Without fit_body the style's own spheres are kept.
    let plain = style_text("Hair((file: \"fit.hair\"))", "");
    let loaded = style::parse(&dir.path().join("s.ron"), &plain).unwrap();
    assert_eq!(loaded.body, loaded.style.head.spheres());
}

#[test]
fn fit_body_refuses_roots_that_determine_no_sphere() {
    // Roots all in the plane y = 1.7.
    let flat: Vec<Vec<[f32; 3]>> = (0..12)
        .map(|s| {
            let (x, z) = ((s % 4) as f32 * 0.02, (s / 4) as f32 * 0.03);
            vec![[x, 1.7, z], [x, 1.5, z]]
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "flat.hair", &encode_hair(&flat, "").unwrap());
    let text = style_text("Hair((file: \"flat.hair\"))", "fit_body: true");
    match style::parse(&dir.path().join("s.ron"), &text) {
        Err(StyleError::Invalid { field, msg, .. }) => {
            assert_eq!(field, "head.fit_body");
            assert!(msg.contains("coplanar"), "{msg}");
        }
        other => panic!("expected an Invalid error, got {other:?}"),
    }
}

#[test]
fn strand_file_fields_are_validated() {
    let p = Path::new("v.ron");
    let field_of = |text: &str| match style::parse(p, text) {
        Err(StyleError::Invalid { field, .. }) => field,
        other => panic!("expected an Invalid error for {text}, got {other:?}"),
    };
    let h = |hair: &str, head: &str| style_text(hair, head);
    assert_eq!(field_of(&h("Hair((file: \"\"))", "")), "hair.file");
    assert_eq!(
        field_of(&h("Hair((file: \"a\", scale: 0))", "")),
        "hair.scale"
    );
    assert_eq!(
        field_of(&h("HairSalon((file: \"a\", scale: -1))", "")),
        "hair.scale"
    );
    let nan = h("HairSalon((file: \"a\", translate: (0, NaN, 0)))", "");
    assert_eq!(field_of(&nan), "hair.translate");
    let both = h(
        "TressFx((files: [\"a.tfx\"], project: Some(\"a.tfxproj\")))",
        "fit_body: true",
    );
    assert_eq!(field_of(&both), "head.fit_body");
    // Unknown fields and unknown axes are refused by the parser, with a position.
    for bad in [
        h("Hair((file: \"a\", scael: 1))", ""),
        h("Hair((file: \"a\", up: X))", ""),
    ] {
        assert!(
            matches!(style::parse(p, &bad), Err(StyleError::Parse { .. })),
            "{bad}"
        );
    }
    // A missing file is an I/O error naming it.
    let missing = h("Hair((file: \"/nonexistent/x.hair\"))", "");
    let loaded = style::parse(p, &missing).unwrap();
    assert!(matches!(loaded.strands(), Err(StyleError::Io { .. })));
}

// ---------------------------------------------------------------------------------------------
// Through the command: exit 2, the file and the byte offset in the message.

fn inspect(style: &str) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["inspect", style])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.code().unwrap_or(-1), err)
}

#[test]
fn corrupt_files_exit_2_with_the_byte_offset() {
    let dir = tempfile::tempdir().unwrap();
    let mut cases: Vec<(String, String, &str)> = hair_corruptions()
        .into_iter()
        .map(|(name, bytes, needle)| {
            let file = format!("{name}.hair");
            write(dir.path(), &file, &bytes);
            (file.clone(), format!("Hair((file: \"{file}\"))"), needle)
        })
        .collect();
    let mut zero = encode_hairsalon(&strands_of(&[3, 2])).unwrap();
    zero[44..48].copy_from_slice(&0i32.to_le_bytes());
    write(dir.path(), "zero.data", &zero);
    cases.push((
        "zero.data".into(),
        "HairSalon((file: \"zero.data\"))".into(),
        "byte 44",
    ));
    let cut = encode_hairsalon(&strands_of(&[3, 2])).unwrap();
    write(dir.path(), "cut.data", &cut[..60]);
    cases.push((
        "cut.data".into(),
        "HairSalon((file: \"cut.data\"))".into(),
        "truncated at byte 60",
    ));
    for (file, hair, needle) in cases {
        let style = write(dir.path(), "bad.ron", style_text(&hair, "").as_bytes());
        let (code, err) = inspect(&style);
        assert_eq!(code, 2, "{file}: exit {code}: {err}");
        assert!(err.contains(&file), "{file}: file not named: {err}");
        assert!(err.contains(needle), "{file}: `{needle}` not in: {err}");
        assert!(!err.contains("panicked"), "{file}: {err}");
    }
}

#[test]
fn inspect_and_run_say_how_many_strands_were_skipped() {
    let truth = hanging(&[1, 8, 1, 5, 6, 4], [0.0, 1.6, 0.0], 0.09);
    let f32s: Vec<Vec<[f32; 3]>> = truth
        .iter()
        .map(|s| s.iter().map(|p| p.map(|c| c as f32)).collect())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "n.data", &encode_hairsalon(&f32s).unwrap());
    let style = write(
        dir.path(),
        "n.ron",
        style_text("HairSalon((file: \"n.data\"))", "").as_bytes(),
    );
    let (code, err) = inspect(&style);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("skipped 2 one-point strand"), "{err}");
    // `run` says it too.
    let rrd = dir.path().join("n.rrd").to_string_lossy().into_owned();
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args([
            "run",
            "--style",
            &style,
            "--save",
            &rrd,
            "--seconds",
            "0.04",
        ])
        .output()
        .expect("the binary runs");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("skipped 2 one-point strand"), "{err}");
}
