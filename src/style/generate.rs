//! Generated hair after Zhang & Wünsche 2007 §3: wisps grown on scalp regions from key strands.
//!
//! Every [`Wisp`] is cut into `tiles.0 × tiles.1` tiles of its `(azimuth, elevation)` region;
//! each tile becomes one top-level wisp of the [`RawHair`]. A tile's strands are its key strand
//! (a Catmull-Rom spline given in the styling frame at the tile's centre) translated to each
//! member root, plus an offset that grows linearly from zero at the root to at most
//! `tip_spread` at the tip, applied in a rotation-minimising frame of the key strand (the
//! paper's "torsion minimising reference frame"), plus an optional helix (curl).
//!
//! Everything random comes from a SplitMix64 stream seeded from `style.seed` and the wisp/tile
//! index, so the same style gives bit-identical strands and each tile's strands do not depend
//! on how many strands earlier tiles drew.

use super::{Curl, Ellipsoid, Generated, RawHair, RawStrand, Sphere, Style};
use std::f64::consts::TAU;

type V3 = [f64; 3];
type Invalid = (String, String);

/// More strands than this is a typo in a density, not a hairstyle; refusing it early avoids
/// allocating gigabytes.
const MAX_STRANDS: usize = 2_000_000;
/// Likewise for the total number of generated points.
const MAX_POINTS: usize = 200_000_000;
/// How far a point found inside the scalp or a body sphere is put outside its surface, metres.
const CLEARANCE: f64 = 1e-3;
/// Dense points per Catmull-Rom segment before resampling uniformly in arc length.
const SPLINE_SUBSAMPLES: usize = 64;
/// Midpoint-rule resolution (per axis) for a tile's area.
const AREA_QUADRATURE: usize = 48;
/// Per-strand jitter of the curl phase, radians: small, so a tile's curls stay in step and
/// clump as one wisp, but not so identical that the members look like copies.
const CURL_PHASE_JITTER: f64 = 0.35;

/// Grows every wisp of a generated style. Errors name the offending field.
pub fn generate(style: &Style, g: &Generated) -> Result<RawHair, Invalid> {
    let min_per_tile = style
        .hierarchy
        .branching
        .iter()
        .try_fold(1usize, |acc, &b| acc.checked_mul(b.max(1)))
        .ok_or_else(|| {
            (
                "hierarchy.branching".to_string(),
                "the product of the branching factors overflows".to_string(),
            )
        })?;
    let mut grower = Generator {
        seed: style.seed,
        scalp: &style.head.scalp,
        body: &style.head.body,
        samples: g.samples,
        min_per_tile,
        hair: RawHair::default(),
        points: 0,
    };
    if g.samples < 2 {
        return Err((
            "hair.samples".into(),
            format!("needs at least 2 samples per strand, got {}", g.samples),
        ));
    }

    // Everything a copy may refer to, in declaration order (no map: deterministic, and the
    // lists are short).
    let mut entities: Vec<Entity> = Vec::with_capacity(g.wisps.len() + g.copies.len());
    for (n, w) in g.wisps.iter().enumerate() {
        let def = Def {
            azimuth: w.region.azimuth,
            elevation: w.region.elevation,
            tiles: w.tiles,
            key: w.key_strand.clone(),
            tip_spread: w.tip_spread,
            curl: w.curl.clone(),
            density: w.density.unwrap_or(g.density),
        };
        let field = format!("hair.wisps[{n}]");
        let tiles = grower.grow(&def, &w.name, n as u64, &field)?;
        entities.push(Entity {
            name: w.name.clone(),
            def,
            tiles,
        });
    }
    for (m, c) in g.copies.iter().enumerate() {
        let field = format!("hair.copies[{m}]");
        let Some(src) = entities.iter().position(|e| e.name == c.source) else {
            let known: Vec<&str> = entities.iter().map(|e| e.name.as_str()).collect();
            return Err((
                format!("{field}.source"),
                format!(
                    "there is no wisp or earlier copy named `{}` (known: {})",
                    c.source,
                    known.join(", ")
                ),
            ));
        };
        if entities.iter().any(|e| e.name == c.name) {
            return Err((
                format!("{field}.name"),
                format!("wisp name `{}` is used twice", c.name),
            ));
        }
        let entity = if c.mirror {
            grower.mirror(&entities[src], &c.name, &field)?
        } else {
            let mut def = entities[src].def.clone();
            def.azimuth = (
                def.azimuth.0 + c.azimuth_shift,
                def.azimuth.1 + c.azimuth_shift,
            );
            // A stream id past every wisp's, so a regrown copy never repeats its source's roots.
            let stream = (g.wisps.len() + m) as u64;
            let tiles = grower.grow(&def, &c.name, stream, &field)?;
            Entity {
                name: c.name.clone(),
                def,
                tiles,
            }
        };
        entities.push(entity);
    }
    Ok(grower.hair)
}

