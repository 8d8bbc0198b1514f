//! The solver trait: what `run`, `bench`, frame building and the tests drive, whichever hair
//! model is simulated.
//!
//! A solver owns the state of one hair model under one motion. It knows nothing of threads,
//! Rerun or the renderer: it steps, reports what happened ([`StepReport`]: events, counters,
//! named stats), draws its debug primitives into a [`Frame`], and gives the points of every
//! strand of the model so that the pipeline can smooth them for display and rendering.
//!
//! The solvers:
//!
//! | [`SolverKind`] | paper | module |
//! |---|---|---|
//! | `awt` | Bertails, Kim, Cani, Neumann 2003, *Adaptive Wisp Tree* | [`awt`] |
//! | `single-level` | the same, every finest node active, no adaptation (its §5.2) | [`awt`] |
//! | `layered` | Plante, Cani, Poulin 2002, *Capturing the Complexity of Hair Motion* | [`layered`] |
//! | `guides` | Chang, Jin, Yu 2002, *A practical model for hair mutual interactions* | [`guides`] |

pub mod body;
pub mod common;
pub mod guides;
pub mod layered;
pub mod tunable;

use std::sync::Arc;

use nalgebra::Vector3;

use crate::frame::Frame;
use crate::model::HairModel;
use crate::motion::Pose;
use crate::style::{SimParams, Style};
use tunable::{Tunable, Tuning};

pub mod awt;

pub use crate::report::{AdaptEvent, Aggregate, Counters, EventKind, Stat, StepReport};
pub use awt::inspect::NodeId;

/// Which hair model a run simulates (`--model`, `bench --solvers`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SolverKind {
    /// The Adaptive Wisp Tree: wisps split and merge (AWT §3).
    Awt,
    /// The AWT with every finest node active and no adaptation (the AWT paper's §5.2
    /// comparison).
    SingleLevel,
    /// The layered wisp model (Plante, Cani, Poulin 2002): skeleton, envelope, anisotropic
    /// interactions.
    Layered,
    /// Guide strands as multibody chains with static links and triangle strips (Chang, Jin,
    /// Yu 2002).
    Guides,
}

