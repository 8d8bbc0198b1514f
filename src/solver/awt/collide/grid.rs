//! The broad phase: a uniform voxel grid of segment boxes, each pair found once through the minimum corner of its shared cells (AWT §4.1).

use std::ops::Range;

use nalgebra::Vector3;

use crate::simd::boxes::{BoxTest, Entries, Probe, RUN};

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
            let f = (p[k] - self.origin[k]) / self.cell_size;
            // `as` truncates, which is the floor from 0 up (and `floor` is a libm call in the
            // baseline build), and saturates (NaN → 0); the min keeps the cell inside the grid.
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
    /// Per segment: its data for the relative-motion test and the closest points (cold).
    pub(super) pre: Vec<SegPre>,
    /// Per segment: min and max cell coordinates of its box.
    pub(super) lo: Vec<[u32; 3]>,
    pub(super) hi: Vec<[u32; 3]>,
    /// Dense cell offsets into `items` (counting sort), `ncells + 1` entries.
    pub(super) cell_start: Vec<u32>,
    /// Segment index | mask << [`MASK_SHIFT`], grouped by cell, ascending index within a cell,
    /// then [`RUN`] entries of padding.
    pub(super) items: Vec<u32>,
    /// The entries' boxes, in the order of `items` (what the candidate loop compares, hot).
    pub(super) entries: EntryBoxes,
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
    /// Fills the per-segment data and the grid for a search of the segments `segs` at `pos`
    /// and `vel` (`nodes` node slots).
    pub(super) fn prepare(
        &mut self,
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        nodes: usize,
    ) {
        let n = segs.len();
        self.boxes.clear();
        self.boxes.extend((0..n).map(|i| SegBox::new(segs, pos, i)));
        self.pre.clear();
        self.pre
            .extend((0..n).map(|i| SegPre::new(segs, pos, vel, i)));
        self.build();
        // As `Response::new` computes it: a slot's mass is its mass as a child.
        self.inv_mass.clear();
        self.inv_mass.resize(nodes, 0.0);
        for i in 0..n {
            self.inv_mass[segs.child[i] as usize] = 1.0 / segs.child_mass[i];
        }
        self.ends.clear();
        self.ends.extend((0..n).map(|i| {
            let (parent, child) = (segs.parent[i], segs.child[i]);
            SegEnds {
                parent,
                child,
                inv_parent: self.inv_mass[parent as usize],
                inv_child: self.inv_mass[child as usize],
                mass: segs.child_mass[i],
            }
        }));
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
            len_sum += f64::from(s.lane.len2).sqrt();
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
        self.items.resize(total + RUN, 0);
        self.entries.clear_to(total + RUN);
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
                        self.entries.set(*s as usize, &self.boxes[i]);
                    }
                }
            }
        }
    }
}

crate::simd::dispatch::multiversion! {
    /// Tests the pairs of `broad`'s cells `cells` on the instruction set `level` (the caller
    /// passes [`crate::simd::level`]; tests compare the two), appending the contacts (in cell
    /// order) to `out` and adding their shares to `loads` (one entry per node slot, see
    /// [`Response`]), in the same order. Compiled for AVX2 and for the baseline.
    ///
    /// For each entry `a` of a cell, the entries after it are filtered [`RUN`] at a time
    /// ([`BoxTest::run8`]: found in this cell, boxes overlapping), and only the survivors, in
    /// cell order, go on to [`adjacent`], [`moving`] and the batched narrow phase: the same
    /// pairs in the same order as one pair at a time, so the same contacts and forces bit for
    /// bit.
    pub(super) fn search_cells<I: BoxTest>(
        broad: &Broad,
        cells: Range<usize>,
        p: &ContactParams,
        eps2: f32,
        out: &mut Vec<Contact>,
        loads: &mut [f64],
    ) -> PairStats {
        let mut stats = PairStats::default();
        let (boxes, pre) = (&broad.boxes[..], &broad.pre[..]);
        let items = &broad.items[..];
        let starts = &broad.cell_start[..];
        let entries = broad.entries.view(items);
        let before = out.len();
        let mut batched = Batched::new(p, &broad.ends, loads);
        const INDEX: u32 = (1 << MASK_SHIFT) - 1;
        for c in cells {
            let (first, end) = (starts[c] as usize, starts[c + 1] as usize);
            if end - first < 2 {
                continue;
            }
            for k in first..end - 1 {
                let ia = items[k];
                let a = (ia & INDEX) as usize;
                let ba = &boxes[a];
                // Only in the min corner of the overlap of the two cell ranges (see above):
                // an entry sharing a "starts below" axis bit with `a` meets it in another cell.
                let probe = Probe {
                    lo: ba.lo,
                    hi: ba.hi,
                    flags: ia & !INDEX,
                };
                let mut at = k + 1;
                while at < end {
                    let (found, near) = I::run8(&probe, &entries, at);
                    // Entries past the cell's end belong to the next cells (or the padding).
                    let valid = if end - at >= RUN { u32::MAX } else { (1 << (end - at)) - 1 };
                    stats.candidates += (found & valid).count_ones();
                    let mut bits = near & valid;
                    while bits != 0 {
                        let b = (items[at + bits.trailing_zeros() as usize] & INDEX) as usize;
                        bits &= bits - 1;
                        if adjacent(ba, &boxes[b]) || !moving(&pre[a], &pre[b], eps2) {
                            continue;
                        }
                        stats.tested += 1;
                        // Cell lists are ascending: `a` has the lower index, as `contact` wants.
                        batched.push(pre, a, b, out);
                    }
                    at += RUN;
                }
            }
        }
        batched.flush(pre, out);
        stats.in_contact = (out.len() - before) as u32;
        stats
    }
}

