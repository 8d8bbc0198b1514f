//! Hair–hair and hair–body interaction (AWT §4, after Plante et al. §5).
//!
//! The simulation gathers the ACTIVE AWT nodes of a step into compact slot arrays (`pos`, `vel`)
//! and the active segments (parent slot → child slot) into a [`SegmentsView`]. This module works
//! only on those arrays:
//!
//! * [`HairCollider::accumulate`] adds the anisotropic hair–hair forces (friction, eq. 1, and
//!   repulsion, eq. 2) split onto the segment nodes (eq. 3);
//! * [`resolve_body`] moves child nodes out of the body spheres (§4.3).
//!
//! # Choices where the papers leave room
//!
//! * **Closest points in f64.** `parry3d` 0.25 is f32-only (`parry3d-f64` is a separate crate we do
//!   not depend on), while positions are f64 and hair radii are sub-millimetre, so
//!   [`closest_segment_params`] is Ericson's routine (the one parry uses in
//!   `closest_points_segment_segment_with_locations_nD`) rewritten in f64 with relative epsilons.
//!   A test compares it with parry on random segments. Parameters are reported as `s`, the weight of
//!   the CHILD node (`P = (1 − s)·N_parent + s·N_child`), i.e. the paper's `u` is `1 − s`. For
//!   (near-)parallel axes the closest points are not unique; we take the middle of the overlap of
//!   the two segments (parry takes an end), so friction between parallel wisps — the common case —
//!   is shared by both nodes instead of landing on one end.
//! * **Which mass.** `k_f = α·m` and `R = k_r·m·(r − d)·n` with `m` the LIGHTER of the two child
//!   masses: one coefficient serves both sides of the pair, and using the lighter one keeps
//!   `α·dt < 1` sufficient for neither side to have its relative motion reversed.
//! * **Relative-motion test (§4.1).** A pair is skipped when all four node-velocity differences
//!   between the two segments (`v_i − v_j` for `i` a node of one segment and `j` of the other) are
//!   below `epsilon`. The velocity of any point of a segment is a convex combination of its node
//!   velocities, so then every point-to-point relative velocity, in particular `Ṗ2 − Ṗ1`, is below
//!   `epsilon` too (a midpoint test would miss segments rotating about their middles).
//! * **Degenerate normals.** When the axes intersect (`d ≈ 0`) the repulsion normal is the cross
//!   product of the axes, oriented from the second segment's midpoint towards the first's.
//!   A zero-length segment has no orientation and gets friction only.
//! * **Broad phase: sort and sweep, not a grid.** The coarse wisps are fat (radius up to
//!   ~7 cm) and a third of the active pairs are really in contact, so a voxel grid with cells the
//!   size of the inflated boxes had only a few dozen cells and visited more pairs than the brute
//!   force. The segments are instead sorted by the min of their inflated boxes along the axis where
//!   boxes are thinnest relative to the scene's spread, and each is paired with the following ones
//!   until their min passes its max: every pair overlapping on that axis is visited exactly once,
//!   no memory grows with the scene's extent (a node flung far away costs nothing), and ties in the
//!   sort are broken by segment index, so the forces depend only on the input.
//! * **Filters are exact.** Box overlap (boxes inflated by `r1 + r2`), adjacency and the
//!   relative-motion test are symmetric and computed from per-segment data gathered once per step;
//!   the closest points and the response are computed with the lower segment index first, as in
//!   [`accumulate_brute_force`], so both find the same contacts with bit-identical pair forces
//!   (only the order in which they are summed differs).
//! * **One thread.** Splitting the sweep into chunks run by rayon (own contact list per chunk,
//!   applied in chunk order) was measured at 15–30 % faster on 2 busy cores, but every call from
//!   outside the pool pushes a job on rayon's injector, which allocates a 1.5 kB block every 63
//!   jobs: that breaks the no-allocation-once-warm guarantee (tests/alloc.rs), so the sweep runs on
//!   the calling thread.

use nalgebra::Vector3;

/// The active segments of one step, as parallel slices (structure of arrays).
pub struct SegmentsView<'a> {
    /// Slot of the parent node.
    pub parent: &'a [u32],
    /// Slot of the child node.
    pub child: &'a [u32],
    /// Cylinder radius = the child node's radius (AWT §4.1), m.
    pub radius: &'a [f64],
    /// Mass of the child node, kg.
    pub child_mass: &'a [f64],
}