impl SolverKind {
    /// Every solver, in the order `--help` lists them.
    pub const ALL: &'static [SolverKind] = &[
        SolverKind::Awt,
        SolverKind::SingleLevel,
        SolverKind::Layered,
        SolverKind::Guides,
    ];

    /// The name on the command line and in the bench's JSON.
    pub fn name(self) -> &'static str {
        match self {
            SolverKind::Awt => "awt",
            SolverKind::SingleLevel => "single-level",
            SolverKind::Layered => "layered",
            SolverKind::Guides => "guides",
        }
    }

    /// The entity path segment of its primitives: `/hair/<segment>/nodes`. Single-level is a
    /// mode of the AWT and draws where the AWT does.
    pub fn path_segment(self) -> &'static str {
        match self {
            SolverKind::Awt | SolverKind::SingleLevel => "awt",
            SolverKind::Layered => "layered",
            SolverKind::Guides => "guides",
        }
    }

    /// One line for `--help` and error messages.
    pub fn describe(self) -> &'static str {
        match self {
            SolverKind::Awt => "Adaptive Wisp Tree (Bertails et al. 2003): wisps split and merge",
            SolverKind::SingleLevel => "the AWT with every finest node active, no adaptation",
            SolverKind::Layered => {
                "layered wisps (Plante, Cani, Poulin 2002): skeleton, envelope, anisotropic interactions"
            }
            SolverKind::Guides => {
                "guide strands (Chang, Jin, Yu 2002): multibody chains, static links, triangle strips"
            }
        }
    }

    /// The kind named `s` (case-sensitive, as listed by [`SolverKind::names`]).
    pub fn parse(s: &str) -> Result<SolverKind, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown model `{s}` (expected one of: {})", Self::names()))
    }

    /// Its one table of tunables: what a user may change while it runs.
    pub fn tunables(self) -> &'static [Tunable] {
        match self {
            SolverKind::Awt => awt::tunables::AWT,
            SolverKind::SingleLevel => awt::tunables::SINGLE_LEVEL,
            SolverKind::Layered => layered::tunables::LAYERED,
            SolverKind::Guides => guides::tunables::GUIDES,
        }
    }

    /// `awt, single-level, …`.
    pub fn names() -> String {
        Self::ALL
            .iter()
            .map(|k| k.name())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The settling of every solver (AWT §2.3: the animation starts from hair "often at rest"): the
/// hair hangs under gravity in the starting pose for `seconds`, `round(seconds / dt)` calls of
/// `step` with one report reused. Returns the steps taken; the caller marks itself settling
/// around it and starts from rest after it.
pub fn settle_steps(seconds: f64, dt: f64, mut step: impl FnMut(&mut StepReport)) -> usize {
    let steps = (seconds / dt).round() as usize;
    let mut report = StepReport::default();
    for _ in 0..steps {
        step(&mut report);
    }
    steps
}

/// The [`Solver`] getters that are the same for every solver struct holding its `model`,
/// simulated `time`, `pose` and `params` as fields of those names.
macro_rules! state_getters {
    () => {
        fn model(&self) -> &std::sync::Arc<crate::model::HairModel> {
            &self.model
        }

        fn time(&self) -> f64 {
            self.time
        }

        fn pose(&self) -> &crate::motion::Pose {
            &self.pose
        }

        fn params(&self) -> &crate::style::SimParams {
            &self.params
        }
    };
}
pub(crate) use state_getters;

/// Checks the style's sections of the layered and guide models by their solvers' rules; the
/// dotted field path and the reason. Every loader above the solvers calls it (`scene`), so a
/// bad value stops a command before it runs, whichever model it picks.
pub fn check_sections(style: &Style) -> Result<(), (String, String)> {
    guides::params::validate(&style.guides)?;
    style.layered.validate()?;
    Ok(())
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SolverKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SolverKind::parse(s)
    }
}

/// One hair model in motion. Everything the pipeline needs, and nothing about how it is shown.
///
/// The call order of one displayed frame is: `steps_per_frame()` times [`Solver::step`], then
/// [`Solver::sync_display`], then [`Solver::draw`] and [`Solver::strand_points`] for the strands
/// shown (any number of times).
pub trait Solver: Send {
    /// Which model this is.
    fn kind(&self) -> SolverKind;

    /// The immutable hair model (strands, GC hierarchy, body) the solver was built from.
    fn model(&self) -> &Arc<HairModel>;

    /// Simulated time, s (0 after construction and any settling).
    fn time(&self) -> f64;

    /// Length of one [`Solver::step`], s.
    fn dt(&self) -> f64;

    /// Steps per displayed frame. A displayed frame lasts `dt() · steps_per_frame()` (40 ms for
    /// every shipped style).
    fn steps_per_frame(&self) -> usize;

    /// Where the head and body are at [`Solver::time`].
    fn pose(&self) -> &Pose;

    /// The tunable parameters in force.
    fn params(&self) -> &SimParams;

    /// Applies new parameters from the next step on; the hair's state is kept. Parameters that
    /// the model does not use are listed by [`Solver::ignored_params`].
    fn set_params(&mut self, params: &SimParams);

