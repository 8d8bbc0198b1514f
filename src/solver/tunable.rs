//! What a user may change while the hair moves: each solver declares its tunables once, in one
//! table ([`Tunable`]: name, label, unit, range, scale, doc, and how to read and write the
//! value). The control page's sliders, the keys, the style reload, the `/params/<name>` plots,
//! the bench's JSON and `sweep --set` all read that table; nothing else spells a tunable.
//!
//! Adding a tunable to a solver is one entry in its table (and the solver code that reads the
//! value).

use serde::Serialize;

use crate::style::{GuideParams, LayeredParams, SimParams, Style};

/// The style sections a solver's behaviour is set by: what the tunables read and write.
/// A solver gives the values in force ([`super::Solver::tuning`]); the sections it does not
/// read are their defaults.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tuning {
    /// The `sim:` section (the AWT's parameters, and the gravity, drag and wind of all).
    pub sim: SimParams,
    /// The `layered:` section.
    pub layered: LayeredParams,
    /// The `guides:` section.
    pub guides: GuideParams,
}

impl Tuning {
    /// The sections of `style`.
    pub fn of(style: &Style) -> Tuning {
        Tuning {
            sim: style.sim.clone(),
            layered: style.layered.clone(),
            guides: style.guides.clone(),
        }
    }

    /// Writes these sections into `style`.
    pub fn write_into(&self, style: &mut Style) {
        style.sim = self.sim.clone();
        style.layered = self.layered.clone();
        style.guides = self.guides.clone();
    }
}

/// A bound on a value that depends on the other values in force: the value must stay below
/// the first number, for the reason given.
pub type Below = fn(&Tuning) -> (f64, &'static str);

/// One tunable parameter of a solver.
#[derive(Clone, Copy)]
pub struct Tunable {
    /// The name in requests, in `sweep --set`, in the bench's JSON and in the recording
    /// (`/params/<name>`): the style field's own name where there is one (`split_threshold`).
    pub name: &'static str,
    /// What the page shows beside the slider.
    pub label: &'static str,
    /// The unit shown after the value.
    pub unit: &'static str,
    /// Smallest value a user may set.
    pub min: f64,
    /// Largest value a user may set.
    pub max: f64,
    /// The slider moves on a log scale.
    pub log: bool,
    /// One sentence: what it does, citing the paper.
    pub doc: &'static str,
    /// Its value in `t`.
    pub get: fn(&Tuning) -> f64,
    /// Sets it in `t` (the value already checked).
    pub set: fn(&mut Tuning, f64),
    /// A bound that depends on other values (friction's α·dt < 1).
    pub below: Option<Below>,
}

impl std::fmt::Debug for Tunable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tunable")
            .field("name", &self.name)
            .field("min", &self.min)
            .field("max", &self.max)
            .finish_non_exhaustive()
    }
}

/// A table entry: `tunable!(name, label, unit, min..=max, log, doc, get: |t| …, set: |t, v| …)`,
/// with an optional `below: |t| (limit, why)`.
#[macro_export]
macro_rules! tunable {
    ($name:literal, $label:expr, $unit:expr, $min:literal ..= $max:literal, $log:expr, $doc:expr,
     get: $get:expr, set: $set:expr $(, below: $below:expr)? $(,)?) => {
        $crate::solver::tunable::Tunable {
            name: $name,
            label: $label,
            unit: $unit,
            min: $min,
            max: $max,
            log: $log,
            doc: $doc,
            get: $get,
            set: $set,
            below: $crate::tunable!(@below $($below)?),
        }
    };
    (@below) => { None };
    (@below $b:expr) => { Some($b) };
}

/// The wind's strength, shared by every solver's table (every model feels the style's wind).
pub const WIND: Tunable = crate::tunable!(
    "wind",
    "wind strength",
    "×",
    0.0..=5.0,
    false,
    "A factor on the style's wind (velocity and gusts); for a style without wind, the wind \
     speed in m/s along +x.",
    get: |t| t.sim.wind.strength(),
    set: |t, v| t.sim.wind.set_strength(v),
);

/// The entry named `name` in `table`.
pub fn find<'a>(table: &'a [Tunable], name: &str) -> Option<&'a Tunable> {
    table.iter().find(|t| t.name == name)
}

/// `a, b, c`: the names of a table, for messages.
pub fn names(table: &[Tunable]) -> String {
    table.iter().map(|t| t.name).collect::<Vec<_>>().join(", ")
}

impl Tunable {
    /// Its value in `t`.
    pub fn value(&self, t: &Tuning) -> f64 {
        (self.get)(t)
    }

