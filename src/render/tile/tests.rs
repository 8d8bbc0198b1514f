//! The tile pass against its plain definitions.

use super::super::camera::{Camera, ScreenVertex, View};
use super::super::cull::BodyCull;
use super::hidden::Column;
use super::*;
use crate::frame::BodyBuf;
use crate::render::test_rng::lcg;
use crate::simd::dispatch::{Avx2, Portable};
use crate::simd::Level;

/// One 32-pixel tile (64² samples, a 3° field of view) looking at a sphere of radius
/// 0.1 m at the origin, which fills it, from 1 m away.
fn sphere_tile() -> (View, BodyLayer) {
    let cam = Camera {
        eye: [0.0, 0.0, 1.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 3.0,
    };
    let view = View::new(&cam, 64, 64);
    let (mut buf, mut layer) = (TileBuf::default(), BodyLayer::default());
    buf.cast_layer(
        64,
        (0, 0),
        &view,
        BodyParts {
            prims: &sphere_prims(&view),
            mesh: &Default::default(),
            tris: &[],
        },
        &mut layer,
    );
    (view, layer)
}

/// The body of [`sphere_tile`] as seen by `view`.
fn sphere_prims(view: &View) -> Vec<super::super::body::Prim> {
    let body = BodyBuf {
        sphere_centers: vec![[0.0, 0.0, 0.0]],
        sphere_radii: vec![0.1],
        scalp_center: [0.0, 0.0, 0.0],
        scalp_radii: [0.0; 3],
        scalp_rotation: [0.0, 0.0, 0.0, 1.0],
        ..Default::default()
    };
    let mut prims = Vec::new();
    super::super::body::prims(&body, view, 64.0, 64.0, &mut prims);
    prims
}

fn at(view: &View, p: [f32; 3]) -> ScreenVertex {
    let [x, y, z] = view.project(p);
    ScreenVertex { x, y, z }
}

#[test]
fn the_body_layer_hides_a_segment_behind_the_body_and_no_other() {
    let (view, layer) = sphere_tile();
    assert!(layer.body_seen);
    // The sphere's nearest point is 0.9 m away, its silhouette at 1 m.
    let behind = (at(&view, [-0.01, 0.0, -0.2]), at(&view, [0.01, 0.0, -0.2]));
    let in_front = (at(&view, [-0.01, 0.0, 0.2]), at(&view, [0.01, 0.0, 0.2]));
    // The tile sees the sphere's front between 0.9 m (centre) and about 0.907 m (corners).
    // Just behind the centre but in front of the corners: the whole-tile test keeps it
    // (the tile pass tests it block by block).
    let grazing = (
        at(&view, [-0.01, 0.0, 0.097]),
        at(&view, [0.01, 0.0, 0.097]),
    );
    let cull = BodyCull { far: &[layer.far] };
    let keeps = |(a, b): (ScreenVertex, ScreenVertex)| cull.keeps(0, BodyCull::depth(&a, &b));
    assert!(!keeps(behind));
    assert!(keeps(in_front));
    assert!(keeps(grazing));
    // A segment with no length draws nothing anywhere.
    assert!(!keeps((in_front.0, in_front.0)));
}

#[test]
fn a_tile_without_hair_resolves_as_if_cleared_without_reading_its_samples() {
    let (view, _) = sphere_tile();
    let prims = sphere_prims(&view);
    let maps = super::super::shadow::ShadowMaps::new(16);
    let resolve = super::super::resolve::Resolve {
        view: &view,
        prims: &prims,
        mesh: &Default::default(),
        maps: &maps,
        map_size: 16.0,
        background: [0.3, 0.5, 0.7],
        body: [0.8, 0.6, 0.5],
        ambient: 0.2,
        kappa: 0.5,
        light: [0.0, 0.6, 0.8],
    };
    // The sphere's tile, and one with no body (cast without primitives).
    for with_body in [true, false] {
        let cast = || {
            let (mut scratch, mut layer) = (TileBuf::default(), BodyLayer::default());
            let p: &[super::super::body::Prim] = if with_body { &prims } else { &[] };
            let parts = BodyParts {
                prims: p,
                mesh: &Default::default(),
                tris: &[],
            };
            scratch.cast_layer(64, (0, 0), &view, parts, &mut layer);
            layer
        };
        let mut cleared = TileBuf::default();
        cleared.reset_with(64, &mut cast());
        let mut taken = TileBuf::default();
        // Samples left from another tile, which the resolve must not read.
        taken.reset_samples(64, 64, 64);
        taken.px.fill(Px([9.0, 9.0, 9.0, 0.0]));
        taken.take_body(64, &mut cast());
        assert_eq!(taken.body_seen(), with_body);
        let (mut a, mut b) = (vec![0.0f32; 32 * 32 * 3], vec![1.0f32; 32 * 32 * 3]);
        resolve.tile(&cleared, 2, &mut a);
        resolve.tile(&taken, 2, &mut b);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a), bits(&b), "with body: {with_body}");
        if !with_body {
            assert!(a
                .chunks(3)
                .all(|p| (p[0] - 0.3).abs() < 1e-6 && p[2] > 0.69));
        } else {
            assert!(a.chunks(3).any(|p| (p[0] - 0.3).abs() > 0.01));
        }
    }
}

