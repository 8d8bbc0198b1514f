//! Collision detection between wisp segments (Plante, Cani, Poulin 2002, §4.1): a regular grid
//! of the segments' bounding boxes, a mailbox so each pair is tested once, then a point test: a
//! contact is a skeleton or envelope point of one segment inside the other segment's volume,
//! bounded by its two cross-sections. Non-adjacent segments of one wisp are tested too.
//!
//! Segment `p` runs from skeleton point `p` to `p + 1`; the points it owns for the point test
//! are those of its end section `p + 1` (skeleton and 4 envelope points), so every point is
//! owned by exactly one segment (root sections are moved by the head and own nothing).

use nalgebra::Vector3;

use super::wisp::{Wisps, ENV};

/// Cells of the grid at most, whatever the hair's extent.
const MAX_CELLS: usize = 1 << 18;

/// A point of one segment found inside another segment's volume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// The skeleton point whose section the contact point belongs to.
    pub point: u32,
    /// 0..4: that envelope point; 4: the skeleton point itself.
    pub which: u8,
    /// The start point of the segment it is inside.
    pub seg: u32,
    /// Where along that segment's axis, in [0, 1].
    pub s: f64,
}

/// Two segments found in contact, and their contacts `contacts[first..end]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairContacts {
    /// Start points of the two segments, `a < b`.
    pub a: u32,
    /// See `a`.
    pub b: u32,
    /// Range of this pair's contacts.
    pub first: u32,
    /// See `first`.
    pub end: u32,
}

/// A segment's axis as the point test needs it, computed once per detection.
#[derive(Debug, Clone, Copy, Default)]
struct SegAxis {
    ab: Vector3<f64>,
    l2: f64,
    /// A bound on the squared distance from the axis of any point inside the volume.
    reach2: f64,
}

/// The grid, the mailbox and the contact lists, kept between detections.
#[derive(Debug, Clone, Default)]
pub struct Detector {
    /// Segment start points (all non-tip skeleton points).
    segs: Vec<u32>,
    lo: Vec<Vector3<f64>>,
    hi: Vec<Vector3<f64>>,
    cell_lo: Vec<[u32; 3]>,
    cell_hi: Vec<[u32; 3]>,
    cell_start: Vec<u32>,
    items: Vec<u32>,
    /// Per segment: the last segment it was tested with (the mailbox of §4.1).
    mailbox: Vec<u32>,
    /// Per skeleton point: its section's 4 envelope points in world space, this detection.
    env: Vec<[Vector3<f64>; ENV]>,
    /// Per segment: its axis `b − a`, its squared length and the square of a radius no point
    /// of its volume is farther than from the axis (with a margin for rounding).
    axis: Vec<SegAxis>,
    /// This detection's pairs in contact.
    pub pairs: Vec<PairContacts>,
    /// This detection's contacts, grouped by pair.
    pub contacts: Vec<Contact>,
    /// Pairs whose boxes overlapped (tested point by point) in the last detection.
    pub pairs_tested: u32,
}

impl Detector {
    /// A detector for `w`'s segments, buffers reserved.
    pub fn new(w: &Wisps) -> Detector {
        let mut d = Detector::default();
        for wi in 0..w.len() {
            let r = w.points(wi);
            for p in r.start..r.end - 1 {
                d.segs.push(p as u32);
            }
        }
        let n = d.segs.len();
        d.lo = vec![Vector3::zeros(); n];
        d.hi = vec![Vector3::zeros(); n];
        d.cell_lo = vec![[0; 3]; n];
        d.cell_hi = vec![[0; 3]; n];
        d.mailbox = vec![u32::MAX; n];
        d.env = vec![[Vector3::zeros(); ENV]; w.point_count()];
        d.axis = vec![SegAxis::default(); n];
        d.items.reserve(n * 8);
        d.cell_start.reserve(MAX_CELLS + 1);
        d.pairs.reserve(n * 8);
        d.contacts.reserve(n * 32);
        d
    }

    /// Bytes held by the reused buffers.
    pub fn capacity_bytes(&self) -> usize {
        self.segs.capacity() * 4
            + (self.lo.capacity() + self.hi.capacity()) * 24
            + (self.cell_lo.capacity() + self.cell_hi.capacity()) * 12
            + (self.cell_start.capacity() + self.items.capacity() + self.mailbox.capacity()) * 4
            + self.env.capacity() * std::mem::size_of::<[Vector3<f64>; ENV]>()
            + self.axis.capacity() * std::mem::size_of::<SegAxis>()
            + self.pairs.capacity() * std::mem::size_of::<PairContacts>()
            + self.contacts.capacity() * std::mem::size_of::<Contact>()
    }

