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
//! The files, in the order a step uses them:
//!
//! * `mod.rs`: the inputs and outputs ([`SegmentsView`], [`ContactParams`], [`PairStats`]);
//! * `collider.rs`: [`HairCollider`], one step's broad phase, narrow phase and response, on one
//!   or two threads (the project's pool, [`crate::par::Pool`]);
//! * `grid.rs`: the broad phase, a uniform voxel grid of segment boxes;
//! * `narrow.rs`: per-segment data, the cheap filters and the closest points of two segments;
//! * `batch.rs`: the candidate pairs queued as index pairs, tested in vector lanes by
//!   [`crate::simd::pairs`], which reads the segments straight from their [`SegPre`] records;
//! * `response.rs`: friction and repulsion from the contacts, split onto the nodes;
//! * `body.rs`: the body spheres;
//! * `reference.rs`: [`accumulate_brute_force`], the all-pairs reference the tests compare
//!   the grid against.
//!
//! # Choices where the papers leave room
//!
//! * **Closest points in f32, eight pairs at a time.** The closest points are Ericson's routine
//!   (the one `parry3d` uses in `closest_points_segment_segment_with_locations_nD`), written
//!   twice bit for bit: in eight `f32` lanes (`crate::simd::pairs`) and as the scalar
//!   [`narrow::contact`] that the lanes hand their rare cases to. Since 2026-12-07 (night)
//!   the narrow phase works in `f32` (until then four `f64` lanes): twice the lanes and a
//!   segment record of one cache line, for 1.2–1.3× on the stage
//!   (`docs/performance-history.md`). The positions of a head of hair are within a metre or
//!   two of the origin, where `f32` rounds
//!   to about 0.1 µm against wisp radii of a millimetre and more; a test compares the `f32`
//!   closest points with the `f64` routine ([`closest_segment_params`], itself compared with
//!   parry) to 1 µm. The thresholds that tell parallel and intersecting axes apart sit well
//!   above that rounding (`crate::simd::pairs::{PARALLEL, INTERSECTING}`). Parameters are
//!   reported as `s`, the weight of the CHILD node (`P = (1 − s)·N_parent + s·N_child`), i.e.
//!   the paper's `u` is `1 − s`. For (near-)parallel axes (within about 0.6°) the closest
//!   points are not unique or not well conditioned; we take the middle of the overlap of the
//!   two segments (parry takes an end), so friction between parallel wisps — the common case —
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
//!   paper styles under `lean`.) Under `shake` those sibling contacts are few:
//!   `examples/contact_kinds.rs` (2026-12-07) finds 9 % siblings, 27 % other wisps of the
//!   same top-level wisp and 64 % different top-level wisps on `long`, 15 %, 1 %, 84 % on
//!   `short`, and 4 %, 14 %, 83 % on `long_curly` at split 0.05 (847 k contacts a step). So
//!   leaving siblings (or a whole tree) out would not make the pair stage much cheaper.
//!   The same probe groups the contacts by pair of chains: 40 k pairs of chains with 4.5
//!   contacts each on `long` (55 % of the contacts go on to the next segment of both chains),
//!   24 k with 6.3 on `short` (57 %), 51 k with 16.5 on `long_curly` at split 0.05 (82 %): the
//!   structure a search walking two touching wisps along each other could use.
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
//! * **The candidate loop filters eight entries at a time.** The counting sort that fills the
//!   cell lists also writes each entry's f32 box into structure-of-arrays bounds in the same
//!   order (`EntryBoxes` in `grid.rs`), so for each entry `a` of a cell the entries after it
//!   are tested in runs of eight by `crate::simd::boxes` (AVX2: one integer test of the
//!   "tested once" masks and six compares of the bounds; a portable twin). Only the survivors,
//!   in cell order, read their [`SegBox`] (adjacency) and [`SegPre`] (relative motion), so the
//!   narrow phase sees the same pairs in the same order and the forces are the same bits.
//!   Under `shake` on `long` (3 s, one thread) a call visits 2.9–3.3 M entry pairs, of which
//!   1.1–1.3 M pass the mask, 0.6 M the boxes and 0.3 M the relative-motion test.
//!   2026-12-07, the stage alone on one thread against the build before: a few per cent
//!   (after ÷ before medians 0.91–0.99 by style; `docs/performance-history.md` has the
//!   figures). Tried then and not landed: queuing every pair whose boxes overlap and counting
//!   it only if it passes [`adjacent`] and [`moving`], so as not to branch on the latter (a
//!   coin toss under `shake`): 1.13–1.29× slower on `long`, since each queue slot's address
//!   then waits for the previous pair's loads where a predicted branch lets the processor run
//!   ahead. Before that
//!   (2026-12-06), the box test alone was two SSE compares on an aligned copy of each
//!   segment's bounds, read through the cell list's index: 3–4 % off the stage.
//!   The rest of this point is older. Testing a voxel's segments eight pairs at a time (box,
//!   adjacency and relative-motion tests in AVX2 lanes over a per-voxel copy) was tried and
//!   measured no faster, under `lean` and under `shake` at split threshold 0.05 alike: the
//!   mask test rejects most visits for a few instructions, and the cost is in the pairs that
//!   pass (copying them into the narrow phase's lanes, the closest points, the response), about
//!   90 % of a step at split 0.05 (≈ 280 k contacts per step on `long_curly` over the first
//!   second of `shake`), against ≈ 1 % for the grid and ≈ 2 % for the adaptation. Measured
//!   again with `examples/interactions.rs --motion shake --split 0.05` (long_curly, 1.1 M
//!   contacts per step at 3 s, 1.5 M pairs tested out of 6 M cell-pair visits): branch-free
//!   filters (the passing pairs compacted into a list), with or without a per-cell
//!   structure-of-arrays copy of the boxes, were no faster; a bounding-sphere test beside the
//!   boxes (middle, half length + radius) removes only 4–6 % of the tested pairs (the wisps
//!   are mostly parallel) and was no faster either. Per tested pair, about a fifth of the
//!   stage is the lanes' closest points, and the rest copying the pair into the lanes,
//!   writing the contact and the response. Two more, measured the same way on 2026-12-05
//!   (3 s of `shake` at split 0.05 on `long_curly`, one thread, 63–68 ms a call whatever the
//!   variant): cells of 1, 1.5 or 2 mean segment lengths instead of 3 (with up to 8 or 32
//!   cells per segment) cut the candidates from 4.2 M to 2.6–3.4 M but not the time, the
//!   tested pairs staying at 1.5–1.7 M; and copying each cell's segments side by side before
//!   its pairs, so that the filters and the lanes read the L1 cache instead of all over the
//!   1.3 MB of [`SegPre`], was 1–2 % slower. So the pairs are not waiting on memory for their
//!   segments: the stage is bound by the work per tested pair (≈ 42 ns, ≈ 130 cycles, of
//!   which about a third is the candidate loop's filters and branches, a fifth the closest
//!   points, a quarter writing and reading back the 1.1 M contacts (53 MB a step, more than
//!   the L3 cache) and the rest copying into the lanes). That copy is gone since 2026-12-06:
//!   the lanes now load four segment records and transpose them in registers
//!   (`crate::simd::pairs`), the stage 1.16× faster (`examples/interactions.rs short
//!   --motion shake`, one thread: 10.3 → 8.8 ms a call for 224–240 k tested pairs).
//!   Moving the relative-motion test into the lanes too (the scalar loop then only tests
//!   the boxes), with or without prefetching each queued pair's records, measured within
//!   ±3 % of this (same runs; under `shake` every pair whose boxes overlap moves, so that
//!   test rejects nothing there and only moves the first read of the records); aligning each
//!   record to a cache line, 1 %. Neither landed. (A first try of the former read 2.3× slower
//!   because a closure in the generic kernel was not compiled for AVX2: helpers the kernel
//!   calls must be `#[inline(always)]` functions, not closures.) Testing adjacency in the
//!   eight-entry filter too (parent, child and chain copied beside the boxes in cell-list
//!   order, five integer compares per run, so a survivor no longer reads its [`SegBox`]) was
//!   1.03× slower on 2026-12-07 (the whole `interactions long short --motion shake` process,
//!   the two builds alternated eight times, after ÷ before wall 0.99–1.09): the compares
//!   cost every visit, and the box read they spare was not waiting on memory.
//! * **Where a tested pair's time goes, and five more tries that did not pay** (2026-12-07,
//!   `examples/interactions.rs long short --motion shake`, one thread; "×" is the whole
//!   process, before ÷ after wall, median of the builds alternated 4–6 times). Switching the
//!   stages off one by one on `long` (the scene then has no hair–hair forces, so it is
//!   denser: 3.0 M cell-pair candidates, 0.73 M box overlaps a step): about 2 ns a
//!   candidate for the cell loop and its eight-entry filter, 7 ns a box overlap for the
//!   adjacency and relative-motion tests, and the rest, about 29 ns a tested pair, for the
//!   lanes, writing the contact with its loads and the response. Tried, not landed:
//!   - segments numbered chain by chain (so that the entries of a cell that follow each
//!     other are often one wisp's consecutive segments, side by side in memory): 0.93×;
//!     tried again on 2026-12-07 (night) in the whole pipeline (`wisptree bench --live
//!     --rows "awt long"`, alternated three times): 0.96× (median of 84 pairs of rows).
//!     Numbered cross-section by cross-section, as gathered, the wisps that share a cell
//!     are near one another in each cross-section's run of slots too;
//!   - the response's contact loop built for AVX2 (its `f64` triples in three-operand
//!     instructions instead of SSE2 shuffles), 2026-12-07 (night): 1.00× (median of six
//!     alternations);
//!   - [`Contact`] records of 28 bytes instead of 40, the repulsion (6–19 % of the contacts
//!     under `shake`: 6 % on `long_curly` at split 0.05, 19 % on `long`) kept in a side list
//!     by contact index, the same forces bit for bit, 2026-12-07 (night): no faster (per call,
//!     five alternations: 1.00× within ±4 % on `long_curly` at split 0.05, medians 0.95× and
//!     0.93× on `long` and `short`). The contact list is larger than the L3 cache there,
//!     but writing and reading it back is not what the stage waits on;
//!   - the grid holding pieces of four consecutive segments of one chain instead of
//!     segments, each pair of overlapping pieces filtering its 4 × 4 segment pairs at once
//!     (boxes, adjacency and relative motion without a branch): 0.81×. On `long` at 2 s a
//!     step has 103 k pairs of pieces for 333 k tested pairs (pieces of two: 172 k): the
//!     block filter moves the cost of the candidate loop, it does not remove it;
//!   - the lanes computing two groups of four pairs side by side (two independent chains of
//!     divisions): the lanes' share of the profile rose from 21 % to 31 % (sixteen
//!     registers cannot hold both groups' segments);
//!   - the lanes reading the velocities and masses only once the closest points are known:
//!     0.96× (0.93–1.03);
//!   - the first segment's velocities read once per entry instead of once per pair in the
//!     candidate loop: 1.04× and 1.01× in two series, within the machine's noise;
//!   - the AVX2 builds compiled with AVX-512 enabled too (this machine's processor has it:
//!     32 vector registers, compares into mask registers, the same bits), 2026-12-08:
//!     `interactions long long_curly --motion shake --split 0.05`, one thread, alternated
//!     three times, no change (per call 11.3–12.2 ms before, 11.8–14.0 ms after on `long`;
//!     31.0–34.9 and 32.3–33.7 ms on `long_curly`);
//!   - the response and the loads keeping the first segment's two node sums in registers
//!     while consecutive contacts share that segment (stored once per run instead of each
//!     contact waiting for the previous one's store; the same additions in the same order,
//!     so the same bits), 2026-12-08, same runs, alternated four times: no change (`long`
//!     11.3–12.1 ms before, 11.7–12.5 after; `long_curly` 31.1–32.6 and 31.6–32.3).
//!     The store-to-load chains are not what the response waits on either;
//!   - the response's part buffers padded to four `f64` per node (one load, add and store of
//!     two SSE2 registers per node instead of three scalars, the same bits), 2026-12-08,
//!     same runs, alternated three times: no change (`long` 12.1–13.1 ms before, 12.2–12.7
//!     after; `long_curly` 32.5–34.8 and 33.4–34.4);
//!   - the loads summed per segment end (two neighbouring `f64` per segment, the node's
//!     `1 / mass` applied once per chunk afterwards) instead of per node: two cache lines
//!     written per contact instead of four and no multiplication by the inverse masses,
//!     2026-12-08, same runs plus `long short --motion shake`, alternated three times: no
//!     change (`long_curly` 31.0–31.8 ms before, 31.1–31.5 after; `long` at its defaults
//!     6.7–7.1 and 6.8–6.9).
//!
//!   Where the rest goes, by switching parts off (2026-12-08, same runs and states, one
//!   thread, three alternations): without the response, `long_curly` 25.9–27.5 ms a call
//!   instead of 31.9–33.5 and `long` 9.9–10.6 instead of 12.1–12.4; without storing the
//!   contacts either, 22.3–23.9 and 8.8–9.0. So per contact about 7 ns for the response and
//!   4 ns for writing the contact, on both styles alike, although Long curly's 36 MB of
//!   contacts a step overflow the 32 MB L3 cache and Long's 12 MB do not: neither waits on
//!   memory.
//!
//!   What did pay: [`moving`] stopping at the first velocity difference that passes
//!   (1.04–1.05× under `shake`, see there).
//! * **No candidate pairs kept from step to step.** A list built once per frame and reused for
//!   its four steps (temporal coherence, with a margin) would have to hold every pair that
//!   comes within reach during the frame. Measured on 2026-12-07 with
//!   `examples/coherence_probe.rs` (3 s of `shake`): every frame has splits or merges (so the
//!   segments themselves change); the largest node displacement over a frame is 9–11 cm
//!   (median), up to 16 cm, in the head's frame: 3 to 10 segment lengths (under `lean` on
//!   `long`, median 2 cm, p90 9 cm); and a list with that margin holds 12–16× the pairs whose
//!   boxes overlap at one step (`long` and `short` at their defaults, `long_curly` at split
//!   0.05; 3.6× under `lean` on `long`). The search already tests just those pairs (under
//!   `shake` the tested pairs are the overlapping boxes within 1 %), so the grid is rebuilt
//!   every step.
//! * **Filters are conservative and shared.** Box overlap (each box inflated by its own radius
//!   and rounded outwards to f32, so two boxes overlap whenever the segments are within
//!   `r1 + r2` on every axis), adjacency and the
//!   relative-motion test are symmetric and computed from per-segment data gathered once per step;
//!   the closest points and the response are computed with the lower segment index first (cell
//!   lists are ascending), as in [`accumulate_brute_force`], so both find the same contacts with
//!   bit-identical pair forces (only the order in which they are summed differs).
//! * **Two threads, same forces.** The pair search (the cell loop and the closest points) and
//!   the response are shared with the helper of a two-worker [`crate::par::Pool`] (the
//!   project's one pool implementation; the collider owns its instance, so that a solver
//!   depends on nothing above it), work item by work item, see [`HairCollider`]; the cuts into
//!   items do not depend on the thread count, so the result is bit-identical. (A fixed
//!   half-and-half split was tried first: on a loaded 2-core machine the caller then often
//!   waited for a descheduled helper, and `wisptree run` took 4.5–8 s instead of ~4; the pool's
//!   `for_each` therefore lets off a helper that has not woken by the time the caller has
//!   taken the last item.) rayon was tried too (15–30 % faster on 2 busy cores) but every call
//!   from outside its pool pushes a job on its injector, which allocates a 1.5 kB block every
//!   63 jobs and breaks the no-allocation guarantee (tests/alloc.rs); the project's pool hands
//!   a borrowed closure over by pointer and allocates nothing.

