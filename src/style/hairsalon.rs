//! USC-HairSalon's hairstyle format (`.data`, Hu et al. 2015, "Single-View Hair Modeling Using
//! a Hairstyle Database", whose database ships in it).
//!
//! Little-endian: an i32 strand count, then per strand an i32 vertex count and that many
//! f32 (x, y, z) triples, root first. The database has one strand per scalp sample, and a strand
//! of a single vertex marks a root from which no hair grows: such strands are skipped and
//! counted.
//!
//! As for `.hair`, every count is untrusted: sizes are checked against the file's length before
//! anything is allocated, and errors name the byte offset.

use super::StyleError;
use std::path::Path;

/// The strands of a `.data` file, in file units, and how many one-point strands were skipped.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct HairSalonFile {
    /// Every strand with at least two points, root first, in file order.
    pub strands: Vec<Vec<[f32; 3]>>,
    /// One-point strands ("no hair grown from this root"), skipped.
    pub skipped_one_point: usize,
}

/// Reads a `.data` file.
pub fn load_hairsalon(path: &Path) -> Result<HairSalonFile, StyleError> {
    let bytes = std::fs::read(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_hairsalon(path, &bytes)
}

/// Parses the bytes of a `.data` file; `path` only names the file in errors.
pub fn parse_hairsalon(path: &Path, bytes: &[u8]) -> Result<HairSalonFile, StyleError> {
    let err = |msg: String| StyleError::StrandFile {
        path: path.to_path_buf(),
        msg,
    };
    let count = read_i32(bytes, 0).ok_or_else(|| {
        err(format!(
            "truncated at byte {}: the strand count needs 4 bytes",
            bytes.len()
        ))
    })?;
    if count <= 0 {
        return Err(err(format!(
            "byte 0: the strand count is {count}, expected a positive number"
        )));
    }
    let count = count as usize;
    // Each strand takes at least its 4-byte vertex count: never reserve more than that.
    let mut out = HairSalonFile {
        strands: Vec::with_capacity(count.min(bytes.len() / 4)),
        skipped_one_point: 0,
    };
    let mut at = 4usize;
    for s in 0..count {
        let n = read_i32(bytes, at).ok_or_else(|| {
            err(format!(
                "truncated at byte {}: strand {s} of {count} has no vertex count (needed at byte \
                 {at})",
                bytes.len()
            ))
        })?;
        if n <= 0 {
            return Err(err(format!(
                "byte {at}: strand {s} has {n} points, expected at least one"
            )));
        }
        let n = n as usize;
        let start = at + 4;
        let end = n.checked_mul(12).and_then(|b| b.checked_add(start));
        let Some(end) = end.filter(|&e| e <= bytes.len()) else {
            return Err(err(format!(
                "truncated at byte {}: strand {s} has {n} points × 12 bytes from byte {start} \
                 (room for {} whole points)",
                bytes.len(),
                bytes.len().saturating_sub(start) / 12
            )));
        };
        let mut strand = Vec::with_capacity(n);
        for (v, c) in bytes[start..end].chunks_exact(12).enumerate() {
            let p = [0, 4, 8].map(|o| f32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]]));
            if !p.iter().all(|x| x.is_finite()) {
                return Err(err(format!(
                    "byte {}: strand {s} point {v} has a non-finite coordinate {p:?}",
                    start + 12 * v
                )));
            }
            strand.push(p);
        }
        if n == 1 {
            out.skipped_one_point += 1;
        } else {
            out.strands.push(strand);
        }
        at = end;
    }
    if at != bytes.len() {
        return Err(err(format!(
            "counts do not add up: the {count} strands end at byte {at}, the file has {} bytes",
            bytes.len()
        )));
    }
    if out.strands.is_empty() {
        return Err(err(format!(
            "all {count} strands have a single point: no hair is grown from any root"
        )));
    }
    Ok(out)
}

/// Encodes strands as a `.data` file (for tests and conversions). Every strand must have at
/// least one point; fails with `InvalidInput` when a count does not fit an i32.
pub fn encode_hairsalon(strands: &[Vec<[f32; 3]>]) -> std::io::Result<Vec<u8>> {
    let count = |n: usize| {
        i32::try_from(n).map_err(|_| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("{n} does not fit an i32"),
            )
        })
    };
    let total: usize = strands.iter().map(Vec::len).sum();
    let mut out = Vec::with_capacity(4 + 4 * strands.len() + 12 * total);
    out.extend_from_slice(&count(strands.len())?.to_le_bytes());
    for strand in strands {
        out.extend_from_slice(&count(strand.len())?.to_le_bytes());
        for c in strand.iter().flatten() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    Ok(out)
}

fn read_i32(bytes: &[u8], at: usize) -> Option<i32> {
    let b = bytes.get(at..at.checked_add(4)?)?;
    Some(i32::from_le_bytes(b.try_into().ok()?))
}
