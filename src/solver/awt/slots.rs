//! The active nodes in compact structure-of-arrays form, topologically ordered, on which the
//! dynamics run; gathered from the forest when the active set changes and scattered back.

use nalgebra::Vector3;

use super::{collide, Simulation, NO_SLOT};

/// The active nodes in compact arrays, topologically ordered (every parent before its children).
#[derive(Debug, Default, Clone)]
pub struct Slots {
    /// Level and node index (`g * K + i`) of each slot.
    pub level: Vec<u8>,
    /// Node index on its level (`g * K + i`).
    pub node: Vec<u32>,
    /// Cross-section index.
    pub cs: Vec<u16>,
    /// Parent slot (`NO_SLOT` for roots, which are kinematic).
    pub parent: Vec<u32>,
    /// Position, m.
    pub pos: Vec<Vector3<f64>>,
    /// Position at the start of the step, m.
    pub prev_pos: Vec<Vector3<f64>>,
    /// Velocity, m/s.
    pub vel: Vec<Vector3<f64>>,
    /// Velocity at the start of the step, m/s.
    pub vel_start: Vec<Vector3<f64>>,
    /// Smoothed acceleration (the split test), m/s².
    pub acc: Vec<Vector3<f64>>,
    /// Accumulated force of the step, N.
    pub force: Vec<Vector3<f64>>,
    /// Mass, kg.
    pub mass: Vec<f64>,
    /// Mass carried by the link ending at the node (node to tip of its GC).
    pub mass_below: Vec<f64>,
    /// Radius, m.
    pub radius: Vec<f64>,
    /// Rest vector from the parent to this node in the rest pose (the styled direction).
    pub rest_vec: Vec<Vector3<f64>>,
    /// Rest length of the link from the parent, m.
    pub rest_len: Vec<f64>,
    /// Scratch: positions before the body stage, and which nodes the body touched this step.
    pub pre_body: Vec<Vector3<f64>>,
    /// Touched by the body this step.
    pub contact: Vec<bool>,
    /// Scratch of the rigid-link projection: `1 / mass`, 0 for a root (which no link moves).
    pub link_weight: Vec<f64>,
    /// Segments (non-root slots) for the collider.
    pub segs: Segments,
}

/// The active segments (one per non-root slot, in slot order), as the collider sees them.
#[derive(Debug, Default, Clone)]
pub struct Segments {
    /// Parent and child slot.
    pub parent: Vec<u32>,
    /// The child slot.
    pub child: Vec<u32>,
    /// The child's radius (AWT §4.1) and mass.
    pub radius: Vec<f64>,
    /// The child's mass, kg.
    pub mass: Vec<f64>,
    /// The generalized cylinder `(level, GC)` of the child node, numbered over all levels.
    pub chain: Vec<u32>,
}

impl Segments {
    /// The segments as the collider reads them.
    pub fn view(&self) -> collide::SegmentsView<'_> {
        collide::SegmentsView {
            parent: &self.parent,
            child: &self.child,
            radius: &self.radius,
            child_mass: &self.mass,
            chain: &self.chain,
        }
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.child.len()
    }

    /// No segment.
    pub fn is_empty(&self) -> bool {
        self.child.is_empty()
    }

    fn reserve(&mut self, n: usize) {
        self.parent.reserve(n);
        self.child.reserve(n);
        self.radius.reserve(n);
        self.mass.reserve(n);
        self.chain.reserve(n);
    }

    fn clear(&mut self) {
        self.parent.clear();
        self.child.clear();
        self.radius.clear();
        self.mass.clear();
        self.chain.clear();
    }
}

impl Slots {
    fn reserve(&mut self, n: usize) {
        let n = n.saturating_sub(self.level.len());
        self.level.reserve(n);
        self.node.reserve(n);
        self.cs.reserve(n);
        self.parent.reserve(n);
        self.pos.reserve(n);
        self.prev_pos.reserve(n);
        self.vel.reserve(n);
        self.vel_start.reserve(n);
        self.acc.reserve(n);
        self.force.reserve(n);
        self.mass.reserve(n);
        self.mass_below.reserve(n);
        self.radius.reserve(n);
        self.rest_vec.reserve(n);
        self.rest_len.reserve(n);
        self.pre_body.reserve(n);
        self.contact.reserve(n);
        self.link_weight.reserve(n);
        self.segs.reserve(n);
    }

