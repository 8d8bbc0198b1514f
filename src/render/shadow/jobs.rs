//! The jobs of a shadow-map build: the light-space transform, the deposits (segments cut into
//! pieces and splatted bilinearly) and the front-to-back sums.

use std::sync::Mutex;

use super::MAPS;
use crate::render::camera::dot;
use crate::simd::dispatch::multiversion;
use crate::simd::Level;

/// The strands are deposited in two halves, one per thread at most.
pub(super) const HALVES: usize = 2;
/// Bands of texel rows of the front-to-back sum.
pub(super) const SUM_BANDS: usize = 8;
/// Chunks of points for the light-space transform.
pub(super) const FRAME_CHUNKS: usize = 8;

multiversion! {
    /// Writes into `out` the points `points` (as many as `out` holds) in the frame `axes`,
    /// widening `lo`/`hi` to their bounds.
    fn to_light_frame(
        points: &[[f32; 3]],
        axes: [[f32; 3]; 3],
        out: &mut [[f32; 3]],
        lo: &mut [f32; 3],
        hi: &mut [f32; 3],
    ) {
        use crate::render::num::{mn, mx};
        for (q, p) in out.iter_mut().zip(points) {
            *q = axes.map(|a| dot(*p, a));
            // The point first: a NaN point leaves the bounds as they were.
            for a in 0..3 {
                lo[a] = mn(q[a], lo[a]);
                hi[a] = mx(q[a], hi[a]);
            }
        }
    }
}

multiversion! {
    /// Scales the light-space points `lp` (u, v in metres) to texels, then deposits every
    /// segment of strands `range` (their points in `lp`, which starts at point `base`) into
    /// `m`.
    fn deposit_strands(
        splat: &Splat,
        m: &mut [f32],
        lp: (usize, &mut [[f32; 3]]),
        offsets: &[u32],
        range: std::ops::Range<usize>,
    ) {
        let (base, lp) = lp;
        for q in lp.iter_mut() {
            q[0] = (q[0] - splat.u0) * splat.inv_texel;
            q[1] = (q[1] - splat.v0) * splat.inv_texel;
        }
        // The segments are cut into pieces, eight at a time in vector lanes, into a short run
        // that is splatted whenever it fills: cutting a segment into one or two pieces takes
        // no branch on which (the processor guessed wrong at about every other segment), and
        // the splats come in the order of the segments, so the sums are those of depositing
        // the segments one by one.
        let mut run = [Piece::default(); PIECE_RUN];
        let mut n = 0;
        for s in range {
            let (a, b) = (offsets[s] as usize - base, offsets[s + 1] as usize - base);
            let pts = &lp[a..b];
            for k0 in (0..pts.len().saturating_sub(1)).step_by(CUT_LANES) {
                if n + 2 * CUT_LANES > PIECE_RUN {
                    splat.apply(m, &run[..n]);
                    n = 0;
                }
                n = splat.cut_lanes(m, pts, k0, &mut run, n);
            }
        }
        splat.apply(m, &run[..n]);
    }
}

/// Segments cut together, one per vector lane ([`Splat::cut_lanes`]).
const CUT_LANES: usize = 8;

/// Pieces cut before they are splatted ([`Splat::cut`], [`Splat::apply`]): 4 kB on the stack.
const PIECE_RUN: usize = 256;

/// A piece of a segment, ready to splat: the map-major index of the first texel of its 2×2
/// footprint (less than MAPS·size² − size − 1), its position in the footprint, its length.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Piece {
    base: u32,
    fx: f32,
    fy: f32,
    w: f32,
}

/// What a deposit needs of the frame's light frame (a copy, so that the deposits can write
/// the light-space points while they read it).
#[derive(Debug, Clone, Copy)]
pub(super) struct Splat {
    pub(super) size: usize,
    pub(super) u0: f32,
    pub(super) v0: f32,
    pub(super) inv_texel: f32,
    pub(super) z0: f32,
    pub(super) inv_dz: f32,
}

/// A run of light-space points with the index of its first point, behind its own lock.
type PointRun<'a> = Mutex<(usize, &'a mut [[f32; 3]])>;

/// The light-space transform of a frame's points, in [`LightFrame::CHUNKS`] jobs that any
/// threads may run at once ([`ShadowMaps::light_frame`]).
pub(crate) struct LightFrame<'a> {
    pub(super) level: Level,
    pub(super) points: &'a [[f32; 3]],
    pub(super) axes: [[f32; 3]; 3],
    pub(super) parts: [PointRun<'a>; FRAME_CHUNKS],
    /// Per chunk, the bounds of its points.
    pub(super) bounds: [Mutex<([f32; 3], [f32; 3])>; FRAME_CHUNKS],
}

