//! The edits themselves, on the `Generated` section of a style copy: each checks its input
//! and says why it refuses (the caller then drops the copy, so nothing changes).

use serde::Serialize;

use super::frames::{self, local_frame, to_styling, to_world, under_scalp, wisp_frame};
use crate::style::{Ellipsoid, Generated, Region, Vec3, Wisp};

/// Wisps and copies a style may hold here (the shipped ones have 11): more is a runaway
/// script, not a hairstyle.
pub const MAX_WISPS: usize = 256;
/// A key strand's control point lies at most this far from its root, m.
const MAX_REACH: f64 = 2.0;
/// One move goes at most this far, m.
const MAX_STEP: f64 = 0.5;
/// Points checked along a move's path.
const PATH_CHECKS: usize = 32;
/// A new wisp's region: half-widths in azimuth and elevation, degrees.
const NEW_RADIUS: [f64; 2] = [10.0, 8.0];

/// A wisp of the list, as the page shows it.
#[derive(Debug, Clone, Serialize)]
pub struct WispView {
    /// Its name.
    pub name: String,
    /// For a copy: the wisp it copies (it has no key strand of its own).
    pub copy_of: Option<String>,
    /// A mirrored copy.
    pub mirror: bool,
    /// The region, degrees.
    pub azimuth: (f64, f64),
    /// See `azimuth`.
    pub elevation: (f64, f64),
    /// Tiles of the region.
    pub tiles: (u32, u32),
    /// Strands per cm² in force.
    pub density: f64,
    /// Largest tip distance from the key strand, m (smooth ↔ fringy).
    pub tip_spread: f64,
    /// Curled.
    pub curl: bool,
    /// The key strand's control points in the styling frame at the root (without the root).
    pub key_strand: Vec<Vec3>,
    /// The control points in the world, root first (at rest).
    pub world: Vec<Vec3>,
    /// The local frame at each of them, root first: tangent, normal, perpendicular (§3.1).
    pub frames: Vec<[Vec3; 3]>,
}

/// What the logger draws for the Style panel (world coordinates at rest, f32 for Rerun).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Marks {
    /// Every wisp's key strand, in the list's order (clicking one in the view selects it).
    pub key_strands: Vec<Vec<[f32; 3]>>,
    /// The selected one.
    pub selected: Option<SelectedMarks>,
}

/// The selected key strand: its curve, control points and local frames.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectedMarks {
    /// The wisp's name.
    pub name: String,
    /// The spline.
    pub curve: Vec<[f32; 3]>,
    /// The control points, root first.
    pub points: Vec<[f32; 3]>,
    /// The local frame's axes at each point (unit vectors).
    pub frames: Vec<[[f32; 3]; 3]>,
}

/// Where a name is: a declared wisp or a copy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Entry {
    /// `wisps[i]`.
    Wisp(usize),
    /// `copies[i]`.
    Copy(usize),
}

/// The wisp or copy called `name`.
pub fn entry(g: &Generated, name: &str) -> Result<Entry, String> {
    if let Some(i) = g.wisps.iter().position(|w| w.name == name) {
        return Ok(Entry::Wisp(i));
    }
    if let Some(i) = g.copies.iter().position(|c| c.name == name) {
        return Ok(Entry::Copy(i));
    }
    let names: Vec<&str> = g
        .wisps
        .iter()
        .map(|w| w.name.as_str())
        .chain(g.copies.iter().map(|c| c.name.as_str()))
        .collect();
    Err(format!(
        "there is no wisp `{}` (the wisps: {})",
        name.chars().take(60).collect::<String>(),
        names.join(", ")
    ))
}

/// The wisp `name` stands for: a declared wisp, or the wisp a copy grows (its source's,
/// shifted or mirrored).
pub fn resolved(g: &Generated, name: &str) -> Result<Wisp, String> {
    resolve_depth(g, name, 0)
}

