//! The multiresolution hair model (AWT §2.1–2.2): a hierarchy of generalized cylinders (GCs)
//! with circular cross-sections, built once from a style's strands and never changed after.
//!
//! Indices: a node is `(level l, GC g, cross-section i)`; its data sits at `g * K + i` in the
//! level's node arrays. GCs are stored level by level in breadth-first order, so the sub-GCs of
//! a GC are a contiguous range of the next level, and so are its finest descendants.

use std::ops::Range;

use nalgebra::Vector3;

use crate::style::{Link, LoadedStyle, RawHair, Sphere, StyleError};

pub mod body;
pub mod body_sdf;
mod check;

use check::check_strands;
pub use check::MAX_COORDINATE;

/// Marks "no super-GC" (level 0).
pub const NONE: u32 = u32::MAX;

/// Smallest radius given to a cross-section (a single strand still has a thickness), m.
pub const MIN_RADIUS: f64 = 5e-4;

/// One level of detail.
#[derive(Debug, Clone, Default)]
pub struct Level {
    /// Per GC: its super-GC in the previous level (`NONE` on level 0).
    pub super_gc: Vec<u32>,
    /// Per GC: its sub-GCs in the next level (empty on the finest level).
    pub sub_gcs: Vec<Range<u32>>,
    /// Per GC: its finest descendants (itself on the finest level).
    pub finest: Vec<Range<u32>>,
    /// Per GC: the top-level GC (tree) it belongs to.
    pub tree: Vec<u32>,
    /// Per GC: how many strands it stands for.
    pub strand_count: Vec<u32>,
    /// Per node (`g * K + i`): rest position, the centre of mass of its strands' points.
    pub rest_pos: Vec<Vector3<f64>>,
    /// Per node: radius enclosing its sub-nodes' cross-sections (finest: its strands).
    pub radius: Vec<f64>,
    /// Per node: mass of the strand pieces it stands for, kg.
    pub mass: Vec<f64>,
    /// Per node: mass of its GC from this cross-section to the tip, kg (what a link ending at
    /// the node carries).
    pub mass_below: Vec<f64>,
}

impl Level {
    /// Number of GCs on the level.
    pub fn gc_count(&self) -> usize {
        self.super_gc.len()
    }
}

/// The strands, resampled to K points and bound to their finest GC.
#[derive(Debug, Clone, Default)]
pub struct Strands {
    /// Per strand: the finest GC that drives it. Strands are sorted by it.
    pub finest_gc: Vec<u32>,
    /// Per strand point (`s * K + i`): rest position.
    pub rest: Vec<Vector3<f64>>,
    /// Per strand point: offset from the finest node `(finest_gc, i)` at rest. The reference
    /// tangent of an offset is the finest GC's rest tangent at `i` (`HairModel::rest_tangent`).
    pub offset: Vec<Vector3<f64>>,
}

impl Strands {
    /// Number of strands.
    pub fn len(&self) -> usize {
        self.finest_gc.len()
    }
    /// No strand.
    pub fn is_empty(&self) -> bool {
        self.finest_gc.is_empty()
    }
}

/// The immutable multiresolution model.
#[derive(Debug, Clone)]
pub struct HairModel {
    /// Cross-sections per GC.
    pub k: usize,
    /// Levels of detail, coarsest first.
    pub levels: Vec<Level>,
    /// Names of the top-level GCs (trees).
    pub tree_names: Vec<String>,
    /// The strands, resampled and bound to their finest GCs.
    pub strands: Strands,
    /// Mass of one strand, kg.
    pub strand_mass: f64,
    /// Mass of all the hair, kg.
    pub total_mass: f64,
    /// Length of the longest strand as given (before resampling, curls included), m.
    pub longest_strand: f64,
    /// How the nodes are linked (rigid or springs).
    pub link: Link,
    /// Scalp ellipsoid (centre, radii) and body spheres in the rest pose.
    pub scalp_center: Vector3<f64>,
    /// Scalp ellipsoid semi-axes, m.
    pub scalp_radii: Vector3<f64>,
    /// Collision spheres in the rest pose.
    pub body: Vec<Sphere>,
    /// The capsules and meshes of the body, in the rest pose.
    pub colliders: Vec<body::Collider>,
    /// What the import had to tell the user (skipped strands), from [`RawHair::notes`].
    pub notes: Vec<String>,
}