impl SegmentsView<'_> {
    /// Number of segments. Panics if the slices differ in length (a bug in the caller).
    pub fn len(&self) -> usize {
        let n = self.parent.len();
        assert!(
            self.child.len() == n && self.radius.len() == n && self.child_mass.len() == n,
            "SegmentsView slices differ in length: parent {}, child {}, radius {}, child_mass {}",
            n,
            self.child.len(),
            self.radius.len(),
            self.child_mass.len()
        );
        n
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Parameters of the hair–hair response (AWT §4.2).
#[derive(Debug, Clone, Copy)]
pub struct ContactParams {
    /// α, s⁻¹ ; k_f = α·m.
    pub friction: f64,
    /// k_r per kilogram, s⁻² (R = k_r · m · (r − d) · n).
    pub repulsion: f64,
    /// Repulsion only when |cos(angle between axes)| < this.
    pub cos_angle_threshold: f64,
    /// Relative speed below which a pair is skipped, m/s.
    pub epsilon: f64,
    /// The integration step the forces will be applied over, s (see [`apply_contacts`]).
    pub dt: f64,
}

/// One pair of segments in contact: where, and the unscaled eq. 1 and eq. 2 forces on `a`.
#[derive(Debug, Clone, Copy)]
pub struct Contact {
    pub a: u32,
    pub b: u32,
    /// Closest points as fractions from parent (0) to child (1) on `a` and `b`.
    pub s: f64,
    pub t: f64,
    /// Friction (eq. 1) and repulsion (eq. 2) on `a`; `b` gets the opposite.
    pub friction: Vector3<f64>,
    pub repulsion: Vector3<f64>,
    /// The mass in k_f = α·m and k_r·m (the lighter child).
    pub mass: f64,
}

impl ContactParams {
    /// Checks the parameters for a time step `dt` (s); the message names the offending field.
    /// `α·dt < 1` is the AWT's condition for friction never to reverse a relative motion.
    pub fn validate(&self, dt: f64) -> Result<(), String> {
        let finite_nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("contact.{name} must be finite and >= 0, got {v}"))
            }
        };
        finite_nonneg("friction", self.friction)?;
        finite_nonneg("repulsion", self.repulsion)?;
        finite_nonneg("epsilon", self.epsilon)?;
        if !(self.cos_angle_threshold.is_finite() && self.cos_angle_threshold >= 0.0) {
            return Err(format!(
                "contact.cos_angle_threshold must be finite and >= 0, got {}",
                self.cos_angle_threshold
            ));
        }
        if self.friction * dt >= 1.0 {
            return Err(format!(
                "contact.friction: α·dt must be < 1 so friction cannot reverse a relative motion \
                 (AWT §4.2), got α = {} s⁻¹ with dt = {} s (α·dt = {})",
                self.friction,
                dt,
                self.friction * dt
            ));
        }
        Ok(())
    }
}

/// Counters of one [`HairCollider::accumulate`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairStats {
    /// Pairs whose radius-inflated boxes overlap along the sweep axis: the pairs the broad phase
    /// visits (all `n·(n − 1)/2` pairs in [`accumulate_brute_force`]).
    pub candidates: u32,
    /// Pairs that reached the closest-point routine: not adjacent, moving relative to each other,
    /// boxes inflated by `r1 + r2` overlapping on every axis. Each such pair counts once.
    pub tested: u32,
    /// Of those, the pairs whose cylinders intersect (`d < r1 + r2`).
    pub in_contact: u32,
}

/// Reused buffers of the broad phase (sort and sweep) and of the response. Allocation only while
/// warming up.
///
/// The segments are sorted by the min of their radius-inflated boxes along one axis (the one where
/// boxes are thinnest relative to the spread of the scene); each segment is then paired with the
/// following ones until their min passes its max, so every pair whose boxes overlap on that axis is
/// visited exactly once, and the other two axes are checked from a compact per-position array
/// before the exact tests.
#[derive(Default)]
pub struct HairCollider {
    /// `(min along the sweep axis, segment)` in sweep order.
    order: Vec<(f64, u32)>,
    /// Per sweep position: max of the inflated box along the sweep axis.
    reach: Vec<f64>,
    /// Per sweep position: the segment's data.
    pre: Vec<SegPre>,
    contacts: Vec<Contact>,
    /// Sweep axis of the last call (0 = x, 1 = y, 2 = z).
    axis: usize,
    load: Vec<f64>,
    node_mass: Vec<f64>,
}

