//! Hair–hair and hair–body interaction (AWT §4, after Plante et al. §5).
//!
//! The simulation gathers the ACTIVE AWT nodes of a step into compact slot arrays (`pos`, `vel`)
//! and the active segments (parent slot → child slot) into a [`SegmentsView`]. This module works
//! only on those arrays:
//!
//! * [`HairCollider::accumulate`] adds the anisotropic hair–hair forces (friction, eq. 1, and
//!   repulsion, eq. 2) split onto the segment nodes (eq. 3);
//! * [`resolve_body`] moves child nodes out of the body spheres (§4.3).
//!
//! # Choices where the papers leave room
//!
//! * **Closest points in f64.** `parry3d` 0.25 is f32-only (`parry3d-f64` is a separate crate we do
//!   not depend on), while positions are f64 and hair radii are sub-millimetre, so
//!   [`closest_segment_params`] is Ericson's routine (the one parry uses in
//!   `closest_points_segment_segment_with_locations_nD`) rewritten in f64 with relative epsilons.
//!   A test compares it with parry on random segments. Parameters are reported as `s`, the weight of
//!   the CHILD node (`P = (1 − s)·N_parent + s·N_child`), i.e. the paper's `u` is `1 − s`. For
//!   (near-)parallel axes the closest points are not unique; we take the middle of the overlap of
//!   the two segments (parry takes an end), so friction between parallel wisps — the common case —
//!   is shared by both nodes instead of landing on one end.
//! * **Which mass.** `k_f = α·m` and `R = k_r·m·(r − d)·n` with `m` the LIGHTER of the two child
//!   masses: one coefficient serves both sides of the pair, and using the lighter one keeps
//!   `α·dt < 1` sufficient for neither side to have its relative motion reversed.
//! * **Relative-motion test (§4.1).** A pair is skipped when all four node-velocity differences
//!   between the two segments (`v_i − v_j` for `i` a node of one segment and `j` of the other) are
//!   below `epsilon`. The velocity of any point of a segment is a convex combination of its node
//!   velocities, so then every point-to-point relative velocity, in particular `Ṗ2 − Ṗ1`, is below
//!   `epsilon` too (a midpoint test would miss segments rotating about their middles).
//! * **A wisp does not rub against itself.** Besides adjacent segments (sharing a node, which
//!   always touch), two segments of the same GC are never tested: they are consecutive pieces of
//!   one wisp, and a fat coarse wisp (radius ≈ segment length) would otherwise "touch" its own
//!   segments two and three links away at rest and damp its own bending through friction. Split
//!   sub-wisps are other GCs and do collide with each other. (5–10 % of the contacts of the
//!   paper styles under `lean`.)
//! * **Degenerate normals.** When the axes intersect (`d ≈ 0`) the repulsion normal is the cross
//!   product of the axes, oriented from the second segment's midpoint towards the first's.
//!   A zero-length segment has no orientation and gets friction only.
//! * **Broad phase: a uniform voxel grid** (AWT §4.1), rebuilt every step: a dense cell array
//!   over the bounding box of the segments' radius-inflated boxes, filled by a counting sort into
//!   reused buffers. A pair is tested only in the cell at the min corner of the overlap of its two
//!   cell ranges, so each pair sharing a voxel is tested once without a pair set or hashing (the
//!   rule is one AND of two 3-bit masks stored in the cell lists, see [`HairCollider`]). Cell lists
//!   are filled in segment order, so the forces depend only on the input.
//! * **Cell size: three mean segment lengths.** The coarse wisps are fat (radius up to ~7 cm,
//!   larger than a segment) and most pairs that share a voxel really are close, so the
//!   closest-point tests dominate and the grid only has to keep its own costs below them. Smaller
//!   cells put a fat wisp in dozens of cells and the pair visits repeated in every shared cell
//!   grow faster than the pairs pruned (one mean length: 350 k cell-pair visits per step on
//!   `long` for 25 k candidates); larger cells let more distant pairs through, which costs little
//!   now that a candidate is rejected on a 36-byte [`SegBox`], but beyond ~6 lengths there are so
//!   few cells that the search can no longer be cut into balanced chunks for two threads.
//!   Measured with `examples/interactions.rs` on the four paper styles under `lean`: 2–4 lengths within
//!   the noise of one another. The dense array is capped at [`CELLS_PER_SEGMENT`] cells per
//!   segment (clearing and scanning it cost per cell) and at [`MAX_CELLS`] in all (the cell side
//!   grows instead), which bounds time and memory when a node flies away.
//! * **Filters are conservative and shared.** Box overlap (each box inflated by its own radius
//!   and rounded outwards to f32, so two boxes overlap whenever the segments are within
//!   `r1 + r2` on every axis), adjacency and the
//!   relative-motion test are symmetric and computed from per-segment data gathered once per step;
//!   the closest points and the response are computed with the lower segment index first (cell
//!   lists are ascending), as in [`accumulate_brute_force`], so both find the same contacts with
//!   bit-identical pair forces (only the order in which they are summed differs).
//! * **Two threads, same forces.** The pair search (the cell loop and the closest points, ~¾ of
//!   the stage) can be shared with one helper thread, chunk by chunk, see [`HairCollider`]; the
//!   contacts are applied in the one-thread order, so the result is bit-identical. (A fixed
//!   half-and-half split was tried first: on a loaded 2-core machine the caller then often
//!   waited for a descheduled helper, and `wisptree run` took 4.5–8 s instead of ~4.) rayon was tried first
//!   (15–30 % faster on 2 busy cores) but every call from outside its pool pushes a job on its
//!   injector, which allocates a 1.5 kB block every 63 jobs and breaks the no-allocation
//!   guarantee (tests/alloc.rs); a parked helper thread with its own buffers does not.

use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, RwLock};

use nalgebra::Vector3;

/// The active segments of one step, as parallel slices (structure of arrays).
pub struct SegmentsView<'a> {
    /// Slot of the parent node.
    pub parent: &'a [u32],
    /// Slot of the child node.
    pub child: &'a [u32],
    /// Cylinder radius = the child node's radius (AWT §4.1), m.
    pub radius: &'a [f64],
    /// Mass of the child node, kg.
    pub child_mass: &'a [f64],
    /// The generalized cylinder (level and GC) of the child node: two segments of one chain
    /// never collide (see the module docs).
    pub chain: &'a [u32],
}

