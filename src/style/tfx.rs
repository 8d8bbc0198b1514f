//! TressFX import: strands from `.tfx` files (versions 3.0 and 4.0) and collision spheres from
//! a `.tfxproj` project (layouts: `../shared/data/tressfx/FORMAT.md`).
//!
//! Every size and offset read from a file is untrusted: all arithmetic on them is checked and
//! every read is bounds-checked, so no byte input can make the parser panic or allocate more
//! than the file itself justifies.

use super::{Sphere, StyleError, Vec3};
use std::path::Path;

/// Header length of a version 3.0 file (positions usually start right after it).
const V3_HEADER: usize = 296;
/// Header length of a version 4.0 file.
const V4_HEADER: usize = 160;
/// Byte offset of the vertex-positions offset field in a version 3.0 header.
const V3_POSITIONS_FIELD: usize = 144;
/// Byte offset of the vertex-positions offset field in a version 4.0 header.
const V4_POSITIONS_FIELD: usize = 12;
/// Fewest vertices a strand can have: a root and a tip.
const MIN_VERTICES: u32 = 2;
/// TressFX exporters write 4 to 64 vertices per strand; anything beyond this bound is a corrupt
/// header rather than a real strand, and would only make us allocate for nothing.
const MAX_VERTICES: u32 = 1024;