impl HairCollider {
    pub fn new() -> Self {
        Self::default()
    }

    /// The sweep axis chosen by the last call to [`Self::accumulate`] (0 = x, 1 = y, 2 = z).
    pub fn sweep_axis(&self) -> usize {
        self.axis
    }

    /// Bytes reserved by the reused buffers (stays constant once warmed up on a scene size).
    pub fn capacity_bytes(&self) -> usize {
        self.order.capacity() * std::mem::size_of::<(f64, u32)>()
            + self.reach.capacity() * 8
            + self.pre.capacity() * std::mem::size_of::<SegPre>()
            + self.contacts.capacity() * std::mem::size_of::<Contact>()
            + (self.load.capacity() + self.node_mass.capacity()) * 8
    }

    /// Adds the hair–hair friction and repulsion forces to `force` (indexed by slot).
    pub fn accumulate(
        &mut self,
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        vel: &[Vector3<f64>],
        p: &ContactParams,
        force: &mut [Vector3<f64>],
    ) -> PairStats {
        let mut stats = PairStats::default();
        let n = segs.len();
        if n < 2 {
            return stats;
        }
        assert!(
            n < u32::MAX as usize,
            "too many segments for u32 indices: {n}"
        );
        self.sort_boxes(segs, pos);
        self.gather(segs, pos, vel);
        let order = &self.order[..];
        let reach = &self.reach[..];
        let pre = &self.pre[..];
        let eps2 = p.epsilon * p.epsilon;
        let contacts = &mut self.contacts;
        contacts.clear();
        for i in 0..n {
            let (ri, si) = (reach[i], &pre[i]);
            for j in i + 1..n {
                // Sorted by min: no later segment can overlap `i` along the sweep axis.
                if order[j].0 > ri {
                    break;
                }
                stats.candidates += 1;
                let sj = &pre[j];
                if !pair_filter(si, sj, eps2) {
                    continue;
                }
                stats.tested += 1;
                // `contact` wants the lower segment index first (same rounding as the reference).
                let (a, b) = if si.seg < sj.seg { (si, sj) } else { (sj, si) };
                if let Some(c) = contact(a, b, p) {
                    contacts.push(c);
                }
            }
        }
        stats.in_contact = contacts.len() as u32;
        apply_contacts(
            contacts,
            segs,
            p,
            &mut self.node_mass,
            &mut self.load,
            force,
        );
        stats
    }

    /// Inflated boxes, the sweep axis, and the segments sorted along it.
    fn sort_boxes(&mut self, segs: &SegmentsView, pos: &[Vector3<f64>]) {
        let n = segs.len();
        let mut bmin = Vector3::repeat(f64::INFINITY);
        let mut bmax = Vector3::repeat(f64::NEG_INFINITY);
        let mut width = Vector3::zeros();
        for i in 0..n {
            let (lo, hi) = inflated_box(segs, pos, i);
            bmin = bmin.inf(&lo);
            bmax = bmax.sup(&hi);
            width += hi - lo;
        }
        // The expected number of overlaps along an axis grows with (mean width) / (spread).
        let mut axis = 1;
        let mut best = f64::INFINITY;
        for k in [1, 0, 2] {
            let ratio = width[k] / (bmax[k] - bmin[k]);
            if ratio < best {
                best = ratio;
                axis = k;
            }
        }
        self.axis = axis;
        self.order.clear();
        for i in 0..n {
            let (lo, _) = sweep_box(segs, pos, i);
            self.order.push((lo[axis], i as u32));
        }
        // Ties broken by segment index: the order, hence the forces, depend only on the input.
        self.order
            .sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    }

    /// Per sweep position: the max along the sweep axis and the segment's data.
    fn gather(&mut self, segs: &SegmentsView, pos: &[Vector3<f64>], vel: &[Vector3<f64>]) {
        self.reach.clear();
        self.pre.clear();
        for &(_, i) in &self.order {
            let (_, hi) = sweep_box(segs, pos, i as usize);
            self.reach.push(hi[self.axis]);
            self.pre.push(SegPre::new(segs, pos, vel, i as usize));
        }
    }
}

