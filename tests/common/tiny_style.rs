//! The tiny test style shared by `tests/run.rs` and `tests/sweep.rs`: 4 top-level wisps, 2
//! levels, K = 8, about 300 strands; fast enough for whole runs in a test.
#![allow(dead_code)]

pub const TINY: &str = r#"Style(
    name: "tiny",
    seed: 7,
    hair: Generated((
        density: 3.0,
        samples: 12,
        wisps: [
        (
            name: "back",
            region: (azimuth: (140, 220), elevation: (0, 70)),
            tiles: (2, 2),
            key_strand: [(0.03, 0.0, 0.0), (0.08, 0.02, 0.0), (0.16, 0.04, 0.0), (0.24, 0.05, 0.0)],
            tip_spread: 0.01,
        ),
        ],
    )),
    hierarchy: (levels: 2, cross_sections: 8, branching: [4]),
    link: Rigid(iterations: 8),
    sim: (split_threshold: SPLIT, merge_velocity: 0.05),
)
"#;

/// The tiny style with this split threshold.
pub fn tiny_style(split: &str) -> String {
    TINY.replace("SPLIT", split)
}
