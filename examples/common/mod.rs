//! What the AWT probes among the examples share (not an example itself: Cargo builds only
//! `examples/*.rs` and `examples/*/main.rs`). Each example compiles its own copy and uses
//! part of it, hence the `allow`.
#![allow(dead_code)]

use std::path::Path;
use std::sync::Arc;

use nalgebra::Point3;
use wisptree::model::HairModel;
use wisptree::motion::Motion;
use wisptree::solver::awt::Simulation;

/// The command line of a probe: `PROBE STYLE MOTION [SPLIT_THRESHOLD]`.
pub struct ProbeArgs {
    pub style: String,
    pub motion: String,
    pub split: Option<f64>,
}

/// Reads [`ProbeArgs`]; `probe` names the example in the usage message.
pub fn probe_args(probe: &str) -> anyhow::Result<ProbeArgs> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(style), Some(motion)) = (args.get(1), args.get(2)) else {
        anyhow::bail!("usage: {probe} STYLE MOTION [SPLIT_THRESHOLD]");
    };
    let split = args.get(3).map(|s| s.parse()).transpose()?;
    Ok(ProbeArgs {
        style: style.clone(),
        motion: motion.clone(),
        split,
    })
}

/// The AWT on the style file `styles/STYLE.ron` under the motion preset `motion`, at the
/// style's split threshold or at `split`.
pub fn awt_simulation(
    style: &str,
    motion: &str,
    split: Option<f64>,
) -> anyhow::Result<(Arc<HairModel>, Simulation)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("styles");
    let (mut loaded, model) = wisptree::scene::load_model(
        &wisptree::style::builtin::StyleSource::File(dir.join(format!("{style}.ron"))),
    )?;
    if let Some(v) = split {
        loaded.style.sim.split_threshold = v;
    }
    let model = Arc::new(model);
    let motion = Motion::parse(motion, Point3::from(model.scalp_center))?;
    let sim = Simulation::from_style(model.clone(), &loaded.style, motion, false);
    Ok((model, sim))
}
