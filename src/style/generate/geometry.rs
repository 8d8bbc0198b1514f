//! The scalp geometry and the small vector and random-number helpers of generation: points,
//! normals and styling frames on the scalp ellipsoid, tile areas, root sampling, splines,
//! arc-length resampling and rotation-minimising frames (Zhang & Wünsche 2007, §3).

use super::super::Ellipsoid;
use super::{AREA_QUADRATURE, SPLINE_SUBSAMPLES, V3};

/// A tile of a region, radians: azimuth and elevation ranges.
pub(super) struct Tile {
    pub(super) az: (f64, f64),
    pub(super) el: (f64, f64),
}

/// The unit direction at azimuth `az` (from +z towards +x) and elevation `el`.
pub fn direction(az: f64, el: f64) -> V3 {
    [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()]
}

/// `Σ ((p − c)ᵢ / rᵢ)²`: 1 on the ellipsoid, < 1 inside.
pub fn implicit(e: &Ellipsoid, p: V3) -> f64 {
    (0..3)
        .map(|i| {
            let u = (p[i] - e.center[i]) / e.radii[i];
            u * u
        })
        .sum()
}

/// Distance from the centre to the ellipsoid along the unit direction `d`.
pub(super) fn ray_radius(e: &Ellipsoid, d: V3) -> f64 {
    1.0 / q(e, d).sqrt()
}

pub(super) fn q(e: &Ellipsoid, d: V3) -> f64 {
    (0..3).map(|i| (d[i] / e.radii[i]).powi(2)).sum()
}

/// The point of the scalp on the ray from its centre at azimuth `az`, elevation `el` (radians).
pub fn scalp_point(e: &Ellipsoid, az: f64, el: f64) -> V3 {
    let d = direction(az, el);
    add(e.center, scale(d, ray_radius(e, d)))
}

/// The outward unit normal of the ellipsoid at a point `p` on it (its gradient's direction).
pub fn scalp_normal(e: &Ellipsoid, p: V3) -> V3 {
    normalize([
        (p[0] - e.center[0]) / (e.radii[0] * e.radii[0]),
        (p[1] - e.center[1]) / (e.radii[1] * e.radii[1]),
        (p[2] - e.center[2]) / (e.radii[2] * e.radii[2]),
    ])
}

/// The styling frame of Zhang & Wünsche §3.1 at a scalp point.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// The point on the scalp.
    pub origin: V3,
    /// Down the scalp, towards decreasing elevation.
    pub t: V3,
    /// The scalp normal.
    pub n: V3,
    /// `t × n`.
    pub b: V3,
}

/// The styling frame at azimuth `az`, elevation `el` (radians). The tangent is −∂p/∂el: it
/// lies in the meridian plane, so it stays well defined at the crown (el = 90°), where it
/// points down towards `az`.
pub fn styling_frame(e: &Ellipsoid, az: f64, el: f64) -> Frame {
    let d = direction(az, el);
    let dd = [-el.sin() * az.sin(), el.cos(), -el.sin() * az.cos()];
    let qv = q(e, d);
    let dq: f64 = (0..3)
        .map(|i| 2.0 * d[i] * dd[i] / (e.radii[i] * e.radii[i]))
        .sum();
    let rho = qv.powf(-0.5);
    let drho = -0.5 * qv.powf(-1.5) * dq;
    let origin = add(e.center, scale(d, rho));
    let n = scalp_normal(e, origin);
    let dp = add(scale(d, drho), scale(dd, rho));
    let t0 = scale(dp, -1.0);
    let t = normalize(sub(t0, scale(n, dot(t0, n))));
    let b = cross(t, n);
    Frame { origin, t, n, b }
}

/// Scalp area per unit azimuth per unit elevation (radians) at `(az, el)`: for a surface
/// `ρ(d)·d` it is `ρ² cos el / (n̂·d)`.
pub(super) fn area_element(e: &Ellipsoid, az: f64, el: f64) -> f64 {
    let d = direction(az, el);
    let qv = q(e, d);
    let g = norm([
        d[0] / (e.radii[0] * e.radii[0]),
        d[1] / (e.radii[1] * e.radii[1]),
        d[2] / (e.radii[2] * e.radii[2]),
    ]);
    let n_dot_d = qv / g;
    (1.0 / qv) * el.cos().max(0.0) / n_dot_d
}

/// A tile's scalp area, m² (midpoint rule).
pub(super) fn tile_area(e: &Ellipsoid, t: &Tile) -> f64 {
    let m = AREA_QUADRATURE;
    let (ha, he) = ((t.az.1 - t.az.0) / m as f64, (t.el.1 - t.el.0) / m as f64);
    let mut sum = 0.0;
    for j in 0..m {
        let el = t.el.0 + (j as f64 + 0.5) * he;
        for i in 0..m {
            sum += area_element(e, t.az.0 + (i as f64 + 0.5) * ha, el);
        }
    }
    sum * ha * he
}