#[test]
fn the_buckets_draw_in_the_stable_order_of_the_whole_key_and_culling_changes_nothing() {
    use super::super::point_colors::pack;
    use super::super::raster::{bucket_tile, DepthKey};
    let mut rng = 11u64;
    // Many short overlapping strokes in one corner of the tile (so that samples turn
    // opaque and later strokes are culled), half with depths from a small set (so that
    // many keys are equal and the strand order decides), half anywhere (so that the low
    // byte of the key orders segments within a bucket).
    let segs: Vec<SegRec> = (0..1500)
        .map(|_| {
            let (x, y) = (8.0 + 24.0 * lcg(&mut rng), 8.0 + 24.0 * lcg(&mut rng));
            let (dx, dy) = (6.0 * lcg(&mut rng) - 3.0, 6.0 * lcg(&mut rng) - 3.0);
            let z = if lcg(&mut rng) < 0.5 {
                1.0 + (lcg(&mut rng) * 40.0).floor() * 0.01
            } else {
                1.0 + lcg(&mut rng) * 0.4
            };
            let dz = if lcg(&mut rng) < 0.5 { 0.0 } else { 0.005 };
            let mut c = || [lcg(&mut rng), lcg(&mut rng), lcg(&mut rng)];
            SegRec {
                a: ScreenVertex { x, y, z: z - dz },
                b: ScreenVertex {
                    x: x + dx,
                    y: y + dy,
                    z: z + dz,
                },
                ca: pack(c()),
                cb: pack(c()),
            }
        })
        .collect();
    let mid = |r: &SegRec| 0.5 * (r.a.z + r.b.z);
    let (lo, hi) = segs
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(l, h), r| {
            (l.min(mid(r)), h.max(mid(r)))
        });
    let key = DepthKey::new(lo, hi);
    let (half, alpha) = (0.9, 0.6);
    let fresh = || {
        let mut buf = TileBuf::default();
        buf.reset_samples(64, 0, 0);
        buf.reset_body();
        buf
    };
    // As the tile pass draws them: two halves, bucketed, culled, finished sorting.
    // Both builds: AVX2 (where the processor has it) and the portable one.
    let draw_bucketed = |level: Level| {
        let mut bucketed = fresh();
        let (first, second) = segs.split_at(700);
        let (mut out, mut lows, mut keys, mut buckets) = (vec![], vec![], vec![], [0; 257]);
        let n = bucket_tile(
            first,
            second,
            key,
            &mut out,
            &mut lows,
            &mut keys,
            &mut buckets,
        );
        assert_eq!(n, segs.len());
        draw_buckets(
            level,
            &mut bucketed,
            &out[..n],
            &lows[..n],
            &buckets,
            &mut vec![],
            half,
            alpha,
        );
        bucketed
    };
    let (bucketed, portable) = (draw_bucketed(Level::Avx2), draw_bucketed(Level::Portable));
    // The reference: a stable sort of the whole key, every segment drawn, none culled.
    let draw_all = |order: &[usize]| {
        let mut buf = fresh();
        for &i in order {
            buf.segment::<Portable>(&segs[i], half, alpha);
        }
        buf
    };
    let mut order: Vec<usize> = (0..segs.len()).collect();
    order.sort_by_key(|&i| key.of(&segs[i]));
    let reference = draw_all(&order);
    let bits = |b: &TileBuf| {
        b.px.iter()
            .flat_map(|p| p.0.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&bucketed), bits(&reference));
    assert_eq!(bucketed.alive, reference.alive);
    assert_eq!(bits(&portable), bits(&reference));
    assert_eq!(portable.alive, reference.alive);
    // The scene tests what it should: samples turned opaque (so culling had work), and
    // the order shows in the bits.
    assert!(reference.alive < 64 * 64 - 200, "{}", reference.alive);
    order.reverse();
    assert_ne!(bits(&draw_all(&order)), bits(&reference));
}