impl SegmentsView<'_> {
    /// Number of segments. Panics if the slices differ in length (a bug in the caller).
    pub fn len(&self) -> usize {
        let n = self.parent.len();
        assert!(
            self.child.len() == n
                && self.radius.len() == n
                && self.child_mass.len() == n
                && self.chain.len() == n,
            "SegmentsView slices differ in length: parent {}, child {}, radius {}, child_mass {}, \
             chain {}",
            n,
            self.child.len(),
            self.radius.len(),
            self.child_mass.len(),
            self.chain.len()
        );
        n
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Parameters of the hair–hair response (AWT §4.2).
#[derive(Debug, Clone, Copy)]
pub struct ContactParams {
    /// α, s⁻¹ ; k_f = α·m.
    pub friction: f64,
    /// k_r per kilogram, s⁻² (R = k_r · m · (r − d) · n).
    pub repulsion: f64,
    /// Repulsion only when |cos(angle between axes)| < this.
    pub cos_angle_threshold: f64,
    /// Relative speed below which a pair is skipped, m/s.
    pub epsilon: f64,
    /// The integration step the forces will be applied over, s (see [`apply_contacts`]).
    pub dt: f64,
}

/// One pair of segments in contact: where, and the unscaled eq. 1 and eq. 2 forces on `a`.
///
/// The forces are stored in f32: they only scale the f64 force accumulators, the same rounded
/// value goes to both sides (so pair forces still cancel exactly), and the list is the largest
/// buffer of the step (tens of thousands of entries), so halving it keeps it in cache.
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    pub a: u32,
    pub b: u32,
    /// Closest points as fractions from parent (0) to child (1) on `a` and `b`.
    pub s: f64,
    pub t: f64,
    /// Friction (eq. 1) and repulsion (eq. 2) on `a`; `b` gets the opposite.
    pub friction: [f32; 3],
    pub repulsion: [f32; 3],
}

impl ContactParams {
    /// Checks the parameters for a time step `dt` (s); the message names the offending field.
    /// `α·dt < 1` is the AWT's condition for friction never to reverse a relative motion.
    pub fn validate(&self, dt: f64) -> Result<(), String> {
        let finite_nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("contact.{name} must be finite and >= 0, got {v}"))
            }
        };
        finite_nonneg("friction", self.friction)?;
        finite_nonneg("repulsion", self.repulsion)?;
        finite_nonneg("epsilon", self.epsilon)?;
        if !(self.cos_angle_threshold.is_finite() && self.cos_angle_threshold >= 0.0) {
            return Err(format!(
                "contact.cos_angle_threshold must be finite and >= 0, got {}",
                self.cos_angle_threshold
            ));
        }
        if self.friction * dt >= 1.0 {
            return Err(format!(
                "contact.friction: α·dt must be < 1 so friction cannot reverse a relative motion \
                 (AWT §4.2), got α = {} s⁻¹ with dt = {} s (α·dt = {})",
                self.friction,
                dt,
                self.friction * dt
            ));
        }
        Ok(())
    }
}

/// Upper bound on the number of cells of the dense voxel grid (4 MiB of `u32` offsets), whatever
/// the number of segments: bounds memory when a node flies away.
pub const MAX_CELLS: usize = 1 << 20;

/// Cells allowed per segment: the dense cell array is cleared, counted and scanned every step,
/// so beyond a few cells per segment the scan of empty cells costs more than it prunes.
pub const CELLS_PER_SEGMENT: usize = 8;

/// Cell-list entries reserved per segment by [`HairCollider::with_capacity`].
const ITEMS_PER_SEGMENT: usize = 32;

/// Cell side in mean segment lengths (see the module docs).
const CELL_IN_SEGMENT_LENGTHS: f64 = 3.0;

/// The mask bits of an item of a cell list (see [`HairCollider`]): bit `k` set when the segment's
/// cell range starts below this cell along axis `k`.
const MASK_SHIFT: u32 = 29;

/// Counters of one [`HairCollider::accumulate`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairStats {
    /// Pairs the broad phase visits, each once: the pairs sharing at least one voxel (all
    /// `n·(n − 1)/2` pairs in [`accumulate_brute_force`]).
    pub candidates: u32,
    /// Pairs that reached the closest-point routine: not adjacent, moving relative to each other,
    /// boxes inflated by `r1 + r2` overlapping on every axis. Each such pair counts once.
    pub tested: u32,
    /// Of those, the pairs whose cylinders intersect (`d < r1 + r2`).
    pub in_contact: u32,
}

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

    fn box_cells(&self, b: &SegBox) -> ([u32; 3], [u32; 3]) {
        let (lo, hi) = b.bounds();
        (self.cell_of(&lo), self.cell_of(&hi))
    }
}

/// Reused buffers of the broad phase (uniform voxel grid) and of the response, and the helper
/// thread that shares the pair search. Allocation only while warming up (or never, with
/// [`HairCollider::with_capacity`] from the model's size).
///
/// The grid is dense over the segments' bounding box and filled by a counting sort. Each item of
/// a cell list is a segment index with, in its top 3 bits, a mask saying along which axes the
/// segment's cell range starts BELOW this cell. A pair belongs to the min corner of the overlap of
/// its two cell ranges, i.e. to the one shared cell where, on every axis, at least one of the two
/// ranges starts: there the two masks have no bit in common. So the "tested once" rule is one AND
/// on data already in the cell list, without a pair set or a lookup of the ranges.
///
/// Per-segment data is split by temperature: the pair loop reads only [`SegBox`] (36 bytes, the
/// whole scene fits in L1), and [`SegPre`] (positions, velocities, f64) only for the pairs that
/// pass the box and adjacency tests.
///
/// **Two threads, same result.** With [`Self::set_threads`]`(2)` the cells are cut into
/// [`CHUNKS`] runs of about equal work, and the caller and a helper thread (spawned once, then
/// parked on a condition variable) claim them from an atomic counter until none is left. If the
/// helper is slow to wake (the logging thread or another job holds the other core), the caller
/// simply does more chunks, so sharing never costs much more than one thread. Loads and forces
/// are then applied chunk by chunk in cell order, exactly the order of the one-thread search, so
/// the forces are bit-identical whatever the thread count and whoever did which chunk. The
/// helper works on buffers it keeps, so a warm step allocates nothing (rayon's injector would:
/// see the module docs).
pub struct HairCollider {
    broad: Arc<RwLock<Broad>>,
    contacts: Vec<Contact>,
    /// Per node slot: the load, then the repulsion scale (scratch of [`Response`]).
    load: Vec<f64>,
    /// Per node slot: 1 / mass, then the friction scale (scratch of [`Response`]).
    inv_mass: Vec<f64>,
    threads: usize,
    helper: Option<Helper>,
    /// Contacts the helper thread found in the last call.
    helper_contacts: u32,
    /// Wait for the helper to pick up each search before claiming chunks (tests).
    helper_first: bool,
}

