//! `wisptree bench --live`: does every solver keep up with the wall clock, on every built-in
//! style, motion preset and slider end a user can pick?
//!
//! Each row runs the whole pipeline as `wisptree run` does (simulation thread, strands, the
//! logging thread into an in-memory recording that drops nothing; the render thread too in
//! the rendering rows), unpaced, so its real-time factor says how much faster than the wall
//! clock it could go: at 1 or more a live run keeps up, under 1 it is slow motion. Loading
//! and settling before t = 0 are not counted; the rows' frames are.
//!
//! The rows:
//! * every solver (`awt`, `layered`, `guides`) × style × motion preset, at the style's
//!   defaults, rendering off;
//! * the AWT under `shake` at the ends of the control page's split and merge sliders (read
//!   from the page's own table, so the bench follows the page);
//! * the AWT at the defaults with rendering on, on every style × motion: the render thread
//!   competes for the same cores and skips images when it falls behind, as it does live
//!   (never simulation frames).

use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};

use crate::app::{simulate_into, LoopOptions, StopSignal};
use crate::scene::Scene;
use crate::solver::SolverKind;
use crate::stream::sink::Recording;
use crate::style::builtin::StyleSource;

use super::steps::StageMs;
use super::style_label;
use crate::error::BadInput;

/// The solvers a live user can pick on the page (single-level is the AWT's §5.2 baseline,
/// not a live model).
pub const LIVE_SOLVERS: [SolverKind; 3] =
    [SolverKind::Awt, SolverKind::Layered, SolverKind::Guides];
/// The motion presets of the matrix (every preset that moves).
pub const LIVE_MOTIONS: [&str; 5] = ["lean", "run", "jump", "shake", "stop"];
/// The motion of the slider-end rows: the fastest, where low thresholds split the most.
pub const SLIDER_MOTION: &str = "shake";

/// One row of the matrix, as written to JSON under `"live"` (the key names are an interface).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LiveRow {
    /// The solver's name.
    pub solver: String,
    /// The style's name.
    pub style: String,
    /// The motion preset.
    pub motion: String,
    /// The AWT's split threshold in force, N·m·kg⁻¹ (`null` for the other solvers).
    pub split: Option<f64>,
    /// The AWT's merge velocity threshold in force, m/s (`null` for the other solvers).
    pub merge: Option<f64>,
    /// Rendering on (the render thread competing for the cores).
    pub render: bool,
    /// Every tunable of the row's solver in force, by the names of its table.
    pub params: std::collections::BTreeMap<&'static str, f64>,
    /// Simulated seconds ÷ wall seconds over the row's frames (the median over the passes of
    /// `--runs`).
    pub realtime_factor: f64,
    /// Every pass's real-time factor, in pass order (one without `--runs`).
    pub realtime_factors: Vec<f64>,
    /// The 95th-percentile wall time of a frame, ms (the median over the passes).
    pub p95_frame_ms: f64,
    /// Mean and largest active nodes after a frame (guides for `guides`, skeleton points for
    /// `layered`).
    pub mean_active: f64,
    /// See `mean_active`.
    pub max_active: u32,
    /// Mean segment pairs in contact per step.
    pub contacts_per_step: f64,
    /// Simulated seconds of the row.
    pub sim_seconds: f64,
    /// Frames of the row.
    pub frames: u64,
    /// A frame's simulated length, ms (the factor's numerator per frame).
    pub frame_ms: f64,
    /// Where a step's wall time went, mean ms per step by stage of the AWT's step (`null`
    /// for solvers that do not time their stages), from the pass whose factor is the median.
    pub stages_ms: Option<StageMs>,
}

/// What one row runs.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveCase {
    /// The solver.
    pub solver: SolverKind,
    /// Index into the styles.
    pub style: usize,
    /// The motion preset.
    pub motion: &'static str,
    /// Split threshold other than the style's.
    pub split: Option<f64>,
    /// Merge velocity other than the style's.
    pub merge: Option<f64>,
    /// Rendering on.
    pub render: bool,
}

