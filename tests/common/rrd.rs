//! Reading decoded Rerun chunks back in tests (shared by tests/run.rs and tests/stream.rs;
//! included with `#[path]` there only, so other test binaries need not build it).

use rerun::log::Chunk;
use rerun::{ComponentIdentifier, TimelineName};

/// `(frame, instance count)` of every row holding `component` at `path`, in frame order.
pub fn rows(chunks: &[Chunk], path: &str, component: ComponentIdentifier) -> Vec<(i64, usize)> {
    let path: rerun::EntityPath = path.into();
    let timeline = TimelineName::from("frame");
    let mut out = Vec::new();
    for c in chunks.iter().filter(|c| *c.entity_path() == path) {
        for ((t, _), span) in c
            .iter_component_indices(timeline, component)
            .zip(c.iter_component_offsets(component))
        {
            out.push((t.as_i64(), span.len));
        }
    }
    out.sort();
    out
}
