//! Opacity shadow maps (Kim and Neumann 2001, "Opacity Shadow Maps"; as used by Zhang and
//! Wünsche 2007, §4 and §6.1).
//!
//! [`MAPS`] = 16 maps perpendicular to the light direction, equally spaced over the hair's
//! extent along it: map i lies at depth z_i = z_0 + i·dz from the front of the hair (as seen
//! from the light) to its back. Map i holds Ω_i, the opacity of all hair in front of z_i, in
//! units of strand crossings: every strand segment deposits its projected length (in texels)
//! into the first map behind it, bilinearly over the 4 nearest texels, then the maps are summed
//! front to back. The opacity at depth z is interpolated between the two nearest maps with
//! Zhang and Wünsche's eq. 1, Ω = Σ_i Ω_i·max(0, 1 − |z − z_i|/dz) (see [`eq1_opacity`]), and
//! the light transmittance is exp(−κ·Ω).
//!
//! **Bias.** A segment lies in front of the map behind it, so a lookup at its own depth would
//! see part of its own deposit. Hair is looked up one map spacing nearer the light (at z − dz):
//! a strand then never shadows itself, and hair less than dz in front of a point shadows it
//! only in part (fully from 2·dz on). The body, which deposits nothing, is looked up unbiased.

use std::sync::Mutex;

use super::camera::{cross, dot, normalize};
use super::pool::{for_each_on, split_parts};

/// Number of opacity maps (Zhang and Wünsche 2007, §6.1: sixteen, four per render target).
pub const MAPS: usize = 16;

/// Zhang and Wünsche 2007, eq. 1: the opacity at depth `z` from the maps' opacities `omega`
/// (map i at depth `z_first + i·dz`), written as in the paper with no search for the two
/// nearest maps. The renderer uses the equivalent two-map interpolation (and holds the last
/// map's value behind it, where eq. 1 would fade to zero).
pub fn eq1_opacity(omega: &[f32], z: f32, z_first: f32, dz: f32) -> f32 {
    omega
        .iter()
        .enumerate()
        .map(|(i, o)| o * (1.0 - ((z - (z_first + i as f32 * dz)) / dz).abs()).max(0.0))
        .sum()
}

/// The 16 maps of one frame and the light frame they were built in.
#[derive(Debug)]
pub struct ShadowMaps {
    size: usize,
    /// Light frame: `ax_d` is the direction the light travels (depth grows along it).
    ax_u: [f32; 3],
    ax_v: [f32; 3],
    ax_d: [f32; 3],
    u0: f32,
    v0: f32,
    inv_texel: f32,
    z0: f32,
    dz: f32,
    inv_dz: f32,
    /// Per texel (row-major), the [`MAPS`] values, front to back: one cache line per texel.
    omega: Vec<f32>,
    /// Light-space points of the frame (u, v in texels; z in metres).
    lp: Vec<[f32; 3]>,
    /// What each half of the strands deposited, before the front-to-back sum: map-major, one
    /// `size`² plane per map.
    partial: [std::sync::Mutex<Vec<f32>>; HALVES],
}

/// The strands are deposited in two halves, one per thread at most.
const HALVES: usize = 2;
/// Bands of texel rows of the front-to-back sum.
const SUM_BANDS: usize = 8;
/// Chunks of points for the light-space transform.
const FRAME_CHUNKS: usize = 8;

