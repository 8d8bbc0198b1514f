//! The kinds of body a style may give in `head.body`: spheres (the AWT paper's own proxy,
//! §4.3), capsules (as TressFX uses) and triangle meshes read from Wavefront OBJ files (Plante,
//! Cani, Poulin 2002 collide with the character's mesh).
//!
//! ```ron
//! body: [
//!     (center: (0, 1.6, 0), radius: 0.07),          // a sphere, as before
//!     Sphere(center: (0, 1.47, 0), radius: 0.05),
//!     Capsule(a: (0.1, 1.4, 0), b: (0.3, 1.4, 0), radius: 0.05),
//!     Mesh(file: "head.obj", scale: 1.0, translate: (0, 1.3, 0), up: Y),
//! ]
//! ```
//!
//! ron 0.11 hands a struct-like value to `deserialize_any` as a map and drops its name
//! (`Capsule(...)` and `(...)` look the same), so the kind is told by the fields: `center` →
//! sphere, `a`/`b` → capsule, `file` → mesh. The fields are read with typed calls, so `up: Y`
//! keeps its variant name.

use std::fmt;

use serde::de::{self, MapAccess, Visitor};
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::schema::{Sphere, Up, Vec3};

/// One item of `head.body`.
#[derive(Debug, Clone, PartialEq)]
pub enum BodyItem {
    /// `(center: .., radius: ..)` or `Sphere(center: .., radius: ..)`.
    Sphere(Sphere),
    /// `Capsule(a: .., b: .., radius: ..)`: the points within `radius` of the segment `a`–`b`.
    Capsule(Capsule),
    /// `Mesh(file: .., scale: .., translate: .., up: Y|Z)`: a triangle mesh from an OBJ file.
    Mesh(MeshRef),
}

/// A capsule: the segment `a`–`b` swept by a ball of `radius`, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// One end of the axis, m.
    pub a: Vec3,
    /// The other end of the axis, m.
    pub b: Vec3,
    /// Radius, m (> 0).
    pub radius: f64,
}

/// A mesh body: where its OBJ file is and how it is placed.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshRef {
    /// The OBJ file, relative to the style file (or absolute).
    pub file: String,
    /// Uniform scale applied to the file's coordinates first. Default 1.
    pub scale: f64,
    /// Added after scaling and turning y up, m. Default (0, 0, 0).
    pub translate: Vec3,
    /// The file's up axis. Default Y.
    pub up: Up,
}

impl MeshRef {
    /// A file point in the style's rest frame: scaled, turned y up, translated.
    pub fn place(&self, p: [f64; 3]) -> [f64; 3] {
        let s = self.scale;
        let q = match self.up {
            Up::Y => [p[0] * s, p[1] * s, p[2] * s],
            Up::Z => [p[0] * s, p[2] * s, -p[1] * s],
        };
        let t = self.translate;
        [q[0] + t[0], q[1] + t[1], q[2] + t[2]]
    }
}

impl BodyItem {
    /// The sphere, if this item is one.
    pub fn sphere(&self) -> Option<&Sphere> {
        match self {
            BodyItem::Sphere(s) => Some(s),
            _ => None,
        }
    }
}

impl From<Sphere> for BodyItem {
    fn from(s: Sphere) -> Self {
        BodyItem::Sphere(s)
    }
}

impl Serialize for BodyItem {
    fn serialize<S: Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        match self {
            BodyItem::Sphere(s) => s.serialize(ser),
            BodyItem::Capsule(c) => {
                let mut st = ser.serialize_struct("Capsule", 3)?;
                st.serialize_field("a", &c.a)?;
                st.serialize_field("b", &c.b)?;
                st.serialize_field("radius", &c.radius)?;
                st.end()
            }
            BodyItem::Mesh(m) => {
                let mut st = ser.serialize_struct("Mesh", 4)?;
                st.serialize_field("file", &m.file)?;
                st.serialize_field("scale", &m.scale)?;
                st.serialize_field("translate", &m.translate)?;
                st.serialize_field("up", &m.up)?;
                st.end()
            }
        }
    }
}