/// Reference all-pairs version of [`HairCollider::accumulate`], O(n²): same pair filters and
/// response, pairs visited in lexicographic order. For tests and benchmarks.
pub fn accumulate_brute_force(
    segs: &SegmentsView,
    pos: &[Vector3<f64>],
    vel: &[Vector3<f64>],
    p: &ContactParams,
    force: &mut [Vector3<f64>],
) -> PairStats {
    let mut stats = PairStats::default();
    let n = segs.len();
    let pre: Vec<SegPre> = (0..n).map(|i| SegPre::new(segs, pos, vel, i)).collect();
    let eps2 = p.epsilon * p.epsilon;
    let mut contacts = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            stats.candidates += 1;
            if pair_filter(&pre[a], &pre[b], eps2) {
                stats.tested += 1;
                contacts.extend(contact(&pre[a], &pre[b], p));
            }
        }
    }
    stats.in_contact = contacts.len() as u32;
    apply_contacts(&contacts, segs, p, &mut Vec::new(), &mut Vec::new(), force);
    stats
}

/// Adds the contacts' forces to the nodes (eq. 3), limited so that a node touching many
/// segments at once stays stable.
///
/// The AWT's `α·dt < 1` keeps ONE contact from reversing a relative velocity, but a node in a
/// dense wisp touches dozens of segments in the same step and the explicit sum of their
/// friction impulses overshoots (the hair explodes). Each node's load `W = Σ share·m/m_node`
/// over its contacts is therefore computed first, and a pair's friction is scaled by
/// `1 / max(1, 2·α·dt·W)` and its repulsion by `1 / max(1, 2·k_r·dt²·W)`, W the largest load
/// among the pair's four nodes. The scale is the same on both sides, so forces still sum to
/// zero; a lone contact (W ≤ 1) is untouched when `α·dt < 1/2`.
pub fn apply_contacts(
    contacts: &[Contact],
    segs: &SegmentsView,
    p: &ContactParams,
    node_mass: &mut Vec<f64>,
    load: &mut Vec<f64>,
    force: &mut [Vector3<f64>],
) {
    let nodes = force.len();
    // A slot's mass is its mass as a child; a slot that is never a child is a kinematic root,
    // which no force moves (infinite mass, no load).
    node_mass.clear();
    node_mass.resize(nodes, f64::INFINITY);
    for i in 0..segs.len() {
        node_mass[segs.child[i] as usize] = segs.child_mass[i];
    }
    load.clear();
    load.resize(nodes, 0.0);
    for c in contacts {
        let (a, b) = (c.a as usize, c.b as usize);
        for (n, share) in [
            (segs.parent[a], 1.0 - c.s),
            (segs.child[a], c.s),
            (segs.parent[b], 1.0 - c.t),
            (segs.child[b], c.t),
        ] {
            load[n as usize] += share * c.mass / node_mass[n as usize];
        }
    }
    for c in contacts {
        let (a, b) = (c.a as usize, c.b as usize);
        let (pa, ca) = (segs.parent[a] as usize, segs.child[a] as usize);
        let (pb, cb) = (segs.parent[b] as usize, segs.child[b] as usize);
        let w = load[pa].max(load[ca]).max(load[pb]).max(load[cb]);
        let fric = 1.0 / (2.0 * p.friction * p.dt * w).max(1.0);
        let rep = 1.0 / (2.0 * p.repulsion * p.dt * p.dt * w).max(1.0);
        let f = c.friction * fric + c.repulsion * rep;
        // Eq. 3: F at P = (1 − s)·N_p + s·N_c goes (1 − s)·F to the parent, s·F to the child.
        let fa_child = f * c.s;
        force[pa] += f - fa_child;
        force[ca] += fa_child;
        let fb_child = f * c.t;
        force[pb] -= f - fb_child;
        force[cb] -= fb_child;
    }
}