    /// Its tunables ([`SolverKind::tunables`]).
    fn tunables(&self) -> &'static [Tunable] {
        self.kind().tunables()
    }

    /// The values in force of everything its tunables read. The sections this model does not
    /// read are their defaults.
    fn tuning(&self) -> Tuning {
        Tuning {
            sim: self.params().clone(),
            ..Tuning::default()
        }
    }

    /// Applies the tunable values of `t` from the next step on; the hair's state is kept.
    fn set_tuning(&mut self, t: &Tuning) {
        self.set_params(&t.sim);
    }

    /// Sets the tunable `name` to `value` (checked against its table entry); returns the
    /// value it replaced. The error is the message a user reads.
    fn set_tunable(&mut self, name: &str, value: f64) -> Result<f64, String> {
        let entry = tunable::find(self.tunables(), name).ok_or_else(|| {
            format!(
                "`{name}` is not a tunable of model {} (its tunables: {})",
                self.kind(),
                tunable::names(self.tunables())
            )
        })?;
        let mut t = self.tuning();
        let old = entry.apply(&mut t, value)?;
        self.set_tuning(&t);
        Ok(old)
    }

    /// Names of the `sim:` fields this model ignores (the pipeline says so once).
    fn ignored_params(&self) -> &'static [&'static str] {
        &[]
    }

    /// A report with room for everything a step writes into it, so that stepping allocates
    /// nothing.
    fn new_report(&self) -> StepReport;

    /// Advances by [`Solver::dt`], writing the step's events, counters and stats into `report`
    /// (cleared first).
    fn step(&mut self, report: &mut StepReport);

    /// Brings derived positions (followed nodes, dense strands) up to date with the last step.
    /// Call before [`Solver::draw`] and [`Solver::strand_points`].
    fn sync_display(&mut self);

    /// Which strands the display will read with [`Solver::strand_points`] after the coming
    /// [`Solver::sync_display`]s: `Some(list)`, or `None` for every strand (the default). A
    /// solver whose strands cost work to place may place only those; reading another is then
    /// an error of the caller (its points are stale).
    fn display_strands(&mut self, _strands: Option<&[u32]>) {}

    /// Draws the model's debug primitives into `frame`: [`Frame::nodes`], [`Frame::segments`]
    /// (already cleared) and any extra primitive sets ([`Frame::primitives`]) under
    /// `/hair/<path_segment>/…`. Strands and body are drawn by the pipeline.
    fn draw(&self, frame: &mut Frame);

    /// Appends the spheres that move on their own path rather than with the head (the
    /// `guides:` obstacles, the sphere of Chang, Jin, Yu 2002, Fig. 7), posed now: centre and
    /// radius. A picture of the frame draws them like the body spheres; most solvers have none.
    fn obstacle_spheres(&self, _out: &mut Vec<(Vector3<f64>, f64)>) {}

    /// Appends the current control points of strand `strand` of the model (root first) to
    /// `out`. Every strand of the model has points; the pipeline smooths them.
    fn strand_points(&self, strand: usize, out: &mut Vec<Vector3<f64>>);

    /// Checks the model's invariants (structure, finiteness); `Err` says which one broke.
    fn validate(&self) -> Result<(), String>;

    /// Threads used inside a step (1 or 2), where the solver has a parallel stage. The result
    /// never depends on it.
    fn set_threads(&mut self, _threads: usize) {}

    /// Bytes held by reused step buffers (for the allocation checks); 0 if not tracked.
    fn reserved_bytes(&self) -> usize {
        0
    }

    /// The numbers behind node `node`'s adaptation after the last step, by name (the AWT:
    /// [`awt::inspect::INSPECT_NAMES`]); `Err` says why there are none (no such node, or a
    /// model without an inspector).
    fn inspect(&self, node: &NodeId, out: &mut Vec<(&'static str, f64)>) -> Result<(), String> {
        let _ = (node, out);
        Err(format!(
            "the {} model has no node inspector",
            self.kind().name()
        ))
    }

    /// The node a user clicked in the 3D view: with a point (`near`, m), the drawn node whose
    /// sphere surface is nearest it; else the one drawn as `instance` of the frame's nodes
    /// ([`Solver::draw`] order). `None` when there is no such node or no inspector.
    fn pick_node(&self, instance: Option<usize>, near: Option<[f64; 3]>) -> Option<NodeId> {
        let _ = (instance, near);
        None
    }
}
