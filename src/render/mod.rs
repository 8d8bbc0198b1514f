//! The hair renderer: strands and body to an RGB image, on the CPU (the right half of the AWT
//! paper's Figure 4; Zhang and Wünsche 2007, §4–6).
//!
//! A frame goes through four stages:
//!
//! 1. **Shadow maps** ([`shadow`]): 16 opacity maps perpendicular to the light.
//! 2. **Projection**: every strand point is projected to the screen.
//! 3. **Rasterising** ([`raster`], [`tile`]): the body is ray cast ([`body`]: spheres,
//!    capsules, the scalp) and its meshes rasterised ([`mesh`]) into every 32×32-pixel
//!    tile; segments are binned into the tiles they touch, except where the body hides them.
//!    Then the points that binned segments use get their Kajiya-Kay colour under the maps'
//!    transmittance ([`shading`], [`point_colors`]): Zhang and Wünsche shade per vertex and
//!    let the rasteriser interpolate colours (§6.1), and so does this renderer.
//!    Each tile sorts its segments by depth and blends them front to back on a supersampled
//!    grid (a first pass puts them in 256 depth buckets; bucket by bucket, the segments that
//!    hair already drawn or the body hides are culled, and only the rest are sorted and
//!    drawn). A tile no segment reaches is neither cleared nor drawn.
//! 4. **Resolve** ([`resolve`]): body or background behind the hair, box filter per pixel,
//!    3×3 postfilter, sRGB.
//!
//! The stage times report the shading with the projection ([`StageTimes::shading`]). The
//! stages' jobs share rounds on the thread pool ([`Renderer::render`]), so each stage's time
//! is its share of the work done, of the frame's wall time: on one thread, the time it took.
//!
//! The hot loops are compiled twice, for the baseline processor and for AVX2, and the tile
//! pass's vector operations (the window blend, the block depth compares) exist as intrinsics
//! and as portable twins, all in [`crate::simd`]. The renderer's [`Level`] chooses
//! ([`crate::simd::level`]: AVX2 where the processor has it, unless `WISPTREE_SIMD=off`;
//! [`Renderer::with_simd_level`] for a test). No fused multiply-add is enabled, so every level
//! gives the same pixels, bit for bit.
//!
//! The files, bottom up (a file uses only those above it in this list): `num.rs` (numeric
//! helpers), `camera.rs`, `shading.rs`, `body.rs`, `cull.rs` (the body culling before
//! binning), `raster.rs` (binning and depth buckets), `mesh.rs` (the body's triangle meshes),
//! `shadow/`, `point_colors.rs`, `tile/`
//! (the tile's samples, its culling tests and the line rasteriser), `resolve.rs`, `stages.rs`
//! (the stages' per-job functions), `finish.rs` (gather and postfilter), `output.rs` (the
//! image and its encodings), `scene_16k.rs`, and this file. The thread pool is
//! [`crate::par`]'s.
//!
//! Tiles are independent and each is done by one thread, in a fixed order of segments, so the
//! image is the same bit for bit whatever the number of threads. Every buffer belongs to the
//! [`Renderer`] and is reused: once warm, rendering a frame allocates nothing. No physics and no
//! Rerun here.

pub mod body;
pub mod camera;
mod cull;
mod finish;
mod mesh;
mod num;
mod output;
mod point_colors;
pub mod raster;
pub mod resolve;
pub mod scene_16k;
pub mod shading;
pub mod shadow;
mod stages;
mod tile;

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub use crate::style::RenderParams;
pub use camera::{bounds, Camera};
pub use output::{encode_jpeg, encode_jpeg_into, write_png, Image};
pub use raster::Sampling;
pub use scene_16k::{bench_render, zhang_16k_body, zhang_16k_strands, RenderBench};
pub use shading::{kajiya_kay_diffuse, kajiya_kay_specular};
pub use shadow::{eq1_opacity, ShadowMaps, MAPS};

use crate::frame::{BodyBuf, StrandBuf};
use crate::par::{split_parts, Pool};
use crate::simd::Level;
use camera::{normalize, ScreenVertex, View};
use raster::{Bins, Grid, TILE};
use shading::{srgb3_to_linear, HairShader};
pub use stages::StageTimes;
use stages::{
    count_half, fill_half, project_points, render_tile, shade_strands, split_by_strands, TileSetup,
};
use tile::TileBuf;

