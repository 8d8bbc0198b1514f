//! Hair–hair and hair–body interaction (src/sim/collide.rs).

use nalgebra::Vector3;
use wisptree::solver::awt::collide::{
    accumulate_brute_force, closest_segment_params, resolve_body, BodySphere, ContactParams,
    HairCollider, PairStats, SegmentsView, CELLS_PER_SEGMENT, MAX_CELLS,
};

type V = Vector3<f64>;

/// SplitMix64: seeded, no dependency.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f()
    }
    fn vec(&mut self, s: f64) -> V {
        V::new(self.range(-s, s), self.range(-s, s), self.range(-s, s))
    }
}

/// Owned segment arrays plus node state.
#[derive(Clone, Default)]
struct Scene {
    parent: Vec<u32>,
    child: Vec<u32>,
    radius: Vec<f64>,
    mass: Vec<f64>,
    /// The GC of each segment: segments of one chain never collide.
    chain: Vec<u32>,
    pos: Vec<V>,
    vel: Vec<V>,
}

impl Scene {
    fn view(&self) -> SegmentsView<'_> {
        SegmentsView {
            parent: &self.parent,
            child: &self.child,
            radius: &self.radius,
            child_mass: &self.mass,
            chain: &self.chain,
        }
    }
    /// `resolve_body` on this scene (field-wise borrows: the view and the node state are disjoint).
    fn resolve(&mut self, sph: &[BodySphere], ov: impl Fn(&V) -> V) -> u32 {
        let view = SegmentsView {
            parent: &self.parent,
            child: &self.child,
            radius: &self.radius,
            child_mass: &self.mass,
            chain: &self.chain,
        };
        resolve_body(&view, &mut self.pos, &mut self.vel, sph, ov)
    }
    fn node(&mut self, p: V, v: V) -> u32 {
        self.pos.push(p);
        self.vel.push(v);
        (self.pos.len() - 1) as u32
    }
    /// A segment of its own chain.
    fn seg(&mut self, parent: u32, child: u32, radius: f64, mass: f64) {
        let chain = self.chain.len() as u32;
        self.chained(parent, child, radius, mass, chain);
    }
    fn chained(&mut self, parent: u32, child: u32, radius: f64, mass: f64, chain: u32) {
        self.parent.push(parent);
        self.child.push(child);
        self.radius.push(radius);
        self.mass.push(mass);
        self.chain.push(chain);
    }
    /// One isolated segment with both nodes moving at `v`.
    fn lone(&mut self, a: V, b: V, v: V, radius: f64, mass: f64) {
        let p = self.node(a, v);
        let c = self.node(b, v);
        self.seg(p, c, radius, mass);
    }

    /// Random wavy strands with some branching (siblings sharing a parent), in a box of
    /// half-size `half`, with segment length about `len`. The main line of strand `i` is chain
    /// `i` (one GC); each sibling is a chain of its own.
    fn random(rng: &mut Rng, strands: usize, nodes: usize, half: f64, len: f64) -> Scene {
        let mut s = Scene::default();
        let mut next_chain = strands as u32;
        for strand in 0..strands {
            let mut x = rng.vec(half);
            let mut dir = rng.vec(1.0).normalize();
            let mut prev = s.node(x, rng.vec(0.5));
            for k in 1..nodes {
                dir = (dir + rng.vec(0.6)).normalize();
                x += dir * len * rng.range(0.7, 1.3);
                let v = rng.vec(0.5);
                let c = s.node(x, v);
                let r = rng.range(0.002, 0.01);
                let m = rng.range(0.0005, 0.003);
                s.chained(prev, c, r, m, strand as u32);
                if k % 4 == 0 {
                    // A sibling: a second child of the same parent.
                    let y = s.pos[prev as usize] + rng.vec(len);
                    let sib = s.node(y, rng.vec(0.5));
                    s.chained(prev, sib, r, m, next_chain);
                    next_chain += 1;
                }
                prev = c;
            }
        }
        s
    }
}