#[test]
fn a_box_is_hidden_exactly_when_every_block_it_touches_is_closed_at_its_depth() {
    // Against the plain definition, at 2×2, 3×3 and 4×4 supersampling (one and two
    // 16-block chunks per row), for boxes of one to many block rows and columns (narrow
    // and tall, wide and short, and large).
    let mut rng = 7u64;
    for n in [64usize, 96, 128] {
        let mut buf = TileBuf::default();
        buf.reset_samples(n, 0, 0);
        buf.reset_body();
        let nb = buf.nb;
        for by in 0..nb {
            for bx in 0..nb {
                let b = buf.block_at(bx, by);
                let r = lcg(&mut rng);
                buf.block_close[b] = if r < 0.2 {
                    f32::NEG_INFINITY
                } else if r < 0.3 {
                    f32::INFINITY
                } else {
                    r
                };
            }
        }
        let (mut shown, mut hidden) = (0, 0);
        for _ in 0..4000 {
            let x0 = lcg(&mut rng) * (n as f32 + 8.0) - 4.0;
            let y0 = lcg(&mut rng) * (n as f32 + 8.0) - 4.0;
            let x1 = x0 + lcg(&mut rng) * if lcg(&mut rng) < 0.2 { 40.0 } else { 12.0 };
            let y1 = y0 + lcg(&mut rng) * if lcg(&mut rng) < 0.2 { 40.0 } else { 12.0 };
            let z = lcg(&mut rng) * 1.2 - 0.1;
            let clamp = |v: f32| (floor_pos(v) / BLOCK).min(nb - 1);
            let mut far = f32::NEG_INFINITY;
            for by in clamp(y0)..=clamp(y1) {
                for bx in clamp(x0)..=clamp(x1) {
                    far = far.max(buf.block_close[buf.block_at(bx, by)]);
                }
            }
            let want = z >= far;
            assert_eq!(
                buf.hidden::<Portable>(x0, x1, y0, y1, z),
                want,
                "n {n} box {x0} {x1} {y0} {y1} z {z}"
            );
            assert_eq!(
                buf.hidden::<Avx2>(x0, x1, y0, y1, z),
                want,
                "SSE: n {n} box {x0} {x1} {y0} {y1} z {z}"
            );
            if want {
                hidden += 1;
            } else {
                shown += 1;
            }
        }
        // Both answers were exercised.
        assert!(shown > 100 && hidden > 100, "{shown} {hidden}");
    }
}

#[test]
fn the_sse_window_blend_gives_the_portable_blend_bit_for_bit_with_the_opaque_counts() {
    let n = 64;
    let mut rng = 11u64;
    let mut a = TileBuf::default();
    a.reset_samples(n, 0, 0);
    a.reset_body();
    for (p, zb) in a.px.iter_mut().zip(a.zb.iter_mut()) {
        let tr = if lcg(&mut rng) < 0.3 {
            0.0025
        } else {
            lcg(&mut rng)
        };
        *p = Px([
            lcg(&mut rng) * 0.3,
            lcg(&mut rng) * 0.2,
            lcg(&mut rng) * 0.1,
            tr,
        ]);
        *zb = if lcg(&mut rng) < 0.3 {
            lcg(&mut rng) * 2.0
        } else {
            f32::INFINITY
        };
    }
    let mut b = TileBuf::default();
    b.reset_samples(n, 0, 0);
    b.px.clone_from(&a.px);
    b.zb.clone_from(&a.zb);
    let mut turned = 0;
    for _ in 0..3000 {
        let x_major = lcg(&mut rng) < 0.5;
        let col_i = (lcg(&mut rng) * n as f32) as usize;
        let y_lo = lcg(&mut rng) * (n as f32 - 1.0);
        let y_hi = y_lo + lcg(&mut rng) * 2.9;
        let js = floor_pos(y_lo).min(n - WINDOW);
        let (stride_maj, stride_min) = if x_major { (1, n) } else { (n, 1) };
        let at = col_i * stride_maj + js * stride_min;
        let col = Column::new(x_major, col_i, a.stride);
        let z = lcg(&mut rng) * 2.0;
        let w0 = lcg(&mut rng) * 0.55;
        let rgb = Px([lcg(&mut rng), lcg(&mut rng), lcg(&mut rng), -1.0]);
        let alive = a.alive;
        a.blend_window::<Avx2>(at, stride_min, js, col, z, w0, (y_lo, y_hi), &rgb);
        b.blend_window::<Portable>(at, stride_min, js, col, z, w0, (y_lo, y_hi), &rgb);
        turned += alive - a.alive;
    }
    let bits =
        |t: &TileBuf| -> Vec<u32> { t.px.iter().flat_map(|p| p.0.map(f32::to_bits)).collect() };
    assert!(bits(&a) == bits(&b), "the two blends differ");
    assert_eq!((a.alive, &a.block_alive), (b.alive, &b.block_alive));
    // Samples did turn opaque along the way, and were counted alike.
    assert!(turned > 10, "{turned}");
}

#[test]
fn a_tile_started_from_its_body_layer_has_the_body_cast_in_it() {
    let (view, mut layer) = sphere_tile();
    let mut direct = TileBuf::default();
    direct.reset_samples(64, 0, 0);
    direct.reset_body();
    direct.cast_body(&view, &sphere_prims(&view));
    direct.close_blocks();
    let mut from_layer = TileBuf::default();
    // A previous tile's leftovers must not survive.
    from_layer.reset_samples(64, 64, 64);
    from_layer.reset_body();
    from_layer.zb.fill(-1.0);
    from_layer.reset_with(64, &mut layer);
    assert_eq!(from_layer.zb, direct.zb);
    assert_eq!(from_layer.block_close, direct.block_close);
    assert_eq!((from_layer.ox, from_layer.oy), (0, 0));
    assert!(from_layer.px.iter().all(|p| p.0 == [0.0, 0.0, 0.0, 1.0]));
}
