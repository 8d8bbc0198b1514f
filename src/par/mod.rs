//! The project's thread pool: a fixed set of worker threads that run one job at a time,
//! started once by its owner (the renderer) so that a frame's jobs spawn nothing and, once
//! warm, allocate nothing (a job is a borrowed closure, handed over by pointer).
//!
//! A module of its own, below the renderer and the solvers, so that both can use one pool
//! without a solver importing the renderer. It uses nothing of wisptree's.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// The job being run, its lifetime erased (see [`Pool::run`] for why that is sound).
#[derive(Clone, Copy)]
struct JobPtr(*const (dyn Fn(usize) + Sync + 'static));

// SAFETY: the pointee is `Sync`, and `Pool::run` keeps it alive until every worker is done.
unsafe impl Send for JobPtr {}

struct State {
    generation: u64,
    /// The job of this generation; `None` once it is withdrawn (see [`Pool::for_each`]).
    job: Option<JobPtr>,
    /// Workers that have not yet picked up this generation's job.
    pending: usize,
    /// Workers running it.
    running: usize,
    panicked: bool,
    quit: bool,
}

struct Shared {
    state: Mutex<State>,
    start: Condvar,
    done: Condvar,
}

fn lock(m: &Mutex<State>) -> MutexGuard<'_, State> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// `n` workers: the calling thread (worker 0) and `n − 1` helper threads.
pub struct Pool {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
}

impl Pool {
    /// Starts `n − 1` helper threads (none for `n` ≤ 1), named `wisptree-pool-k`.
    pub fn new(n: usize) -> Result<Pool, String> {
        Pool::named(n, "wisptree-pool")
    }

    /// [`Pool::new`] with the helper threads named `{name}-k` (a thread's name says whose it
    /// is, e.g. to the test that checks the render threads run nicer than the simulation's).
    pub fn named(n: usize, name: &str) -> Result<Pool, String> {
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                generation: 0,
                job: None,
                pending: 0,
                running: 0,
                panicked: false,
                quit: false,
            }),
            start: Condvar::new(),
            done: Condvar::new(),
        });
        let mut threads = Vec::new();
        for k in 1..n.max(1) {
            let s = shared.clone();
            let t = std::thread::Builder::new()
                .name(format!("{name}-{k}"))
                .spawn(move || serve(&s, k))
                .map_err(|e| format!("cannot start pool thread {k}: {e}"))?;
            threads.push(t);
        }
        Ok(Pool { shared, threads })
    }

    /// Number of workers, the caller included.
    pub fn workers(&self) -> usize {
        self.threads.len() + 1
    }

    /// Runs `f(k)` once on every worker k (the caller is worker 0) and returns when all are
    /// done. A panic in any of them is re-raised here.
    pub fn run(&self, f: &(dyn Fn(usize) + Sync)) {
        self.run_with(f, false)
    }

    /// [`Pool::run`]; with `optional`, the helpers that have not picked the job up by the time
    /// the caller is done with its own call are let off (their `f(k)` never runs).
    fn run_with(&self, f: &(dyn Fn(usize) + Sync), optional: bool) {
        if self.threads.is_empty() {
            f(0);
            return;
        }
        let ptr: *const (dyn Fn(usize) + Sync + '_) = f;
        // SAFETY: only the lifetime changes. Workers call the job only between taking it out
        // of the state (under the lock, while it is still there) and decrementing `running`;
        // this function withdraws it and waits for `running` and `pending` to be back to 0
        // before it returns (or unwinds), so `f` outlives every call.
        let ptr: *const (dyn Fn(usize) + Sync + 'static) = unsafe { std::mem::transmute(ptr) };
        {
            let mut st = lock(&self.shared.state);
            st.job = Some(JobPtr(ptr));
            st.pending = self.threads.len();
            st.generation += 1;
            self.shared.start.notify_all();
        }
        let mine = catch_unwind(AssertUnwindSafe(|| f(0)));
        let theirs = {
            let mut st = lock(&self.shared.state);
            if optional || mine.is_err() {
                // Withdrawn: a helper that wakes later finds no job and goes back to sleep.
                st.job = None;
                st.pending = 0;
            }
            while st.running > 0 || st.pending > 0 {
                st = self.shared.done.wait(st).unwrap_or_else(|e| e.into_inner());
            }
            st.job = None;
            std::mem::take(&mut st.panicked)
        };
        if let Err(e) = mine {
            std::panic::resume_unwind(e);
        }
        assert!(!theirs, "a pool worker thread panicked");
    }

    /// Runs `f(i)` for every item `i` in `0..n`, each worker taking the next item not yet
    /// taken, and returns when all are done. Which worker does an item varies from run to run,
    /// so `f` must not depend on it.
    ///
    /// A helper that has not woken up by the time the caller has taken the last item is not
    /// waited for: on a loaded machine (two cores shared with the logging thread and other
    /// processes) the caller then simply does more items, instead of waiting for a
    /// descheduled thread to wake only to find nothing left.
    pub fn for_each(&self, n: usize, f: &(dyn Fn(usize) + Sync)) {
        self.for_each_worker(n, &|_k, i| f(i));
    }

    /// [`Pool::for_each`], `f(k, i)` told which worker k runs item i (to use that worker's
    /// scratch buffers).
    pub fn for_each_worker(&self, n: usize, f: &(dyn Fn(usize, usize) + Sync)) {
        let next = AtomicUsize::new(0);
        self.run_with(
            &|k| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                if i >= n {
                    break;
                }
                f(k, i);
            },
            true,
        );
    }
}