/// The slider ends of the page's split threshold and merge velocity (the AWT's table of
/// tunables): (split, merge) overrides.
fn slider_ends() -> Vec<(Option<f64>, Option<f64>)> {
    let spec = |name: &str| {
        crate::solver::tunable::find(SolverKind::Awt.tunables(), name)
            .unwrap_or_else(|| panic!("the AWT has a `{name}` tunable"))
    };
    let (split, merge) = (spec("split_threshold"), spec("merge_velocity"));
    vec![
        (Some(split.min), None),
        (Some(split.max), None),
        (None, Some(merge.min)),
        (None, Some(merge.max)),
    ]
}

/// Every row of the matrix over `styles` styles, in the order they run.
pub fn live_cases(styles: usize) -> Vec<LiveCase> {
    let mut cases = Vec::new();
    let plain = |solver, style, motion| LiveCase {
        solver,
        style,
        motion,
        split: None,
        merge: None,
        render: false,
    };
    for solver in LIVE_SOLVERS {
        for style in 0..styles {
            for motion in LIVE_MOTIONS {
                cases.push(plain(solver, style, motion));
            }
        }
    }
    for style in 0..styles {
        for (split, merge) in slider_ends() {
            cases.push(LiveCase {
                split,
                merge,
                ..plain(SolverKind::Awt, style, SLIDER_MOTION)
            });
        }
    }
    for style in 0..styles {
        for motion in LIVE_MOTIONS {
            cases.push(LiveCase {
                render: true,
                ..plain(SolverKind::Awt, style, motion)
            });
        }
    }
    cases
}

/// The rows of the matrix over `styles` whose label (see [`case_label`], with the style as
/// `--models` names it) contains one of `only` (every row when `only` is empty). No row is a
/// [`BadInput`] naming the labels it could have matched.
pub fn select_cases(styles: &[StyleSource], only: &[String]) -> Result<Vec<LiveCase>, BadInput> {
    let label = |c: &LiveCase| case_label(c, &style_label(&styles[c.style]));
    let cases: Vec<LiveCase> = live_cases(styles.len())
        .into_iter()
        .filter(|c| only.is_empty() || only.iter().any(|o| label(c).contains(o.as_str())))
        .collect();
    if cases.is_empty() {
        let examples: Vec<String> = live_cases(styles.len())
            .iter()
            .filter(|c| c.motion == SLIDER_MOTION && c.solver == SolverKind::Awt && c.style == 0)
            .map(label)
            .collect();
        return Err(BadInput(format!(
            "--rows: no row of the live matrix matches {only:?}; labels read like {}",
            examples.join(", ")
        )));
    }
    Ok(cases)
}

/// Runs the matrix `runs` times, pass after pass: `seconds` simulated per row on `styles`,
/// drawing `strands` strands; only the rows [`select_cases`] picks with `only`. Each row
/// reports its medians over the passes ([`combine_passes`]).
pub fn bench_live(
    styles: &[StyleSource],
    seconds: f64,
    strands: usize,
    only: &[String],
    runs: usize,
) -> anyhow::Result<Vec<LiveRow>> {
    let cases = select_cases(styles, only)?;
    let runs = runs.max(1);
    let progress = ProgressBar::new((cases.len() * runs) as u64);
    progress.set_style(
        ProgressStyle::with_template(
            "{msg:44} [{bar:30}] {pos}/{len} rows {elapsed_precise} (eta {eta})",
        )
        .expect("a valid progress template")
        .progress_chars("=> "),
    );
    // Each style is read and its model built once; the rows share it.
    let mut scenes = Vec::with_capacity(styles.len());
    for s in styles {
        progress.set_message(format!("loading {}", style_label(s)));
        let scene = Scene::load_source(s.clone(), LIVE_MOTIONS[0], SolverKind::Awt)
            .map_err(|e| e.context(format!("setting up style {}", style_label(s))))?;
        scenes.push(scene);
    }
    let mut passes: Vec<Vec<LiveRow>> = vec![Vec::with_capacity(runs); cases.len()];
    for pass in 0..runs {
        for (case, row_passes) in cases.iter().zip(&mut passes) {
            let scene = &scenes[case.style];
            let label = case_label(case, &scene.style_name());
            progress.set_message(if runs > 1 {
                format!("pass {}/{runs}: {label}", pass + 1)
            } else {
                label
            });
            row_passes.push(run_case(scene, case, seconds, strands)?);
            progress.inc(1);
        }
    }
    progress.finish_and_clear();
    Ok(passes.into_iter().map(combine_passes).collect())
}