impl HairModel {
    /// Loads the style's strands and builds the model.
    pub fn from_style(style: &LoadedStyle) -> Result<HairModel, StyleError> {
        let mut hair = style.strands()?;
        if hair.strands.is_empty() {
            return Err(StyleError::Invalid {
                path: style.path.clone(),
                line: None,
                field: "hair".into(),
                msg: "the style produces no strands".into(),
            });
        }
        if let Some((n, _)) = hair
            .strands
            .iter()
            .enumerate()
            .find(|(_, s)| s.points.len() < 2)
        {
            return Err(StyleError::Invalid {
                path: style.path.clone(),
                line: None,
                field: "hair".into(),
                msg: format!("strand {n} has fewer than 2 points"),
            });
        }
        check_strands(style, &hair)?;
        hair.notes.extend(check::short_strands_note(&hair));
        Ok(Self::build(style, &hair))
    }

    /// Builds the hierarchy from raw strands (any source).
    pub fn build(style: &LoadedStyle, hair: &RawHair) -> HairModel {
        let s = &style.style;
        let colliders: Vec<body::Collider> = style.shapes.iter().map(body::Collider::new).collect();
        let pushed;
        let hair = if s.head.push_roots_out {
            pushed = body::push_roots_out(hair, &colliders);
            &pushed
        } else {
            hair
        };
        let k = s.hierarchy.cross_sections;
        let n = hair.strands.len();
        // 1. Resample every strand to K points, uniform in arc length.
        let mut pts: Vec<Vector3<f64>> = Vec::with_capacity(n * k);
        for st in &hair.strands {
            resample(&st.points, k, &mut pts);
        }

        // 2. Top-level GCs: the style's wisps, or clusters of imported strands.
        let (mut groups, tree_names) = top_level_groups(hair, s.hierarchy.top_level, &pts, k);

        // 3. Refine level by level, breadth first, so children are contiguous.
        let n_levels = s.hierarchy.levels;
        let mut levels: Vec<Level> = Vec::with_capacity(n_levels);
        let mut members_per_level: Vec<Vec<Vec<u32>>> = Vec::with_capacity(n_levels);
        let mut lvl0 = Level::default();
        for (t, _) in groups.iter().enumerate() {
            lvl0.super_gc.push(NONE);
            lvl0.tree.push(t as u32);
        }
        levels.push(lvl0);
        members_per_level.push(std::mem::take(&mut groups));
        for l in 1..n_levels {
            let branching = s.hierarchy.branching[l - 1];
            let mut next = Level::default();
            let mut next_members = Vec::new();
            let prev_members = &members_per_level[l - 1];
            let prev = &mut levels[l - 1];
            for (g, members) in prev_members.iter().enumerate() {
                let start = next.super_gc.len() as u32;
                for sub in cluster(members, branching, &pts, k) {
                    next.super_gc.push(g as u32);
                    next.tree.push(prev.tree[g]);
                    next_members.push(sub);
                }
                prev.sub_gcs.push(start..next.super_gc.len() as u32);
            }
            levels.push(next);
            members_per_level.push(next_members);
        }
        let finest = n_levels - 1;
        let n_finest = levels[finest].gc_count();
        levels[finest].sub_gcs = vec![0..0; n_finest];

        // Finest descendant ranges, from the finest level up.
        levels[finest].finest = (0..n_finest as u32).map(|g| g..g + 1).collect();
        for l in (0..finest).rev() {
            let fin: Vec<Range<u32>> = levels[l]
                .sub_gcs
                .iter()
                .map(|r| {
                    let a = &levels[l + 1].finest[r.start as usize];
                    let b = &levels[l + 1].finest[r.end as usize - 1];
                    a.start..b.end
                })
                .collect();
            levels[l].finest = fin;
        }

        // 4. Strand binding, strands sorted by finest GC.
        let strand_mass = s.sim.total_mass / n as f64;
        let point_mass = strand_mass / k as f64;
        let mut strands = Strands::default();
        for (g, members) in members_per_level[finest].iter().enumerate() {
            for &m in members {
                strands.finest_gc.push(g as u32);
                let base = m as usize * k;
                strands.rest.extend_from_slice(&pts[base..base + k]);
            }
        }

        // 5. Finest nodes: centre of mass and enclosing radius of their strands; masses.
        for (l, members) in members_per_level.iter().enumerate() {
            let lv = &mut levels[l];
            lv.strand_count = members.iter().map(|m| m.len() as u32).collect();
            let _ = l;
        }
        finest_nodes(
            &mut levels[finest],
            &members_per_level[finest],
            &pts,
            k,
            point_mass,
        );
        coarse_nodes(&mut levels, k);
        masses_below(&mut levels, k);

        // Strand offsets from their finest node.
        strands.offset = strands
            .rest
            .iter()
            .enumerate()
            .map(|(p, x)| {
                let s_ = p / k;
                let i = p % k;
                x - levels[finest].rest_pos[strands.finest_gc[s_] as usize * k + i]
            })
            .collect();

        HairModel {
            k,
            levels,
            tree_names,
            strands,
            strand_mass,
            total_mass: s.sim.total_mass,
            longest_strand: hair
                .strands
                .iter()
                .map(|st| {
                    st.points
                        .windows(2)
                        .map(|w| (Vector3::from(w[1]) - Vector3::from(w[0])).norm())
                        .sum::<f64>()
                })
                .fold(0.0, f64::max),
            link: s.link.clone(),
            scalp_center: Vector3::from(style.scalp.center),
            scalp_radii: Vector3::from(style.scalp.radii),
            body: style.body.clone(),
            colliders,
            notes: hair.notes.clone(),
        }
    }

