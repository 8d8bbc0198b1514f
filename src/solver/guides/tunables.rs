//! The guide model's tunables (Chang, Jin, Yu 2002): the static links of §4.1 (stiffness and
//! damping), the strips' break threshold and the contact spring and friction of §4.2, the body
//! friction of §3.3, and the wind.

use crate::solver::tunable::{Tunable, WIND};
use crate::tunable;

/// The guide model's table, in the order the page shows it.
pub const GUIDES: &[Tunable] = &[
    tunable!(
        "link_strength",
        "static link stiffness",
        "s⁻²",
        0.0..=2000.0,
        false,
        "Spring of the static links that keep the hairstyle, per kilogram (Chang §4.1, Eq. 2); \
         0 lets the hair fall freely.",
        get: |t| t.guides.link_strength,
        set: |t, v| t.guides.link_strength = v,
    ),
    tunable!(
        "link_damping",
        "static link damping",
        "s⁻¹",
        0.0..=50.0,
        false,
        "Damping of the static links, per kilogram (Chang §4.1, the universal k_d).",
        get: |t| t.guides.link_damping,
        set: |t, v| t.guides.link_damping = v,
    ),
    tunable!(
        "strip_break",
        "strip break ratio",
        "× rest width",
        1.1..=10.0,
        true,
        "A strip triangle stretched wider than this many times its rest width is broken while \
         it stays so (Chang §4.2, reversible).",
        get: |t| t.guides.strip_break,
        set: |t, v| t.guides.strip_break = v,
    ),
    tunable!(
        "contact_stiffness",
        "contact stiffness",
        "s⁻²",
        0.0..=6000.0,
        false,
        "Repulsive spring of a hair–hair contact, per kilogram (Chang §4.2).",
        get: |t| t.guides.contact_stiffness,
        set: |t, v| t.guides.contact_stiffness = v,
    ),
    tunable!(
        "contact_friction",
        "contact friction",
        "s⁻¹",
        0.0..=100.0,
        false,
        "Viscous friction on the tangential relative motion of a contact (Chang §4.2).",
        get: |t| t.guides.contact_friction,
        set: |t, v| t.guides.contact_friction = v,
    ),
    tunable!(
        "body_friction",
        "body friction",
        "fraction",
        0.0..=1.0,
        false,
        "Fraction of a body-contact vertex's sliding removed per sub-step (Chang §3.3).",
        get: |t| t.guides.body_friction,
        set: |t, v| t.guides.body_friction = v,
    ),
    WIND,
];