impl Default for HairCollider {
    fn default() -> Self {
        Self::with_capacity(0, 0, 0)
    }
}

/// The grid and the per-segment data, written by the caller, then read by both threads.
#[derive(Default)]
struct Broad {
    /// Per segment: inflated box and node slots (hot).
    boxes: Vec<SegBox>,
    /// Per segment: its data for the relative-motion test and the closest points (cold).
    pre: Vec<SegPre>,
    /// Per segment: min and max cell coordinates of its box.
    lo: Vec<[u32; 3]>,
    hi: Vec<[u32; 3]>,
    /// Dense cell offsets into `items` (counting sort), `ncells + 1` entries.
    cell_start: Vec<u32>,
    /// Segment index | mask << [`MASK_SHIFT`], grouped by cell, ascending index within a cell.
    items: Vec<u32>,
    grid: GridInfo,
}

/// Below this many segments the pair search stays on one thread (the hand-over costs more).
const MIN_SEGMENTS_TO_SHARE: usize = 128;

impl HairCollider {
    pub fn new() -> Self {
        Self::default()
    }

    /// A collider whose buffers already hold `segments` segments over `nodes` node slots and
    /// `contacts` contacts, so that steps within those sizes never allocate. One thread.
    pub fn with_capacity(segments: usize, nodes: usize, contacts: usize) -> Self {
        let cells = if segments == 0 {
            0
        } else {
            (CELLS_PER_SEGMENT * segments).clamp(64, MAX_CELLS) + 1
        };
        let broad = Broad {
            boxes: Vec::with_capacity(segments),
            pre: Vec::with_capacity(segments),
            lo: Vec::with_capacity(segments),
            hi: Vec::with_capacity(segments),
            cell_start: Vec::with_capacity(cells),
            items: Vec::with_capacity(ITEMS_PER_SEGMENT * segments),
            grid: GridInfo::default(),
        };
        HairCollider {
            broad: Arc::new(RwLock::new(broad)),
            contacts: Vec::with_capacity(contacts),
            load: Vec::with_capacity(nodes),
            inv_mass: Vec::with_capacity(nodes),
            threads: 1,
            helper: None,
            helper_contacts: 0,
            helper_first: false,
        }
    }

    /// Threads used by the pair search: 1, or 2 (more are treated as 2). The forces do not
    /// depend on it. The helper thread starts here (once), with room for as many contacts as
    /// this collider has reserved, so no later step allocates for it.
    pub fn set_threads(&mut self, threads: usize) {
        self.threads = threads.clamp(1, 2);
        if self.threads > 1 && self.helper.is_none() {
            self.helper = Some(Helper::spawn(self.broad.clone(), self.contacts.capacity()));
        }
    }

    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Makes every shared search wait until the helper has picked it up, so that both threads
    /// surely take part (otherwise the caller may do all chunks when the helper is slow to
    /// wake). For tests; the result is the same either way.
    #[doc(hidden)]
    pub fn set_helper_first(&mut self, on: bool) {
        self.helper_first = on;
    }

    /// How many of the last call's contacts the helper thread found (0 on one thread).
    pub fn helper_contacts(&self) -> u32 {
        self.helper_contacts
    }

    /// The grid built by the last call to [`Self::accumulate`].
    pub fn grid(&self) -> GridInfo {
        read(&self.broad).grid
    }

    /// Bytes reserved by the reused buffers (stays constant once warmed up on a scene size).
    pub fn capacity_bytes(&self) -> usize {
        let b = read(&self.broad);
        let helper = self.helper.as_ref().map_or(0, |h| {
            lock(&h.shared.job).contacts.capacity() * std::mem::size_of::<Contact>()
        });
        b.boxes.capacity() * std::mem::size_of::<SegBox>()
            + b.pre.capacity() * std::mem::size_of::<SegPre>()
            + (b.lo.capacity() + b.hi.capacity()) * std::mem::size_of::<[u32; 3]>()
            + (b.cell_start.capacity() + b.items.capacity()) * 4
            + self.contacts.capacity() * std::mem::size_of::<Contact>()
            + (self.load.capacity() + self.inv_mass.capacity()) * 8
            + helper
    }

    /// Adds the hair–hair friction and repulsion forces to `force` (indexed by slot).
    pub fn accumulate(
        &mut self,
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        p: &ContactParams,
        force: &mut [Vector3<f64>],
    ) -> PairStats {
        let n = segs.len();
        if n < 2 {
            return PairStats::default();
        }
        assert!(
            n < 1 << MASK_SHIFT,
            "too many segments for the cell lists: {n}"
        );
        {
            let mut b = write(&self.broad);
            b.boxes.clear();
            b.boxes.extend((0..n).map(|i| SegBox::new(segs, pos, i)));
            b.pre.clear();
            b.pre.extend((0..n).map(|i| SegPre::new(segs, pos, vel, i)));
            b.build();
        }
        let eps2 = p.epsilon * p.epsilon;
        self.contacts.clear();
        let broad = read(&self.broad);
        let ncells = broad.cell_start.len() - 1;
        let mut response = Response::new(segs, force.len(), &mut self.inv_mass, &mut self.load);
        self.helper_contacts = 0;
        let stats = if self.threads > 1 && n >= MIN_SEGMENTS_TO_SHARE {
            let bounds = broad.chunk_bounds();
            let helper = self
                .helper
                .as_ref()
                .expect("set_threads started the helper");
            helper.start(bounds, *p, self.helper_first);
            // Claim chunks until none is left; the helper does the same, so if it is slow to
            // wake (a busy machine) this thread simply does more of them.
            let mut stats = PairStats::default();
            let mut spans = [None; CHUNKS];
            loop {
                let k = helper.shared.next.fetch_add(1, Ordering::AcqRel);
                if k >= CHUNKS {
                    break;
                }
                let start = self.contacts.len();
                stats.add(&broad.search(bounds[k]..bounds[k + 1], p, eps2, &mut self.contacts));
                spans[k] = Some((start, self.contacts.len()));
            }
            let job = helper.finish();
            stats.add(&job.stats);
            self.helper_contacts = job.stats.in_contact;
            // The contacts chunk by chunk, i.e. in cell order: the one-thread order.
            let lists: [&[Contact]; CHUNKS] = std::array::from_fn(|k| match spans[k] {
                Some((a, b)) => &self.contacts[a..b],
                None => {
                    let (a, b) = job.spans[k];
                    &job.contacts[a..b]
                }
            });
            for c in lists.iter().flat_map(|l| l.iter()) {
                response.record(c, segs);
            }
            response.apply(&lists, segs, p, force);
            stats
        } else {
            let stats = broad.search(0..ncells, p, eps2, &mut self.contacts);
            for c in &self.contacts {
                response.record(c, segs);
            }
            response.apply(&[&self.contacts], segs, p, force);
            stats
        };
        stats
    }
}