    /// Finds every pair of non-adjacent segments in contact and their contacts.
    pub fn detect(&mut self, w: &Wisps) {
        self.pairs.clear();
        self.contacts.clear();
        self.pairs_tested = 0;
        let n = self.segs.len();
        if n == 0 {
            return;
        }
        let (mut glo, mut ghi) = (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        );
        let mut size = 0.0;
        for (p, env) in self.env.iter_mut().enumerate() {
            for (j, e) in env.iter_mut().enumerate() {
                *e = w.env_pos(p, j);
            }
        }
        for i in 0..n {
            let p = self.segs[i] as usize;
            let (mut lo, mut hi) = (w.pos[p], w.pos[p]);
            for q in [p, p + 1] {
                lo = lo.inf(&w.pos[q]);
                hi = hi.sup(&w.pos[q]);
                for e in &self.env[q] {
                    lo = lo.inf(e);
                    hi = hi.sup(e);
                }
            }
            self.lo[i] = lo;
            self.hi[i] = hi;
            let ab = w.pos[p + 1] - w.pos[p];
            let reach = w.rho[p * ENV..p * ENV + 2 * ENV]
                .iter()
                .fold(0.0f64, |m, &r| m.max(r))
                * (1.0 + 1e-9);
            self.axis[i] = SegAxis {
                ab,
                l2: ab.norm_squared(),
                reach2: reach * reach,
            };
            glo = glo.inf(&lo);
            ghi = ghi.sup(&hi);
            size += (hi - lo).max();
        }
        // Cells about the mean box size, fewer if the grid would be too large.
        let ext = (ghi - glo).add_scalar(1e-9);
        let mut cell = (size / n as f64).max(1e-4);
        let dims = |c: f64| ext.map(|e| ((e / c).ceil() as usize).max(1));
        while dims(cell).iter().product::<usize>() > MAX_CELLS {
            cell *= 1.5;
        }
        let dm = dims(cell);
        let ncells = dm.iter().product::<usize>();
        let cell_of = |x: &Vector3<f64>| -> [u32; 3] {
            std::array::from_fn(|k| {
                (((x[k] - glo[k]) / cell).floor().max(0.0) as usize).min(dm[k] - 1) as u32
            })
        };
        let index = |c: [u32; 3]| (c[0] as usize * dm[1] + c[1] as usize) * dm[2] + c[2] as usize;
        // Counting sort of the segments into the cells their boxes cover.
        self.cell_start.clear();
        self.cell_start.resize(ncells + 1, 0);
        for i in 0..n {
            let (a, b) = (cell_of(&self.lo[i]), cell_of(&self.hi[i]));
            self.cell_lo[i] = a;
            self.cell_hi[i] = b;
            for_cells(a, b, |c| self.cell_start[index(c) + 1] += 1);
        }
        for c in 0..ncells {
            self.cell_start[c + 1] += self.cell_start[c];
        }
        let total = self.cell_start[ncells] as usize;
        self.items.clear();
        self.items.resize(total, 0);
        {
            let (starts, items) = (&mut self.cell_start, &mut self.items);
            for i in 0..n {
                for_cells(self.cell_lo[i], self.cell_hi[i], |c| {
                    let at = &mut starts[index(c)];
                    items[*at as usize] = i as u32;
                    *at += 1;
                });
            }
            // The fill advanced every start by its count: shift back.
            for c in (1..=ncells).rev() {
                starts[c] = starts[c - 1];
            }
            starts[0] = 0;
        }
        self.mailbox.iter_mut().for_each(|m| *m = u32::MAX);
        for i in 0..n {
            let (a, b) = (self.cell_lo[i], self.cell_hi[i]);
            let mut c = a;
            loop {
                let ci = index(c);
                for k in self.cell_start[ci]..self.cell_start[ci + 1] {
                    let j = self.items[k as usize] as usize;
                    if j <= i || self.mailbox[j] == i as u32 {
                        continue;
                    }
                    self.mailbox[j] = i as u32;
                    self.test_pair(w, i, j);
                }
                if !next_cell(&mut c, a, b) {
                    break;
                }
            }
        }
    }

    fn test_pair(&mut self, w: &Wisps, i: usize, j: usize) {
        let (pa, pb) = (self.segs[i] as usize, self.segs[j] as usize);
        if w.wisp_of[pa] == w.wisp_of[pb] && pb <= pa + 1 {
            return; // adjacent segments share a section
        }
        let (li, hi, lj, hj) = (&self.lo[i], &self.hi[i], &self.lo[j], &self.hi[j]);
        if (0..3).any(|k| li[k] > hj[k] || lj[k] > hi[k]) {
            return;
        }
        self.pairs_tested += 1;
        let first = self.contacts.len() as u32;
        for (own, other, oi) in [(pa, pb, j), (pb, pa, i)] {
            let q = own + 1;
            let ax = self.axis[oi];
            if !section_may_enter(w, q, other, &ax) {
                continue;
            }
            for which in 0..=ENV {
                let x = if which == ENV {
                    w.pos[q]
                } else {
                    self.env[q][which]
                };
                if let Some(s) = inside_axis(w, other, &ax, &x) {
                    self.contacts.push(Contact {
                        point: q as u32,
                        which: which as u8,
                        seg: other as u32,
                        s,
                    });
                }
            }
        }
        let end = self.contacts.len() as u32;
        if end > first {
            self.pairs.push(PairContacts {
                a: pa as u32,
                b: pb as u32,
                first,
                end,
            });
        }
    }
}

