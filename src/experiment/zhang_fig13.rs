//! Zhang and Wünsche 2007, Fig. 13 (§3.2, §7.1): one large wisp on a uniformly curved key
//! strand, its members offset by Choe and Ko's distribution (a random offset per control point)
//! and by Zhang's function (one offset vector growing linearly along the strand) with a small and
//! a large maximum initial offset. The paper: Choe and Ko's strands come out slightly wavy,
//! Zhang's uniformly smooth; the larger offset gives fuzzy hair, wider towards the tip. "The
//! results were exaggerated by using large offset vectors": so are ours (ε = 5 mm per control
//! interval, 4 cm at the tip of a 40 cm strand).
//!
//! The geometry is [`crate::style::generate::wisp_study`]; each wisp is also rendered, seen
//! from the side of the key strand's plane.

use serde_json::{json, Map};

use super::zhang_images::{round, side_by_side, strand_buf};
use super::{ExperimentDef, ExperimentOptions, ExperimentRun, FrameSink};
use crate::frame::BodyBuf;
use crate::render::{Camera, Image, RenderInput, RenderParams, Renderer};
use crate::style::generate::wisp_study::{Offsets, WispStudy};

/// The large ε (Choe and Ko's, and Zhang's fuzzy wisp), m per control interval.
const LARGE: f64 = 0.005;
/// The small ε (Zhang's smooth wisp).
const SMALL: f64 = 0.0005;
/// Side of each rendered image, pixels.
const SIDE: u32 = 360;

/// `zhang-fig13`.
pub static ZHANG_FIG13: ExperimentDef = ExperimentDef {
    name: "zhang-fig13",
    description: "Zhang & Wünsche 2007, Fig. 13: a large wisp on a uniformly curved key strand, \
                  Choe and Ko's per-control-point offsets vs Zhang's function, small and large \
                  maximum initial offset",
    expectation: "waviness (1/m) of choe_ko well above both zhang runs; spread_tip_mm of \
                  zhang_large well above zhang_small",
    run: run_fig13,
};

/// The three runs: label and offsets.
pub fn variants() -> [(&'static str, Offsets); 3] {
    [
        ("choe_ko", Offsets::ChoeKo { epsilon: LARGE }),
        ("zhang_small", Offsets::Zhang { epsilon: SMALL }),
        ("zhang_large", Offsets::Zhang { epsilon: LARGE }),
    ]
}

fn run_fig13(
    opts: &ExperimentOptions,
    sink: &mut dyn FrameSink,
) -> anyhow::Result<Vec<ExperimentRun>> {
    let mut study = WispStudy::default();
    // Shorter runs grow fewer members (the measures are means over members).
    study.members = ((study.members as f64 * opts.duration_scale).round() as usize).max(12);
    let wisps: Vec<_> = variants()
        .iter()
        .map(|&(label, o)| (label, o, study.grow(o)))
        .collect();
    // One camera for all three, framing the widest wisp, looking at the key strand's plane.
    let all: Vec<[f32; 3]> = wisps
        .iter()
        .flat_map(|(_, _, w)| w.members.iter().flatten())
        .map(|p| p.map(|x| x as f32))
        .collect();
    let (lo, hi) = crate::render::bounds(&all);
    let camera = Camera::framing(lo, hi, [0.0, 0.0, -1.0]);
    let params = RenderParams {
        strand_alpha: 0.8,
        ..RenderParams::default()
    };
    let mut renderer = Renderer::new(params, SIDE, SIDE, crate::render::default_threads())
        .map_err(|e| anyhow::anyhow!("rendering: {e}"))?;
    let body = BodyBuf::default();
    let mut images = Vec::new();
    let mut runs = Vec::new();
    for (label, offsets, wisp) in &wisps {
        let strands = strand_buf(&wisp.members);
        let mut image = Image::default();
        renderer.render(
            &RenderInput {
                strands: &strands,
                body: &body,
            },
            &camera,
            &mut image,
        );
        sink.rendered(label, 0, &strands, &image)?;
        images.push(image);
        let eps = match offsets {
            Offsets::ChoeKo { epsilon } | Offsets::Zhang { epsilon } => *epsilon,
        };
        let mut m = Map::new();
        m.insert("epsilon_mm".into(), json!(eps * 1e3));
        m.insert("waviness".into(), json!(round(wisp.waviness(), 4)));
        m.insert(
            "spread_root_mm".into(),
            json!(round(wisp.spread(0) * 1e3, 2)),
        );
        m.insert(
            "spread_tip_mm".into(),
            json!(round(wisp.spread(study.samples - 1) * 1e3, 2)),
        );
        runs.push(ExperimentRun {
            label: (*label).into(),
            metrics: m,
        });
    }
    let refs: Vec<&Image> = images.iter().collect();
    sink.picture("zhang_fig13", &side_by_side(&refs, 8))?;
    Ok(runs)
}
