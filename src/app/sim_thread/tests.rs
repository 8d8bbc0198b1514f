//! Tests of the simulation thread: which frames carry the renderer's strands (the draw gate).

use super::*;
use crate::solver::SolverKind;
use crossbeam_channel::{bounded, unbounded};

/// A simulation thread of `scene` that makes `frames` frames, each with 10 drawn strands and
/// rendering on, into `tx`, handing `gate` to the simulation; paced and dropping frames when
/// `live`. No controls arrive and no frame comes back for reuse.
fn rendering_sim(
    scene: Scene,
    tx: crossbeam_channel::Sender<Frame>,
    gate: Option<DrawGate>,
    frames: u64,
    live: bool,
) -> SimThread {
    SimThread {
        scene,
        strands: 10,
        render: true,
        frames_total: Some(frames),
        live,
        ctl: unbounded().1,
        tx,
        free: unbounded().1,
        shared: None,
        tunes: None,
        inspect: None,
        draw_gate: gate,
    }
}

/// Runs `frames` frames of Short under `lean` with rendering, handing `gate` to the
/// simulation; `before_rest` runs after the first two frames are received. Per frame:
/// whether it carried every strand for the renderer.
fn placed(gate: Option<DrawGate>, frames: u64, before_rest: impl Fn()) -> Vec<bool> {
    let scene = Scene::load("short", "lean", SolverKind::Awt).expect("the built-in style");
    let total = scene.model.strands.len();
    // A rendezvous: the simulation makes frame k + 1 only once frame k is taken.
    let (tx, rx) = bounded::<Frame>(0);
    let sim = rendering_sim(scene, tx, gate, frames, false);
    let run =
        std::thread::spawn(move || sim.run(&StopSignal::new(), &Console::with_progress(None)));
    let mut out = Vec::new();
    for k in 0..frames {
        if k == 2 {
            before_rest();
        }
        let f = rx.recv().expect("a frame");
        assert_eq!(f.strands.offsets.len(), 11, "the 10 drawn strands, always");
        let n = f.render_strands.offsets.len();
        assert!(n == 0 || n == total + 1, "all strands or none: {n}");
        out.push(n > 0);
    }
    run.join().expect("the simulation thread");
    out
}

/// The simulation places every strand for the renderer only in a frame it claimed the
/// gate for: none while the drawing thread holds the gate, exactly one frame after it
/// opens it once. Without a gate (recording), every frame.
#[test]
fn every_strand_is_placed_only_for_frames_that_claimed_the_draw_gate() {
    let gate = DrawGate::default();
    assert!(
        gate.claim(),
        "the drawing thread takes the gate: it is busy"
    );
    let opened = gate.clone();
    let frames = placed(Some(gate.clone()), 6, move || opened.open());
    assert_eq!(&frames[..2], [false, false], "gate closed: {frames:?}");
    assert_eq!(
        frames[2..].iter().filter(|p| **p).count(),
        1,
        "opened once: one frame placed them, {frames:?}"
    );
    assert!(!gate.claim(), "the frame that placed them claimed the gate");
    assert_eq!(placed(None, 3, || {}), [true; 3], "no gate: every frame");
}

/// Live, a frame that claimed the gate but found the logger's queue full is dropped, and
/// its strands never reach the drawing thread: the simulation must open the gate again,
/// or the drawing thread would wait for strands that no frame places any more.
#[test]
fn a_dropped_frame_gives_back_its_claim_on_the_draw_gate() {
    let scene = Scene::load("short", "lean", SolverKind::Awt).expect("the built-in style");
    // A queue of one, already full and never read: every frame of the run is dropped.
    let (tx, _rx) = bounded::<Frame>(1);
    tx.try_send(Frame::default()).expect("room for one frame");
    let gate = DrawGate::default();
    let frames = 3;
    let sim = rendering_sim(scene, tx, Some(gate.clone()), frames, true);
    let out = sim.run(&StopSignal::new(), &Console::with_progress(None));
    assert_eq!(out.frames, frames, "every frame was made");
    assert_eq!(
        out.dropped, frames,
        "and every one dropped: the queue stayed full"
    );
    assert!(
        gate.claim(),
        "the gate is open again after the dropped frames that claimed it"
    );
}
