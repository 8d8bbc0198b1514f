//! TressFX export: strands of any lengths resampled to one power-of-two vertex count, written
//! as a version 4.0 `.tfx` (layout: `../shared/data/tressfx/FORMAT.md`).

use std::path::Path;

use super::tfx::write_tfx_v4;

/// Vertices per strand in exported `.tfx` files. TressFX needs the same power-of-two count on
/// every strand (its simulation runs one GPU thread group per strand); 32 keeps the smoothed
/// strands' shape (wisptree's K is 12 to 16, smoothed to 2K − 1 points).
pub const TFX_VERTICES: usize = 32;

/// Appends `n ≥ 2` points spaced uniformly in arc length along `strand` (root and tip kept
/// exactly). A strand of one point, or of zero length, gives `n` copies of its root.
pub fn resample_arc_length(strand: &[[f32; 3]], n: usize, out: &mut Vec<[f32; 3]>) {
    let Some(&root) = strand.first() else {
        return;
    };
    let p = |i: usize| strand[i].map(f64::from);
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let total: f64 = (1..strand.len()).map(|i| dist(p(i - 1), p(i))).sum();
    if strand.len() < 2 || total <= 0.0 || n < 2 {
        out.extend(std::iter::repeat_n(root, n));
        return;
    }
    let last = strand.len() - 1;
    let (mut seg, mut seg_start) = (0usize, 0.0f64);
    for k in 0..n {
        if k == n - 1 {
            out.push(strand[last]);
            break;
        }
        let target = total * k as f64 / (n - 1) as f64;
        let mut len = dist(p(seg), p(seg + 1));
        while seg + 1 < last && seg_start + len < target {
            seg_start += len;
            seg += 1;
            len = dist(p(seg), p(seg + 1));
        }
        let t = if len > 0.0 {
            ((target - seg_start) / len).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (a, b) = (p(seg), p(seg + 1));
        out.push([0, 1, 2].map(|c| (a[c] + (b[c] - a[c]) * t) as f32));
    }
}

/// Encodes strands as a version 4.0 `.tfx`, each resampled to [`TFX_VERTICES`] vertices.
pub fn encode_tfx(strands: &[Vec<[f32; 3]>]) -> Vec<u8> {
    let resampled: Vec<Vec<[f32; 3]>> = strands
        .iter()
        .map(|s| {
            let mut out = Vec::with_capacity(TFX_VERTICES);
            resample_arc_length(s, TFX_VERTICES, &mut out);
            out
        })
        .collect();
    write_tfx_v4(&resampled)
}

/// Writes strands to a `.tfx` file (see [`encode_tfx`]). Strands with no point are an
/// `InvalidInput` error (the format cannot hold them).
pub fn write_tfx(path: &Path, strands: &[Vec<[f32; 3]>]) -> std::io::Result<()> {
    if let Some(s) = strands.iter().position(Vec::is_empty) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("strand {s} has no point"),
        ));
    }
    std::fs::write(path, encode_tfx(strands))
}
