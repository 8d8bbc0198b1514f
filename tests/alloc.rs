//! The per-step loop does no allocation once warm (issue 5): a counting global allocator in this
//! test binary counts every `alloc`/`alloc_zeroed`/`realloc` made by the measuring thread while
//! the simulation steps.
//!
//! Warm-up runs long enough that every reused buffer reached its high-water mark: the `lean`
//! motion repeats every 2.2 s, so the counted steps replay a motion period the warm-up already
//! went through. A non-zero count is therefore a real per-step allocation, not a first-time
//! growth.
//!
//! To see where allocations happen:
//! `WISPTREE_ALLOC_TRACE=5 cargo test --release --test alloc -- --ignored --nocapture`
//! prints a backtrace for each of the first 5 counted allocations of each test.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::sync::Arc;

use nalgebra::Point3;
use wisptree::frame::Frame;
use wisptree::motion::Motion;
use wisptree::pipeline::FrameBuilder;
use wisptree::solver::awt::{Simulation, StepReport};

struct Counting;

thread_local! {
    /// Counting is per thread, so tests running in parallel do not see each other.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
    static BYTES: Cell<u64> = const { Cell::new(0) };
    /// Backtraces still to print on this thread.
    static TRACES_LEFT: Cell<u32> = const { Cell::new(0) };
}