/// Axis-aligned box of segment `i` inflated by its radius.
#[inline]
fn inflated_box(
    segs: &SegmentsView,
    pos: &[Vector3<f64>],
    i: usize,
) -> (Vector3<f64>, Vector3<f64>) {
    let a = pos[segs.parent[i] as usize];
    let b = pos[segs.child[i] as usize];
    let r = Vector3::repeat(segs.radius[i]);
    (a.inf(&b) - r, a.sup(&b) + r)
}

/// The broad phase's box of segment `i`: [`inflated_box`] grown by a relative 1e-12 so that its
/// rounding can never reject a pair the exact test in [`interact`] keeps.
#[inline]
fn sweep_box(segs: &SegmentsView, pos: &[Vector3<f64>], i: usize) -> (Vector3<f64>, Vector3<f64>) {
    let a = pos[segs.parent[i] as usize];
    let b = pos[segs.child[i] as usize];
    let (lo, hi) = (a.inf(&b), a.sup(&b));
    let r = segs.radius[i];
    let m = Vector3::repeat(r + 1e-12 * (r + lo.abs().max().max(hi.abs().max())));
    (lo - m, hi + m)
}

/// One segment's data for the pair tests, gathered once per step.
#[derive(Clone, Copy)]
struct SegPre {
    /// Box of the two nodes, not inflated.
    lo: [f64; 3],
    hi: [f64; 3],
    radius: f64,
    parent: u32,
    child: u32,
    /// Index in the [`SegmentsView`].
    seg: u32,
    xp: Vector3<f64>,
    xc: Vector3<f64>,
    /// `xc − xp` and its squared length.
    d: Vector3<f64>,
    len2: f64,
    vp: Vector3<f64>,
    vc: Vector3<f64>,
    mass: f64,
}

impl SegPre {
    #[inline]
    fn new(segs: &SegmentsView, pos: &[Vector3<f64>], vel: &[Vector3<f64>], i: usize) -> Self {
        let (parent, child) = (segs.parent[i], segs.child[i]);
        let (xp, xc) = (pos[parent as usize], pos[child as usize]);
        let (lo, hi) = (xp.inf(&xc), xp.sup(&xc));
        let d = xc - xp;
        SegPre {
            lo: [lo.x, lo.y, lo.z],
            hi: [hi.x, hi.y, hi.z],
            radius: segs.radius[i],
            parent,
            child,
            seg: i as u32,
            xp,
            xc,
            d,
            len2: d.norm_squared(),
            vp: vel[parent as usize],
            vc: vel[child as usize],
            mass: segs.child_mass[i],
        }
    }
}

/// Whether a pair reaches the closest-point routine: boxes inflated by `r1 + r2` overlapping on
/// every axis (cylinders closer than `r1 + r2` must), not adjacent, moving relative to each other.
/// Symmetric in its two arguments (bit for bit), so the sweep may call it in either order.
#[inline(always)]
fn pair_filter(a: &SegPre, b: &SegPre, eps2: f64) -> bool {
    let r = a.radius + b.radius;
    // Non-short-circuit `|`: the six comparisons are independent, one branch instead of six.
    let apart = (a.lo[0] - b.hi[0] > r)
        | (b.lo[0] - a.hi[0] > r)
        | (a.lo[1] - b.hi[1] > r)
        | (b.lo[1] - a.hi[1] > r)
        | (a.lo[2] - b.hi[2] > r)
        | (b.lo[2] - a.hi[2] > r);
    if apart {
        return false;
    }
    // Adjacent segments (a chain, or siblings on one parent) always touch: never test them.
    if (a.parent == b.parent) | (a.parent == b.child) | (a.child == b.parent) | (a.child == b.child)
    {
        return false;
    }
    // Bound on every point-to-point relative speed (see module docs).
    let rel2 = (a.vp - b.vp)
        .norm_squared()
        .max((a.vp - b.vc).norm_squared())
        .max((a.vc - b.vp).norm_squared())
        .max((a.vc - b.vc).norm_squared());
    rel2 >= eps2
}

