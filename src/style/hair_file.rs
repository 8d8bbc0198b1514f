//! Cem Yuksel's HAIR file format (`.hair`, cemyuksel.com/research/hairmodels, "HAIR File
//! Format Specification"): reader and writer.
//!
//! Little-endian. A 128-byte header — bytes 0–3 `"HAIR"`, 4–7 u32 strands, 8–11 u32 total
//! points, 12–15 u32 bit array of the arrays present (bit 0 segments, 1 points, 2 thickness,
//! 3 transparency, 4 colour, 5–31 reserved and 0), 16–19 u32 default segments per strand (used
//! without a segments array), 20–23 f32 default thickness, 24–27 f32 default transparency,
//! 28–39 3×f32 default colour, 40–127 an 88-byte information string, zero padded — then, in
//! this order and only when its bit is set: segments (u16 per strand: its points − 1), points
//! (3×f32 per point, strand after strand, root first), thickness (f32 per point), transparency
//! (f32 per point), colour (3×f32 per point). A hair model must have the points array.
//!
//! Every count read from a file is untrusted: sizes are computed with checked arithmetic and
//! compared with the file's length before anything is allocated, so no input can make the
//! parser panic or allocate more than the file justifies. Errors name the byte offset.

use super::StyleError;
use std::path::Path;

/// Length of the header.
pub const HEADER: usize = 128;
/// Bit of the segments array in the header's array flags.
pub const SEGMENTS_BIT: u32 = 1;
/// Bit of the points array.
pub const POINTS_BIT: u32 = 2;
/// Bit of the thickness array.
pub const THICKNESS_BIT: u32 = 4;
/// Bit of the transparency array.
pub const TRANSPARENCY_BIT: u32 = 8;
/// Bit of the colour array.
pub const COLOR_BIT: u32 = 16;
/// Length of the information string at bytes 40..128.
pub const INFO_LEN: usize = 88;
/// Byte offset of the information string.
const INFO_AT: usize = 40;
/// Byte offset of the array flags.
const FLAGS_AT: usize = 12;

/// What the header says when an optional array is absent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HairDefaults {
    /// Segments of every strand (used only without a segments array).
    pub segments: u32,
    /// Thickness of every point.
    pub thickness: f32,
    /// Transparency of every point.
    pub transparency: f32,
    /// Colour (r, g, b) of every point.
    pub color: [f32; 3],
}

/// The contents of a `.hair` file, exactly as stored (f32, file units, no strand dropped).
#[derive(Debug, Clone, PartialEq)]
pub struct HairFile {
    /// Every strand's points, root first. A strand has at least one point (zero segments).
    pub strands: Vec<Vec<[f32; 3]>>,
    /// Per point, strand after strand, when the file has a thickness array.
    pub thickness: Option<Vec<f32>>,
    /// Per point, when the file has a transparency array.
    pub transparency: Option<Vec<f32>>,
    /// Per point (r, g, b), when the file has a colour array.
    pub colors: Option<Vec<[f32; 3]>>,
    /// The header's defaults.
    pub defaults: HairDefaults,
    /// The header's information string, up to its first NUL (lossy UTF-8).
    pub info: String,
}

