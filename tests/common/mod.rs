//! Shared test fixtures: small synthetic hair models built without any file.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Point3;
use wisptree::model::HairModel;
use wisptree::motion::Motion;
use wisptree::solver::awt::Simulation;
use wisptree::style::{LoadedStyle, RawHair, RawStrand};

pub mod shared;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A tiny deterministic PRNG for fixtures.
pub struct Rng(u64);
impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.f64()
    }
}

/// A style text with the given hierarchy, link and parameters; the hair itself comes from
/// `synthetic_hair` (the `files` entry is never read).
pub fn style_text(
    levels: usize,
    branching: &[usize],
    k: usize,
    top: usize,
    link: &str,
    sim: &str,
) -> String {
    format!(
        "(hair: TressFx((files: [\"unused.tfx\"])), \
          hierarchy: (levels: {levels}, cross_sections: {k}, branching: {branching:?}, top_level: {top}), \
          link: {link}, sim: ({sim}))"
    )
}

/// Straight strands hanging from a patch on top of the default head, slightly jittered,
/// optionally fanned outwards.
pub fn synthetic_hair(strands: usize, length: f64, seed: u64) -> RawHair {
    let mut rng = Rng::new(seed);
    let mut hair = RawHair::default();
    for _ in 0..strands {
        // Roots on the back of the default scalp (centre (0,1.6,0), radii .075/.095/.09).
        let az = rng.range(150f64.to_radians(), 210f64.to_radians());
        let el = rng.range(0f64.to_radians(), 40f64.to_radians());
        let dir = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
        let root = [
            0.0 + 0.075 * dir[0] * 1.02,
            1.6 + 0.095 * dir[1] * 1.02,
            0.0 + 0.09 * dir[2] * 1.02,
        ];
        let n = 20;
        let mut points = Vec::with_capacity(n);
        let out = [dir[0] * 0.04, 0.0, dir[2] * 0.04];
        for s in 0..n {
            let t = s as f64 / (n - 1) as f64;
            points.push([
                root[0] + out[0] * t.min(0.3) / 0.3 + rng.range(-1e-3, 1e-3) * t,
                root[1] - length * t,
                root[2] + out[2] * t.min(0.3) / 0.3 + rng.range(-1e-3, 1e-3) * t,
            ]);
        }
        hair.strands.push(RawStrand { wisp: 0, points });
    }
    hair
}

/// A synthetic model: `strands` straight strands, clustered into `top` wisps.
pub fn synthetic_model(
    text: &str,
    strands: usize,
    length: f64,
    seed: u64,
) -> (LoadedStyle, Arc<HairModel>) {
    let loaded = wisptree::scene::parse_style(Path::new("synthetic.ron"), text)
        .expect("fixture style parses");
    let hair = synthetic_hair(strands, length, seed);
    let model = HairModel::build(&loaded, &hair);
    (loaded, Arc::new(model))
}

pub fn motion(name: &str) -> Motion {
    Motion::parse(name, Point3::new(0.0, 1.6, 0.0)).expect("preset exists")
}

/// A simulation of a synthetic model with the style's parameters.
pub fn synthetic_sim(text: &str, strands: usize, motion_name: &str) -> Simulation {
    let (loaded, model) = synthetic_model(text, strands, 0.4, 7);
    Simulation::from_style(model, &loaded.style, motion(motion_name), false)
}

/// Loads a shipped style and builds its model.
pub fn shipped(name: &str) -> (LoadedStyle, Arc<HairModel>) {
    let path = root().join("styles").join(name);
    let loaded = wisptree::scene::load_style(&path).unwrap_or_else(|e| panic!("{e}"));
    let model = HairModel::from_style(&loaded).unwrap_or_else(|e| panic!("{e}"));
    (loaded, Arc::new(model))
}
