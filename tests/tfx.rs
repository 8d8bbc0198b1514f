//! TressFX import: the real ponytail and test assets, version 4 round trips, and every kind of
//! corrupt input giving the right error (never a panic).

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use wisptree::style::tfx::{load_project_spheres, load_tfx, parse_tfx, write_tfx_v4};
use wisptree::style::StyleError;

#[path = "common/shared.rs"]
mod shared;

/// The shared TressFX data folder; the test fails, saying how to get it, when it is absent.
fn data_dir() -> PathBuf {
    shared::shared_path("data/tressfx")
}

/// The message of a `StyleError::Tfx`, or a test failure naming what came instead.
fn tfx_msg(r: Result<Vec<Vec<[f64; 3]>>, StyleError>) -> String {
    match r {
        Err(StyleError::Tfx { msg, .. }) => msg,
        Err(e) => panic!("expected a Tfx error, got {e}"),
        Ok(s) => panic!("expected a Tfx error, got {} strands", s.len()),
    }
}

fn project_msg(r: Result<Vec<wisptree::style::Sphere>, StyleError>) -> String {
    match r {
        Err(StyleError::Tfx { msg, .. }) => msg,
        Err(e) => panic!("expected a Tfx error, got {e}"),
        Ok(s) => panic!("expected a Tfx error, got {} spheres", s.len()),
    }
}

/// Little-endian f32 at `at`, decoded independently of the crate's parser.
fn f32_le(bytes: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
}

/// Distance from `p` to the surface of the nearest sphere.
fn to_nearest_sphere(p: [f64; 3], spheres: &[([f64; 3], f64)]) -> f64 {
    spheres
        .iter()
        .map(|(c, r)| {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - r
        })
        .fold(f64::INFINITY, f64::min)
}

/// A small deterministic set of ragged-free strands with distinct coordinates.
fn sample_strands(strands: usize, vertices: usize) -> Vec<Vec<[f32; 3]>> {
    (0..strands)
        .map(|s| {
            (0..vertices)
                .map(|v| {
                    let (s, v) = (s as f32, v as f32);
                    [s * 0.5 - 3.25, 92.0 - v * 1.75 + s * 0.01, -v * 0.125 + s]
                })
                .collect()
        })
        .collect()
}