    /// Number of active nodes.
    pub fn len(&self) -> usize {
        self.level.len()
    }
    /// No active node.
    pub fn is_empty(&self) -> bool {
        self.level.is_empty()
    }
    fn clear(&mut self) {
        self.level.clear();
        self.node.clear();
        self.cs.clear();
        self.parent.clear();
        self.pos.clear();
        self.prev_pos.clear();
        self.vel.clear();
        self.vel_start.clear();
        self.acc.clear();
        self.force.clear();
        self.mass.clear();
        self.mass_below.clear();
        self.radius.clear();
        self.rest_vec.clear();
        self.rest_len.clear();
        self.pre_body.clear();
        self.contact.clear();
        self.link_weight.clear();
        self.segs.clear();
    }
}

impl Simulation {
    pub(super) fn gather(&mut self) {
        let m = &*self.model;
        let k = m.k;
        let f = &mut self.forest;
        let s = &mut self.slots;
        s.clear();
        // At most one active node per finest cross-section: reserve that once, so the active
        // set can grow to anything without reallocating inside a step.
        s.reserve(m.nodes_on_level(m.level_count() - 1));
        for i in 0..k {
            for (l, lv) in m.levels.iter().enumerate() {
                for g in 0..lv.gc_count() {
                    let j = g * k + i;
                    if !f.active[l][j] {
                        continue;
                    }
                    let slot = s.level.len() as u32;
                    f.slot_of[l][j] = slot;
                    s.level.push(l as u8);
                    s.node.push(j as u32);
                    s.cs.push(i as u16);
                    let parent = if i == 0 {
                        NO_SLOT
                    } else {
                        let (pl, pj) = f
                            .governor_above(m, l, g, i - 1)
                            .expect("the AWT invariant gives every non-root node a parent");
                        f.slot_of[pl][pj]
                    };
                    s.parent.push(parent);
                    let st = &f.state[l];
                    s.pos.push(st.pos[j]);
                    s.prev_pos.push(st.pos[j]);
                    s.vel.push(st.vel[j]);
                    s.vel_start.push(st.vel[j]);
                    s.acc.push(st.acc[j]);
                    s.force.push(Vector3::zeros());
                    s.mass.push(lv.mass[j]);
                    s.mass_below.push(lv.mass_below[j]);
                    s.radius.push(st.radius[j]);
                    s.rest_vec.push(Vector3::zeros());
                    s.rest_len.push(0.0);
                    s.pre_body.push(Vector3::zeros());
                    s.contact.push(false);
                }
            }
        }
        self.refresh_slot_constants();
    }

    /// Rest vectors and lengths of the active links, and the collider's segment lists.
    pub(super) fn refresh_slot_constants(&mut self) {
        let m = &*self.model;
        let s = &mut self.slots;
        s.segs.clear();
        // First GC number of each level, for the segments' chain ids.
        let mut first_gc = [0u32; 256];
        for l in 1..m.level_count() {
            first_gc[l] = first_gc[l - 1] + m.levels[l - 1].gc_count() as u32;
        }
        for c in 0..s.len() {
            let p = s.parent[c];
            if p == NO_SLOT {
                continue;
            }
            let rc = m.levels[s.level[c] as usize].rest_pos[s.node[c] as usize];
            let rp = m.levels[s.level[p as usize] as usize].rest_pos[s.node[p as usize] as usize];
            s.rest_vec[c] = rc - rp;
            s.rest_len[c] = (rc - rp).norm();
            let level = s.level[c] as usize;
            s.segs.parent.push(p);
            s.segs.child.push(c as u32);
            s.segs.radius.push(s.radius[c]);
            s.segs.mass.push(s.mass[c]);
            s.segs.chain.push(first_gc[level] + s.node[c] / m.k as u32);
        }
    }

    /// Writes the active nodes' state back into the forest.
    pub(super) fn scatter(&mut self) {
        let s = &self.slots;
        for c in 0..s.len() {
            let st = &mut self.forest.state[s.level[c] as usize];
            let j = s.node[c] as usize;
            st.pos[j] = s.pos[c];
            st.vel[j] = s.vel[c];
            st.acc[j] = s.acc[c];
            st.radius[j] = s.radius[c];
        }
    }
}
