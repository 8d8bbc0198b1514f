//! Checks of the `layered:` style section (plain data in `style::layered_section`) and the
//! defaults that depend on the style's link: the layered solver owns the rules.

pub use crate::style::layered_section::LayeredParams;

/// Stiffness used when the style gives none: stiff for straight (rigid-link) hair, soft for
/// curly (spring-link) hair (§3.2, §6: wavy wisps use "the same wisp sections, simply reducing
/// the stiffness of the skeletal springs").
pub fn default_stiffness(link: &crate::style::Link) -> f64 {
    match link {
        crate::style::Link::Rigid { .. } => 1e5,
        crate::style::Link::Spring { .. } => 2e4,
    }
}

impl LayeredParams {
    /// Checks every value; returns the dotted field path (`layered.rate`) and the reason.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let f = |name: &str| format!("layered.{name}");
        let pos = |v: f64, name: &str| -> Result<(), (String, String)> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((f(name), format!("must be a positive number, got {v}")))
            }
        };
        let nonneg = |v: f64, name: &str| -> Result<(), (String, String)> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err((f(name), format!("must be zero or positive, got {v}")))
            }
        };
        pos(self.rate, "rate")?;
        if self.rate > 100_000.0 {
            return Err((f("rate"), format!("at most 100000 Hz, got {}", self.rate)));
        }
        pos(self.body_rate, "body_rate")?;
        pos(self.interaction_rate, "interaction_rate")?;
        for (v, n) in [
            (self.body_rate, "body_rate"),
            (self.interaction_rate, "interaction_rate"),
        ] {
            if v > self.rate {
                return Err((
                    f(n),
                    format!(
                        "must not exceed the integration rate {} Hz, got {v}",
                        self.rate
                    ),
                ));
            }
        }
        if let Some(k) = self.stiffness {
            pos(k, "stiffness")?;
            // Explicit Euler on a chain: stable while 2·sqrt(k)·dt < 2 (k per kilogram).
            if 4.0 * k / (self.rate * self.rate) >= 4.0 {
                return Err((
                    f("stiffness"),
                    format!(
                        "explicit Euler at {} Hz is unstable above {} s⁻², got {k}",
                        self.rate,
                        self.rate * self.rate
                    ),
                ));
            }
        }
        nonneg(self.damping, "damping")?;
        nonneg(self.bending, "bending")?;
        nonneg(self.bending_damping, "bending_damping")?;
        pos(self.envelope_mass, "envelope_mass")?;
        if self.envelope_mass > 1.0 {
            return Err((
                f("envelope_mass"),
                format!(
                    "an envelope point weighs at most its skeleton point, got {}",
                    self.envelope_mass
                ),
            ));
        }
        nonneg(self.envelope_stiffness, "envelope_stiffness")?;
        nonneg(self.ring_stiffness, "ring_stiffness")?;
        nonneg(self.envelope_damping, "envelope_damping")?;
        if !(0.0..=90.0).contains(&self.interpenetration_angle) {
            return Err((
                f("interpenetration_angle"),
                format!(
                    "must be between 0 and 90 degrees, got {}",
                    self.interpenetration_angle
                ),
            ));
        }
        nonneg(self.viscosity, "viscosity")?;
        nonneg(self.body_threshold, "body_threshold")?;
        nonneg(self.body_friction, "body_friction")?;
        if !(0.0..=1.0).contains(&self.jitter) {
            return Err((
                f("jitter"),
                format!("must be in [0, 1], got {}", self.jitter),
            ));
        }
        Ok(())
    }
}
