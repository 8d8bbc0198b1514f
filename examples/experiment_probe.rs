//! Runs one registered experiment without recording and prints its JSON report (until the
//! `wisptree experiment` command lands). `cargo run --release --example experiment_probe NAME [SCALE]`
use wisptree::experiment::{self, ExperimentOptions, ExperimentReport, NoFrames};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map(String::as_str).unwrap_or("plante-fig8");
    let scale = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let def = experiment::find(name).ok_or_else(|| anyhow::anyhow!("no experiment {name}"))?;
    let runs = (def.run)(
        &ExperimentOptions {
            duration_scale: scale,
        },
        &mut NoFrames,
    )?;
    let report = ExperimentReport {
        experiment: name.into(),
        runs,
    };
    println!("{}", serde_json::to_string_pretty(&report)?);
    println!("expected: {}", def.expectation);
    Ok(())
}
