//! Tests of the strips: every pair within the reach found, the prism test, the floor, one
//! thread or two.

use super::*;

/// A small deterministic generator (the tests need no statistics, only variety).
struct Lcg(u64);

impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn vec(&mut self, scale: f64) -> Vector3<f64> {
        Vector3::new(self.unit(), self.unit(), self.unit()).map(|c| (c - 0.5) * scale)
    }
}

/// `guides` random zig-zag guides of `n` links crowded in a few centimetres, every pair of
/// consecutive guides joined by a strip, moving at random velocities.
fn tangle(seed: u64, guides: usize, n: usize) -> (Chains, Strips) {
    let mut rng = Lcg(seed);
    let mut c = Chains::new(n, guides);
    for g in 0..guides {
        let mut p = rng.vec(0.04);
        let mut pts = vec![p];
        for _ in 0..n {
            p += rng.vec(0.02);
            pts.push(p);
        }
        c.init_guide(g, &pts, 0.01, (0.0, 1.0, 0.0));
        for (i, q) in pts.iter().enumerate() {
            c.x[g * (n + 1) + i] = *q;
            c.v[g * (n + 1) + i] = rng.vec(1.0);
        }
    }
    let pairs: Vec<(u32, u32)> = (1..guides as u32).map(|g| (g - 1, g)).collect();
    let mut s = Strips::default();
    s.rebuild(n, &pairs, &c.x.clone(), 0.001);
    (c, s)
}

/// The contact parameters of the force tests: a contact distance the tangles' crowded guides
/// meet often.
fn contact_params() -> GuideParams {
    GuideParams {
        contact_distance: 0.008,
        ..GuideParams::default()
    }
}

/// [`Strips::evaluate_on`], then its forces added (`c`'s factors `soft` as they are).
fn eval(s: &mut Strips, pool: Option<&Pool>, c: &mut Chains, p: &GuideParams) -> usize {
    let n = s.evaluate_on(pool, c, p);
    s.add_forces(c);
    n
}

/// [`Strips::detect_evaluate_on`], then its forces added.
fn detect_eval(
    s: &mut Strips,
    pool: Option<&Pool>,
    c: &mut Chains,
    alive: &[usize],
    p: &GuideParams,
) -> usize {
    let n = s.detect_evaluate_on(pool, c, alive, p);
    s.add_forces(c);
    n
}

/// [`Strips::reevaluate_on`], then its forces added.
fn reeval(s: &mut Strips, pool: Option<&Pool>, c: &mut Chains, p: &GuideParams) -> usize {
    let n = s.reevaluate_on(pool, c, p);
    s.add_forces(c);
    n
}

/// Forces and damping of `c`, bit for bit.
fn force_bits(c: &Chains) -> Vec<u64> {
    c.f.iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()))
        .chain(c.damp.iter().map(|x| x.to_bits()))
        .collect()
}

/// The vertex–triangle candidates of the last broad phase, as (vertex, triangle).
fn vt_set(s: &Strips) -> std::collections::BTreeSet<(u32, u32)> {
    let mut out = std::collections::BTreeSet::new();
    for t in 0..s.tri.len() {
        for &v in &s.tri_verts[s.tri_start[t] as usize..s.tri_start[t + 1] as usize] {
            out.insert((v, t as u32));
        }
    }
    out
}

#[test]
fn floor_is_the_library_floor() {
    for t in [
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        2.999,
        -2.999,
        1e300,
        -1e300,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
        4.5e15,
        -4.5e15,
    ] {
        assert_eq!(floor(t), t.floor() as i64, "{t}");
    }
    let mut rng = Lcg(3);
    for _ in 0..10_000 {
        let t = (rng.unit() - 0.5) * 100.0;
        assert_eq!(floor(t), t.floor() as i64, "{t}");
    }
}

#[test]
fn prism_keeps_every_point_closer_than_the_reach() {
    let mut rng = Lcg(7);
    let mut rejected = 0;
    for _ in 0..20_000 {
        let t = [rng.vec(0.03), rng.vec(0.03), rng.vec(0.03)];
        let x = rng.vec(0.06);
        let r = 0.002 + 0.01 * rng.unit();
        let (cp, _) = closest_on_triangle(&x, &t);
        let near = Prism::new(&t).near(&x, r);
        if (x - cp).norm() < r {
            assert!(near, "{x:?} is {} from {t:?}, reach {r}", (x - cp).norm());
        }
        rejected += !near as usize;
    }
    // It is a filter: most random points are turned down.
    assert!(rejected > 10_000, "{rejected}");
    // A flat (collinear) triangle lets every point through to the exact test.
    let line = [Vector3::zeros(), Vector3::x(), Vector3::x() * 2.0];
    assert!(Prism::new(&line).near(&Vector3::y(), 1e-3));
}

