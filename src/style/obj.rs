//! Wavefront OBJ meshes for `Mesh(file: ..)` bodies, read with the `tobj` crate (polygons
//! fan-triangulated, negative indices, `v/vt/vn` faces, line continuations handled there).
//! tobj's errors carry no line number, so on an error the offending line is found by a small
//! second look at the text: every message names the file and the line.

use std::collections::HashMap;
use std::path::Path;

use super::body::MeshRef;
use super::StyleError;

/// A triangle mesh in the style's rest frame.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleMesh {
    /// Vertices, m (placed: scaled, turned y up, translated).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles, indices into `vertices`, wound outwards (flipped at load if the file's
    /// winding encloses a negative volume).
    pub triangles: Vec<[u32; 3]>,
    /// Edges used by one triangle only: 0 for a closed mesh.
    pub boundary_edges: usize,
}

/// Reads `path` and places it as `m` says.
pub fn load_obj(path: &Path, m: &MeshRef) -> Result<TriangleMesh, StyleError> {
    let text = std::fs::read_to_string(path).map_err(|error| StyleError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    // Materials are not needed: a missing `.mtl` is not an error.
    let loaded = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    });
    let models = match loaded {
        Ok((models, _)) => models,
        Err(e) => {
            let (line, what) = locate(&text, &e);
            return Err(StyleError::Parse {
                path: path.to_path_buf(),
                line,
                col: 1,
                msg: format!("{what} ({e})"),
            });
        }
    };
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for model in &models {
        let base = vertices.len() as u32;
        let p = &model.mesh.positions;
        vertices.extend(p.chunks_exact(3).map(|c| m.place([c[0], c[1], c[2]])));
        triangles.extend(
            model
                .mesh
                .indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    if triangles.is_empty() {
        return Err(StyleError::Parse {
            path: path.to_path_buf(),
            line: text.lines().count().max(1),
            col: 1,
            msg: "the mesh has no faces (no `f` line with three or more vertices)".into(),
        });
    }
    if let Some(v) = vertices.iter().flatten().find(|v| !v.is_finite()) {
        return Err(StyleError::Parse {
            path: path.to_path_buf(),
            line: 1,
            col: 1,
            msg: format!("a vertex coordinate is not finite ({v})"),
        });
    }
    // Outward winding: the divergence theorem's volume is positive for outward faces (for an
    // open mesh such as a head open at the neck it is still dominated by the closed part).
    let volume: f64 = triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                + a[2] * (b[0] * c[1] - b[1] * c[0])
        })
        .sum();
    if volume < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let boundary_edges = edges.values().filter(|&&n| n == 1).count();
    Ok(TriangleMesh {
        vertices,
        triangles,
        boundary_edges,
    })
}

/// The line (from 1) where tobj's error `e` arises, and what is wrong there.
fn locate(text: &str, e: &tobj::LoadError) -> (usize, String) {
    use tobj::LoadError as E;
    let mut positions = 0i64;
    let total = text
        .lines()
        .filter(|l| l.split_whitespace().next() == Some("v"))
        .count() as i64;
    for (n, raw) in text.lines().enumerate() {
        let mut words = raw.split_whitespace();
        let Some(tag) = words.next() else { continue };
        let rest: Vec<&str> = words.collect();
        let line = n + 1;
        match (tag, e) {
            ("v", E::PositionParseError)
                if rest.len() < 3 || rest.iter().any(|w| w.parse::<f64>().is_err()) =>
            {
                return (line, format!("bad vertex line `{}`", raw.trim()));
            }
            ("v", _) => positions += 1,
            ("f", E::FaceParseError | E::FaceVertexOutOfBounds | E::InvalidPolygon) => {
                for w in &rest {
                    let first = w.split('/').next().unwrap_or("");
                    let Ok(i) = first.parse::<i64>() else {
                        return (line, format!("bad face line `{}`", raw.trim()));
                    };
                    // Negative indices count back from the vertices read so far.
                    let (abs, max) = if i < 0 {
                        (positions + 1 + i, positions)
                    } else {
                        (i, total)
                    };
                    if abs < 1 || abs > max {
                        return (
                            line,
                            format!(
                                "face vertex index {i} is out of range (the file has {total} \
                                 vertices)"
                            ),
                        );
                    }
                }
            }
            _ => {}
        }
    }
    // An error kind that the look above does not place (tobj rejects more than it says).
    (1, "the file is not a mesh tobj can read".into())
}