/// Reads a `.hair` file.
pub fn load_hair(path: &Path) -> Result<HairFile, StyleError> {
    let bytes = std::fs::read(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_hair(path, &bytes)
}

/// Parses the bytes of a `.hair` file; `path` only names the file in errors.
pub fn parse_hair(path: &Path, bytes: &[u8]) -> Result<HairFile, StyleError> {
    let err = |msg: String| StyleError::StrandFile {
        path: path.to_path_buf(),
        msg,
    };
    if bytes.len() < HEADER {
        return Err(err(format!(
            "truncated at byte {}: the header needs {HEADER} bytes",
            bytes.len()
        )));
    }
    if &bytes[0..4] != b"HAIR" {
        return Err(err(format!(
            "byte 0: the signature is {:02x?}, expected \"HAIR\": not a .hair file",
            &bytes[0..4]
        )));
    }
    // The header is long enough for every fixed field (checked above).
    let u32_at = |at: usize| read_u32(bytes, at).unwrap_or(0);
    let f32_at = |at: usize| f32::from_bits(u32_at(at));
    let strands = u32_at(4) as usize;
    let points = u32_at(8) as usize;
    let flags = u32_at(FLAGS_AT);
    let defaults = HairDefaults {
        segments: u32_at(16),
        thickness: f32_at(20),
        transparency: f32_at(24),
        color: [f32_at(28), f32_at(32), f32_at(36)],
    };
    if flags & !31 != 0 {
        return Err(err(format!(
            "byte {FLAGS_AT}: array flags {flags:#x} set reserved bits 5-31 (they must be 0)"
        )));
    }
    if flags & POINTS_BIT == 0 {
        return Err(err(format!(
            "byte {FLAGS_AT}: array flags {flags:#x} have no points array (bit 1), which every \
             hair model needs"
        )));
    }
    if strands == 0 {
        return Err(err("byte 4: the header says the file has 0 strands".into()));
    }
    check_defaults(flags, &defaults).map_err(err)?;

    let (lengths, mut at) =
        strand_lengths(bytes, flags, strands, points, defaults.segments).map_err(err)?;
    let end = array_end(bytes.len(), at, points, 12, "points", "points").map_err(err)?;
    let positions = read_points(&bytes[at..end], at, &lengths, strands, points).map_err(err)?;
    at = end;

    let mut optional = |bit: u32, name: &str, width: usize| {
        if flags & bit == 0 {
            return Ok(None);
        }
        let (values, end) =
            float_array(bytes, at, points, width, name, bit == THICKNESS_BIT).map_err(err)?;
        at = end;
        Ok::<_, StyleError>(Some(values))
    };
    let thickness = optional(THICKNESS_BIT, "thickness", 1)?;
    let transparency = optional(TRANSPARENCY_BIT, "transparency", 1)?;
    let colors = optional(COLOR_BIT, "colour", 3)?
        .map(|c| c.chunks_exact(3).map(|v| [v[0], v[1], v[2]]).collect());
    if at != bytes.len() {
        return Err(err(format!(
            "counts do not add up: the arrays the header announces end at byte {at}, the file \
             has {} bytes",
            bytes.len()
        )));
    }
    let info_bytes = &bytes[INFO_AT..HEADER];
    let info_len = info_bytes.iter().position(|&b| b == 0).unwrap_or(INFO_LEN);
    Ok(HairFile {
        strands: positions,
        thickness,
        transparency,
        colors,
        defaults,
        info: String::from_utf8_lossy(&info_bytes[..info_len]).into_owned(),
    })
}

/// Points per strand, from the segments array or the default segments, checked against the
/// header's point count; and the byte where the points array starts.
fn strand_lengths(
    bytes: &[u8],
    flags: u32,
    strands: usize,
    points: usize,
    default_segments: u32,
) -> Result<(Vec<usize>, usize), String> {
    if flags & SEGMENTS_BIT == 0 {
        let per = default_segments as usize + 1;
        if strands.checked_mul(per) != Some(points) {
            return Err(format!(
                "counts do not add up: {strands} strands (byte 4) × {per} points (default \
                 segments {default_segments} at byte 16, + 1) is not the {points} points of byte 8"
            ));
        }
        // Every strand has `per` points: no array needed.
        return Ok((Vec::new(), HEADER));
    }
    let end = array_end(bytes.len(), HEADER, strands, 2, "segments", "strands")?;
    // Segments + 1 points; a u16 + 1 always fits.
    let lengths: Vec<usize> = bytes[HEADER..end]
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]) as usize + 1)
        .collect();
    let sum: usize = lengths.iter().sum();
    if sum != points {
        return Err(format!(
            "counts do not add up: the segments array (bytes {HEADER}..{end}) gives {sum} \
             points, the header (byte 8) says {points}"
        ));
    }
    Ok((lengths, end))
}

/// An optional per-point array of `width` f32 per point starting at byte `at`: its values
/// (finite, and non-negative if `non_negative`) and the byte after it.
fn float_array(
    bytes: &[u8],
    at: usize,
    points: usize,
    width: usize,
    name: &str,
    non_negative: bool,
) -> Result<(Vec<f32>, usize), String> {
    let end = array_end(bytes.len(), at, points, 4 * width, name, "points")?;
    let mut out = Vec::with_capacity(points * width);
    for (i, c) in bytes[at..end].chunks_exact(4).enumerate() {
        let v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if !v.is_finite() || (non_negative && v < 0.0) {
            return Err(format!(
                "byte {}: {name} of point {} is {v}, expected a finite{} number",
                at + 4 * i,
                i / width,
                if non_negative { ", non-negative" } else { "" }
            ));
        }
        out.push(v);
    }
    Ok((out, end))
}

/// The defaults a file relies on (its optional arrays are absent) must be usable numbers.
fn check_defaults(flags: u32, d: &HairDefaults) -> Result<(), String> {
    if flags & THICKNESS_BIT == 0 && !(d.thickness.is_finite() && d.thickness >= 0.0) {
        return Err(format!(
            "byte 20: default thickness {} is not a finite, non-negative number",
            d.thickness
        ));
    }
    if flags & TRANSPARENCY_BIT == 0 && !d.transparency.is_finite() {
        return Err(format!(
            "byte 24: default transparency {} is not finite",
            d.transparency
        ));
    }
    if flags & COLOR_BIT == 0 {
        if let Some(c) = d.color.iter().position(|c| !c.is_finite()) {
            return Err(format!(
                "byte {}: default colour {:?} is not finite",
                28 + 4 * c,
                d.color
            ));
        }
    }
    Ok(())
}

