//! Hairstyle files: parsing, validation, and turning a style into raw strands.
//!
//! `load` reads and validates a `.ron` file; `LoadedStyle::strands` generates (Zhang & Wünsche 2007, §3) or
//! imports (TressFX `.tfx`, Cem Yuksel `.hair`, USC-HairSalon `.data`) the strands that the
//! multiresolution model (`crate::model`) is built from.

pub mod body;
pub mod builtin;
pub mod edit;
pub mod generate;
pub mod generated_section;
pub mod guides_section;
pub mod hair_file;
pub mod hairsalon;
pub mod import;
pub mod layered_section;
pub mod obj;
pub mod render_params;
pub mod scalp;
pub mod schema;
pub mod tfx;
pub mod tfx_write;

use std::path::{Path, PathBuf};

pub use guides_section::{GuideParams, MovingSphere, PathKey, StripLayout};
pub use layered_section::LayeredParams;
pub use render_params::RenderParams;
pub use schema::*;

/// Anything wrong with a style or the files it refers to. Every message names the file, the
/// position where there is one, and the field.
#[derive(Debug, thiserror::Error)]
pub enum StyleError {
    /// (The I/O error is part of the message, not a `source`: an error chain printed with
    /// `{:#}` would say it twice.)
    #[error("{path}: cannot read: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why it cannot be read.
        error: std::io::Error,
    },
    #[error("{path}: no such file (and not a built-in style: {builtins})")]
    /// A style path that is neither a file nor a built-in name.
    Missing {
        /// The path given.
        path: PathBuf,
        /// The built-in names.
        builtins: String,
    },
    #[error("{path}: the file is empty")]
    /// An empty file.
    Empty {
        /// The file.
        path: PathBuf,
    },
    #[error("{path}:{line}:{col}: {msg}")]
    /// Not valid RON.
    Parse {
        /// The file.
        path: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        col: usize,
        /// What is wrong.
        msg: String,
    },
    #[error("{path}{}: field `{field}`: {msg}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    /// A value out of range.
    Invalid {
        /// The file.
        path: PathBuf,
        /// The line of the field, where it can be found.
        line: Option<usize>,
        /// The field, as a dotted path.
        field: String,
        /// What is wrong.
        msg: String,
    },
    #[error("{path}: {msg}")]
    /// A TressFX file that cannot be read.
    Tfx {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// A corrupt `.hair` or `.data` strand file; the message names the byte offset.
    #[error("{path}: {msg}")]
    StrandFile {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the byte offset.
        msg: String,
    },
}

/// A parsed, validated style and where it came from (relative paths inside it are resolved
/// against the style file's folder).
#[derive(Debug, Clone)]
pub struct LoadedStyle {
    /// The file (or `<built-in style NAME>`).
    pub path: PathBuf,
    /// The style.
    pub style: Style,
    /// Collision spheres after resolving `TressFx.project`, if any (else the spheres of
    /// `style.head.body`).
    pub body: Vec<Sphere>,
    /// The scalp in force: `head.scalp`, else on the fitted head (`fit_body`), else the default.
    pub scalp: Ellipsoid,
    /// The capsules and meshes of `style.head.body`, meshes read from their files.
    pub shapes: Vec<body::Shape>,
}

/// One strand before resampling: its top-level wisp and its polyline, root first.
#[derive(Debug, Clone, PartialEq)]
pub struct RawStrand {
    /// Index of its top-level wisp in `RawHair::wisp_names`.
    pub wisp: u32,
    /// Points, root first, m.
    pub points: Vec<[f64; 3]>,
}

/// All strands of a style, grouped into named top-level wisps. For imported hair the wisps are
/// not known yet (`wisp_names` is empty and every `wisp` is 0): the model clusters them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RawHair {
    /// Names of the top-level wisps.
    pub wisp_names: Vec<String>,
    /// The strands.
    pub strands: Vec<RawStrand>,
    /// What the user should be told about the import (strands skipped, and why).
    pub notes: Vec<String>,
}

