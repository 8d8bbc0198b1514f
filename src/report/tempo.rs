//! How fast a run goes against the wall clock: the real-time factor (simulated seconds ÷ wall
//! seconds; 1 is live, under 1 is slow motion), frame by frame and over the whole run.
//!
//! A frame's wall time is the time between the ends of two consecutive frames: stepping,
//! filling, and whatever the thread waited for (a live run's pacing, a full logging queue), so
//! a paced live run that keeps up reads 1, and a recording reads how much faster than real
//! time it went. The logged factor is taken over a sliding window of one second of frames, so
//! a single slow frame (a burst of other work on a shared machine) does not read as slow
//! motion.

use std::time::Instant;

/// Frames in the window of the logged factor: one second at the paper's 25 frames/s.
pub const WINDOW_FRAMES: usize = 25;

/// A live run reads as slow motion below this factor. A paced run that keeps up reads 1 to
/// within the jitter of its sleeps (well under 1 %); 3 % below is a run that cannot keep up.
pub const SLOW_BELOW: f64 = 0.97;

/// Bins of the frame-time histogram: log-spaced by [`BIN_RATIO`] from [`BIN_FLOOR_MS`], up to
/// ~100 s a frame (anything longer lands in the last bin).
const BINS: usize = 820;
/// The lower edge of the first bin, ms.
const BIN_FLOOR_MS: f64 = 0.01;
/// The ratio of neighbouring bin edges: a percentile is read to within 2 %.
const BIN_RATIO: f64 = 1.02;

/// The real-time factor of a run, frame by frame and in total.
#[derive(Debug, Clone)]
pub struct RealtimeMeter {
    clock: Instant,
    /// The last [`WINDOW_FRAMES`] frames: (wall s, simulated s).
    window: [(f64, f64); WINDOW_FRAMES],
    filled: usize,
    next: usize,
    tempo: Tempo,
}

impl Default for RealtimeMeter {
    fn default() -> Self {
        RealtimeMeter::new()
    }
}

impl RealtimeMeter {
    /// A meter whose first frame starts now.
    pub fn new() -> RealtimeMeter {
        RealtimeMeter {
            clock: Instant::now(),
            window: [(0.0, 0.0); WINDOW_FRAMES],
            filled: 0,
            next: 0,
            tempo: Tempo::default(),
        }
    }

    /// The next frame starts now: the time since the last one (a pause, a restart, loading a
    /// new model) is not the run's. The window starts afresh too.
    pub fn restart_clock(&mut self) {
        self.clock = Instant::now();
        self.filled = 0;
        self.next = 0;
    }

    /// A frame of `sim_dt` simulated seconds ended now. Returns the factor over the window.
    pub fn frame_done(&mut self, sim_dt: f64) -> f64 {
        let now = Instant::now();
        let wall = (now - self.clock).as_secs_f64();
        self.clock = now;
        self.record(wall, sim_dt)
    }

    /// Records a frame that took `wall` seconds for `sim_dt` simulated ones (what
    /// [`RealtimeMeter::frame_done`] measures). Returns the factor over the window.
    pub fn record(&mut self, wall: f64, sim_dt: f64) -> f64 {
        self.window[self.next] = (wall, sim_dt);
        self.next = (self.next + 1) % WINDOW_FRAMES;
        self.filled = (self.filled + 1).min(WINDOW_FRAMES);
        self.tempo.add(wall, sim_dt);
        self.window_factor()
    }

    /// Simulated over wall seconds of the last second of frames (fewer right after a start).
    pub fn window_factor(&self) -> f64 {
        let (wall, sim) = self.window[..self.filled]
            .iter()
            .fold((0.0, 0.0), |(w, s), &(fw, fs)| (w + fw, s + fs));
        factor(sim, wall)
    }

    /// Whether the window holds a whole second of frames.
    pub fn window_full(&self) -> bool {
        self.filled == WINDOW_FRAMES
    }

    /// Whether the window says enough to judge the pace: a whole second of frames, or, for a
    /// run so slow that a second of frames is long in coming, two seconds of wall time.
    pub fn window_settled(&self) -> bool {
        self.window_full() || self.window[..self.filled].iter().map(|w| w.0).sum::<f64>() >= 2.0
    }

    /// Everything measured since the meter was made (restarts included).
    pub fn tempo(&self) -> &Tempo {
        &self.tempo
    }
}

fn factor(sim: f64, wall: f64) -> f64 {
    if wall > 0.0 {
        sim / wall
    } else {
        f64::INFINITY
    }
}

