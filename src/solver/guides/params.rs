//! Checks of the `guides:` style section (plain data in `style::guides_section`): the guide
//! solver owns the rules its values must keep.

pub use crate::style::guides_section::{GuideParams, StripLayout};

/// Checks every value of the section; returns the dotted field path and the reason.
pub fn validate(p: &GuideParams) -> Result<(), (String, String)> {
    let err = |f: &str, m: String| Err((format!("guides.{f}"), m));
    let pos = |v: f64, f: &str| -> Result<(), (String, String)> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            err(f, format!("must be positive and finite, got {v}"))
        }
    };
    let nonneg = |v: f64, f: &str| -> Result<(), (String, String)> {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            err(f, format!("must be non-negative and finite, got {v}"))
        }
    };
    if p.count < 1 || p.count > 5000 {
        return err(
            "count",
            format!("must be between 1 and 5000, got {}", p.count),
        );
    }
    if p.segments < 2 || p.segments > 64 {
        return err(
            "segments",
            format!("must be between 2 and 64, got {}", p.segments),
        );
    }
    if p.substeps < 1 || p.substeps > 64 {
        return err(
            "substeps",
            format!("must be between 1 and 64, got {}", p.substeps),
        );
    }
    if p.contact_search_every < 1 || p.contact_search_every > 16 {
        return err(
            "contact_search_every",
            format!("must be between 1 and 16, got {}", p.contact_search_every),
        );
    }
    nonneg(p.stiffness, "stiffness")?;
    if !(0.0..=1.0).contains(&p.tip_stiffness) {
        return err(
            "tip_stiffness",
            format!("must be in [0, 1], got {}", p.tip_stiffness),
        );
    }
    nonneg(p.joint_damping, "joint_damping")?;
    if p.links_per_segment > 16 {
        return err(
            "links_per_segment",
            format!("at most 16, got {}", p.links_per_segment),
        );
    }
    pos(p.link_radius, "link_radius")?;
    nonneg(p.link_strength, "link_strength")?;
    nonneg(p.link_damping, "link_damping")?;
    if let Some(r) = p.link_reference {
        pos(r, "link_reference")?;
    }
    pos(p.strip_root_distance, "strip_root_distance")?;
    pos(p.contact_distance, "contact_distance")?;
    nonneg(p.contact_stiffness, "contact_stiffness")?;
    nonneg(p.contact_damping, "contact_damping")?;
    nonneg(p.contact_friction, "contact_friction")?;
    if !(p.strip_break.is_finite() && p.strip_break > 1.0) {
        return err(
            "strip_break",
            format!("must be greater than 1, got {}", p.strip_break),
        );
    }
    if !(0.0..=1.0).contains(&p.body_friction) {
        return err(
            "body_friction",
            format!("must be in [0, 1], got {}", p.body_friction),
        );
    }
    nonneg(p.body_margin, "body_margin")?;
    if p.max_inserted > 1000 {
        return err(
            "max_inserted",
            format!("at most 1000, got {}", p.max_inserted),
        );
    }
    pos(p.insert_distance, "insert_distance")?;
    pos(p.remove_distance, "remove_distance")?;
    if p.remove_distance >= p.insert_distance {
        return err(
            "remove_distance",
            format!(
                "must be smaller than insert_distance ({}), got {}",
                p.insert_distance, p.remove_distance
            ),
        );
    }
    if p.blend < 1 || p.blend > 8 {
        return err("blend", format!("must be between 1 and 8, got {}", p.blend));
    }
    for (i, o) in p.obstacles.iter().enumerate() {
        super::obstacle::validate(i, o).map_err(|(f, m)| (format!("guides.{f}"), m))?;
    }
    Ok(())
}
