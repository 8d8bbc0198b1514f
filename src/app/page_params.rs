//! Values set from the control page (`run --web`): one parameter at a time, and the wind
//! strength that scales the style's wind.

use crate::style::{SimParams, Wind};
use crate::web::Param;

/// The wind a wind strength of 1 gives: the style's own wind, or 1 m/s along +x when the style
/// has none (so the page's wind slider always does something).
pub fn base_wind(style_wind: &Wind) -> Wind {
    if has_wind(style_wind) {
        style_wind.clone()
    } else {
        Wind {
            velocity: [1.0, 0.0, 0.0],
            ..style_wind.clone()
        }
    }
}

/// The wind strength a style starts with: 1 (its own wind) if it has wind, else 0.
pub fn initial_wind_strength(style_wind: &Wind) -> f64 {
    if has_wind(style_wind) {
        1.0
    } else {
        0.0
    }
}

fn has_wind(w: &Wind) -> bool {
    w.velocity.iter().any(|v| *v != 0.0) || w.gust != 0.0
}

/// Sets one parameter from the control page (the value is already checked against its range
/// and α·dt < 1) and returns the message for the log. `wind_strength` is the page's wind
/// value in force; `base` the wind it scales.
pub fn apply_param(
    p: &mut SimParams,
    wind_strength: &mut f64,
    base: &Wind,
    param: Param,
    value: f64,
) -> String {
    let spec = param.spec();
    let old = match param {
        Param::SplitThreshold => std::mem::replace(&mut p.split_threshold, value),
        Param::MergeVelocity => std::mem::replace(&mut p.merge_velocity, value),
        Param::Friction => std::mem::replace(&mut p.friction, value),
        Param::Repulsion => std::mem::replace(&mut p.repulsion, value),
        Param::Wind => {
            p.wind.velocity = base.velocity.map(|v| v * value);
            p.wind.gust = base.gust * value;
            std::mem::replace(wind_strength, value)
        }
    };
    format!(
        "{} {old:.4} → {value:.4} {} (web page)",
        spec.label, spec.unit
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pages_values_set_their_parameter_and_wind_scales_the_styles_wind() {
        let mut p = SimParams::default();
        let mut strength = initial_wind_strength(&p.wind);
        assert_eq!(strength, 0.0, "the default style has no wind");
        let base = base_wind(&p.wind);
        let msg = apply_param(&mut p, &mut strength, &base, Param::SplitThreshold, 0.42);
        assert_eq!(p.split_threshold, 0.42);
        assert!(
            msg.contains("split threshold") && msg.contains("0.4200"),
            "{msg}"
        );
        apply_param(&mut p, &mut strength, &base, Param::MergeVelocity, 0.07);
        apply_param(&mut p, &mut strength, &base, Param::Friction, 12.0);
        apply_param(&mut p, &mut strength, &base, Param::Repulsion, 900.0);
        assert_eq!(
            (p.merge_velocity, p.friction, p.repulsion),
            (0.07, 12.0, 900.0)
        );
        // No wind in the style: the strength is m/s along +x.
        apply_param(&mut p, &mut strength, &base, Param::Wind, 2.0);
        assert_eq!((p.wind.velocity, strength), ([2.0, 0.0, 0.0], 2.0));
        // A style's own wind is scaled, gusts too.
        let styled = Wind {
            velocity: [0.0, 0.0, -1.5],
            gust: 0.4,
            ..Wind::default()
        };
        assert_eq!(initial_wind_strength(&styled), 1.0);
        let base = base_wind(&styled);
        apply_param(&mut p, &mut strength, &base, Param::Wind, 0.5);
        assert_eq!((p.wind.velocity, p.wind.gust), ([0.0, 0.0, -0.75], 0.2));
    }
}