/// What a grid of tiles is grown from: a declared wisp, or the (shifted or mirrored) wisp a
/// copy stands for.
#[derive(Debug, Clone)]
struct Def {
    azimuth: (f64, f64),
    elevation: (f64, f64),
    tiles: (u32, u32),
    key: Vec<V3>,
    tip_spread: f64,
    curl: Option<Curl>,
    density: f64,
}

/// A named wisp or copy and the top-level wisps (tiles) it produced, with their name suffixes.
struct Entity {
    name: String,
    def: Def,
    tiles: Vec<(u32, String)>,
}

struct Generator<'a> {
    seed: u64,
    scalp: &'a Ellipsoid,
    body: &'a [Sphere],
    samples: usize,
    min_per_tile: usize,
    hair: RawHair,
    points: usize,
}

impl Generator<'_> {
    /// Grows all tiles of `def`, appending top-level wisps named `name[i,j]` (or `name` for a
    /// single tile). Returns the new top-level wisp ids with their suffixes.
    fn grow(
        &mut self,
        def: &Def,
        name: &str,
        stream: u64,
        field: &str,
    ) -> Result<Vec<(u32, String)>, Invalid> {
        let (ta, te) = def.tiles;
        let single = ta == 1 && te == 1;
        let da = (def.azimuth.1 - def.azimuth.0) / f64::from(ta);
        let de = (def.elevation.1 - def.elevation.0) / f64::from(te);
        let mut out = Vec::with_capacity((ta as usize) * (te as usize));
        for j in 0..te {
            for i in 0..ta {
                let tile = Tile {
                    az: (
                        (def.azimuth.0 + da * f64::from(i)).to_radians(),
                        (def.azimuth.0 + da * f64::from(i + 1)).to_radians(),
                    ),
                    el: (
                        (def.elevation.0 + de * f64::from(j)).to_radians(),
                        (def.elevation.0 + de * f64::from(j + 1)).to_radians(),
                    ),
                };
                let suffix = if single {
                    String::new()
                } else {
                    format!("[{i},{j}]")
                };
                let id = self.hair.wisp_names.len() as u32;
                self.hair.wisp_names.push(format!("{name}{suffix}"));
                let tile_index = u64::from(j) * u64::from(ta) + u64::from(i);
                let mut rng = SplitMix64::new(mix(self.seed, stream, tile_index));
                self.grow_tile(def, &tile, id, &mut rng, field)?;
                out.push((id, suffix));
            }
        }
        Ok(out)
    }

    fn grow_tile(
        &mut self,
        def: &Def,
        tile: &Tile,
        id: u32,
        rng: &mut SplitMix64,
        field: &str,
    ) -> Result<(), Invalid> {
        let area_cm2 = tile_area(self.scalp, tile) * 1e4;
        let wanted = (def.density * area_cm2).round();
        let count = if wanted.is_finite() && wanted < MAX_STRANDS as f64 {
            (wanted as usize).max(self.min_per_tile)
        } else {
            usize::MAX
        };
        let strands_after = self.hair.strands.len().saturating_add(count);
        if strands_after > MAX_STRANDS {
            return Err((
                format!("{field}.density"),
                format!(
                    "the style would generate more than {MAX_STRANDS} strands; lower the density"
                ),
            ));
        }
        let points_after = count
            .saturating_mul(self.samples)
            .saturating_add(self.points);
        if points_after > MAX_POINTS {
            return Err((
                "hair.samples".into(),
                format!(
                    "the style would generate more than {MAX_POINTS} points; lower samples or density"
                ),
            ));
        }
        self.points = points_after;

        let roots = sample_roots(self.scalp, tile, count, rng);

        // The key strand lives in the styling frame at the tile's centre.
        let (az_c, el_c) = (0.5 * (tile.az.0 + tile.az.1), 0.5 * (tile.el.0 + tile.el.1));
        let frame = styling_frame(self.scalp, az_c, el_c);
        let centre = frame.origin;
        let mut control = Vec::with_capacity(def.key.len() + 1);
        control.push(centre);
        for c in &def.key {
            let p = add(
                centre,
                add(
                    add(scale(frame.t, c[0]), scale(frame.n, c[1])),
                    scale(frame.b, c[2]),
                ),
            );
            // Repeated control points carry no shape and would make a zero-length segment.
            if dist(p, *control.last().expect("root pushed")) > 1e-12 {
                control.push(p);
            }
        }
        if control.len() < 2 {
            return Err((
                format!("{field}.key_strand"),
                "the key strand has zero length (every control point is at the root)".into(),
            ));
        }
        let key = resample_uniform(&catmull_rom(&control), self.samples);
        let length = polyline_length(&key);
        let (rmf_r, rmf_s) = rotation_minimising_frame(&key, frame.b, frame.n);
        let step = length / (self.samples - 1) as f64;

        let phase = rng.next_f64() * TAU;
        let ramp = (0.25 * length).min(0.03);
        for root in roots {
            let offset = sub(root, centre);
            let rho = def.tip_spread * rng.next_f64().sqrt();
            let ang = rng.next_f64() * TAU;
            let (o1, o2) = (rho * ang.cos(), rho * ang.sin());
            let jitter = (2.0 * rng.next_f64() - 1.0) * CURL_PHASE_JITTER;
            let mut points = Vec::with_capacity(self.samples);
            points.push(root);
            for j in 1..self.samples {
                let f = j as f64 / (self.samples - 1) as f64;
                let mut p = add(
                    add(key[j], offset),
                    add(scale(rmf_r[j], f * o1), scale(rmf_s[j], f * o2)),
                );
                if let Some(curl) = &def.curl {
                    let s = step * j as f64;
                    // The helix fades in from the root so the root stays on the scalp.
                    let a = curl.radius * smoothstep(s / ramp);
                    let phi = phase + jitter + TAU * curl.turns_per_metre * s;
                    p = add(
                        p,
                        add(
                            scale(rmf_r[j], a * phi.cos()),
                            scale(rmf_s[j], a * phi.sin()),
                        ),
                    );
                }
                points.push(p);
            }
            self.push_out(&mut points);
            self.hair.strands.push(RawStrand { wisp: id, points });
        }
        Ok(())
    }

    /// Appends the exact mirror image (x ↦ 2·cx − x) of every tile of `src`.
    fn mirror(&mut self, src: &Entity, name: &str, field: &str) -> Result<Entity, Invalid> {
        let cx = self.scalp.center[0];
        let mut tiles = Vec::with_capacity(src.tiles.len());
        for (src_id, suffix) in &src.tiles {
            let id = self.hair.wisp_names.len() as u32;
            self.hair.wisp_names.push(format!("{name}{suffix}"));
            // Strands of one top-level wisp are contiguous (grown tile by tile), but a scan keeps
            // this correct whatever the order.
            let mirrored: Vec<RawStrand> = self
                .hair
                .strands
                .iter()
                .filter(|s| s.wisp == *src_id)
                .map(|s| RawStrand {
                    wisp: id,
                    points: s
                        .points
                        .iter()
                        .map(|p| [2.0 * cx - p[0], p[1], p[2]])
                        .collect(),
                })
                .collect();
            let n_points: usize = mirrored.iter().map(|s| s.points.len()).sum();
            if self.hair.strands.len() + mirrored.len() > MAX_STRANDS
                || self.points + n_points > MAX_POINTS
            {
                return Err((
                    format!("{field}.source"),
                    "mirroring this wisp would exceed the strand limit".into(),
                ));
            }
            self.points += n_points;
            for mut s in mirrored {
                // A no-op for a left–right symmetric body (the source is already outside it);
                // for an asymmetric one, no hair may end up inside the body.
                self.push_out(&mut s.points);
                self.hair.strands.push(s);
            }
            tiles.push((id, suffix.clone()));
        }
        let d = &src.def;
        let def = Def {
            azimuth: (-d.azimuth.1, -d.azimuth.0),
            elevation: d.elevation,
            tiles: d.tiles,
            // A reflection reverses handedness: the mirrored frame's binormal (t × n) is minus
            // the mirror of the source's, so the binormal component changes sign.
            key: d.key.iter().map(|c| [c[0], c[1], -c[2]]).collect(),
            tip_spread: d.tip_spread,
            curl: d.curl.clone(),
            density: d.density,
        };
        Ok(Entity {
            name: name.to_string(),
            def,
            tiles,
        })
    }

    /// Moves every point but the root out of the scalp ellipsoid and the body spheres (to
    /// 1 mm outside their surface). Overlapping obstacles can push a point into one another,
    /// so this repeats a few times.
    fn push_out(&self, points: &mut [V3]) {
        for p in points.iter_mut().skip(1) {
            for _ in 0..8 {
                let mut moved = false;
                let c = self.scalp.center;
                let d = sub(*p, c);
                if implicit(self.scalp, *p) < 1.0 {
                    let len = norm(d);
                    let dir = if len > 1e-12 {
                        scale(d, 1.0 / len)
                    } else {
                        [0.0, 1.0, 0.0]
                    };
                    *p = add(c, scale(dir, ray_radius(self.scalp, dir) + CLEARANCE));
                    moved = true;
                }
                for s in self.body {
                    let d = sub(*p, s.center);
                    let len = norm(d);
                    if len < s.radius {
                        let dir = if len > 1e-12 {
                            scale(d, 1.0 / len)
                        } else {
                            [0.0, 1.0, 0.0]
                        };
                        *p = add(s.center, scale(dir, s.radius + CLEARANCE));
                        moved = true;
                    }
                }
                if !moved {
                    break;
                }
            }
        }
    }
}

