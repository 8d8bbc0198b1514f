//! Criterion benchmarks of the simulation step, its stages, frame building and logging.
//!
//! `cargo bench --bench step` (about 2 minutes). Every simulation is warmed up with 1 s of the
//! `lean` motion after its settling, so the AWT has split where the motion makes it split. The
//! stage benchmarks call the stage functions of `wisptree::sim` directly on a snapshot of a
//! warmed-up simulation's active nodes (`sim.slots`), in the order `Simulation::step` does;
//! stages that move the state run on a fresh copy per iteration (`iter_batched_ref`, copy not
//! timed).

use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nalgebra::{Point3, Vector3};
use wisptree::frame::Frame;
use wisptree::motion::Motion;
use wisptree::pipeline::FrameBuilder;
use wisptree::solver::awt::collide::{self, BodySphere, ContactParams, HairCollider};
use wisptree::solver::awt::{dynamics, forest as awt, Simulation, StepReport};
use wisptree::style::Link;

/// Steps of warm-up after settling: 1 s of `lean` at 10 ms.
const WARM_STEPS: usize = 100;

fn warmed(style: &str, single_level: bool) -> Simulation {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("styles")
        .join(style);
    let (loaded, model) = wisptree::scene::load_model(
        &wisptree::style::builtin::StyleSource::File(path.to_path_buf()),
    )
    .expect("the style loads");
    let model = Arc::new(model);
    let motion = Motion::parse("lean", Point3::from(model.scalp_center)).expect("lean");
    let mut sim = Simulation::from_style(model, &loaded.style, motion, single_level);
    let mut report = StepReport::default();
    for _ in 0..WARM_STEPS {
        sim.step(&mut report);
    }
    sim
}

fn contact_params(sim: &Simulation) -> ContactParams {
    let p = &sim.params;
    ContactParams {
        friction: p.friction,
        repulsion: p.repulsion,
        cos_angle_threshold: p.angle_threshold.to_radians().cos(),
        epsilon: p.contact_epsilon,
        dt: p.dt,
    }
}

/// The body spheres in the simulation's current pose, as `step` places them.
fn spheres(sim: &Simulation) -> Vec<BodySphere> {
    sim.model
        .body
        .iter()
        .map(|sp| BodySphere {
            center: sim
                .pose()
                .transform_point(&Point3::from(Vector3::from(sp.center)))
                .coords,
            radius: sp.radius,
        })
        .collect()
}

fn step(c: &mut Criterion) {
    let mut g = c.benchmark_group("step");
    g.sample_size(20)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    for style in ["long", "long_curly"] {
        let mut sim = warmed(&format!("{style}.ron"), false);
        let mut report = StepReport::default();
        // The motion goes on across iterations: this is the mean step over a stretch of `lean`.
        g.bench_function(format!("{style}/awt"), |b| {
            b.iter(|| sim.step(black_box(&mut report)))
        });
    }
    g.finish();
}

/// Each stage of one AWT step on Long (rigid links) and Long curly (springs).
fn stages(c: &mut Criterion) {
    let mut g = c.benchmark_group("stage");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for style in ["long", "long_curly"] {
        let mut sim = warmed(&format!("{style}.ron"), false);
        let t = sim.time();
        let dt = sim.params.dt;
        let params = sim.params.clone();
        let link = sim.link.clone();
        let model = sim.model.clone();
        let pose = *sim.pose();
        let body = spheres(&sim);
        let cp = contact_params(&sim);
        let slots = sim.slots.clone();

        g.bench_function(format!("{style}/forces"), |b| {
            let mut s = slots.clone();
            b.iter(|| {
                dynamics::begin_step(&mut s);
                dynamics::pose_roots(&model, &pose, &mut s);
                dynamics::external_forces(&model, &params, &pose, t, &mut s);
            })
        });

        let mut collider = HairCollider::new();
        g.bench_function(format!("{style}/interactions"), |b| {
            let s = &slots;
            let view = s.segs.view();
            let mut force = s.force.clone();
            b.iter(|| black_box(collider.accumulate(&view, &s.pos, &s.vel, &cp, &mut force)))
        });

        let mut scratch = dynamics::Scratch::default();
        g.bench_function(format!("{style}/integrate"), |b| {
            b.iter_batched_ref(
                || slots.clone(),
                |s| dynamics::integrate(&link, &params, t, dt, s, &mut scratch),
                BatchSize::LargeInput,
            )
        });

        if let Link::Rigid { iterations } = link {
            g.bench_function(format!("{style}/links"), |b| {
                b.iter_batched_ref(
                    || slots.clone(),
                    |s| dynamics::project_rigid_links(s, iterations),
                    BatchSize::LargeInput,
                )
            });
        }

        g.bench_function(format!("{style}/obstacles"), |b| {
            b.iter_batched_ref(
                || slots.clone(),
                |s| {
                    let view = s.segs.view();
                    let n = collide::resolve_body(&view, &mut s.pos, &mut s.vel, &body, |x| {
                        pose.velocity_at(&Point3::from(*x))
                    });
                    if matches!(link, Link::Rigid { .. }) {
                        dynamics::restore_lengths_outside(s, &body, &[], &pose);
                    }
                    dynamics::update_accelerations(s, dt, params.accel_smoothing);
                    n
                },
                BatchSize::LargeInput,
            )
        });

        // `adapt` alone (split and merge tests over the forest), on a copy of the forest as the
        // step leaves it; the re-gather of the active set after a change is `step`'s own.
        let forest = sim.forest.clone();
        let mut adapt_scratch = awt::AdaptScratch::default();
        let mut events = Vec::new();
        g.bench_function(format!("{style}/adapt"), |b| {
            b.iter_batched_ref(
                || forest.clone(),
                |f| {
                    events.clear();
                    awt::adapt(&model, f, &params, t, &mut adapt_scratch, &mut events)
                },
                BatchSize::LargeInput,
            )
        });

        g.bench_function(format!("{style}/follow"), |b| {
            b.iter(|| sim.update_followers())
        });
    }
    g.finish();
}