    /// Number of levels of detail.
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// The finest level.
    pub fn finest(&self) -> &Level {
        self.levels.last().expect("a model has at least one level")
    }

    /// Rest tangent of GC `g` of level `l` at cross-section `i`: the direction of the segment
    /// that ends there (at the root, of the first segment).
    pub fn rest_tangent(&self, l: usize, g: usize, i: usize) -> Vector3<f64> {
        let k = self.k;
        let p = &self.levels[l].rest_pos;
        let (a, b) = if i == 0 { (0, 1) } else { (i - 1, i) };
        let d = p[g * k + b] - p[g * k + a];
        let n = d.norm();
        if n > 0.0 {
            d / n
        } else {
            Vector3::y()
        }
    }

    /// Total number of nodes on a level (GCs × K).
    pub fn nodes_on_level(&self, l: usize) -> usize {
        self.levels[l].gc_count() * self.k
    }

    /// A fingerprint of the hair as built: 64-bit FNV-1a over K, the strand count and the bits
    /// of every strand point at rest. Two styles that build the same hair, bit for bit, have the
    /// same hash (a saved edit against its source, for instance); FNV-1a is stable across
    /// machines and Rust versions, which std's hasher does not promise.
    pub fn point_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: u64| {
            for b in x.to_le_bytes() {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        eat(self.k as u64);
        eat(self.strands.len() as u64);
        for p in &self.strands.rest {
            eat(p.x.to_bits());
            eat(p.y.to_bits());
            eat(p.z.to_bits());
        }
        h
    }

    /// Smallest and largest node radius over all levels.
    pub fn radius_range(&self) -> (f64, f64) {
        self.levels
            .iter()
            .flat_map(|l| l.radius.iter().copied())
            .fold((f64::INFINITY, 0.0), |(a, b), r| (a.min(r), b.max(r)))
    }

    /// Length of the longest strand as given (curls included), m.
    pub fn max_strand_length(&self) -> f64 {
        self.longest_strand
    }
}

/// Appends `k` points resampled uniformly in arc length along a polyline.
fn resample(points: &[[f64; 3]], k: usize, out: &mut Vec<Vector3<f64>>) {
    let p: Vec<Vector3<f64>> = points.iter().map(|v| Vector3::from(*v)).collect();
    let mut cum = Vec::with_capacity(p.len());
    cum.push(0.0);
    for w in p.windows(2) {
        let l = cum.last().copied().unwrap_or(0.0) + (w[1] - w[0]).norm();
        cum.push(l);
    }
    let total = *cum.last().unwrap_or(&0.0);
    let mut seg = 0;
    for i in 0..k {
        let target = total * i as f64 / (k - 1) as f64;
        while seg + 2 < p.len() && cum[seg + 1] < target {
            seg += 1;
        }
        let span = cum[seg + 1] - cum[seg];
        let t = if span > 0.0 {
            ((target - cum[seg]) / span).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(p[seg] + (p[seg + 1] - p[seg]) * t);
    }
}

/// Deterministic k-means of strands into at most `k_clusters` non-empty groups, on their
/// resampled shape (every point, the root weighted more so that clusters stay contiguous on
/// the scalp). Farthest-point seeding from the strand nearest the mean; ties by index.
fn cluster(members: &[u32], k_clusters: usize, pts: &[Vector3<f64>], k: usize) -> Vec<Vec<u32>> {
    let n = members.len();
    if n <= k_clusters {
        return members.iter().map(|&m| vec![m]).collect();
    }
    const ROOT_WEIGHT: f64 = 4.0;
    let dim = k * 3;
    let feat = |m: u32, out: &mut [f64]| {
        for i in 0..k {
            let w = if i == 0 { ROOT_WEIGHT } else { 1.0 };
            let p = pts[m as usize * k + i];
            out[i * 3] = p.x * w;
            out[i * 3 + 1] = p.y * w;
            out[i * 3 + 2] = p.z * w;
        }
    };
    let mut f = vec![0.0; n * dim];
    for (j, &m) in members.iter().enumerate() {
        feat(m, &mut f[j * dim..(j + 1) * dim]);
    }
    let dist2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>();
    let mut mean = vec![0.0; dim];
    for j in 0..n {
        for d in 0..dim {
            mean[d] += f[j * dim + d] / n as f64;
        }
    }
    // Seeding.
    let first = (0..n)
        .min_by(|&a, &b| {
            dist2(&f[a * dim..(a + 1) * dim], &mean)
                .total_cmp(&dist2(&f[b * dim..(b + 1) * dim], &mean))
        })
        .unwrap_or(0);
    let mut centres: Vec<f64> = f[first * dim..(first + 1) * dim].to_vec();
    let mut best = vec![f64::INFINITY; n];
    for c in 1..k_clusters {
        let last = &centres[(c - 1) * dim..c * dim].to_vec();
        let mut far = 0;
        let mut far_d = -1.0;
        for j in 0..n {
            best[j] = best[j].min(dist2(&f[j * dim..(j + 1) * dim], last));
            if best[j] > far_d {
                far_d = best[j];
                far = j;
            }
        }
        centres.extend_from_slice(&f[far * dim..(far + 1) * dim]);
    }
    // Lloyd iterations.
    let mut assign = vec![0usize; n];
    for _ in 0..20 {
        let mut changed = false;
        for j in 0..n {
            let fj = &f[j * dim..(j + 1) * dim];
            let mut bc = 0;
            let mut bd = f64::INFINITY;
            for c in 0..k_clusters {
                let d = dist2(fj, &centres[c * dim..(c + 1) * dim]);
                if d < bd {
                    bd = d;
                    bc = c;
                }
            }
            if assign[j] != bc {
                assign[j] = bc;
                changed = true;
            }
        }
        // Refill empty clusters with the point farthest from its centre (deterministic).
        let mut counts = vec![0usize; k_clusters];
        for &a in &assign {
            counts[a] += 1;
        }
        for c in 0..k_clusters {
            if counts[c] == 0 {
                let (j, _) = (0..n)
                    .filter(|&j| counts[assign[j]] > 1)
                    .map(|j| {
                        (
                            j,
                            dist2(
                                &f[j * dim..(j + 1) * dim],
                                &centres[assign[j] * dim..(assign[j] + 1) * dim],
                            ),
                        )
                    })
                    .fold(
                        (usize::MAX, -1.0),
                        |acc, x| if x.1 > acc.1 { x } else { acc },
                    );
                counts[assign[j]] -= 1;
                assign[j] = c;
                counts[c] = 1;
                changed = true;
            }
        }
        centres.iter_mut().for_each(|x| *x = 0.0);
        for j in 0..n {
            let c = assign[j];
            for d in 0..dim {
                centres[c * dim + d] += f[j * dim + d] / counts[c] as f64;
            }
        }
        if !changed {
            break;
        }
    }
    let mut out = vec![Vec::new(); k_clusters];
    for (j, &a) in assign.iter().enumerate() {
        out[a].push(members[j]);
    }
    // Order clusters by their first member for a stable, readable layout.
    out.sort_by_key(|c| c[0]);
    out
}

/// Finest nodes: centre of mass and enclosing radius of their strands' points; masses.
fn finest_nodes(
    lv: &mut Level,
    members: &[Vec<u32>],
    pts: &[Vector3<f64>],
    k: usize,
    point_mass: f64,
) {
    let n_finest = members.len();
    lv.rest_pos = vec![Vector3::zeros(); n_finest * k];
    lv.radius = vec![0.0; n_finest * k];
    lv.mass = vec![0.0; n_finest * k];
    for (g, members) in members.iter().enumerate() {
        for i in 0..k {
            let mut c = Vector3::zeros();
            for &m in members {
                c += pts[m as usize * k + i];
            }
            c /= members.len() as f64;
            let mut r: f64 = MIN_RADIUS;
            for &m in members {
                r = r.max((pts[m as usize * k + i] - c).norm());
            }
            lv.rest_pos[g * k + i] = c;
            lv.radius[g * k + i] = r;
            lv.mass[g * k + i] = point_mass * members.len() as f64;
        }
    }
}

/// Coarser nodes from their sub-nodes: mass = exact sum, position = centre of mass, radius
/// refitted to enclose every sub cross-section (the paper's post-processing).
fn coarse_nodes(levels: &mut [Level], k: usize) {
    let finest = levels.len() - 1;
    for l in (0..finest).rev() {
        let (upper, lower) = levels.split_at_mut(l + 1);
        let lv = &mut upper[l];
        let sub = &lower[0];
        let gcs = lv.gc_count();
        lv.rest_pos = vec![Vector3::zeros(); gcs * k];
        lv.radius = vec![0.0; gcs * k];
        lv.mass = vec![0.0; gcs * k];
        for g in 0..gcs {
            for i in 0..k {
                let mut m = 0.0;
                let mut c = Vector3::zeros();
                for sg in lv.sub_gcs[g].clone() {
                    let j = sg as usize * k + i;
                    m += sub.mass[j];
                    c += sub.rest_pos[j] * sub.mass[j];
                }
                c /= m;
                let mut r: f64 = MIN_RADIUS;
                for sg in lv.sub_gcs[g].clone() {
                    let j = sg as usize * k + i;
                    r = r.max((sub.rest_pos[j] - c).norm() + sub.radius[j]);
                }
                lv.rest_pos[g * k + i] = c;
                lv.radius[g * k + i] = r;
                lv.mass[g * k + i] = m;
            }
        }
    }
}

/// Per node, the mass from it to the tip of its GC (what the link ending there carries).
fn masses_below(levels: &mut [Level], k: usize) {
    for lv in levels.iter_mut() {
        lv.mass_below = vec![0.0; lv.mass.len()];
        for g in 0..lv.gc_count() {
            let mut acc = 0.0;
            for i in (0..k).rev() {
                acc += lv.mass[g * k + i];
                lv.mass_below[g * k + i] = acc;
            }
        }
    }
}

/// The top-level GCs: the style's wisps (empty ones dropped, names kept aligned), or clusters of
/// imported strands.
fn top_level_groups(
    hair: &RawHair,
    top_level: usize,
    pts: &[Vector3<f64>],
    k: usize,
) -> (Vec<Vec<u32>>, Vec<String>) {
    let n = hair.strands.len();
    if hair.wisp_names.is_empty() {
        let all: Vec<u32> = (0..n as u32).collect();
        let groups = cluster(&all, top_level, pts, k);
        let names = (0..groups.len()).map(|t| format!("wisp {t}")).collect();
        (groups, names)
    } else {
        let mut groups = vec![Vec::new(); hair.wisp_names.len()];
        for (i, st) in hair.strands.iter().enumerate() {
            groups[st.wisp as usize].push(i as u32);
        }
        let names = hair.wisp_names.clone();
        // Drop empty wisps (a tile too small to hold a root), keeping names aligned.
        let (g, nm): (Vec<_>, Vec<_>) = groups
            .into_iter()
            .zip(names)
            .filter(|(g, _)| !g.is_empty())
            .unzip();
        (g, nm)
    }
}