/// Whether `x` is inside the volume of segment `p → p + 1`: between its two section planes and
/// within the envelope radius (interpolated along the axis, per quadrant of each section)
/// around the axis. Returns the axis parameter.
pub fn inside_segment(w: &Wisps, p: usize, x: &Vector3<f64>) -> Option<f64> {
    let (a, b) = (w.pos[p], w.pos[p + 1]);
    if (x - a).dot(&w.t[p]) < 0.0 || (x - b).dot(&w.t[p + 1]) > 0.0 {
        return None;
    }
    let ab = b - a;
    let l2 = ab.norm_squared();
    let s = if l2 > 0.0 {
        ((x - a).dot(&ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let r = x - (a + ab * s);
    let d = r.norm();
    let radius = (1.0 - s) * section_radius(w, p, &r) + s * section_radius(w, p + 1, &r);
    (d < radius).then_some(s)
}

/// Whether any of the 5 points of section `q` (within its largest radius of its skeleton
/// point) can be inside segment `p`'s volume: its skeleton point is within the two reaches of
/// the segment's axis. A conservative bound, with a margin for rounding.
#[inline]
fn section_may_enter(w: &Wisps, q: usize, p: usize, ax: &SegAxis) -> bool {
    let x = w.pos[q];
    let a = w.pos[p];
    let s = if ax.l2 > 0.0 {
        ((x - a).dot(&ax.ab) / ax.l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d2 = (x - (a + ax.ab * s)).norm_squared();
    let own = w.rho[q * ENV..q * ENV + ENV]
        .iter()
        .fold(0.0f64, |m, &r| m.max(r))
        * (1.0 + 1e-9);
    let lim = ax.reach2.sqrt() + own + 1e-12;
    d2 <= lim * lim
}

/// [`inside_segment`] with the segment's axis computed once: the same arithmetic, and a point
/// farther from the axis than every envelope point of the two sections is out at once (the
/// ellipse quadrants never reach beyond their envelope points).
#[inline]
fn inside_axis(w: &Wisps, p: usize, ax: &SegAxis, x: &Vector3<f64>) -> Option<f64> {
    let (a, b) = (w.pos[p], w.pos[p + 1]);
    if (x - a).dot(&w.t[p]) < 0.0 || (x - b).dot(&w.t[p + 1]) > 0.0 {
        return None;
    }
    let s = if ax.l2 > 0.0 {
        ((x - a).dot(&ax.ab) / ax.l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let r = x - (a + ax.ab * s);
    let d2 = r.norm_squared();
    if d2 >= ax.reach2 {
        return None;
    }
    let d = d2.sqrt();
    let radius = (1.0 - s) * section_radius(w, p, &r) + s * section_radius(w, p + 1, &r);
    (d < radius).then_some(s)
}

/// Radius of section `p` in the direction of `r` (projected on the section plane): the ellipse
/// quadrant through the two envelope points around that direction.
pub fn section_radius(w: &Wisps, p: usize, r: &Vector3<f64>) -> f64 {
    let (x, y) = (r.dot(&w.u[p]), r.dot(&w.v[p]));
    let h = (x * x + y * y).sqrt();
    let rho = &w.rho[p * ENV..p * ENV + ENV];
    let rx = if x >= 0.0 { rho[0] } else { rho[2] };
    let ry = if y >= 0.0 { rho[1] } else { rho[3] };
    if h < 1e-12 {
        return rx.min(ry);
    }
    let (cx, cy) = (x / h, y / h);
    1.0 / ((cx / rx).powi(2) + (cy / ry).powi(2)).sqrt()
}

fn for_cells(a: [u32; 3], b: [u32; 3], mut f: impl FnMut([u32; 3])) {
    let mut c = a;
    loop {
        f(c);
        if !next_cell(&mut c, a, b) {
            break;
        }
    }
}

/// Advances `c` through the box `a..=b` (z fastest); false after the last cell.
fn next_cell(c: &mut [u32; 3], a: [u32; 3], b: [u32; 3]) -> bool {
    for k in (0..3).rev() {
        if c[k] < b[k] {
            c[k] += 1;
            return true;
        }
        c[k] = a[k];
    }
    false
}