fn params() -> ContactParams {
    ContactParams {
        friction: 20.0,
        repulsion: 2000.0,
        cos_angle_threshold: 0.8,
        epsilon: 1e-4,
        dt: 0.01,
    }
}

fn run(col: &mut HairCollider, s: &Scene, p: &ContactParams) -> (Vec<V>, PairStats) {
    let mut f = vec![V::zeros(); s.pos.len()];
    let st = col.accumulate(&s.view(), &s.pos, &s.vel, p, &mut f);
    (f, st)
}

/// Velocities after one explicit step with each node's mass (child mass of its segment).
fn step_velocities(s: &Scene, f: &[V], dt: f64) -> Vec<V> {
    let mut m = vec![f64::NAN; s.pos.len()];
    for i in 0..s.parent.len() {
        m[s.parent[i] as usize] = s.mass[i];
        m[s.child[i] as usize] = s.mass[i];
    }
    (0..s.pos.len())
        .map(|i| s.vel[i] + f[i] / m[i] * dt)
        .collect()
}

#[test]
fn crossing_segments_are_pushed_apart() {
    let r = 0.01;
    let mut s = Scene::default();
    // A along x at y = 0 moving +y; B along z at y = 0.012 (< r1 + r2 = 0.02) moving -y.
    s.lone(
        V::new(-0.1, 0.0, 0.0),
        V::new(0.1, 0.0, 0.0),
        V::new(0.0, 0.3, 0.0),
        r,
        0.001,
    );
    s.lone(
        V::new(0.0, 0.012, -0.1),
        V::new(0.0, 0.012, 0.1),
        V::new(0.0, -0.3, 0.0),
        r,
        0.001,
    );
    let p = params();
    let (f, st) = run(&mut HairCollider::new(), &s, &p);
    assert_eq!(
        st,
        PairStats {
            candidates: 1,
            tested: 1,
            in_contact: 1
        }
    );
    let fa = f[0] + f[1];
    let fb = f[2] + f[3];
    // Closest points P1 = (0,0,0), P2 = (0,0.012,0): P1 − P2 points along −y.
    assert!(fa.y < 0.0 && fb.y > 0.0, "fa {fa:?} fb {fb:?}");
    assert!(fa.x.abs() < 1e-12 * fa.norm() && fa.z.abs() < 1e-12 * fa.norm());
    // Crossing at the middles: each node carries half.
    assert!((f[0] - f[1]).norm() < 1e-12 * fa.norm());
    // Repulsion magnitude k_r·m·(r − d) plus friction α·m·0.6 m/s.
    let expect = p.repulsion * 0.001 * (0.02 - 0.012) + p.friction * 0.001 * 0.6;
    // Pair forces are stored in f32 (relative precision ~6e-8).
    assert!(
        (fa.norm() - expect).abs() < 1e-6 * expect,
        "{} vs {expect}",
        fa.norm()
    );
    // Approach speed is reduced.
    let v = step_velocities(&s, &f, 0.01);
    let approach_before = (s.vel[0] - s.vel[2]).y;
    let approach_after = ((v[0] + v[1]) * 0.5 - (v[2] + v[3]) * 0.5).y;
    assert!(
        approach_after < approach_before,
        "{approach_after} vs {approach_before}"
    );
    assert!(approach_after.abs() < approach_before.abs());

    // Without repulsion (threshold 0), only friction: still opposes the approach, but weaker.
    let mut q = p;
    q.cos_angle_threshold = 0.0;
    let (g, _) = run(&mut HairCollider::new(), &s, &q);
    assert!((g[0] + g[1]).y < 0.0 && (g[0] + g[1]).norm() < fa.norm());
}