/// A run's frames: how many, their simulated and wall seconds, and the distribution of their
/// wall times (bounded memory however long the run).
#[derive(Debug, Clone, PartialEq)]
pub struct Tempo {
    /// Frames measured.
    pub frames: u64,
    /// Their wall seconds.
    pub wall_s: f64,
    /// Their simulated seconds.
    pub sim_s: f64,
    /// The longest frame, s.
    pub max_frame_s: f64,
    histogram: Vec<u32>,
}

impl Default for Tempo {
    fn default() -> Self {
        Tempo {
            frames: 0,
            wall_s: 0.0,
            sim_s: 0.0,
            max_frame_s: 0.0,
            histogram: vec![0; BINS],
        }
    }
}

impl Tempo {
    fn add(&mut self, wall: f64, sim: f64) {
        self.frames += 1;
        self.wall_s += wall;
        self.sim_s += sim;
        self.max_frame_s = self.max_frame_s.max(wall);
        self.histogram[bin(wall * 1e3)] += 1;
    }

    /// Simulated over wall seconds over the whole run.
    pub fn realtime_factor(&self) -> f64 {
        factor(self.sim_s, self.wall_s)
    }

    /// The wall time of a frame that `q` (0–1) of the frames do not exceed, ms: the upper edge
    /// of its histogram bin (within 2 % above the true value), never above the longest frame.
    pub fn frame_ms_quantile(&self, q: f64) -> f64 {
        if self.frames == 0 {
            return 0.0;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.frames as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (b, &n) in self.histogram.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank {
                return upper_edge_ms(b).min(self.max_frame_s * 1e3);
            }
        }
        self.max_frame_s * 1e3
    }
}

fn bin(ms: f64) -> usize {
    if ms.is_nan() || ms <= BIN_FLOOR_MS {
        return 0;
    }
    let b = ((ms / BIN_FLOOR_MS).ln() / BIN_RATIO.ln()).floor();
    (b as usize).min(BINS - 1)
}

fn upper_edge_ms(b: usize) -> f64 {
    BIN_FLOOR_MS * BIN_RATIO.powi(b as i32 + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_is_simulated_over_wall_seconds_in_the_window_and_overall() {
        let mut m = RealtimeMeter::new();
        // 25 frames of 40 ms simulated, each taking 100 ms: 0.4 of real time.
        for _ in 0..WINDOW_FRAMES {
            m.record(0.1, 0.04);
        }
        assert!((m.window_factor() - 0.4).abs() < 1e-12);
        assert!(m.window_full());
        // Then 25 frames at twice real time: the window forgets the slow second...
        for _ in 0..WINDOW_FRAMES {
            m.record(0.02, 0.04);
        }
        assert!((m.window_factor() - 2.0).abs() < 1e-12);
        // ...the whole run does not: 2 s simulated in 3 s.
        assert!((m.tempo().realtime_factor() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.tempo().frames, 50);
    }

    #[test]
    fn a_restart_empties_the_window_but_keeps_the_run() {
        let mut m = RealtimeMeter::new();
        for _ in 0..10 {
            m.record(0.1, 0.04);
        }
        m.restart_clock();
        assert!(!m.window_full());
        assert!((m.record(0.01, 0.04) - 4.0).abs() < 1e-12);
        assert_eq!(m.tempo().frames, 11);
    }

    #[test]
    fn a_slow_run_is_judged_after_two_seconds_without_a_full_window() {
        let mut m = RealtimeMeter::new();
        for _ in 0..3 {
            m.record(0.5, 0.04);
            assert!(!m.window_settled());
        }
        m.record(0.5, 0.04);
        assert!(m.window_settled() && !m.window_full());
    }

    #[test]
    fn the_95th_percentile_frame_is_read_within_two_percent() {
        let mut m = RealtimeMeter::new();
        // 1..=100 ms: the 95th percentile is 95 ms.
        for k in 1..=100 {
            m.record(k as f64 * 1e-3, 0.04);
        }
        let p95 = m.tempo().frame_ms_quantile(0.95);
        assert!((95.0..=95.0 * 1.02).contains(&p95), "p95 = {p95}");
        assert!((m.tempo().frame_ms_quantile(1.0) - 100.0).abs() < 1e-9);
        // One frame: its own time (the edge never exceeds the longest frame).
        let mut one = RealtimeMeter::new();
        one.record(0.0123, 0.04);
        assert!((one.tempo().frame_ms_quantile(0.95) - 12.3).abs() < 1e-9);
    }

    #[test]
    fn frame_done_measures_the_time_since_the_last_frame() {
        let mut m = RealtimeMeter::new();
        std::thread::sleep(std::time::Duration::from_millis(20));
        let f = m.frame_done(0.04);
        // At least 20 ms went by, so at most 2× real time.
        assert!(f <= 2.0 + 1e-9 && f > 0.0, "factor {f}");
        assert!(m.tempo().wall_s >= 0.02);
    }
}
