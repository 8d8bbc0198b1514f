//! Shared by the `.hair` / `.data` tests: an independent writer and reader that follow the
//! published HAIR layout, fixtures, and the catalogue of corrupt files.
#![allow(dead_code)]

use wisptree::style::StyleError;

// ---------------------------------------------------------------------------------------------
// An independent writer and reader, straight from the format's description: 128-byte header
// (signature, u32 strands, u32 points, u32 flags, u32 default segments, f32 thickness, f32
// transparency, 3×f32 colour, 88 bytes of info), then segments (u16), points (3×f32),
// thickness (f32), transparency (f32), colour (3×f32), each only when its flag bit is set.

/// Which optional arrays the independent writer puts in.
#[derive(Debug, Clone, Copy)]
pub struct Arrays {
    pub segments: bool,
    pub thickness: bool,
    pub transparency: bool,
    pub color: bool,
}

pub fn le32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

pub fn lef(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Per-point values the independent writer stores, derived from the point index.
pub fn thickness_of(i: usize) -> f32 {
    0.01 * (1 + i) as f32
}
pub fn transparency_of(i: usize) -> f32 {
    (i % 7) as f32 / 7.0
}
pub fn color_of(i: usize) -> [f32; 3] {
    [(i % 3) as f32 / 3.0, 0.5, 1.0 - (i % 5) as f32 / 5.0]
}

/// A `.hair` file laid out by hand. Without a segments array every strand must have
/// `d_segments + 1` points.
pub fn spec_hair(strands: &[Vec<[f32; 3]>], a: Arrays, info: &[u8]) -> Vec<u8> {
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
pub fn spec_read(b: &[u8]) -> Vec<Vec<[f32; 3]>> {
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
pub fn strands_of(lens: &[usize]) -> Vec<Vec<[f32; 3]>> {
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

pub fn bits(s: &[Vec<[f32; 3]>]) -> Vec<Vec<[u32; 3]>> {
    s.iter()
        .map(|p| p.iter().map(|q| q.map(f32::to_bits)).collect())
        .collect()
}

/// The message of a file error, or a test failure naming what came instead.
pub fn msg<T: std::fmt::Debug>(r: Result<T, StyleError>) -> String {
    match r {
        Err(StyleError::StrandFile { msg, .. }) => msg,
        other => panic!("expected a file error, got {other:?}"),
    }
}

pub fn victim() -> Vec<u8> {
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
pub fn hair_corruptions() -> Vec<(&'static str, Vec<u8>, &'static str)> {
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
