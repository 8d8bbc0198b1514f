//! Criterion benchmark of the hair renderer on the 16,215-strand head of Zhang and Wünsche
//! 2007, §7.2, at 640×480 with 1 and 2 threads.
//!
//! `cargo bench --bench render`

use criterion::{criterion_group, criterion_main, Criterion};
use wisptree::render::{
    bounds, camera::DEFAULT_VIEW, zhang_16k_body, zhang_16k_strands, Camera, Image, RenderInput,
    RenderParams, Renderer,
};

fn render(c: &mut Criterion) {
    let strands = zhang_16k_strands();
    let body = zhang_16k_body();
    let (lo, hi) = bounds(&strands.points);
    let cam = Camera::framing(lo, hi, DEFAULT_VIEW);
    let input = RenderInput {
        strands: &strands,
        body: &body,
    };
    let mut g = c.benchmark_group("render");
    g.sample_size(20);
    for threads in [1, 2] {
        let mut r =
            Renderer::new(RenderParams::default(), 640, 480, threads).expect("a valid renderer");
        let mut img = Image::default();
        r.render(&input, &cam, &mut img);
        g.bench_function(format!("16k_640x480/{threads}t"), |b| {
            b.iter(|| r.render(&input, &cam, &mut img))
        });
    }
    g.finish();
}

criterion_group!(benches, render);
criterion_main!(benches);