#[test]
fn intersecting_axes_use_cross_product_normal() {
    let mut s = Scene::default();
    s.lone(
        V::new(-0.1, 0.0, 0.0),
        V::new(0.1, 0.0, 0.0),
        V::zeros(),
        0.01,
        0.001,
    );
    // B crosses A's axis exactly (d = 0) at the origin: P1 − P2 has no direction.
    s.lone(
        V::new(0.0, -0.05, 0.0),
        V::new(0.0, 0.15, 0.0),
        V::new(0.0, 0.0, 1.0),
        0.01,
        0.001,
    );
    let mut p = params();
    p.friction = 0.0;
    let (f, st) = run(&mut HairCollider::new(), &s, &p);
    assert_eq!(st.in_contact, 1);
    let fa = f[0] + f[1];
    // Normal ⟂ both axes (±z) with full penetration depth r.
    assert!(fa.x.abs() < 1e-15 && fa.y.abs() < 1e-15, "{fa:?}");
    assert!(
        (fa.z.abs() - p.repulsion * 0.001 * 0.02).abs() < 1e-6 * p.repulsion * 0.001 * 0.02,
        "{fa:?}"
    );
    assert!(fa.iter().all(|c| c.is_finite()));
    assert_eq!(f[2] + f[3], -fa);
}

#[test]
fn parallel_sliding_gets_friction_only() {
    let mut s = Scene::default();
    s.lone(
        V::new(0.0, 0.0, 0.0),
        V::new(0.2, 0.0, 0.0),
        V::new(0.5, 0.0, 0.0),
        0.01,
        0.002,
    );
    s.lone(
        V::new(0.1, 0.005, 0.0),
        V::new(0.3, 0.005, 0.0),
        V::new(-0.5, 0.0, 0.0),
        0.01,
        0.001,
    );
    let p = params();
    let (f, st) = run(&mut HairCollider::new(), &s, &p);
    assert_eq!(st.in_contact, 1);
    let fa = f[0] + f[1];
    let fb = f[2] + f[3];
    // Opposes the relative velocity (A moves +x relative to B) and nothing across.
    assert!(fa.x < 0.0 && fb.x > 0.0);
    assert_eq!((fa.y, fa.z, fb.y, fb.z), (0.0, 0.0, 0.0, 0.0));
    // k_f uses the lighter child mass.
    let expect = p.friction * 0.001 * 1.0;
    assert!((fa.x + expect).abs() < 1e-6 * expect, "{fa:?}");
    // Overlap x ∈ [0.1, 0.2]: the force sits at x = 0.15, 3/4 of the way along A.
    assert!((f[1].x / fa.x - 0.75).abs() < 1e-12);
    // Slows them, never reverses (α·dt < 1).
    let v = step_velocities(&s, &f, 0.01);
    let rel_before = (s.vel[0] - s.vel[2]).x;
    let rel_after = ((v[0] + v[1]) * 0.5 - (v[2] + v[3]) * 0.5).x;
    assert!(
        rel_after > 0.0 && rel_after < rel_before,
        "{rel_after} vs {rel_before}"
    );
}

#[test]
fn equal_velocities_and_adjacent_segments_are_skipped() {
    let p = params();
    // Two crossing, penetrating segments with the same velocity: not tested.
    let mut s = Scene::default();
    let v = V::new(0.3, -0.2, 0.1);
    s.lone(
        V::new(-0.1, 0.0, 0.0),
        V::new(0.1, 0.0, 0.0),
        v,
        0.01,
        0.001,
    );
    s.lone(
        V::new(0.0, 0.0, -0.1),
        V::new(0.0, 0.0, 0.1),
        v,
        0.01,
        0.001,
    );
    let (f, st) = run(&mut HairCollider::new(), &s, &p);
    assert_eq!((st.tested, st.in_contact), (0, 0));
    assert_eq!(st.candidates, 1);
    assert!(f.iter().all(|x| *x == V::zeros()));
    // A relative speed just above epsilon is tested.
    s.vel[3] += V::new(0.0, 2.0 * p.epsilon, 0.0);
    let (_, st) = run(&mut HairCollider::new(), &s, &p);
    assert_eq!(
        st,
        PairStats {
            candidates: 1,
            tested: 1,
            in_contact: 1
        }
    );

    // A folded chain 0-1-2 and a sibling 1-3, all overlapping and moving apart: all adjacent.
    let mut c = Scene::default();
    let n0 = c.node(V::new(0.0, 0.0, 0.0), V::new(1.0, 0.0, 0.0));
    let n1 = c.node(V::new(0.1, 0.0, 0.0), V::new(0.0, 1.0, 0.0));
    let n2 = c.node(V::new(0.0, 0.001, 0.0), V::new(0.0, 0.0, 1.0));
    let n3 = c.node(V::new(0.015, 0.0, 0.001), V::new(-1.0, 0.0, 0.0));
    c.seg(n0, n1, 0.01, 0.001);
    c.seg(n1, n2, 0.01, 0.001);
    c.seg(n1, n3, 0.01, 0.001);
    let (f, st) = run(&mut HairCollider::new(), &c, &p);
    assert_eq!(st.tested, 0);
    assert!(f.iter().all(|x| *x == V::zeros()));
    // Siblings of the root 0 too.
    c.seg(n0, n2, 0.01, 0.001);
    let (_, st) = run(&mut HairCollider::new(), &c, &p);
    // (0-2) vs (1-3) is the only non-adjacent pair.
    assert_eq!(st.tested, 1);
}