    /// Whether `v` may be set with `t` in force; the error is the message a user reads.
    pub fn check(&self, t: &Tuning, v: f64) -> Result<(), String> {
        // One set of rules: the page checks against the view it was shown.
        self.view(t).check(v)
    }

    /// Checks `v` and sets it in `t`; returns the value it replaced.
    pub fn apply(&self, t: &mut Tuning, v: f64) -> Result<f64, String> {
        self.check(t, v)?;
        let old = (self.get)(t);
        (self.set)(t, v);
        Ok(old)
    }

    /// `label old → new unit`, for the log.
    pub fn describe_change(&self, old: f64, new: f64) -> String {
        format!("{} {old:.4} → {new:.4} {}", self.label, self.unit)
    }

    /// What the page shows of it with `t` in force.
    pub fn view(&self, t: &Tuning) -> TunableView {
        let (below, below_reason) = match self.below {
            Some(b) => {
                let (v, why) = b(t);
                (Some(v), Some(why))
            }
            None => (None, None),
        };
        TunableView {
            name: self.name,
            label: self.label,
            unit: self.unit,
            min: self.min,
            max: self.max,
            log: self.log,
            doc: self.doc,
            value: (self.get)(t),
            below,
            below_reason,
        }
    }
}

/// A tunable as the page sees it: its table entry and its value in force.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TunableView {
    /// See [`Tunable::name`].
    pub name: &'static str,
    /// See [`Tunable::label`].
    pub label: &'static str,
    /// See [`Tunable::unit`].
    pub unit: &'static str,
    /// See [`Tunable::min`].
    pub min: f64,
    /// See [`Tunable::max`].
    pub max: f64,
    /// See [`Tunable::log`].
    pub log: bool,
    /// See [`Tunable::doc`].
    pub doc: &'static str,
    /// The value in force.
    pub value: f64,
    /// The bound from the other values in force, if it has one.
    pub below: Option<f64>,
    /// Why that bound.
    pub below_reason: Option<&'static str>,
}

impl TunableView {
    /// Whether `v` may be set: inside the range, and below the bound from the other values in
    /// force. [`Tunable::check`] is this on the view of the values in force.
    pub fn check(&self, v: f64) -> Result<(), String> {
        if !v.is_finite() {
            return Err(format!("{}: `{v}` is not a number", self.label));
        }
        if !(self.min..=self.max).contains(&v) {
            return Err(format!(
                "{} {v} refused: it must be between {} and {} {}",
                self.label, self.min, self.max, self.unit
            ));
        }
        if let Some(limit) = self.below.filter(|l| v >= *l) {
            return Err(format!(
                "{} {v} refused: it must stay below {limit:.4} {}: {}",
                self.label,
                self.unit,
                self.below_reason.unwrap_or_default()
            ));
        }
        Ok(())
    }
}