/// One row from its passes (in pass order): the median real-time factor and the median
/// 95th-percentile frame time (the mean of the middle two for an even count), every pass's
/// factor, and the counts of the first pass (the simulation is deterministic: every pass has
/// the same).
pub fn combine_passes(passes: Vec<LiveRow>) -> LiveRow {
    let factors: Vec<f64> = passes.iter().map(|r| r.realtime_factor).collect();
    let p95: Vec<f64> = passes.iter().map(|r| r.p95_frame_ms).collect();
    // The stage times of the median pass (the lower middle one for an even count).
    let mut order: Vec<usize> = (0..passes.len()).collect();
    order.sort_by(|&a, &b| factors[a].total_cmp(&factors[b]));
    let stages_ms = order
        .get((order.len().max(1) - 1) / 2)
        .and_then(|&k| passes[k].stages_ms);
    let mut row = passes
        .into_iter()
        .next()
        .expect("a row has at least one pass");
    row.stages_ms = stages_ms;
    row.realtime_factor = median(&factors);
    row.p95_frame_ms = median(&p95);
    row.realtime_factors = factors;
    row
}

/// The median of `v` (not empty): the middle value, or the mean of the middle two.
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn case_label(case: &LiveCase, style: &str) -> String {
    let mut s = format!("{} {style} {}", case.solver, case.motion);
    if let Some(v) = case.split {
        s.push_str(&format!(" split {v}"));
    }
    if let Some(v) = case.merge {
        s.push_str(&format!(" merge {v}"));
    }
    if case.render {
        s.push_str(" +render");
    }
    s
}

/// One row: the scene under the case's solver, motion and thresholds, through the pipeline.
fn run_case(
    base: &Scene,
    case: &LiveCase,
    seconds: f64,
    strands: usize,
) -> anyhow::Result<LiveRow> {
    let mut scene = base.with_motion(case.motion)?.with_solver(case.solver);
    let sim = &mut scene.loaded.style.sim;
    if let Some(v) = case.split {
        sim.split_threshold = v;
    }
    if let Some(v) = case.merge {
        sim.merge_velocity = v;
    }
    let (split, merge) = match case.solver {
        SolverKind::Awt | SolverKind::SingleLevel => {
            (Some(sim.split_threshold), Some(sim.merge_velocity))
        }
        _ => (None, None),
    };
    let tuning = crate::solver::tunable::Tuning::of(&scene.loaded.style);
    let params = case
        .solver
        .tunables()
        .iter()
        .map(|t| (t.name, t.value(&tuning)))
        .collect();
    let (rec, memory) = Recording::memory()?;
    let opts = LoopOptions {
        seconds: Some(seconds),
        // Unpaced, and every frame logged: the factor says how fast it could go.
        live: false,
        watch: false,
        keys: false,
        progress: false,
        strands,
        render: case
            .render
            .then_some(crate::app::render_thread::DEFAULT_RENDER_SIZE),
        render_skips_when_behind: true,
        quiet: true,
        web: None,
        inspect: None,
    };
    let t0 = Instant::now();
    let summary = simulate_into(&scene, rec, &opts, &StopSignal::new())?;
    drop(memory);
    let tempo = &summary.tempo;
    anyhow::ensure!(
        tempo.frames > 0,
        "{}: the run made no frame in {:.1} s",
        case_label(case, &scene.style_name()),
        t0.elapsed().as_secs_f64()
    );
    Ok(LiveRow {
        solver: case.solver.name().to_owned(),
        // The name `--models` takes (`short_curly`), not the display name.
        style: style_label(&scene.source),
        motion: case.motion.to_owned(),
        split,
        merge,
        render: case.render,
        params,
        realtime_factor: tempo.realtime_factor(),
        realtime_factors: vec![tempo.realtime_factor()],
        p95_frame_ms: tempo.frame_ms_quantile(0.95),
        mean_active: summary.load.mean_active(),
        max_active: summary.load.active_max,
        contacts_per_step: summary.load.contacts_per_step(),
        sim_seconds: tempo.sim_s,
        frames: tempo.frames,
        frame_ms: tempo.sim_s * 1e3 / tempo.frames as f64,
        stages_ms: {
            let load = &summary.load;
            (load.stages.total() > std::time::Duration::ZERO)
                .then(|| StageMs::from_sums(&load.stages, load.step_wall, load.steps as usize))
        },
    })
}

