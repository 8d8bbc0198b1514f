//! The broad phase: a uniform voxel grid of segment boxes, each pair found once through the minimum corner of its shared cells (AWT §4.1).

use std::ops::Range;

use nalgebra::Vector3;

use crate::simd::boxes::BoxTest;
use crate::simd::dispatch::{Avx2, Portable};
use crate::simd::Level;

use super::*;

/// Upper bound on the number of cells of the dense voxel grid (4 MiB of `u32` offsets), whatever
/// the number of segments: bounds memory when a node flies away.
pub const MAX_CELLS: usize = 1 << 20;

/// Cells allowed per segment: the dense cell array is cleared, counted and scanned every step,
/// so beyond a few cells per segment the scan of empty cells costs more than it prunes.
pub const CELLS_PER_SEGMENT: usize = 8;

/// Cell-list entries reserved per segment by [`HairCollider::with_capacity`].
pub(super) const ITEMS_PER_SEGMENT: usize = 32;

/// Cell side in mean segment lengths (see the module docs).
pub(super) const CELL_IN_SEGMENT_LENGTHS: f64 = 3.0;

/// The mask bits of an item of a cell list (see [`HairCollider`]): bit `k` set when the segment's
/// cell range starts below this cell along axis `k`.
pub(super) const MASK_SHIFT: u32 = 29;

/// The voxel grid of the last [`HairCollider::accumulate`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GridInfo {
    /// World position of the min corner of cell (0, 0, 0), m.
    pub origin: Vector3<f64>,
    /// Side of the cubic cells, m.
    pub cell_size: f64,
    /// Number of cells along x, y, z.
    pub dims: [u32; 3],
}

impl GridInfo {
    /// Cell coordinates of a point, clamped to the grid.
    pub fn cell_of(&self, p: &Vector3<f64>) -> [u32; 3] {
        let mut c = [0u32; 3];
        for k in 0..3 {
            let f = ((p[k] - self.origin[k]) / self.cell_size).floor();
            // `as` saturates (NaN → 0), the min keeps the cell inside the grid.
            c[k] = (f.max(0.0) as u32).min(self.dims[k].saturating_sub(1));
        }
        c
    }

    /// Inclusive cell range `(lo, hi)` of segment `i`: the cells its box, inflated by its radius
    /// (and rounded outwards to f32, as the pair filter sees it), touches.
    pub fn cell_range(
        &self,
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        i: usize,
    ) -> ([u32; 3], [u32; 3]) {
        self.box_cells(&SegBox::new(segs, pos, i))
    }

    pub(super) fn box_cells(&self, b: &SegBox) -> ([u32; 3], [u32; 3]) {
        let (lo, hi) = b.bounds();
        (self.cell_of(&lo), self.cell_of(&hi))
    }
}

/// The grid and the per-segment data, written by the caller, then read by both threads.
#[derive(Default)]
pub(super) struct Broad {
    /// Per segment: inflated box and node slots (the slots read for overlapping boxes).
    pub(super) boxes: Vec<SegBox>,
    /// Per segment: [`Reach::far`] of its box, what the candidate loop compares (hot).
    pub(super) reach: Vec<Reach>,
    /// Per segment: its data for the relative-motion test and the closest points (cold).
    pub(super) pre: Vec<SegPre>,
    /// Per segment: min and max cell coordinates of its box.
    pub(super) lo: Vec<[u32; 3]>,
    pub(super) hi: Vec<[u32; 3]>,
    /// Dense cell offsets into `items` (counting sort), `ncells + 1` entries.
    pub(super) cell_start: Vec<u32>,
    /// Segment index | mask << [`MASK_SHIFT`], grouped by cell, ascending index within a cell.
    pub(super) items: Vec<u32>,
    pub(super) grid: GridInfo,
    /// Per node slot: 1 / its mass as a child, 0 for a kinematic root (as [`Response`] has it),
    /// for the loads the search records.
    pub(super) inv_mass: Vec<f64>,
    /// Per segment: its node slots and their entries of `inv_mass`.
    pub(super) ends: Vec<SegEnds>,
}

