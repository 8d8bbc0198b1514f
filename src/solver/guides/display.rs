//! What the guide solver draws: guide vertices and segments, static links (intact and broken
//! in two colours), the triangle strips (translucent, broken ones marked) and the moving
//! obstacles (three great circles each: the body spheres are drawn by the pipeline, posed with
//! the head, which these do not follow).

use nalgebra::Vector3;

use super::GuideSolver;
use crate::frame::{Frame, PrimitiveKind};

/// Entity path of the static links.
pub const LINKS_PATH: &str = "/hair/guides/static_links";
/// Entity path of the triangle strips.
pub const STRIPS_PATH: &str = "/hair/guides/strips";
/// Entity path of the moving obstacles.
pub const OBSTACLES_PATH: &str = "/hair/guides/obstacles";

const LINK_INTACT: [u8; 4] = [90, 220, 130, 255];
const LINK_BROKEN: [u8; 4] = [235, 70, 60, 255];
const STRIP_INTACT: [u8; 4] = [90, 150, 255, 60];
const STRIP_BROKEN: [u8; 4] = [255, 90, 60, 120];
const OBSTACLE: [u8; 4] = [230, 200, 90, 255];
/// Points per drawn circle of an obstacle.
const CIRCLE: usize = 48;

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
    if s.gp.obstacles.is_empty() {
        return;
    }
    let obs = f.primitives(OBSTACLES_PATH, PrimitiveKind::LineStrips);
    obs.radius_ui = 1.0;
    for o in &s.gp.obstacles {
        let p = super::obstacle::posed(o, s.time);
        for axis in 0..3 {
            let pts = (0..=CIRCLE).map(|k| {
                let a = std::f64::consts::TAU * k as f64 / CIRCLE as f64;
                let (u, w) = (a.cos() * p.radius, a.sin() * p.radius);
                let d = match axis {
                    0 => Vector3::new(0.0, u, w),
                    1 => Vector3::new(u, 0.0, w),
                    _ => Vector3::new(u, w, 0.0),
                };
                to32(&(p.center + d))
            });
            obs.push_strip(pts);
            obs.colors.push(OBSTACLE);
        }
    }
}
