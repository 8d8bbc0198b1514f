//! The hair renderer: strands and body to an RGB image, on the CPU (the right half of the AWT
//! paper's Figure 4; Zhang and Wünsche 2007, §4–6).
//!
//! A frame goes through four stages:
//!
//! 1. **Shadow maps** ([`shadow`]): 16 opacity maps perpendicular to the light.
//! 2. **Projection**: every strand point is projected to the screen.
//! 3. **Rasterising** ([`raster`], [`tile`]): the body ([`body`]) is ray cast into every
//!    32×32-pixel tile; segments are binned into the tiles they touch, except where the body
//!    hides them. Then the points that binned segments use get their Kajiya-Kay colour under
//!    the maps' transmittance ([`shading`], [`point_colors`]): Zhang and Wünsche shade per
//!    vertex and let the rasteriser interpolate colours (§6.1), and so does this renderer.
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
//! The hot loops are compiled twice, for the baseline x86-64 and for AVX2, and chosen at run
//! time (`pool::multiversion!`); no fused multiply-add is enabled, so both give the same
//! pixels.
//!
//! Tiles are independent and each is done by one thread, in a fixed order of segments, so the
//! image is the same bit for bit whatever the number of threads. Every buffer belongs to the
//! [`Renderer`] and is reused: once warm, rendering a frame allocates nothing. No physics and no
//! Rerun here.

pub mod body;
pub mod camera;
mod point_colors;
mod pool;
pub mod raster;
pub mod resolve;
pub mod scene_16k;
pub mod shading;
pub mod shadow;
mod tile;

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

pub use crate::style::RenderParams;
pub use camera::{bounds, Camera};
pub use scene_16k::{bench_render, zhang_16k_body, zhang_16k_strands, RenderBench};
pub use shading::{kajiya_kay_diffuse, kajiya_kay_specular};
pub use shadow::{eq1_opacity, ShadowMaps, MAPS};

use crate::frame::{BodyBuf, StrandBuf};
use camera::{normalize, View};
use raster::{Bins, Grid, ScreenVertex, TILE};
use shading::{srgb3_to_linear, HairShader};
use tile::TileBuf;

/// Largest image side accepted, pixels.
pub const MAX_SIDE: u32 = 8192;

/// What to draw.
pub struct RenderInput<'a> {
    /// All strands, already smoothed polylines.
    pub strands: &'a StrandBuf,
    /// Spheres and scalp ellipsoid as posed.
    pub body: &'a BodyBuf,
}

