//! The hair–hair collider: one step's broad phase, narrow phase and response, on one or two threads.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use nalgebra::Vector3;

use super::*;
use crate::par::{split_parts, Pool};
use crate::simd::boxes::RUN;

/// Chunks of cells the pair search is cut into: enough for two threads to even out, few
/// enough that each chunk's per-node loads stay cheap to add. (16 was tried on 2026-12-06
/// for a finer balance: `examples/interactions.rs long short long_curly --threads 2 --motion
/// shake`, with and without `--split 0.05`, alternated three times, gave ratios from 0.80
/// to 1.11 around 1, no change the noisy machine could show; it would also change the
/// order in which the loads are summed, and with it the determinism hashes.) Tried again on
/// 2026-12-08 with 32 chunks and the loads summed per thread in whole units of `2⁻³²` (integer
/// sums, so that no cut changes the forces; a test checked it with 1, 2, 5, 13 and 31 chunks
/// on one and two threads): the stage alone on two threads 1.09–1.15× faster at the styles'
/// defaults under `shake` (medians by style; single alternations 0.92–1.20;
/// `examples/interactions.rs long long_curly short --motion shake --threads 2`, three
/// alternations), but not in the live pipeline, where each step's own timer gave
/// 1.03× MORE time per contact in the interactions (median of 18 rows of `bench --live --rows
/// "awt long shake,awt short shake,awt short_curly shake"`, five alternations; the real-time
/// factors 0.98×). Not landed.
pub(super) const CHUNKS: usize = 8;

/// Parts the contact list is cut into for the response (see [`HairCollider`]).
pub(super) const PARTS: usize = 2;

/// Below this many contacts the response stays on the calling thread. Sharing it is a second
/// hand-over per step, and one the caller cannot take back once the helper has started its
/// half: on a busy two-core machine (the logging thread holds the other core in a live run) a
/// helper descheduled in the middle of its half stalls the step. Worth it only where the
/// response is milliseconds long: at the page's lowest split threshold (140–280 k contacts
/// per step under `shake`), not at the styles' defaults (20–90 k). The forces do not depend on
/// it (the halves are the same either way). Tried 2026-12-08: sharing from 30 k on, against
/// this, `bench --live --rows "awt long_curly shake,awt short_curly shake"` alternated five
/// times: median 0.97 (0.73–1.40) over 60 pairs of rows, and no gain on the rows it changes
/// (Short curly at its defaults, 32 k contacts, 0.89; Long curly, 89 k, 0.95; with rendering
/// on 1.00 and 1.08).
pub(super) const MIN_CONTACTS_TO_SHARE: usize = 100_000;

/// One worker's contacts: the chunks it searched, and for each its span in `contacts`.
#[derive(Default)]
pub(super) struct WorkerOut {
    pub(super) contacts: Vec<Contact>,
    pub(super) spans: [Option<(usize, usize)>; CHUNKS],
    pub(super) stats: PairStats,
}

