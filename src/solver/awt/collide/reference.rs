//! The brute-force reference the tests compare the grid against.

use nalgebra::Vector3;

use super::*;

/// Reference all-pairs version of [`HairCollider::accumulate`], O(n²): same pair filters and
/// response, pairs visited in lexicographic order. For tests and benchmarks.
pub fn accumulate_brute_force(
    segs: &SegmentsView,
    pos: &[Vector3<f64>],
    vel: &[Vector3<f64>],
    p: &ContactParams,
    force: &mut [Vector3<f64>],
) -> PairStats {
    let mut stats = PairStats::default();
    let n = segs.len();
    let boxes: Vec<SegBox> = (0..n).map(|i| SegBox::new(segs, pos, i)).collect();
    let pre: Vec<SegPre> = (0..n).map(|i| SegPre::new(segs, pos, vel, i)).collect();
    let eps2 = (p.epsilon * p.epsilon) as f32;
    let (mut inv_mass, mut load) = (Vec::new(), Vec::new());
    let mut response = Response::new(segs, force.len(), &mut inv_mass, &mut load);
    let mut contacts = Vec::new();
    let params = pair_params(p);
    for a in 0..n {
        for b in a + 1..n {
            stats.candidates += 1;
            if near(&boxes[a], &boxes[b]) && moving(&pre[a], &pre[b], eps2) {
                stats.tested += 1;
                if let Some(c) = contact(&pre[a], &pre[b], (a as u32, b as u32), &params) {
                    response.record(&c, segs);
                    contacts.push(c);
                }
            }
        }
    }
    stats.in_contact = contacts.len() as u32;
    response.apply(&[&contacts], segs, p, force);
    stats
}
