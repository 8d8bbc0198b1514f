//! Imported strand files (`.hair`, `.data`) into wisptree's frame, and collision spheres fitted
//! to the roots (`head.fit_body`).

use nalgebra::{Matrix4, Vector3, Vector4};

use super::{RawHair, RawStrand, Sphere, StrandFile, Up};

/// A point of the file in wisptree's frame: turned to y-up, scaled, translated (the order of
/// [`StrandFile`]'s documentation).
pub fn transform(p: [f32; 3], f: &StrandFile) -> [f64; 3] {
    let [x, y, z] = p.map(f64::from);
    let up = match f.up {
        Up::Y => [x, y, z],
        Up::Z => [x, z, -y],
    };
    [0, 1, 2].map(|a| up[a] * f.scale + f.translate[a])
}

/// Appends the strands of a file to `hair`, transformed; one-point strands are skipped (they
/// cannot be resampled to K cross-sections, and in the HairSalon database they mean "no hair
/// here"). Returns how many were skipped.
pub fn append_strands(f: &StrandFile, strands: &[Vec<[f32; 3]>], hair: &mut RawHair) -> usize {
    let mut skipped = 0;
    for s in strands {
        if s.len() < 2 {
            skipped += 1;
            continue;
        }
        hair.strands.push(RawStrand {
            wisp: 0,
            points: s.iter().map(|&p| transform(p, f)).collect(),
        });
    }
    skipped
}

/// Share of the smallest root distance kept as the fitted sphere's radius: every root then lies
/// just outside the sphere, so no strand starts in contact with the head (like the default
/// head sphere, which sits a few millimetres inside the scalp).
pub(super) const FIT_SHRINK: f64 = 0.98;

/// The head sphere of a set of roots: the algebraic least-squares sphere through them (centre
/// `c` and `d = r² − |c|²` solve the linear system `2 c·p + d = |p|²` over all roots, in
/// coordinates centred on the roots' mean for conditioning), then shrunk to
/// [`FIT_SHRINK`] × the nearest root's distance from `c`.
///
/// Roots on a scalp cap determine the sphere well; fewer than four roots, or roots that are
/// (nearly) coplanar, do not determine one and give an error saying so.
pub fn fit_head_sphere(roots: &[[f64; 3]]) -> Result<Sphere, String> {
    if roots.len() < 4 {
        return Err(format!(
            "needs at least 4 strand roots to fit a sphere, the hair has {}",
            roots.len()
        ));
    }
    let n = roots.len() as f64;
    let mean = roots
        .iter()
        .fold(Vector3::zeros(), |a, p| a + Vector3::from(*p))
        / n;
    let mut ata = Matrix4::<f64>::zeros();
    let mut atb = Vector4::<f64>::zeros();
    for p in roots {
        let q = Vector3::from(*p) - mean;
        let row = Vector4::new(2.0 * q.x, 2.0 * q.y, 2.0 * q.z, 1.0);
        ata += row * row.transpose();
        atb += row * q.norm_squared();
    }
    // Conditioning: coplanar roots make the system singular (any sphere through their circle,
    // or none, fits), which shows as a vanishing eigenvalue relative to the largest.
    let eig = ata.symmetric_eigen().eigenvalues;
    let (lo, hi) = eig.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &e| {
        (a.min(e), b.max(e.abs()))
    });
    if !(hi > 0.0 && lo > hi * 1e-10) {
        return Err(format!(
            "the {} strand roots are (nearly) coplanar: they do not determine a head sphere; \
             give head.body instead",
            roots.len()
        ));
    }
    let x = ata
        .cholesky()
        .map(|c| c.solve(&atb))
        .ok_or_else(|| "the roots do not determine a head sphere; give head.body".to_string())?;
    let c = Vector3::new(x[0], x[1], x[2]) + mean;
    let nearest = roots
        .iter()
        .map(|p| (Vector3::from(*p) - c).norm())
        .fold(f64::INFINITY, f64::min);
    let radius = FIT_SHRINK * nearest;
    if !(radius.is_finite() && radius > 0.0 && c.iter().all(|v| v.is_finite())) {
        return Err(format!(
            "the fitted sphere (centre {:?}, radius {radius}) is degenerate; give head.body",
            [c.x, c.y, c.z]
        ));
    }
    Ok(Sphere {
        center: [c.x, c.y, c.z],
        radius,
    })
}