impl LightFrame<'_> {
    /// Number of jobs.
    pub const CHUNKS: usize = FRAME_CHUNKS;

    /// Job `c`: its points in the light frame (u, v, depth in metres), and their bounds.
    pub fn run(&self, c: usize) {
        let mut g = self.parts[c].lock().unwrap_or_else(|e| e.into_inner());
        let (p0, ref mut out) = *g;
        let mut b = self.bounds[c].lock().unwrap_or_else(|e| e.into_inner());
        let (lo, hi) = &mut *b;
        to_light_frame(self.level, &self.points[p0..], self.axes, out, lo, hi);
    }

    /// The bounds of every point, once every job has run.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for b in &self.bounds {
            let (l, h) = *b.lock().unwrap_or_else(|e| e.into_inner());
            for a in 0..3 {
                lo[a] = lo[a].min(l[a]);
                hi[a] = hi[a].max(h[a]);
            }
        }
        (lo, hi)
    }
}

/// The deposits of a frame's strands, in [`Deposit::HALVES`] jobs that any threads may run at
/// once ([`ShadowMaps::deposits`]): half h of the strands into its own partial maps.
pub(crate) struct Deposit<'a> {
    pub(super) level: Level,
    pub(super) splat: Splat,
    pub(super) offsets: &'a [u32],
    pub(super) lp: [PointRun<'a>; HALVES],
    pub(super) partial: &'a [Mutex<Vec<f32>>; HALVES],
}

impl Deposit<'_> {
    /// Number of jobs.
    pub const HALVES: usize = HALVES;

    /// Job `h`: half h's points scaled to texels, and its segments deposited.
    pub fn run(&self, h: usize) {
        let mut m = self.partial[h].lock().unwrap_or_else(|e| e.into_inner());
        m.clear();
        m.resize(self.splat.size * self.splat.size * MAPS, 0.0);
        let mut lp = self.lp[h].lock().unwrap_or_else(|e| e.into_inner());
        let (base, ref mut lp) = *lp;
        let ns = self.offsets.len().saturating_sub(1);
        deposit_strands(
            self.level,
            &self.splat,
            &mut m,
            (base, lp),
            self.offsets,
            h * ns / HALVES..(h + 1) * ns / HALVES,
        );
    }
}

/// The front-to-back sums of the partial maps into Ω, in [`Sum::BANDS`] jobs of texel rows
/// that any threads may run at once ([`ShadowMaps::sums`]): each texel's sum is the same
/// whoever does it.
pub(crate) struct Sum<'a> {
    pub(super) size: usize,
    pub(super) bands: [Mutex<(usize, &'a mut [f32])>; SUM_BANDS],
    pub(super) p0: &'a [f32],
    pub(super) p1: &'a [f32],
}

impl Sum<'_> {
    /// Number of jobs.
    pub const BANDS: usize = SUM_BANDS;

    /// Job `c`: Ω_i = everything deposited into maps 0..=i, for band c's texels.
    pub fn run(&self, c: usize) {
        let (p0, p1) = (self.p0, self.p1);
        let plane = self.size * self.size;
        let mut g = self.bands[c].lock().unwrap_or_else(|e| e.into_inner());
        let (at, ref mut out) = *g;
        // From the map-major deposits to texel-major opacities (a lookup reads every map
        // of a texel from one cache line).
        // Runs of 64 texels, map by map, so that the reads are contiguous.
        const RUN: usize = 64;
        let first = at / MAPS;
        for (k, run) in out.chunks_mut(RUN * MAPS).enumerate() {
            let t0 = first + k * RUN;
            let len = run.len() / MAPS;
            let mut acc = [0.0f32; RUN];
            for i in 0..MAPS {
                let (a, b) = (
                    &p0[i * plane + t0..i * plane + t0 + len],
                    &p1[i * plane + t0..i * plane + t0 + len],
                );
                for (j, (x, y)) in a.iter().zip(b).enumerate() {
                    acc[j] += x + y;
                    run[j * MAPS + i] = acc[j];
                }
            }
        }
    }
}