/// Reads, parses and validates a style file.
pub fn load(path: &Path) -> Result<LoadedStyle, StyleError> {
    let text = std::fs::read_to_string(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse(path, &text)
}

/// Parses and validates style text; `path` names it in errors and anchors relative paths.
pub fn parse(path: &Path, text: &str) -> Result<LoadedStyle, StyleError> {
    if text.trim().is_empty() {
        return Err(StyleError::Empty {
            path: path.to_path_buf(),
        });
    }
    let style: Style =
        ron::Options::default()
            .from_str(text)
            .map_err(|e: ron::error::SpannedError| StyleError::Parse {
                path: path.to_path_buf(),
                line: e.span.start.line,
                col: e.span.start.col,
                msg: e.code.to_string(),
            })?;
    let invalid = |field: &str, msg: String| StyleError::Invalid {
        path: path.to_path_buf(),
        line: line_of_field(text, field),
        field: field.to_string(),
        msg,
    };
    validate(&style).map_err(|(field, msg)| invalid(&field, msg))?;
    let body = match &style.hair {
        Hair::TressFx(t) => match &t.project {
            Some(p) => {
                let proj = resolve(path, p);
                tfx::load_project_spheres(&proj, t.scale, t.translate)?
            }
            None => style.head.spheres(),
        },
        Hair::Generated(_) | Hair::HairFile(_) | Hair::HairSalon(_) | Hair::Explicit(_) => {
            style.head.spheres()
        }
    };
    let scalp = style.head.scalp();
    let shapes = body::load_shapes(path, &style.head.body)?;
    let mut loaded = LoadedStyle {
        path: path.to_path_buf(),
        style,
        body,
        scalp,
        shapes,
    };
    if loaded.style.head.fit_body {
        // The roots are only known once the strands are read (a second read, when the model is
        // built: styles stay plain data, with no strands cached in them).
        let roots: Vec<[f64; 3]> = loaded
            .strands()?
            .strands
            .iter()
            .filter_map(|s| s.points.first().copied())
            .collect();
        let sphere =
            import::fit_head_sphere(&roots).map_err(|msg| invalid("head.fit_body", msg))?;
        if loaded.style.head.scalp.is_none() {
            loaded.scalp = scalp::fitted_scalp(&sphere);
        }
        loaded.body = vec![sphere];
    }
    Ok(loaded)
}

/// Resolves a path written in a style file against the style file's folder.
pub fn resolve(style_path: &Path, rel: &str) -> PathBuf {
    let rel = Path::new(rel);
    if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        style_path
            .parent()
            .unwrap_or_else(|| Path::new("."))
            .join(rel)
    }
}

impl LoadedStyle {
    /// Generates or imports the strands.
    pub fn strands(&self) -> Result<RawHair, StyleError> {
        match &self.style.hair {
            Hair::Generated(g) => {
                generate::generate(&self.style, g).map_err(|(field, msg)| StyleError::Invalid {
                    path: self.path.clone(),
                    line: None,
                    field,
                    msg,
                })
            }
            Hair::TressFx(t) => {
                let mut hair = RawHair::default();
                for f in &t.files {
                    let p = resolve(&self.path, f);
                    let strands = tfx::load_tfx(&p)?;
                    for s in strands {
                        let points = s
                            .iter()
                            .map(|v| {
                                [
                                    v[0] * t.scale + t.translate[0],
                                    v[1] * t.scale + t.translate[1],
                                    v[2] * t.scale + t.translate[2],
                                ]
                            })
                            .collect();
                        hair.strands.push(RawStrand { wisp: 0, points });
                    }
                }
                Ok(hair)
            }
            Hair::HairFile(f) => {
                let file = hair_file::load_hair(&resolve(&self.path, &f.file))?;
                let mut hair = RawHair::default();
                let skipped = import::append_strands(f, &file.strands, &mut hair);
                if skipped > 0 {
                    hair.notes.push(format!(
                        "{}: skipped {skipped} one-point strand(s) of {} (a strand needs a root \
                         and a tip)",
                        f.file,
                        file.strands.len()
                    ));
                }
                Ok(hair)
            }
            Hair::HairSalon(f) => {
                let file = hairsalon::load_hairsalon(&resolve(&self.path, &f.file))?;
                let mut hair = RawHair::default();
                import::append_strands(f, &file.strands, &mut hair);
                if file.skipped_one_point > 0 {
                    hair.notes.push(format!(
                        "{}: skipped {} one-point strand(s) (roots with no hair) of {}",
                        f.file,
                        file.skipped_one_point,
                        file.skipped_one_point + file.strands.len()
                    ));
                }
                Ok(hair)
            }
            Hair::Explicit(e) => Ok(explicit_hair(e)),
        }
    }
}