fn max_norm(f: &[V]) -> f64 {
    f.iter().map(|x| x.norm()).fold(0.0, f64::max)
}

#[test]
fn grid_matches_brute_force_and_tests_each_pair_once() {
    let p = params();
    let mut rng = Rng(7);
    let mut col = HairCollider::new();
    let mut total_contacts = 0;
    for scene in 0..12 {
        let s = Scene::random(&mut rng, 10 + 5 * scene, 12, 0.12, 0.03);
        let view = s.view();
        let (f, st) = run(&mut col, &s, &p);
        let mut fb = vec![V::zeros(); s.pos.len()];
        let sb = accumulate_brute_force(&view, &s.pos, &s.vel, &p, &mut fb);
        assert_eq!(st.in_contact, sb.in_contact, "scene {scene}");
        let scale = max_norm(&fb).max(1e-30);
        for (a, b) in f.iter().zip(&fb) {
            assert!(
                (a - b).norm() <= 1e-12 * scale,
                "scene {scene}: {a:?} vs {b:?}"
            );
        }
        total_contacts += st.in_contact;

        // Momentum: all pair forces cancel.
        let sum: V = f.iter().sum();
        assert!(sum.norm() <= 1e-12 * scale * f.len() as f64, "sum {sum:?}");

        // Same pairs reach the closest-point routine, fewer are visited.
        assert_eq!(st.tested, sb.tested, "scene {scene}");
        let n = view.len() as u32;
        assert_eq!(sb.candidates, n * (n - 1) / 2);

        // Independent counts over the cell ranges of the grid the collider built: every pair
        // sharing a voxel is visited exactly once (candidates), and the tested pairs are those
        // that share one, are not adjacent, not on one chain, move relative to each other and
        // whose inflated boxes overlap.
        let grid = col.grid();
        let ncells = grid.dims.iter().map(|&d| d as usize).product::<usize>();
        assert!(ncells <= MAX_CELLS.min((CELLS_PER_SEGMENT * view.len()).max(64)));
        let ranges: Vec<_> = (0..view.len())
            .map(|i| grid.cell_range(&view, &s.pos, i))
            .collect();
        let boxes: Vec<(V, V)> = (0..view.len())
            .map(|i| {
                let (a, b) = (
                    s.pos[view.parent[i] as usize],
                    s.pos[view.child[i] as usize],
                );
                (a.inf(&b), a.sup(&b))
            })
            .collect();
        let (mut sharing, mut expected_tested) = (0, 0);
        for a in 0..view.len() {
            for b in a + 1..view.len() {
                let (la, ha) = ranges[a];
                let (lb, hb) = ranges[b];
                if (0..3).any(|k| la[k].max(lb[k]) > ha[k].min(hb[k])) {
                    continue;
                }
                sharing += 1;
                let nodes = [view.parent[a], view.child[a]];
                if nodes.contains(&view.parent[b]) || nodes.contains(&view.child[b]) {
                    continue;
                }
                if view.chain[a] == view.chain[b] {
                    continue;
                }
                let r = view.radius[a] + view.radius[b];
                let ((bla, bha), (blb, bhb)) = (boxes[a], boxes[b]);
                if (0..3).any(|k| bla[k] - bhb[k] > r || blb[k] - bha[k] > r) {
                    continue;
                }
                let vs = |i: usize| {
                    [
                        s.vel[view.parent[i] as usize],
                        s.vel[view.child[i] as usize],
                    ]
                };
                let moving = vs(a)
                    .iter()
                    .any(|x| vs(b).iter().any(|y| (x - y).norm() >= p.epsilon));
                expected_tested += moving as u32;
            }
        }
        assert_eq!(st.candidates, sharing, "scene {scene}");
        assert_eq!(st.tested, expected_tested, "scene {scene}");
        // The grid must actually prune (otherwise it is just the brute force).
        if scene > 4 {
            assert!(
                st.candidates < sb.candidates / 2,
                "{} vs {}",
                st.candidates,
                sb.candidates
            );
            assert!(ncells > 8, "scene {scene}: {:?}", grid.dims);
        }
    }
    assert!(
        total_contacts > 50,
        "scenes too sparse: {total_contacts} contacts"
    );
}