impl Splat {
    /// Cuts segment a–b (light space, u and v in texels) into pieces at most two texels long
    /// (the bilinear splat spreads each over a 2×2 footprint, so the deposit stays continuous
    /// at half the cost of one piece per texel), each to be deposited into the first map
    /// behind it, and appends them to `run[..n]`, splatting the run into `m` whenever it is
    /// full; returns the new length of the run. The reference of [`Splat::cut_lanes`], which
    /// leaves it the rare segments more than four texels long.
    #[inline(always)]
    pub(super) fn cut(
        &self,
        m: &mut [f32],
        a: [f32; 3],
        b: [f32; 3],
        run: &mut [Piece; PIECE_RUN],
        n: usize,
    ) -> usize {
        let (du, dv) = (b[0] - a[0], b[1] - a[1]);
        let len = (du * du + dv * dv).sqrt();
        let pieces = crate::render::num::ceil_pos(0.5 * len).max(1);
        let step = 1.0 / pieces as f32;
        let w = len * step;
        let (mut n, mut t) = (n, 0.5 * step);
        for _ in 0..pieces {
            if n == PIECE_RUN {
                self.apply(m, &run[..n]);
                n = 0;
            }
            run[n] = self.piece(a, b, t, w);
            n += 1;
            t += step;
        }
        n
    }

    /// [`Splat::cut`] of segments `k0..k0 + CUT_LANES` of a strand whose points are `pts`
    /// (those that exist), computed lane by lane with the same arithmetic (so that it compiles
    /// to vector code, with the same bits), then put in `run` one after the other. There must
    /// be room for two pieces per lane.
    #[inline(always)]
    pub(super) fn cut_lanes(
        &self,
        m: &mut [f32],
        pts: &[[f32; 3]],
        k0: usize,
        run: &mut [Piece; PIECE_RUN],
        n: usize,
    ) -> usize {
        const L: usize = CUT_LANES;
        let segs = pts.len() - 1;
        // Lanes past the strand's last segment repeat it, and are dropped.
        let count = (segs - k0).min(L);
        let a: [[f32; 3]; L] = std::array::from_fn(|l| pts[(k0 + l).min(segs - 1)]);
        let b: [[f32; 3]; L] = std::array::from_fn(|l| pts[(k0 + l).min(segs - 1) + 1]);
        let len: [f32; L] = std::array::from_fn(|l| {
            let (du, dv) = (b[l][0] - a[l][0], b[l][1] - a[l][1]);
            (du * du + dv * dv).sqrt()
        });
        let pieces: [usize; L] =
            std::array::from_fn(|l| crate::render::num::ceil_pos(0.5 * len[l]).max(1));
        // The correctly rounded quotient, as in `cut`.
        let step: [f32; L] = std::array::from_fn(|l| 1.0 / pieces[l] as f32);
        let w: [f32; L] = std::array::from_fn(|l| len[l] * step[l]);
        let t0: [f32; L] = std::array::from_fn(|l| 0.5 * step[l]);
        let first: [Piece; L] = std::array::from_fn(|l| self.piece(a[l], b[l], t0[l], w[l]));
        // A second piece past b (of a one-piece segment) is clamped into the maps like any
        // other, and dropped.
        let second: [Piece; L] =
            std::array::from_fn(|l| self.piece(a[l], b[l], t0[l] + step[l], w[l]));
        let mut n = n;
        if pieces[..count].iter().all(|&p| p <= 2) {
            // Nearly always (segments up to four texels long): both pieces written, one or
            // two counted, with no branch on which.
            for l in 0..count {
                run[n] = first[l];
                run[n + 1] = second[l];
                n += pieces[l];
            }
            return n;
        }
        for l in 0..count {
            n = self.cut(m, a[l], b[l], run, n);
        }
        n
    }

    /// The piece of length `w` texels at parameter `t` of segment a–b.
    #[inline(always)]
    pub(super) fn piece(&self, a: [f32; 3], b: [f32; 3], t: f32, w: f32) -> Piece {
        use crate::render::num::{mn, mx};
        let s = self.size;
        let max = (s - 2) as f32;
        let top = (MAPS - 1) as f32;
        // Texel centres are at integer + 0.5.
        // (`mx`/`mn` send NaN to 0, so the conversions below are in range.)
        let x = mn(mx(a[0] + (b[0] - a[0]) * t - 0.5, 0.0), max);
        let y = mn(mx(a[1] + (b[1] - a[1]) * t - 0.5, 0.0), max);
        let z = a[2] + (b[2] - a[2]) * t;
        let map = crate::render::num::ceil_pos(mn((z - self.z0) * self.inv_dz, top));
        // SAFETY: x and y are in [0, size − 2].
        let (xi, yi) = unsafe { (x.to_int_unchecked::<i32>(), y.to_int_unchecked::<i32>()) };
        let (fx, fy) = (x - xi as f32, y - yi as f32);
        // Deposits are map-major (one s² plane per map): the pieces of a strand mostly fall
        // in one map, so successive splats touch nearby memory (texel-major, each splat
        // touched four cache lines of a 1 MB array).
        let base = map * s * s + yi as usize * s + xi as usize;
        Piece {
            base: base as u32,
            fx,
            fy,
            w,
        }
    }

