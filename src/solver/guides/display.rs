//! What the guide solver draws: guide vertices and segments, static links (intact and broken
//! in two colours) and the triangle strips (translucent, broken ones marked).

use nalgebra::Vector3;

use super::GuideSolver;
use crate::frame::{Frame, PrimitiveKind};

/// Entity path of the static links.
pub const LINKS_PATH: &str = "/hair/guides/static_links";
/// Entity path of the triangle strips.
pub const STRIPS_PATH: &str = "/hair/guides/strips";

const LINK_INTACT: [u8; 4] = [90, 220, 130, 255];
const LINK_BROKEN: [u8; 4] = [235, 70, 60, 255];
const STRIP_INTACT: [u8; 4] = [90, 150, 255, 60];
const STRIP_BROKEN: [u8; 4] = [255, 90, 60, 120];

fn to32(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

pub(super) fn draw(s: &GuideSolver, f: &mut Frame) {
    let n = s.gp.segments;
    let c = &s.chains;
    for &g in &s.alive {
        let level = (g >= s.initial) as u16;
        for i in 0..=n {
            let v = g * (n + 1) + i;
            f.nodes.positions.push(to32(&c.x[v]));
            f.nodes.radii.push(0.002);
            f.nodes.levels.push(level);
            if i > 0 {
                f.segments.starts.push(to32(&c.x[v - 1]));
                f.segments.ends.push(to32(&c.x[v]));
                f.segments.radii.push(0.001);
                f.segments.levels.push(level);
            }
        }
    }
    let links = f.primitives(LINKS_PATH, PrimitiveKind::LineStrips);
    links.radius_ui = 0.5;
    for k in 0..s.links.len() {
        let (a, b) = s.links.ends(c, k);
        links.push_strip([to32(&a), to32(&b)]);
        links.colors.push(if s.links.broken[k] {
            LINK_BROKEN
        } else {
            LINK_INTACT
        });
    }
    let strips = f.primitives(STRIPS_PATH, PrimitiveKind::Triangles);
    for t in 0..s.strips.tri.len() {
        for v in s.strips.tri[t] {
            strips.points.push(to32(&c.x[v as usize]));
        }
        strips.colors.push(if s.strips.broken[t] {
            STRIP_BROKEN
        } else {
            STRIP_INTACT
        });
    }
}