#[test]
fn deterministic_and_no_growth_after_warm_up() {
    let p = params();
    let s = Scene::random(&mut Rng(99), 60, 16, 0.15, 0.03);
    let mut col = HairCollider::new();
    let (f1, st1) = run(&mut col, &s, &p);
    let cap = col.capacity_bytes();
    assert!(cap > 0);
    for _ in 0..3 {
        let (f2, st2) = run(&mut col, &s, &p);
        assert_eq!(st1, st2);
        assert!(f1 == f2, "reused collider changed the forces");
        assert_eq!(col.capacity_bytes(), cap, "buffers grew on the same scene");
    }
    // A fresh collider after another scene gives bit-identical results too.
    let mut other = HairCollider::new();
    run(
        &mut other,
        &Scene::random(&mut Rng(5), 30, 8, 0.3, 0.05),
        &p,
    );
    let (f3, _) = run(&mut other, &s, &p);
    assert!(f1 == f3);
    assert!(st1.in_contact > 0);
}

#[test]
fn far_away_node_keeps_grid_bounded() {
    let p = params();
    let mut s = Scene::random(&mut Rng(3), 20, 10, 0.1, 0.03);
    // One node flung 1 km away: the cell side must grow instead of the grid.
    s.lone(
        V::new(1000.0, 0.0, 0.0),
        V::new(1000.01, 0.0, 0.0),
        V::new(1.0, 0.0, 0.0),
        0.01,
        0.001,
    );
    let mut col = HairCollider::new();
    let (f, st) = run(&mut col, &s, &p);
    let g = col.grid();
    let ncells = g.dims.iter().map(|&d| d as usize).product::<usize>();
    assert!(
        ncells <= (CELLS_PER_SEGMENT * s.parent.len()).max(64),
        "{g:?}"
    );
    // The grid still covers the far node: the cell side grew instead of the cell count.
    assert!(g.dims[0] as f64 * g.cell_size >= 1000.0, "{g:?}");
    let mut fb = vec![V::zeros(); s.pos.len()];
    let sb = accumulate_brute_force(&s.view(), &s.pos, &s.vel, &p, &mut fb);
    assert_eq!(st.in_contact, sb.in_contact);
    assert_eq!(st.tested, sb.tested);
    let scale = max_norm(&fb);
    assert!(f
        .iter()
        .zip(&fb)
        .all(|(a, b)| (a - b).norm() <= 1e-12 * scale));
}