use std::sync::Mutex;

mod batch;
mod body;
mod collider;
mod grid;
mod narrow;
mod reference;
mod response;

use batch::*;
pub use body::*;
pub use collider::*;
pub use grid::*;
pub use narrow::*;
pub use reference::*;
pub use response::*;

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

    /// No segment.
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
/// Everything but the indices is f32, as the narrow phase computes it (`crate::simd::pairs`):
/// the forces only scale the f64 force accumulators, the same value goes to both sides (so pair
/// forces still cancel exactly), and the list is the largest buffer of the step (up to a
/// million entries of 40 bytes under `shake` at the lowest split threshold).
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    /// The first segment of the pair.
    pub a: u32,
    /// The second segment.
    pub b: u32,
    /// Closest points as fractions from parent (0) to child (1) on `a` and `b`.
    pub s: f32,
    /// Closest-point parameter on the second segment.
    pub t: f32,
    /// Friction (eq. 1) and repulsion (eq. 2) on `a`; `b` gets the opposite.
    pub friction: [f32; 3],
    /// Repulsion force on the first segment, N.
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

impl PairStats {
    pub(super) fn add(&mut self, o: &PairStats) {
        self.candidates += o.candidates;
        self.tested += o.tested;
        self.in_contact += o.in_contact;
    }
}

// The locks only guard plain buffers: a panic elsewhere leaves them consistent enough to reuse
// (they are cleared before every use), so poisoning is ignored.
pub(super) fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
