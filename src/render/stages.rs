//! The per-job functions of a frame's stages, each compiled for the baseline and for AVX2
//! ([`crate::simd::dispatch`]) and called with the renderer's [`Level`].

use std::sync::Mutex;
use std::time::{Duration, Instant};

use super::camera::{ScreenVertex, View};
use super::raster::{self, Grid};
use super::{cull, point_colors, resolve, tile, Worker};
use crate::frame::StrandBuf;
use crate::par::split_parts;
use crate::simd::dispatch::multiversion;
use crate::simd::Level;

/// Each stage's share of the last frame's wall-clock time (its share of the work done by all
/// threads; on one thread, the time it took).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Building the 16 opacity shadow maps.
    pub shadow_maps: Duration,
    /// Projecting every strand point, and shading those that binned segments use.
    pub shading: Duration,
    /// Casting the body into the tiles, binning the segments, then the tile pass's sorting
    /// and blending.
    pub rasterising: Duration,
    /// The tile pass's resolve (body shading, filters, sRGB) and the copy to the image.
    pub resolve: Duration,
}

impl StageTimes {
    /// All stages.
    pub fn total(&self) -> Duration {
        self.shadow_maps + self.shading + self.rasterising + self.resolve
    }
}

/// What every tile of a frame shares.
pub(super) struct TileSetup<'a> {
    pub(super) grid: Grid,
    pub(super) layers: &'a [Mutex<cull::BodyLayer>],
    pub(super) halves: [&'a raster::HalfBins; 2],
    pub(super) key: raster::DepthKey,
    pub(super) half: f32,
    pub(super) alpha: f32,
    pub(super) resolve: &'a resolve::Resolve<'a>,
    /// The instruction set of the tile pass.
    pub(super) level: Level,
    /// Lines point-sampled ([`tile::TileBuf::point_sampled`]).
    pub(super) point_sampled: bool,
}

multiversion! {
    /// Renders tile `t`, which has hair, with worker `w`'s buffers into `out` (its resolved
    /// linear pixels); returns the nanoseconds spent rasterising and resolving.
    pub(super) fn render_tile(
        w: &mut Worker,
        t: usize,
        f: &TileSetup,
        out: &mut [f32],
    ) -> (u64, u64) {
        let r0 = Instant::now();
        let mut layer = f.layers[t].lock().unwrap_or_else(|e| e.into_inner());
        let (first, second) = (f.halves[0].tile(t), f.halves[1].tile(t));
        w.buf.reset_with(f.grid.tile_samples(), &mut layer);
        w.buf.point_sampled = f.point_sampled;
        let n_segs = raster::bucket_tile(
            first,
            second,
            f.key,
            &mut w.sorted,
            &mut w.lows,
            &mut w.keys,
            &mut w.buckets,
        );
        tile::draw_buckets(
            f.level,
            &mut w.buf,
            &w.sorted[..n_segs],
            &w.lows[..n_segs],
            &w.buckets,
            &mut w.order,
            f.half,
            f.alpha,
        );
        let r1 = Instant::now();
        f.resolve.tile(&w.buf, f.grid.ss, out);
        ((r1 - r0).as_nanos() as u64, r1.elapsed().as_nanos() as u64)
    }
}

multiversion! {
    /// [`raster::HalfBins::count`].
    #[allow(clippy::too_many_arguments)]
    pub(super) fn count_half(
        b: &mut raster::HalfBins,
        verts: &[ScreenVertex],
        offsets: &[u32],
        strands: std::ops::Range<usize>,
        grid: &Grid,
        reach: f32,
        cull: &cull::BodyCull,
        needed: (usize, &mut [u8]),
    ) {
        b.count(verts, offsets, strands, grid, reach, cull, needed);
    }
}

multiversion! {
    /// [`raster::HalfBins::fill`].
    pub(super) fn fill_half(
        b: &mut raster::HalfBins,
        verts: &[ScreenVertex],
        colors: &[u32],
        grid: &Grid,
    ) {
        b.fill(verts, colors, grid);
    }
}

multiversion! {
    /// Projects `points` into `out`.
    pub(super) fn project_points(view: &View, points: &[[f32; 3]], out: &mut [ScreenVertex]) {
        for (o, &pt) in out.iter_mut().zip(points) {
            let sp = view.project(pt);
            *o = ScreenVertex {
                x: sp[0],
                y: sp[1],
                z: sp[2],
            };
        }
    }
}

multiversion! {
    /// Shades the needed points of strands `range` into `colors`, which starts at point
    /// `base` (`needed` covers every point).
    pub(super) fn shade_strands(
        shade: &point_colors::PointShader,
        strands: &StrandBuf,
        range: std::ops::Range<usize>,
        base: usize,
        needed: &[u8],
        colors: &mut [u32],
    ) {
        for s in range {
            let (a, b) = (strands.offsets[s] as usize, strands.offsets[s + 1] as usize);
            let out = &mut colors[a - base..b - base];
            shade.strand(s, &strands.points[a..b], a, &needed[a..b], out);
        }
    }
}

/// Splits `v`, one entry per strand point, into the points of K equal runs of strands (run c
/// holds strands c·ns/K..(c+1)·ns/K, ns = `offsets.len()` − 1), each with the index of its
/// first point and behind its own lock, so that K jobs can fill them at once.
pub(super) fn split_by_strands<'a, T, const K: usize>(
    v: &'a mut [T],
    offsets: &[u32],
) -> [Mutex<(usize, &'a mut [T])>; K] {
    let ns = offsets.len().saturating_sub(1);
    split_parts(v, |c| {
        if ns == 0 {
            0
        } else {
            offsets[(c + 1) * ns / K] as usize
        }
    })
}