/// An 8-bit sRGB image, row-major, 3 bytes per pixel.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Image {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width × height × 3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// The (r, g, b) of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let o = ((y * self.width + x) * 3) as usize;
        [self.rgb[o], self.rgb[o + 1], self.rgb[o + 2]]
    }
}

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
    pool: pool::Pool,
    maps: ShadowMaps,
    verts: Vec<ScreenVertex>,
    /// Per strand point, its packed colour ([`point_colors`]).
    colors: Vec<u32>,
    /// Per strand point, whether a binned segment uses it (1) or not (0).
    needed: Vec<u8>,
    /// Per tile, its body as cast before binning.
    layers: Vec<Mutex<tile::BodyLayer>>,
    /// Each tile's farthest body depth (from `layers`), for binning.
    far: Vec<f32>,
    bins: Bins,
    prims: Vec<body::Prim>,
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
        params
            .validate()
            .map_err(|(f, m)| format!("field `{f}`: {m}"))?;
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
        let pool = pool::Pool::new(threads)?;
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
            verts: Vec::new(),
            colors: Vec::new(),
            needed: Vec::new(),
            layers: Vec::new(),
            far: Vec::new(),
            bins: Bins::default(),
            prims: Vec::new(),
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
        })
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
    /// and the body cast into every tile's [`tile::BodyLayer`] (runs of tiles); then the maps
    /// are spread over the points' bounds.
    fn transform(&mut self, strands: &StrandBuf, view: &View, light: [f32; 3]) {
        // Every vertex is written below: resized, not cleared.
        self.verts
            .resize(strands.points.len(), ScreenVertex::default());
        let nt = self.grid.tiles();
        self.layers.resize_with(nt, Default::default);
        let frame = self.maps.light_frame(&strands.points, light);
        let screen = split_by_strands::<_, CHUNKS>(&mut self.verts, &strands.offsets);
        let runs = pool::split_parts::<_, CHUNKS>(&mut self.layers, |c| (c + 1) * nt / CHUNKS);
        let (grid, prims, workers, ns) = (self.grid, &self.prims, &self.workers, &self.stage_ns);
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
                    project_points(view, &strands.points[first..first + out.len()], out);
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
                            &mut w.buf,
                            grid.tile_samples(),
                            origin,
                            view,
                            prims,
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
        let cull = tile::BodyCull { far: &self.far };
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
        let ns = &self.stage_ns;
        let job = |c: usize| {
            timed(&ns[SHADING], || {
                let mut g = parts[c].lock().unwrap_or_else(|e| e.into_inner());
                let (base, ref mut colors) = *g;
                let range = c * n_strands / CHUNKS..(c + 1) * n_strands / CHUNKS;
                shade_strands(&shade, strands, range, base, needed, colors);
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
            maps: &self.maps,
            map_size: p.shadow_map_size as f32,
            background: srgb3_to_linear(p.background),
            body: srgb3_to_linear(p.body_color),
            ambient: p.ambient,
            kappa: p.kappa,
            light,
        };
        let alpha = p.strand_alpha;
        let grid = self.grid;
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
                    fill_half(&mut b, verts, colors, &grid);
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
        };
        let hairy = &self.hairy;
        let job = |k: usize, i: usize| {
            let t = hairy[i].1 as usize;
            let mut w = workers[k].lock().unwrap_or_else(|e| e.into_inner());
            let mut out = tiles[t].lock().unwrap_or_else(|e| e.into_inner());
            let (rn, sn) = render_tile(&mut w, t, &setup, &mut out);
            ns[RASTER].fetch_add(rn, Ordering::Relaxed);
            ns[RESOLVE].fetch_add(sn, Ordering::Relaxed);
        };
        self.pool.for_each_worker(hairy.len(), &job);
    }

    /// Gathers the tiles' linear pixels into the frame, then postfilters and encodes it into
    /// `out` in bands of rows, one job per band.
    fn finish(&mut self, out: &mut Image) {
        let (w, h) = (self.width as usize, self.height as usize);
        self.linear.resize(w * h * 3, 0.0);
        // The gather, in bands of whole rows of tiles, one job each.
        let (grid, tiles) = (self.grid, &self.tiles);
        let rows = pool::split_parts::<_, CHUNKS>(&mut self.linear, |c| {
            ((c + 1) * grid.tiles_y / CHUNKS * TILE).min(h) * w * 3
        });
        let gather = |c: usize| {
            let (t0, t1) = (c * grid.tiles_y / CHUNKS, (c + 1) * grid.tiles_y / CHUNKS);
            let mut g = rows[c].lock().unwrap_or_else(|e| e.into_inner());
            let (_, ref mut dst) = *g;
            for ty in t0..t1 {
                let y0 = (ty - t0) * TILE;
                let ny = TILE.min(h - ty * TILE);
                for tx in 0..grid.tiles_x {
                    let tile = tiles[ty * grid.tiles_x + tx]
                        .lock()
                        .unwrap_or_else(|e| e.into_inner());
                    let x0 = tx * TILE;
                    let cols = TILE.min(w - x0);
                    for y in 0..ny {
                        let src = &tile[y * TILE * 3..(y * TILE + cols) * 3];
                        let o = ((y0 + y) * w + x0) * 3;
                        dst[o..o + cols * 3].copy_from_slice(src);
                    }
                }
            }
        };
        let ns = &self.stage_ns[RESOLVE];
        self.pool.for_each(CHUNKS, &|c| timed(ns, || gather(c)));
        out.width = self.width;
        out.height = self.height;
        out.rgb.resize(w * h * 3, 0);
        let bands = pool::split_parts::<_, CHUNKS>(&mut out.rgb, |c| (c + 1) * h / CHUNKS * w * 3);
        let (linear, lut, s) = (&self.linear, &self.lut, self.params.postfilter);
        let scratch = &self.band_scratch;
        let job = |c: usize| {
            let (y0, y1) = (c * h / CHUNKS, (c + 1) * h / CHUNKS);
            let mut g = bands[c].lock().unwrap_or_else(|e| e.into_inner());
            let (_, ref mut band) = *g;
            let mut row = scratch[c].lock().unwrap_or_else(|e| e.into_inner());
            resolve::postfilter_rows((linear, w, h), y0..y1, s, lut, band, &mut row);
        };
        let ns = &self.stage_ns[RESOLVE];
        self.pool.for_each(CHUNKS, &|c| timed(ns, || job(c)));
    }
}