/// Checks by brute force that the last broad phase of `s` kept every vertex–triangle pair
/// closer than `reach` that the contacts could need (vertex off the triangle's guides,
/// crossing it); returns how many there are.
fn assert_finds_every_vt_pair(c: &Chains, s: &Strips, reach: f64, seed: u64) -> usize {
    let found = vt_set(s);
    let n = c.n;
    let mut tangents = Vec::new();
    fill_all_tangents(c, &mut tangents);
    let mut exact = 0;
    for v in 0..c.x.len() {
        if v % (n + 1) == 0 {
            continue;
        }
        for (t, tv) in s.tri.iter().enumerate() {
            let tp = tv.map(|w| c.x[w as usize]);
            let (cp, _) = closest_on_triangle(&c.x[v], &tp);
            let dir = tv
                .iter()
                .map(|&w| tangents[w as usize])
                .sum::<Vector3<f64>>();
            let dir = dir.normalize();
            let own = tv.iter().any(|&w| w as usize / (n + 1) == v / (n + 1));
            let crossing = tangents[v].cross(&dir).norm() >= MIN_CROSSING * 1.001;
            if (c.x[v] - cp).norm() < reach && !own && crossing {
                exact += 1;
                assert!(
                    found.contains(&(v as u32, t as u32)),
                    "seed {seed} reach {reach}: vertex {v} triangle {t} missed"
                );
            }
        }
    }
    exact
}

/// A few guides flung metres away from the others stretch the vertices' grid past its
/// largest size: the cells past its edge are clamped into it, and every pair is still found,
/// both among the far guides and among the near ones.
#[test]
fn guides_far_from_the_others_still_find_their_pairs() {
    for seed in 1..4 {
        let (mut c, mut s) = tangle(seed, 12, 6);
        let n = c.n;
        for v in 8 * (n + 1)..12 * (n + 1) {
            c.x[v] += Vector3::new(7.0, -3.0, 5.0);
        }
        // No strip between the two groups (a triangle metres long gets no contact at all).
        let pairs: Vec<(u32, u32)> = s.pairs.iter().copied().filter(|&p| p != (7, 8)).collect();
        s.rebuild(n, &pairs, &c.x.clone(), 0.001);
        let alive: Vec<usize> = (0..12).collect();
        s.detect(&c, &alive, 0.012);
        let exact = assert_finds_every_vt_pair(&c, &s, 0.012, seed);
        assert!(exact > 20, "seed {seed}: only {exact} pairs");
        let far = vt_set(&s)
            .iter()
            .filter(|&&(v, _)| v as usize >= 8 * (n + 1))
            .count();
        assert!(far > 0, "seed {seed}: no pair among the far guides");
    }
}

/// The broad phase keeps every vertex–triangle pair closer than the reach that the
/// contacts could need (vertex off the triangle's guides, crossing it), and every crossing
/// segment pair closer than the reach, whatever the grid makes of them.
#[test]
fn broad_phase_finds_every_pair_within_the_reach() {
    for seed in 1..6 {
        let (c, mut s) = tangle(seed, 12, 6);
        let alive: Vec<usize> = (0..12).collect();
        for reach in [0.002, 0.006, 0.012, 0.03] {
            s.detect(&c, &alive, reach);
            let exact = assert_finds_every_vt_pair(&c, &s, reach, seed);
            let n = c.n;
            if reach >= 0.012 {
                assert!(exact > 20, "seed {seed} reach {reach}: only {exact} pairs");
            }
            let segs: std::collections::BTreeSet<_> = s.seg_pairs.iter().copied().collect();
            for la in 0..c.len.len() {
                for lb in la + 1..c.len.len() {
                    if la / n == lb / n {
                        continue;
                    }
                    let va = la / n * (n + 1) + la % n;
                    let vb = lb / n * (n + 1) + lb % n;
                    let (a0, a1, b0, b1) = (c.x[va], c.x[va + 1], c.x[vb], c.x[vb + 1]);
                    let (p, q) = closest_segments(&a0, &a1, &b0, &b1);
                    let d = (a0.lerp(&a1, p) - b0.lerp(&b1, q)).norm();
                    let cross = orientation_scale(&(a1 - a0).normalize(), &(b1 - b0).normalize());
                    if d < reach && cross >= MIN_CROSSING * 1.001 {
                        assert!(
                            segs.contains(&(la as u32, lb as u32)),
                            "seed {seed}: {la} {lb}"
                        );
                    }
                }
            }
        }
    }
}

