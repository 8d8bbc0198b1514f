//! Colours and sizes of everything drawn.

use rerun::datatypes::Rgba32;

use crate::report::EventKind;

/// Level colours, from coarse (warm, dark) to fine (cool, light). A model with `L` levels takes
/// `L` entries spread over the whole ramp, so 2 levels are dark red and pale blue, not dark red
/// and orange.
pub(super) const LEVEL_RAMP: [(u8, u8, u8); 6] = [
    (170, 40, 30),   // dark red
    (225, 110, 30),  // orange
    (230, 195, 60),  // gold
    (120, 200, 120), // light green
    (95, 180, 240),  // sky blue
    (205, 215, 255), // pale periwinkle
];

/// The colour of `level` in a model with `levels` levels.
pub fn level_color(level: u16, levels: u16) -> Rgba32 {
    let (r, g, b) = level_rgb(level, levels);
    Rgba32::from_rgb(r, g, b)
}

/// [`level_color`] as plain RGB, for writers that do not speak Rerun (the USD export).
pub fn level_rgb(level: u16, levels: u16) -> (u8, u8, u8) {
    let last = LEVEL_RAMP.len() - 1;
    let idx = if levels <= 1 {
        0
    } else {
        let l = level.min(levels - 1) as usize;
        // Round to the nearest ramp entry; exact ends for the coarsest and finest level.
        (l * last + (levels as usize - 1) / 2) / (levels as usize - 1)
    };
    LEVEL_RAMP[idx.min(last)]
}

pub(super) const HAIR_COLOR: (u8, u8, u8) = (255, 205, 120);
/// Opacity of the active nodes and segments (0–255).
pub(super) const NODE_ALPHA: u8 = 255;
/// Segment opacity of the coarsest and the finest level; levels in between are interpolated.
/// Coarse capsules are large and overlap many times over (a 7 cm capsule per cross-section of
/// every top-level wisp), so they need to be the most transparent.
pub(super) const SEGMENT_ALPHA_COARSE: f32 = 22.0;
pub(super) const SEGMENT_ALPHA_FINE: f32 = 30.0;
/// Nodes are drawn as spheres of this fraction of their radius: at full size the coarse nodes
/// (up to 15 cm) cover the strands and all finer levels; the segment capsules around them show
/// the full radius.
pub(super) const NODE_DRAW_SCALE: f32 = 0.25;
pub(super) const SPLIT_COLOR: (u8, u8, u8) = (255, 90, 20);
pub(super) const GUIDE_INSERT_COLOR: (u8, u8, u8) = (120, 255, 120);
pub(super) const GUIDE_REMOVE_COLOR: (u8, u8, u8) = (255, 120, 255);

/// The marker colour of an event kind.
pub(super) fn event_color(kind: EventKind) -> (u8, u8, u8) {
    match kind {
        EventKind::Split => SPLIT_COLOR,
        EventKind::Merge => MERGE_COLOR,
        EventKind::GuideInsert => GUIDE_INSERT_COLOR,
        EventKind::GuideRemove => GUIDE_REMOVE_COLOR,
    }
}
pub(super) const MERGE_COLOR: (u8, u8, u8) = (40, 200, 230);
pub(super) const BODY_COLOR: (u8, u8, u8, u8) = (170, 170, 180, 110);
pub(super) const SCALP_COLOR: (u8, u8, u8) = (225, 190, 160);
/// The inspected node's ring: magenta, a colour no level and no event uses.
pub(super) const INSPECTED_COLOR: (u8, u8, u8) = (255, 40, 220);
/// The ring's radius over the node's (it encloses the node's sphere).
pub(super) const INSPECTED_SCALE: f32 = 1.3;
/// Strand width on screen: thin and independent of zoom, so 10,000 strands stay readable.
pub(super) const STRAND_RADIUS_UI: f32 = 1.0;
/// Event markers: big enough to find in a frame.
pub(super) const EVENT_RADIUS_UI: f32 = 6.0;

/// Series names and colours of the stats every solver has, by stat name.
pub const COMMON_SERIES: [(&str, (u8, u8, u8), &str); 9] = {
    use crate::report::names as p;
    [
        (p::SPLITS, SPLIT_COLOR, "splits"),
        (p::MERGES, MERGE_COLOR, "merges"),
        (p::PAIRS_TESTED, (150, 150, 255), "pairs tested"),
        (p::PAIRS_IN_CONTACT, (255, 120, 200), "pairs in contact"),
        (p::BODY_CONTACTS, (120, 230, 140), "body contacts"),
        (p::KINETIC_ENERGY, (255, 210, 80), "kinetic energy (J)"),
        (p::STEP_MS, (200, 200, 210), "step (ms)"),
        (p::DROPPED_FRAMES, (255, 80, 80), "dropped frames"),
        (p::REALTIME_FACTOR, (120, 255, 180), "real-time factor (×)"),
    ]
};

/// Whether `name` is a measure with a fixed series style (common or per level).
pub fn is_common_stat(name: &str) -> bool {
    name.starts_with(crate::report::names::ACTIVE_LEVEL_PREFIX)
        || COMMON_SERIES.iter().any(|(p, _, _)| *p == name)
}

/// Colours for solver-specific stats, by order of appearance.
pub(super) const STAT_RAMP: [(u8, u8, u8); 6] = [
    (255, 160, 60),
    (90, 220, 255),
    (200, 120, 255),
    (140, 255, 140),
    (255, 110, 110),
    (240, 240, 120),
];

/// The colour of the `k`-th (from 1) solver-specific stat.
pub fn stat_color(k: usize) -> (u8, u8, u8) {
    STAT_RAMP[(k.max(1) - 1) % STAT_RAMP.len()]
}
