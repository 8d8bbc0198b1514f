//! Ask one guide why (issue 27's inspector for Chang's guide strands): a vertex of a guide, its
//! state, the contacts the last sub-step found for it and for its guide through the triangle
//! strips (Chang, Jin, Yu 2002, "A practical model for hair mutual interactions", §4.2), and
//! its static links (§4.1) and strip triangles with their stretch beside the threshold that
//! breaks them.
//!
//! A node is named as for the AWT, `TREE:LEVEL:INDEX`, read here as `GUIDE:0:VERTEX`: the guide
//! model has one level, a guide is its slot (the initial guides first, then the slots of the
//! guides §4.3 inserts), and a vertex counts from the root.

use std::ops::Range;

use super::links::BREAK_STRETCH;
use super::{pick_guides, GuideSolver, Origin};
use crate::model::HairModel;
use crate::solver::NodeId;
use crate::style::GuideParams;

/// The names [`GuideSolver::inspect`] fills, in its order.
pub const INSPECT_NAMES: [&str; 21] = [
    "guide",
    "vertex",
    "inserted",
    "radius",
    "speed",
    "position_x",
    "position_y",
    "position_z",
    "velocity_x",
    "velocity_y",
    "velocity_z",
    "vertex_contacts",
    "guide_contacts",
    "links",
    "links_broken",
    "link_stretch_max",
    "link_break_stretch",
    "strip_triangles",
    "strip_triangles_broken",
    "strip_width_ratio_max",
    "strip_break",
];

/// Checks the form of `id` against `slots` guide slots of `segments` segments.
fn check(id: &NodeId, slots: usize, segments: usize) -> Result<(), String> {
    if id.level != 0 {
        return Err(format!(
            "level {} does not exist: the guide model has one level (GUIDE:0:VERTEX)",
            id.level
        ));
    }
    if id.tree as usize >= slots {
        return Err(format!(
            "guide {} does not exist: the model has guide slots 0 to {}",
            id.tree,
            slots.saturating_sub(1)
        ));
    }
    if id.index > segments {
        return Err(format!(
            "vertex {} does not exist: a guide has vertices 0 (the root) to {segments}",
            id.index
        ));
    }
    Ok(())
}

/// Checks `id` against the guides the model would have on `model` (before a run starts): the
/// initial guides and the slots left for inserted ones.
pub fn resolve(model: &HairModel, gp: &GuideParams, id: &NodeId) -> Result<(), String> {
    let slots = pick_guides(model, gp.count).len() + gp.max_inserted;
    check(id, slots, gp.segments)
}

impl GuideSolver {
    /// Fills `out` with [`INSPECT_NAMES`] for vertex `id` (`GUIDE:0:VERTEX`) after the last
    /// step. The contacts are those of the last sub-step (a vertex–triangle contact counts for
    /// the vertex and the triangle's three vertices, a segment pair for both ends of both
    /// segments). The links and triangles are those touching the vertex: links owned by or
    /// pointing at one of its two segments, triangles with it as a corner. A link breaks for
    /// good at stretch [`BREAK_STRETCH`]; a triangle is broken while its width is more than
    /// `strip_break` times its rest width, as checked at the start of the step (the width
    /// ratio given is the one after it).
    pub fn inspect(&self, id: &NodeId, out: &mut Vec<(&'static str, f64)>) -> Result<(), String> {
        let n = self.gp.segments;
        check(id, self.origin.len(), n)?;
        let g = id.tree as usize;
        if !self.alive.contains(&g) {
            return Err(format!(
                "guide {g} is not simulated now (a slot for a guide §4.3 inserts, empty or removed)"
            ));
        }
        let v = g * (n + 1) + id.index;
        let guide_verts = (g * (n + 1)) as u32..((g + 1) * (n + 1)) as u32;
        let (vertex_contacts, guide_contacts) =
            self.strips.contacts_touching(v as u32, guide_verts);
        // The vertex's segments (links, `g · n + i`): the one ending at it and the one
        // starting at it.
        let segs: Range<usize> =
            g * n + id.index.saturating_sub(1)..g * n + id.index.min(n - 1) + 1;
        let (mut links, mut broken, mut stretch) = (0usize, 0usize, 0.0f64);
        for k in 0..self.links.len() {
            let (o, p) = (self.links.owner[k] as usize, self.links.other[k] as usize);
            if !segs.contains(&o) && !segs.contains(&p) {
                continue;
            }
            links += 1;
            if self.links.broken[k] {
                broken += 1;
            } else {
                stretch = stretch.max(self.links.stretch[k]);
            }
        }
        let (mut tris, mut tris_broken, mut width) = (0usize, 0usize, 0.0f64);
        let strips = &self.strips;
        for t in 0..strips.tri.len() {
            if !strips.tri[t].contains(&(v as u32)) {
                continue;
            }
            tris += 1;
            tris_broken += strips.broken[t] as usize;
            let [a, b] = strips.width_edge[t];
            let w = (self.chains.x[a as usize] - self.chains.x[b as usize]).norm();
            width = width.max(w / strips.rest_width[t]);
        }
        let (x, vel) = (self.chains.x[v], self.chains.v[v]);
        out.clear();
        out.extend(INSPECT_NAMES.iter().copied().zip([
            g as f64,
            id.index as f64,
            f64::from(u8::from(matches!(self.origin[g], Origin::Inserted(..)))),
            // A guide stands for a cluster as thick as the contact distance (§4.2): the ring
            // the view draws around the inspected vertex.
            self.gp.contact_distance,
            vel.norm(),
            x.x,
            x.y,
            x.z,
            vel.x,
            vel.y,
            vel.z,
            vertex_contacts as f64,
            guide_contacts as f64,
            links as f64,
            broken as f64,
            stretch,
            BREAK_STRETCH,
            tris as f64,
            tris_broken as f64,
            width,
            self.gp.strip_break,
        ]));
        Ok(())
    }

    /// The vertex clicked (see [`crate::solver::Solver::pick_node`]): nearest the point, else
    /// drawn as `instance` (vertices are drawn guide after guide, root to tip, alive guides
    /// only).
    pub fn pick(&self, instance: Option<usize>, near: Option<[f64; 3]>) -> Option<NodeId> {
        let n = self.gp.segments;
        let drawn = |k: usize| -> Option<(usize, usize)> {
            let g = *self.alive.get(k / (n + 1))?;
            Some((g, k % (n + 1)))
        };
        let (g, i) = match near {
            Some(q) => {
                let q = nalgebra::Vector3::new(q[0], q[1], q[2]);
                let d = |k: usize| {
                    drawn(k).map_or(f64::INFINITY, |(g, i)| {
                        (self.chains.x[g * (n + 1) + i] - q).norm()
                    })
                };
                let k = (0..self.alive.len() * (n + 1)).min_by(|&a, &b| d(a).total_cmp(&d(b)))?;
                drawn(k)?
            }
            None => drawn(instance?)?,
        };
        Some(NodeId {
            tree: g as u32,
            level: 0,
            index: i,
        })
    }
}
