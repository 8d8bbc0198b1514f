//! The response (AWT §4.2): friction and repulsion forces from the contacts, split between parent and child nodes.

use nalgebra::Vector3;

use super::*;

/// Adds the contacts' forces to the nodes (eq. 3), limited so that a node touching many
/// segments at once stays stable. (For callers holding a list of contacts; the collider itself
/// accumulates the loads while it finds the contacts.)
///
/// The AWT's `α·dt < 1` keeps ONE contact from reversing a relative velocity, but a node in a
/// dense wisp touches dozens of segments in the same step and the explicit sum of their
/// friction impulses overshoots (the hair explodes). Each node's load `W = Σ share·m/m_node`
/// over its contacts is therefore computed first, and a pair's friction is scaled by
/// `1 / max(1, 2·α·dt·W)` and its repulsion by `1 / max(1, 2·k_r·dt²·W)`, W the largest load
/// among the pair's four nodes. The scale is the same on both sides, so forces still sum to
/// zero; a lone contact (W ≤ 1) is untouched when `α·dt < 1/2`. Here `m` is the pair's mass
/// (the lighter child). `inv_mass` and `load` are scratch buffers (one entry per node slot).
pub fn apply_contacts(
    contacts: &[Contact],
    segs: &SegmentsView,
    p: &ContactParams,
    inv_mass: &mut Vec<f64>,
    load: &mut Vec<f64>,
    force: &mut [Vector3<f64>],
) {
    let mut response = Response::new(segs, force.len(), inv_mass, load);
    for c in contacts {
        response.record(c, segs);
    }
    response.apply(&[contacts], segs, p, force);
}

/// The per-node loads of [`apply_contacts`], accumulated contact by contact.
pub(super) struct Response<'a> {
    /// Per slot: 1 / its mass as a child (0 for a kinematic root); then, in [`Self::apply`],
    /// the friction scale of the node.
    pub(super) inv_mass: &'a mut Vec<f64>,
    /// Per slot: the load `W`; then, in [`Self::apply`], the repulsion scale of the node.
    pub(super) load: &'a mut Vec<f64>,
}

impl<'a> Response<'a> {
    pub(super) fn new(
        segs: &SegmentsView,
        nodes: usize,
        inv_mass: &'a mut Vec<f64>,
        load: &'a mut Vec<f64>,
    ) -> Self {
        // A slot's mass is its mass as a child; a slot that is never a child is a kinematic
        // root, which no force moves (infinite mass, no load).
        inv_mass.clear();
        inv_mass.resize(nodes, 0.0);
        for i in 0..segs.len() {
            inv_mass[segs.child[i] as usize] = 1.0 / segs.child_mass[i];
        }
        load.clear();
        load.resize(nodes, 0.0);
        Response { inv_mass, load }
    }

    /// Adds a contact's shares to the loads of its four nodes.
    #[inline]
    pub(super) fn record(&mut self, c: &Contact, segs: &SegmentsView) {
        let (a, b) = (c.a as usize, c.b as usize);
        let m = segs.child_mass[a].min(segs.child_mass[b]);
        for (n, share) in [
            (segs.parent[a], 1.0 - f64::from(c.s)),
            (segs.child[a], f64::from(c.s)),
            (segs.parent[b], 1.0 - f64::from(c.t)),
            (segs.child[b], f64::from(c.t)),
        ] {
            self.load[n as usize] += share * m * self.inv_mass[n as usize];
        }
    }

    /// Adds the loads of the search's chunks, in chunk order (each is what [`Self::record`]
    /// would have summed over that chunk's contacts).
    pub(super) fn add_loads(&mut self, chunks: &[&[f64]]) {
        for c in chunks {
            for (w, x) in self.load.iter_mut().zip(c.iter()) {
                *w += x;
            }
        }
    }

    /// Turns the loads into the per-node scales: `inv_mass` becomes the friction scale and
    /// `load` the repulsion scale.
    ///
    /// `1 / max(1, k·W)` with `W` the largest of the four loads is the smallest of the four
    /// nodes' `1 / max(1, k·W_n)` (the map is decreasing), so the scales are computed once per
    /// node instead of twice per contact.
    fn scales(&mut self, p: &ContactParams) {
        let (kf, kr) = (2.0 * p.friction * p.dt, 2.0 * p.repulsion * p.dt * p.dt);
        for (f, w) in self.inv_mass.iter_mut().zip(self.load.iter_mut()) {
            *f = 1.0 / (kf * *w).max(1.0);
            *w = 1.0 / (kr * *w).max(1.0);
        }
    }

    /// Scales each contact by the loads of its nodes and adds its forces (eq. 3).
    pub(super) fn apply(
        mut self,
        lists: &[&[Contact]],
        segs: &SegmentsView,
        p: &ContactParams,
        force: &mut [Vector3<f64>],
    ) {
        self.scales(p);
        for c in lists.iter().flat_map(|l| l.iter()) {
            add_contact(c, segs, self.inv_mass, self.load, force);
        }
    }

