//! The hair–hair collider: one step's broad phase, narrow phase and response, on one or two threads.

use std::sync::atomic::Ordering;
use std::sync::{Arc, RwLock};

use nalgebra::Vector3;

use super::*;

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
/// simply does more chunks, so sharing never costs much more than one thread. One thread cuts
/// the cells into the same chunks. Each chunk sums the loads of its own contacts as it finds
/// them (on whichever thread searched it); the chunks' loads are then added, and the forces
/// applied, chunk by chunk in cell order, so the forces are bit-identical whatever the thread
/// count and whoever did which chunk. The
/// helper works on buffers it keeps, so a warm step allocates nothing (rayon's injector would:
/// see the module docs).
pub struct HairCollider {
    pub(super) broad: Arc<RwLock<Broad>>,
    pub(super) contacts: Vec<Contact>,
    /// Per node slot: the load, then the repulsion scale (scratch of [`Response`]).
    pub(super) load: Vec<f64>,
    /// Per chunk of the search and node slot: the loads of the chunk's contacts (the chunks
    /// this thread searched).
    pub(super) chunk_loads: Vec<f64>,
    /// Per node slot: 1 / mass, then the friction scale (scratch of [`Response`]).
    pub(super) inv_mass: Vec<f64>,
    pub(super) threads: usize,
    pub(super) helper: Option<Helper>,
    /// Contacts the helper thread found in the last call.
    pub(super) helper_contacts: u32,
    /// Wait for the helper to pick up each search before claiming chunks (tests).
    pub(super) helper_first: bool,
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
            inv_mass: Vec::with_capacity(nodes),
        };
        HairCollider {
            broad: Arc::new(RwLock::new(broad)),
            contacts: Vec::with_capacity(contacts),
            load: Vec::with_capacity(nodes),
            chunk_loads: Vec::with_capacity(CHUNKS * nodes),
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
            self.helper = Some(Helper::spawn(
                self.broad.clone(),
                self.contacts.capacity(),
                self.chunk_loads.capacity(),
            ));
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
            let job = lock(&h.shared.job);
            job.contacts.capacity() * std::mem::size_of::<Contact>() + job.loads.capacity() * 8
        });
        b.boxes.capacity() * std::mem::size_of::<SegBox>()
            + b.pre.capacity() * std::mem::size_of::<SegPre>()
            + (b.lo.capacity() + b.hi.capacity()) * std::mem::size_of::<[u32; 3]>()
            + (b.cell_start.capacity() + b.items.capacity()) * 4
            + self.contacts.capacity() * std::mem::size_of::<Contact>()
            + (self.load.capacity() + self.inv_mass.capacity() + self.chunk_loads.capacity()) * 8
            + b.inv_mass.capacity() * 8
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
        let nodes = force.len();
        {
            let mut b = write(&self.broad);
            b.boxes.clear();
            b.boxes.extend((0..n).map(|i| SegBox::new(segs, pos, i)));
            b.pre.clear();
            b.pre.extend((0..n).map(|i| SegPre::new(segs, pos, vel, i)));
            b.build();
            // As `Response::new` computes it: a slot's mass is its mass as a child.
            b.inv_mass.clear();
            b.inv_mass.resize(nodes, 0.0);
            for i in 0..n {
                b.inv_mass[segs.child[i] as usize] = 1.0 / segs.child_mass[i];
            }
        }
        let eps2 = p.epsilon * p.epsilon;
        self.contacts.clear();
        let broad = read(&self.broad);
        let mut response = Response::new(segs, nodes, &mut self.inv_mass, &mut self.load);
        self.helper_contacts = 0;
        // The search is cut into CHUNKS runs of cells whatever the thread count, and each
        // chunk sums its own loads: the loads are then the chunks' sums added in chunk order,
        // so they are the same bit for bit on one thread or two.
        let bounds = broad.chunk_bounds();
        let shared = self.threads > 1 && n >= MIN_SEGMENTS_TO_SHARE;
        let helper = self.helper.as_ref().filter(|_| shared);
        if let Some(h) = helper {
            h.start(bounds, *p, self.helper_first);
        }
        if self.chunk_loads.len() != CHUNKS * nodes {
            self.chunk_loads.clear();
            self.chunk_loads.resize(CHUNKS * nodes, 0.0);
        }
        // Claim chunks until none is left; the helper does the same, so if it is slow to wake
        // (a busy machine) this thread simply does more of them.
        let mut stats = PairStats::default();
        let mut spans = [None; CHUNKS];
        let mut next = 0;
        loop {
            let k = match helper {
                Some(h) => h.shared.next.fetch_add(1, Ordering::AcqRel),
                None => {
                    next += 1;
                    next - 1
                }
            };
            if k >= CHUNKS {
                break;
            }
            let start = self.contacts.len();
            let loads = &mut self.chunk_loads[k * nodes..(k + 1) * nodes];
            loads.fill(0.0);
            stats.add(&broad.search(bounds[k]..bounds[k + 1], p, eps2, &mut self.contacts, loads));
            spans[k] = Some((start, self.contacts.len()));
        }
        let job = helper.map(|h| h.finish());
        if let Some(job) = &job {
            stats.add(&job.stats);
            self.helper_contacts = job.stats.in_contact;
        }
        // The contacts chunk by chunk, i.e. in cell order: the one-thread order.
        let pick = |k: usize| match (spans[k], &job) {
            (Some((a, b)), _) => (
                &self.contacts[a..b],
                &self.chunk_loads[k * nodes..(k + 1) * nodes],
            ),
            (None, Some(job)) => {
                let (a, b) = job.spans[k];
                (&job.contacts[a..b], &job.loads[k * nodes..(k + 1) * nodes])
            }
            (None, None) => unreachable!("every chunk is searched by one of the threads"),
        };
        let lists: [&[Contact]; CHUNKS] = std::array::from_fn(|k| pick(k).0);
        let loads: [&[f64]; CHUNKS] = std::array::from_fn(|k| pick(k).1);
        response.add_loads(&loads);
        response.apply(&lists, segs, p, force);
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