/// A valid version 3.0 file built by hand (header fields at the documented offsets).
fn v3_bytes(strands: &[Vec<[f32; 3]>]) -> Vec<u8> {
    let mut b = vec![0u8; 296];
    b[0..4].copy_from_slice(&3.0f32.to_le_bytes());
    b[4..8].copy_from_slice(&(strands.len() as u32).to_le_bytes());
    b[8..12].copy_from_slice(&(strands[0].len() as u32).to_le_bytes());
    b[144..148].copy_from_slice(&296u32.to_le_bytes());
    for p in strands.iter().flatten() {
        for c in p {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b
}

#[test]
fn ponytail_parts_load_root_first() {
    let dir = data_dir();
    // The project's spheres (cm) around the head: roots lie on the scalp, tips hang away.
    let spheres = [
        ([-0.095, 92.000, 9.899], 26.5),
        ([-0.405, 93.707, -5.111], 24.113),
        ([-0.072, 68.548, -10.561], 25.500),
    ];
    let mut total = 0;
    for (part, count) in [
        ("front_top", 876),
        ("side", 3066),
        ("back", 517),
        ("tail", 255),
    ] {
        let path = dir.join(format!("ponytail/{part}.tfx"));
        let strands = load_tfx(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(strands.len(), count, "{part}: strand count");
        assert!(strands.iter().all(|s| s.len() == 16), "{part}: 16 vertices");
        // The first and last vertex match the raw bytes at the documented positions.
        let bytes = std::fs::read(&path).unwrap();
        for (i, c) in strands[0][0].iter().enumerate() {
            assert_eq!(
                *c,
                f32_le(&bytes, 296 + 4 * i) as f64,
                "{part}: first vertex"
            );
        }
        let last = bytes.len() - 12;
        for (i, c) in strands[count - 1][15].iter().enumerate() {
            assert_eq!(
                *c,
                f32_le(&bytes, last + 4 * i) as f64,
                "{part}: last vertex"
            );
        }
        // Root first: on average roots are nearer the head than tips.
        let mean = |idx: usize| {
            strands
                .iter()
                .map(|s| to_nearest_sphere(s[idx], &spheres))
                .sum::<f64>()
                / count as f64
        };
        let (root, tip) = (mean(0), mean(15));
        assert!(
            root < tip,
            "{part}: roots {root} cm, tips {tip} cm from the head"
        );
        // Centimetres: the whole style spans a human head and ponytail (< 2 m, y mostly > 0).
        for p in strands.iter().flatten() {
            assert!(p.iter().all(|c| c.abs() < 200.0), "{part}: {p:?} not in cm");
        }
        total += count;
    }
    assert_eq!(total, 4714);
}

#[test]
fn ponytail_project_spheres_in_metres() {
    let dir = data_dir();
    let path = dir.join("ponytail/ponytail.tfxproj");
    let want = [
        [-0.095, 92.000, 9.899, 26.5],
        [-0.405, 93.707, -5.111, 24.113],
        [-0.072, 68.548, -10.561, 25.500],
    ];
    for translate in [[0.0, 0.0, 0.0], [0.1, -0.92, 0.25]] {
        let spheres = load_project_spheres(&path, 0.01, translate).unwrap();
        assert_eq!(spheres.len(), 3);
        for (s, w) in spheres.iter().zip(want) {
            for a in 0..3 {
                let expect = w[a] * 0.01 + translate[a];
                assert!((s.center[a] - expect).abs() < 1e-12, "{s:?} vs {w:?}");
            }
            assert!((s.radius - w[3] * 0.01).abs() < 1e-12, "{s:?} vs {w:?}");
        }
    }
}

#[test]
fn test_hair_loads_10027_strands_of_4() {
    let dir = data_dir();
    let strands = load_tfx(&dir.join("TestHair1.tfx")).unwrap();
    assert_eq!(strands.len(), 10_027);
    assert!(strands.iter().all(|s| s.len() == 4));
    // Distinct strands: a parser that repeated one strand would fail this.
    assert_ne!(strands[0], strands[10_026]);
}

#[test]
fn hand_built_v3_parses_exactly() {
    let strands = sample_strands(5, 4);
    let parsed = parse_tfx(Path::new("mem.tfx"), &v3_bytes(&strands)).unwrap();
    let want: Vec<Vec<[f64; 3]>> = strands
        .iter()
        .map(|s| s.iter().map(|p| p.map(f64::from)).collect())
        .collect();
    assert_eq!(parsed, want);
}

#[test]
fn v4_round_trip_and_w() {
    let strands = sample_strands(7, 8);
    let bytes = write_tfx_v4(&strands);
    // Layout per FORMAT.md: 160-byte header, then x y z w per vertex.
    assert_eq!(bytes.len(), 160 + 7 * 8 * 16);
    assert_eq!(f32_le(&bytes, 0), 4.0);
    assert_eq!(u32::from_le_bytes(bytes[4..8].try_into().unwrap()), 7);
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 8);
    assert_eq!(u32::from_le_bytes(bytes[12..16].try_into().unwrap()), 160);
    for s in 0..7 {
        for v in 0..8 {
            let w = f32_le(&bytes, 160 + (s * 8 + v) * 16 + 12);
            let want = if v == 0 { 0.0 } else { 1.0 };
            assert_eq!(w, want, "strand {s} vertex {v}: w (0 pinned root, 1 free)");
        }
    }
    // Through a real file too, so load_tfx is exercised on version 4.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("round.tfx");
    std::fs::write(&path, &bytes).unwrap();
    let parsed = load_tfx(&path).unwrap();
    assert_eq!(parsed.len(), 7);
    for (p, s) in parsed.iter().zip(&strands) {
        let s: Vec<[f64; 3]> = s.iter().map(|q| q.map(f64::from)).collect();
        assert_eq!(*p, s, "xyz survive the round trip exactly, w is dropped");
    }
}

#[test]
fn truncated_files_say_how_much_is_missing() {
    let bytes = write_tfx_v4(&sample_strands(3, 4));
    let full = bytes.len(); // 160 + 192 = 352
                            // Cut inside the positions: names needed and actual size.
    let msg = tfx_msg(parse_tfx(Path::new("t.tfx"), &bytes[..full - 5]));
    assert!(msg.contains("truncated"), "{msg}");
    assert!(msg.contains(&full.to_string()), "{msg}");
    assert!(msg.contains(&(full - 5).to_string()), "{msg}");
    assert!(msg.contains("room for 2 whole strands"), "{msg}");
    // Cut inside the header.
    let msg = tfx_msg(parse_tfx(Path::new("t.tfx"), &bytes[..100]));
    assert!(msg.contains("header needs 160 bytes"), "{msg}");
    assert!(msg.contains("100"), "{msg}");
    let v3 = v3_bytes(&sample_strands(2, 4));
    let msg = tfx_msg(parse_tfx(Path::new("t.tfx"), &v3[..200]));
    assert!(msg.contains("header needs 296 bytes"), "{msg}");
    // Shorter than the version field.
    let msg = tfx_msg(parse_tfx(Path::new("t.tfx"), &bytes[..3]));
    assert!(msg.contains("truncated"), "{msg}");
}

#[test]
fn truncated_real_file() {
    let dir = data_dir();
    let bytes = std::fs::read(dir.join("ponytail/tail.tfx")).unwrap();
    let cut = 296 + 12 * 16 * 100 + 7; // 100 whole strands and a bit
    let msg = tfx_msg(parse_tfx(Path::new("tail.tfx"), &bytes[..cut]));
    assert!(msg.contains("255 strands"), "{msg}");
    assert!(msg.contains("room for 100 whole strands"), "{msg}");
}

#[test]
fn wrong_version_is_named() {
    let mut bytes = write_tfx_v4(&sample_strands(2, 4));
    bytes[0..4].copy_from_slice(&5.0f32.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("v.tfx"), &bytes));
    assert!(msg.contains("unknown version 5"), "{msg}");
    assert!(msg.contains("3.0 or 4.0"), "{msg}");
    // An integer 3 instead of the float 3.0 is not a version either.
    bytes[0..4].copy_from_slice(&3u32.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("v.tfx"), &bytes));
    assert!(msg.contains("unknown version"), "{msg}");
}

