//! `.hair` (Cem Yuksel) and `.data` (USC-HairSalon) files: exact round trips, files from an
//! independent writer that follows the published layout, every corruption located by byte
//! offset, the TressFX resampling, and random bytes.

mod hair_common;

use hair_common::*;
use proptest::prelude::*;
use std::path::Path;
use wisptree::style::hair_file::{encode_hair, load_hair, parse_hair, write_hair};
use wisptree::style::hairsalon::{encode_hairsalon, parse_hairsalon};
use wisptree::style::tfx::parse_tfx;
use wisptree::style::tfx_write::{encode_tfx, resample_arc_length};

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

#[test]
fn tfx_resampling_is_uniform_in_arc_length() {
    // An L of length 3 (1 along x, then 2 along y): 4 samples land at arc 0, 1, 2, 3.
    let l = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 2.0, 0.0]];
    let mut out = Vec::new();
    resample_arc_length(&l, 4, &mut out);
    assert_eq!(
        out,
        [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 2.0, 0.0]
        ]
    );
    // Seven samples: every 0.5 of arc, across the corner.
    out.clear();
    resample_arc_length(&l, 7, &mut out);
    assert_eq!(out[1], [0.5, 0.0, 0.0]);
    assert_eq!(out[3], [1.0, 0.5, 0.0]);
    // Degenerate strands give copies of the root.
    out.clear();
    resample_arc_length(&[[1.0, 2.0, 3.0]; 3], 5, &mut out);
    assert_eq!(out, vec![[1.0, 2.0, 3.0]; 5]);
    // Mixed lengths become one 32-vertex TressFX file our reader takes, roots and tips kept.
    let strands = strands_of(&[2, 7, 40, 3]);
    let tfx = parse_tfx(Path::new("e.tfx"), &encode_tfx(&strands)).unwrap();
    assert!(tfx.iter().all(|s| s.len() == 32));
    for (t, s) in tfx.iter().zip(&strands) {
        assert_eq!(t[0], s[0].map(f64::from));
        assert_eq!(t[31], s[s.len() - 1].map(f64::from));
    }
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
