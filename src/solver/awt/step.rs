//! One step of the AWT, stage by stage (AWT §2.2–§4):
//!
//! ```text
//! pose → forces → interactions → integrate → links → obstacles → adapt (split, merge)
//! ```

use nalgebra::{Point3, Vector3};

use super::{collide, dynamics, forest, Simulation, NO_SLOT};
use crate::report::{Stage, StageTimes, StepReport};
use crate::style::Link;

impl Simulation {
    /// Advances the simulation by one step of `params.dt`, filling `report`.
    pub fn step(&mut self, report: &mut StepReport) {
        report.events.clear();
        report.stats.clear();
        // At most one event per node and step: reserved once, so a step never allocates.
        report
            .events
            .reserve(self.model.nodes_on_level(self.model.level_count() - 1));
        let dt = self.params.dt;
        let t_new = self.time + dt;
        let mut times = StageTimes::default();

        times.time(Stage::Forces, || self.stage_forces(t_new));
        let pairs = times.time(Stage::Interactions, || self.stage_interactions(dt));
        times.time(Stage::Integrate, || {
            dynamics::integrate(
                &self.link,
                &self.params,
                t_new,
                dt,
                &mut self.slots,
                &mut self.dyn_scratch,
            )
        });
        times.time(Stage::Links, || {
            if let Link::Rigid { iterations } = self.link {
                dynamics::project_rigid_links(&mut self.slots, iterations);
            }
        });
        let body_contacts = times.time(Stage::Obstacles, || self.stage_obstacles(dt));
        self.time = t_new;
        self.steps += 1;
        times.time(Stage::Adapt, || self.stage_adapt(&mut report.events));
        self.write_counters(report, pairs, body_contacts, times);
    }

    /// Pose: roots and body spheres move with the character; external forces.
    fn stage_forces(&mut self, t_new: f64) {
        self.prev_pose = self.pose;
        self.pose = self.motion.pose(if self.settling { 0.0 } else { t_new });
        self.spheres.clear();
        for sp in &self.model.body {
            let c = self
                .pose
                .transform_point(&Point3::from(Vector3::from(sp.center)));
            self.spheres.push(collide::BodySphere {
                center: c.coords,
                radius: sp.radius,
            });
        }
        dynamics::begin_step(&mut self.slots);
        dynamics::pose_roots(&self.model, &self.pose, &mut self.slots);
        dynamics::external_forces(
            &self.model,
            &self.params,
            &self.pose,
            t_new,
            &mut self.slots,
        );
    }

    /// Hair–hair friction and repulsion between active segments (AWT §4.2).
    fn stage_interactions(&mut self, dt: f64) -> collide::PairStats {
        if self.params.friction <= 0.0 && self.params.repulsion <= 0.0 {
            return collide::PairStats::default();
        }
        let s = &mut self.slots;
        let view = s.segs.view();
        let cp = collide::ContactParams {
            friction: self.params.friction,
            repulsion: self.params.repulsion,
            cos_angle_threshold: self.params.angle_threshold.to_radians().cos(),
            epsilon: self.params.contact_epsilon,
            dt,
        };
        self.collider
            .accumulate(&view, &s.pos, &s.vel, &cp, &mut s.force)
    }

    /// Body spheres (AWT §4.3): push out, hold with static friction, restore rigid lengths;
    /// then the accelerations of the split test. Returns the body contacts.
    fn stage_obstacles(&mut self, dt: f64) -> u32 {
        let pose = &self.pose;
        let body_contacts = {
            let s = &mut self.slots;
            s.pre_body.copy_from_slice(&s.pos);
            let view = s.segs.view();
            collide::resolve_body(&view, &mut s.pos, &mut s.vel, &self.spheres, |x| {
                pose.velocity_at(&Point3::from(*x))
            }) + collide::resolve_shapes(&view, &mut s.pos, &mut s.vel, &self.model.colliders, pose)
        };
        {
            // Static friction (§4.3): a node the body pushed keeps its place on the body, i.e.
            // its start-of-step position carried by the body's motion, when that is outside
            // every sphere; otherwise it would slide down the sphere a little every step.
            let carry = self.pose.iso * self.prev_pose.iso.inverse();
            let s = &mut self.slots;
            for c in 0..s.len() {
                s.contact[c] = s.pos[c] != s.pre_body[c];
                if s.contact[c] {
                    let held = (carry * Point3::from(s.prev_pos[c])).coords;
                    if self
                        .spheres
                        .iter()
                        .all(|sp| (held - sp.center).norm() >= sp.radius)
                        && !crate::solver::body::inside(&self.model.colliders, pose, &held)
                    {
                        s.pos[c] = held;
                    }
                }
            }
        }
        if matches!(self.link, Link::Rigid { .. }) {
            dynamics::restore_lengths_outside(
                &mut self.slots,
                &self.spheres,
                &self.model.colliders,
                pose,
            );
            dynamics::rigid_velocities(&mut self.slots, dt);
        }
        dynamics::update_accelerations(&mut self.slots, dt, self.params.accel_smoothing);
        body_contacts
    }

    /// Splits and merges (AWT §3), then the new active set gathered and made valid.
    fn stage_adapt(&mut self, events: &mut Vec<crate::report::AdaptEvent>) {
        if !self.single_level && !self.settling {
            self.scatter();
            let changed = forest::adapt(
                &self.model,
                &mut self.forest,
                &self.params,
                self.time,
                &mut self.adapt_scratch,
                events,
            );
            if changed {
                self.gather();
                // Roots activated by a split or merge sit exactly on the scalp.
                dynamics::pose_roots(&self.model, &self.pose, &mut self.slots);
                // New links join followed positions, which need not be at rest length (and a
                // followed node may sit inside the body): one exact pass ends the step valid.
                if matches!(self.link, Link::Rigid { .. }) {
                    dynamics::restore_lengths_outside(
                        &mut self.slots,
                        &self.spheres,
                        &self.model.colliders,
                        &self.pose,
                    );
                } else {
                    let s = &mut self.slots;
                    let view = s.segs.view();
                    let pose = &self.pose;
                    collide::resolve_body(&view, &mut s.pos, &mut s.vel, &self.spheres, |x| {
                        pose.velocity_at(&Point3::from(*x))
                    });
                    collide::resolve_shapes(
                        &view,
                        &mut s.pos,
                        &mut s.vel,
                        &self.model.colliders,
                        pose,
                    );
                }
            }
        }
        self.scatter();
    }

    /// The step's counters: active nodes per level, segments, pairs, contacts, energy, times.
    fn write_counters(
        &self,
        report: &mut StepReport,
        pairs: collide::PairStats,
        body_contacts: u32,
        times: StageTimes,
    ) {
        let c = &mut report.counters;
        c.active_per_level.clear();
        c.active_per_level.resize(self.model.level_count(), 0);
        let mut ke = 0.0;
        for (slot, &l) in self.slots.level.iter().enumerate() {
            c.active_per_level[l as usize] += 1;
            if self.slots.parent[slot] != NO_SLOT {
                ke += 0.5 * self.slots.mass[slot] * self.slots.vel[slot].norm_squared();
            }
        }
        c.segments = self.slots.segs.len() as u32;
        c.pairs_tested = pairs.tested;
        c.pairs_in_contact = pairs.in_contact;
        c.body_contacts = body_contacts;
        c.kinetic_energy = ke;
        c.times = times;
    }
}