/// `count` roots spread evenly by area over a tile: the tile is cut into about `count` cells
/// of similar size, and points are placed by jittered systematic sampling along a serpentine
/// walk through the cells weighted by their areas (so every cell gets its share and
/// neighbouring roots do not clump), then uniformly by area inside their cell (rejection on the
/// area element).
pub(super) fn sample_roots(e: &Ellipsoid, t: &Tile, count: usize, rng: &mut SplitMix64) -> Vec<V3> {
    let (wa, we) = (t.az.1 - t.az.0, t.el.1 - t.el.0);
    let el_mid = 0.5 * (t.el.0 + t.el.1);
    // Metric sizes of the tile (the ratio is all that matters).
    let width = wa * el_mid.cos().abs().max(0.05);
    let ne = ((count as f64 * we / width).sqrt().round() as usize).clamp(1, count.max(1));
    let na = (count as f64 / ne as f64).round().max(1.0) as usize;
    let (ca, ce) = (wa / na as f64, we / ne as f64);
    // Serpentine order keeps consecutive cells adjacent.
    let mut cells = Vec::with_capacity(na * ne);
    let mut cum = Vec::with_capacity(na * ne);
    let mut total = 0.0;
    for j in 0..ne {
        for k in 0..na {
            let i = if j % 2 == 0 { k } else { na - 1 - k };
            let (a0, e0) = (t.az.0 + ca * i as f64, t.el.0 + ce * j as f64);
            total += area_element(e, a0 + 0.5 * ca, e0 + 0.5 * ce) * ca * ce;
            cells.push((a0, e0));
            cum.push(total);
        }
    }
    let mut roots = Vec::with_capacity(count);
    for k in 0..count {
        let target = (k as f64 + rng.next_f64()) / count as f64 * total;
        let c = cum.partition_point(|&x| x < target).min(cells.len() - 1);
        let (a0, e0) = cells[c];
        // Bound of the area element over the cell: it is smooth and the cell small, so the
        // largest corner/centre value with a margin bounds it.
        let mut bound = 0.0f64;
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)] {
            bound = bound.max(area_element(e, a0 + u * ca, e0 + v * ce));
        }
        bound *= 1.05;
        let (mut az, mut el) = (a0 + 0.5 * ca, e0 + 0.5 * ce);
        for _ in 0..64 {
            let (a, b) = (a0 + rng.next_f64() * ca, e0 + rng.next_f64() * ce);
            if rng.next_f64() * bound <= area_element(e, a, b) {
                (az, el) = (a, b);
                break;
            }
        }
        roots.push(scalp_point(e, az, el));
    }
    roots
}

/// A centripetal Catmull-Rom spline through `p` (at least 2 distinct consecutive points),
/// densely sampled. Centripetal parametrisation never forms cusps or self-intersections within
/// a segment, which uniform Catmull-Rom can with unevenly spaced control points.
pub fn catmull_rom(p: &[V3]) -> Vec<V3> {
    let m = p.len();
    // Phantom end points continue the first and last segment straight.
    let first = sub(scale(p[0], 2.0), p[1]);
    let last = sub(scale(p[m - 1], 2.0), p[m - 2]);
    let at = |i: isize| -> V3 {
        if i < 0 {
            first
        } else if i as usize >= m {
            last
        } else {
            p[i as usize]
        }
    };
    let mut out = Vec::with_capacity((m - 1) * SPLINE_SUBSAMPLES + 1);
    for seg in 0..m - 1 {
        let s = seg as isize;
        let (p0, p1, p2, p3) = (at(s - 1), at(s), at(s + 1), at(s + 2));
        let knot = |a: V3, b: V3| dist(a, b).sqrt().max(1e-12);
        let t0 = 0.0;
        let t1 = t0 + knot(p0, p1);
        let t2 = t1 + knot(p1, p2);
        let t3 = t2 + knot(p2, p3);
        for k in 0..SPLINE_SUBSAMPLES {
            let t = t1 + (t2 - t1) * k as f64 / SPLINE_SUBSAMPLES as f64;
            // Barry–Goldman pyramid.
            let lerp = |a: V3, b: V3, ta: f64, tb: f64| {
                add(
                    scale(a, (tb - t) / (tb - ta)),
                    scale(b, (t - ta) / (tb - ta)),
                )
            };
            let a1 = lerp(p0, p1, t0, t1);
            let a2 = lerp(p1, p2, t1, t2);
            let a3 = lerp(p2, p3, t2, t3);
            let b1 = lerp(a1, a2, t0, t2);
            let b2 = lerp(a2, a3, t1, t3);
            out.push(lerp(b1, b2, t1, t2));
        }
    }
    out.push(p[m - 1]);
    out
}