/// The strands of explicitly given hair, one top-level wisp per given wisp.
fn explicit_hair(e: &Explicit) -> RawHair {
    let mut hair = RawHair::default();
    for (n, w) in e.wisps.iter().enumerate() {
        hair.wisp_names.push(if w.name.is_empty() {
            format!("wisp {n}")
        } else {
            w.name.clone()
        });
        for st in &w.strands {
            hair.strands.push(RawStrand {
                wisp: n as u32,
                points: st.clone(),
            });
        }
    }
    hair
}

/// Best-effort line number of the first `leaf:` of a dotted field path in the text.
/// The error for `field` of the style at `path` (its text, if at hand, gives the line): for
/// the checks that the layers above make of a loaded style (the solvers' sections).
pub fn field_error(path: &Path, text: Option<&str>, field: &str, msg: String) -> StyleError {
    StyleError::Invalid {
        path: path.to_path_buf(),
        line: text.and_then(|t| line_of_field(t, field)),
        field: field.to_string(),
        msg,
    }
}

fn line_of_field(text: &str, field: &str) -> Option<usize> {
    let leaf = field
        .rsplit('.')
        .next()?
        .split('[')
        .next()
        .unwrap_or_default();
    if leaf.is_empty() {
        return None;
    }
    text.lines().enumerate().find_map(|(n, line)| {
        // `leaf` as a whole word followed by `:` anywhere on the line (fields are often inline).
        let found = line.match_indices(leaf).any(|(at, _)| {
            let before_ok = line[..at]
                .chars()
                .next_back()
                .is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
            before_ok && line[at + leaf.len()..].trim_start().starts_with(':')
        });
        found.then_some(n + 1)
    })
}

type Invalid = (String, String);

fn check(ok: bool, field: &str, msg: impl FnOnce() -> String) -> Result<(), Invalid> {
    if ok {
        Ok(())
    } else {
        Err((field.to_string(), msg()))
    }
}

fn positive(v: f64, field: &str) -> Result<(), Invalid> {
    check(v.is_finite() && v > 0.0, field, || {
        format!("must be a positive number, got {v:?}")
    })
}

fn non_negative(v: f64, field: &str) -> Result<(), Invalid> {
    check(v.is_finite() && v >= 0.0, field, || {
        format!("must be zero or positive, got {v:?}")
    })
}

fn finite3(v: &Vec3, field: &str) -> Result<(), Invalid> {
    check(v.iter().all(|x| x.is_finite()), field, || {
        format!("must be finite, got {v:?}")
    })
}

/// A key strand's points are offsets from its root: more than this many metres is a typo.
pub const MAX_KEY_OFFSET: f64 = 10.0;
/// Tiles of one wisp: each becomes a top-level wisp. The shipped styles use at most 4; a count
/// in the thousands is a typo that would take minutes to simulate.
pub const MAX_TILES_PER_WISP: u64 = 256;

/// Checks every value a style may get wrong; returns the dotted field path and the reason.
pub fn validate(style: &Style) -> Result<(), Invalid> {
    validate_head(style)?;
    validate_hierarchy(style)?;
    validate_link(style)?;
    validate_sim(style)?;
    validate_hair(style)?;
    validate_models(style)?;
    Ok(())
}

/// The head: scalp and collision spheres.
fn validate_head(style: &Style) -> Result<(), Invalid> {
    let h = &style.head;
    let scalp = h.scalp();
    finite3(&scalp.center, "head.scalp.center")?;
    for (a, r) in scalp.radii.iter().enumerate() {
        positive(*r, &format!("head.scalp.radii[{a}]"))?;
    }
    body::validate(&h.body)?;

    Ok(())
}

/// The GC hierarchy: levels, K, branching.
fn validate_hierarchy(style: &Style) -> Result<(), Invalid> {
    let hi = &style.hierarchy;
    check(hi.levels >= 1, "hierarchy.levels", || {
        format!("needs at least one level of detail, got {}", hi.levels)
    })?;
    check(hi.levels <= 8, "hierarchy.levels", || {
        format!("at most 8 levels are supported, got {}", hi.levels)
    })?;
    check(hi.cross_sections >= 2, "hierarchy.cross_sections", || {
        format!(
            "K must be at least 2 (a root and a tip), got {}",
            hi.cross_sections
        )
    })?;
    check(
        hi.branching.len() == hi.levels - 1,
        "hierarchy.branching",
        || {
            format!(
                "needs levels - 1 = {} entries, got {}",
                hi.levels - 1,
                hi.branching.len()
            )
        },
    )?;
    for (n, b) in hi.branching.iter().enumerate() {
        check(*b >= 2, &format!("hierarchy.branching[{n}]"), || {
            format!("a GC must split into at least 2 sub-GCs, got {b}")
        })?;
    }
    check(hi.top_level >= 1, "hierarchy.top_level", || {
        "needs at least one top-level wisp".into()
    })?;

    Ok(())
}