#[test]
fn closest_points_agree_with_parry() {
    use parry3d::na::Point3;
    use parry3d::query::details::closest_points_segment_segment_with_locations_nD;
    use parry3d::shape::SegmentPointLocation;
    let param = |l: SegmentPointLocation| match l {
        SegmentPointLocation::OnVertex(0) => 0.0f64,
        SegmentPointLocation::OnVertex(_) => 1.0,
        SegmentPointLocation::OnEdge([_, s]) => s as f64,
    };
    let mut rng = Rng(11);
    let mut checked = 0;
    for _ in 0..5000 {
        let p: Vec<V> = (0..4).map(|_| rng.vec(1.0)).collect();
        let q: Vec<Point3<f32>> = p.iter().map(|x| Point3::from(x.cast::<f32>())).collect();
        let (l1, l2) =
            closest_points_segment_segment_with_locations_nD((&q[0], &q[1]), (&q[2], &q[3]));
        let (ps, pt) = (param(l1), param(l2));
        let (s, t) = closest_segment_params(&p[0], &p[1], &p[2], &p[3]);
        let dist =
            |s: f64, t: f64| ((p[0] + (p[1] - p[0]) * s) - (p[2] + (p[3] - p[2]) * t)).norm();
        let (d, dp) = (dist(s, t), dist(ps, pt));
        // Ours is at least as close (it is exact in f64) and agrees with parry to f32 accuracy.
        assert!(d <= dp + 1e-12, "ours {d} parry {dp}");
        assert!(dp - d < 1e-5, "ours {d} parry {dp}");
        // Where the problem is well conditioned the parameters agree too.
        let (d1, d2) = (p[1] - p[0], p[3] - p[2]);
        if d1.cross(&d2).norm() > 0.1 * d1.norm() * d2.norm() {
            assert!(
                (s - ps).abs() < 1e-4 && (t - pt).abs() < 1e-4,
                "{s},{t} vs {ps},{pt}"
            );
            checked += 1;
        }
    }
    assert!(checked > 3000);
}

fn spheres() -> Vec<BodySphere> {
    vec![
        BodySphere {
            center: V::new(0.0, 0.0, 0.0),
            radius: 0.1,
        },
        // Overlapping neck sphere.
        BodySphere {
            center: V::new(0.0, -0.12, 0.0),
            radius: 0.06,
        },
        BodySphere {
            center: V::new(0.0, -0.3, 0.0),
            radius: 0.15,
        },
    ]
}

fn obstacle_velocity(x: &V) -> V {
    // A rotation about y plus a translation, so the velocity depends on the point.
    V::new(0.2, 0.0, 0.0) + V::new(0.0, 1.5, 0.0).cross(x)
}

#[test]
fn body_pushes_children_out_with_obstacle_velocity() {
    let sph = spheres();
    let mut rng = Rng(21);
    let mut s = Scene::random(&mut rng, 80, 10, 0.25, 0.04);
    let before = s.clone();
    let pushed = s.resolve(&sph, obstacle_velocity);
    assert!(pushed > 20, "scene does not exercise the spheres: {pushed}");
    let mut moved = 0;
    for i in 0..s.parent.len() {
        let c = s.child[i] as usize;
        for (k, sp) in sph.iter().enumerate() {
            assert!(
                (s.pos[c] - sp.center).norm_squared() >= sp.radius * sp.radius,
                "child of segment {i} inside sphere {k}"
            );
        }
        if s.pos[c] != before.pos[c] {
            moved += 1;
            assert_eq!(s.vel[c], obstacle_velocity(&s.pos[c]), "segment {i}");
        }
    }
    assert_eq!(
        moved, pushed as usize,
        "each pushed segment moves its own child"
    );
    // Parents are never moved except as some segment's child.
    let children: std::collections::BTreeSet<u32> = s.child.iter().copied().collect();
    for n in 0..s.pos.len() {
        if !children.contains(&(n as u32)) {
            assert_eq!(s.pos[n], before.pos[n]);
        }
    }
    // Second pass: nothing left to push through the interiors of segments whose parents are out.
    let again = s.resolve(&sph, obstacle_velocity);
    assert!(again < pushed / 2, "{again} vs {pushed}");
}

