//! The frame's last round: the tiles' pixels gathered into the frame, then the postfilter and
//! the sRGB encoding, in bands of rows.

use super::{resolve, timed, Image, Renderer, CHUNKS, RESOLVE, TILE};
use crate::par::split_parts;

impl Renderer {
    /// Gathers the tiles' linear pixels into the frame, then postfilters and encodes it into
    /// `out` in bands of rows, one job per band.
    pub(super) fn finish(&mut self, out: &mut Image) {
        let (w, h) = (self.width as usize, self.height as usize);
        self.linear.resize(w * h * 3, 0.0);
        // The gather, in bands of whole rows of tiles, one job each.
        let (grid, tiles) = (self.grid, &self.tiles);
        let rows = split_parts::<_, CHUNKS>(&mut self.linear, |c| {
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
        let bands = split_parts::<_, CHUNKS>(&mut out.rgb, |c| (c + 1) * h / CHUNKS * w * 3);
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