/// What every tile of a frame shares.
struct TileSetup<'a> {
    grid: Grid,
    layers: &'a [Mutex<tile::BodyLayer>],
    halves: [&'a raster::HalfBins; 2],
    key: raster::DepthKey,
    half: f32,
    alpha: f32,
    resolve: &'a resolve::Resolve<'a>,
}

pool::multiversion! {
    /// Renders tile `t`, which has hair, with worker `w`'s buffers into `out` (its resolved
    /// linear pixels); returns the nanoseconds spent rasterising and resolving.
    fn render_tile(w: &mut Worker, t: usize, f: &TileSetup, out: &mut [f32]) -> (u64, u64) {
        let r0 = Instant::now();
        let mut layer = f.layers[t].lock().unwrap_or_else(|e| e.into_inner());
        let (first, second) = (f.halves[0].tile(t), f.halves[1].tile(t));
        w.buf.reset_with(f.grid.tile_samples(), &mut layer);
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

pool::multiversion! {
    /// [`raster::HalfBins::count`].
    #[allow(clippy::too_many_arguments)]
    fn count_half(
        b: &mut raster::HalfBins,
        verts: &[ScreenVertex],
        offsets: &[u32],
        strands: std::ops::Range<usize>,
        grid: &Grid,
        reach: f32,
        cull: &tile::BodyCull,
        needed: (usize, &mut [u8]),
    ) {
        b.count(verts, offsets, strands, grid, reach, cull, needed);
    }
}

pool::multiversion! {
    /// [`raster::HalfBins::fill`].
    fn fill_half(b: &mut raster::HalfBins, verts: &[ScreenVertex], colors: &[u32], grid: &Grid) {
        b.fill(verts, colors, grid);
    }
}

pool::multiversion! {
    /// Projects `points` into `out`.
    fn project_points(view: &View, points: &[[f32; 3]], out: &mut [ScreenVertex]) {
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

pool::multiversion! {
    /// Shades the needed points of strands `range` into `colors`, which starts at point
    /// `base` (`needed` covers every point).
    fn shade_strands(
        shade: &point_colors::PointShader,
        strands: &StrandBuf,
        range: std::ops::Range<usize>,
        base: usize,
        needed: &[u8],
        colors: &mut [u32],
    ) {
        for s in range {
            let (a, b) = (strands.offsets[s] as usize, strands.offsets[s + 1] as usize);
            shade.strand(s, &strands.points[a..b], a, &needed[a..b], &mut colors[a - base..b - base]);
        }
    }
}

/// Splits `v`, one entry per strand point, into the points of K equal runs of strands (run c
/// holds strands c·ns/K..(c+1)·ns/K, ns = `offsets.len()` − 1), each with the index of its
/// first point and behind its own lock, so that K jobs can fill them at once.
fn split_by_strands<'a, T, const K: usize>(
    v: &'a mut [T],
    offsets: &[u32],
) -> [Mutex<(usize, &'a mut [T])>; K] {
    let ns = offsets.len().saturating_sub(1);
    pool::split_parts(v, |c| {
        if ns == 0 {
            0
        } else {
            offsets[(c + 1) * ns / K] as usize
        }
    })
}

/// Writes `img` as an 8-bit RGB PNG.
pub fn write_png(img: &Image, path: &Path) -> std::io::Result<()> {
    image::save_buffer_with_format(
        path,
        &img.rgb,
        img.width,
        img.height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(std::io::Error::other)
}

/// Encodes `img` as a baseline JPEG of `quality` (1–100, clamped).
pub fn encode_jpeg(img: &Image, quality: u8) -> Vec<u8> {
    let mut out = Vec::new();
    encode_jpeg_into(img, quality, &mut out);
    out
}

/// [`encode_jpeg`] into `out` (cleared first), reusing its allocation.
///
/// By the `jpeg-encoder` crate (with its AVX2 colour conversion and DCT where the processor
/// has them): four times faster than the `image` crate's encoder, which took a tenth of a
/// recording's time. Quality below 90 subsamples the chroma 2×2, as the `image` encoder did.
pub fn encode_jpeg_into(img: &Image, quality: u8, out: &mut Vec<u8>) {
    out.clear();
    let enc = jpeg_encoder::Encoder::new(&mut *out, quality.clamp(1, 100));
    // Encoding fails only on a size beyond 65,535 per side or a short pixel buffer, which an
    // `Image` from the renderer (≤ 8192 per side) never has.
    let (Ok(w), Ok(h)) = (u16::try_from(img.width), u16::try_from(img.height)) else {
        return;
    };
    if enc
        .encode(&img.rgb, w, h, jpeg_encoder::ColorType::Rgb)
        .is_err()
    {
        out.clear();
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