/// One `NAME=v1,v2,…` of `sweep --set`, checked against `table`: the entry and its values.
/// The error names what is wrong (the caller exits 2).
pub fn parse_assignment<'a>(
    table: &'a [Tunable],
    text: &str,
    solver: &str,
    tuning: &Tuning,
) -> Result<(&'a Tunable, Vec<f64>), String> {
    let (name, values) = text.split_once('=').ok_or_else(|| {
        format!("`{text}`: expected NAME=v1,v2,… (for example split_threshold=0.1,0.2)")
    })?;
    let name = name.trim();
    let t = find(table, name).ok_or_else(|| {
        format!(
            "`{name}` is not a tunable of model {solver} (its tunables: {})",
            names(table)
        )
    })?;
    let mut out = Vec::new();
    for (k, item) in values.split(',').enumerate() {
        let item = item.trim();
        let v: f64 = item
            .parse()
            .map_err(|_| format!("{name}: value {} `{item}` is not a number", k + 1))?;
        t.check(tuning, v).map_err(|e| format!("{name}: {e}"))?;
        out.push(v);
    }
    Ok((t, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TABLE: &[Tunable] = &[
        crate::tunable!(
            "merge_velocity",
            "merge velocity threshold",
            "m/s",
            0.005..=1.0,
            true,
            "test",
            get: |t| t.sim.merge_velocity,
            set: |t, v| t.sim.merge_velocity = v,
        ),
        crate::tunable!(
            "friction",
            "friction α",
            "s⁻¹",
            0.0..=1000.0,
            false,
            "test",
            get: |t| t.sim.friction,
            set: |t, v| t.sim.friction = v,
            below: |t| (1.0 / t.sim.dt, "α·dt < 1"),
        ),
    ];

    #[test]
    fn an_entry_reads_writes_and_checks_its_value() {
        let mut t = Tuning::default();
        let e = find(TABLE, "merge_velocity").unwrap();
        assert_eq!(e.apply(&mut t, 0.25), Ok(0.1));
        assert_eq!(t.sim.merge_velocity, 0.25);
        assert!(e
            .apply(&mut t, 2.0)
            .unwrap_err()
            .contains("between 0.005 and 1"));
        assert!(e
            .apply(&mut t, f64::NAN)
            .unwrap_err()
            .contains("not a number"));
        assert_eq!(
            t.sim.merge_velocity, 0.25,
            "a refused value changes nothing"
        );
        let f = find(TABLE, "friction").unwrap();
        assert!(f.apply(&mut t, 100.0).unwrap_err().contains("α·dt"));
        assert_eq!(f.apply(&mut t, 99.0), Ok(30.0));
        // The page's view applies the same rules.
        let v = f.view(&t);
        assert_eq!((v.value, v.below), (99.0, Some(100.0)));
        assert!(v.check(100.0).is_err() && v.check(50.0).is_ok());
    }

    #[test]
    fn every_tables_defaults_lie_in_range_and_every_entry_writes_what_it_reads() {
        for kind in crate::solver::SolverKind::ALL {
            let table = kind.tunables();
            let mut names: Vec<&str> = table.iter().map(|t| t.name).collect();
            names.dedup();
            assert_eq!(names.len(), table.len(), "{kind}: a name twice");
            for e in table {
                let mut t = Tuning::default();
                let d = e.value(&t);
                assert!(
                    (e.min..=e.max).contains(&d),
                    "{kind} {}: default {d}",
                    e.name
                );
                assert!(
                    e.min < e.max && (!e.log || e.min > 0.0),
                    "{kind} {}",
                    e.name
                );
                // Below any bound from the other values (friction's α·dt < 1).
                let hi = e.below.map_or(e.max, |b| 0.5 * b(&t).0).min(e.max);
                for v in [e.min, 0.5 * (e.min + hi)] {
                    e.apply(&mut t, v).unwrap();
                    assert_eq!(e.value(&t), v, "{kind} {}", e.name);
                }
                // Only its own value moved.
                for other in table.iter().filter(|o| o.name != e.name) {
                    assert_eq!(
                        other.value(&t),
                        other.value(&Tuning::default()),
                        "{kind}: setting {} moved {}",
                        e.name,
                        other.name
                    );
                }
            }
        }
    }

    #[test]
    fn assignments_name_what_is_wrong() {
        let (e, v) =
            parse_assignment(TABLE, "merge_velocity=0.01, 0.5", "awt", &Tuning::default()).unwrap();
        assert_eq!((e.name, v), ("merge_velocity", vec![0.01, 0.5]));
        for (bad, needle) in [
            ("merge_velocity", "NAME=v1"),
            ("gravity=1", "not a tunable of model awt"),
            ("merge_velocity=0.1,fast", "value 2 `fast`"),
            (
                "merge_velocity=5",
                "merge_velocity: merge velocity threshold 5 refused",
            ),
        ] {
            let e = parse_assignment(TABLE, bad, "awt", &Tuning::default()).unwrap_err();
            assert!(e.contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn the_wind_strength_scales_the_styles_wind_and_blows_along_x_without_one() {
        let mut t = Tuning::default();
        assert_eq!(WIND.value(&t), 0.0, "the default style has no wind");
        WIND.apply(&mut t, 2.0).unwrap();
        assert_eq!(
            (t.sim.wind.velocity, WIND.value(&t)),
            ([2.0, 0.0, 0.0], 2.0)
        );
        WIND.apply(&mut t, 0.0).unwrap();
        WIND.apply(&mut t, 1.0).unwrap();
        assert_eq!(t.sim.wind.velocity, [1.0, 0.0, 0.0]);
        let mut styled = Tuning::default();
        styled.sim.wind.velocity = [0.0, 0.0, -1.5];
        styled.sim.wind.gust = 0.4;
        assert_eq!(WIND.value(&styled), 1.0);
        WIND.apply(&mut styled, 0.5).unwrap();
        assert_eq!(
            (styled.sim.wind.velocity, styled.sim.wind.gust),
            ([0.0, 0.0, -0.75], 0.2)
        );
        WIND.apply(&mut styled, 0.0).unwrap();
        WIND.apply(&mut styled, 2.0).unwrap();
        assert_eq!(
            styled.sim.wind.velocity,
            [0.0, 0.0, -3.0],
            "the direction survives 0"
        );
    }
}
