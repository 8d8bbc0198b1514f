//! The AWT paper's Figure 7 (Bertails et al. 2003, §5.1) on shortened runs: the four styles
//! under their motions split and merge, the active-node counts it prints follow from those
//! events, and its contact sheet holds a rendered picture in each of its 4 × 4 cells.

use wisptree::experiment::{ExperimentOptions, ExperimentRun, FrameExtras, FrameSink};
use wisptree::render::Image;
use wisptree::solver::{AdaptEvent, Solver};

/// Keeps the pictures, and counts the frames that came with counters and with an image.
#[derive(Default)]
struct Keep {
    wants_images: bool,
    pictures: Vec<(String, Image)>,
    frames: usize,
    with_counters: usize,
    with_images: usize,
    /// Runs asked to follow their head.
    followed: Vec<String>,
}

impl FrameSink for Keep {
    fn frame(&mut self, _: &str, _: &mut dyn Solver, _: &[AdaptEvent]) -> anyhow::Result<()> {
        self.frames += 1;
        Ok(())
    }

    fn frame_with(
        &mut self,
        label: &str,
        solver: &mut dyn Solver,
        events: &[AdaptEvent],
        extras: FrameExtras<'_>,
    ) -> anyhow::Result<()> {
        self.with_counters += usize::from(extras.counters.is_some());
        if extras.follow_head && !self.followed.iter().any(|l| l == label) {
            self.followed.push(label.to_owned());
        }
        if let Some(img) = extras.image {
            assert!(img.width > 0 && img.rgb.len() == (img.width * img.height * 3) as usize);
            self.with_images += 1;
        }
        self.frame(label, solver, events)
    }

    fn wants_images(&self) -> bool {
        self.wants_images
    }

    fn picture(&mut self, name: &str, image: &Image) -> anyhow::Result<()> {
        self.pictures.push((name.to_owned(), image.clone()));
        Ok(())
    }
}

fn run(scale: f64, sink: &mut Keep) -> Vec<ExperimentRun> {
    let def = wisptree::experiment::find("awt-fig7").expect("registered");
    let opts = ExperimentOptions {
        duration_scale: scale,
    };
    (def.run)(&opts, sink).expect("runs")
}

fn int(r: &ExperimentRun, key: &str) -> i64 {
    r.metrics[key]
        .as_i64()
        .unwrap_or_else(|| panic!("{}: {key} = {}", r.label, r.metrics[key]))
}

#[test]
fn every_style_splits_and_merges_and_its_counts_follow_from_the_events() {
    let mut sink = Keep::default();
    let runs = run(0.5, &mut sink);
    let labels: Vec<&str> = runs.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(
        labels,
        [
            "short_run",
            "long_lean",
            "long_curly_lean",
            "short_curly_lean"
        ],
        "the figure's rows, top to bottom"
    );
    for r in &runs {
        let (splits, merges) = (int(r, "splits"), int(r, "merges"));
        assert!(splits > 0, "{}: the motion splits wisps", r.label);
        assert!(merges > 0, "{}: and they merge back", r.label);
        // The active set changes only by splits and merges.
        assert_eq!(
            int(r, "active_end") - int(r, "active_start"),
            int(r, "active_change_by_events"),
            "{}",
            r.label
        );
        assert_eq!(int(r, "active_change"), int(r, "active_change_by_events"));
        let finest = int(r, "finest_nodes");
        let series: Vec<i64> = r.metrics["active_over_time"]
            .as_array()
            .expect("a list")
            .iter()
            .map(|v| v.as_i64().expect("a count"))
            .collect();
        // 2.2 s sampled every 0.2 s (0.4 s scaled by a half).
        assert_eq!(series.len(), 11, "{}: {series:?}", r.label);
        assert!(
            series.iter().all(|&n| n > 0 && n <= int(r, "active_max")),
            "{}: {series:?}",
            r.label
        );
        assert!(
            int(r, "active_max") < finest,
            "{}: the AWT keeps fewer nodes than the finest level ({finest})",
            r.label
        );
        assert!(
            series.windows(2).any(|w| w[0] != w[1]),
            "{}: the count moves over time: {series:?}",
            r.label
        );
    }
    assert_eq!(
        sink.frames,
        4 * 55,
        "every frame of every run reaches the sink"
    );
    assert_eq!(sink.with_counters, sink.frames);
    assert_eq!(sink.with_images, 0, "no image unless the sink wants them");
    assert_eq!(
        sink.followed,
        ["short_run"],
        "only the running head leaves a fixed view"
    );

    // The contact sheet: 4 rows (styles) × 4 columns (times), each cell rendered hair.
    assert_eq!(sink.pictures.len(), 1);
    let (name, sheet) = &sink.pictures[0];
    assert_eq!(name, "awt_fig7");
    let (cols, rows) = (4u32, 4u32);
    let (cw, ch) = ((sheet.width - 4) / cols, (sheet.height - 4) / rows);
    for r in 0..rows {
        for c in 0..cols {
            let mut dark = 0;
            for y in (r * ch + 8..(r + 1) * ch - 4).step_by(2) {
                for x in (c * cw + 8..(c + 1) * cw - 4).step_by(2) {
                    let p = sheet.pixel(x, y);
                    // Hair is dark brown; the background is near white.
                    dark += usize::from(p.iter().all(|&v| v < 110));
                }
            }
            assert!(
                dark > 200,
                "cell ({r}, {c}) shows hair: {dark} dark samples"
            );
        }
    }
}

#[test]
fn a_sink_that_shows_images_gets_every_frame_rendered() {
    let mut sink = Keep {
        wants_images: true,
        ..Keep::default()
    };
    run(0.05, &mut sink);
    assert!(sink.frames > 0);
    assert_eq!(sink.with_images, sink.frames);
}
