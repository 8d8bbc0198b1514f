//! Reading decoded Rerun chunks back in tests (shared by tests/run.rs, tests/live.rs and tests/stream.rs;
//! included with `#[path]` there only, so other test binaries need not build it).
#![allow(dead_code)] // each test binary uses its own part

use std::io::BufReader;
use std::path::Path;

use rerun::external::re_log_types::LogMsg;
use rerun::Scalars;

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

/// The recording's (non-blueprint) chunks, decoded from the file with the SDK's decoder.
pub fn decode_file(path: &Path) -> Vec<Chunk> {
    let file = std::fs::File::open(path).expect("the recording exists");
    let mut chunks = Vec::new();
    for msg in rerun::external::re_log_encoding::DecoderApp::decode_lazy(BufReader::new(file)) {
        match msg.expect("every message decodes") {
            LogMsg::ArrowMsg(store, arrow) if !store.is_blueprint() => {
                chunks.push(Chunk::from_arrow_msg(&arrow).expect("chunk decodes"));
            }
            _ => {}
        }
    }
    assert!(!chunks.is_empty(), "{}: no data", path.display());
    chunks
}

/// `(frame, value)` of a scalar series.
pub fn scalars(chunks: &[Chunk], path: &str) -> Vec<(i64, f64)> {
    let path: rerun::EntityPath = path.into();
    let timeline = TimelineName::from("frame");
    let component = Scalars::descriptor_scalars().component;
    let mut out = Vec::new();
    for c in chunks.iter().filter(|c| *c.entity_path() == path) {
        for ((t, _), v) in c
            .iter_component_indices(timeline, component)
            .zip(c.iter_component::<rerun::components::Scalar>(component))
        {
            out.push((t.as_i64(), v.as_slice()[0].0 .0));
        }
    }
    out.sort_by_key(|a| a.0);
    out
}