/// Reads a `.tfx` file (version 3.0 or 4.0): every strand's vertices, root first, in file units.
pub fn load_tfx(path: &Path) -> Result<Vec<Vec<[f64; 3]>>, StyleError> {
    let bytes = std::fs::read(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_tfx(path, &bytes)
}

/// Parses the bytes of a `.tfx` file (version 3.0 or 4.0); `path` only names the file in errors.
///
/// Returns every strand's vertices, root first, in file units. Version 4.0's fourth component
/// `w` (0 on pinned vertices) is not returned: which vertices are pinned is decided by the
/// simulation (the root), not by the file.
pub fn parse_tfx(path: &Path, bytes: &[u8]) -> Result<Vec<Vec<[f64; 3]>>, StyleError> {
    let err = |msg: String| StyleError::Tfx {
        path: path.to_path_buf(),
        msg,
    };
    if bytes.is_empty() {
        return Err(err("the file is empty (0 bytes), not a TressFX file".into()));
    }
    let version = f32_at(bytes, 0).ok_or_else(|| {
        err(format!(
            "truncated: {} bytes, too short for even the version field (4 bytes)",
            bytes.len()
        ))
    })?;
    // The version is written as an exact float, so exact comparison is what identifies it.
    let (header, positions_field, stride, name) = if version == 3.0 {
        (V3_HEADER, V3_POSITIONS_FIELD, 12usize, "3.0")
    } else if version == 4.0 {
        (V4_HEADER, V4_POSITIONS_FIELD, 16usize, "4.0")
    } else {
        return Err(err(format!(
            "unknown version {version} in the header (bytes 0..4 = {:02x?}), expected 3.0 or 4.0",
            &bytes[..4]
        )));
    };
    if bytes.len() < header {
        return Err(err(format!(
            "truncated: a version {name} header needs {header} bytes, the file has {}",
            bytes.len()
        )));
    }
    // Both headers are long enough for these reads (checked just above).
    let strands = u32_at(bytes, 4).unwrap_or(0);
    let vertices = u32_at(bytes, 8).unwrap_or(0);
    let offset = u32_at(bytes, positions_field).unwrap_or(0);
    if strands == 0 {
        return Err(err("the header says the file has 0 strands".into()));
    }
    if !(MIN_VERTICES..=MAX_VERTICES).contains(&vertices) {
        return Err(err(format!(
            "the header says each strand has {vertices} vertices, expected {MIN_VERTICES} to {MAX_VERTICES}"
        )));
    }
    if offset == 0 {
        return Err(err(format!(
            "the header has no vertex positions (their offset, at byte {positions_field}, is 0)"
        )));
    }
    let offset = offset as usize;
    if offset < header {
        return Err(err(format!(
            "the vertex positions offset {offset} lies inside the {header}-byte header"
        )));
    }
    if offset > bytes.len() {
        return Err(err(format!(
            "truncated: the vertex positions start at byte {offset}, the file has {} bytes",
            bytes.len()
        )));
    }
    let strand_bytes = (vertices as usize)
        .checked_mul(stride)
        .ok_or_else(|| err("vertices per strand × vertex size overflows".into()))?;
    let end = (strands as usize)
        .checked_mul(strand_bytes)
        .and_then(|n| n.checked_add(offset));
    let Some(end) = end.filter(|&e| e <= bytes.len()) else {
        let whole = (bytes.len() - offset) / strand_bytes;
        return Err(err(format!(
            "truncated or wrong strand count: {strands} strands × {vertices} vertices × {stride} \
             bytes from offset {offset} need {} bytes, the file has {} (room for {whole} whole \
             strands)",
            end.map_or_else(|| "more than 2^64".to_string(), |e| e.to_string()),
            bytes.len()
        )));
    };
    let positions = &bytes[offset..end];
    let mut out = Vec::with_capacity(strands as usize);
    for (s, strand) in positions.chunks_exact(strand_bytes).enumerate() {
        let mut points = Vec::with_capacity(vertices as usize);
        for (v, vertex) in strand.chunks_exact(stride).enumerate() {
            let p = [
                f32_at(vertex, 0).unwrap_or(f32::NAN),
                f32_at(vertex, 4).unwrap_or(f32::NAN),
                f32_at(vertex, 8).unwrap_or(f32::NAN),
            ];
            if !p.iter().all(|x| x.is_finite()) {
                let at = offset + s * strand_bytes + v * stride;
                return Err(err(format!(
                    "strand {s} vertex {v} (byte {at}): non-finite coordinate {p:?}"
                )));
            }
            points.push(p.map(f64::from));
        }
        out.push(points);
    }
    Ok(out)
}

/// Writes strands as a version 4.0 `.tfx` file: a test and export helper (the simulation only
/// reads TressFX files).
///
/// Every vertex gets `w = 0` on the root (pinned) and `w = 1` elsewhere, as TressFX expects.
/// Only positions are written; the UV, thickness and colour offsets are 0 (absent).
///
/// # Panics
/// If the strands do not all have the same number of vertices (the format cannot express it),
/// or if the counts do not fit the header's `u32` fields; both are caller bugs.
pub fn write_tfx_v4(strands: &[Vec<[f32; 3]>]) -> Vec<u8> {
    let vertices = strands.first().map_or(0, Vec::len);
    assert!(
        strands.iter().all(|s| s.len() == vertices),
        "write_tfx_v4: every strand must have the same number of vertices"
    );
    let count = |n: usize| u32::try_from(n).expect("write_tfx_v4: count does not fit in a u32");
    let mut out = Vec::with_capacity(V4_HEADER + strands.len() * vertices * 16);
    out.extend_from_slice(&4.0f32.to_le_bytes());
    out.extend_from_slice(&count(strands.len()).to_le_bytes());
    out.extend_from_slice(&count(vertices).to_le_bytes());
    // Offsets of positions, per-strand UVs, per-vertex UVs, thickness, colours.
    for off in [V4_HEADER as u32, 0, 0, 0, 0] {
        out.extend_from_slice(&off.to_le_bytes());
    }
    out.resize(V4_HEADER, 0); // the 32 reserved u32
    for strand in strands {
        for (v, p) in strand.iter().enumerate() {
            let w: f32 = if v == 0 { 0.0 } else { 1.0 };
            for c in [p[0], p[1], p[2], w] {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    out
}

/// Reads the collision spheres of a `.tfxproj`, scaled (`scale`, file units → metres) and
/// translated.
///
/// The project is line-oriented text: `#` starts a comment, and each sphere is a line
/// `collision_sphere x y z radius` (file units; commas are accepted between numbers). Every
/// other line (version, part list, mesh, settings) is irrelevant here and skipped. A project
/// without spheres yields an empty list, since TressFX makes them optional.
pub fn load_project_spheres(
    path: &Path,
    scale: f64,
    translate: Vec3,
) -> Result<Vec<Sphere>, StyleError> {
    let bytes = std::fs::read(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let err = |msg: String| StyleError::Tfx {
        path: path.to_path_buf(),
        msg,
    };
    if !(scale.is_finite() && scale > 0.0) {
        return Err(err(format!(
            "the scale must be a positive number, got {scale}"
        )));
    }
    if !translate.iter().all(|x| x.is_finite()) {
        return Err(err(format!(
            "the translation must be finite, got {translate:?}"
        )));
    }
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        err(format!("line {line}: not UTF-8 text"))
    })?;
    if text.trim().is_empty() {
        return Err(err("the project file is empty".into()));
    }
    let mut spheres = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let content = raw.split('#').next().unwrap_or_default();
        let mut words = content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|w| !w.is_empty());
        if words.next() != Some("collision_sphere") {
            continue;
        }
        let words: Vec<&str> = words.collect();
        if words.len() != 4 {
            return Err(err(format!(
                "line {line}: collision_sphere needs 4 numbers (centre x y z, radius), got {}: `{}`",
                words.len(),
                raw.trim()
            )));
        }
        let mut v = [0.0f64; 4];
        for (slot, (word, what)) in v
            .iter_mut()
            .zip(words.iter().zip(["x", "y", "z", "radius"]))
        {
            *slot = word
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    err(format!(
                        "line {line}: collision_sphere {what} `{word}` is not a finite number"
                    ))
                })?;
        }
        if v[3] <= 0.0 {
            return Err(err(format!(
                "line {line}: collision_sphere radius must be positive, got {}",
                v[3]
            )));
        }
        spheres.push(Sphere {
            center: [
                v[0] * scale + translate[0],
                v[1] * scale + translate[1],
                v[2] * scale + translate[2],
            ],
            radius: v[3] * scale,
        });
    }
    Ok(spheres)
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?))
}

fn f32_at(bytes: &[u8], at: usize) -> Option<f32> {
    u32_at(bytes, at).map(f32::from_bits)
}