/// The contact of a pair that passed [`pair_filter`], if the cylinders intersect. `a` must be the
/// segment with the lower index, so that the sweep and the reference compute bit-identical pair
/// forces.
#[inline]
fn contact(a: &SegPre, b: &SegPre, p: &ContactParams) -> Option<Contact> {
    let (xpa, xca, xpb, xcb) = (a.xp, a.xc, b.xp, b.xc);
    let (vpa, vca, vpb, vcb) = (a.vp, a.vc, b.vp, b.vc);
    let r = a.radius + b.radius;
    let (s, t) = closest_params(&xpa, &a.d, a.len2, &xpb, &b.d, b.len2);
    let (d1, d2) = (a.d, b.d);
    let p1 = xpa + d1 * s;
    let p2 = xpb + d2 * t;
    let delta = p1 - p2;
    let dist2 = delta.norm_squared();
    if dist2 >= r * r {
        return None;
    }
    let m = a.mass.min(b.mass);

    // Eq. 1: viscous friction at the closest points.
    let v1 = vpa * (1.0 - s) + vca * s;
    let v2 = vpb * (1.0 - t) + vcb * t;
    let friction = (v2 - v1) * (p.friction * m);
    let mut repulsion = Vector3::zeros();

    // Eq. 2: repulsion only between wisps crossing at a large enough angle.
    let len2 = a.len2 * b.len2;
    let cos = if len2 > 0.0 {
        d1.dot(&d2).abs() / len2.sqrt()
    } else {
        1.0
    };
    if cos < p.cos_angle_threshold {
        let d = dist2.sqrt();
        let n = if d > 1e-9 * r {
            delta / d
        } else {
            let mid = (xpa + xca - xpb - xcb) * 0.5;
            degenerate_normal(&d1, &d2, &mid)
        };
        // Only while the two approach: a penalty that also pushed separating wisps would, with
        // the skipping of still pairs (§4.1), chatter forever on resting hair and pump energy
        // into it. The response stays soft (§4.2) and never accelerates a separation.
        // It is also capped at the impulse that stops the approach within the step, so like
        // friction it can bring the normal relative velocity to zero but never reverse it.
        let approach = -(v1 - v2).dot(&n);
        if approach > 0.0 {
            let push = (p.repulsion * m * (r - d)).min(m * approach / p.dt.max(1e-12));
            repulsion = n * push;
        }
    }

    Some(Contact {
        a: a.seg,
        b: b.seg,
        s,
        t,
        friction,
        repulsion,
        mass: m,
    })
}

/// Unit normal for intersecting axes: perpendicular to both, pointing to the side of `mid`
/// (first midpoint minus second).
fn degenerate_normal(d1: &Vector3<f64>, d2: &Vector3<f64>, mid: &Vector3<f64>) -> Vector3<f64> {
    let c = d1.cross(d2);
    let cn = c.norm();
    let scale = d1.norm() * d2.norm();
    let n = if cn > 1e-9 * scale {
        c / cn
    } else {
        // Parallel axes (only reachable with a threshold above 1): the midpoint offset across d1.
        let u = d1.try_normalize(0.0).unwrap_or_else(Vector3::x);
        let across = mid - u * u.dot(mid);
        across
            .try_normalize(1e-300)
            .unwrap_or_else(|| any_perpendicular(&u))
    };
    if n.dot(mid) < 0.0 {
        -n
    } else {
        n
    }
}

/// A unit vector perpendicular to the unit vector `u`, chosen deterministically.
fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let axis = if u.x.abs() < 0.57 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    u.cross(&axis).normalize()
}

/// Closest points between segments `[a1, b1]` and `[a2, b2]` (Ericson, *Real-Time Collision
/// Detection* §5.1.9, as in parry), in f64. Returns `(s, t)` with the closest points
/// `a1 + s·(b1 − a1)` and `a2 + t·(b2 − a2)`, both in `[0, 1]`. For parallel overlapping segments
/// `s` is the middle of the overlap.
pub fn closest_segment_params(
    a1: &Vector3<f64>,
    b1: &Vector3<f64>,
    a2: &Vector3<f64>,
    b2: &Vector3<f64>,
) -> (f64, f64) {
    let d1 = b1 - a1;
    let d2 = b2 - a2;
    closest_params(a1, &d1, d1.norm_squared(), a2, &d2, d2.norm_squared())
}