fn serve(s: &Shared, k: usize) {
    let mut seen = 0;
    loop {
        let job = {
            let mut st = lock(&s.state);
            loop {
                while st.generation == seen && !st.quit {
                    st = s.start.wait(st).unwrap_or_else(|e| e.into_inner());
                }
                if st.quit {
                    return;
                }
                seen = st.generation;
                // `None`: the job was withdrawn before this worker woke up.
                if let Some(job) = st.job {
                    st.pending -= 1;
                    st.running += 1;
                    break job;
                }
            }
        };
        // SAFETY: `Pool::run_with` keeps the job alive until `running` drops to 0 below.
        let r = catch_unwind(AssertUnwindSafe(|| unsafe { (*job.0)(k) }));
        let mut st = lock(&s.state);
        if r.is_err() {
            st.panicked = true;
        }
        st.running -= 1;
        if st.running == 0 && st.pending == 0 {
            s.done.notify_all();
        }
    }
}

impl Drop for Pool {
    fn drop(&mut self) {
        lock(&self.shared.state).quit = true;
        self.shared.start.notify_all();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Splits `v` into K consecutive parts, part c ending at index `end(c)` (non-decreasing, the
/// last one at most `v.len()`), each with the index of its first element and behind its own
/// lock, so that K jobs can each fill one at once. An array, not a `Vec`: splitting allocates
/// nothing.
pub fn split_parts<T, const K: usize>(
    v: &mut [T],
    end: impl Fn(usize) -> usize,
) -> [Mutex<(usize, &mut [T])>; K] {
    let mut rest = v;
    let mut taken = 0usize;
    std::array::from_fn(|c| {
        let e = end(c);
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(e - taken);
        rest = tail;
        let first = taken;
        taken = e;
        Mutex::new((first, mine))
    })
}

/// Runs `f(0..n)` on `pool`, or on the calling thread when there is none.
pub fn for_each_on(pool: Option<&Pool>, n: usize, f: &(dyn Fn(usize) + Sync)) {
    match pool {
        Some(p) => p.for_each(n, f),
        None => (0..n).for_each(f),
    }
}

#[cfg(test)]
mod split_tests {
    use super::*;

    /// `for_each` lets off the helpers that are late (see there): every item must still be
    /// done exactly once, call after call, and a helper that missed a withdrawn job must take
    /// the next one; `run` still calls every worker every time.
    #[test]
    fn late_helpers_are_let_off_yet_every_item_is_done_once() {
        let pool = Pool::named(3, "wisptree-test").unwrap();
        let mut by_helpers = 0;
        for round in 0..2000usize {
            let n = round % 7;
            let hits: Vec<AtomicUsize> = (0..n).map(|_| AtomicUsize::new(0)).collect();
            let helped = AtomicUsize::new(0);
            pool.for_each_worker(n, &|k, i| {
                hits[i].fetch_add(1, Ordering::Relaxed);
                if k > 0 {
                    helped.fetch_add(1, Ordering::Relaxed);
                }
                if round % 100 == 0 {
                    // A slow item gives the helpers time to wake and take part.
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
            });
            assert!(
                hits.iter().all(|h| h.load(Ordering::Relaxed) == 1),
                "{round}"
            );
            by_helpers += helped.load(Ordering::Relaxed);
            if round % 10 == 0 {
                let calls: Vec<AtomicUsize> = (0..3).map(|_| AtomicUsize::new(0)).collect();
                pool.run(&|k| {
                    calls[k].fetch_add(1, Ordering::Relaxed);
                });
                assert!(
                    calls.iter().all(|c| c.load(Ordering::Relaxed) == 1),
                    "{round}"
                );
            }
        }
        assert!(by_helpers > 0, "the helpers never took part");
    }

    #[test]
    fn split_parts_cover_the_slice_in_order_with_their_starts() {
        let mut v: Vec<u32> = (0..10).collect();
        let ends = [3, 3, 7, 10];
        let parts = split_parts::<_, 4>(&mut v, |c| ends[c]);
        let got: Vec<(usize, Vec<u32>)> = parts
            .into_iter()
            .map(|m| {
                let (first, s) = m.into_inner().unwrap();
                (first, s.to_vec())
            })
            .collect();
        assert_eq!(
            got,
            vec![
                (0, vec![0, 1, 2]),
                (3, vec![]),
                (3, vec![3, 4, 5, 6]),
                (7, vec![7, 8, 9])
            ]
        );
    }
}