/// On a pool of two threads the broad phase lists the same candidates in the same order,
/// and a sub-step adds the same forces, bit for bit, as on the calling thread alone.
#[test]
fn two_threads_give_the_same_candidates_and_forces() {
    let pool = Pool::new(2).unwrap();
    let p = contact_params();
    for seed in 1..4 {
        let (c, mut one) = tangle(seed, 16, 8);
        let (_, mut two) = tangle(seed, 16, 8);
        let alive: Vec<usize> = (0..16).collect();
        one.detect_on(None, &c, &alive, 2.0 * p.contact_distance);
        two.detect_on(Some(&pool), &c, &alive, 2.0 * p.contact_distance);
        assert_eq!(one.seg_pairs, two.seg_pairs);
        assert_eq!(one.tri_start, two.tri_start);
        assert_eq!(one.tri_verts, two.tri_verts);
        let (mut ca, mut cb) = (c.clone(), c.clone());
        let na = eval(&mut one, None, &mut ca, &p);
        let nb = eval(&mut two, Some(&pool), &mut cb, &p);
        assert_eq!(na, nb);
        assert!(na > 10, "seed {seed}: {na} contacts");
        assert_eq!(force_bits(&ca), force_bits(&cb), "seed {seed}");
    }
}

/// A step of one sub-step searches and evaluates at once: the same contacts and forces, bit
/// for bit, as the broad phase within the contact distance followed by the contacts, on one
/// thread or two.
#[test]
fn searching_while_evaluating_gives_the_same_forces() {
    let pool = Pool::new(2).unwrap();
    let p = contact_params();
    for seed in 1..4 {
        let (c, mut listed) = tangle(seed, 16, 8);
        let alive: Vec<usize> = (0..16).collect();
        listed.detect_on(None, &c, &alive, p.contact_distance * (1.0 + 1e-6));
        let mut ca = c.clone();
        let na = eval(&mut listed, None, &mut ca, &p);
        assert!(na > 10, "seed {seed}: {na} contacts");
        for pool in [None, Some(&pool)] {
            let (_, mut fused) = tangle(seed, 16, 8);
            let mut cb = c.clone();
            let nb = detect_eval(&mut fused, pool, &mut cb, &alive, &p);
            assert_eq!(na, nb, "seed {seed}");
            assert_eq!(listed.candidates(), fused.candidates(), "seed {seed}");
            assert_eq!(force_bits(&ca), force_bits(&cb), "seed {seed}");
        }
    }
}

/// The pieces' AVX2 build (`crate::simd::dispatch`) and their portable build list the same
/// candidates in the same order and add the same forces, bit for bit, through the listed
/// broad phase and contacts and through the fused search of one sub-step alike. (Where the
/// processor has no AVX2 both runs take the portable build; CI's machines have it.)
#[test]
fn the_avx2_build_of_the_pieces_matches_the_portable_one_bit_for_bit() {
    let p = contact_params();
    let alive: Vec<usize> = (0..24).collect();
    let run = |seed: u64, level: Level, fused: bool| {
        let (c, mut s) = tangle(seed, 24, 10);
        s.simd_level = Some(level);
        let mut forces = c.clone();
        let contacts = if fused {
            detect_eval(&mut s, None, &mut forces, &alive, &p)
        } else {
            s.detect_on(None, &c, &alive, 2.0 * p.contact_distance);
            eval(&mut s, None, &mut forces, &p)
        };
        (
            contacts,
            s.candidates(),
            s.seg_pairs.clone(),
            force_bits(&forces),
        )
    };
    let best = crate::simd::best_available();
    for seed in 1..6 {
        for fused in [false, true] {
            let portable = run(seed, Level::Portable, fused);
            assert!(portable.0 > 10, "seed {seed}: {} contacts", portable.0);
            let vector = run(seed, best, fused);
            assert_eq!(portable.0, vector.0, "seed {seed}, fused {fused}: contacts");
            assert_eq!(
                portable.1, vector.1,
                "seed {seed}, fused {fused}: candidates"
            );
            assert_eq!(
                portable.2, vector.2,
                "seed {seed}, fused {fused}: segment pairs"
            );
            assert!(
                portable.3 == vector.3,
                "seed {seed}, fused {fused}: forces differ between {} and portable",
                best.name()
            );
        }
    }
}