/// The links between nodes.
fn validate_link(style: &Style) -> Result<(), Invalid> {
    match &style.link {
        Link::Rigid { iterations } => check(*iterations >= 1, "link.iterations", || {
            "needs at least one projection sweep".into()
        })?,
        Link::Spring { stiffness, damping } => {
            positive(*stiffness, "link.stiffness")?;
            non_negative(*damping, "link.damping")?;
        }
    }

    Ok(())
}

/// The `sim:` parameters.
fn validate_sim(style: &Style) -> Result<(), Invalid> {
    let s = &style.sim;
    positive(s.total_mass, "sim.total_mass")?;
    non_negative(s.split_threshold, "sim.split_threshold")?;
    non_negative(s.merge_velocity, "sim.merge_velocity")?;
    positive(s.merge_radius_factor, "sim.merge_radius_factor")?;
    non_negative(s.friction, "sim.friction")?;
    non_negative(s.repulsion, "sim.repulsion")?;
    check(
        (0.0..=180.0).contains(&s.angle_threshold),
        "sim.angle_threshold",
        || {
            format!(
                "must be between 0 and 180 degrees, got {:?}",
                s.angle_threshold
            )
        },
    )?;
    positive(s.dt, "sim.dt")?;
    check(s.dt <= 0.1, "sim.dt", || {
        format!("a step longer than 0.1 s is not stable, got {:?}", s.dt)
    })?;
    check(s.friction * s.dt < 1.0, "sim.friction", || {
        format!(
            "friction α·dt must be < 1 so friction never reverses a relative motion (AWT §4.2); α = {:?}, dt = {:?} gives {:?}",
            s.friction,
            s.dt,
            s.friction * s.dt
        )
    })?;
    check(s.steps_per_frame >= 1, "sim.steps_per_frame", || {
        "needs at least one step per frame".into()
    })?;
    finite3(&s.gravity, "sim.gravity")?;
    non_negative(s.air_drag, "sim.air_drag")?;
    non_negative(s.bending, "sim.bending")?;
    non_negative(s.contact_epsilon, "sim.contact_epsilon")?;
    non_negative(s.settle, "sim.settle")?;
    check(s.settle <= 60.0, "sim.settle", || {
        format!("at most 60 s of settling, got {:?}", s.settle)
    })?;
    check(
        s.accel_smoothing > 0.0 && s.accel_smoothing <= 1.0,
        "sim.accel_smoothing",
        || format!("must be in (0, 1], got {:?}", s.accel_smoothing),
    )?;
    finite3(&s.wind.velocity, "sim.wind.velocity")?;
    non_negative(s.wind.gust, "sim.wind.gust")?;
    non_negative(s.wind.frequency, "sim.wind.frequency")?;
    positive(s.wind.wavelength, "sim.wind.wavelength")?;
    Ok(())
}