/// Prints every row, then the worst row of each solver, then the worst of all, last.
pub fn print_live(rows: &[LiveRow], seconds: f64) {
    println!(
        "wisptree bench --live: {seconds} s simulated per row through the run pipeline \
         (simulation, strands, logging; unpaced). Real-time factor = simulated ÷ wall seconds: \
         1 or more keeps up live, under 1 is slow motion."
    );
    let passes = rows.first().map_or(1, |r| r.realtime_factors.len());
    if passes > 1 {
        println!(
            "Each row: the median of {passes} passes of the matrix (the factor's range after \
             the contacts)."
        );
    }
    println!(
        "{:<8} {:<12} {:<6} {:>7} {:>7} {:>6} {:>9} {:>9} {:>12} {:>11}",
        "solver",
        "style",
        "motion",
        "split",
        "merge",
        "render",
        "realtime",
        "p95 ms",
        "active mean/max",
        "contacts"
    );
    for r in rows {
        print_row(r);
    }
    println!();
    println!("worst row per solver:");
    let mut solvers: Vec<&str> = Vec::new();
    for r in rows {
        if !solvers.contains(&r.solver.as_str()) {
            solvers.push(&r.solver);
        }
    }
    for s in solvers {
        if let Some(w) = worst(rows.iter().filter(|r| r.solver == s)) {
            print_row(w);
        }
    }
    if let Some(w) = worst(rows.iter().filter(|r| r.stages_ms.is_some())) {
        print_stages(w);
    }
    if let Some(w) = worst(rows.iter()) {
        println!();
        println!(
            "worst of all: {} on {} under `{}`{}{}: ×{:.2} of real time{}",
            w.solver,
            w.style,
            w.motion,
            thresholds(w, ", "),
            if w.render { ", rendering" } else { "" },
            w.realtime_factor,
            if w.realtime_factor >= 1.0 {
                " (keeps up)"
            } else {
                " (slow motion when live)"
            }
        );
    }
}

/// Where the step's time goes in row `w` (the slowest of those that time their stages):
/// what to speed up first, or why a row stays slow.
fn print_stages(w: &LiveRow) {
    let Some(st) = w.stages_ms else {
        return;
    };
    let total: f64 = st.entries().iter().map(|e| e.1).sum();
    let parts: Vec<String> = st
        .entries()
        .iter()
        .filter(|e| e.1 >= 0.005)
        .map(|(name, ms)| format!("{name} {ms:.2} ({:.0} %)", 100.0 * ms / total.max(1e-12)))
        .collect();
    println!();
    println!(
        "where a step's {total:.2} ms go in the slowest {} row ({} {}{}): {}",
        w.solver,
        w.style,
        w.motion,
        thresholds(w, " "),
        parts.join(", ")
    );
}

/// The row's AWT thresholds as ` split X merge Y`, each item after `sep` (empty for the
/// models without them).
fn thresholds(r: &LiveRow, sep: &str) -> String {
    let item = |name: &str, v: Option<f64>| v.map_or(String::new(), |v| format!("{sep}{name} {v}"));
    item("split", r.split) + &item("merge", r.merge)
}

fn worst<'a>(rows: impl Iterator<Item = &'a LiveRow>) -> Option<&'a LiveRow> {
    rows.min_by(|a, b| a.realtime_factor.total_cmp(&b.realtime_factor))
}

