//! A saved edit of the watched style file, turned into what the simulation thread must do.
//!
//! What counts as a parameter and what as geometry: the style's `sim` section is tunable in
//! place, except `total_mass` (the model's node masses are built from it), and so are the values
//! of the `layered:` and `guides:` sections that their solvers' tables of tunables list. The
//! head, the hair, the hierarchy, the link, the seed and the other values of those sections
//! describe the model itself (or are read when a solver is built): a change there needs a new
//! model and a restart.

use crossbeam_channel::Sender;

use std::path::Path;

use super::console::Console;
use super::sim_thread::Control;
use crate::model::HairModel;
use crate::scene::Scene;
use crate::solver::tunable::Tuning;
use crate::solver::SolverKind;
use crate::stream::MessageLevel;
use crate::style::{LoadedStyle, SimParams, Style, StyleError};

/// What a new version of the style file means for a running simulation.
#[derive(Debug)]
pub enum StyleChange {
    /// Same model and same parameters (an editor touched the file, or only comments changed).
    Unchanged,
    /// Only tunable parameters changed: apply them in place, keep the hair's state.
    Params(Box<LoadedStyle>),
    /// The model itself changed: the new style and its freshly built model; restart.
    Geometry(Box<(LoadedStyle, HairModel)>),
    /// The edit does not load or build: keep everything as it is and show the error.
    Invalid(StyleError),
}

/// Whether going from `old` to `new` needs a new model (and so a restart) rather than new
/// parameters. The display name does not count.
pub fn geometry_changed(old: &Style, new: &Style) -> bool {
    old.seed != new.seed
        || old.head != new.head
        || old.hair != new.hair
        || old.hierarchy != new.hierarchy
        || old.link != new.link
        // Node masses are built from the total mass.
        || old.sim.total_mass != new.sim.total_mass
        || model_sections_changed(old, new)
}

/// The tunables of the `layered:` and `guides:` sections (the `sim:` section is applied whole).
fn section_tunables() -> impl Iterator<Item = &'static crate::solver::tunable::Tunable> {
    [SolverKind::Layered, SolverKind::Guides]
        .into_iter()
        .flat_map(|k| k.tunables())
        .filter(|t| t.name != crate::solver::tunable::WIND.name)
}

/// Whether the `layered:` or `guides:` section changed in a value that no table of tunables
/// lists (such values are read when a solver is built).
fn model_sections_changed(old: &Style, new: &Style) -> bool {
    let target = Tuning::of(new);
    let mut probe = Tuning::of(old);
    for t in section_tunables() {
        (t.set)(&mut probe, t.value(&target));
    }
    probe.layered != target.layered || probe.guides != target.guides
}

/// Reads `path` again and says what changed relative to `current`. A model is built only when
/// the geometry changed (and then with the same code as every command: `style::load` +
/// `HairModel::from_style`, as in `cli::load_model`).
pub fn reload(path: &Path, current: &Style) -> StyleChange {
    let loaded = match crate::scene::load_style(path) {
        Ok(l) => l,
        Err(e) => return StyleChange::Invalid(e),
    };
    if geometry_changed(current, &loaded.style) {
        return match HairModel::from_style(&loaded) {
            Ok(model) => StyleChange::Geometry(Box::new((loaded, model))),
            Err(e) => StyleChange::Invalid(e),
        };
    }
    if Tuning::of(&loaded.style) == Tuning::of(current) {
        StyleChange::Unchanged
    } else {
        StyleChange::Params(Box::new(loaded))
    }
}

/// The names and values of the parameters that differ, `name old → new`, for the log.
pub fn describe_changes(old: &Style, new: &Style) -> String {
    describe_param_changes(&old.sim, &new.sim, &Tuning::of(old), &Tuning::of(new))
}

/// The tunables of the layered and guide sections that differ, `name old → new`.
fn describe_section_changes(old: &Tuning, new: &Tuning) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for t in section_tunables() {
        let (a, b) = (t.value(old), t.value(new));
        let line = format!("{} {a} → {b}", t.name);
        if a != b && !out.contains(&line) {
            out.push(line);
        }
    }
    out
}

