//! Will the export fit? The bytes an export writes, bounded from above before anything is
//! simulated, against the free space of the output's disk: `export --seconds 1e6` of the Short
//! style would write 57.6 TB of `.hair`, and must be refused at once, not after filling the
//! disk.

use std::path::Path;

use super::export::{ExportFormat, ExportOptions, SUBDIVISIONS};
use super::usda::MAX_VEC3_BYTES;
use crate::error::BadInput;
use crate::model::HairModel;

/// Points per exported strand: K nodes smoothed with `SUBDIVISIONS` points per span (the
/// pipeline's Catmull-Rom keeps fewer than three nodes as they are).
pub fn points_per_strand(k: usize) -> u64 {
    if k >= 3 {
        ((k - 1) * SUBDIVISIONS + 1) as u64
    } else {
        k as u64
    }
}

/// At most how many bytes `frames` exported frames of `model` take in `format`.
pub fn bound(format: ExportFormat, model: &HairModel, frames: u64, structure: bool) -> u64 {
    let n = model.strands.len() as u64;
    let p = points_per_strand(model.k);
    let per_frame = match format {
        // The 128-byte header, u16 segments per strand, 3 f32 per point.
        ExportFormat::Hair => 128 + 2 * n + 12 * n * p,
        // The 160-byte header, 32 vertices of 4 f32 per strand.
        ExportFormat::Tfx => 160 + 16 * n * crate::style::tfx_write::TFX_VERTICES as u64,
        // Every point as text (`(x, y, z), `), the time code and the extent; with the
        // structure, every node of the finest level as a point, a width and a colour, and as
        // a segment of two points, two widths and a colour.
        ExportFormat::Usd => {
            let nodes = if structure {
                model.levels.last().map_or(0, |l| l.rest_pos.len()) as u64
            } else {
                0
            };
            let node = 3 * (MAX_VEC3_BYTES + 2) + 2 * 17 + 3 * (MAX_VEC3_BYTES + 2);
            n * p * (MAX_VEC3_BYTES + 2) + 2 * (MAX_VEC3_BYTES + 2) + 256 + nodes * node
        }
    };
    // The layer's fixed part: the vertex counts (up to 7 bytes each) and the body.
    let fixed = match format {
        ExportFormat::Usd => 8 * n + 4096 + 256 * model.body.len() as u64 + 200 * frames,
        ExportFormat::Hair | ExportFormat::Tfx => 0,
    };
    per_frame.saturating_mul(frames).saturating_add(fixed)
}

/// Refuses an export whose files cannot fit in the free space where they go.
pub fn check(opts: &ExportOptions, model: &HairModel, frames: u64) -> Result<(), BadInput> {
    let need = bound(opts.format, model, frames, opts.debug_structure);
    let Some(free) = free_bytes(&opts.out) else {
        return Ok(()); // no answer from the file system: the writes will tell
    };
    if need > free {
        return Err(BadInput(format!(
            "--out {}: the {frames} frames to export take up to {}, and only {} are free on \
             that disk: export fewer frames (--seconds, --every)",
            opts.out.display(),
            human(need),
            human(free)
        )));
    }
    Ok(())
}

/// `12.3 GB`.
fn human(bytes: u64) -> String {
    let b = bytes as f64;
    for (unit, size) in [("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)] {
        if b >= size {
            return format!("{:.1} {unit}", b / size);
        }
    }
    format!("{bytes} bytes")
}

/// Bytes an unprivileged writer may still use on the disk of `path` (or of its nearest
/// existing ancestor: the output folder may not exist yet).
fn free_bytes(path: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt as _;
    let mut dir = path;
    while !dir.exists() {
        dir = match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
    let c = std::ffi::CString::new(dir.as_os_str().as_bytes()).ok()?;
    // SAFETY: `c` is a valid NUL-terminated path and `st` a plain struct statvfs fills.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(c.as_ptr(), &mut st) } != 0 {
        return None;
    }
    Some((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
}
