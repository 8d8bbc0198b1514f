//! `.hair` (Cem Yuksel) and `.data` (USC-HairSalon) import: exact round trips, files from an
//! independent writer that follows the published layout, every corruption located by byte
//! offset (also through the command, exit 2), styles that import them, and random bytes.

use proptest::prelude::*;
use std::path::Path;
use std::process::Command;
use wisptree::model::HairModel;
use wisptree::style::hair_file::{encode_hair, load_hair, parse_hair, write_hair};
use wisptree::style::hairsalon::{encode_hairsalon, parse_hairsalon};
use wisptree::style::{self, StyleError};

// ---------------------------------------------------------------------------------------------
// An independent writer and reader, straight from the format's description: 128-byte header
// (signature, u32 strands, u32 points, u32 flags, u32 default segments, f32 thickness, f32
// transparency, 3×f32 colour, 88 bytes of info), then segments (u16), points (3×f32),
// thickness (f32), transparency (f32), colour (3×f32), each only when its flag bit is set.

/// Which optional arrays the independent writer puts in.
#[derive(Debug, Clone, Copy)]
struct Arrays {
    segments: bool,
    thickness: bool,
    transparency: bool,
    color: bool,
}

fn le32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn lef(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Per-point values the independent writer stores, derived from the point index.
fn thickness_of(i: usize) -> f32 {
    0.01 * (1 + i) as f32
}
fn transparency_of(i: usize) -> f32 {
    (i % 7) as f32 / 7.0
}
fn color_of(i: usize) -> [f32; 3] {
    [(i % 3) as f32 / 3.0, 0.5, 1.0 - (i % 5) as f32 / 5.0]
}

/// A `.hair` file laid out by hand. Without a segments array every strand must have
/// `d_segments + 1` points.
fn spec_hair(strands: &[Vec<[f32; 3]>], a: Arrays, info: &[u8]) -> Vec<u8> {
    let points: usize = strands.iter().map(Vec::len).sum();
    let flags = (a.segments as u32)
        | 2
        | ((a.thickness as u32) << 2)
        | ((a.transparency as u32) << 3)
        | ((a.color as u32) << 4);
    let mut b = b"HAIR".to_vec();
    le32(&mut b, strands.len() as u32);
    le32(&mut b, points as u32);
    le32(&mut b, flags);
    le32(&mut b, strands[0].len() as u32 - 1);
    for v in [0.5f32, 0.25, 0.1, 0.2, 0.3] {
        lef(&mut b, v);
    }
    b.extend_from_slice(info);
    b.resize(128, 0);
    if a.segments {
        for s in strands {
            b.extend_from_slice(&(s.len() as u16 - 1).to_le_bytes());
        }
    }
    for c in strands.iter().flatten().flatten() {
        lef(&mut b, *c);
    }
    if a.thickness {
        (0..points).for_each(|i| lef(&mut b, thickness_of(i)));
    }
    if a.transparency {
        (0..points).for_each(|i| lef(&mut b, transparency_of(i)));
    }
    if a.color {
        (0..points).for_each(|i| color_of(i).iter().for_each(|&c| lef(&mut b, c)));
    }
    b
}

/// The strands of a valid `.hair` file, decoded by hand (segments and points arrays only).
fn spec_read(b: &[u8]) -> Vec<Vec<[f32; 3]>> {
    let u = |at: usize| u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    let f = |at: usize| f32::from_le_bytes(b[at..at + 4].try_into().unwrap());
    assert_eq!(&b[0..4], b"HAIR");
    let (n, flags) = (u(4) as usize, u(12));
    assert!(flags & 2 != 0, "points array present");
    let mut at = 128;
    let lens: Vec<usize> = if flags & 1 != 0 {
        let l = (0..n)
            .map(|s| u16::from_le_bytes([b[128 + 2 * s], b[129 + 2 * s]]) as usize + 1)
            .collect();
        at += 2 * n;
        l
    } else {
        vec![u(16) as usize + 1; n]
    };
    lens.iter()
        .map(|&l| {
            (0..l)
                .map(|_| {
                    let p = [f(at), f(at + 4), f(at + 8)];
                    at += 12;
                    p
                })
                .collect()
        })
        .collect()
}

/// Strands with `lens[s]` points each, distinct coordinates (not round numbers).
fn strands_of(lens: &[usize]) -> Vec<Vec<[f32; 3]>> {
    lens.iter()
        .enumerate()
        .map(|(s, &n)| {
            (0..n)
                .map(|v| {
                    let (s, v) = (s as f32, v as f32);
                    [
                        0.1 * s - 0.037,
                        1.61 - 0.013 * v * v,
                        0.3 + s / 3.0 + v / 7.0,
                    ]
                })
                .collect()
        })
        .collect()
}

fn bits(s: &[Vec<[f32; 3]>]) -> Vec<Vec<[u32; 3]>> {
    s.iter()
        .map(|p| p.iter().map(|q| q.map(f32::to_bits)).collect())
        .collect()
}

/// The message of a file error, or a test failure naming what came instead.
fn msg<T: std::fmt::Debug>(r: Result<T, StyleError>) -> String {
    match r {
        Err(StyleError::Tfx { msg, .. }) => msg,
        other => panic!("expected a file error, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------

#[test]
fn hair_round_trip_is_exact_and_follows_the_layout() {
    let strands = strands_of(&[2, 5, 17, 1, 3, 64]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("round.hair");
    write_hair(&path, &strands, "round trip").unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let back = load_hair(&path).unwrap();
    assert_eq!(
        bits(&back.strands),
        bits(&strands),
        "f32 points bit for bit"
    );
    assert_eq!(back.info, "round trip");
    assert!(back.thickness.is_none() && back.transparency.is_none() && back.colors.is_none());
    // The same bytes decoded by hand, per the published layout.
    assert_eq!(bits(&spec_read(&bytes)), bits(&strands));
    let u = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!((u(4), u(8), u(12)), (6, 92, 0b11), "strands, points, flags");
    assert_eq!(bytes.len(), 128 + 2 * 6 + 12 * 92);
    assert_eq!(&bytes[40..50], b"round trip");
    assert!(bytes[50..128].iter().all(|&b| b == 0), "info zero padded");
    // Default thickness, transparency, colour as the reference implementation initialises.
    let f = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!(
        [f(20), f(24), f(28), f(32), f(36)],
        [1.0, 0.0, 1.0, 1.0, 1.0]
    );
}

#[test]
fn writer_refuses_what_the_format_cannot_hold_and_cuts_long_info() {
    assert!(
        encode_hair(&[vec![]], "").is_err(),
        "a strand with no point"
    );
    let long = vec![[0.0f32; 3]; 65_537];
    assert!(
        encode_hair(&[long], "").is_err(),
        "65,536 segments do not fit a u16"
    );
    let ok = vec![[1.0f32, 2.0, 3.0]; 65_536];
    assert!(encode_hair(&[ok], "").is_ok(), "65,535 segments do");
    let info = "é".repeat(60); // 120 bytes of two-byte characters
    let b = encode_hair(&strands_of(&[3]), &info).unwrap();
    let back = parse_hair(Path::new("i.hair"), &b).unwrap();
    assert_eq!(
        back.info,
        "é".repeat(43),
        "87 bytes cut at a character boundary"
    );
    assert_eq!(b[127], 0, "NUL-terminated");
}

#[test]
fn independent_writer_with_each_optional_array_loads() {
    let mixed = strands_of(&[4, 9, 2, 30, 5]);
    let uniform = strands_of(&[6, 6, 6, 6]);
    for mask in 0..16u32 {
        let a = Arrays {
            segments: mask & 1 != 0,
            thickness: mask & 2 != 0,
            transparency: mask & 4 != 0,
            color: mask & 8 != 0,
        };
        let strands = if a.segments { &mixed } else { &uniform };
        let bytes = spec_hair(strands, a, b"made by hand");
        let h = parse_hair(Path::new("spec.hair"), &bytes).unwrap_or_else(|e| panic!("{a:?}: {e}"));
        assert_eq!(bits(&h.strands), bits(strands), "{a:?}");
        assert_eq!(h.info, "made by hand");
        let n: usize = strands.iter().map(Vec::len).sum();
        let want = |on: bool, f: fn(usize) -> f32| on.then(|| (0..n).map(f).collect::<Vec<_>>());
        assert_eq!(h.thickness, want(a.thickness, thickness_of), "{a:?}");
        assert_eq!(
            h.transparency,
            want(a.transparency, transparency_of),
            "{a:?}"
        );
        let colors = a.color.then(|| (0..n).map(color_of).collect::<Vec<_>>());
        assert_eq!(h.colors, colors, "{a:?}");
        assert_eq!(h.defaults.thickness, 0.5);
        assert_eq!(h.defaults.color, [0.1, 0.2, 0.3]);
        if !a.segments {
            assert_eq!(h.defaults.segments, 5);
        }
    }
}

/// A valid file to corrupt: 3 strands of 2, 4 and 3 points, with a thickness array.
fn victim() -> Vec<u8> {
    let a = Arrays {
        segments: true,
        thickness: true,
        transparency: false,
        color: false,
    };
    spec_hair(&strands_of(&[2, 4, 3]), a, b"")
}

/// Every kind of corrupt `.hair`, with the text its message must contain (the byte offset).
/// Layout of `victim()`: header 0..128, segments 128..134, points 134..242, thickness 242..278.
fn hair_corruptions() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let good = victim();
    let with = |at: usize, v: &[u8]| {
        let mut b = good.clone();
        b[at..at + v.len()].copy_from_slice(v);
        b
    };
    vec![
        ("empty", Vec::new(), "truncated at byte 0"),
        (
            "short_header",
            good[..100].to_vec(),
            "truncated at byte 100",
        ),
        ("signature", with(0, b"HAIX"), "byte 0"),
        (
            "reserved_bits",
            with(12, &(0x25u32 | 3).to_le_bytes()),
            "byte 12",
        ),
        ("no_points", with(12, &1u32.to_le_bytes()), "byte 12"),
        ("zero_strands", with(4, &0u32.to_le_bytes()), "byte 4"),
        ("points_count", with(8, &10u32.to_le_bytes()), "byte 8"),
        (
            "segments_sum",
            with(130, &7u16.to_le_bytes()),
            "gives 13 points",
        ),
        ("default_segments", with(12, &6u32.to_le_bytes()), "byte 16"),
        ("cut_segments", good[..131].to_vec(), "starts at byte 128"),
        ("cut_points", good[..200].to_vec(), "starts at byte 134"),
        ("cut_thickness", good[..250].to_vec(), "starts at byte 242"),
        (
            "huge_count",
            with(4, &u32::MAX.to_le_bytes()),
            "starts at byte 128",
        ),
        (
            "nan_point",
            with(134 + 3 * 12 + 4, &f32::NAN.to_le_bytes()),
            "byte 170",
        ),
        (
            "inf_point",
            with(134, &f32::INFINITY.to_le_bytes()),
            "byte 134",
        ),
        (
            "bad_thickness",
            with(242 + 8, &(-1.0f32).to_le_bytes()),
            "byte 250",
        ),
        (
            "default_thickness",
            with(12, &3u32.to_le_bytes()),
            "end at byte 242",
        ),
        (
            "trailing",
            [good.as_slice(), &[0u8; 5]].concat(),
            "end at byte 278",
        ),
        (
            "bad_default",
            {
                let mut b = with(12, &3u32.to_le_bytes());
                b.truncate(242);
                b[20..24].copy_from_slice(&f32::NAN.to_le_bytes());
                b
            },
            "byte 20",
        ),
    ]
}

#[test]
fn every_hair_corruption_names_its_byte() {
    assert!(parse_hair(Path::new("ok.hair"), &victim()).is_ok());
    for (name, bytes, needle) in hair_corruptions() {
        let m = msg(parse_hair(Path::new("c.hair"), &bytes));
        assert!(m.contains(needle), "{name}: `{needle}` not in: {m}");
    }
}

#[test]
fn hairsalon_reads_skips_one_point_strands_and_counts_them() {
    let strands = strands_of(&[5, 1, 12, 1, 1, 2]);
    let bytes = encode_hairsalon(&strands).unwrap();
    // Layout by hand: i32 count, then per strand i32 vertex count and xyz triples.
    assert_eq!(&bytes[0..4], &6i32.to_le_bytes());
    assert_eq!(&bytes[4..8], &5i32.to_le_bytes());
    assert_eq!(bytes.len(), 4 + 6 * 4 + 12 * 22);
    let h = parse_hairsalon(Path::new("s.data"), &bytes).unwrap();
    assert_eq!(h.skipped_one_point, 3);
    let kept: Vec<_> = [0, 2, 5].iter().map(|&s| strands[s].clone()).collect();
    assert_eq!(bits(&h.strands), bits(&kept), "file order, exact f32");
}

#[test]
fn every_hairsalon_corruption_names_its_byte() {
    let good = encode_hairsalon(&strands_of(&[3, 2])).unwrap(); // strand 1 count at byte 44
    let with = |at: usize, v: &[u8]| {
        let mut b = good.clone();
        b[at..at + v.len()].copy_from_slice(v);
        b
    };
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty", Vec::new(), "truncated at byte 0"),
        ("negative_count", with(0, &(-3i32).to_le_bytes()), "byte 0"),
        ("zero_count", with(0, &0i32.to_le_bytes()), "byte 0"),
        ("no_points", with(44, &0i32.to_le_bytes()), "byte 44"),
        (
            "negative_points",
            with(44, &(-1i32).to_le_bytes()),
            "byte 44",
        ),
        ("cut_strand", good[..60].to_vec(), "from byte 48"),
        ("cut_count", good[..46].to_vec(), "needed at byte 44"),
        (
            "huge_points",
            with(44, &i32::MAX.to_le_bytes()),
            "from byte 48",
        ),
        (
            "more_strands",
            with(0, &3i32.to_le_bytes()),
            "needed at byte 72",
        ),
        ("nan", with(8 + 12 + 8, &f32::NAN.to_le_bytes()), "byte 20"),
        (
            "trailing",
            [good.as_slice(), &[1u8]].concat(),
            "end at byte 72",
        ),
        (
            "all_one_point",
            encode_hairsalon(&strands_of(&[1, 1])).unwrap(),
            "single point",
        ),
    ];
    assert!(parse_hairsalon(Path::new("ok.data"), &good).is_ok());
    for (name, bytes, needle) in cases {
        let m = msg(parse_hairsalon(Path::new("c.data"), &bytes));
        assert!(m.contains(needle), "{name}: `{needle}` not in: {m}");
    }
}

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
    assert_eq!(loaded.body, loaded.style.head.body, "head.body by default");
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
    assert_eq!(loaded.body, loaded.style.head.body);
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

// ---------------------------------------------------------------------------------------------

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(
        bytes in proptest::collection::vec(any::<u8>(), 0..700),
        hair_sig in any::<bool>(),
    ) {
        let mut b = bytes;
        if hair_sig && b.len() >= 4 {
            b[0..4].copy_from_slice(b"HAIR");
        }
        let _ = parse_hair(Path::new("r.hair"), &b);
        let _ = parse_hairsalon(Path::new("r.data"), &b);
    }

    #[test]
    fn mutated_files_never_panic_and_what_parses_is_consistent(
        edits in proptest::collection::vec((0usize..300, any::<u8>()), 1..10),
        cut in 0usize..320,
        salon in any::<bool>(),
    ) {
        let mut b = if salon {
            encode_hairsalon(&strands_of(&[3, 1, 5, 2])).unwrap()
        } else {
            victim()
        };
        for (at, v) in edits {
            if let Some(x) = b.get_mut(at) {
                *x = v;
            }
        }
        b.truncate(cut);
        if salon {
            if let Ok(h) = parse_hairsalon(Path::new("m.data"), &b) {
                prop_assert!(!h.strands.is_empty());
                prop_assert!(h.strands.iter().all(|s| s.len() >= 2));
                prop_assert!(h.strands.iter().flatten().flatten().all(|c| c.is_finite()));
            }
        } else if let Ok(h) = parse_hair(Path::new("m.hair"), &b) {
            let points = u32::from_le_bytes(b[8..12].try_into().unwrap()) as usize;
            prop_assert_eq!(h.strands.iter().map(Vec::len).sum::<usize>(), points);
            prop_assert!(h.strands.iter().flatten().flatten().all(|c| c.is_finite()));
            if let Some(t) = &h.thickness {
                prop_assert_eq!(t.len(), points);
            }
        }
    }
}
