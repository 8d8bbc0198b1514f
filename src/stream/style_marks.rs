//! The Style panel's key strands (`run --web`): every wisp's key strand at
//! `/style/key_strands` (clicking one in the viewer selects it on the page), and the selected
//! one highlighted at `/style/selected`, with its control points and the local frame at each
//! (Zhang & Wünsche 2007, §3.1). They are drawn at rest under `/style`, which follows the
//! head's pose every frame. What to draw comes from the editor ([`Marks`]), not the solver.

use rerun::{Arrows3D, Color, LineStrips3D, Points3D, Transform3D};

use super::Logger;
use crate::frame::Frame;
use crate::style::edit::Marks;

/// The head-fixed space of the marks.
const STYLE: &str = "/style";
/// Every key strand.
pub const KEY_STRANDS: &str = "/style/key_strands";
/// The selected key strand.
pub const SELECTED: &str = "/style/selected";
const SELECTED_POINTS: &str = "/style/selected/points";
const SELECTED_FRAMES: &str = "/style/selected/frames";
/// Length of the drawn local-frame axes, m.
const AXIS: f32 = 0.025;

impl Logger {
    /// Draws the key strands as the Style panel has them now (static: they stand until the
    /// next edit, whatever the time cursor).
    pub fn log_style_marks(&mut self, m: &Marks) -> anyhow::Result<()> {
        let rec = &self.rec;
        rec.log_static(
            KEY_STRANDS,
            &LineStrips3D::new(m.key_strands.iter().cloned())
                .with_colors([Color::from_rgb(150, 230, 255)])
                .with_radii([0.0015]),
        )?;
        match &m.selected {
            Some(s) => {
                rec.log_static(
                    SELECTED,
                    &LineStrips3D::new([s.curve.clone()])
                        .with_colors([Color::from_rgb(255, 40, 220)])
                        .with_radii([0.004])
                        .with_labels([format!("key strand of {}", s.name)]),
                )?;
                rec.log_static(
                    SELECTED_POINTS,
                    &Points3D::new(s.points.iter().copied())
                        .with_colors([Color::from_rgb(255, 255, 255)])
                        .with_radii([0.006]),
                )?;
                // Tangent red, normal green, perpendicular blue, as the page's axes.
                let mut origins = Vec::new();
                let mut vectors = Vec::new();
                let mut colors = Vec::new();
                for (p, f) in s.points.iter().zip(&s.frames) {
                    for (axis, c) in f.iter().zip([(255, 60, 60), (60, 220, 60), (80, 140, 255)]) {
                        origins.push(*p);
                        vectors.push(axis.map(|v| v * AXIS));
                        colors.push(Color::from_rgb(c.0, c.1, c.2));
                    }
                }
                rec.log_static(
                    SELECTED_FRAMES,
                    &Arrows3D::from_vectors(vectors)
                        .with_origins(origins)
                        .with_colors(colors),
                )?;
            }
            None => {
                rec.log_static(SELECTED, &LineStrips3D::clear_fields())?;
                rec.log_static(SELECTED_POINTS, &Points3D::clear_fields())?;
                rec.log_static(SELECTED_FRAMES, &Arrows3D::clear_fields())?;
            }
        }
        self.style_drawn = true;
        Ok(())
    }

    /// Moves the marks with the head (they are drawn at rest).
    pub(super) fn log_style_pose(&self, frame: &Frame) -> anyhow::Result<()> {
        if self.style_drawn {
            let b = &frame.body;
            self.rec.log(
                STYLE,
                &Transform3D::from_translation_rotation(
                    b.pose_translation,
                    rerun::Quaternion::from_xyzw(b.pose_rotation),
                ),
            )?;
        }
        Ok(())
    }
}
