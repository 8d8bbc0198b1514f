//! What a model refuses to be built from: strands that would make the clustering into wisps
//! degenerate.

use nalgebra::Vector3;

use crate::style::{LoadedStyle, RawHair, StyleError};

/// Strands shorter than this (m) are counted at load and reported: a stub of hair, or a
/// root-only strand written with two nearly coincident points (a real TressFX style has some
/// 7.5 µm long). They are kept, and simulated like any other strand.
pub const SHORT_STRAND: f64 = 1e-3;

/// How many strands are shorter than [`SHORT_STRAND`], as a note, with the shortest length.
pub(super) fn short_strands_note(hair: &RawHair) -> Option<String> {
    let lengths = hair.strands.iter().map(|st| {
        st.points
            .windows(2)
            .map(|w| (Vector3::from(w[1]) - Vector3::from(w[0])).norm())
            .sum::<f64>()
    });
    let (n, shortest) = lengths
        .filter(|&l| l < SHORT_STRAND)
        .fold((0usize, f64::INFINITY), |(n, m), l| (n + 1, m.min(l)));
    (n > 0).then(|| {
        format!(
            "{n} of {} strands are shorter than {} mm (the shortest {:.1} µm); they are kept \
             (a stub of hair, or a wrong scale?)",
            hair.strands.len(),
            SHORT_STRAND * 1e3,
            shortest * 1e6
        )
    })
}

/// Coordinates beyond this many metres are a typo (or a unit error in an import), and their
/// squares would overflow the clustering's distances.
pub const MAX_COORDINATE: f64 = 1.0e3;

/// Refuses strands that would make clustering degenerate: non-finite or absurd coordinates,
/// zero-length strands, two identical strands, and a declared wisp that grew no strand. Each
/// error names the style's field and the strand.
pub(super) fn check_strands(style: &LoadedStyle, hair: &RawHair) -> Result<(), StyleError> {
    let invalid = |field: String, msg: String| StyleError::Invalid {
        path: style.path.clone(),
        line: None,
        field,
        msg,
    };
    let wisp_of = |st: &crate::style::RawStrand| -> String {
        hair.wisp_names
            .get(st.wisp as usize)
            .map(|w| format!(" (wisp `{w}`)"))
            .unwrap_or_default()
    };
    let mut seen = std::collections::HashMap::with_capacity(hair.strands.len());
    for (n, st) in hair.strands.iter().enumerate() {
        if let Some(p) = st
            .points
            .iter()
            .find(|p| p.iter().any(|c| !c.is_finite() || c.abs() > MAX_COORDINATE))
        {
            return Err(invalid(
                "hair".into(),
                format!(
                    "strand {n}{} reaches ({:e}, {:e}, {:e}) m: coordinates must be finite and \
                     within ±{MAX_COORDINATE} m (a typo in a key strand, or a wrong scale?)",
                    wisp_of(st),
                    p[0],
                    p[1],
                    p[2]
                ),
            ));
        }
        let length: f64 = st
            .points
            .windows(2)
            .map(|w| (Vector3::from(w[1]) - Vector3::from(w[0])).norm())
            .sum();
        if length < 1e-6 {
            return Err(invalid(
                "hair".into(),
                format!(
                    "strand {n}{} has zero length ({length:e} m): all its points coincide",
                    wisp_of(st)
                ),
            ));
        }
        let key: Vec<u64> = st.points.iter().flatten().map(|c| c.to_bits()).collect();
        if let Some(first) = seen.insert(key, n) {
            return Err(invalid(
                "hair".into(),
                format!(
                    "strands {first} and {n}{} are identical: duplicate strands make the \
                     clustering into wisps degenerate",
                    wisp_of(st)
                ),
            ));
        }
    }
    if let crate::style::Hair::Generated(g) = &style.style.hair {
        let grew = |name: &str| {
            hair.strands.iter().any(|st| {
                hair.wisp_names.get(st.wisp as usize).is_some_and(|w| {
                    w == name || (w.starts_with(name) && w[name.len()..].starts_with('['))
                })
            })
        };
        for (n, w) in g.wisps.iter().enumerate() {
            if !grew(&w.name) {
                return Err(invalid(
                    format!("hair.wisps[{n}]"),
                    format!(
                        "wisp `{}` grows no strand: its region is too small for its density \
                         (raise `density` or widen `region`)",
                        w.name
                    ),
                ));
            }
        }
    }
    Ok(())
}
