//! The inspected node (`run --inspect`, the page's inspector): its numbers as scalars and a
//! ring around it in the 3D view. Only what the frame carries is drawn (no physics here).

use rerun::components::FillMode;
use rerun::{Color, Ellipsoids3D, Scalars};

use super::colors::{INSPECTED_COLOR, INSPECTED_SCALE};
use super::{paths, Logger};
use crate::frame::Frame;

impl Logger {
    /// The inspected node's numbers (`run --inspect`), each its own scalar at
    /// `/inspect/<tree>/<level>/<index>/<name>`, so that a recording made with a node selected
    /// can be reviewed later.
    pub(super) fn log_inspect(&mut self, frame: &Frame) -> anyhow::Result<()> {
        let marker = format!("{}{}", self.paths.prefix, paths::INSPECTED_MARKER);
        let Some((node, values)) = &frame.inspect else {
            if std::mem::take(&mut self.inspected_drawn) {
                self.rec.log(marker, &Ellipsoids3D::clear_fields())?;
            }
            return Ok(());
        };
        for (name, v) in values {
            let path = format!("{}{}/{node}/{name}", self.paths.prefix, paths::INSPECT);
            self.rec.log(path, &Scalars::single(*v))?;
        }
        // The node itself, ringed so that it stands out among the active nodes.
        let get = |n: &str| values.iter().find(|(k, _)| *k == n).map(|(_, v)| *v as f32);
        if let (Some(x), Some(y), Some(z), Some(r)) = (
            get("position_x"),
            get("position_y"),
            get("position_z"),
            get("radius"),
        ) {
            let (cr, cg, cb) = INSPECTED_COLOR;
            self.rec.log(
                marker,
                &Ellipsoids3D::from_centers_and_radii([[x, y, z]], [r * INSPECTED_SCALE])
                    .with_colors([Color::from_rgb(cr, cg, cb)])
                    .with_fill_mode(FillMode::MajorWireframe),
            )?;
            self.inspected_drawn = true;
        }
        Ok(())
    }
}
