//! Ask one wisp why (issue 27's inspector for Plante's layered wisps): a skeleton point of a
//! wisp, its state, and the contacts the last detection found for it and for its wisp
//! (Plante et al. 2001, "A layered wisp model for simulating interactions inside long hair",
//! §4.1–4.2: points of one wisp's segments inside another's volume).
//!
//! A node is named as for the AWT, `TREE:LEVEL:INDEX`, read here as `WISP:0:POINT`: the layered
//! model has one level of wisps, and a point counts from the wisp's root.

use super::{wisp_level, LayeredSolver};
use crate::model::HairModel;
use crate::solver::NodeId;
use crate::style::LayeredParams;

/// The names [`LayeredSolver::inspect`] fills, in its order.
pub const INSPECT_NAMES: [&str; 15] = [
    "wisp",
    "point",
    "gc",
    "radius",
    "mass",
    "speed",
    "position_x",
    "position_y",
    "position_z",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "wisp_contact_pairs",
    "point_contacts",
    "wisp_contacts",
];

/// The skeleton point of `id`, given each wisp's range of points, or why there is none.
fn point_of(points_per_wisp: &[std::ops::Range<usize>], id: &NodeId) -> Result<usize, String> {
    let n = points_per_wisp.len();
    if id.level != 0 {
        return Err(format!(
            "level {} does not exist: the layered model has one level of wisps (WISP:0:POINT)",
            id.level
        ));
    }
    let Some(r) = points_per_wisp.get(id.tree as usize) else {
        return Err(format!(
            "wisp {} does not exist: the model has wisps 0 to {}",
            id.tree,
            n.saturating_sub(1)
        ));
    };
    if id.index >= r.len() {
        return Err(format!(
            "point {} does not exist: wisp {} has points 0 to {}",
            id.index,
            id.tree,
            r.len().saturating_sub(1)
        ));
    }
    Ok(r.start + id.index)
}

/// Checks `id` against the wisps the layered model builds on `model` (before a run starts).
pub fn resolve(model: &HairModel, lp: &LayeredParams, id: &NodeId) -> Result<(), String> {
    let w = super::wisp::Wisps::build(model, wisp_level(model, lp));
    let ranges: Vec<_> = (0..w.len()).map(|k| w.points(k)).collect();
    point_of(&ranges, id).map(|_| ())
}

impl LayeredSolver {
    /// Fills `out` with [`INSPECT_NAMES`] for skeleton point `id` (`WISP:0:POINT`), from the
    /// state after the last step: its wisp and GC, radius (the mean of its section's envelope
    /// radii, as drawn), mass, speed, position and velocity; the
    /// contacts the last detection found: segment pairs that involve its wisp
    /// (`wisp_contact_pairs`), the contact points of its own section (`point_contacts`) and
    /// of its wisp's sections (`wisp_contacts`).
    pub fn inspect(&self, id: &NodeId, out: &mut Vec<(&'static str, f64)>) -> Result<(), String> {
        let w = &self.wisps;
        let ranges: Vec<_> = (0..w.len()).map(|k| w.points(k)).collect();
        let p = point_of(&ranges, id)?;
        let wisp = id.tree as usize;
        let of_wisp = |point: u32| w.wisp_of[point as usize] as usize == wisp;
        let d = &self.detector;
        let pairs = d
            .pairs
            .iter()
            .filter(|c| of_wisp(c.a) || of_wisp(c.b))
            .count();
        let point_contacts = d.contacts.iter().filter(|c| c.point as usize == p).count();
        let wisp_contacts = d.contacts.iter().filter(|c| of_wisp(c.point)).count();
        let (x, v) = (w.pos[p], w.vel[p]);
        out.clear();
        out.extend(
            INSPECT_NAMES.iter().copied().zip([
                wisp as f64,
                id.index as f64,
                f64::from(w.gc[wisp]),
                w.rho[p * super::ENV..(p + 1) * super::ENV]
                    .iter()
                    .sum::<f64>()
                    / super::ENV as f64,
                w.mass[p],
                v.norm(),
                x.x,
                x.y,
                x.z,
                v.x,
                v.y,
                v.z,
                pairs as f64,
                point_contacts as f64,
                wisp_contacts as f64,
            ]),
        );
        Ok(())
    }
}

impl LayeredSolver {
    /// The skeleton point clicked (see [`crate::solver::Solver::pick_node`]): nearest the
    /// point, else drawn as `instance` (points are drawn wisp after wisp, root to tip).
    pub fn pick(&self, instance: Option<usize>, near: Option<[f64; 3]>) -> Option<NodeId> {
        let w = &self.wisps;
        let p = match near {
            Some(q) => {
                let q = nalgebra::Vector3::new(q[0], q[1], q[2]);
                (0..w.point_count())
                    .min_by(|&a, &b| (w.pos[a] - q).norm().total_cmp(&(w.pos[b] - q).norm()))?
            }
            None => instance.filter(|&p| p < w.point_count())?,
        };
        let wisp = w.wisp_of[p];
        Some(NodeId {
            tree: wisp,
            level: 0,
            index: p - w.points(wisp as usize).start,
        })
    }
}