pub(super) fn polyline_length(p: &[V3]) -> f64 {
    p.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// `n` points uniformly spaced in arc length along the polyline `p`, ends included exactly.
pub(super) fn resample_uniform(p: &[V3], n: usize) -> Vec<V3> {
    let mut cum = Vec::with_capacity(p.len());
    cum.push(0.0);
    for w in p.windows(2) {
        let l = cum.last().copied().unwrap_or(0.0) + dist(w[0], w[1]);
        cum.push(l);
    }
    let total = *cum.last().expect("non-empty");
    let mut out = Vec::with_capacity(n);
    let mut seg = 0;
    for k in 0..n {
        if k == 0 {
            out.push(p[0]);
            continue;
        }
        if k == n - 1 {
            out.push(p[p.len() - 1]);
            continue;
        }
        let s = total * k as f64 / (n - 1) as f64;
        while seg + 2 < cum.len() && cum[seg + 1] < s {
            seg += 1;
        }
        let l = cum[seg + 1] - cum[seg];
        let u = if l > 0.0 { (s - cum[seg]) / l } else { 0.0 };
        out.push(add(p[seg], scale(sub(p[seg + 1], p[seg]), u)));
    }
    out
}

/// A rotation-minimising frame `(r, s)` (both ⟂ to the tangent) along a polyline, by the
/// double-reflection method of Wang, Jüttler, Zheng & Liu (2008). The first `r` is `hint`
/// (else `fallback`) made perpendicular to the first tangent.
pub(super) fn rotation_minimising_frame(x: &[V3], hint: V3, fallback: V3) -> (Vec<V3>, Vec<V3>) {
    let n = x.len();
    let tangent = |j: usize| -> V3 {
        let (a, b) = if j == 0 {
            (x[0], x[1])
        } else if j == n - 1 {
            (x[n - 2], x[n - 1])
        } else {
            (x[j - 1], x[j + 1])
        };
        normalize(sub(b, a))
    };
    let t0 = tangent(0);
    let perp = |v: V3| sub(v, scale(t0, dot(v, t0)));
    let r0 = if norm(perp(hint)) > 1e-6 {
        normalize(perp(hint))
    } else {
        normalize(perp(fallback))
    };
    let mut r = Vec::with_capacity(n);
    let mut s = Vec::with_capacity(n);
    r.push(r0);
    s.push(cross(t0, r0));
    let mut ti = t0;
    for j in 0..n - 1 {
        let tn = tangent(j + 1);
        let v1 = sub(x[j + 1], x[j]);
        let c1 = dot(v1, v1);
        let ri = r[j];
        let (rl, tl) = if c1 > 0.0 {
            (
                sub(ri, scale(v1, 2.0 / c1 * dot(v1, ri))),
                sub(ti, scale(v1, 2.0 / c1 * dot(v1, ti))),
            )
        } else {
            (ri, ti)
        };
        let v2 = sub(tn, tl);
        let c2 = dot(v2, v2);
        let rn = if c2 > 1e-24 {
            sub(rl, scale(v2, 2.0 / c2 * dot(v2, rl)))
        } else {
            rl
        };
        // Re-orthonormalise against round-off drift over many samples.
        let rn = normalize(sub(rn, scale(tn, dot(rn, tn))));
        s.push(cross(tn, rn));
        r.push(rn);
        ti = tn;
    }
    (r, s)
}

pub(super) fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, fast, and good enough for placing hair.
pub(super) struct SplitMix64(u64);

impl SplitMix64 {
    pub(super) fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }
    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        finalize(self.0)
    }
    /// Uniform in [0, 1).
    pub(super) fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

pub(super) fn finalize(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of one tile's stream: the style seed, the wisp (or copy) and the tile, hashed so
/// neighbouring ids give unrelated streams.
pub(super) fn mix(seed: u64, stream: u64, tile: u64) -> u64 {
    let a = finalize(seed ^ 0x5851_F42D_4C95_7F2D);
    let b = finalize(a ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    finalize(b ^ tile.wrapping_mul(0xD1B5_4A32_D192_ED03))
}

pub(super) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(super) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(super) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(super) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(super) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub(super) fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
pub(super) fn dist(a: V3, b: V3) -> f64 {
    norm(sub(a, b))
}
pub(super) fn normalize(a: V3) -> V3 {
    let l = norm(a);
    if l > 0.0 {
        scale(a, 1.0 / l)
    } else {
        a
    }
}
