//! Every value a slider allows keeps every model sound: each tunable of each solver's table, set
//! at both ends of its range while the hair moves under `shake`, leaves the model valid and its
//! energy bounded at every step (issue 25: live at every setting; issue 26: one table).

use wisptree::report::StepReport;
use wisptree::scene::Scene;
use wisptree::solver::{Solver, SolverKind};

/// Hair of 1 kg moving with the head: well under 10 m/s everywhere, so far under this.
const MAX_KINETIC_ENERGY_J: f64 = 50.0;
/// Simulated seconds after the change.
const SECONDS: f64 = 0.4;

fn check_both_ends(kind: SolverKind) {
    let mut scene = Scene::load("short", "shake", kind).unwrap();
    // A short settle: the test is about the change, not the hanging.
    scene.loaded.style.sim.settle = 0.1;
    for entry in kind.tunables() {
        let below = entry.below.map_or(f64::INFINITY, |b| {
            0.999 * b(&wisptree::solver::tunable::Tuning::of(&scene.loaded.style)).0
        });
        for v in [entry.min, entry.max.min(below)] {
            let mut s: Box<dyn Solver> = scene.solver();
            // Half a second into the motion, then the change, as a user's slider does.
            let mut r: StepReport = s.new_report();
            for _ in 0..10 {
                s.step(&mut r);
            }
            s.set_tunable(entry.name, v)
                .unwrap_or_else(|e| panic!("{kind} {} = {v}: {e}", entry.name));
            let steps = (SECONDS / s.dt()).round() as usize;
            for k in 0..steps {
                s.step(&mut r);
                s.validate()
                    .unwrap_or_else(|e| panic!("{kind} {} = {v}, step {k}: {e}", entry.name));
                let ke = r.counters.kinetic_energy;
                assert!(
                    ke.is_finite() && ke < MAX_KINETIC_ENERGY_J,
                    "{kind} {} = {v}, step {k}: kinetic energy {ke} J",
                    entry.name
                );
            }
            let now = entry.value(&s.tuning());
            assert_eq!(
                now, v,
                "{kind} {}: the solver holds what was set",
                entry.name
            );
        }
    }
}

#[test]
fn every_awt_slider_end_keeps_the_model_valid_and_bounded() {
    check_both_ends(SolverKind::Awt);
    check_both_ends(SolverKind::SingleLevel);
}

#[test]
fn every_layered_slider_end_keeps_the_model_valid_and_bounded() {
    check_both_ends(SolverKind::Layered);
}

#[test]
fn every_guides_slider_end_keeps_the_model_valid_and_bounded() {
    check_both_ends(SolverKind::Guides);
}
