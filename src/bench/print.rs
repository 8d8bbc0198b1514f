//! Printing what the bench measured.

use super::*;

/// Prints the §5.2 table, the paper's, and the per-stage breakdowns.
pub fn print_report(r: &BenchReport) {
    if r.solvers.is_empty() {
        return;
    }
    print_solvers(r);
    let models: &[ModelResult] = r.models.as_deref().unwrap_or(&[]);
    if !models.is_empty() {
        print_table(r, models);
    }
    print_pipeline(r);
}

/// Every style under every solver: wall ms per simulated second, the ratio to the AWT on the
/// same style, pairs tested per simulated second, and the solver's own stats.
fn print_solvers(r: &BenchReport) {
    println!(
        "wisptree bench: motion `{}`, {} s simulated per style and solver, only `step` timed, one core",
        r.motion, r.sim_seconds
    );
    println!(
        "{:<12} {:<13} {:>14} {:>9} {:>16}  solver stats (mean / max per step)",
        "style", "solver", "ms per sim s", "vs awt", "pairs per sim s"
    );
    for row in &r.solvers {
        let awt = r
            .solvers
            .iter()
            .find(|o| o.style == row.style && o.solver == "awt")
            .map(|a| row.ms_per_simulated_second / a.ms_per_simulated_second);
        let ratio = awt.map_or_else(|| "-".to_owned(), |x| format!("{x:.2}x"));
        let stats: Vec<String> = row
            .run
            .solver_stats
            .iter()
            .map(|(k, (mean, max))| format!("{k} {mean:.1}/{max:.0}"))
            .collect();
        println!(
            "{:<12} {:<13} {:>14.1} {:>9} {:>16.0}  {}",
            row.style,
            row.solver,
            row.ms_per_simulated_second,
            ratio,
            row.pairs_tested_per_simulated_second,
            stats.join(", ")
        );
    }
    println!();
}

/// The §5.2 table and the per-stage breakdowns.
fn print_table(r: &BenchReport, models: &[ModelResult]) {
    println!(
        "wisptree bench: motion `{}`, {} s simulated per model and mode, only `step` timed",
        r.motion, r.sim_seconds
    );
    println!(
        "machine: {}; single-level and AWT on one core; `AWT 2 thr`: the hair-hair search shared \
         with a helper thread (same result; `wisptree run` uses {} thread(s) here)",
        r.machine, r.run_threads
    );
    println!();
    println!(
        "{:<12} {:>6} {:>2} {:>12} {:>10} {:>7} {:>10} {:>8} {:>7} {:>7} {:>7}",
        "model",
        "N",
        "L",
        "single ms",
        "AWT ms",
        "ratio",
        "AWT 2 thr",
        "active",
        "max",
        "splits",
        "merges"
    );
    for m in models {
        let two = m
            .awt_two_threads_ms_per_step
            .map_or_else(|| "-".to_string(), |t| format!("{t:.4}"));
        println!(
            "{:<12} {:>6} {:>2} {:>12.3} {:>10.4} {:>7.1} {:>10} {:>8.1} {:>7} {:>7} {:>7}",
            m.model,
            m.finest_nodes,
            m.levels,
            m.single_level_ms_per_step,
            m.awt_ms_per_step,
            m.ratio,
            two,
            m.mean_active_nodes,
            m.max_active_nodes,
            m.splits,
            m.merges
        );
    }
    println!();
    println!("paper (AWT §5.2, 1.7 GHz Pentium, s per step):");
    println!(
        "{:<12} {:>6} {:>2} {:>12} {:>10} {:>7}",
        "model", "N", "L", "single s", "AWT s", "ratio"
    );
    for (name, n, l, single, awt, ratio) in PAPER_TABLE {
        println!("{name:<12} {n:>6} {l:>2} {single:>12.1} {awt:>10.2} {ratio:>7.1}");
    }
    for (mode, pick) in [
        (
            "AWT",
            (|m: &ModelResult| &m.awt) as fn(&ModelResult) -> &RunStats,
        ),
        ("single-level", |m: &ModelResult| &m.single_level),
    ] {
        println!();
        println!("{mode} mean step by stage, ms (other = wall time outside the stage clocks):");
        print!("{:<12}", "model");
        for (stage, _) in StageMs::default().entries() {
            print!(" {stage:>12}");
        }
        println!(" {:>9} {:>9} {:>9}", "pairs", "contacts", "max ms");
        for m in models {
            let s = pick(m);
            print!("{:<12}", m.model);
            for (_, ms) in s.stages_ms.entries() {
                print!(" {ms:>12.4}");
            }
            println!(
                " {:>9.0} {:>9.0} {:>9.3}",
                s.mean_pairs_tested, s.mean_pairs_in_contact, s.max_ms_per_step
            );
        }
    }
}

/// The pipeline timings.
fn print_pipeline(r: &BenchReport) {
    if let Some(p) = &r.pipeline {
        println!();
        println!(
            "pipeline: `wisptree run --style {}.ron --motion lean --seconds {} --strands {} --save FILE`",
            p.model, r.sim_seconds, p.strands
        );
        println!(
            "  {:.2} s wall for {:.2} s simulated ({} frames, .rrd {:.1} MB) = {:.3} wall s per simulated s",
            p.wall_s,
            p.sim_seconds,
            p.frames,
            p.rrd_bytes as f64 / 1e6,
            p.wall_s_per_sim_s
        );
    }
    if let Some(p) = &r.pipeline_sequential {
        println!();
        println!(
            "the same work sequentially in one thread ({}, {} frames of {} steps, {} strands, .rrd {:.1} MB):",
            p.model,
            p.frames,
            STEPS_PER_FRAME,
            p.strands,
            p.rrd_bytes as f64 / 1e6
        );
        println!(
            "  {:.2} s wall for {:.1} s simulated = {:.3} wall s per simulated s",
            p.wall_s, p.sim_seconds, p.wall_s_per_sim_s
        );
        println!(
            "  load+settle {:.2} s, steps {:.2} s, frames {:.2} s, logging {:.2} s, flush {:.2} s",
            p.setup_s, p.step_s, p.frame_build_s, p.log_s, p.flush_s
        );
    }
}