/// Below this many segments the pair search stays on one thread (the hand-over costs more).
pub(super) const MIN_SEGMENTS_TO_SHARE: usize = 128;

impl Broad {
    /// Tests the pairs of cells `cells`, appending the contacts (in cell order) to `out` and
    /// adding their shares to `loads` (one entry per node slot, see [`Response`]), in the same
    /// order.
    pub(super) fn search(
        &self,
        cells: Range<usize>,
        p: &ContactParams,
        eps2: f64,
        out: &mut Vec<Contact>,
        loads: &mut [f64],
    ) -> PairStats {
        match crate::simd::level() {
            Level::Avx2 => self.search_on::<Avx2>(cells, p, eps2, out, loads),
            Level::Portable => self.search_on::<Portable>(cells, p, eps2, out, loads),
        }
    }

    /// [`Self::search`] with the box test on the instruction set `I`.
    #[inline(always)]
    fn search_on<I: BoxTest>(
        &self,
        cells: Range<usize>,
        p: &ContactParams,
        eps2: f64,
        out: &mut Vec<Contact>,
        loads: &mut [f64],
    ) -> PairStats {
        let mut stats = PairStats::default();
        let (boxes, pre, reach) = (&self.boxes[..], &self.pre[..], &self.reach[..]);
        let items = &self.items[..];
        let starts = &self.cell_start[..];
        let before = out.len();
        let mut batched = Batched::new(p, &self.ends, loads);
        const INDEX: u32 = (1 << MASK_SHIFT) - 1;
        for c in cells {
            let cell = &items[starts[c] as usize..starts[c + 1] as usize];
            if cell.len() < 2 {
                continue;
            }
            for (k, &ia) in cell.iter().enumerate() {
                let ma = ia >> MASK_SHIFT;
                let a = (ia & INDEX) as usize;
                let ba = &boxes[a];
                let corner = Reach::corner(ba);
                for &ib in &cell[k + 1..] {
                    // Only in the min corner of the overlap of the two cell ranges (see above).
                    if ma & (ib >> MASK_SHIFT) != 0 {
                        continue;
                    }
                    stats.candidates += 1;
                    let b = (ib & INDEX) as usize;
                    // `near`, with the box test on the aligned `Reach` first: most candidates
                    // stop there without reading the node slots.
                    if apart::<I>(&corner, &reach[b])
                        || adjacent(ba, &boxes[b])
                        || !moving(&pre[a], &pre[b], eps2)
                    {
                        continue;
                    }
                    stats.tested += 1;
                    // Cell lists are ascending: `a` has the lower index, as `contact` wants.
                    batched.push((boxes, pre), a, b, p, out);
                }
            }
        }
        batched.flush((boxes, pre), p, out);
        stats.in_contact = (out.len() - before) as u32;
        stats
    }

    /// Cuts the cells into [`CHUNKS`] runs of about equal work (chunk `k` is cells
    /// `bounds[k]..bounds[k + 1]`). A pair is tested in the cell where one of the two ranges
    /// starts on every axis, so a cell's work is about (segments whose range starts there) ×
    /// (segments in it).
    pub(super) fn chunk_bounds(&self) -> [usize; CHUNKS + 1] {
        let starts = &self.cell_start[..];
        let items = &self.items[..];
        let work = |c: usize| {
            let cell = &items[starts[c] as usize..starts[c + 1] as usize];
            let starting = cell.iter().filter(|&&i| i >> MASK_SHIFT == 0).count() as u64;
            starting * cell.len() as u64
        };
        let ncells = starts.len() - 1;
        let total: u64 = (0..ncells).map(work).sum();
        let mut bounds = [ncells; CHUNKS + 1];
        bounds[0] = 0;
        let (mut acc, mut k) = (0u64, 1);
        for c in 0..ncells {
            acc += work(c);
            while k < CHUNKS && acc * CHUNKS as u64 >= total * k as u64 {
                bounds[k] = c + 1;
                k += 1;
            }
        }
        bounds
    }