fn note(size: usize) {
    // `try_with`: the allocator may run while a thread's locals are being torn down.
    if COUNTING.try_with(|c| c.get()) != Ok(true) {
        return;
    }
    let _ = ALLOCS.try_with(|a| a.set(a.get() + 1));
    let _ = BYTES.try_with(|b| b.set(b.get() + size as u64));
    let left = TRACES_LEFT.try_with(|t| t.get()).unwrap_or(0);
    if left > 0 {
        // Capturing and printing allocate: stop counting meanwhile.
        COUNTING.with(|c| c.set(false));
        TRACES_LEFT.with(|t| t.set(left - 1));
        let bt = std::backtrace::Backtrace::force_capture();
        eprintln!("--- allocation of {size} bytes ---\n{bt}");
        COUNTING.with(|c| c.set(true));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Runs `f` and returns its result with the allocations (count, bytes) it made on this thread.
fn counted<R>(f: impl FnOnce() -> R) -> (R, u64, u64) {
    ALLOCS.with(|a| a.set(0));
    BYTES.with(|b| b.set(0));
    COUNTING.with(|c| c.set(true));
    let r = f();
    COUNTING.with(|c| c.set(false));
    (r, ALLOCS.with(|a| a.get()), BYTES.with(|b| b.get()))
}

fn arm_traces() {
    let n = std::env::var("WISPTREE_ALLOC_TRACE")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    TRACES_LEFT.with(|t| t.set(n));
}

fn simulation(style: &str, single_level: bool) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("styles")
        .join(style);
    let (loaded, model) = wisptree::scene::load_model(
        &wisptree::style::builtin::StyleSource::File(path.to_path_buf()),
    )
    .expect("the style loads");
    let model = Arc::new(model);
    let motion = Motion::parse("lean", Point3::from(model.scalp_center)).expect("lean");
    Simulation::from_style(model, &loaded.style, motion, single_level)
}

/// Steps of one `lean` period (2.2 s).
fn period_steps(sim: &Simulation) -> usize {
    (2.2 / sim.params.dt).round() as usize
}

/// Largest per-step sizes seen so far in a simulation's life (warm-up included): the numbers
/// that size its reused buffers.
#[derive(Default, Clone, Copy)]
struct Highs {
    active: usize,
    contacts: u32,
    tested: u32,
    events: usize,
}

/// One step that allocated.
struct Allocating {
    step: usize,
    allocs: u64,
    bytes: u64,
    events: usize,
    active: usize,
    contacts: u32,
    /// Which of the sizes set a new record in this step (a high-water mark, not a leak).
    records: String,
}

/// What counting allocations over a run of steps found.
struct Tally {
    steps: usize,
    allocs: u64,
    bytes: u64,
    /// The first allocating steps.
    first: Vec<Allocating>,
    allocating_steps: usize,
}

fn count_steps(
    sim: &mut Simulation,
    report: &mut StepReport,
    highs: &mut Highs,
    steps: usize,
) -> Tally {
    let mut first = Vec::with_capacity(16);
    let (mut allocs, mut bytes, mut allocating_steps) = (0, 0, 0);
    arm_traces();
    for i in 0..steps {
        let ((), a, b) = counted(|| sim.step(report));
        let c = &report.counters;
        let (active, events) = (sim.active_count(), report.events.len());
        if a > 0 {
            allocating_steps += 1;
            allocs += a;
            bytes += b;
            if first.len() < first.capacity() {
                let mut records = String::new();
                let mut record = |what: &str, now: u64, before: u64| {
                    if now > before {
                        records += &format!(" new max {what} {now} > {before};");
                    }
                };
                record("active nodes", active as u64, highs.active as u64);
                record(
                    "pairs in contact",
                    u64::from(c.pairs_in_contact),
                    u64::from(highs.contacts),
                );
                record(
                    "pairs tested",
                    u64::from(c.pairs_tested),
                    u64::from(highs.tested),
                );
                record("events", events as u64, highs.events as u64);
                first.push(Allocating {
                    step: i,
                    allocs: a,
                    bytes: b,
                    events,
                    active,
                    contacts: c.pairs_in_contact,
                    records,
                });
            }
        }
        highs.active = highs.active.max(active);
        highs.contacts = highs.contacts.max(c.pairs_in_contact);
        highs.tested = highs.tested.max(c.pairs_tested);
        highs.events = highs.events.max(events);
    }
    Tally {
        steps,
        allocs,
        bytes,
        first,
        allocating_steps,
    }
}

fn describe(name: &str, t: &Tally) -> String {
    let mut s = format!(
        "{name}: {} allocations ({} bytes) in {} of {} steps",
        t.allocs, t.bytes, t.allocating_steps, t.steps
    );
    for x in &t.first {
        s += &format!(
            "\n  step {}: {} allocations, {} bytes ({} events, {} active nodes, {} contacts;{})",
            x.step,
            x.allocs,
            x.bytes,
            x.events,
            x.active,
            x.contacts,
            if x.records.is_empty() {
                " no new maximum"
            } else {
                &x.records
            }
        );
    }
    s
}

/// Warm-up over two `lean` periods (counted, to show the buffers growing to their high-water
/// marks), then the counted steady state: two more periods, of which the second is asserted.
fn awt_allocations(style: &str) -> [Tally; 4] {
    let mut sim = simulation(style, false);
    let mut report = StepReport::default();
    let period = period_steps(&sim);
    let mut highs = Highs::default();
    let tallies = std::array::from_fn(|_| count_steps(&mut sim, &mut report, &mut highs, period));
    for (i, t) in tallies.iter().enumerate() {
        eprintln!(
            "{}",
            describe(&format!("{style} AWT, lean period {}", i + 1), t)
        );
    }
    tallies
}

/// Sanity check of the instrument: it does see allocations made on this thread.
#[test]
fn the_allocator_counts_this_threads_allocations() {
    let (v, n, bytes) = counted(|| {
        let mut v: Vec<u64> = Vec::with_capacity(10);
        v.extend(0..10);
        std::hint::black_box(v)
    });
    assert_eq!(v.len(), 10);
    assert_eq!(n, 1);
    assert_eq!(bytes, 80);
    // A reserved, warm Vec that is cleared and refilled does not allocate.
    let mut v = v;
    let ((), n, _) = counted(|| {
        v.clear();
        v.extend(0..10);
    });
    assert_eq!(n, 0);
}

/// Single-level mode (no adaptation): the dynamics and collision code alone.
#[test]
fn single_level_step_does_not_allocate_once_warm() {
    let mut sim = simulation("short_curly.ron", true);
    let mut report = StepReport::default();
    let mut highs = Highs::default();
    // A whole lean period of warm-up: contacts and the grid's extent grow with the motion.
    let period = period_steps(&sim);
    let warm = count_steps(&mut sim, &mut report, &mut highs, period);
    eprintln!("{}", describe("single-level short_curly warm-up", &warm));
    // The start of the next period replays the motion's start.
    let t = count_steps(&mut sim, &mut report, &mut highs, 60);
    assert_eq!(t.allocs, 0, "{}", describe("single-level short_curly", &t));
}

/// The adaptive step on Long (3 levels, rigid links, the most splits and merges of the four
/// styles), in the 4th `lean` period.
#[test]
fn awt_step_does_not_allocate_once_warm_long() {
    let t = awt_allocations("long.ron");
    assert_eq!(t[3].allocs, 0, "{}", describe("long AWT, period 4", &t[3]));
}

/// The adaptive step on Long curly (soft springs: the implicit solve's scratch).
#[test]
fn awt_step_does_not_allocate_once_warm_long_curly() {
    let t = awt_allocations("long_curly.ron");
    assert_eq!(
        t[3].allocs,
        0,
        "{}",
        describe("long_curly AWT, period 4", &t[3])
    );
}

/// The stricter goal: no allocation even while the active set, the contact list and the grid
/// grow, from the very first step: every buffer is reserved from the model's size when the
/// simulation is built (`Slots`, the collider's grid, cell lists and contact list, the adapt
/// scratch) or by `Simulation::new_report` (events, per-level counts).
///
/// The hair–hair search runs on two threads here (forced below); the helper thread only ever
/// pushes into its own contact list, reserved when it starts,
/// and this counter sees only the test thread, so the collider's reserved bytes are checked too.
#[test]
fn awt_step_does_not_allocate_from_the_first_step() {
    let mut sim = simulation("long.ron", false);
    sim.set_threads(2);
    let mut report = sim.new_report();
    let mut highs = Highs::default();
    let steps = period_steps(&sim);
    let reserved = sim.reserved_bytes();
    let t = count_steps(&mut sim, &mut report, &mut highs, steps);
    assert_eq!(t.allocs, 0, "{}", describe("long AWT, first period", &t));
    assert_eq!(
        sim.reserved_bytes(),
        reserved,
        "the collider's buffers (incl. the helper thread's) grew"
    );
}

/// Building a display frame (followers, Catmull-Rom strands) reuses its buffers.
#[test]
fn frame_building_does_not_allocate_once_warm() {
    let mut sim = simulation("long_curly.ron", false);
    let mut report = StepReport::default();
    let mut builder = FrameBuilder::new(&sim.model, 500, 4);
    let mut frame = Frame::default();
    for _ in 0..50 {
        for _ in 0..4 {
            sim.step(&mut report);
        }
        builder.fill(&mut sim, &mut frame);
    }
    let strands = frame.strands.len();
    for _ in 0..10 {
        for _ in 0..4 {
            sim.step(&mut report);
        }
        let ((), n, bytes) = counted(|| builder.fill(&mut sim, &mut frame));
        assert_eq!(
            n, 0,
            "FrameBuilder::fill made {n} allocations ({bytes} bytes)"
        );
    }
    assert_eq!(frame.strands.len(), strands);
    assert!(strands > 0);
}
