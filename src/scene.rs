//! The one scene loader: a style (built-in name or path), a motion and a model choice become a
//! ready [`Solver`]. Every command, example, bench and test builds its simulation here.

use std::sync::Arc;

use nalgebra::Point3;

use crate::model::HairModel;
use crate::motion::Motion;
use crate::solver::{Solver, SolverKind};
use std::path::Path;

use crate::style::builtin::{builtin, StyleSource};
use crate::style::{LoadedStyle, SimParams, StyleError};

/// A loaded style, its model, the motion and the solver choice: everything a run is built
/// from. Cheap to clone (the model is shared).
#[derive(Clone)]
pub struct Scene {
    /// Where the style came from (a file is watched while live; a built-in name is not).
    pub source: StyleSource,
    /// The parsed and validated style.
    pub loaded: LoadedStyle,
    /// The model built from it, shared by every solver of the scene.
    pub model: Arc<HairModel>,
    /// The `--motion` argument, kept to rebuild the motion on a reloaded model.
    pub motion_spec: String,
    /// The motion.
    pub motion: Motion,
    /// Which hair model [`Scene::solver`] builds.
    pub solver: SolverKind,
}

impl Scene {
    /// Loads the style named or pointed to by `style`, builds its model and parses the motion.
    /// The errors keep their `StyleError`/`MotionError` roots, so the command exits with code 2.
    pub fn load(style: &str, motion: &str, solver: SolverKind) -> anyhow::Result<Scene> {
        Self::load_source(StyleSource::parse(style), motion, solver)
    }

    /// Like [`Scene::load`], from a parsed source.
    pub fn load_source(
        source: StyleSource,
        motion: &str,
        solver: SolverKind,
    ) -> anyhow::Result<Scene> {
        let (loaded, model) = load_model(&source)?;
        Self::from_model(source, loaded, model, motion, solver)
    }

    /// A scene on an already built model (a reloaded style file).
    pub fn from_model(
        source: StyleSource,
        loaded: LoadedStyle,
        model: HairModel,
        motion: &str,
        solver: SolverKind,
    ) -> anyhow::Result<Scene> {
        let motion_parsed = Motion::parse(motion, Point3::from(model.scalp_center))?;
        Ok(Scene {
            source,
            loaded,
            model: Arc::new(model),
            motion_spec: motion.to_owned(),
            motion: motion_parsed,
            solver,
        })
    }

    /// The same scene with another solver.
    pub fn with_solver(&self, solver: SolverKind) -> Scene {
        Scene {
            solver,
            ..self.clone()
        }
    }

    /// The same scene under another motion (a preset name or a keyframed `.ron` file).
    pub fn with_motion(&self, spec: &str) -> anyhow::Result<Scene> {
        Ok(Scene {
            motion_spec: spec.to_owned(),
            motion: Motion::parse(spec, Point3::from(self.model.scalp_center))?,
            ..self.clone()
        })
    }

    /// A fresh solver with the style's own parameters.
    pub fn solver(&self) -> Box<dyn Solver> {
        self.solver_with(&self.loaded.style.sim)
    }

    /// A fresh solver with parameters other than the style's (a restart keeps the tuned ones).
    pub fn solver_with(&self, params: &SimParams) -> Box<dyn Solver> {
        match self.solver {
            SolverKind::Awt | SolverKind::SingleLevel => Box::new(self.awt_with(params)),
            SolverKind::Layered => Box::new(crate::solver::layered::LayeredSolver::new(
                self.model.clone(),
                self.motion.clone(),
                params,
                &self.loaded.style,
            )),
            SolverKind::Guides => Box::new(crate::solver::guides::GuideSolver::new(
                self.model.clone(),
                self.motion.clone(),
                params.clone(),
                self.loaded.style.guides.clone(),
            )),
        }
    }

    /// The AWT (or its single-level mode, as [`Scene::solver`] chooses) as its concrete type,
    /// for tests and benches that look inside it.
    pub fn awt(&self) -> crate::solver::awt::Simulation {
        self.awt_with(&self.loaded.style.sim)
    }

    fn awt_with(&self, params: &SimParams) -> crate::solver::awt::Simulation {
        crate::solver::awt::Simulation::with_params(
            self.model.clone(),
            self.motion.clone(),
            self.solver == SolverKind::SingleLevel,
            Some(crate::solver::awt::Tunables {
                params: params.clone(),
                link: self.loaded.style.link.clone(),
            }),
        )
    }