    /// Splats `pieces` into `m`, in order, each bilinearly over its 2×2 footprint.
    #[inline(always)]
    pub(super) fn apply(&self, m: &mut [f32], pieces: &[Piece]) {
        let s = self.size;
        assert!(s >= 2 && m.len() >= s * s * MAPS, "a map of {s}² texels");
        for p in pieces {
            let (base, fx, fy, w) = (p.base as usize, p.fx, p.fy, p.w);
            // SAFETY: `piece` makes base ≤ (MAPS − 1)·s² + (s − 2)·s + s − 2, so
            // base + s + 1 ≤ MAPS·s² − 1, and `m` holds MAPS·s² values (asserted above).
            // (Four bounds checks a piece were a tenth of the deposit's instructions.)
            unsafe {
                *m.get_unchecked_mut(base) += w * (1.0 - fx) * (1.0 - fy);
                *m.get_unchecked_mut(base + 1) += w * fx * (1.0 - fy);
                *m.get_unchecked_mut(base + s) += w * (1.0 - fx) * fy;
                *m.get_unchecked_mut(base + s + 1) += w * fx * fy;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::test_rng::lcg;

    #[test]
    fn the_lanes_cut_deposits_what_the_segments_cut_one_by_one_deposit_bit_for_bit() {
        let splat = Splat {
            size: 32,
            u0: 0.0,
            v0: 0.0,
            inv_texel: 1.0,
            z0: 0.0,
            inv_dz: 1.0 / 0.01,
        };
        let mut rng = 5u64;
        // Strands of 1 to 30 points with steps of up to 1, 4 or 12 texels (so that runs of
        // one- and two-piece segments meet longer ones), some reaching out of the maps.
        let mut offsets = vec![0u32];
        let mut pts: Vec<[f32; 3]> = Vec::new();
        let mut long_segments = 0;
        for k in 0..300 {
            let reach = [1.0, 4.0, 12.0][k % 3];
            let mut p = [40.0 * lcg(&mut rng) - 4.0, 40.0 * lcg(&mut rng) - 4.0, 0.0];
            let n = 1 + (lcg(&mut rng) * 30.0) as usize;
            for i in 0..n {
                if i > 0 {
                    let d = [reach * (lcg(&mut rng) - 0.5), reach * (lcg(&mut rng) - 0.5)];
                    long_segments += (d[0].hypot(d[1]) > 4.0) as usize;
                    p = [p[0] + d[0], p[1] + d[1], 0.2 * lcg(&mut rng)];
                }
                pts.push(p);
            }
            offsets.push(pts.len() as u32);
        }
        assert!(long_segments > 50, "{long_segments}");
        let plane = splat.size * splat.size * MAPS;
        // The reference: every segment cut and splatted on its own.
        let mut want = vec![0.0f32; plane];
        let mut run = [Piece::default(); PIECE_RUN];
        for s in 0..offsets.len() - 1 {
            let (a, b) = (offsets[s] as usize, offsets[s + 1] as usize);
            for i in a..b.saturating_sub(1) {
                let n = splat.cut(&mut want, pts[i], pts[i + 1], &mut run, 0);
                splat.apply(&mut want, &run[..n]);
            }
        }
        // The renderer's deposit (its points already in texels: u0 = 0, one texel a unit).
        // Both builds: AVX2 (where the processor has it) and the portable one.
        for level in [Level::Avx2, Level::Portable] {
            let mut got = vec![0.0f32; plane];
            let mut lp = pts.clone();
            deposit_strands(
                level,
                &splat,
                &mut got,
                (0, &mut lp),
                &offsets,
                0..offsets.len() - 1,
            );
            assert!(want.iter().filter(|&&v| v > 0.0).count() > 1000);
            let bits = |m: &[f32]| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want), "{level:?}");
        }
    }
}