/// The boxes of the cell-list entries in cell-list order, as [`BoxTest::run8`] reads them,
/// with [`RUN`] entries of padding.
#[derive(Default)]
pub(super) struct EntryBoxes {
    lo: [Vec<f32>; 3],
    hi: [Vec<f32>; 3],
}

impl EntryBoxes {
    pub(super) fn with_capacity(len: usize) -> Self {
        EntryBoxes {
            lo: std::array::from_fn(|_| Vec::with_capacity(len)),
            hi: std::array::from_fn(|_| Vec::with_capacity(len)),
        }
    }

    fn clear_to(&mut self, len: usize) {
        for v in self.lo.iter_mut().chain(&mut self.hi) {
            v.clear();
            v.resize(len, 0.0);
        }
    }

    #[inline(always)]
    fn set(&mut self, at: usize, b: &SegBox) {
        for k in 0..3 {
            self.lo[k][at] = b.lo[k];
            self.hi[k][at] = b.hi[k];
        }
    }

    /// The boxes with `words` (the items, padded alike).
    fn view<'a>(&'a self, words: &'a [u32]) -> Entries<'a> {
        Entries {
            lo: [&self.lo[0], &self.lo[1], &self.lo[2]],
            hi: [&self.hi[0], &self.hi[1], &self.hi[2]],
            word: words,
        }
    }

    pub(super) fn capacity_bytes(&self) -> usize {
        self.lo
            .iter()
            .chain(&self.hi)
            .map(|v| v.capacity() * 4)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::Level;

    /// The whole candidate loop on the portable twin and on the best instruction set finds the
    /// same pairs and gives the same contacts and loads bit for bit, on a tangle of strands
    /// dense enough that some cells hold more than sixteen entries (runs of eight with ragged ends) and
    /// every filter rejects some pairs.
    #[test]
    fn the_search_is_the_same_on_both_twins() {
        let mut unit = crate::solver::common::uniform_stream(0x9e37_79b9_7f4a_7c15);
        let mut rand = || unit() - 0.5;
        let (strands, nodes_per) = (80, 12);
        let (mut pos, mut vel) = (Vec::new(), Vec::new());
        let (mut parent, mut child, mut radius, mut mass, mut chain) =
            (vec![], vec![], vec![], vec![], vec![]);
        for s in 0..strands {
            let mut x = Vector3::new(rand() * 0.1, 0.0, rand() * 0.1);
            let v = Vector3::new(rand(), rand(), rand());
            for k in 0..nodes_per {
                if k > 0 {
                    parent.push((pos.len() - 1) as u32);
                    child.push(pos.len() as u32);
                    radius.push(0.003 + 0.005 * (rand() + 0.5));
                    mass.push(1e-3);
                    chain.push(s as u32);
                }
                pos.push(x);
                // Some strands move together: those pairs fail the relative-motion test.
                vel.push(if s % 3 == 0 {
                    Vector3::zeros()
                } else {
                    v * (k as f64)
                });
                x += Vector3::new(rand() * 0.02, -0.01, rand() * 0.02);
            }
        }
        let segs = SegmentsView {
            parent: &parent,
            child: &child,
            radius: &radius,
            child_mass: &mass,
            chain: &chain,
        };
        let mut broad = Broad::default();
        broad.prepare(&segs, &pos, &vel, pos.len());
        let p = ContactParams {
            friction: 40.0,
            repulsion: 2000.0,
            cos_angle_threshold: 0.9,
            epsilon: 0.05,
            dt: 0.01,
        };
        let cells = 0..broad.cell_start.len() - 1;
        let run = |level: Level| {
            let (mut out, mut loads) = (Vec::new(), vec![0.0; pos.len()]);
            let stats = search_cells(
                level,
                &broad,
                cells.clone(),
                &p,
                (p.epsilon * p.epsilon) as f32,
                &mut out,
                &mut loads,
            );
            (
                stats,
                format!("{out:?}"),
                loads.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            )
        };
        let portable = run(Level::Portable);
        let best = run(crate::simd::best_available());
        assert_eq!(portable.0, best.0);
        assert!(portable.1 == best.1, "the contacts differ");
        assert_eq!(portable.2, best.2, "the loads differ");
        let s = portable.0;
        assert!(
            s.tested > 1000 && s.in_contact > 100 && s.tested < s.candidates,
            "a mix of pairs: {s:?}"
        );
        let longest = cells
            .map(|c| broad.cell_start[c + 1] - broad.cell_start[c])
            .max();
        assert!(longest > Some(2 * RUN as u32), "runs of eight: {longest:?}");
    }
}