    /// The grid's geometry, then a counting sort of the segments into its dense cell array.
    pub(super) fn build(&mut self) {
        let n = self.boxes.len();
        let mut bmin = Vector3::repeat(f64::INFINITY);
        let mut bmax = Vector3::repeat(f64::NEG_INFINITY);
        let mut len_sum = 0.0;
        for (b, s) in self.boxes.iter().zip(&self.pre) {
            let (lo, hi) = b.bounds();
            bmin = bmin.inf(&lo);
            bmax = bmax.sup(&hi);
            len_sum += s.lane.len2.sqrt();
        }
        let extent = bmax - bmin;
        let mut grid = GridInfo {
            origin: bmin,
            cell_size: 1.0,
            dims: [1, 1, 1],
        };
        let max_cells = (CELLS_PER_SEGMENT * n).clamp(64, MAX_CELLS) as f64;
        if extent.iter().all(|e| e.is_finite()) {
            // A floor keeps degenerate scenes (all points equal) finite.
            let mut h = (CELL_IN_SEGMENT_LENGTHS * len_sum / n as f64)
                .max(extent.max() * 1e-6)
                .max(1e-9);
            for _ in 0..64 {
                let dims = extent.map(|e| (e / h).floor() + 1.0);
                let cells = dims.x * dims.y * dims.z;
                if cells <= max_cells {
                    grid.dims = [dims.x as u32, dims.y as u32, dims.z as u32];
                    grid.cell_size = h;
                    break;
                }
                // Grow the cells so the product fits; the margin absorbs the `+ 1` per axis.
                h *= (cells / max_cells).cbrt() * 1.01;
            }
        }
        // Non-finite extents (a bug upstream, e.g. a NaN position) fall back to one cell: slow
        // but bounded, and never a hang.
        self.grid = grid;
        let ncells = grid.dims.iter().map(|&d| d as usize).product::<usize>();

        self.lo.clear();
        self.hi.clear();
        self.cell_start.clear();
        self.cell_start.resize(ncells + 1, 0);
        let [dx, dy, _] = grid.dims.map(|d| d as usize);
        let mut total = 0usize;
        for b in &self.boxes {
            let (lo, hi) = grid.box_cells(b);
            self.lo.push(lo);
            self.hi.push(hi);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    let row = (z as usize * dy + y as usize) * dx;
                    for x in lo[0]..=hi[0] {
                        self.cell_start[row + x as usize] += 1;
                    }
                }
            }
            total += ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1)) as usize;
        }
        assert!(total < u32::MAX as usize, "too many cell entries: {total}");
        // Inclusive prefix sums: cell_start[c] = end of cell c.
        let mut acc = 0u32;
        for s in &mut self.cell_start[..ncells] {
            acc += *s;
            *s = acc;
        }
        self.cell_start[ncells] = acc;
        self.items.clear();
        self.items.resize(total, 0);
        // Filling from the last segment backwards while decrementing the ends leaves each cell
        // list ascending and cell_start[c] at the start of cell c.
        for i in (0..n).rev() {
            let (lo, hi) = (self.lo[i], self.hi[i]);
            for z in lo[2]..=hi[2] {
                let mz = ((z > lo[2]) as u32) << 2;
                for y in lo[1]..=hi[1] {
                    let myz = mz | ((y > lo[1]) as u32) << 1;
                    let row = (z as usize * dy + y as usize) * dx;
                    for x in lo[0]..=hi[0] {
                        let mask = myz | (x > lo[0]) as u32;
                        let s = &mut self.cell_start[row + x as usize];
                        *s -= 1;
                        self.items[*s as usize] = i as u32 | mask << MASK_SHIFT;
                    }
                }
            }
        }
    }
}