const FIELDS: &[&str] = &[
    "center",
    "radius",
    "a",
    "b",
    "file",
    "scale",
    "translate",
    "up",
];

impl<'de> Deserialize<'de> for BodyItem {
    fn deserialize<D: Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        de.deserialize_any(ItemVisitor)
    }
}

struct ItemVisitor;

/// The fields seen, before the kind is known.
#[derive(Default)]
struct Seen {
    center: Option<Vec3>,
    radius: Option<f64>,
    a: Option<Vec3>,
    b: Option<Vec3>,
    file: Option<String>,
    scale: Option<f64>,
    translate: Option<Vec3>,
    up: Option<Up>,
}

fn once<T, E: de::Error>(slot: &mut Option<T>, v: T, name: &'static str) -> Result<(), E> {
    if slot.is_some() {
        return Err(E::duplicate_field(name));
    }
    *slot = Some(v);
    Ok(())
}

impl<'de> Visitor<'de> for ItemVisitor {
    type Value = BodyItem;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(
            "a body: (center: .., radius: ..), Sphere(center: .., radius: ..), \
             Capsule(a: .., b: .., radius: ..) or Mesh(file: .., scale: .., translate: .., up: Y|Z)",
        )
    }

    fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<BodyItem, M::Error> {
        let mut s = Seen::default();
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "center" => once(&mut s.center, map.next_value()?, "center")?,
                "radius" => once(&mut s.radius, map.next_value()?, "radius")?,
                "a" => once(&mut s.a, map.next_value()?, "a")?,
                "b" => once(&mut s.b, map.next_value()?, "b")?,
                "file" => once(&mut s.file, map.next_value()?, "file")?,
                "scale" => once(&mut s.scale, map.next_value()?, "scale")?,
                "translate" => once(&mut s.translate, map.next_value()?, "translate")?,
                "up" => once(&mut s.up, map.next_value()?, "up")?,
                other => return Err(de::Error::unknown_field(other, FIELDS)),
            }
        }
        let stray = |ok: &[&str], s: &Seen| -> Option<&'static str> {
            let present = [
                ("center", s.center.is_some()),
                ("radius", s.radius.is_some()),
                ("a", s.a.is_some()),
                ("b", s.b.is_some()),
                ("file", s.file.is_some()),
                ("scale", s.scale.is_some()),
                ("translate", s.translate.is_some()),
                ("up", s.up.is_some()),
            ];
            present
                .iter()
                .find(|(n, p)| *p && !ok.contains(n))
                .map(|(n, _)| *n)
        };
        let kind_err = |kind: &str, n: &str| {
            de::Error::custom(format!("field `{n}` does not belong to a {kind} body"))
        };
        if let Some(file) = s.file.take() {
            if let Some(n) = stray(&["scale", "translate", "up"], &s) {
                return Err(kind_err("Mesh", n));
            }
            return Ok(BodyItem::Mesh(MeshRef {
                file,
                scale: s.scale.unwrap_or(1.0),
                translate: s.translate.unwrap_or([0.0; 3]),
                up: s.up.unwrap_or(Up::Y),
            }));
        }
        if s.a.is_some() || s.b.is_some() {
            if let Some(n) = stray(&["a", "b", "radius"], &s) {
                return Err(kind_err("Capsule", n));
            }
            return Ok(BodyItem::Capsule(Capsule {
                a: s.a.ok_or_else(|| de::Error::missing_field("a"))?,
                b: s.b.ok_or_else(|| de::Error::missing_field("b"))?,
                radius: s.radius.ok_or_else(|| de::Error::missing_field("radius"))?,
            }));
        }
        if let Some(n) = stray(&["center", "radius"], &s) {
            return Err(kind_err("Sphere", n));
        }
        Ok(BodyItem::Sphere(Sphere {
            center: s.center.ok_or_else(|| de::Error::missing_field("center"))?,
            radius: s.radius.ok_or_else(|| de::Error::missing_field("radius"))?,
        }))
    }
}