impl Drop for HairCollider {
    fn drop(&mut self) {
        if let Some(h) = self.helper.take() {
            h.stop();
        }
    }
}

impl Broad {
    /// Tests the pairs of cells `cells`, appending the contacts (in cell order) to `out`.
    fn search(
        &self,
        cells: Range<usize>,
        p: &ContactParams,
        eps2: f64,
        out: &mut Vec<Contact>,
    ) -> PairStats {
        let mut stats = PairStats::default();
        let (boxes, pre) = (&self.boxes[..], &self.pre[..]);
        let items = &self.items[..];
        let starts = &self.cell_start[..];
        let before = out.len();
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
                for &ib in &cell[k + 1..] {
                    // Only in the min corner of the overlap of the two cell ranges (see above).
                    if ma & (ib >> MASK_SHIFT) != 0 {
                        continue;
                    }
                    stats.candidates += 1;
                    let b = (ib & INDEX) as usize;
                    if !near(ba, &boxes[b]) || !moving(&pre[a], &pre[b], eps2) {
                        continue;
                    }
                    stats.tested += 1;
                    // Cell lists are ascending: `a` has the lower index, as `contact` wants.
                    if let Some(c) = contact(&pre[a], &pre[b], p) {
                        out.push(c);
                    }
                }
            }
        }
        stats.in_contact = (out.len() - before) as u32;
        stats
    }

    /// Cuts the cells into [`CHUNKS`] runs of about equal work (chunk `k` is cells
    /// `bounds[k]..bounds[k + 1]`). A pair is tested in the cell where one of the two ranges
    /// starts on every axis, so a cell's work is about (segments whose range starts there) ×
    /// (segments in it).
    fn chunk_bounds(&self) -> [usize; CHUNKS + 1] {
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
    fn build(&mut self) {
        let n = self.boxes.len();
        let mut bmin = Vector3::repeat(f64::INFINITY);
        let mut bmax = Vector3::repeat(f64::NEG_INFINITY);
        let mut len_sum = 0.0;
        for (b, s) in self.boxes.iter().zip(&self.pre) {
            let (lo, hi) = b.bounds();
            bmin = bmin.inf(&lo);
            bmax = bmax.sup(&hi);
            len_sum += s.len2.sqrt();
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

impl PairStats {
    fn add(&mut self, o: &PairStats) {
        self.candidates += o.candidates;
        self.tested += o.tested;
        self.in_contact += o.in_contact;
    }
}

/// Chunks of cells the pair search is cut into when shared: enough for the two threads to
/// even out, few enough that the hand-over stays cheap.
const CHUNKS: usize = 8;

/// What the caller hands to the helper thread and gets back.
struct Job {
    state: JobState,
    bounds: [usize; CHUNKS + 1],
    params: Option<ContactParams>,
    /// The helper's contacts, and for each chunk it searched, its span in them.
    contacts: Vec<Contact>,
    spans: [(usize, usize); CHUNKS],
    stats: PairStats,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum JobState {
    Idle,
    /// Posted, not yet picked up.
    Run,
    /// The helper is claiming chunks.
    Busy,
    Done,
    Failed,
    Quit,
}

struct Shared {
    broad: Arc<RwLock<Broad>>,
    job: Mutex<Job>,
    wake: Condvar,
    /// The next chunk to claim, by either thread.
    next: AtomicUsize,
}

/// The helper thread of [`HairCollider`].
struct Helper {
    shared: Arc<Shared>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Helper {
    fn spawn(broad: Arc<RwLock<Broad>>, contacts: usize) -> Helper {
        let shared = Arc::new(Shared {
            broad,
            job: Mutex::new(Job {
                state: JobState::Idle,
                bounds: [0; CHUNKS + 1],
                params: None,
                contacts: Vec::with_capacity(contacts),
                spans: [(0, 0); CHUNKS],
                stats: PairStats::default(),
            }),
            wake: Condvar::new(),
            next: AtomicUsize::new(CHUNKS),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("wisptree-collide".into())
            .spawn(move || Helper::serve(&s))
            .expect("cannot start the collision helper thread");
        Helper {
            shared,
            thread: Some(thread),
        }
    }

    fn serve(s: &Shared) {
        let mut job = lock(&s.job);
        loop {
            match job.state {
                JobState::Quit => return,
                JobState::Run => {
                    // The first chunk is claimed before saying so: a caller that waits for the
                    // pickup (`helper_first`) is then sure the helper takes part.
                    let mut claimed = s.next.fetch_add(1, Ordering::AcqRel);
                    job.state = JobState::Busy;
                    s.wake.notify_all();
                    let (bounds, p) = (job.bounds, job.params.expect("params of a job"));
                    let mut out = std::mem::take(&mut job.contacts);
                    drop(job);
                    out.clear();
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        let broad = read(&s.broad);
                        let eps2 = p.epsilon * p.epsilon;
                        let mut stats = PairStats::default();
                        let mut spans = [(0, 0); CHUNKS];
                        loop {
                            let k = claimed;
                            if k >= CHUNKS {
                                break;
                            }
                            claimed = s.next.fetch_add(1, Ordering::AcqRel);
                            let start = out.len();
                            stats.add(&broad.search(bounds[k]..bounds[k + 1], &p, eps2, &mut out));
                            spans[k] = (start, out.len());
                        }
                        (stats, spans)
                    }));
                    job = lock(&s.job);
                    job.contacts = out;
                    match result {
                        Ok((stats, spans)) => {
                            job.stats = stats;
                            job.spans = spans;
                            job.state = JobState::Done;
                        }
                        Err(_) => job.state = JobState::Failed,
                    }
                    s.wake.notify_all();
                }
                _ => job = s.wake.wait(job).unwrap_or_else(|e| e.into_inner()),
            }
        }
    }

    /// Posts a search; with `wait_for_pickup`, returns only once the helper has started on it
    /// (so that it surely takes part: for tests).
    fn start(&self, bounds: [usize; CHUNKS + 1], p: ContactParams, wait_for_pickup: bool) {
        let mut job = lock(&self.shared.job);
        self.shared.next.store(0, Ordering::Release);
        job.bounds = bounds;
        job.params = Some(p);
        job.stats = PairStats::default();
        job.state = JobState::Run;
        self.shared.wake.notify_all();
        while wait_for_pickup && job.state == JobState::Run {
            job = self
                .shared
                .wake
                .wait(job)
                .unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Once every chunk is claimed: withdraws the job if the helper never picked it up, else
    /// waits for it to finish. Returns the job (its contacts stay in the helper's buffer).
    fn finish(&self) -> std::sync::MutexGuard<'_, Job> {
        let mut job = lock(&self.shared.job);
        if job.state == JobState::Run {
            job.state = JobState::Idle;
            job.stats = PairStats::default();
            return job;
        }
        while job.state == JobState::Busy {
            job = self
                .shared
                .wake
                .wait(job)
                .unwrap_or_else(|e| e.into_inner());
        }
        assert!(
            job.state == JobState::Done,
            "the collision helper thread panicked"
        );
        job.state = JobState::Idle;
        job
    }

    fn stop(mut self) {
        lock(&self.shared.job).state = JobState::Quit;
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

// The locks only guard plain buffers: a panic elsewhere leaves them consistent enough to reuse
// (they are cleared before every use), so poisoning is ignored.
fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

fn read<T>(l: &RwLock<T>) -> std::sync::RwLockReadGuard<'_, T> {
    l.read().unwrap_or_else(|e| e.into_inner())
}

fn write<T>(l: &RwLock<T>) -> std::sync::RwLockWriteGuard<'_, T> {
    l.write().unwrap_or_else(|e| e.into_inner())
}

/// Reference all-pairs version of [`HairCollider::accumulate`], O(n²): same pair filters and
/// response, pairs visited in lexicographic order. For tests and benchmarks.
pub fn accumulate_brute_force(
    segs: &SegmentsView,
    pos: &[Vector3<f64>],
    vel: &[Vector3<f64>],
    p: &ContactParams,
    force: &mut [Vector3<f64>],
) -> PairStats {
    let mut stats = PairStats::default();
    let n = segs.len();
    let boxes: Vec<SegBox> = (0..n).map(|i| SegBox::new(segs, pos, i)).collect();
    let pre: Vec<SegPre> = (0..n).map(|i| SegPre::new(segs, pos, vel, i)).collect();
    let eps2 = p.epsilon * p.epsilon;
    let (mut inv_mass, mut load) = (Vec::new(), Vec::new());
    let mut response = Response::new(segs, force.len(), &mut inv_mass, &mut load);
    let mut contacts = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            stats.candidates += 1;
            if near(&boxes[a], &boxes[b]) && moving(&pre[a], &pre[b], eps2) {
                stats.tested += 1;
                if let Some(c) = contact(&pre[a], &pre[b], p) {
                    response.record(&c, segs);
                    contacts.push(c);
                }
            }
        }
    }
    stats.in_contact = contacts.len() as u32;
    response.apply(&[&contacts], segs, p, force);
    stats
}

/// Adds the contacts' forces to the nodes (eq. 3), limited so that a node touching many
/// segments at once stays stable. (For callers holding a list of contacts; the collider itself
/// accumulates the loads while it finds the contacts.)
///
/// The AWT's `α·dt < 1` keeps ONE contact from reversing a relative velocity, but a node in a
/// dense wisp touches dozens of segments in the same step and the explicit sum of their
/// friction impulses overshoots (the hair explodes). Each node's load `W = Σ share·m/m_node`
/// over its contacts is therefore computed first, and a pair's friction is scaled by
/// `1 / max(1, 2·α·dt·W)` and its repulsion by `1 / max(1, 2·k_r·dt²·W)`, W the largest load
/// among the pair's four nodes. The scale is the same on both sides, so forces still sum to
/// zero; a lone contact (W ≤ 1) is untouched when `α·dt < 1/2`. Here `m` is the pair's mass
/// (the lighter child). `inv_mass` and `load` are scratch buffers (one entry per node slot).
pub fn apply_contacts(
    contacts: &[Contact],
    segs: &SegmentsView,
    p: &ContactParams,
    inv_mass: &mut Vec<f64>,
    load: &mut Vec<f64>,
    force: &mut [Vector3<f64>],
) {
    let mut response = Response::new(segs, force.len(), inv_mass, load);
    for c in contacts {
        response.record(c, segs);
    }
    response.apply(&[contacts], segs, p, force);
}

/// The per-node loads of [`apply_contacts`], accumulated contact by contact.
struct Response<'a> {
    /// Per slot: 1 / its mass as a child (0 for a kinematic root); then, in [`Self::apply`],
    /// the friction scale of the node.
    inv_mass: &'a mut Vec<f64>,
    /// Per slot: the load `W`; then, in [`Self::apply`], the repulsion scale of the node.
    load: &'a mut Vec<f64>,
}

impl<'a> Response<'a> {
    fn new(
        segs: &SegmentsView,
        nodes: usize,
        inv_mass: &'a mut Vec<f64>,
        load: &'a mut Vec<f64>,
    ) -> Self {
        // A slot's mass is its mass as a child; a slot that is never a child is a kinematic
        // root, which no force moves (infinite mass, no load).
        inv_mass.clear();
        inv_mass.resize(nodes, 0.0);
        for i in 0..segs.len() {
            inv_mass[segs.child[i] as usize] = 1.0 / segs.child_mass[i];
        }
        load.clear();
        load.resize(nodes, 0.0);
        Response { inv_mass, load }
    }

    /// Adds a contact's shares to the loads of its four nodes.
    #[inline]
    fn record(&mut self, c: &Contact, segs: &SegmentsView) {
        let (a, b) = (c.a as usize, c.b as usize);
        let m = segs.child_mass[a].min(segs.child_mass[b]);
        for (n, share) in [
            (segs.parent[a], 1.0 - c.s),
            (segs.child[a], c.s),
            (segs.parent[b], 1.0 - c.t),
            (segs.child[b], c.t),
        ] {
            self.load[n as usize] += share * m * self.inv_mass[n as usize];
        }
    }

    /// Scales each contact by the loads of its nodes and adds its forces (eq. 3).
    ///
    /// `1 / max(1, k·W)` with `W` the largest of the four loads is the smallest of the four
    /// nodes' `1 / max(1, k·W_n)` (the map is decreasing), so the scales are computed once per
    /// node instead of twice per contact.
    fn apply(
        self,
        lists: &[&[Contact]],
        segs: &SegmentsView,
        p: &ContactParams,
        force: &mut [Vector3<f64>],
    ) {
        let (kf, kr) = (2.0 * p.friction * p.dt, 2.0 * p.repulsion * p.dt * p.dt);
        let (fric, rep) = (&mut self.inv_mass[..], &mut self.load[..]);
        for (f, w) in fric.iter_mut().zip(rep.iter_mut()) {
            *f = 1.0 / (kf * *w).max(1.0);
            *w = 1.0 / (kr * *w).max(1.0);
        }
        for c in lists.iter().flat_map(|l| l.iter()) {
            let (a, b) = (c.a as usize, c.b as usize);
            let (pa, ca) = (segs.parent[a] as usize, segs.child[a] as usize);
            let (pb, cb) = (segs.parent[b] as usize, segs.child[b] as usize);
            let fs = fric[pa].min(fric[ca]).min(fric[pb]).min(fric[cb]);
            let rs = rep[pa].min(rep[ca]).min(rep[pb]).min(rep[cb]);
            let f = widen(c.friction) * fs + widen(c.repulsion) * rs;
            // Eq. 3: F at P = (1 − s)·N_p + s·N_c goes (1 − s)·F to the parent, s·F to the
            // child.
            let fa_child = f * c.s;
            force[pa] += f - fa_child;
            force[ca] += fa_child;
            let fb_child = f * c.t;
            force[pb] -= f - fb_child;
            force[cb] -= fb_child;
        }
    }
}

#[inline]
fn widen(v: [f32; 3]) -> Vector3<f64> {
    Vector3::new(v[0] as f64, v[1] as f64, v[2] as f64)
}

#[inline]
fn narrow(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// One segment's broad-phase data: the box of its nodes inflated by its radius, in f32 rounded
/// outwards (so it always contains the f64 box), and its node slots for the adjacency test.
/// Two inflated boxes overlap exactly when the plain boxes are within `r1 + r2` on every axis.
#[derive(Clone, Copy, Default)]
struct SegBox {
    lo: [f32; 3],
    hi: [f32; 3],
    parent: u32,
    child: u32,
    chain: u32,
}

impl SegBox {
    #[inline]
    fn new(segs: &SegmentsView, pos: &[Vector3<f64>], i: usize) -> Self {
        let (parent, child) = (segs.parent[i], segs.child[i]);
        let (xp, xc) = (pos[parent as usize], pos[child as usize]);
        let r = segs.radius[i];
        let (lo, hi) = (xp.inf(&xc).add_scalar(-r), xp.sup(&xc).add_scalar(r));
        SegBox {
            lo: [0, 1, 2].map(|k| (lo[k] as f32).next_down()),
            hi: [0, 1, 2].map(|k| (hi[k] as f32).next_up()),
            parent,
            child,
            chain: segs.chain[i],
        }
    }

    fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        (
            Vector3::from(self.lo.map(f64::from)),
            Vector3::from(self.hi.map(f64::from)),
        )
    }
}

/// Whether a pair may touch: inflated boxes overlapping on every axis, not adjacent, not on one
/// chain.
#[inline(always)]
fn near(a: &SegBox, b: &SegBox) -> bool {
    // Non-short-circuit `|`: the six comparisons are independent, one branch instead of six.
    let apart = (a.lo[0] > b.hi[0])
        | (b.lo[0] > a.hi[0])
        | (a.lo[1] > b.hi[1])
        | (b.lo[1] > a.hi[1])
        | (a.lo[2] > b.hi[2])
        | (b.lo[2] > a.hi[2]);
    // Adjacent segments (a chain, or siblings on one parent) always touch, and the segments
    // of one GC are pieces of one wisp: never test them.
    let adjacent = (a.parent == b.parent)
        | (a.parent == b.child)
        | (a.child == b.parent)
        | (a.child == b.child)
        | (a.chain == b.chain);
    !(apart | adjacent)
}

/// One segment's data for the relative-motion test and the closest points, gathered once per
/// step.
#[derive(Clone, Copy)]
struct SegPre {
    radius: f64,
    /// Index in the [`SegmentsView`].
    seg: u32,
    xp: Vector3<f64>,
    xc: Vector3<f64>,
    /// `xc − xp` and its squared length.
    d: Vector3<f64>,
    len2: f64,
    vp: Vector3<f64>,
    vc: Vector3<f64>,
    mass: f64,
}

impl SegPre {
    #[inline]
    fn new(segs: &SegmentsView, pos: &[Vector3<f64>], vel: &[Vector3<f64>], i: usize) -> Self {
        let (parent, child) = (segs.parent[i] as usize, segs.child[i] as usize);
        let (xp, xc) = (pos[parent], pos[child]);
        let d = xc - xp;
        SegPre {
            radius: segs.radius[i],
            seg: i as u32,
            xp,
            xc,
            d,
            len2: d.norm_squared(),
            vp: vel[parent],
            vc: vel[child],
            mass: segs.child_mass[i],
        }
    }
}

/// Whether the two segments move relative to each other: a bound on every point-to-point
/// relative speed (see the module docs) at or above `epsilon`.
#[inline(always)]
fn moving(a: &SegPre, b: &SegPre, eps2: f64) -> bool {
    // max(…) ≥ ε² as four independent comparisons (`f64::max` branches on NaN).
    ((a.vp - b.vp).norm_squared() >= eps2)
        | ((a.vp - b.vc).norm_squared() >= eps2)
        | ((a.vc - b.vp).norm_squared() >= eps2)
        | ((a.vc - b.vc).norm_squared() >= eps2)
}

/// The contact of a pair that passed [`near`] and [`moving`], if the cylinders intersect. `a`
/// must be the segment with the lower index, so that the grid and the reference compute
/// bit-identical pair forces.
#[inline]
fn contact(a: &SegPre, b: &SegPre, p: &ContactParams) -> Option<Contact> {
    let (xpa, xca, xpb, xcb) = (a.xp, a.xc, b.xp, b.xc);
    let (vpa, vca, vpb, vcb) = (a.vp, a.vc, b.vp, b.vc);
    let r = a.radius + b.radius;
    let (s, t) = closest_params(&xpa, &a.d, a.len2, &xpb, &b.d, b.len2);
    let (d1, d2) = (a.d, b.d);
    let p1 = xpa + d1 * s;
    let p2 = xpb + d2 * t;
    let delta = p1 - p2;
    let dist2 = delta.norm_squared();
    if dist2 >= r * r {
        return None;
    }
    let m = a.mass.min(b.mass);

    // Eq. 1: viscous friction at the closest points.
    let v1 = vpa * (1.0 - s) + vca * s;
    let v2 = vpb * (1.0 - t) + vcb * t;
    let friction = (v2 - v1) * (p.friction * m);
    let mut repulsion = Vector3::zeros();

    // Eq. 2: repulsion only between wisps crossing at a large enough angle.
    // |cos| < threshold, compared squared (no root or division on the common parallel pair);
    // a zero-length segment counts as parallel (|cos| = 1).
    let len2 = a.len2 * b.len2;
    let dot = d1.dot(&d2);
    let thr = p.cos_angle_threshold;
    let crossing = if len2 > 0.0 {
        dot * dot < thr * thr * len2
    } else {
        1.0 < thr
    };
    if crossing {
        let d = dist2.sqrt();
        let n = if d > 1e-9 * r {
            delta / d
        } else {
            let mid = (xpa + xca - xpb - xcb) * 0.5;
            degenerate_normal(&d1, &d2, &mid)
        };
        // Only while the two approach: a penalty that also pushed separating wisps would, with
        // the skipping of still pairs (§4.1), chatter forever on resting hair and pump energy
        // into it. The response stays soft (§4.2) and never accelerates a separation.
        // It is also capped at the impulse that stops the approach within the step, so like
        // friction it can bring the normal relative velocity to zero but never reverse it.
        let approach = -(v1 - v2).dot(&n);
        if approach > 0.0 {
            let push = (p.repulsion * m * (r - d)).min(m * approach / p.dt.max(1e-12));
            repulsion = n * push;
        }
    }

    Some(Contact {
        a: a.seg,
        b: b.seg,
        s,
        t,
        friction: narrow(&friction),
        repulsion: narrow(&repulsion),
    })
}

/// Unit normal for intersecting axes: perpendicular to both, pointing to the side of `mid`
/// (first midpoint minus second).
fn degenerate_normal(d1: &Vector3<f64>, d2: &Vector3<f64>, mid: &Vector3<f64>) -> Vector3<f64> {
    let c = d1.cross(d2);
    let cn = c.norm();
    let scale = d1.norm() * d2.norm();
    let n = if cn > 1e-9 * scale {
        c / cn
    } else {
        // Parallel axes (only reachable with a threshold above 1): the midpoint offset across d1.
        let u = d1.try_normalize(0.0).unwrap_or_else(Vector3::x);
        let across = mid - u * u.dot(mid);
        across
            .try_normalize(1e-300)
            .unwrap_or_else(|| any_perpendicular(&u))
    };
    if n.dot(mid) < 0.0 {
        -n
    } else {
        n
    }
}

/// A unit vector perpendicular to the unit vector `u`, chosen deterministically.
fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let axis = if u.x.abs() < 0.57 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    u.cross(&axis).normalize()
}

/// Closest points between segments `[a1, b1]` and `[a2, b2]` (Ericson, *Real-Time Collision
/// Detection* §5.1.9, as in parry), in f64. Returns `(s, t)` with the closest points
/// `a1 + s·(b1 − a1)` and `a2 + t·(b2 − a2)`, both in `[0, 1]`. For parallel overlapping segments
/// `s` is the middle of the overlap.
pub fn closest_segment_params(
    a1: &Vector3<f64>,
    b1: &Vector3<f64>,
    a2: &Vector3<f64>,
    b2: &Vector3<f64>,
) -> (f64, f64) {
    let d1 = b1 - a1;
    let d2 = b2 - a2;
    closest_params(a1, &d1, d1.norm_squared(), a2, &d2, d2.norm_squared())
}

/// [`closest_segment_params`] from the first points, the directions `d = b − a` and their squared
/// lengths (computed once per segment by the caller).
#[inline]
fn closest_params(
    a1: &Vector3<f64>,
    d1: &Vector3<f64>,
    a: f64,
    a2: &Vector3<f64>,
    d2: &Vector3<f64>,
    e: f64,
) -> (f64, f64) {
    let r = a1 - a2;
    let f = d2.dot(&r);
    // Relative to the scene: a segment shorter than 1e-12 of the other or of the gap is a point.
    let scale = a.max(e).max(r.norm_squared());
    let tiny = 1e-24 * scale;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b; // = |d1 × d2|² ≥ 0
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        // Parallel: seg 2's ends project on seg 1 at -c/a and (b - c)/a.
        let (p, q) = (-c / a, (b - c) / a);
        let (lo, hi) = (p.min(q).max(0.0), p.max(q).min(1.0));
        if lo <= hi {
            0.5 * (lo + hi)
        } else {
            (0.5 * (p + q)).clamp(0.0, 1.0)
        }
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// A sphere of the body proxy (AWT §4.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodySphere {
    pub center: Vector3<f64>,
    pub radius: f64,
}

/// Passes over the spheres per segment before the exit fallback (overlapping spheres can push a
/// node back and forth).
const BODY_PASSES: usize = 4;
/// Relative tolerance on `|q − c|²` below which a segment's interior counts as inside: the
/// tangent placement is exact only up to rounding and must not re-trigger a push.
const CHORD_TOLERANCE: f64 = 1e-9;

/// AWT §4.3: every segment that enters a sphere has its CHILD node moved out to the surface and
/// given the obstacle's velocity `obstacle_velocity(world_point)` (static friction, no bounce).
/// Returns the number of segments pushed.
///
/// Segments are handled in order, each seeing the positions already moved by earlier ones (so
/// give them root to tip). The test uses the sphere radius only, not sphere + hair radius: the
/// body proxy is meant to be drawn slightly inside the skin. For each sphere:
/// * a child strictly inside (`|x − c|² < R²`) is projected radially onto the surface;
/// * if the parent is outside but the segment's interior cuts the sphere, the child is rotated
///   about the parent, keeping the segment's length, until the segment is tangent to the sphere;
/// * a parent inside (e.g. a root planted under the proxy) is left to its own segment: moving the
///   child cannot get such a segment out, so only the child is kept out.
///
/// Afterwards no child node is strictly inside any sphere, even where spheres overlap.
pub fn resolve_body(
    segs: &SegmentsView,
    pos: &mut [Vector3<f64>],
    vel: &mut [Vector3<f64>],
    spheres: &[BodySphere],
    obstacle_velocity: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> u32 {
    let mut pushed = 0;
    for i in 0..segs.len() {
        let (pi, ci) = (segs.parent[i] as usize, segs.child[i] as usize);
        let parent = pos[pi];
        let mut child = pos[ci];
        let mut moved = false;
        for _ in 0..BODY_PASSES {
            let mut changed = false;
            for s in spheres {
                if let Some(c) = push_out(&parent, &child, s) {
                    child = c;
                    changed = true;
                }
            }
            moved |= changed;
            if !changed {
                break;
            }
        }
        if let Some(c) = exit_union(&child, spheres) {
            child = c;
            moved = true;
        }
        if moved {
            pos[ci] = child;
            vel[ci] = obstacle_velocity(&child);
            pushed += 1;
        }
    }
    pushed
}

#[inline]
fn strictly_inside(x: &Vector3<f64>, s: &BodySphere) -> bool {
    (x - s.center).norm_squared() < s.radius * s.radius
}

/// New child position if segment `parent → child` enters sphere `s`, else `None`.
fn push_out(parent: &Vector3<f64>, child: &Vector3<f64>, s: &BodySphere) -> Option<Vector3<f64>> {
    let r2 = s.radius * s.radius;
    let mut x = *child;
    let mut moved = false;
    if strictly_inside(&x, s) {
        let dir = (x - s.center)
            .try_normalize(1e-300)
            .or_else(|| (x - parent).try_normalize(1e-300))
            .unwrap_or_else(Vector3::y);
        x = onto_surface(s, &dir);
        moved = true;
    }
    let w = s.center - parent;
    let dd = w.norm_squared();
    if dd >= r2 {
        let seg = x - parent;
        let l2 = seg.norm_squared();
        if l2 > 0.0 {
            let t = w.dot(&seg) / l2;
            if t > 0.0 && t < 1.0 {
                let q = parent + seg * t;
                if (q - s.center).norm_squared() < r2 * (1.0 - CHORD_TOLERANCE) {
                    // Rotate about the parent onto the tangent cone: angle θ from the centre
                    // direction with sin θ = R / D, in the plane of parent, centre and child.
                    let dlen = dd.sqrt();
                    let wh = w / dlen;
                    let len = l2.sqrt();
                    let u = seg / len;
                    let across = u - wh * wh.dot(&u);
                    let eh = across
                        .try_normalize(1e-300)
                        .unwrap_or_else(|| any_perpendicular(&wh));
                    let sin = (s.radius / dlen).min(1.0);
                    let cos = (1.0 - sin * sin).max(0.0).sqrt();
                    x = parent + (wh * cos + eh * sin) * len;
                    if strictly_inside(&x, s) {
                        let dir = (x - s.center).try_normalize(1e-300).unwrap_or(eh);
                        x = onto_surface(s, &dir);
                    }
                    moved = true;
                }
            }
        }
    }
    moved.then_some(x)
}

/// The point of `s`'s surface in unit direction `dir` from the centre, nudged outwards until
/// rounding no longer leaves it strictly inside.
fn onto_surface(s: &BodySphere, dir: &Vector3<f64>) -> Vector3<f64> {
    let mut rr = s.radius;
    let mut x = s.center + dir * rr;
    for _ in 0..64 {
        if !strictly_inside(&x, s) {
            break;
        }
        rr = rr * (1.0 + 1e-14) + f64::MIN_POSITIVE;
        x = s.center + dir * rr;
    }
    x
}

/// If `x` is strictly inside some sphere after the passes (overlapping spheres), moves it along a
/// fixed ray out of the union: the ray meets each sphere in one interval, so stepping to the far
/// end of each sphere that still contains the point leaves the union in at most one step per
/// sphere.
fn exit_union(x: &Vector3<f64>, spheres: &[BodySphere]) -> Option<Vector3<f64>> {
    let first = spheres.iter().find(|s| strictly_inside(x, s))?;
    let dir = (x - first.center)
        .try_normalize(1e-300)
        .unwrap_or_else(Vector3::y);
    let mut p = *x;
    for _ in 0..=2 * spheres.len() {
        let Some(s) = spheres.iter().find(|s| strictly_inside(&p, s)) else {
            break;
        };
        let o = p - s.center;
        let b = o.dot(&dir);
        let disc = (b * b - (o.norm_squared() - s.radius * s.radius)).max(0.0);
        p += dir * (-b + disc.sqrt()).max(0.0);
        if strictly_inside(&p, s) {
            let d = (p - s.center).try_normalize(1e-300).unwrap_or(dir);
            p = onto_surface(s, &d);
        }
    }
    debug_assert!(
        !spheres.iter().any(|s| strictly_inside(&p, s)),
        "exit_union left {p:?} inside a sphere"
    );
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_params_cross() {
        let (s, t) = closest_segment_params(
            &Vector3::new(-1.0, 0.0, 0.0),
            &Vector3::new(3.0, 0.0, 0.0),
            &Vector3::new(0.0, -1.0, 1.0),
            &Vector3::new(0.0, 1.0, 1.0),
        );
        assert!(
            (s - 0.25).abs() < 1e-15 && (t - 0.5).abs() < 1e-15,
            "{s} {t}"
        );
    }

    #[test]
    fn closest_params_parallel_overlap_takes_middle() {
        // Seg 2 covers x ∈ [1, 3] above seg 1 (x ∈ [0, 2]): overlap [1, 2], middle x = 1.5.
        let (s, t) = closest_segment_params(
            &Vector3::new(0.0, 0.0, 0.0),
            &Vector3::new(2.0, 0.0, 0.0),
            &Vector3::new(1.0, 0.1, 0.0),
            &Vector3::new(3.0, 0.1, 0.0),
        );
        assert!(
            (s - 0.75).abs() < 1e-15 && (t - 0.25).abs() < 1e-15,
            "{s} {t}"
        );
    }
}
