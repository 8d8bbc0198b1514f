//! A live run's rendering: the hair is drawn on the cores the simulation leaves free, and each
//! image is logged at the frame it shows. A file of its own, so that no other test of this
//! crate runs beside it: the drawing thread is in the idle scheduling class (see
//! `src/app/render_thread.rs`) and gets only cores nothing else wants.

#[path = "common/rrd.rs"]
mod rrd;
#[path = "common/tiny_style.rs"]
mod tiny_style;

use std::collections::BTreeSet;

use wisptree::app::{self as run, StopSignal};
use wisptree::scene::Scene;
use wisptree::solver::SolverKind;

/// Live (paced, as `run --web` or `--connect` runs), the hair is still rendered: the drawing
/// thread works while the simulation waits for the wall clock, and each image is logged at the
/// frame it shows, never later than the frame that carried it.
#[test]
fn a_live_run_renders_images_and_logs_each_at_the_frame_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let style = dir.path().join("tiny.ron");
    std::fs::write(&style, tiny_style::tiny_style("0.2")).unwrap();
    let out = dir.path().join("live.rrd");
    let scene = Scene::load(style.to_str().unwrap(), "shake", SolverKind::Awt).unwrap();
    let rec = wisptree::stream::sink::Recording(
        rerun::RecordingStreamBuilder::new("wisptree-test")
            .save(&out)
            .expect("opening the recording"),
    );
    let opts = run::LoopOptions {
        seconds: Some(2.0),
        live: true,
        watch: false,
        keys: false,
        progress: false,
        strands: 20,
        render: Some((160, 120)),
        render_skips_when_behind: true,
        quiet: true,
        web: None,
        inspect: None,
    };
    let summary = run::simulate_into(&scene, rec, &opts, &StopSignal::new()).expect("the run");
    assert_eq!(summary.frames_logged, 50, "every frame of 2 s logged");
    let chunks = rrd::decode_file(&out);
    let blob = rerun::EncodedImage::descriptor_blob().component;
    let images = rrd::rows(&chunks, wisptree::stream::paths::RENDER, blob);
    // A tiny style keeps up easily, so the drawing thread has most of the time: many frames
    // get their image (each at most once). Fewer means the idle-class drawing thread found no
    // free core: something else kept this machine's cores busy (run this test alone).
    assert!(
        images.len() >= 10,
        "{} images in 50 frames: {images:?}",
        images.len()
    );
    let frames: BTreeSet<i64> = images.iter().map(|r| r.0).collect();
    assert_eq!(frames.len(), images.len(), "one image per frame at most");
    assert!(frames.iter().all(|f| (0..50).contains(f)), "{frames:?}");
    let skipped = rrd::scalars(&chunks, "/stats/render_skipped");
    let last = skipped.last().expect("render_skipped logged").1;
    assert!(
        last <= (50 - images.len()) as f64,
        "skipped {last} with {} images",
        images.len()
    );
}