/// End of an array of `count` items of `size` bytes starting at `at`, if the file holds it.
fn array_end(
    len: usize,
    at: usize,
    count: usize,
    size: usize,
    name: &str,
    items: &str,
) -> Result<usize, String> {
    let end = count.checked_mul(size).and_then(|n| n.checked_add(at));
    match end {
        Some(e) if e <= len => Ok(e),
        _ => Err(format!(
            "truncated at byte {len}: the {name} array of {count} {items} × {size} bytes starts \
             at byte {at} and needs {} bytes (room for {} whole {items})",
            end.map_or_else(|| "more than 2^64".to_string(), |e| e.to_string()),
            (len.saturating_sub(at)) / size
        )),
    }
}

/// Splits the points array (`data`, starting at byte `base` of the file) into strands of
/// `lengths` points (every strand `points / strands` long when `lengths` is empty), checking
/// that every coordinate is finite.
fn read_points(
    data: &[u8],
    base: usize,
    lengths: &[usize],
    strands: usize,
    points: usize,
) -> Result<Vec<Vec<[f32; 3]>>, String> {
    let per = points.checked_div(strands).unwrap_or(0);
    let mut out = Vec::with_capacity(strands);
    let mut chunks = data.chunks_exact(12).enumerate();
    for s in 0..strands {
        let n = lengths.get(s).copied().unwrap_or(per);
        let mut strand = Vec::with_capacity(n);
        for v in 0..n {
            // The array's length was checked against the counts, so every chunk exists.
            let Some((i, c)) = chunks.next() else {
                return Err(format!("the points array ends inside strand {s}"));
            };
            let p = [0, 4, 8].map(|o| f32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]]));
            if !p.iter().all(|x| x.is_finite()) {
                return Err(format!(
                    "byte {}: strand {s} point {v} has a non-finite coordinate {p:?}",
                    base + 12 * i
                ));
            }
            strand.push(p);
        }
        out.push(strand);
    }
    Ok(out)
}

/// Encodes strands as a `.hair` file: a segments array and a points array (thickness,
/// transparency and colour are left to the header's defaults: 1, 0 and white, as the format's
/// reference implementation initialises them). `info` is cut to 87 bytes at a character boundary
/// so that the string stays NUL-terminated for C readers.
///
/// Fails with `InvalidInput` when a strand has no point or more than 65,536 (a u16 of
/// segments), or when the counts do not fit the header's u32 fields.
pub fn encode_hair(strands: &[Vec<[f32; 3]>], info: &str) -> std::io::Result<Vec<u8>> {
    let invalid = |msg: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, msg);
    let mut segments = Vec::with_capacity(strands.len());
    for (s, strand) in strands.iter().enumerate() {
        let seg = strand
            .len()
            .checked_sub(1)
            .and_then(|n| u16::try_from(n).ok())
            .ok_or_else(|| {
                invalid(format!(
                    "strand {s} has {} points; a .hair strand has 1 to 65536",
                    strand.len()
                ))
            })?;
        segments.push(seg);
    }
    let total: usize = strands.iter().map(Vec::len).sum();
    let count = |n: usize| {
        u32::try_from(n).map_err(|_| invalid(format!("{n} does not fit the header's u32")))
    };
    let uniform = segments
        .first()
        .filter(|&&f| segments.iter().all(|&s| s == f));
    let mut out = Vec::with_capacity(HEADER + 2 * strands.len() + 12 * total);
    out.extend_from_slice(b"HAIR");
    out.extend_from_slice(&count(strands.len())?.to_le_bytes());
    out.extend_from_slice(&count(total)?.to_le_bytes());
    out.extend_from_slice(&(SEGMENTS_BIT | POINTS_BIT).to_le_bytes());
    // The default is unused when the segments array is present; a reader that looks at it
    // anyway gets the right value when every strand has the same length.
    out.extend_from_slice(&uniform.map_or(0, |&s| u32::from(s)).to_le_bytes());
    for v in [1.0f32, 0.0, 1.0, 1.0, 1.0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let mut cut = info.len().min(INFO_LEN - 1);
    while !info.is_char_boundary(cut) {
        cut -= 1;
    }
    out.extend_from_slice(&info.as_bytes()[..cut]);
    out.resize(HEADER, 0);
    for s in &segments {
        out.extend_from_slice(&s.to_le_bytes());
    }
    for p in strands.iter().flatten() {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    Ok(out)
}

/// Writes strands to a `.hair` file (see [`encode_hair`]).
pub fn write_hair(path: &Path, strands: &[Vec<[f32; 3]>], info: &str) -> std::io::Result<()> {
    std::fs::write(path, encode_hair(strands, info)?)
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?))
}