#[test]
fn chord_through_sphere_is_rotated_to_tangent() {
    let sph = [BodySphere {
        center: V::zeros(),
        radius: 0.1,
    }];
    let mut s = Scene::default();
    // Both nodes outside, the segment passes 0.05 from the centre.
    s.lone(
        V::new(-0.2, 0.05, 0.0),
        V::new(0.2, 0.05, 0.0),
        V::new(0.0, -1.0, 0.0),
        0.005,
        0.001,
    );
    let len = 0.4;
    let n = s.resolve(&sph, |_| V::new(0.0, 0.0, 0.3));
    assert_eq!(n, 1);
    assert_eq!(s.pos[0], V::new(-0.2, 0.05, 0.0), "parent untouched");
    assert!(
        ((s.pos[1] - s.pos[0]).norm() - len).abs() < 1e-12,
        "length kept"
    );
    // Tangent: the axis' closest distance to the centre is the radius.
    let (a, b) = (s.pos[0], s.pos[1]);
    let t = (-a).dot(&(b - a)) / (b - a).norm_squared();
    let q = a + (b - a) * t.clamp(0.0, 1.0);
    assert!(
        (q.norm() - 0.1).abs() < 1e-9,
        "closest distance {}",
        q.norm()
    );
    assert!(s.pos[1].y > 0.05, "rotated outwards (away from the centre)");
    assert_eq!(s.vel[1], V::new(0.0, 0.0, 0.3));

    // A child inside with its parent inside too: projected radially onto the surface.
    let mut s = Scene::default();
    s.lone(
        V::new(0.0, 0.05, 0.0),
        V::new(0.03, 0.04, 0.0),
        V::zeros(),
        0.005,
        0.001,
    );
    s.resolve(&sph, |_| V::zeros());
    let dir = s.pos[1].normalize();
    assert!((dir - V::new(0.6, 0.8, 0.0)).norm() < 1e-12);
    assert!(s.pos[1].norm_squared() >= 0.01 && (s.pos[1].norm() - 0.1).abs() < 1e-12);

    // A segment outside is left alone.
    let mut s = Scene::default();
    s.lone(
        V::new(0.2, 0.0, 0.0),
        V::new(0.3, 0.0, 0.0),
        V::new(1.0, 0.0, 0.0),
        0.005,
        0.001,
    );
    let before = s.clone();
    assert_eq!(s.resolve(&sph, |_| V::zeros()), 0);
    assert_eq!(s.pos, before.pos);
    assert_eq!(s.vel, before.vel);
}

#[test]
fn validate_refuses_reversing_friction() {
    let p = params();
    assert!(p.validate(0.01).is_ok());
    let e = p.validate(0.05).unwrap_err();
    assert!(e.contains("friction"), "{e}");
    let mut q = p;
    q.repulsion = f64::NAN;
    assert!(q.validate(0.01).unwrap_err().contains("repulsion"));
}

#[test]
fn clustered_overlapping_spheres_leave_no_child_inside() {
    // Many small overlapping spheres (a lumpy body): pushing out of one can land in another.
    let mut rng = Rng(42);
    let sph: Vec<BodySphere> = (0..40)
        .map(|_| BodySphere {
            center: rng.vec(0.08),
            radius: rng.range(0.03, 0.09),
        })
        .collect();
    let mut s = Scene::default();
    for _ in 0..2000 {
        s.lone(rng.vec(0.15), rng.vec(0.15), rng.vec(1.0), 0.005, 0.001);
    }
    let pushed = s.resolve(&sph, obstacle_velocity);
    assert!(pushed > 500, "{pushed}");
    for c in &s.child {
        let x = s.pos[*c as usize];
        for sp in &sph {
            assert!((x - sp.center).norm_squared() >= sp.radius * sp.radius);
        }
    }
}