    /// [`Self::apply`] with the contacts (the lists joined in order) cut into [`PARTS`] parts
    /// of equal length, each summed into its own buffer in `part_force` (on `pool` when there
    /// is one), and the buffers added to `force` in part order. The cut depends only on the
    /// number of contacts, so the sums are the same bit for bit with or without the pool.
    /// `seg_scale` is scratch for the segments' [`SegScale`]s.
    pub(super) fn apply_parts(
        mut self,
        lists: &[&[Contact]; CHUNKS],
        segs: &SegmentsView,
        p: &ContactParams,
        (part_force, seg_scale): (&mut Vec<Vector3<f64>>, &mut Vec<SegScale>),
        pool: Option<&crate::par::Pool>,
        force: &mut [Vector3<f64>],
    ) {
        self.scales(p);
        let nodes = force.len();
        part_force.clear();
        part_force.resize(PARTS * nodes, Vector3::zeros());
        let total: usize = lists.iter().map(|l| l.len()).sum();
        let (fric, rep) = (&self.inv_mass[..], &self.load[..]);
        seg_scale.clear();
        seg_scale.extend((0..segs.len()).map(|i| {
            let (parent, child) = (segs.parent[i], segs.child[i]);
            let (pi, ci) = (parent as usize, child as usize);
            SegScale {
                parent,
                child,
                fric: fric[pi].min(fric[ci]),
                rep: rep[pi].min(rep[ci]),
            }
        }));
        let seg_scale = &seg_scale[..];
        {
            let parts = crate::par::split_parts::<_, PARTS>(part_force, |k| (k + 1) * nodes);
            let run = |k: usize| {
                let (from, to) = (total * k / PARTS, total * (k + 1) / PARTS);
                let mut part = lock(&parts[k]);
                let f = &mut *part.1;
                let mut at = 0;
                for l in lists {
                    let (lo, hi) = (from.max(at), to.min(at + l.len()));
                    if lo < hi {
                        for c in &l[lo - at..hi - at] {
                            add_contact_scaled(c, seg_scale, f);
                        }
                    }
                    at += l.len();
                }
            };
            crate::par::for_each_on(pool, PARTS, &run);
        }
        for part in part_force.chunks_exact(nodes) {
            for (f, x) in force.iter_mut().zip(part) {
                *f += x;
            }
        }
    }
}

/// Adds one contact's forces, scaled by the scales of its nodes, to its four nodes (eq. 3).
#[inline(always)]
fn add_contact(
    c: &Contact,
    segs: &SegmentsView,
    fric: &[f64],
    rep: &[f64],
    force: &mut [Vector3<f64>],
) {
    let (a, b) = (c.a as usize, c.b as usize);
    let (pa, ca) = (segs.parent[a] as usize, segs.child[a] as usize);
    let (pb, cb) = (segs.parent[b] as usize, segs.child[b] as usize);
    let fs = fric[pa].min(fric[ca]).min(fric[pb]).min(fric[cb]);
    let rs = rep[pa].min(rep[ca]).min(rep[pb]).min(rep[cb]);
    let f = widen(c.friction) * fs + widen(c.repulsion) * rs;
    // Eq. 3: F at P = (1 − s)·N_p + s·N_c goes (1 − s)·F to the parent, s·F to the child.
    let fa_child = f * f64::from(c.s);
    force[pa] += f - fa_child;
    force[ca] += fa_child;
    let fb_child = f * f64::from(c.t);
    force[pb] -= f - fb_child;
    force[cb] -= fb_child;
}

/// One segment's node slots and the smaller of its two nodes' friction and repulsion scales,
/// gathered once per step: a contact then reads two of these instead of four slots and eight
/// scales (`min` is exact, so the pair's scale is the same bit for bit).
#[derive(Clone, Copy, Default)]
pub(super) struct SegScale {
    parent: u32,
    child: u32,
    fric: f64,
    rep: f64,
}

/// [`add_contact`] with the scales of [`SegScale`].
#[inline(always)]
fn add_contact_scaled(c: &Contact, seg_scale: &[SegScale], force: &mut [Vector3<f64>]) {
    let (sa, sb) = (&seg_scale[c.a as usize], &seg_scale[c.b as usize]);
    let (pa, ca) = (sa.parent as usize, sa.child as usize);
    let (pb, cb) = (sb.parent as usize, sb.child as usize);
    let fs = sa.fric.min(sb.fric);
    let rs = sa.rep.min(sb.rep);
    let f = widen(c.friction) * fs + widen(c.repulsion) * rs;
    // Eq. 3, as in `add_contact`.
    let fa_child = f * f64::from(c.s);
    force[pa] += f - fa_child;
    force[ca] += fa_child;
    let fb_child = f * f64::from(c.t);
    force[pb] -= f - fb_child;
    force[cb] -= fb_child;
}