fn resolve_depth(g: &Generated, name: &str, depth: usize) -> Result<Wisp, String> {
    match entry(g, name)? {
        Entry::Wisp(i) => Ok(g.wisps[i].clone()),
        Entry::Copy(i) => {
            let c = &g.copies[i];
            if depth > g.copies.len() {
                return Err(format!("the copy `{name}` refers to itself"));
            }
            let mut w = resolve_depth(g, &c.source, depth + 1)?;
            w.name.clone_from(&c.name);
            if c.mirror {
                mirror_in_place(&mut w);
            } else {
                w.region.azimuth.0 += c.azimuth_shift;
                w.region.azimuth.1 += c.azimuth_shift;
            }
            Ok(w)
        }
    }
}

/// The declared wisp `name`, for an edit of its own values (a copy has none).
fn own<'a>(g: &'a mut Generated, name: &str) -> Result<&'a mut Wisp, String> {
    match entry(g, name)? {
        Entry::Wisp(i) => Ok(&mut g.wisps[i]),
        Entry::Copy(i) => {
            let c = &g.copies[i];
            Err(format!(
                "`{name}` is a {}copy of `{}` and has no key strand of its own: edit `{}`, \
                 or delete the copy",
                if c.mirror { "mirrored " } else { "" },
                c.source,
                c.source
            ))
        }
    }
}

fn finite(v: &[f64], what: &str) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what}: not a number"))
    }
}

/// Index of control point `point` (from 1) in `key_strand`.
fn point_index(w: &Wisp, point: usize) -> Result<usize, String> {
    if point == 0 {
        return Err(format!(
            "point 0 is the root of `{}`: it stays on the scalp (move the wisp's region instead)",
            w.name
        ));
    }
    if point > w.key_strand.len() {
        return Err(format!(
            "the key strand of `{}` has control points 1 to {}, not {point}",
            w.name,
            w.key_strand.len()
        ));
    }
    Ok(point - 1)
}

/// Sets point `point` of `w` to styling-frame `c`, refusing a point under the scalp or out of
/// reach.
fn place(w: &mut Wisp, scalp: &Ellipsoid, point: usize, c: Vec3) -> Result<(), String> {
    finite(&c, "the point")?;
    if c.iter().any(|x| x.abs() > MAX_REACH) {
        return Err(format!(
            "point {point} of `{}`: too large a value ({c:?}); a control point lies within \
             {MAX_REACH} m of its root",
            w.name
        ));
    }
    let world = to_world(&wisp_frame(scalp, w), c);
    if under_scalp(scalp, world) {
        return Err(format!(
            "point {point} of `{}` would be under the scalp: a key strand grows outside the head",
            w.name
        ));
    }
    w.key_strand[point - 1] = c;
    Ok(())
}

/// Moves a control point along its local frame (§3.1).
pub fn move_point(
    g: &mut Generated,
    scalp: &Ellipsoid,
    name: &str,
    point: usize,
    delta: Vec3,
) -> Result<String, String> {
    finite(&delta, "the move")?;
    if delta.iter().map(|d| d * d).sum::<f64>().sqrt() > MAX_STEP {
        return Err(format!(
            "too large a move ({delta:?} m); one move goes at most {MAX_STEP} m"
        ));
    }
    let w = own(g, name)?;
    point_index(w, point)?;
    let f = wisp_frame(scalp, w);
    let world = frames::world_points(scalp, w);
    let axes = local_frame(scalp, &world, point);
    let from = world[point];
    let step = |s: f64| -> Vec3 {
        let mut p = from;
        for (k, v) in p.iter_mut().enumerate() {
            *v += s * (delta[0] * axes[0][k] + delta[1] * axes[1][k] + delta[2] * axes[2][k]);
        }
        p
    };
    // A point dragged through the head and out the other side is as wrong as one left in it.
    if (1..PATH_CHECKS).any(|k| under_scalp(scalp, step(k as f64 / PATH_CHECKS as f64))) {
        return Err(format!(
            "point {point} of `{name}` would pass under the scalp: a key strand grows outside \
             the head"
        ));
    }
    place(w, scalp, point, to_styling(&f, step(1.0)))?;
    Ok(format!(
        "moved point {point} of `{name}` by ({:+.1}, {:+.1}, {:+.1}) mm along its tangent, normal and perpendicular",
        delta[0] * 1e3,
        delta[1] * 1e3,
        delta[2] * 1e3
    ))
}

