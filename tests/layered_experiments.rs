//! The papers' two-wisp and splitting experiments on shortened runs: Plante, Cani, Poulin 2002,
//! Figs. 8 and 9 (layered wisps) and Bertails et al. 2003, Fig. 5 (the AWT's splitting).

fn experiment(name: &str, scale: f64) -> Vec<wisptree::experiment::ExperimentRun> {
    let def = wisptree::experiment::find(name).expect("registered");
    let opts = wisptree::experiment::ExperimentOptions {
        duration_scale: scale,
    };
    (def.run)(&opts, &mut wisptree::experiment::NoFrames).expect("runs")
}

fn metric(
    runs: &[wisptree::experiment::ExperimentRun],
    label: &str,
    key: &str,
) -> serde_json::Value {
    runs.iter()
        .find(|r| r.label == label)
        .unwrap_or_else(|| panic!("no run {label}"))
        .metrics[key]
        .clone()
}

#[test]
fn plante_fig8_collision_stops_crossings_and_friction_slows_the_encounter() {
    let runs = experiment("plante-fig8", 0.5);
    let labels: Vec<&str> = runs.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(labels, ["none", "friction", "collision", "both"]);
    let crossings = |l| metric(&runs, l, "crossings").as_u64().expect("a count");
    assert!(
        crossings("none") > 0,
        "without interaction they pass through each other"
    );
    assert_eq!(crossings("collision"), 0);
    assert_eq!(crossings("both"), 0);
    let speed = |l| metric(&runs, l, "speed_after_first_encounter").as_f64();
    let (none, friction) = (
        speed("none").expect("an encounter"),
        speed("friction").expect("one"),
    );
    assert!(
        friction < none,
        "friction {friction} m/s vs none {none} m/s"
    );
}

#[test]
fn plante_fig9_high_viscosity_keeps_the_wisps_together_longer() {
    let runs = experiment("plante-fig9", 0.5);
    let low = metric(&runs, "0.5", "separation_s")
        .as_f64()
        .expect("0.5 separates");
    match metric(&runs, "50", "separation_s").as_f64() {
        None => {}
        Some(high) => assert!(
            high > 2.0 * low,
            "separation at 50: {high} s, at 0.5: {low} s"
        ),
    }
}

#[test]
fn awt_fig5_the_split_travels_from_tip_to_root() {
    let runs = experiment("awt-fig5", 0.5);
    assert_eq!(runs.len(), 1);
    let list: Vec<u64> = metric(&runs, "swing", "split_cross_sections")
        .as_array()
        .expect("a list")
        .iter()
        .map(|v| v.as_u64().expect("an index"))
        .collect();
    assert!(
        list.len() >= 2,
        "the swung wisp splits over several sections: {list:?}"
    );
    assert!(
        list.windows(2).all(|w| w[1] <= w[0]),
        "tip to root: {list:?}"
    );
}

#[test]
fn every_experiment_is_registered_once() {
    let names: Vec<&str> = wisptree::experiment::all().iter().map(|e| e.name).collect();
    for n in ["plante-fig8", "plante-fig9", "awt-fig5", "chang-shake"] {
        assert_eq!(
            names.iter().filter(|m| **m == n).count(),
            1,
            "{n} once in {names:?}"
        );
        assert!(wisptree::experiment::find(n).is_some(), "{n}");
    }
    assert!(wisptree::experiment::find("plante-fig10").is_none());
}
