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
//! * **Grid.** Cubic cells whose side is the mean largest side of the radius-inflated segment
//!   boxes, so a segment touches about 1–8 cells; the dense cell array is capped at
//!   [`MAX_CELLS`] cells (the cell side grows instead), which bounds memory when a node flies away.
//!   A pair is tested only in the cell at the min corner of the overlap of its two cell ranges, so
//!   it is tested once without a pair set. Cell lists are filled in segment order, so forces depend
//!   only on the input order.

use nalgebra::Vector3;

/// Upper bound on the number of cells of the dense voxel grid (4 MiB of `u32` offsets).
pub const MAX_CELLS: usize = 1 << 20;

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
    /// Pairs that reached the cylinder test (box overlap, then closest points): sharing a voxel,
    /// not adjacent, moving relative to each other. Each such pair counts once.
    pub tested: u32,
    /// Of those, the pairs whose cylinders intersect (`d < r1 + r2`).
    pub in_contact: u32,
}

/// The voxel grid of the last [`HairCollider::accumulate`] call.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GridInfo {
    /// World position of the min corner of cell (0, 0, 0), m.
    pub origin: Vector3<f64>,
    /// Side of the cubic cells, m.
    pub cell_size: f64,
    /// Number of cells along x, y, z.
    pub dims: [u32; 3],
}

impl GridInfo {
    /// Cell coordinates of a point, clamped to the grid.
    pub fn cell_of(&self, p: &Vector3<f64>) -> [u32; 3] {
        let mut c = [0u32; 3];
        for k in 0..3 {
            let f = ((p[k] - self.origin[k]) / self.cell_size).floor();
            // `as` saturates (NaN → 0), the min keeps the cell inside the grid.
            c[k] = (f.max(0.0) as u32).min(self.dims[k].saturating_sub(1));
        }
        c
    }

    /// Inclusive cell range `(lo, hi)` of segment `i`'s box inflated by its radius.
    pub fn cell_range(
        &self,
        segs: &SegmentsView,
        pos: &[Vector3<f64>],
        i: usize,
    ) -> ([u32; 3], [u32; 3]) {
        let (lo, hi) = inflated_box(segs, pos, i);
        (self.cell_of(&lo), self.cell_of(&hi))
    }
}

/// Reused buffers: the voxel grid, per-cell lists. Allocation only while warming up.
#[derive(Default)]
pub struct HairCollider {
    /// Per segment: min and max cell coordinates of its inflated box.
    lo: Vec<[u32; 3]>,
    hi: Vec<[u32; 3]>,
    /// Dense cell offsets into `items` (counting sort), `ncells + 1` entries.
    cell_start: Vec<u32>,
    /// Segment indices, grouped by cell, ascending within a cell.
    items: Vec<u32>,
    grid: GridInfo,
    contacts: Vec<Contact>,
    load: Vec<f64>,
    node_mass: Vec<f64>,
}

impl HairCollider {
    pub fn new() -> Self {
        Self::default()
    }

    /// The grid built by the last call to [`Self::accumulate`].
    pub fn grid(&self) -> GridInfo {
        self.grid
    }

    /// Bytes reserved by the reused buffers (stays constant once warmed up on a scene size).
    pub fn capacity_bytes(&self) -> usize {
        self.lo.capacity() * std::mem::size_of::<[u32; 3]>()
            + self.hi.capacity() * std::mem::size_of::<[u32; 3]>()
            + self.cell_start.capacity() * 4
            + self.items.capacity() * 4
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
        self.build_grid(segs, pos);
        self.contacts.clear();

        let [dx, dy, dz] = self.grid.dims.map(|d| d as usize);
        let items = &self.items;
        for z in 0..dz {
            for y in 0..dy {
                for x in 0..dx {
                    let c = (z * dy + y) * dx + x;
                    let cell = &items[self.cell_start[c] as usize..self.cell_start[c + 1] as usize];
                    let here = [x as u32, y as u32, z as u32];
                    for (k, &a) in cell.iter().enumerate() {
                        let lo_a = self.lo[a as usize];
                        for &b in &cell[k + 1..] {
                            let lo_b = self.lo[b as usize];
                            // Test the pair only in the min corner of the overlap of the two
                            // cell ranges: every shared cell sees the pair, exactly one is that.
                            if lo_a[0].max(lo_b[0]) == here[0]
                                && lo_a[1].max(lo_b[1]) == here[1]
                                && lo_a[2].max(lo_b[2]) == here[2]
                            {
                                if let Some(c) =
                                    interact(a as usize, b as usize, segs, pos, vel, p, &mut stats)
                                {
                                    self.contacts.push(c);
                                }
                            }
                        }
                    }
                }
            }
        }
        apply_contacts(
            &self.contacts,
            segs,
            p,
            &mut self.node_mass,
            &mut self.load,
            force,
        );
        stats
    }