    /// The display name: the style's name, else the file stem.
    pub fn style_name(&self) -> String {
        style_name(&self.loaded)
    }

    /// Length of one displayed frame, s.
    pub fn frame_dt(&self) -> f64 {
        let p = &self.loaded.style.sim;
        p.dt * p.steps_per_frame.max(1) as f64
    }

    /// Frames of `seconds` simulated time (at least one).
    pub fn frames_for(&self, seconds: f64) -> u64 {
        ((seconds / self.frame_dt()).round() as u64).max(1)
    }

    /// Where the camera looks: the middle of the range the scalp centre sweeps during the first
    /// seconds of the motion, so a motion that carries the head away (lean: 35° about the
    /// hips, a third of a metre) stays in view instead of leaving the frame on one side.
    pub fn camera_target(&self) -> [f32; 3] {
        let rest = Point3::from(self.model.scalp_center);
        let (mut lo, mut hi) = (rest.coords, rest.coords);
        for k in 0..=50 {
            let p = self.motion.pose(k as f64 * 0.1).transform_point(&rest);
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let c = (lo + hi) * 0.5;
        [c.x as f32, c.y as f32, c.z as f32]
    }
}

/// Reads a style and builds its model: the one way every command reads a style.
pub fn load_model(source: &StyleSource) -> Result<(LoadedStyle, HairModel), StyleError> {
    let loaded = source.load()?;
    let text = match source {
        StyleSource::Builtin(name) => builtin(name).map(|b| b.text.to_owned()),
        StyleSource::File(p) => std::fs::read_to_string(p).ok(),
    };
    check_sections(&loaded, text.as_deref())?;
    let model = HairModel::from_style(&loaded)?;
    Ok((loaded, model))
}

/// Reads and checks a style file, the solvers' sections included (as [`load_model`] does).
pub fn load_style(path: &Path) -> Result<LoadedStyle, StyleError> {
    let loaded = crate::style::load(path)?;
    check_sections(&loaded, std::fs::read_to_string(path).ok().as_deref())?;
    Ok(loaded)
}

/// Parses and checks style text, the solvers' sections included; `path` names it in errors.
pub fn parse_style(path: &Path, text: &str) -> Result<LoadedStyle, StyleError> {
    let loaded = crate::style::parse(path, text)?;
    check_sections(&loaded, Some(text))?;
    Ok(loaded)
}

/// The `layered:` and `guides:` sections by their solvers' rules ([`crate::solver::check_sections`]),
/// as an error naming the file, line and field.
fn check_sections(loaded: &LoadedStyle, text: Option<&str>) -> Result<(), StyleError> {
    crate::solver::check_sections(&loaded.style)
        .map_err(|(field, msg)| crate::style::field_error(&loaded.path, text, &field, msg))
}

/// The display name of a loaded style: its `name`, else the file stem.
pub fn style_name(l: &LoadedStyle) -> String {
    if l.style.name.is_empty() {
        l.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    } else {
        l.style.name.clone()
    }
}

impl Scene {
    /// What the user should know about the scene before it runs (roots or rest nodes inside a
    /// collision sphere, …); see [`warnings`].
    pub fn warnings(&self) -> Vec<String> {
        warnings(&self.model)
    }
}

/// Strand roots and rest nodes that start inside a body sphere, per sphere: how many, and by
/// how much at most. Imported hair often has them (its collision spheres were fitted for
/// another solver). What then happens, as measured (`tests/real_data.rs`): a wisp root
/// (cross-section 0 of a GC, on any level) is fixed to the head and stays inside for the whole
/// run, as deep as it started; the body pushes every other node out, the AWT at its first step,
/// the layered model within its first frames.
pub fn warnings(model: &HairModel) -> Vec<String> {
    let mut out = Vec::new();
    let k = model.k;
    if let Some(w) = scalp_warning(model) {
        out.push(w);
    }
    for (si, sp) in model.body.iter().enumerate() {
        let c = nalgebra::Vector3::from(sp.center);
        let depth = |p: &nalgebra::Vector3<f64>| sp.radius - (p - c).norm();
        let (mut roots, mut root_depth) = (0usize, 0.0f64);
        for s in 0..model.strands.len() {
            let d = depth(&model.strands.rest[s * k]);
            if d > 0.0 {
                roots += 1;
                root_depth = root_depth.max(d);
            }
        }
        let (mut nodes, mut node_depth) = (0usize, 0.0f64);
        let (mut wisp_roots, mut wisp_root_depth) = (0usize, 0.0f64);
        for lv in &model.levels {
            for (j, p) in lv.rest_pos.iter().enumerate() {
                let d = depth(p);
                if d > 0.0 {
                    nodes += 1;
                    node_depth = node_depth.max(d);
                    if j % k == 0 {
                        wisp_roots += 1;
                        wisp_root_depth = wisp_root_depth.max(d);
                    }
                }
            }
        }
        let at = format!(
            "body sphere {si} (centre ({:.3}, {:.3}, {:.3}) m, radius {:.3} m)",
            sp.center[0], sp.center[1], sp.center[2], sp.radius
        );
        if roots > 0 {
            out.push(format!(
                "{roots} of {} strand roots are inside {at}, by up to {:.1} mm",
                model.strands.len(),
                root_depth * 1e3
            ));
        }
        if nodes > 0 {
            let others = nodes - wisp_roots;
            let fate = match (wisp_roots, others) {
                (0, _) => "none is a wisp root: the body pushes them out (the AWT at its first \
                           step, the layered model within its first frames)"
                    .to_owned(),
                (r, 0) => format!(
                    "all {r} are wisp roots (cross-section 0), fixed to the head: they stay \
                     inside for the whole run"
                ),
                (r, o) => format!(
                    "{r} of them are wisp roots (cross-section 0), fixed to the head, which stay \
                     inside, by up to {:.1} mm, for the whole run; the body pushes the other {o} \
                     out (the AWT at its first step, the layered model within its first frames)",
                    wisp_root_depth * 1e3
                ),
            };
            out.push(format!(
                "{nodes} rest nodes (all levels) are inside {at}, by up to {:.1} mm: {fate}",
                node_depth * 1e3
            ));
        }
    }
    out.extend(crate::model::body::warnings(model));
    out
}

/// Roots this far from the scalp's surface (median) mean the scalp is not on this hair's head:
/// a real scalp is within a few centimetres of every root.
pub const FAR_FROM_SCALP: f64 = 0.1;

/// A warning when the strands' roots lie far from the scalp (the motion's pivot, the viewer's
/// head): imported hair with the default scalp, 1.5 m above a USC-HairSalon head.
fn scalp_warning(model: &HairModel) -> Option<String> {
    let roots = (0..model.strands.len()).map(|s| model.strands.rest[s * model.k]);
    let d =
        crate::style::scalp::median_root_distance(&model.scalp_center, &model.scalp_radii, roots)?;
    (d > FAR_FROM_SCALP).then(|| {
        let c = model.scalp_center;
        format!(
            "half of the strand roots lie more than {d:.2} m from the scalp (centre ({:.3}, \
             {:.3}, {:.3}) m): the motion turns the hair about that far-away head, and the \
             viewer draws the head there. Set head.scalp on the hair's head, or use \
             head: (fit_body: true) without a scalp to place it on the fitted head",
            c.x, c.y, c.z
        )
    })
}

impl Scene {
    /// The box the hair sweeps during the first seconds of the motion, world metres: every
    /// seventh strand's rest points carried by the head's pose every quarter second for 5 s.
    /// The renderer's camera and the 3D view's starting eye both frame it.
    pub fn hair_extent(&self) -> ([f32; 3], [f32; 3]) {
        let m = &self.model;
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for q in 0..=20 {
            let pose = self.motion.pose(q as f64 * 0.25);
            for (j, p) in m.strands.rest.iter().enumerate() {
                if !(j / m.k).is_multiple_of(7) {
                    continue;
                }
                let w = pose.transform_point(&nalgebra::Point3::from(*p));
                for a in 0..3 {
                    lo[a] = lo[a].min(w[a] as f32);
                    hi[a] = hi[a].max(w[a] as f32);
                }
            }
        }
        if !lo[0].is_finite() {
            let c = self.camera_target();
            return (c, c);
        }
        (lo, hi)
    }
}