/// Where the strands come from.
fn validate_hair(style: &Style) -> Result<(), Invalid> {
    match &style.hair {
        Hair::Generated(g) => {
            positive(g.density, "hair.density")?;
            non_negative(g.fan_out, "hair.fan_out")?;
            check(g.samples >= 2, "hair.samples", || {
                format!("needs at least 2 samples per strand, got {}", g.samples)
            })?;
            check(!g.wisps.is_empty(), "hair.wisps", || {
                "needs at least one wisp".into()
            })?;
            let mut names: Vec<&str> = Vec::new();
            for (n, w) in g.wisps.iter().enumerate() {
                let f = |x: &str| format!("hair.wisps[{n}].{x}");
                check(!names.contains(&w.name.as_str()), &f("name"), || {
                    format!("wisp name `{}` is used twice", w.name)
                })?;
                names.push(&w.name);
                let (e0, e1) = w.region.elevation;
                check(
                    (-90.0..=90.0).contains(&e0) && (-90.0..=90.0).contains(&e1) && e0 < e1,
                    &f("region.elevation"),
                    || format!("must be (from, to) with -90 ≤ from < to ≤ 90, got ({e0}, {e1})"),
                )?;
                let (a0, a1) = w.region.azimuth;
                check(
                    a0.is_finite() && a1.is_finite() && a0 < a1 && a1 - a0 <= 360.0,
                    &f("region.azimuth"),
                    || format!("must be (from, to) with from < to ≤ from + 360, got ({a0}, {a1})"),
                )?;
                check(w.tiles.0 >= 1 && w.tiles.1 >= 1, &f("tiles"), || {
                    format!("both tile counts must be ≥ 1, got {:?}", w.tiles)
                })?;
                let tiles = u64::from(w.tiles.0) * u64::from(w.tiles.1);
                check(tiles <= MAX_TILES_PER_WISP, &f("tiles"), || {
                    format!(
                        "at most {MAX_TILES_PER_WISP} tiles per wisp (each tile is a top-level \
                         wisp of the AWT), got {} × {} = {tiles}",
                        w.tiles.0, w.tiles.1
                    )
                })?;
                check(!w.key_strand.is_empty(), &f("key_strand"), || {
                    "needs at least one control point after the root".into()
                })?;
                for (c, p) in w.key_strand.iter().enumerate() {
                    let field = f(&format!("key_strand[{c}]"));
                    finite3(p, &field)?;
                    check(p.iter().all(|x| x.abs() <= MAX_KEY_OFFSET), &field, || {
                        format!(
                            "a key-strand point must lie within {MAX_KEY_OFFSET} m of its root, got {p:?}"
                        )
                    })?;
                }
                non_negative(w.tip_spread, &f("tip_spread"))?;
                if let Some(c) = &w.curl {
                    non_negative(c.radius, &f("curl.radius"))?;
                    non_negative(c.turns_per_metre, &f("curl.turns_per_metre"))?;
                }
                if let Some(d) = w.density {
                    positive(d, &f("density"))?;
                }
            }
            for (n, c) in g.copies.iter().enumerate() {
                let f = |x: &str| format!("hair.copies[{n}].{x}");
                check(names.contains(&c.source.as_str()), &f("source"), || {
                    format!(
                        "there is no wisp named `{}` (known: {})",
                        c.source,
                        names.join(", ")
                    )
                })?;
                check(!names.contains(&c.name.as_str()), &f("name"), || {
                    format!("wisp name `{}` is used twice", c.name)
                })?;
                check(c.azimuth_shift.is_finite(), &f("azimuth_shift"), || {
                    "must be finite".into()
                })?;
                names.push(&c.name);
            }
        }
        Hair::TressFx(t) => {
            check(!t.files.is_empty(), "hair.files", || {
                "needs at least one .tfx file".into()
            })?;
            positive(t.scale, "hair.scale")?;
            finite3(&t.translate, "hair.translate")?;
            check(
                !(style.head.fit_body && t.project.is_some()),
                "head.fit_body",
                || "conflicts with hair.project, which gives the collision spheres".into(),
            )?;
        }
        Hair::HairFile(f) | Hair::HairSalon(f) => {
            check(!f.file.trim().is_empty(), "hair.file", || {
                "needs the path of the strand file".into()
            })?;
            positive(f.scale, "hair.scale")?;
            finite3(&f.translate, "hair.translate")?;
        }
        Hair::Explicit(e) => {
            check(!e.wisps.is_empty(), "hair.wisps", || {
                "needs at least one wisp".into()
            })?;
            for (n, w) in e.wisps.iter().enumerate() {
                let f = format!("hair.wisps[{n}].strands");
                check(!w.strands.is_empty(), &f, || {
                    "needs at least one strand".into()
                })?;
                for (k, st) in w.strands.iter().enumerate() {
                    let fk = format!("{f}[{k}]");
                    check(st.len() >= 2, &fk, || {
                        format!("a strand needs at least 2 points, got {}", st.len())
                    })?;
                    for p in st {
                        finite3(p, &fk)?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// The renderer's section, and where the layered model's level sits in the hierarchy. The
/// values of the `layered:` and `guides:` sections are checked by their solvers
/// (`solver::check_sections`, called by every loader above the solvers: `scene`).
fn validate_models(style: &Style) -> Result<(), Invalid> {
    style.render.validate()?;
    check(
        style.layered.level < style.hierarchy.levels.max(1) || style.layered.level == 1,
        "layered.level",
        || {
            format!(
                "the hierarchy has levels 0..{}, got {}",
                style.hierarchy.levels, style.layered.level
            )
        },
    )?;
    Ok(())
}