super::pool::multiversion! {
    /// Writes into `out` the points `points` (as many as `out` holds) in the frame `axes`,
    /// widening `lo`/`hi` to their bounds.
    fn to_light_frame(
        points: &[[f32; 3]],
        axes: [[f32; 3]; 3],
        out: &mut [[f32; 3]],
        lo: &mut [f32; 3],
        hi: &mut [f32; 3],
    ) {
        use super::raster::{mn, mx};
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

super::pool::multiversion! {
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
struct Piece {
    base: u32,
    fx: f32,
    fy: f32,
    w: f32,
}

/// What a deposit needs of the frame's light frame (a copy, so that the deposits can write
/// the light-space points while they read it).
#[derive(Debug, Clone, Copy)]
struct Splat {
    size: usize,
    u0: f32,
    v0: f32,
    inv_texel: f32,
    z0: f32,
    inv_dz: f32,
}

/// A run of light-space points with the index of its first point, behind its own lock.
type PointRun<'a> = Mutex<(usize, &'a mut [[f32; 3]])>;

/// The light-space transform of a frame's points, in [`LightFrame::CHUNKS`] jobs that any
/// threads may run at once ([`ShadowMaps::light_frame`]).
pub(crate) struct LightFrame<'a> {
    points: &'a [[f32; 3]],
    axes: [[f32; 3]; 3],
    parts: [PointRun<'a>; FRAME_CHUNKS],
    /// Per chunk, the bounds of its points.
    bounds: [Mutex<([f32; 3], [f32; 3])>; FRAME_CHUNKS],
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
        to_light_frame(&self.points[p0..], self.axes, out, lo, hi);
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
    splat: Splat,
    offsets: &'a [u32],
    lp: [PointRun<'a>; HALVES],
    partial: &'a [Mutex<Vec<f32>>; HALVES],
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
    size: usize,
    bands: [Mutex<(usize, &'a mut [f32])>; SUM_BANDS],
    p0: &'a [f32],
    p1: &'a [f32],
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
    fn cut(
        &self,
        m: &mut [f32],
        a: [f32; 3],
        b: [f32; 3],
        run: &mut [Piece; PIECE_RUN],
        n: usize,
    ) -> usize {
        let (du, dv) = (b[0] - a[0], b[1] - a[1]);
        let len = (du * du + dv * dv).sqrt();
        let pieces = super::raster::ceil_pos(0.5 * len).max(1);
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
    fn cut_lanes(
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
            std::array::from_fn(|l| super::raster::ceil_pos(0.5 * len[l]).max(1));
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
    fn piece(&self, a: [f32; 3], b: [f32; 3], t: f32, w: f32) -> Piece {
        use super::raster::{mn, mx};
        let s = self.size;
        let max = (s - 2) as f32;
        let top = (MAPS - 1) as f32;
        // Texel centres are at integer + 0.5.
        // (`mx`/`mn` send NaN to 0, so the conversions below are in range.)
        let x = mn(mx(a[0] + (b[0] - a[0]) * t - 0.5, 0.0), max);
        let y = mn(mx(a[1] + (b[1] - a[1]) * t - 0.5, 0.0), max);
        let z = a[2] + (b[2] - a[2]) * t;
        let map = super::raster::ceil_pos(mn((z - self.z0) * self.inv_dz, top));
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
    fn apply(&self, m: &mut [f32], pieces: &[Piece]) {
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

impl ShadowMaps {
    /// Empty maps of `size`² texels each.
    pub fn new(size: usize) -> ShadowMaps {
        ShadowMaps {
            size,
            ax_u: [1.0, 0.0, 0.0],
            ax_v: [0.0, 0.0, 1.0],
            ax_d: [0.0, -1.0, 0.0],
            u0: 0.0,
            v0: 0.0,
            inv_texel: 1.0,
            z0: 0.0,
            dz: 1.0,
            inv_dz: 1.0,
            omega: vec![0.0; size * size * MAPS],
            lp: Vec::new(),
            partial: Default::default(),
        }
    }

    /// Distance between two maps, metres.
    pub fn spacing(&self) -> f32 {
        self.dz
    }

    /// Builds the maps for strands `points`/`offsets` lit from direction `to_light`, on the
    /// calling thread.
    pub fn build(&mut self, points: &[[f32; 3]], offsets: &[u32], to_light: [f32; 3]) {
        self.build_with(points, offsets, to_light, None);
    }

    /// [`ShadowMaps::build`], each step's jobs run by the pool's threads. The two halves of
    /// the strands are deposited into maps of their own, summed half 0 + half 1 afterwards, so
    /// the result does not depend on the number of threads.
    pub(crate) fn build_with(
        &mut self,
        points: &[[f32; 3]],
        offsets: &[u32],
        to_light: [f32; 3],
        pool: Option<&super::pool::Pool>,
    ) {
        let frame = self.light_frame(points, to_light);
        for_each_on(pool, LightFrame::CHUNKS, &|c| frame.run(c));
        let (lo, hi) = frame.bounds();
        self.set_extent(lo, hi, points.is_empty());
        let deposits = self.deposits(offsets);
        for_each_on(pool, Deposit::HALVES, &|h| deposits.run(h));
        let sums = self.sums();
        for_each_on(pool, Sum::BANDS, &|c| sums.run(c));
    }

    /// Sets up the light frame for light direction `to_light`, and returns the jobs that
    /// put `points` in it. Then: [`ShadowMaps::set_extent`], [`ShadowMaps::deposits`],
    /// [`ShadowMaps::sums`], each after the previous step's jobs have all run.
    pub(crate) fn light_frame<'a>(
        &'a mut self,
        points: &'a [[f32; 3]],
        to_light: [f32; 3],
    ) -> LightFrame<'a> {
        let d = normalize([-to_light[0], -to_light[1], -to_light[2]]);
        let helper = if d[1].abs() < 0.9 {
            [0.0, 1.0, 0.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let u = normalize(cross(helper, d));
        let v = cross(d, u);
        (self.ax_u, self.ax_v, self.ax_d) = (u, v, d);
        // Every point is written by the jobs: resized, not cleared.
        self.lp.resize(points.len(), [0.0; 3]);
        let n = points.len();
        LightFrame {
            points,
            axes: [u, v, d],
            parts: split_parts(&mut self.lp, |c| (c + 1) * n / FRAME_CHUNKS),
            bounds: std::array::from_fn(|_| {
                Mutex::new(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]))
            }),
        }
    }

    /// Spreads the maps over the light-space bounds `lo`..`hi` of the points (`empty`: there
    /// are none).
    pub(crate) fn set_extent(&mut self, mut lo: [f32; 3], mut hi: [f32; 3], empty: bool) {
        if empty {
            (lo, hi) = ([0.0; 3], [1.0; 3]);
        }
        let size = self.size as f32;
        let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-4);
        // One texel of margin on each side, so that bilinear splats stay inside.
        let inv_texel = (size - 3.0) / extent;
        let (u0, v0) = (lo[0] - 1.0 / inv_texel, lo[1] - 1.0 / inv_texel);
        (self.inv_texel, self.u0, self.v0) = (inv_texel, u0, v0);
        self.z0 = lo[2];
        self.dz = ((hi[2] - lo[2]) / (MAPS - 1) as f32).max(1e-5);
        self.inv_dz = 1.0 / self.dz;
    }

    /// The jobs that deposit the strands (`offsets` into the points of
    /// [`ShadowMaps::light_frame`]); each first scales its own points' u and v to texels.
    pub(crate) fn deposits<'a>(&'a mut self, offsets: &'a [u32]) -> Deposit<'a> {
        let splat = Splat {
            size: self.size,
            u0: self.u0,
            v0: self.v0,
            inv_texel: self.inv_texel,
            z0: self.z0,
            inv_dz: self.inv_dz,
        };
        let ns = offsets.len().saturating_sub(1);
        let lp = split_parts(&mut self.lp, |h| {
            if ns == 0 {
                0
            } else {
                offsets[(h + 1) * ns / HALVES] as usize
            }
        });
        Deposit {
            splat,
            offsets,
            lp,
            partial: &self.partial,
        }
    }

    /// The jobs that sum the deposits front to back into the maps.
    pub(crate) fn sums(&mut self) -> Sum<'_> {
        let [p0, p1] = &mut self.partial;
        let (p0, p1) = (
            &*p0.get_mut().unwrap_or_else(|e| e.into_inner()),
            &*p1.get_mut().unwrap_or_else(|e| e.into_inner()),
        );
        let row = self.size * MAPS;
        let rows = self.size;
        Sum {
            size: self.size,
            bands: split_parts(&mut self.omega, |c| (c + 1) * rows / SUM_BANDS * row),
            p0,
            p1,
        }
    }

    /// The light-space position of world point `p` (u, v in texels, z in metres).
    #[inline]
    pub fn light_space(&self, p: [f32; 3]) -> [f32; 3] {
        [
            (dot(p, self.ax_u) - self.u0) * self.inv_texel,
            (dot(p, self.ax_v) - self.v0) * self.inv_texel,
            dot(p, self.ax_d),
        ]
    }

    /// Light-space position of strand point `i` of the last build.
    #[inline(always)]
    pub fn point(&self, i: usize) -> [f32; 3] {
        self.lp[i]
    }

    /// The opacity Ω (strand crossings) at light-space position `q`, looked up `bias` map
    /// spacings nearer the light.
    #[inline]
    pub fn opacity(&self, q: [f32; 3], bias: f32) -> f32 {
        let f = (q[2] - self.z0) / self.dz - bias;
        let (i, w0, w1) = if f <= 0.0 {
            (0, (1.0 + f).max(0.0), 0.0)
        } else if f >= (MAPS - 1) as f32 {
            (MAPS - 2, 0.0, 1.0)
        } else {
            let i = f as i32 as usize;
            let w = f - i as i32 as f32;
            (i, 1.0 - w, w)
        };
        let s = self.size;
        let max = (s - 2) as f32;
        let x = (q[0] - 0.5).clamp(0.0, max);
        let y = (q[1] - 0.5).clamp(0.0, max);
        let (xi, yi) = (x as i32 as usize, y as i32 as usize);
        let (fx, fy) = (x - xi as i32 as f32, y - yi as i32 as f32);
        let base = (yi * s + xi) * MAPS + i;
        let o = &self.omega;
        let at = |b: usize| w0 * o[b] + w1 * o[b + 1];
        let top = at(base) * (1.0 - fx) + at(base + MAPS) * fx;
        let bottom = at(base + s * MAPS) * (1.0 - fx) + at(base + (s + 1) * MAPS) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// [`ShadowMaps::opacity`] at N light-space points (`q[axis][lane]`) at once: the
    /// same interpolation, without branches, for the per-point shading.
    #[inline(always)]
    pub fn opacity_lanes<const N: usize>(&self, q: [[f32; N]; 3], bias: f32) -> [f32; N] {
        use super::raster::{mn, mx};
        use std::array::from_fn;
        let s = self.size;
        let max = (s - 2) as f32;
        // The weights and texel addresses lane by lane (vector code), then the loads lane
        // after lane, then the interpolation lane by lane again.
        // Eq. 1's two maps: f between map ⌊f⌋ and ⌊f⌋ + 1; in front of map 0, map "−1"
        // (which holds nothing) and map 0; beyond the last map, the last map alone.
        // (`mx`/`mn` send NaN to the bound, so the conversions below are in range.)
        let f: [f32; N] = from_fn(|l| {
            mn(
                mx((q[2][l] - self.z0) * self.inv_dz - bias, -1.0),
                (MAPS - 1) as f32,
            )
        });
        // SAFETY: f + 1 is in [0, MAPS], and x, y below in [0, size − 2].
        let fl: [i32; N] = from_fn(|l| {
            (unsafe { (f[l] + 1.0).to_int_unchecked::<i32>() } - 1).min(MAPS as i32 - 2)
        });
        let w1: [f32; N] = from_fn(|l| f[l] - fl[l] as f32);
        // Map ⌊f⌋ is −1 in front of map 0: it gets no weight, and reads map 0.
        let w0: [f32; N] = from_fn(|l| if fl[l] >= 0 { 1.0 - w1[l] } else { 0.0 });
        let i: [usize; N] = from_fn(|l| (fl[l].max(0) as usize) & (MAPS - 1));
        let i1: [usize; N] = from_fn(|l| (if fl[l] >= 0 { i[l] + 1 } else { 0 }) & (MAPS - 1));
        let x: [f32; N] = from_fn(|l| mn(mx(q[0][l] - 0.5, 0.0), max));
        let y: [f32; N] = from_fn(|l| mn(mx(q[1][l] - 0.5, 0.0), max));
        let xi: [i32; N] = from_fn(|l| unsafe { x[l].to_int_unchecked::<i32>() });
        let yi: [i32; N] = from_fn(|l| unsafe { y[l].to_int_unchecked::<i32>() });
        let fx: [f32; N] = from_fn(|l| x[l] - xi[l] as f32);
        let fy: [f32; N] = from_fn(|l| y[l] - yi[l] as f32);
        // The 2×2 texels, each MAPS opacities, at the two maps.
        let mut t = [[[0.0f32; N]; 2]; 4];
        for l in 0..N {
            let at = (yi[l] as usize * s + xi[l] as usize) * MAPS;
            let (top, bottom) = (
                &self.omega[at..at + 2 * MAPS],
                &self.omega[at + s * MAPS..at + (s + 2) * MAPS],
            );
            for (c, (row, k)) in [(top, 0), (top, MAPS), (bottom, 0), (bottom, MAPS)]
                .into_iter()
                .enumerate()
            {
                t[c][0][l] = row[k + i[l]];
                t[c][1][l] = row[k + i1[l]];
            }
        }
        let pair = |c: usize| -> [f32; N] { from_fn(|l| w0[l] * t[c][0][l] + w1[l] * t[c][1][l]) };
        let (p0, p1, p2, p3) = (pair(0), pair(1), pair(2), pair(3));
        from_fn(|l| {
            let upper = p0[l] * (1.0 - fx[l]) + p1[l] * fx[l];
            let lower = p2[l] * (1.0 - fx[l]) + p3[l] * fx[l];
            upper * (1.0 - fy[l]) + lower * fy[l]
        })
    }

    /// The 16 opacities Ω_0..Ω_15 at texel (x, y) (for tests).
    pub fn texel(&self, x: usize, y: usize) -> &[f32] {
        let b = (y * self.size + x) * MAPS;
        &self.omega[b..b + MAPS]
    }

    /// Depth of map 0 along the light direction, metres.
    pub fn first_depth(&self) -> f32 {
        self.z0
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
        let mut got = vec![0.0f32; plane];
        let mut lp = pts.clone();
        deposit_strands(
            &splat,
            &mut got,
            (0, &mut lp),
            &offsets,
            0..offsets.len() - 1,
        );
        assert!(want.iter().filter(|&&v| v > 0.0).count() > 1000);
        let bits = |m: &[f32]| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got), bits(&want));
    }
}
