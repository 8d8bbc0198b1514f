//! A saved edit of the watched style file, turned into what the simulation thread must do.

use crossbeam_channel::Sender;

use super::console::Console;
use super::run::RunSummary;
use super::sim_thread::Control;
use super::tune::{self, StyleChange};
use crate::scene::Scene;
use crate::stream::MessageLevel;
use crate::style::LoadedStyle;

/// Reads the watched style again and tells the simulation thread what to do: new parameters in
/// place, or a restart on a new model; an edit that does not load is reported and ignored.
pub fn handle_reload(
    scene: &mut Scene,
    file_style: &mut LoadedStyle,
    ctl: &Sender<Control>,
    notes: &Sender<(MessageLevel, String)>,
    console: &Console,
    summary: &mut RunSummary,
) {
    let path = file_style.path.clone();
    let warn = |msg: String| {
        console.say(&format!("warning: {msg}"));
        let _ = notes.send((MessageLevel::Warn, msg));
    };
    match tune::reload(&path, &file_style.style) {
        StyleChange::Unchanged => {}
        StyleChange::Params(new) => {
            let msg = format!(
                "{}: applied {}",
                path.display(),
                tune::describe_param_changes(&file_style.style.sim, &new.style.sim)
            );
            let _ = ctl.send(Control::Params(Box::new(new.style.sim.clone()), msg));
            *file_style = *new;
            summary.reloads += 1;
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
}