/// See [`describe_changes`].
fn describe_param_changes(
    old: &SimParams,
    new: &SimParams,
    old_t: &Tuning,
    new_t: &Tuning,
) -> String {
    let mut parts = Vec::new();
    let mut num = |name: &str, a: f64, b: f64| {
        if a != b {
            parts.push(format!("{name} {a} → {b}"));
        }
    };
    num("split_threshold", old.split_threshold, new.split_threshold);
    num("merge_velocity", old.merge_velocity, new.merge_velocity);
    num("friction", old.friction, new.friction);
    num("repulsion", old.repulsion, new.repulsion);
    num("angle_threshold", old.angle_threshold, new.angle_threshold);
    num("dt", old.dt, new.dt);
    num(
        "steps_per_frame",
        old.steps_per_frame as f64,
        new.steps_per_frame as f64,
    );
    num("air_drag", old.air_drag, new.air_drag);
    num("bending", old.bending, new.bending);
    num("contact_epsilon", old.contact_epsilon, new.contact_epsilon);
    num("settle", old.settle, new.settle);
    num("accel_smoothing", old.accel_smoothing, new.accel_smoothing);
    if old.gravity != new.gravity {
        parts.push(format!("gravity {:?} → {:?}", old.gravity, new.gravity));
    }
    if old.wind != new.wind {
        parts.push("wind".to_owned());
    }
    parts.extend(describe_section_changes(old_t, new_t));
    if parts.is_empty() {
        "no parameter changed".to_owned()
    } else {
        parts.join(", ")
    }
}

/// Reads the watched style again and tells the simulation thread what to do: new parameters in
/// place, or a restart on a new model; an edit that does not load is reported and ignored.
/// Returns whether new parameters were applied in place.
pub fn handle_reload(
    scene: &mut Scene,
    file_style: &mut LoadedStyle,
    ctl: &Sender<Control>,
    notes: &Sender<(MessageLevel, String)>,
    console: &Console,
) -> bool {
    let path = file_style.path.clone();
    let warn = |msg: String| {
        console.say(&format!("warning: {msg}"));
        let _ = notes.send((MessageLevel::Warn, msg));
    };
    match reload(&path, &file_style.style) {
        StyleChange::Unchanged => {}
        StyleChange::Params(new) => {
            let msg = format!(
                "{}: applied {}",
                path.display(),
                describe_changes(&file_style.style, &new.style)
            );
            let _ = ctl.send(Control::Params(Box::new(Tuning::of(&new.style)), msg));
            *file_style = *new;
            return true;
        }
        StyleChange::Geometry(b) => {
            let (loaded, model) = *b;
            match Scene::from_model(
                scene.source.clone(),
                loaded.clone(),
                model,
                &scene.motion_spec,
                scene.solver,
            ) {
                Ok(new_scene) => {
                    let msg = format!(
                        "{}: the model changed (head, hair, hierarchy, link, seed, total mass or a model section); restarting the simulation",
                        path.display()
                    );
                    *scene = new_scene.clone();
                    let _ = ctl.send(Control::Rebuild(Box::new(new_scene), msg));
                    *file_style = loaded;
                }
                Err(e) => warn(format!(
                    "{}: not applied, the motion failed: {e}",
                    path.display()
                )),
            }
        }
        StyleChange::Invalid(e) => warn(format!(
            "style edit not applied, keeping the current parameters: {e}"
        )),
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_and_parameters_are_told_apart() {
        let text =
            std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/long.ron"))
                .unwrap();
        let a = crate::style::parse(Path::new("long.ron"), &text)
            .unwrap()
            .style;
        let mut b = a.clone();
        b.sim.split_threshold *= 2.0;
        assert!(!geometry_changed(&a, &b));
        b.sim.total_mass *= 2.0;
        assert!(geometry_changed(&a, &b));
        let mut c = a.clone();
        c.hierarchy.levels = 2;
        assert!(geometry_changed(&a, &c));
        let mut d = a.clone();
        d.name = "renamed".into();
        assert!(!geometry_changed(&a, &d));
        // A tunable of a model's section is applied in place; its other values need a restart.
        let mut e = a.clone();
        e.layered.viscosity = 50.0;
        e.guides.link_strength = 900.0;
        assert!(!geometry_changed(&a, &e));
        let msg = describe_changes(&a, &e);
        assert!(
            msg.contains("viscosity 10 → 50") && msg.contains("link_strength 300 → 900"),
            "{msg}"
        );
        let mut f = a.clone();
        f.guides.count = 50;
        assert!(geometry_changed(&a, &f));
        let mut g = a.clone();
        g.layered.level = 0;
        assert!(geometry_changed(&a, &g));
    }
}