/// Sets a control point to an exact styling-frame value.
pub fn set_point(
    g: &mut Generated,
    scalp: &Ellipsoid,
    name: &str,
    point: usize,
    value: Vec3,
) -> Result<String, String> {
    let w = own(g, name)?;
    point_index(w, point)?;
    place(w, scalp, point, value)?;
    Ok(format!("set point {point} of `{name}` to {value:?} m"))
}

/// A region of half-widths `r` (degrees) centred at `(az, el)`, inside the scalp's range.
fn region_at(az: f64, el: f64, r: [f64; 2]) -> Result<Region, String> {
    finite(&[az, el], "the scalp position")?;
    if az.abs() > 360.0 || el.abs() > 90.0 {
        return Err(format!(
            "({az}, {el}) is not a scalp position: azimuth -360..360, elevation -90..90 degrees"
        ));
    }
    Ok(Region {
        azimuth: (az - r[0], az + r[0]),
        elevation: ((el - r[1]).max(-90.0), (el + r[1]).min(90.0)),
    })
}

/// A name not yet taken: `base`, else `base2`, `base3`, …
fn fresh_name(g: &Generated, base: &str) -> String {
    let taken = |n: &str| entry(g, n).is_ok();
    if !taken(base) {
        return base.to_owned();
    }
    (2..)
        .map(|k| format!("{base}{k}"))
        .find(|n| !taken(n))
        .expect("some name is free")
}

fn room(g: &Generated) -> Result<(), String> {
    if g.wisps.len() + g.copies.len() >= MAX_WISPS {
        return Err(format!(
            "too large a style: at most {MAX_WISPS} wisps and copies are edited here"
        ));
    }
    Ok(())
}

/// Adds `w` at `(az, el)`, refusing a key strand under the scalp there.
fn add_at(
    g: &mut Generated,
    scalp: &Ellipsoid,
    mut w: Wisp,
    az: f64,
    el: f64,
    r: [f64; 2],
) -> Result<String, String> {
    room(g)?;
    w.region = region_at(az, el, r)?;
    for (k, p) in frames::world_points(scalp, &w).iter().enumerate().skip(1) {
        if under_scalp(scalp, *p) {
            return Err(format!(
                "at ({az}, {el}) point {k} of the key strand would be under the scalp"
            ));
        }
    }
    let name = w.name.clone();
    g.wisps.push(w);
    Ok(name)
}

/// A new wisp from the template key strand.
pub fn create(g: &mut Generated, scalp: &Ellipsoid, az: f64, el: f64) -> Result<String, String> {
    let w = Wisp {
        name: fresh_name(g, "wisp"),
        region: Region {
            azimuth: (0.0, 0.0),
            elevation: (0.0, 0.0),
        },
        tiles: (1, 1),
        key_strand: frames::TEMPLATE_KEY.to_vec(),
        tip_spread: 0.01,
        curl: None,
        density: None,
    };
    add_at(g, scalp, w, az, el, NEW_RADIUS)
}

/// The clipboard's wisp at a new root: same key strand in the new root's styling frame, same
/// region size, spread, curl and density.
pub fn paste(
    g: &mut Generated,
    scalp: &Ellipsoid,
    mut w: Wisp,
    az: f64,
    el: f64,
) -> Result<String, String> {
    let r = [
        0.5 * (w.region.azimuth.1 - w.region.azimuth.0).abs(),
        0.5 * (w.region.elevation.1 - w.region.elevation.0).abs(),
    ];
    w.name = fresh_name(g, &format!("{}_copy", w.name));
    add_at(g, scalp, w, az, el, r)
}

/// Deletes a wisp or copy that no copy refers to.
pub fn delete(g: &mut Generated, name: &str) -> Result<(), String> {
    let e = entry(g, name)?;
    if let Some(c) = g.copies.iter().find(|c| c.source == name) {
        return Err(format!(
            "the copy `{}` is made from `{name}`: delete it first",
            c.name
        ));
    }
    if g.wisps.len() == 1 && e == Entry::Wisp(0) {
        return Err("a style needs at least one wisp: create another first".to_owned());
    }
    match e {
        Entry::Wisp(i) => {
            g.wisps.remove(i);
        }
        Entry::Copy(i) => {
            g.copies.remove(i);
        }
    }
    Ok(())
}