#[test]
fn strand_count_that_does_not_fit() {
    let mut bytes = v3_bytes(&sample_strands(3, 4));
    bytes[4..8].copy_from_slice(&4u32.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("c.tfx"), &bytes));
    assert!(msg.contains("4 strands × 4 vertices × 12 bytes"), "{msg}");
    assert!(msg.contains(&(296 + 4 * 4 * 12).to_string()), "{msg}");
    // A huge count must not overflow or allocate.
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("c.tfx"), &bytes));
    assert!(msg.contains(&u32::MAX.to_string()), "{msg}");
}

#[test]
fn bad_header_fields() {
    let good = v3_bytes(&sample_strands(3, 4));
    let with = |at: usize, v: u32| {
        let mut b = good.clone();
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        tfx_msg(parse_tfx(Path::new("h.tfx"), &b))
    };
    assert!(with(4, 0).contains("0 strands"));
    let msg = with(8, 0);
    assert!(msg.contains("0 vertices"), "{msg}");
    let msg = with(8, 1);
    assert!(msg.contains("1 vertices"), "{msg}");
    let msg = with(8, 100_000);
    assert!(msg.contains("100000 vertices"), "{msg}");
    let msg = with(144, 0);
    assert!(msg.contains("no vertex positions"), "{msg}");
    let msg = with(144, 40);
    assert!(msg.contains("inside the 296-byte header"), "{msg}");
    let msg = with(144, 1_000_000);
    assert!(msg.contains("start at byte 1000000"), "{msg}");
}

#[test]
fn non_finite_coordinate_is_located() {
    let mut bytes = v3_bytes(&sample_strands(3, 4));
    let at = 296 + (4 + 2) * 12 + 4; // strand 1, vertex 2, y
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("n.tfx"), &bytes));
    assert!(msg.contains("strand 1 vertex 2"), "{msg}");
    assert!(msg.contains("non-finite"), "{msg}");
    let mut bytes = write_tfx_v4(&sample_strands(2, 4));
    bytes[160..164].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let msg = tfx_msg(parse_tfx(Path::new("n.tfx"), &bytes));
    assert!(msg.contains("strand 0 vertex 0"), "{msg}");
}