/// Between two searches, the last search's contacts evaluated again on an unchanged state
/// are the search's own contacts with the same forces, bit for bit, on one thread or two;
/// a vertex moved out of reach drops its contacts (and one moved into reach waits for the
/// next search).
#[test]
fn the_last_contacts_evaluated_again_are_the_searched_ones() {
    let pool = Pool::new(2).unwrap();
    let p = contact_params();
    let alive: Vec<usize> = (0..16).collect();
    for seed in 1..4 {
        for pool in [None, Some(&pool)] {
            let (c, mut s) = tangle(seed, 16, 8);
            let mut searched = c.clone();
            let found = detect_eval(&mut s, pool, &mut searched, &alive, &p);
            assert!(found > 10, "seed {seed}: {found} contacts");
            let mut again = c.clone();
            assert_eq!(reeval(&mut s, pool, &mut again, &p), found, "seed {seed}");
            assert_eq!(force_bits(&searched), force_bits(&again), "seed {seed}");
            // Twice in a row: the pairs are carried from evaluation to evaluation.
            let mut third = c.clone();
            assert_eq!(reeval(&mut s, pool, &mut third, &p), found, "seed {seed}");
            assert_eq!(force_bits(&searched), force_bits(&third), "seed {seed}");
            // Every vertex of guide 3 flown far away: its contacts are gone.
            let mut moved = c.clone();
            for v in moved.verts(3) {
                moved.x[v].x += 10.0;
            }
            let mut fresh = moved.clone();
            let (_, mut s2) = tangle(seed, 16, 8);
            let want = detect_eval(&mut s2, None, &mut fresh, &alive, &p);
            let got = reeval(&mut s, pool, &mut moved, &p);
            assert!(got < found, "seed {seed}: {got} of {found} contacts left");
            assert!(
                got >= want,
                "seed {seed}: {got} kept, a search finds {want}"
            );
        }
    }
}

/// A search of `c` over the strips `pairs` of `tangle(seed, 16, 8)`: its contacts and forces.
fn fresh_search(seed: u64, pairs: &[(u32, u32)], c: &Chains, alive: &[usize]) -> (usize, Vec<u64>) {
    let p = contact_params();
    let (_, mut s) = tangle(seed, 16, 8);
    s.rebuild(8, pairs, &c.x.clone(), 0.001);
    let mut forces = c.clone();
    let found = detect_eval(&mut s, None, &mut forces, alive, &p);
    (found, force_bits(&forces))
}

/// A rebuild carries the last contacts over to the new numbering of the triangles: dropping
/// a strip and evaluating again gives what a fresh search over the remaining strips gives
/// (no contact of the state came or went), and a removed guide's contacts are dropped.
#[test]
fn a_rebuild_carries_the_last_contacts_over() {
    let p = contact_params();
    let n = 8;
    for seed in 1..4 {
        let (c, mut s) = tangle(seed, 16, n);
        let alive: Vec<usize> = (0..16).collect();
        let mut first = c.clone();
        detect_eval(&mut s, None, &mut first, &alive, &p);
        // Strip (4, 5) gone: the later strips move down by 2·n triangles.
        let pairs: Vec<(u32, u32)> = (1..16u32).filter(|&g| g != 5).map(|g| (g - 1, g)).collect();
        s.rebuild(n, &pairs, &c.x.clone(), 0.001);
        let (nw, want) = fresh_search(seed, &pairs, &c, &alive);
        let mut got = c.clone();
        assert_eq!(reeval(&mut s, None, &mut got, &p), nw, "seed {seed}");
        assert_eq!(want, force_bits(&got), "seed {seed}");
        // Guide 15 removed (its strip too): none of its contacts is evaluated again.
        let mut c2 = c.clone();
        c2.alive[15] = false;
        let alive2: Vec<usize> = (0..15).collect();
        let pairs2: Vec<(u32, u32)> = pairs.iter().copied().filter(|&(_, b)| b != 15).collect();
        s.rebuild(n, &pairs2, &c.x.clone(), 0.001);
        let (nw2, want2) = fresh_search(seed, &pairs2, &c2, &alive2);
        let mut got2 = c2.clone();
        assert_eq!(reeval(&mut s, None, &mut got2, &p), nw2, "seed {seed}");
        assert_eq!(want2, force_bits(&got2), "seed {seed}");
    }
}
