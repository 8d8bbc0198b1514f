//! The helper thread of the pair search: chunks of cells claimed from an atomic counter.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, RwLock};

use super::*;

/// Chunks of cells the pair search is cut into when shared: enough for the two threads to
/// even out, few enough that the hand-over stays cheap.
pub(super) const CHUNKS: usize = 8;

/// What the caller hands to the helper thread and gets back.
pub(super) struct Job {
    pub(super) state: JobState,
    pub(super) bounds: [usize; CHUNKS + 1],
    pub(super) params: Option<ContactParams>,
    /// The helper's contacts, and for each chunk it searched, its span in them.
    pub(super) contacts: Vec<Contact>,
    /// The loads of the chunks it searched: chunk `k`'s per node slot at `k · nodes`.
    pub(super) loads: Vec<f64>,
    pub(super) spans: [(usize, usize); CHUNKS],
    pub(super) stats: PairStats,
}

#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum JobState {
    Idle,
    /// Posted, not yet picked up.
    Run,
    /// The helper is claiming chunks.
    Busy,
    Done,
    Failed,
    Quit,
}

pub(super) struct Shared {
    pub(super) broad: Arc<RwLock<Broad>>,
    pub(super) job: Mutex<Job>,
    pub(super) wake: Condvar,
    /// The next chunk to claim, by either thread.
    pub(super) next: AtomicUsize,
}

/// The helper thread of [`HairCollider`].
pub(super) struct Helper {
    pub(super) shared: Arc<Shared>,
    pub(super) thread: Option<std::thread::JoinHandle<()>>,
}

impl Helper {
    pub(super) fn spawn(broad: Arc<RwLock<Broad>>, contacts: usize, loads: usize) -> Helper {
        let shared = Arc::new(Shared {
            broad,
            job: Mutex::new(Job {
                state: JobState::Idle,
                bounds: [0; CHUNKS + 1],
                params: None,
                contacts: Vec::with_capacity(contacts),
                loads: Vec::with_capacity(loads),
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

    pub(super) fn serve(s: &Shared) {
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
                    let mut loads = std::mem::take(&mut job.loads);
                    drop(job);
                    out.clear();
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        let broad = read(&s.broad);
                        let nodes = broad.inv_mass.len();
                        if loads.len() != CHUNKS * nodes {
                            loads.clear();
                            loads.resize(CHUNKS * nodes, 0.0);
                        }
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
                            let chunk = &mut loads[k * nodes..(k + 1) * nodes];
                            chunk.fill(0.0);
                            stats.add(&broad.search(
                                bounds[k]..bounds[k + 1],
                                &p,
                                eps2,
                                &mut out,
                                chunk,
                            ));
                            spans[k] = (start, out.len());
                        }
                        (stats, spans)
                    }));
                    job = lock(&s.job);
                    job.contacts = out;
                    job.loads = loads;
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
    pub(super) fn start(
        &self,
        bounds: [usize; CHUNKS + 1],
        p: ContactParams,
        wait_for_pickup: bool,
    ) {
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
    pub(super) fn finish(&self) -> std::sync::MutexGuard<'_, Job> {
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

    pub(super) fn stop(mut self) {
        lock(&self.shared.job).state = JobState::Quit;
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