/// A non-sphere body after loading, in the style's rest frame (spheres stay in
/// [`super::LoadedStyle::body`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A capsule, as written.
    Capsule(Capsule),
    /// A mesh read from its file and placed.
    Mesh(std::sync::Arc<super::obj::TriangleMesh>, std::path::PathBuf),
}

impl super::schema::Head {
    /// The spheres of `body`, in order.
    pub fn spheres(&self) -> Vec<Sphere> {
        self.body
            .iter()
            .filter_map(BodyItem::sphere)
            .cloned()
            .collect()
    }
}

/// Loads the capsules and meshes of `body`; mesh files are relative to `style_path`'s folder.
pub fn load_shapes(
    style_path: &std::path::Path,
    body: &[BodyItem],
) -> Result<Vec<Shape>, super::StyleError> {
    let mut out = Vec::new();
    for item in body {
        match item {
            BodyItem::Sphere(_) => {}
            BodyItem::Capsule(c) => out.push(Shape::Capsule(*c)),
            BodyItem::Mesh(m) => {
                let path = super::resolve(style_path, &m.file);
                let mesh = super::obj::load_obj(&path, m)?;
                out.push(Shape::Mesh(std::sync::Arc::new(mesh), path));
            }
        }
    }
    Ok(out)
}

/// Checks the numbers of every body item; returns the dotted field and the reason.
pub fn validate(body: &[BodyItem]) -> Result<(), (String, String)> {
    let bad = |f: String, m: String| Err((f, m));
    let finite = |v: &Vec3| v.iter().all(|x| x.is_finite());
    let pos = |r: f64| r.is_finite() && r > 0.0;
    for (n, item) in body.iter().enumerate() {
        let at = format!("head.body[{n}]");
        match item {
            BodyItem::Sphere(s) => {
                if !finite(&s.center) {
                    return bad(
                        format!("{at}.center"),
                        format!("must be finite, got {:?}", s.center),
                    );
                }
                if !pos(s.radius) {
                    return bad(
                        format!("{at}.radius"),
                        format!("must be a positive number, got {:?}", s.radius),
                    );
                }
            }
            BodyItem::Capsule(c) => {
                for (v, f) in [(&c.a, "a"), (&c.b, "b")] {
                    if !finite(v) {
                        return bad(format!("{at}.{f}"), format!("must be finite, got {v:?}"));
                    }
                }
                if !pos(c.radius) {
                    return bad(
                        format!("{at}.radius"),
                        format!("must be a positive number, got {:?}", c.radius),
                    );
                }
            }
            BodyItem::Mesh(m) => {
                if !pos(m.scale) {
                    return bad(
                        format!("{at}.scale"),
                        format!("must be a positive number, got {:?}", m.scale),
                    );
                }
                if !finite(&m.translate) {
                    return bad(
                        format!("{at}.translate"),
                        format!("must be finite, got {:?}", m.translate),
                    );
                }
                if m.file.trim().is_empty() {
                    return bad(format!("{at}.file"), "needs the path of an OBJ file".into());
                }
            }
        }
    }
    Ok(())
}

/// The default body: a head sphere just inside the scalp, a neck and two shoulders/torso
/// spheres.
pub fn default_body() -> Vec<BodyItem> {
    [
        Sphere {
            center: [0.0, 1.6, 0.0],
            radius: 0.072,
        },
        Sphere {
            center: [0.0, 1.47, -0.01],
            radius: 0.05,
        },
        Sphere {
            center: [0.0, 1.25, -0.02],
            radius: 0.15,
        },
        Sphere {
            center: [0.12, 1.36, -0.02],
            radius: 0.07,
        },
        Sphere {
            center: [-0.12, 1.36, -0.02],
            radius: 0.07,
        },
    ]
    .into_iter()
    .map(BodyItem::Sphere)
    .collect()
}