/// The pair search shared with the helper thread finds the same contacts and gives
/// bit-identical forces (same summation order), on scenes big enough to be shared, again and
/// again with the same helper.
#[test]
fn two_threads_give_bit_identical_forces() {
    let p = params();
    let mut rng = Rng(2024);
    let mut one = HairCollider::new();
    let mut two = HairCollider::new();
    two.set_threads(2);
    two.set_helper_first(true);
    assert_eq!((one.threads(), two.threads()), (1, 2));
    let mut shared_contacts = 0;
    for scene in 0..6 {
        let s = Scene::random(&mut rng, 20 + 10 * scene, 14, 0.1, 0.03);
        assert!(s.parent.len() >= 256, "scene too small to be shared");
        let (f1, st1) = run(&mut one, &s, &p);
        let (f2, st2) = run(&mut two, &s, &p);
        assert_eq!(st1, st2, "scene {scene}");
        assert!(
            f1 == f2,
            "scene {scene}: forces differ between 1 and 2 threads"
        );
        // The helper took part (it may even have done every chunk: small scenes).
        assert!(
            two.helper_contacts() > 0,
            "scene {scene}: helper found {} of {}",
            two.helper_contacts(),
            st2.in_contact
        );
        shared_contacts += st2.in_contact;
    }
    assert!(
        shared_contacts > 500,
        "scenes too sparse: {shared_contacts}"
    );

    // The response shared too (cut in two halves, one per thread): the same forces on one
    // thread or two, and the brute force's up to rounding.
    two.set_min_contacts_to_share(1000);
    let s = Scene::random(&mut rng, 300, 14, 0.04, 0.03);
    let (f1, st1) = run(&mut one, &s, &p);
    let (f2, st2) = run(&mut two, &s, &p);
    assert!(st1.in_contact >= 8192, "scene too sparse: {st1:?}");
    assert_eq!(st1, st2);
    assert!(
        f1 == f2,
        "dense scene: forces differ between 1 and 2 threads"
    );
    let mut fb = vec![V::zeros(); s.pos.len()];
    let sb = accumulate_brute_force(&s.view(), &s.pos, &s.vel, &p, &mut fb);
    assert_eq!(sb.in_contact, st1.in_contact);
    let scale = max_norm(&fb).max(1e-30);
    for (a, b) in f2.iter().zip(&fb) {
        assert!((a - b).norm() <= 1e-12 * scale, "{a:?} vs {b:?}");
    }
}

/// Two segments of one GC (chain) never collide, even far from adjacent and crossing: a wisp's
/// cylinder chain does not rub against itself. The same geometry on two chains does.
#[test]
fn segments_of_one_chain_never_collide() {
    let p = params();
    let build = |same_chain: bool| {
        let mut s = Scene::default();
        // A chain folded back on itself: segment 0 (x axis) and segment 2 (crossing it above,
        // moving down into it), joined by segment 1.
        let a = s.node(V::new(-0.1, 0.0, 0.0), V::zeros());
        let b = s.node(V::new(0.1, 0.0, 0.0), V::zeros());
        let c = s.node(V::new(0.0, 0.005, -0.1), V::new(0.0, -1.0, 0.0));
        let d = s.node(V::new(0.0, 0.005, 0.1), V::new(0.0, -1.0, 0.0));
        s.chained(a, b, 0.01, 0.001, 0);
        s.chained(b, c, 0.01, 0.001, 0);
        s.chained(c, d, 0.01, 0.001, if same_chain { 0 } else { 1 });
        s
    };
    let (f, st) = run(&mut HairCollider::new(), &build(true), &p);
    assert_eq!(st.tested, 0, "{st:?}");
    assert!(f.iter().all(|x| *x == V::zeros()));
    let folded = build(true);
    let mut fb = vec![V::zeros(); 4];
    let sb = accumulate_brute_force(&folded.view(), &folded.pos, &folded.vel, &p, &mut fb);
    assert_eq!(sb.tested, 0);
    let (g, st) = run(&mut HairCollider::new(), &build(false), &p);
    assert_eq!(st.in_contact, 1, "{st:?}");
    // On two chains: segment 2 is pushed up, segment 0 down.
    assert!((g[0] + g[1]).y < 0.0 && (g[2] + g[3]).y > 0.0, "{g:?}");
}