/// [`closest_segment_params`] from the first points, the directions `d = b − a` and their squared
/// lengths (computed once per segment by the caller).
#[inline]
fn closest_params(
    a1: &Vector3<f64>,
    d1: &Vector3<f64>,
    a: f64,
    a2: &Vector3<f64>,
    d2: &Vector3<f64>,
    e: f64,
) -> (f64, f64) {
    let r = a1 - a2;
    let f = d2.dot(&r);
    // Relative to the scene: a segment shorter than 1e-12 of the other or of the gap is a point.
    let scale = a.max(e).max(r.norm_squared());
    let tiny = 1e-24 * scale;
    if a <= tiny && e <= tiny {
        return (0.0, 0.0);
    }
    if a <= tiny {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= tiny {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(d2);
    let denom = a * e - b * b; // = |d1 × d2|² ≥ 0
    let mut s = if denom > 1e-12 * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        // Parallel: seg 2's ends project on seg 1 at -c/a and (b - c)/a.
        let (p, q) = (-c / a, (b - c) / a);
        let (lo, hi) = (p.min(q).max(0.0), p.max(q).min(1.0));
        if lo <= hi {
            0.5 * (lo + hi)
        } else {
            (0.5 * (p + q)).clamp(0.0, 1.0)
        }
    };
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// A sphere of the body proxy (AWT §4.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodySphere {
    pub center: Vector3<f64>,
    pub radius: f64,
}

/// Passes over the spheres per segment before the exit fallback (overlapping spheres can push a
/// node back and forth).
const BODY_PASSES: usize = 4;
/// Relative tolerance on `|q − c|²` below which a segment's interior counts as inside: the
/// tangent placement is exact only up to rounding and must not re-trigger a push.
const CHORD_TOLERANCE: f64 = 1e-9;

/// AWT §4.3: every segment that enters a sphere has its CHILD node moved out to the surface and
/// given the obstacle's velocity `obstacle_velocity(world_point)` (static friction, no bounce).
/// Returns the number of segments pushed.
///
/// Segments are handled in order, each seeing the positions already moved by earlier ones (so
/// give them root to tip). The test uses the sphere radius only, not sphere + hair radius: the
/// body proxy is meant to be drawn slightly inside the skin. For each sphere:
/// * a child strictly inside (`|x − c|² < R²`) is projected radially onto the surface;
/// * if the parent is outside but the segment's interior cuts the sphere, the child is rotated
///   about the parent, keeping the segment's length, until the segment is tangent to the sphere;
/// * a parent inside (e.g. a root planted under the proxy) is left to its own segment: moving the
///   child cannot get such a segment out, so only the child is kept out.
///
/// Afterwards no child node is strictly inside any sphere, even where spheres overlap.
pub fn resolve_body(
    segs: &SegmentsView,
    pos: &mut [Vector3<f64>],
    vel: &mut [Vector3<f64>],
    spheres: &[BodySphere],
    obstacle_velocity: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> u32 {
    let mut pushed = 0;
    for i in 0..segs.len() {
        let (pi, ci) = (segs.parent[i] as usize, segs.child[i] as usize);
        let parent = pos[pi];
        let mut child = pos[ci];
        let mut moved = false;
        for _ in 0..BODY_PASSES {
            let mut changed = false;
            for s in spheres {
                if let Some(c) = push_out(&parent, &child, s) {
                    child = c;
                    changed = true;
                }
            }
            moved |= changed;
            if !changed {
                break;
            }
        }
        if let Some(c) = exit_union(&child, spheres) {
            child = c;
            moved = true;
        }
        if moved {
            pos[ci] = child;
            vel[ci] = obstacle_velocity(&child);
            pushed += 1;
        }
    }
    pushed
}

#[inline]
fn strictly_inside(x: &Vector3<f64>, s: &BodySphere) -> bool {
    (x - s.center).norm_squared() < s.radius * s.radius
}

/// New child position if segment `parent → child` enters sphere `s`, else `None`.
fn push_out(parent: &Vector3<f64>, child: &Vector3<f64>, s: &BodySphere) -> Option<Vector3<f64>> {
    let r2 = s.radius * s.radius;
    let mut x = *child;
    let mut moved = false;
    if strictly_inside(&x, s) {
        let dir = (x - s.center)
            .try_normalize(1e-300)
            .or_else(|| (x - parent).try_normalize(1e-300))
            .unwrap_or_else(Vector3::y);
        x = onto_surface(s, &dir);
        moved = true;
    }
    let w = s.center - parent;
    let dd = w.norm_squared();
    if dd >= r2 {
        let seg = x - parent;
        let l2 = seg.norm_squared();
        if l2 > 0.0 {
            let t = w.dot(&seg) / l2;
            if t > 0.0 && t < 1.0 {
                let q = parent + seg * t;
                if (q - s.center).norm_squared() < r2 * (1.0 - CHORD_TOLERANCE) {
                    // Rotate about the parent onto the tangent cone: angle θ from the centre
                    // direction with sin θ = R / D, in the plane of parent, centre and child.
                    let dlen = dd.sqrt();
                    let wh = w / dlen;
                    let len = l2.sqrt();
                    let u = seg / len;
                    let across = u - wh * wh.dot(&u);
                    let eh = across
                        .try_normalize(1e-300)
                        .unwrap_or_else(|| any_perpendicular(&wh));
                    let sin = (s.radius / dlen).min(1.0);
                    let cos = (1.0 - sin * sin).max(0.0).sqrt();
                    x = parent + (wh * cos + eh * sin) * len;
                    if strictly_inside(&x, s) {
                        let dir = (x - s.center).try_normalize(1e-300).unwrap_or(eh);
                        x = onto_surface(s, &dir);
                    }
                    moved = true;
                }
            }
        }
    }
    moved.then_some(x)
}

/// The point of `s`'s surface in unit direction `dir` from the centre, nudged outwards until
/// rounding no longer leaves it strictly inside.
fn onto_surface(s: &BodySphere, dir: &Vector3<f64>) -> Vector3<f64> {
    let mut rr = s.radius;
    let mut x = s.center + dir * rr;
    for _ in 0..64 {
        if !strictly_inside(&x, s) {
            break;
        }
        rr = rr * (1.0 + 1e-14) + f64::MIN_POSITIVE;
        x = s.center + dir * rr;
    }
    x
}

/// If `x` is strictly inside some sphere after the passes (overlapping spheres), moves it along a
/// fixed ray out of the union: the ray meets each sphere in one interval, so stepping to the far
/// end of each sphere that still contains the point leaves the union in at most one step per
/// sphere.
fn exit_union(x: &Vector3<f64>, spheres: &[BodySphere]) -> Option<Vector3<f64>> {
    let first = spheres.iter().find(|s| strictly_inside(x, s))?;
    let dir = (x - first.center)
        .try_normalize(1e-300)
        .unwrap_or_else(Vector3::y);
    let mut p = *x;
    for _ in 0..=2 * spheres.len() {
        let Some(s) = spheres.iter().find(|s| strictly_inside(&p, s)) else {
            break;
        };
        let o = p - s.center;
        let b = o.dot(&dir);
        let disc = (b * b - (o.norm_squared() - s.radius * s.radius)).max(0.0);
        p += dir * (-b + disc.sqrt()).max(0.0);
        if strictly_inside(&p, s) {
            let d = (p - s.center).try_normalize(1e-300).unwrap_or(dir);
            p = onto_surface(s, &d);
        }
    }
    debug_assert!(
        !spheres.iter().any(|s| strictly_inside(&p, s)),
        "exit_union left {p:?} inside a sphere"
    );
    Some(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_params_cross() {
        let (s, t) = closest_segment_params(
            &Vector3::new(-1.0, 0.0, 0.0),
            &Vector3::new(3.0, 0.0, 0.0),
            &Vector3::new(0.0, -1.0, 1.0),
            &Vector3::new(0.0, 1.0, 1.0),
        );
        assert!(
            (s - 0.25).abs() < 1e-15 && (t - 0.5).abs() < 1e-15,
            "{s} {t}"
        );
    }

    #[test]
    fn closest_params_parallel_overlap_takes_middle() {
        // Seg 2 covers x ∈ [1, 3] above seg 1 (x ∈ [0, 2]): overlap [1, 2], middle x = 1.5.
        let (s, t) = closest_segment_params(
            &Vector3::new(0.0, 0.0, 0.0),
            &Vector3::new(2.0, 0.0, 0.0),
            &Vector3::new(1.0, 0.1, 0.0),
            &Vector3::new(3.0, 0.1, 0.0),
        );
        assert!(
            (s - 0.75).abs() < 1e-15 && (t - 0.25).abs() < 1e-15,
            "{s} {t}"
        );
    }
}