/// Largest image side accepted, pixels.
pub const MAX_SIDE: u32 = 8192;

/// What to draw.
pub struct RenderInput<'a> {
    /// All strands, already smoothed polylines.
    pub strands: &'a StrandBuf,
    /// Spheres, capsules and scalp ellipsoid as posed; meshes in the rest frame with the pose.
    pub body: &'a BodyBuf,
}

/// Threads a renderer should use: every core (`WISPTREE_RENDER_THREADS` overrides, 1 to 64).
///
/// The renderer is the heaviest stage of `wisptree run`: the simulation thread needs a tenth
/// of a core for Long curly, so the renderer takes all of them (with one thread on a 2-core
/// machine, a 10 s recording took 35 s and left a core idle).
pub fn default_threads() -> usize {
    if let Some(t) = std::env::var("WISPTREE_RENDER_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
    {
        return t.clamp(1, 64);
    }
    std::thread::available_parallelism().map_or(1, |n| n.get().min(64))
}

/// Work items of the projection and shading (runs of strands), of the body casting (runs of
/// tiles) and of the gather and postfilter (bands of rows).
const CHUNKS: usize = 16;

/// Indices of [`Renderer::stage_ns`], one per field of [`StageTimes`].
const SHADOW: usize = 0;
const SHADING: usize = 1;
const RASTER: usize = 2;
const RESOLVE: usize = 3;

/// Runs `f`, adding the nanoseconds it took to `ns`.
fn timed<R>(ns: &AtomicU64, f: impl FnOnce() -> R) -> R {
    let t = Instant::now();
    let r = f();
    ns.fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
    r
}

struct Worker {
    buf: TileBuf,
    sorted: Vec<raster::SegRec>,
    lows: Vec<u8>,
    keys: Vec<u16>,
    buckets: [u32; 257],
    order: Vec<u64>,
}

/// The renderer: owns every buffer, a pool of threads, and the parameters.
pub struct Renderer {
    params: RenderParams,
    width: u32,
    height: u32,
    grid: Grid,
    pool: Pool,
    /// The instruction set of the hot loops ([`Renderer::with_simd_level`]).
    level: Level,
    maps: ShadowMaps,
    verts: Vec<ScreenVertex>,
    /// Per strand point, its packed colour ([`point_colors`]).
    colors: Vec<u32>,
    /// Per strand point, whether a binned segment uses it (1) or not (0).
    needed: Vec<u8>,
    /// Per tile, its body as cast before binning.
    layers: Vec<Mutex<cull::BodyLayer>>,
    /// Each tile's farthest body depth (from `layers`), for binning.
    far: Vec<f32>,
    bins: Bins,
    prims: Vec<body::Prim>,
    /// The body's meshes, posed, projected and binned into the tiles.
    meshes: mesh::Meshes,
    workers: Vec<Mutex<Worker>>,
    /// Per tile, its resolved linear pixels (TILE² × 3).
    tiles: Vec<Mutex<Vec<f32>>>,
    /// The whole frame's linear pixels, gathered from the tiles for the postfilter.
    linear: Vec<f32>,
    /// Per postfilter band, its row of vertical sums.
    band_scratch: [Mutex<Vec<f32>>; CHUNKS],
    lut: Vec<u8>,
    times: StageTimes,
    /// Nanoseconds of work in each stage this frame, summed over the threads ([`SHADOW`],
    /// [`SHADING`], [`RASTER`], [`RESOLVE`]).
    stage_ns: [AtomicU64; 4],
    /// This frame's tiles no hair reaches.
    bare: Vec<u32>,
    /// This frame's tiles with hair, with their number of segments, the most first.
    hairy: Vec<(u32, u32)>,
    /// Per-strand linear colours; empty: every strand has `params.hair_color`.
    strand_colors: Vec<[f32; 3]>,
    /// Lines point-sampled ([`Sampling::point`]).
    point_sampled: bool,
}

impl Renderer {
    /// A renderer of `width × height` images using `threads` threads (the caller's included).
    /// Refuses bad parameters, sizes of 0 or above [`MAX_SIDE`], and 0 or more than 64 threads.
    pub fn new(
        params: RenderParams,
        width: u32,
        height: u32,
        threads: usize,
    ) -> Result<Renderer, String> {
        let sampling = Sampling::boxed(params.supersampling);
        Renderer::sampled(params, width, height, threads, sampling)
    }

    /// [`Renderer::new`], sampling lines as `sampling` says instead of `params.supersampling`
    /// (which it replaces once `params` are checked): one point sample per pixel and the like,
    /// for the antialiasing comparison of Zhang and Wünsche 2007, Fig. 14.
    pub fn sampled(
        mut params: RenderParams,
        width: u32,
        height: u32,
        threads: usize,
        sampling: Sampling,
    ) -> Result<Renderer, String> {
        params
            .validate()
            .map_err(|(f, m)| format!("field `{f}`: {m}"))?;
        if !(1..=4).contains(&sampling.per_axis) {
            return Err(format!(
                "samples per axis must be 1 to 4, got {}",
                sampling.per_axis
            ));
        }
        params.supersampling = sampling.per_axis;
        for (v, what) in [(width, "width"), (height, "height")] {
            if v == 0 || v > MAX_SIDE {
                return Err(format!(
                    "image {what} must be 1 to {MAX_SIDE} pixels, got {v}"
                ));
            }
        }
        if threads == 0 || threads > 64 {
            return Err(format!("threads must be 1 to 64, got {threads}"));
        }
        let grid = Grid::new(
            width as usize,
            height as usize,
            params.supersampling as usize,
        );
        let pool = Pool::new(threads)?;
        let workers = (0..pool.workers())
            .map(|_| {
                Mutex::new(Worker {
                    buf: TileBuf::default(),
                    sorted: Vec::new(),
                    lows: Vec::new(),
                    keys: Vec::new(),
                    buckets: [0; 257],
                    order: Vec::new(),
                })
            })
            .collect();
        let tiles = (0..grid.tiles())
            .map(|_| Mutex::new(vec![0.0f32; TILE * TILE * 3]))
            .collect();
        Ok(Renderer {
            maps: ShadowMaps::new(params.shadow_map_size as usize),
            params,
            width,
            height,
            grid,
            pool,
            level: crate::simd::level(),
            verts: Vec::new(),
            colors: Vec::new(),
            needed: Vec::new(),
            layers: Vec::new(),
            far: Vec::new(),
            bins: Bins::default(),
            prims: Vec::new(),
            meshes: mesh::Meshes::default(),
            workers,
            tiles,
            linear: Vec::new(),
            band_scratch: Default::default(),
            lut: shading::srgb_lut(),
            times: StageTimes::default(),
            stage_ns: Default::default(),
            bare: Vec::new(),
            hairy: Vec::new(),
            strand_colors: Vec::new(),
            point_sampled: sampling.point,
        })
    }

    /// The renderer, its hot loops run at `level` rather than at [`crate::simd::level`] (the
    /// process-wide choice): for a test that compares the AVX2 build with the portable one.
    /// [`Level::Avx2`] on a processor without AVX2 runs the portable build.
    pub fn with_simd_level(mut self, level: Level) -> Renderer {
        self.level = level;
        self.maps.level = level;
        self
    }

    /// The instruction set of the hot loops.
    pub fn simd_level(&self) -> Level {
        self.level
    }

    /// The parameters in force.
    pub fn params(&self) -> &RenderParams {
        &self.params
    }

    /// Gives strand `s` the sRGB colour `colors[s]` instead of the hair colour (strands beyond
    /// the list keep the hair colour); an empty list restores the hair colour everywhere.
    pub fn set_strand_colors(&mut self, colors: &[[f32; 3]]) {
        self.strand_colors.clear();
        self.strand_colors.extend(
            colors
                .iter()
                .map(|c| srgb3_to_linear(c.map(|x| x.clamp(0.0, 1.0)))),
        );
    }

    /// Stage times of the last frame.
    pub fn stage_times(&self) -> StageTimes {
        self.times
    }

    /// The opacity shadow maps of the last frame.
    pub fn shadow_maps(&self) -> &ShadowMaps {
        &self.maps
    }

    /// Renders `input` seen by `camera` into `out` (resized to the renderer's size).
    ///
    /// The frame is a few rounds of jobs on the pool, each round waiting for the last. Work
    /// that does not depend on the previous round shares a round with it, so that a thread
    /// done with its share of one kind of work takes jobs of another instead of waiting (the
    /// strands' halves are one job each, and on a shared machine one thread is often slower):
    ///
    /// 1. the light-space transform, the projection, the body cast;
    /// 2. the shadow deposits (two halves) and the binning count (two halves);
    /// 3. the front-to-back sums of the maps;
    /// 4. the point shading;
    /// 5. the binning fill (two halves) and the tiles that no hair reaches;
    /// 6. the tiles with hair, those with the most segments first;
    /// 7. the gather, then the postfilter.
    pub fn render(&mut self, input: &RenderInput, camera: &Camera, out: &mut Image) {
        let t0 = Instant::now();
        for ns in &self.stage_ns {
            ns.store(0, Ordering::Relaxed);
        }
        let ss = self.grid.ss;
        let view = View::new(camera, self.width * ss as u32, self.height * ss as u32);
        let light = normalize(self.params.light_dir);
        let strands = input.strands;
        let (ws, hs) = (
            (self.width as usize * ss) as f32,
            (self.height as usize * ss) as f32,
        );
        body::prims(input.body, &view, ws, hs, &mut self.prims);
        timed(&self.stage_ns[RASTER], || {
            let base = self.prims.len() as u32;
            self.meshes.prepare(input.body, &view, &self.grid, base);
        });
        let half = 0.5 * self.params.strand_width * ss as f32;
        let reach = half * 1.5 + 1.0;

        self.transform(strands, &view, light);
        self.deposit_and_count(&strands.offsets, reach);
        let sums = self.maps.sums();
        let ns = &self.stage_ns;
        self.pool
            .for_each(shadow::Sum::BANDS, &|c| timed(&ns[SHADOW], || sums.run(c)));
        self.shade(strands, &view, light);
        self.tile_pass(&view, light, half);
        self.finish(out);

        // Each stage's share of the work, of the frame's wall time (on one thread, the time
        // each took).
        let wall = t0.elapsed().as_secs_f64();
        let ns = self
            .stage_ns
            .each_ref()
            .map(|n| n.load(Ordering::Relaxed) as f64);
        let total: f64 = ns.iter().sum();
        let part = |k: usize| {
            Duration::from_secs_f64(if total > 0.0 {
                wall * ns[k] / total
            } else {
                0.0
            })
        };
        self.times = StageTimes {
            shadow_maps: part(SHADOW),
            shading: part(SHADING),
            rasterising: part(RASTER),
            resolve: part(RESOLVE),
        };
    }

    /// The hair's Kajiya-Kay shader for light direction `light`.
    fn hair_shader(&self, light: [f32; 3]) -> HairShader {
        let p = &self.params;
        HairShader {
            color: srgb3_to_linear(p.hair_color),
            diffuse: p.diffuse,
            specular: p.specular,
            exponent: p.specular_exponent,
            ambient: p.ambient,
            light,
        }
    }

    /// Round 1: every strand point to the light frame (and their bounds) and to the screen,
    /// and the body cast into every tile's [`cull::BodyLayer`] (runs of tiles); then the maps
    /// are spread over the points' bounds.
    fn transform(&mut self, strands: &StrandBuf, view: &View, light: [f32; 3]) {
        // Every vertex is written below: resized, not cleared.
        self.verts
            .resize(strands.points.len(), ScreenVertex::default());
        let nt = self.grid.tiles();
        self.layers.resize_with(nt, Default::default);
        let frame = self.maps.light_frame(&strands.points, light);
        let screen = split_by_strands::<_, CHUNKS>(&mut self.verts, &strands.offsets);
        let runs = split_parts::<_, CHUNKS>(&mut self.layers, |c| (c + 1) * nt / CHUNKS);
        let (grid, prims, meshes, workers, ns) = (
            self.grid,
            &self.prims,
            &self.meshes,
            &self.workers,
            &self.stage_ns,
        );
        let level = self.level;
        let (n_light, n_screen) = (shadow::LightFrame::CHUNKS, CHUNKS);
        let job = |k: usize, i: usize| {
            if i < n_light {
                timed(&ns[SHADOW], || frame.run(i));
            } else if i < n_light + n_screen {
                timed(&ns[SHADING], || {
                    let mut g = screen[i - n_light]
                        .lock()
                        .unwrap_or_else(|e| e.into_inner());
                    let (first, ref mut out) = *g;
                    project_points(level, view, &strands.points[first..first + out.len()], out);
                });
            } else {
                timed(&ns[RASTER], || {
                    let mut w = workers[k].lock().unwrap_or_else(|e| e.into_inner());
                    let c = i - n_light - n_screen;
                    let mut g = runs[c].lock().unwrap_or_else(|e| e.into_inner());
                    let (t0, ref mut run) = *g;
                    for (j, layer) in run.iter_mut().enumerate() {
                        let origin = grid.origin(t0 + j);
                        let layer = layer.get_mut().unwrap_or_else(|e| e.into_inner());
                        tile::cast_layer(
                            level,
                            &mut w.buf,
                            grid.tile_samples(),
                            origin,
                            view,
                            tile::BodyParts {
                                prims,
                                mesh: meshes,
                                tris: meshes.tile(t0 + j),
                            },
                            layer,
                        );
                    }
                });
            }
        };
        self.pool.for_each_worker(n_light + n_screen + CHUNKS, &job);
        let (lo, hi) = frame.bounds();
        self.maps.set_extent(lo, hi, strands.points.is_empty());
    }

    /// Round 2: the shadow deposits, and the binning count (the segments into the tiles they
    /// touch, less those the body hides there; the points of the binned segments marked as
    /// `needed`), each in two halves of the strands.
    fn deposit_and_count(&mut self, offsets: &[u32], reach: f32) {
        let ns_strands = offsets.len().saturating_sub(1);
        let n = offsets.last().map_or(0, |&e| e as usize);
        self.needed.clear();
        self.needed.resize(n, 0);
        self.far.clear();
        self.far.extend(
            self.layers
                .iter_mut()
                .map(|l| l.get_mut().unwrap_or_else(|e| e.into_inner()).far),
        );
        let deposits = self.maps.deposits(offsets);
        let parts = split_by_strands::<_, 2>(&mut self.needed, offsets);
        let (verts, grid, halves) = (&self.verts, &self.grid, &self.bins.halves);
        let cull = cull::BodyCull { far: &self.far };
        let level = self.level;
        let ns = &self.stage_ns;
        let job = |i: usize| {
            // The deposits first: the longer jobs.
            if i < shadow::Deposit::HALVES {
                timed(&ns[SHADOW], || deposits.run(i));
                return;
            }
            let h = i - shadow::Deposit::HALVES;
            timed(&ns[RASTER], || {
                let mut b = halves[h].lock().unwrap_or_else(|e| e.into_inner());
                let mut g = parts[h].lock().unwrap_or_else(|e| e.into_inner());
                let (base, ref mut needed) = *g;
                let strands = h * ns_strands / 2..(h + 1) * ns_strands / 2;
                count_half(
                    level,
                    &mut b,
                    verts,
                    offsets,
                    strands,
                    grid,
                    reach,
                    &cull,
                    (base, needed),
                );
            });
        };
        self.pool.for_each(shadow::Deposit::HALVES + 2, &job);
    }

    /// Round 4: shades every strand point that a binned segment uses (`needed`); the others
    /// keep a stale colour that nothing reads.
    fn shade(&mut self, strands: &StrandBuf, view: &View, light: [f32; 3]) {
        let shade = point_colors::PointShader {
            maps: &self.maps,
            eye: view.eye,
            shader: self.hair_shader(light),
            strand_colors: &self.strand_colors,
            kappa: self.params.kappa,
        };
        // Written where needed, read only there: resized, not cleared.
        self.colors.resize(strands.points.len(), 0);
        let needed = &self.needed;
        let n_strands = strands.len();
        let parts = split_by_strands::<_, CHUNKS>(&mut self.colors, &strands.offsets);
        let (ns, level) = (&self.stage_ns, self.level);
        let job = |c: usize| {
            timed(&ns[SHADING], || {
                let mut g = parts[c].lock().unwrap_or_else(|e| e.into_inner());
                let (base, ref mut colors) = *g;
                let range = c * n_strands / CHUNKS..(c + 1) * n_strands / CHUNKS;
                shade_strands(level, &shade, strands, range, base, needed, colors);
            });
        };
        self.pool.for_each(CHUNKS, &job);
    }

    /// Rounds 5 and 6: the binning fill (the tile lists counted in round 2, with the points'
    /// colours) and the tiles no hair reaches; then the tiles with hair, the most segments
    /// first (the longest jobs first, so that no thread is left with a long one at the end).
    fn tile_pass(&mut self, view: &View, light: [f32; 3], half: f32) {
        let p = &self.params;
        let resolve = resolve::Resolve {
            view,
            prims: &self.prims,
            mesh: &self.meshes,
            maps: &self.maps,
            map_size: p.shadow_map_size as f32,
            background: srgb3_to_linear(p.background),
            body: srgb3_to_linear(p.body_color),
            ambient: p.ambient,
            kappa: p.kappa,
            light,
        };
        let alpha = p.strand_alpha;
        let (grid, level) = (self.grid, self.level);
        let nt = grid.tiles();
        let (workers, tiles, layers, ns) =
            (&self.workers, &self.tiles, &self.layers, &self.stage_ns);
        {
            let [h0, h1] = &mut self.bins.halves;
            let halves = [
                &*h0.get_mut().unwrap_or_else(|e| e.into_inner()),
                &*h1.get_mut().unwrap_or_else(|e| e.into_inner()),
            ];
            self.bare.clear();
            self.hairy.clear();
            for t in 0..nt {
                let segs = halves[0].tile_len(t) + halves[1].tile_len(t);
                if segs == 0 {
                    self.bare.push(t as u32);
                } else {
                    self.hairy.push((segs as u32, t as u32));
                }
            }
            self.hairy
                .sort_unstable_by_key(|&(segs, t)| (std::cmp::Reverse(segs), t));
        }
        let (verts, colors, halves, bare) =
            (&self.verts, &self.colors, &self.bins.halves, &self.bare);
        let fill = |k: usize, i: usize| {
            if i < 2 {
                timed(&ns[RASTER], || {
                    let mut b = halves[i].lock().unwrap_or_else(|e| e.into_inner());
                    fill_half(level, &mut b, verts, colors, &grid);
                });
                return;
            }
            timed(&ns[RESOLVE], || {
                let t = bare[i - 2] as usize;
                let mut w = workers[k].lock().unwrap_or_else(|e| e.into_inner());
                let mut layer = layers[t].lock().unwrap_or_else(|e| e.into_inner());
                // No hair here (most of the frame, around the figure): nothing to clear or
                // draw.
                w.buf.take_body(grid.tile_samples(), &mut layer);
                let mut out = tiles[t].lock().unwrap_or_else(|e| e.into_inner());
                resolve.tile(&w.buf, grid.ss, &mut out);
            });
        };
        self.pool.for_each_worker(2 + bare.len(), &fill);

        let [h0, h1] = &mut self.bins.halves;
        let halves = [
            &*h0.get_mut().unwrap_or_else(|e| e.into_inner()),
            &*h1.get_mut().unwrap_or_else(|e| e.into_inner()),
        ];
        let key = {
            let ((lo0, hi0), (lo1, hi1)) = (halves[0].depth_range(), halves[1].depth_range());
            raster::DepthKey::new(lo0.min(lo1), hi0.max(hi1))
        };
        let setup = TileSetup {
            grid,
            layers,
            halves,
            key,
            half,
            alpha,
            resolve: &resolve,
            level,
            point_sampled: self.point_sampled,
        };
        let hairy = &self.hairy;
        let job = |k: usize, i: usize| {
            let t = hairy[i].1 as usize;
            let mut w = workers[k].lock().unwrap_or_else(|e| e.into_inner());
            let mut out = tiles[t].lock().unwrap_or_else(|e| e.into_inner());
            let (rn, sn) = render_tile(level, &mut w, t, &setup, &mut out);
            ns[RASTER].fetch_add(rn, Ordering::Relaxed);
            ns[RESOLVE].fetch_add(sn, Ordering::Relaxed);
        };
        self.pool.for_each_worker(hairy.len(), &job);
    }
}

/// A small deterministic generator for the renderer's tests.
#[cfg(test)]
mod test_rng {
    /// The next value of the sequence in `state`: uniform in [0, 1).
    pub fn lcg(state: &mut u64) -> f32 {
        *state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }
}