fn print_row(r: &LiveRow) {
    let opt = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |v| format!("{v}"));
    let f = &r.realtime_factors;
    let range = if f.len() > 1 {
        let lo = f.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        format!("  ({lo:.2}–{hi:.2})")
    } else {
        String::new()
    };
    println!(
        "{:<8} {:<12} {:<6} {:>7} {:>7} {:>6} {:>8.2}x {:>9.1} {:>7.0}/{:<7} {:>11.0}{range}",
        r.solver,
        r.style,
        r.motion,
        opt(r.split),
        opt(r.merge),
        if r.render { "on" } else { "off" },
        r.realtime_factor,
        r.p95_frame_ms,
        r.mean_active,
        r.max_active,
        r.contacts_per_step
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_matrix_has_every_solver_style_and_motion_the_slider_ends_and_the_rendering_rows() {
        let cases = live_cases(4);
        assert_eq!(cases.len(), 3 * 4 * 5 + 4 * 4 + 4 * 5);
        for solver in LIVE_SOLVERS {
            for style in 0..4 {
                for motion in LIVE_MOTIONS {
                    assert!(cases.iter().any(|c| c.solver == solver
                        && c.style == style
                        && c.motion == motion
                        && !c.render
                        && c.split.is_none()
                        && c.merge.is_none()));
                }
            }
        }
        let ends: Vec<_> = cases
            .iter()
            .filter(|c| c.split.is_some() || c.merge.is_some())
            .collect();
        assert!(ends
            .iter()
            .all(|c| c.solver == SolverKind::Awt && c.motion == "shake"));
        assert!(ends.iter().any(|c| c.split == Some(0.05)));
        assert!(ends.iter().any(|c| c.merge == Some(0.005)));
        assert_eq!(cases.iter().filter(|c| c.render).count(), 20);
    }

    fn row(factor: f64, p95: f64) -> LiveRow {
        LiveRow {
            solver: "awt".into(),
            style: "long".into(),
            motion: "shake".into(),
            split: Some(0.2),
            merge: Some(0.1),
            render: false,
            params: Default::default(),
            realtime_factor: factor,
            realtime_factors: vec![factor],
            p95_frame_ms: p95,
            mean_active: 2585.0,
            max_active: 3584,
            contacts_per_step: 157_800.0,
            sim_seconds: 5.0,
            frames: 125,
            frame_ms: 40.0,
            // Tagged by the pass's frame time, to tell the passes apart.
            stages_ms: Some(StageMs {
                interactions: p95,
                ..StageMs::default()
            }),
        }
    }

    #[test]
    fn a_row_of_several_passes_reports_the_medians_and_every_factor() {
        let one = combine_passes(vec![row(1.3, 40.0)]);
        assert_eq!(one, row(1.3, 40.0));
        let three = combine_passes(vec![row(1.5, 30.0), row(0.9, 60.0), row(1.2, 45.0)]);
        assert_eq!(three.realtime_factor, 1.2);
        assert_eq!(three.p95_frame_ms, 45.0);
        assert_eq!(three.realtime_factors, [1.5, 0.9, 1.2]);
        assert_eq!((three.mean_active, three.max_active), (2585.0, 3584));
        // The stage times of the pass whose factor is the median.
        assert_eq!(three.stages_ms.unwrap().interactions, 45.0);
        let four = combine_passes(vec![
            row(1.0, 10.0),
            row(4.0, 40.0),
            row(2.0, 20.0),
            row(3.0, 30.0),
        ]);
        assert_eq!(four.realtime_factor, 2.5);
        assert_eq!(four.p95_frame_ms, 25.0);
        assert_eq!(
            four.stages_ms.unwrap().interactions,
            20.0,
            "the lower middle pass"
        );
    }

    #[test]
    fn rows_picks_the_rows_whose_label_contains_a_text() {
        let styles: Vec<StyleSource> = crate::bench::PAPER_MODELS
            .iter()
            .map(|m| StyleSource::parse(m))
            .collect();
        let all = |only: &[&str]| {
            let only: Vec<String> = only.iter().map(|s| s.to_string()).collect();
            select_cases(&styles, &only)
        };
        assert_eq!(all(&[]).unwrap().len(), live_cases(4).len());
        let split = all(&["split 0.05"]).unwrap();
        assert_eq!(split.len(), 4);
        assert!(split.iter().all(|c| c.split == Some(0.05) && !c.render));
        let two = all(&["split 0.05", "+render"]).unwrap();
        assert_eq!(two.len(), 4 + 20);
        // `long` names a style: not `long_curly`'s rows.
        let long = all(&["awt long shake"]).unwrap();
        assert_eq!(long.len(), 1 + 4 + 1, "plain, four slider ends, rendering");
        assert!(long.iter().all(|c| c.style == 2 && c.motion == "shake"));
        let err = all(&["awt bald shake"]).unwrap_err().to_string();
        assert!(
            err.contains("--rows") && err.contains("awt short shake split 0.05"),
            "{err}"
        );
    }
}
