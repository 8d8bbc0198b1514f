//! Generated hair after Zhang & Wünsche 2007 §3: wisps grown on scalp regions from key strands.
//!
//! Every [`Wisp`](crate::style::schema::Wisp) is cut into `tiles.0 × tiles.1` tiles of its
//! `(azimuth, elevation)` region; each tile becomes one top-level wisp of the [`RawHair`]. A tile's
//! strands are its key strand (a Catmull-Rom spline given in the styling frame at the tile's
//! centre) translated to each member root, plus an offset that grows linearly from zero at the root
//! to at most `tip_spread` at the tip, applied in a rotation-minimising frame of the key strand
//! (the paper's "torsion minimising reference frame"), plus an optional helix (curl).
//! With `fan_out`, each member is then turned about the scalp's vertical axis by its root's
//! azimuth from the tile centre, fading out along the strand, so that tiles meet at the crown.
//!
//! Everything random comes from a SplitMix64 stream seeded from `style.seed` and the wisp/tile
//! index, so the same style gives bit-identical strands and each tile's strands do not depend
//! on how many strands earlier tiles drew.

use super::{Curl, Ellipsoid, Generated, RawHair, RawStrand, Sphere, Style};
use std::f64::consts::TAU;

mod geometry;
pub mod wisp_study;

use geometry::*;
pub use geometry::{
    catmull_rom, direction, implicit, scalp_normal, scalp_point, styling_frame, Frame,
};

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
    let scalp = style.head.scalp();
    let spheres = style.head.spheres();
    let mut grower = Generator {
        seed: style.seed,
        scalp: &scalp,
        body: &spheres,
        samples: g.samples,
        fan_out: g.fan_out,
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
    fan_out: f64,
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
            // `fan_out`: the turn about the vertical axis that takes the tile centre's meridian
            // to the root's (the scalp is axis-aligned, so its vertical axis is y), wrapped to
            // (-π, π]: a tile never spans more than a turn.
            let turn = if self.fan_out > 0.0 {
                let d = sub(root, self.scalp.center);
                let da = d[0].atan2(d[2]) - az_c;
                da - TAU * (da / TAU).round()
            } else {
                0.0
            };
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
                if turn != 0.0 {
                    let a = turn * (1.0 - smoothstep(step * j as f64 / self.fan_out));
                    let (c, s) = (a.cos(), a.sin());
                    let r = sub(p, root);
                    p = add(root, [r[0] * c + r[2] * s, r[1], r[2] * c - r[0] * s]);
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
