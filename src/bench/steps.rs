//! Timing a solver step by step.

use std::time::{Duration, Instant};

use crate::report::{EventKind, Stage, StageTimes};
use crate::solver::Solver;

/// Mean milliseconds per step spent in each stage of `Simulation::step` (`StageTimes`), and
/// the rest of the step's wall time (`other`: bookkeeping between the stage clocks).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
#[allow(missing_docs)] // one field per `Stage`, named as it
pub struct StageMs {
    pub forces: f64,
    pub interactions: f64,
    pub integrate: f64,
    pub links: f64,
    pub obstacles: f64,
    pub adapt: f64,
    pub follow: f64,
    pub other: f64,
}

impl StageMs {
    /// Per-step means from stage sums over `steps` steps whose wall times summed to `wall`.
    pub fn from_sums(sum: &StageTimes, wall: Duration, steps: usize) -> StageMs {
        let per = |d: Duration| d.as_secs_f64() * 1e3 / steps.max(1) as f64;
        StageMs {
            forces: per(sum.get(Stage::Forces)),
            interactions: per(sum.get(Stage::Interactions)),
            integrate: per(sum.get(Stage::Integrate)),
            links: per(sum.get(Stage::Links)),
            obstacles: per(sum.get(Stage::Obstacles)),
            adapt: per(sum.get(Stage::Adapt)),
            follow: per(sum.get(Stage::Follow)),
            other: per(wall.saturating_sub(sum.total())),
        }
    }

    /// `(name, ms)` in step order.
    pub fn entries(&self) -> [(&'static str, f64); 8] {
        [
            ("forces", self.forces),
            ("interactions", self.interactions),
            ("integrate", self.integrate),
            ("links", self.links),
            ("obstacles", self.obstacles),
            ("adapt", self.adapt),
            ("follow", self.follow),
            ("other", self.other),
        ]
    }
}

/// What timing one simulation for a number of steps measured.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RunStats {
    /// Steps timed.
    pub steps: usize,
    /// Sum of the wall time of the `step` calls, s.
    pub wall_s: f64,
    /// Mean and largest wall time of one step, ms.
    pub mean_ms_per_step: f64,
    /// See `mean_ms_per_step`.
    pub max_ms_per_step: f64,
    /// The mean step, by stage.
    pub stages_ms: StageMs,
    /// Active nodes after each step (root nodes included).
    pub mean_active_nodes: f64,
    /// See `mean_active_nodes`.
    pub max_active_nodes: usize,
    /// Splits and merges over the run.
    pub splits: u64,
    /// See `splits`.
    pub merges: u64,
    /// Per step, means of the common counters.
    pub mean_pairs_tested: f64,
    /// See `mean_pairs_tested`.
    pub mean_pairs_in_contact: f64,
    /// See `mean_pairs_tested`.
    pub mean_body_contacts: f64,
    /// The solver's own stats (`guides`, `collisions`, …): mean and largest step value, by
    /// name (the last segment of the stat's path).
    pub solver_stats: std::collections::BTreeMap<String, (f64, f64)>,
}

/// Steps `solver` `steps` times, timing each `step` call alone; `after_step` runs outside the
/// timed region (progress display).
pub fn time_steps(solver: &mut dyn Solver, steps: usize, mut after_step: impl FnMut()) -> RunStats {
    let mut report = solver.new_report();
    let mut wall = Duration::ZERO;
    let mut max = Duration::ZERO;
    let mut stages = StageTimes::default();
    let (mut active_sum, mut active_max) = (0u64, 0usize);
    let (mut splits, mut merges) = (0u64, 0u64);
    let (mut tested, mut contact, mut body) = (0u64, 0u64, 0u64);
    let mut own: std::collections::BTreeMap<String, (f64, f64)> = Default::default();
    for _ in 0..steps {
        let t0 = Instant::now();
        solver.step(&mut report);
        let dt = t0.elapsed();
        wall += dt;
        max = max.max(dt);
        let c = &report.counters;
        stages.add(&c.times);
        let active: usize = c.active_per_level.iter().map(|&n| n as usize).sum();
        active_sum += active as u64;
        active_max = active_max.max(active);
        splits += report
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Split)
            .count() as u64;
        merges += report
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Merge)
            .count() as u64;
        tested += u64::from(c.pairs_tested);
        contact += u64::from(c.pairs_in_contact);
        body += u64::from(c.body_contacts);
        for st in &report.stats {
            let e = own.entry(st.name.to_owned()).or_insert((0.0, f64::MIN));
            e.0 += st.value;
            e.1 = e.1.max(st.value);
        }
        after_step();
    }
    let n = steps.max(1) as f64;
    for v in own.values_mut() {
        v.0 /= n;
    }
    RunStats {
        steps,
        wall_s: wall.as_secs_f64(),
        mean_ms_per_step: wall.as_secs_f64() * 1e3 / n,
        max_ms_per_step: max.as_secs_f64() * 1e3,
        stages_ms: StageMs::from_sums(&stages, wall, steps),
        mean_active_nodes: active_sum as f64 / n,
        max_active_nodes: active_max,
        splits,
        merges,
        mean_pairs_tested: tested as f64 / n,
        mean_pairs_in_contact: contact as f64 / n,
        mean_body_contacts: body as f64 / n,
        solver_stats: own,
    }
}