#[test]
fn missing_and_empty_files() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.tfx");
    match load_tfx(&missing) {
        Err(StyleError::Io { path, error }) => {
            assert_eq!(path, missing);
            assert_eq!(error.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("expected an Io error, got {other:?}"),
    }
    let empty = dir.path().join("empty.tfx");
    std::fs::write(&empty, b"").unwrap();
    let err = load_tfx(&empty).unwrap_err();
    let shown = err.to_string();
    assert!(shown.contains("empty.tfx"), "{shown}");
    assert!(tfx_msg(Err(err)).contains("empty"));
    // The project loader: missing file is an Io error too.
    assert!(matches!(
        load_project_spheres(&dir.path().join("nope.tfxproj"), 0.01, [0.0; 3]),
        Err(StyleError::Io { .. })
    ));
}

#[test]
fn project_parsing() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    // Comments, CRLF, commas, tabs, and other keywords are fine.
    let ok = write(
        "ok.tfxproj",
        "version 3.0\r\n# collision_sphere 9 9 9 9\r\nfoo.tfx 4 0.4 5.0 foo.tfxsim foo\r\n\
         collision_sphere\t1, 2, 3, 4 # trailing comment\r\n",
    );
    let s = load_project_spheres(&ok, 2.0, [0.5, 0.0, 0.0]).unwrap();
    assert_eq!(s.len(), 1);
    assert_eq!(s[0].center, [2.5, 4.0, 6.0]);
    assert_eq!(s[0].radius, 8.0);
    // No spheres is allowed (TressFX makes them optional).
    let none = write("none.tfxproj", "version 3.0\nproject_name x\n");
    assert!(load_project_spheres(&none, 0.01, [0.0; 3])
        .unwrap()
        .is_empty());

    let bad = |name: &str, text: &str| {
        project_msg(load_project_spheres(&write(name, text), 0.01, [0.0; 3]))
    };
    let msg = bad("few.tfxproj", "version 3.0\n\ncollision_sphere 1 2 3\n");
    assert!(msg.contains("line 3") && msg.contains("got 3"), "{msg}");
    let msg = bad(
        "word.tfxproj",
        "collision_sphere 1 2 3 4\ncollision_sphere 1 x 3 4\n",
    );
    assert!(msg.contains("line 2") && msg.contains("`x`"), "{msg}");
    let msg = bad("nan.tfxproj", "collision_sphere 1 2 NaN 4\n");
    assert!(msg.contains("line 1") && msg.contains("z"), "{msg}");
    let msg = bad("neg.tfxproj", "\ncollision_sphere 1 2 3 -4\n");
    assert!(msg.contains("line 2") && msg.contains("radius"), "{msg}");
    let msg = bad("empty.tfxproj", "  \n");
    assert!(msg.contains("empty"), "{msg}");
    let bin = dir.path().join("bin2.tfxproj");
    std::fs::write(&bin, b"version 3.0\ncollision_sphere \xff\xfe\n").unwrap();
    let msg = project_msg(load_project_spheres(&bin, 0.01, [0.0; 3]));
    assert!(msg.contains("line 2") && msg.contains("UTF-8"), "{msg}");
}

#[test]
fn seeded_corruption_never_panics() {
    // Every truncation of a valid file is an error, never a panic or a short read.
    let valid = write_tfx_v4(&sample_strands(3, 4));
    for len in 0..valid.len() {
        assert!(
            parse_tfx(Path::new("cut.tfx"), &valid[..len]).is_err(),
            "len {len}"
        );
    }
    let valid = v3_bytes(&sample_strands(3, 4));
    for len in 0..valid.len() {
        assert!(
            parse_tfx(Path::new("cut.tfx"), &valid[..len]).is_err(),
            "len {len}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = parse_tfx(Path::new("r.tfx"), &bytes);
    }

    #[test]
    fn mutated_headers_never_panic(
        v4 in any::<bool>(),
        edits in proptest::collection::vec((0usize..400, any::<u8>()), 1..12),
        cut in 0usize..500,
    ) {
        let strands = sample_strands(4, 4);
        let mut bytes = if v4 { write_tfx_v4(&strands) } else { v3_bytes(&strands) };
        for (at, b) in edits {
            if let Some(x) = bytes.get_mut(at) {
                *x = b;
            }
        }
        bytes.truncate(cut.max(1));
        if let Ok(s) = parse_tfx(Path::new("m.tfx"), &bytes) {
            // Whatever parses must be consistent with the header it came from.
            prop_assert!(!s.is_empty());
            prop_assert!(s.iter().all(|x| x.len() == s[0].len()));
            prop_assert!(s.iter().flatten().flatten().all(|c| c.is_finite()));
        }
    }
}