/// Interactions on the single-level Long: the cost the AWT avoids.
fn single_level_interactions(c: &mut Criterion) {
    let mut g = c.benchmark_group("stage");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let sim = warmed("long.ron", true);
    let cp = contact_params(&sim);
    let s = &sim.slots;
    let view = s.segs.view();
    let mut force = s.force.clone();
    let mut collider = HairCollider::new();
    g.bench_function("long/single_level/interactions", |b| {
        b.iter(|| black_box(collider.accumulate(&view, &s.pos, &s.vel, &cp, &mut force)))
    });
    g.finish();
}

/// Interactions on the densest AWT the web page can ask for (issue 25): Short under `shake`
/// with the split threshold at the slider's lowest, 0.05, after 2 s (about 3,600 active
/// nodes, 380 k tested pairs, 255 k contacts), on one and two threads. `WISPTREE_SIMD=off`
/// times the portable narrow phase.
fn dense_interactions(c: &mut Criterion) {
    let mut g = c.benchmark_group("stage");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("styles")
        .join("short.ron");
    let (loaded, model) =
        wisptree::scene::load_model(&wisptree::style::builtin::StyleSource::File(path))
            .expect("the style loads");
    let model = Arc::new(model);
    let motion = Motion::parse("shake", Point3::from(model.scalp_center)).expect("shake");
    let mut sim = Simulation::from_style(model, &loaded.style, motion, false);
    sim.params.split_threshold = 0.05;
    let mut report = StepReport::default();
    for _ in 0..200 {
        sim.step(&mut report);
    }
    let cp = contact_params(&sim);
    let s = &sim.slots;
    let view = s.segs.view();
    let mut force = s.force.clone();
    for threads in [1, 2] {
        let mut collider = HairCollider::new();
        collider.set_threads(threads);
        g.bench_function(
            format!(
                "short/shake_split0.05/interactions/{threads}_threads/{}",
                wisptree::simd::level().name()
            ),
            |b| b.iter(|| black_box(collider.accumulate(&view, &s.pos, &s.vel, &cp, &mut force))),
        );
    }
    g.finish();
}

/// `FrameBuilder::fill` (followers, 500 Catmull-Rom strands) and `Logger::log_frame` into a
/// memory sink, on Long curly.
fn display(c: &mut Criterion) {
    let mut g = c.benchmark_group("display");
    g.sample_size(20)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    let mut sim = warmed("long_curly.ron", false);
    let mut builder = FrameBuilder::new(&sim.model, 500, 4);
    let mut frame = Frame::default();
    g.bench_function("long_curly/frame_fill_500_strands", |b| {
        b.iter(|| builder.fill(&mut sim, &mut frame))
    });

    let (rec, storage) = rerun::RecordingStreamBuilder::new("wisptree-bench")
        .memory()
        .expect("memory recording");
    let head = sim.model.scalp_center;
    let mut logger = wisptree::stream::Logger::new(
        wisptree::stream::sink::Recording(rec),
        &wisptree::stream::LoggerSetup::new(
            sim.model.level_count() as u16,
            "long curly",
            [head.x as f32, head.y as f32, head.z as f32],
        ),
    )
    .expect("logger");
    let mut index = 0;
    g.bench_function("long_curly/log_frame_500_strands", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                frame.index = index;
                index += 1;
                let t0 = Instant::now();
                logger.log_frame(&frame).expect("log_frame");
                total += t0.elapsed();
                // Drop what the sink holds now and then (not timed), so memory stays bounded.
                if index % 64 == 0 {
                    drop(black_box(storage.take()));
                }
            }
            total
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    step,
    stages,
    single_level_interactions,
    dense_interactions,
    display
);
criterion_main!(benches);