fn mirror_in_place(w: &mut Wisp) {
    w.region.azimuth = (-w.region.azimuth.1, -w.region.azimuth.0);
    w.key_strand = frames::mirrored_key(&w.key_strand);
}

/// A new wisp, the mirror image of `name` (Fig. 6): `…left…` becomes `…right…` and back.
pub fn mirror(g: &mut Generated, name: &str) -> Result<String, String> {
    room(g)?;
    let mut w = resolved(g, name)?;
    mirror_in_place(&mut w);
    let base = if name.contains("left") {
        name.replace("left", "right")
    } else if name.contains("right") {
        name.replace("right", "left")
    } else {
        format!("{name}_mirror")
    };
    w.name = fresh_name(g, &base);
    let new = w.name.clone();
    g.wisps.push(w);
    Ok(new)
}

/// Changes a wisp's region size, density and spread (§3.2).
pub fn shape(
    g: &mut Generated,
    name: &str,
    radius: Option<[f64; 2]>,
    density: Option<f64>,
    tip_spread: Option<f64>,
) -> Result<(), String> {
    let w = own(g, name)?;
    if let Some(r) = radius {
        finite(&r, "radius")?;
        if r.iter().any(|x| !(0.5..=90.0).contains(x)) {
            return Err(format!("radius {r:?}: half-widths of 0.5 to 90 degrees"));
        }
        let az = 0.5 * (w.region.azimuth.0 + w.region.azimuth.1);
        let el = 0.5 * (w.region.elevation.0 + w.region.elevation.1);
        w.region = region_at(az, el, r)?;
    }
    if let Some(d) = density {
        if !d.is_finite() || d <= 0.0 || d > 500.0 {
            return Err(format!(
                "density {d}: between 0 and 500 strands per cm² (real hair has ~150)"
            ));
        }
        w.density = Some(d);
    }
    if let Some(s) = tip_spread {
        if !(0.0..=0.2).contains(&s) {
            return Err(format!("spread {s}: between 0 and 0.2 m"));
        }
        w.tip_spread = s;
    }
    Ok(())
}

/// The page's list.
pub fn views(g: &Generated, scalp: &Ellipsoid) -> Vec<WispView> {
    let names = g
        .wisps
        .iter()
        .map(|w| (w.name.as_str(), None))
        .chain(g.copies.iter().map(|c| (c.name.as_str(), Some(c))));
    names
        .filter_map(|(name, copy)| {
            let w = resolved(g, name).ok()?;
            let world = frames::world_points(scalp, &w);
            let frames = (0..world.len())
                .map(|i| local_frame(scalp, &world, i))
                .collect();
            Some(WispView {
                name: name.to_owned(),
                copy_of: copy.map(|c| c.source.clone()),
                mirror: copy.is_some_and(|c| c.mirror),
                azimuth: w.region.azimuth,
                elevation: w.region.elevation,
                tiles: w.tiles,
                density: w.density.unwrap_or(g.density),
                tip_spread: w.tip_spread,
                curl: w.curl.is_some(),
                key_strand: w.key_strand,
                world,
                frames,
            })
        })
        .collect()
}

fn f32s(p: Vec3) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, p[2] as f32]
}

/// What the logger draws (see [`Marks`]).
pub fn marks(g: &Generated, scalp: &Ellipsoid, selected: Option<&str>) -> Marks {
    let all: Vec<&str> = g
        .wisps
        .iter()
        .map(|w| w.name.as_str())
        .chain(g.copies.iter().map(|c| c.name.as_str()))
        .collect();
    let curve = |w: &Wisp| -> Vec<[f32; 3]> {
        frames::world_curve(scalp, w)
            .into_iter()
            .map(f32s)
            .collect()
    };
    let key_strands = all
        .iter()
        .map(|n| resolved(g, n).map(|w| curve(&w)).unwrap_or_default())
        .collect();
    let selected = selected.and_then(|n| resolved(g, n).ok()).map(|w| {
        let world = frames::world_points(scalp, &w);
        SelectedMarks {
            name: w.name.clone(),
            curve: curve(&w),
            points: world.iter().map(|p| f32s(*p)).collect(),
            frames: (0..world.len())
                .map(|i| local_frame(scalp, &world, i).map(f32s))
                .collect(),
        }
    });
    Marks {
        key_strands,
        selected,
    }
}
