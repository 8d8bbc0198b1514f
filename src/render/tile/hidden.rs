//! The culling tests of the tile pass: whether a box, or one column of a line, lies at or
//! behind the depth from which nothing more shows in every culling block it touches.

use super::{TileBuf, BLOCK, LANES, NARROW_ROWS};
use crate::render::camera::ScreenVertex;
use crate::render::num::{floor_pos, mn, mx};
use crate::render::raster::SegRec;
use crate::simd::cull::Cull;

impl TileBuf {
    /// Whether nothing at view depth `z` or beyond can show in tile-relative box
    /// [x0, x1] × [y0, y1]: every block it touches is opaque, or hidden by the body.
    #[inline(always)]
    pub(super) fn hidden<I: Cull>(&self, x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> bool {
        let last = self.nb - 1;
        let bx0 = (floor_pos(x0) / BLOCK).min(last);
        let bx1 = (floor_pos(x1) / BLOCK).min(last);
        let by0 = (floor_pos(y0) / BLOCK).min(last);
        let by1 = (floor_pos(y1) / BLOCK).min(last);
        if bx1 - bx0 < 4 && by1 - by0 < NARROW_ROWS {
            // At most 4 blocks wide and NARROW_ROWS tall (nearly all boxes: hair hangs, so
            // most segments are steep): each row's blocks from bx0 in one unaligned 4-lane
            // compare (the array has room past its last row), every one of the NARROW_ROWS
            // rows tested (rows repeated where the box has fewer), and no loop or early
            // exit whose outcome the processor would have to guess.
            let want = (1u32 << (bx1 - bx0 + 1)) - 1;
            let mut m = want;
            // One bounds check for the eight reads: the last row's four are in the array.
            let last_at = by1 * self.stride + bx0;
            let close = &self.block_close[..last_at + 4];
            for r in 0..NARROW_ROWS {
                let at = (by0 + r).min(by1) * self.stride + bx0;
                // SAFETY: at ≤ last_at, and `close` holds last_at + 4 values.
                let four = unsafe { &*(close.as_ptr().add(at) as *const [f32; 4]) };
                m &= I::four_hidden(four, z);
            }
            return m == want;
        }
        // Row by row, each row's blocks compared all at once into a bit mask: no loop with a
        // data-dependent trip count per block, on a test made for every binned segment.
        let want = (u32::MAX >> (31 - bx1)) & (u32::MAX << bx0);
        let row = |by: usize| {
            let r = &self.block_close[by * self.stride..(by + 1) * self.stride];
            row_hidden::<I>(r, z)
        };
        if by1 - by0 < 3 {
            // Up to three rows (nearly always): all three tested (rows repeated when there
            // are fewer) and combined, with no loop or early exit whose outcome the processor
            // would have to guess.
            let mid = (by0 + 1).min(by1);
            return row(by0) & row(mid) & row(by1) & want == want;
        }
        (by0..by1 + 1).all(|by| row(by) & want == want)
    }

    /// Whether samples j0..=j1 of column (or row) i are all in opaque or body-hidden blocks
    /// at depth `z`.
    #[inline(always)]
    pub(super) fn column_hidden(&self, at: Column, j0: usize, j1: usize, z: f32) -> bool {
        let (b0, b1) = (j0 / BLOCK, j1 / BLOCK);
        if b1 - b0 < 2 {
            // One or two blocks (nearly always): both read, with no loop whose trip count
            // the processor would have to guess.
            let far = mx(
                self.block_close[at.base + b0 * at.step],
                self.block_close[at.base + b1 * at.step],
            );
            return z >= far;
        }
        let mut far = f32::NEG_INFINITY;
        for jb in b0..b1 + 1 {
            far = mx(far, self.block_close[at.base + jb * at.step]);
        }
        z >= far
    }

    /// Whether the tile pass can skip segment `s` (a line of half-width `half` samples) as
    /// things stand: it draws nothing here whatever the tile holds, or every block it touches
    /// is opaque or hidden by the body at its nearest depth. Blocks only ever close, so a
    /// segment culled now would be refused by every sample later too.
    #[inline(always)]
    pub(super) fn culls<I: Cull>(&self, s: &SegRec, half: f32) -> bool {
        match cull_box(self.ox, self.oy, &s.a, &s.b, half) {
            Some([lo0, hi0, lo1, hi1, zmin]) => self.hidden::<I>(lo0, hi0, lo1, hi1, zmin),
            None => true,
        }
    }
}

/// The box that the culling tests use for segment a–b in the tile at `(ox, oy)`: tile-relative
/// samples [lo0, hi0] × [lo1, hi1] within the line's reach, and its nearest depth; `None` if
/// the tile pass draws nothing of it whatever the tile holds (no length along its major axis,
/// or entirely left of or above the tile).
#[inline(always)]
fn cull_box(ox: i32, oy: i32, a: &ScreenVertex, b: &ScreenVertex, half: f32) -> Option<[f32; 5]> {
    let (ox, oy) = (ox as f32, oy as f32);
    let (ax, ay, bx, by) = (a.x - ox, a.y - oy, b.x - ox, b.y - oy);
    let d = mx((bx - ax).abs(), (by - ay).abs());
    let r = half * 1.5 + 1.0;
    let (hi0, hi1) = (mx(ax, bx) + r, mx(ay, by) + r);
    // A NaN length draws nothing either.
    if d < 1e-6 || d.is_nan() || hi0 < 0.0 || hi1 < 0.0 {
        return None;
    }
    Some([mn(ax, bx) - r, hi0, mn(ay, by) - r, hi1, mn(a.z, b.z)])
}

/// Bit k set where depth `z` is at or behind `row[k]` (`row.len()` a multiple of LANES, at
/// most 32).
#[inline(always)]
fn row_hidden<I: Cull>(row: &[f32], z: f32) -> u32 {
    let mut mask = 0;
    for (k, chunk) in row.chunks_exact(LANES).enumerate() {
        let chunk: &[f32; LANES] = chunk.try_into().expect("chunks_exact gives LANES");
        mask |= I::chunk_hidden(chunk, z) << (k * LANES);
    }
    mask
}

/// Where one column (x-major) or row (y-major) of samples lies in the culling blocks.
#[derive(Debug, Clone, Copy)]
pub(super) struct Column {
    /// Block of the column's sample 0.
    pub(super) base: usize,
    /// Block step per BLOCK samples along the column.
    pub(super) step: usize,
}

impl Column {
    #[inline(always)]
    pub(super) fn new(x_major: bool, i: usize, nb: usize) -> Column {
        if x_major {
            Column {
                base: i / BLOCK,
                step: nb,
            }
        } else {
            Column {
                base: (i / BLOCK) * nb,
                step: 1,
            }
        }
    }

    /// The block of sample `j` of the column.
    #[inline(always)]
    pub(super) fn block(self, j: usize) -> usize {
        self.base + (j / BLOCK) * self.step
    }
}