/// Reused buffers of the broad phase (uniform voxel grid) and of the response, and the thread
/// pool ([`crate::par::Pool`]) that shares the pair search and the response. Allocation only
/// while warming up (or never, with [`HairCollider::with_capacity`] from the model's size).
///
/// The grid is dense over the segments' bounding box and filled by a counting sort. Each item of
/// a cell list is a segment index with, in its top 3 bits, a mask saying along which axes the
/// segment's cell range starts BELOW this cell. A pair belongs to the min corner of the overlap of
/// its two cell ranges, i.e. to the one shared cell where, on every axis, at least one of the two
/// ranges starts: there the two masks have no bit in common. So the "tested once" rule is one AND
/// on data already in the cell list, without a pair set or a lookup of the ranges.
///
/// Per-segment data is split by temperature: the pair loop reads the cell entries' boxes from
/// arrays kept in cell-list order beside `items` (eight at a time, see [`search_cells`]), the
/// [`SegBox`]'s node slots only when the boxes overlap, and [`SegPre`] (positions, velocities,
/// f64) only for the pairs that pass the box and adjacency tests.
///
/// **Two threads, same result.** The cells are cut into [`CHUNKS`] runs of about equal work,
/// and with [`Self::set_threads`]`(2)` the caller and the pool's helper claim them until none
/// is left ([`Pool::for_each_worker`]). If the helper is slow to wake (the logging thread or
/// another job holds the other core), the caller simply does more chunks and does not wait
/// for it, so sharing never costs much more than one thread. Each chunk sums the loads of its
/// own contacts as it finds them (on whichever thread searched it); the chunks' loads are then
/// added in chunk order. The response then cuts the contacts, in chunk (= cell) order, into
/// [`PARTS`] halves, each adding its forces into a buffer of its own, and the buffers are added
/// to the forces in part order. Neither cut depends on the thread count or on who did what,
/// so the forces are bit-identical on one thread or two. Each worker pushes into buffers it
/// keeps, so a warm step allocates nothing.
pub struct HairCollider {
    pub(super) broad: Broad,
    /// Per pool worker (the caller is worker 0).
    pub(super) out: [Mutex<WorkerOut>; 2],
    /// Per node slot: the load, then the repulsion scale (scratch of [`Response`]).
    pub(super) load: Vec<f64>,
    /// Per chunk of the search and node slot: the loads of the chunk's contacts.
    pub(super) chunk_loads: Vec<f64>,
    /// Per part of the response and node slot: the part's forces.
    pub(super) part_force: Vec<Vector3<f64>>,
    /// Per node slot: 1 / mass, then the friction scale (scratch of [`Response`]).
    pub(super) inv_mass: Vec<f64>,
    /// Per segment: its slots and scales, for the response.
    pub(super) seg_scale: Vec<SegScale>,
    pub(super) threads: usize,
    pub(super) pool: Option<Pool>,
    /// Contacts the helper thread found in the last call.
    pub(super) helper_contacts: u32,
    /// Wait for the helper to pick up each search before claiming chunks (tests).
    pub(super) helper_first: bool,
    /// Contacts from which the response is shared ([`MIN_CONTACTS_TO_SHARE`]; tests lower it).
    pub(super) min_contacts_to_share: usize,
}

impl Default for HairCollider {
    fn default() -> Self {
        Self::with_capacity(0, 0, 0)
    }
}

impl HairCollider {
    /// A collider with no buffer reserved.
    pub fn new() -> Self {
        Self::default()
    }