    /// Counting sort of the segments into a dense grid over their bounding box.
    fn build_grid(&mut self, segs: &SegmentsView, pos: &[Vector3<f64>]) {
        let n = segs.len();
        let mut bmin = Vector3::repeat(f64::INFINITY);
        let mut bmax = Vector3::repeat(f64::NEG_INFINITY);
        let mut side_sum = 0.0;
        for i in 0..n {
            let (lo, hi) = inflated_box(segs, pos, i);
            bmin = bmin.inf(&lo);
            bmax = bmax.sup(&hi);
            side_sum += (hi - lo).max();
        }
        let extent = bmax - bmin;
        let mut grid = GridInfo {
            origin: bmin,
            cell_size: 1.0,
            dims: [1, 1, 1],
        };
        if extent.iter().all(|e| e.is_finite()) {
            // Mean largest side; a floor keeps degenerate scenes (all points equal) finite.
            let mut h = (side_sum / n as f64).max(extent.max() * 1e-6).max(1e-9);
            for _ in 0..64 {
                let dims = extent.map(|e| (e / h).floor() + 1.0);
                let cells = dims.x * dims.y * dims.z;
                if cells <= MAX_CELLS as f64 {
                    grid.dims = [dims.x as u32, dims.y as u32, dims.z as u32];
                    grid.cell_size = h;
                    break;
                }
                // Grow the cells so the product fits; the margin absorbs the `+ 1` per axis.
                h *= (cells / MAX_CELLS as f64).cbrt() * 1.01;
            }
        }
        // Non-finite extents (a bug upstream, e.g. a NaN position) fall back to one cell: slow
        // but bounded, and never a hang.
        self.grid = grid;
        let ncells = grid.dims.iter().map(|&d| d as usize).product::<usize>();

        self.lo.clear();
        self.hi.clear();
        self.cell_start.clear();
        self.cell_start.resize(ncells + 1, 0);
        let [dx, dy, _] = grid.dims.map(|d| d as usize);
        let mut total = 0usize;
        for i in 0..n {
            let (lo, hi) = grid.cell_range(segs, pos, i);
            self.lo.push(lo);
            self.hi.push(hi);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    let row = (z as usize * dy + y as usize) * dx;
                    for x in lo[0]..=hi[0] {
                        self.cell_start[row + x as usize] += 1;
                    }
                }
            }
            total += ((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1)) as usize;
        }
        assert!(total < u32::MAX as usize, "too many cell entries: {total}");
        // Inclusive prefix sums: cell_start[c] = end of cell c.
        let mut acc = 0u32;
        for s in &mut self.cell_start[..ncells] {
            acc += *s;
            *s = acc;
        }
        self.cell_start[ncells] = acc;
        self.items.clear();
        self.items.resize(total, 0);
        // Filling from the last segment backwards while decrementing the ends leaves each cell
        // list ascending and cell_start[c] at the start of cell c.
        for i in (0..n).rev() {
            let (lo, hi) = (self.lo[i], self.hi[i]);
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    let row = (z as usize * dy + y as usize) * dx;
                    for x in lo[0]..=hi[0] {
                        let s = &mut self.cell_start[row + x as usize];
                        *s -= 1;
                        self.items[*s as usize] = i as u32;
                    }
                }
            }
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
    let mut contacts = Vec::new();
    for a in 0..n {
        for b in a + 1..n {
            contacts.extend(interact(a, b, segs, pos, vel, p, &mut stats));
        }
    }
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

/// Tests one pair of segments (`a < b` so that both grid and reference compute bit-identical
/// pair forces) and returns the contact, if any.
#[allow(clippy::too_many_arguments)]
#[inline]
fn interact(
    a: usize,
    b: usize,
    segs: &SegmentsView,
    pos: &[Vector3<f64>],
    vel: &[Vector3<f64>],
    p: &ContactParams,
    stats: &mut PairStats,
) -> Option<Contact> {
    let (pa, ca) = (segs.parent[a] as usize, segs.child[a] as usize);
    let (pb, cb) = (segs.parent[b] as usize, segs.child[b] as usize);
    // Adjacent segments (a chain, or siblings on one parent) always touch: never test them.
    if pa == pb || pa == cb || ca == pb || ca == cb {
        return None;
    }
    let (vpa, vca, vpb, vcb) = (vel[pa], vel[ca], vel[pb], vel[cb]);
    // Bound on every point-to-point relative speed (see module docs).
    let rel2 = (vpa - vpb)
        .norm_squared()
        .max((vpa - vcb).norm_squared())
        .max((vca - vpb).norm_squared())
        .max((vca - vcb).norm_squared());
    if rel2 < p.epsilon * p.epsilon {
        return None;
    }
    stats.tested += 1;
    let (xpa, xca, xpb, xcb) = (pos[pa], pos[ca], pos[pb], pos[cb]);
    let r = segs.radius[a] + segs.radius[b];
    // Cheap exact rejection before the closest points: cylinders closer than r1 + r2 have boxes,
    // inflated by r1 + r2 in total, that overlap on every axis. Segments sharing a cell often
    // do not.
    let (lo_a, hi_a) = (xpa.inf(&xca), xpa.sup(&xca));
    let (lo_b, hi_b) = (xpb.inf(&xcb), xpb.sup(&xcb));
    if (0..3).any(|k| lo_a[k] - hi_b[k] > r || lo_b[k] - hi_a[k] > r) {
        return None;
    }
    let (s, t) = closest_segment_params(&xpa, &xca, &xpb, &xcb);
    let d1 = xca - xpa;
    let d2 = xcb - xpb;
    let p1 = xpa + d1 * s;
    let p2 = xpb + d2 * t;
    let delta = p1 - p2;
    let dist2 = delta.norm_squared();
    if dist2 >= r * r {
        return None;
    }
    stats.in_contact += 1;
    let m = segs.child_mass[a].min(segs.child_mass[b]);

    // Eq. 1: viscous friction at the closest points.
    let v1 = vpa * (1.0 - s) + vca * s;
    let v2 = vpb * (1.0 - t) + vcb * t;
    let friction = (v2 - v1) * (p.friction * m);
    let mut repulsion = Vector3::zeros();

    // Eq. 2: repulsion only between wisps crossing at a large enough angle.
    let len2 = d1.norm_squared() * d2.norm_squared();
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
        a: a as u32,
        b: b as u32,
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
    let r = a1 - a2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
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
    let b = d1.dot(&d2);
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