/// A tile of a region, radians: azimuth and elevation ranges.
struct Tile {
    az: (f64, f64),
    el: (f64, f64),
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
fn ray_radius(e: &Ellipsoid, d: V3) -> f64 {
    1.0 / q(e, d).sqrt()
}

fn q(e: &Ellipsoid, d: V3) -> f64 {
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
fn area_element(e: &Ellipsoid, az: f64, el: f64) -> f64 {
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
fn tile_area(e: &Ellipsoid, t: &Tile) -> f64 {
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
fn sample_roots(e: &Ellipsoid, t: &Tile, count: usize, rng: &mut SplitMix64) -> Vec<V3> {
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
fn catmull_rom(p: &[V3]) -> Vec<V3> {
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

fn polyline_length(p: &[V3]) -> f64 {
    p.windows(2).map(|w| dist(w[0], w[1])).sum()
}

/// `n` points uniformly spaced in arc length along the polyline `p`, ends included exactly.
fn resample_uniform(p: &[V3], n: usize) -> Vec<V3> {
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
fn rotation_minimising_frame(x: &[V3], hint: V3, fallback: V3) -> (Vec<V3>, Vec<V3>) {
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

fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// SplitMix64 (Steele, Lea & Flood 2014): tiny, fast, and good enough for placing hair.
struct SplitMix64(u64);

impl SplitMix64 {
    fn new(seed: u64) -> Self {
        SplitMix64(seed)
    }
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        finalize(self.0)
    }
    /// Uniform in [0, 1).
    fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

fn finalize(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of one tile's stream: the style seed, the wisp (or copy) and the tile, hashed so
/// neighbouring ids give unrelated streams.
fn mix(seed: u64, stream: u64, tile: u64) -> u64 {
    let a = finalize(seed ^ 0x5851_F42D_4C95_7F2D);
    let b = finalize(a ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    finalize(b ^ tile.wrapping_mul(0xD1B5_4A32_D192_ED03))
}

fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}
fn dist(a: V3, b: V3) -> f64 {
    norm(sub(a, b))
}
fn normalize(a: V3) -> V3 {
    let l = norm(a);
    if l > 0.0 {
        scale(a, 1.0 / l)
    } else {
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head() -> Ellipsoid {
        Ellipsoid {
            center: [0.1, 1.6, -0.02],
            radii: [0.075, 0.095, 0.09],
        }
    }

    #[test]
    fn area_element_integrates_to_the_sphere_area() {
        let e = Ellipsoid {
            center: [0.0; 3],
            radii: [0.1; 3],
        };
        let t = Tile {
            az: (0.0, TAU),
            el: (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
        };
        let a = tile_area(&e, &t);
        let exact = 4.0 * std::f64::consts::PI * 0.01;
        assert!((a - exact).abs() / exact < 1e-3, "{a} vs {exact}");
    }

    #[test]
    fn area_element_matches_the_parametric_cross_product() {
        let e = head();
        for &(az, el) in &[(0.3, 0.2), (2.0, 1.2), (-1.0, -0.4), (3.0, 1.5)] {
            let h = 1e-6;
            let pa = sub(scalp_point(&e, az + h, el), scalp_point(&e, az - h, el));
            let pe = sub(scalp_point(&e, az, el + h), scalp_point(&e, az, el - h));
            let numeric = norm(cross(pa, pe)) / (4.0 * h * h);
            let analytic = area_element(&e, az, el);
            assert!((numeric - analytic).abs() < 1e-6 * analytic.max(1e-3));
        }
    }

    #[test]
    fn styling_frame_is_orthonormal_and_points_down_the_scalp() {
        let e = head();
        for &(az, el) in &[
            (0.3, 0.2),
            (2.0, 1.2),
            (-1.0, -0.4),
            (1.0, std::f64::consts::FRAC_PI_2),
        ] {
            let f = styling_frame(&e, az, el);
            assert!((implicit(&e, f.origin) - 1.0).abs() < 1e-12);
            for (a, b) in [(f.t, f.n), (f.t, f.b), (f.n, f.b)] {
                assert!(dot(a, b).abs() < 1e-12);
            }
            assert!((norm(f.b) - 1.0).abs() < 1e-12);
            // Moving along t lowers the elevation.
            let p = add(f.origin, scale(f.t, 1e-4));
            let d = sub(p, e.center);
            let el2 = (d[1] / norm(d)).asin();
            assert!(el2 < el, "t must point towards lower elevation");
        }
    }

    #[test]
    fn rmf_is_orthonormal_and_does_not_twist_on_a_straight_line() {
        let x: Vec<V3> = (0..20).map(|i| [0.0, -0.01 * i as f64, 0.0]).collect();
        let (r, s) = rotation_minimising_frame(&x, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        for j in 0..20 {
            assert!((r[j][0] - 1.0).abs() < 1e-12);
            assert!(dot(r[j], s[j]).abs() < 1e-12);
        }
    }

    #[test]
    fn resampling_is_uniform_in_arc_length() {
        let p = catmull_rom(&[
            [0.0; 3],
            [0.1, 0.0, 0.0],
            [0.1, -0.2, 0.0],
            [0.3, -0.3, 0.1],
        ]);
        let q = resample_uniform(&p, 40);
        let d: Vec<f64> = q.windows(2).map(|w| dist(w[0], w[1])).collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        for x in d {
            // Chords of a curved spline are a hair shorter than their arcs.
            assert!((x - mean).abs() < 0.02 * mean);
        }
        assert_eq!(q[0], [0.0; 3]);
        assert_eq!(q[39], [0.3, -0.3, 0.1]);
    }

    #[test]
    fn catmull_rom_interpolates_its_control_points() {
        let c = [
            [0.0; 3],
            [0.1, 0.0, 0.0],
            [0.1, -0.2, 0.0],
            [0.3, -0.3, 0.1],
        ];
        let p = catmull_rom(&c);
        for (k, cp) in c.iter().enumerate() {
            assert!(dist(p[k * SPLINE_SUBSAMPLES], *cp) < 1e-12);
        }
    }
}