    /// A collider whose buffers already hold `segments` segments over `nodes` node slots and
    /// `contacts` contacts (per worker), so that steps within those sizes never allocate. One
    /// thread.
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
            items: Vec::with_capacity(ITEMS_PER_SEGMENT * segments + RUN),
            entries: EntryBoxes::with_capacity(ITEMS_PER_SEGMENT * segments + RUN),
            grid: GridInfo::default(),
            inv_mass: Vec::with_capacity(nodes),
            ends: Vec::with_capacity(segments),
        };
        let out = || {
            Mutex::new(WorkerOut {
                contacts: Vec::with_capacity(contacts),
                ..WorkerOut::default()
            })
        };
        HairCollider {
            broad,
            out: [out(), out()],
            load: Vec::with_capacity(nodes),
            chunk_loads: Vec::with_capacity(CHUNKS * nodes),
            part_force: Vec::with_capacity(PARTS * nodes),
            inv_mass: Vec::with_capacity(nodes),
            seg_scale: Vec::with_capacity(segments),
            threads: 1,
            pool: None,
            helper_contacts: 0,
            helper_first: false,
            min_contacts_to_share: MIN_CONTACTS_TO_SHARE,
        }
    }

    /// Threads used by the pair search and the response: 1, or 2 (more are treated as 2).
    /// The forces do not depend on it. The pool's helper thread starts here (once).
    pub fn set_threads(&mut self, threads: usize) {
        self.threads = threads.clamp(1, 2);
        if self.threads > 1 && self.pool.is_none() {
            self.pool = Some(
                Pool::named(2, "wisptree-collide")
                    .unwrap_or_else(|e| panic!("the collider's thread pool: {e}")),
            );
        }
    }

    /// Threads of the pair search.
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

    /// Shares the response from `n` contacts on instead of [`MIN_CONTACTS_TO_SHARE`], so that
    /// tests reach the shared response with small scenes. The result is the same either way.
    #[doc(hidden)]
    pub fn set_min_contacts_to_share(&mut self, n: usize) {
        self.min_contacts_to_share = n;
    }

    /// How many of the last call's contacts the helper thread found (0 on one thread).
    pub fn helper_contacts(&self) -> u32 {
        self.helper_contacts
    }

    /// The grid built by the last call to [`Self::accumulate`].
    pub fn grid(&self) -> GridInfo {
        self.broad.grid
    }

    /// Bytes reserved by the reused buffers (stays constant once warmed up on a scene size).
    pub fn capacity_bytes(&self) -> usize {
        let b = &self.broad;
        let out: usize = self
            .out
            .iter()
            .map(|o| lock(o).contacts.capacity() * std::mem::size_of::<Contact>())
            .sum();
        b.boxes.capacity() * std::mem::size_of::<SegBox>()
            + b.entries.capacity_bytes()
            + b.pre.capacity() * std::mem::size_of::<SegPre>()
            + (b.lo.capacity() + b.hi.capacity()) * std::mem::size_of::<[u32; 3]>()
            + (b.cell_start.capacity() + b.items.capacity()) * 4
            + out
            + (self.load.capacity() + self.inv_mass.capacity() + self.chunk_loads.capacity()) * 8
            + self.part_force.capacity() * std::mem::size_of::<Vector3<f64>>()
            + b.inv_mass.capacity() * 8
            + b.ends.capacity() * std::mem::size_of::<SegEnds>()
            + self.seg_scale.capacity() * std::mem::size_of::<SegScale>()
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
        let nodes = force.len();
        self.broad.prepare(segs, pos, vel, nodes);
        let eps2 = (p.epsilon * p.epsilon) as f32;
        let broad = &self.broad;
        let mut response = Response::new(segs, nodes, &mut self.inv_mass, &mut self.load);
        // The search is cut into CHUNKS runs of cells whatever the thread count, and each
        // chunk sums its own loads: the loads are then the chunks' sums added in chunk order,
        // so they are the same bit for bit on one thread or two.
        let bounds = broad.chunk_bounds();
        let pool = self
            .pool
            .as_ref()
            .filter(|_| self.threads > 1 && n >= MIN_SEGMENTS_TO_SHARE);
        if self.chunk_loads.len() != CHUNKS * nodes {
            self.chunk_loads.clear();
            self.chunk_loads.resize(CHUNKS * nodes, 0.0);
        }
        for o in &mut self.out {
            let o = o.get_mut().unwrap_or_else(|e| e.into_inner());
            o.contacts.clear();
            o.spans = [None; CHUNKS];
            o.stats = PairStats::default();
        }
        {
            let loads = split_parts::<_, CHUNKS>(&mut self.chunk_loads, |k| (k + 1) * nodes);
            let out = &self.out;
            let helper_started = AtomicBool::new(false);
            let helper_first = self.helper_first && pool.is_some();
            let level = crate::simd::level();
            let search = |worker: usize, k: usize| {
                if worker > 0 {
                    helper_started.store(true, Ordering::Release);
                } else if helper_first {
                    while !helper_started.load(Ordering::Acquire) {
                        std::thread::yield_now();
                    }
                }
                let mut o = lock(&out[worker]);
                let mut chunk = lock(&loads[k]);
                let chunk = &mut *chunk.1;
                chunk.fill(0.0);
                let o = &mut *o;
                let start = o.contacts.len();
                let st = search_cells(
                    level,
                    broad,
                    bounds[k]..bounds[k + 1],
                    p,
                    eps2,
                    &mut o.contacts,
                    chunk,
                );
                o.stats.add(&st);
                o.spans[k] = Some((start, o.contacts.len()));
            };
            match pool {
                Some(pool) => pool.for_each_worker(CHUNKS, &search),
                None => (0..CHUNKS).for_each(|k| search(0, k)),
            }
        }
        let [o0, o1] = &mut self.out;
        // The pool is done: nothing else holds the locks.
        let out: [&WorkerOut; 2] =
            [o0, o1].map(|o| &*o.get_mut().unwrap_or_else(|e| e.into_inner()));
        let mut stats = PairStats::default();
        stats.add(&out[0].stats);
        stats.add(&out[1].stats);
        self.helper_contacts = out[1].stats.in_contact;
        // The contacts chunk by chunk, i.e. in cell order: the one-thread order.
        let pick = |k: usize| {
            let (w, (a, b)) = (0..2)
                .find_map(|w| out[w].spans[k].map(|s| (w, s)))
                .expect("every chunk is searched by one of the threads");
            (
                &out[w].contacts[a..b],
                &self.chunk_loads[k * nodes..(k + 1) * nodes],
            )
        };
        let lists: [&[Contact]; CHUNKS] = std::array::from_fn(|k| pick(k).0);
        let loads: [&[f64]; CHUNKS] = std::array::from_fn(|k| pick(k).1);
        response.add_loads(&loads);
        let total: usize = lists.iter().map(|l| l.len()).sum();
        let pool = pool.filter(|_| total >= self.min_contacts_to_share);
        response.apply_parts(
            &lists,
            segs,
            p,
            (&mut self.part_force, &mut self.seg_scale),
            pool,
            force,
        );
        stats
    }
}
