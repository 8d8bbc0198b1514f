//! Reading a sweep's `.rrd` back in tests/sweep.rs: every logged cell by entity, component
//! and frame, compared bit for bit between recordings.

use std::collections::BTreeMap;
use std::io::BufReader;
use std::path::Path;

use rerun::external::arrow::array::{Array as _, ArrayRef};
use rerun::external::re_log_types::LogMsg;
use rerun::log::Chunk;
use rerun::TimelineName;

/// A decoded `.rrd`: the recording's chunks, the blueprint's, and the recording store ids.
pub struct Rrd {
    pub data: Vec<Chunk>,
    pub blueprint: Vec<Chunk>,
    pub recording_ids: Vec<String>,
}

pub fn read_rrd(path: &Path) -> Rrd {
    let file = std::fs::File::open(path).expect("the recording exists");
    let mut r = Rrd {
        data: Vec::new(),
        blueprint: Vec::new(),
        recording_ids: Vec::new(),
    };
    for msg in rerun::external::re_log_encoding::DecoderApp::decode_lazy(BufReader::new(file)) {
        match msg.expect("every message decodes") {
            LogMsg::ArrowMsg(store, arrow) => {
                let c = Chunk::from_arrow_msg(&arrow).expect("chunk decodes");
                if store.is_blueprint() {
                    r.blueprint.push(c);
                } else {
                    r.data.push(c);
                }
            }
            LogMsg::SetStoreInfo(info) if !info.info.store_id.is_blueprint() => {
                let id = info.info.store_id.recording_id().to_string();
                if !r.recording_ids.contains(&id) {
                    r.recording_ids.push(id);
                }
            }
            _ => {}
        }
    }
    r
}

/// (entity, component, frame; `None` for static and blueprint data).
pub type CellKey = (String, String, Option<i64>);
pub type Cells = BTreeMap<CellKey, Vec<ArrayRef>>;

/// Every logged cell by (entity, component, frame; `None` for static and blueprint data), the
/// cells of one key in a fixed order.
pub fn cells(chunks: &[Chunk]) -> Cells {
    let frame = TimelineName::from("frame");
    let mut out: Cells = BTreeMap::new();
    for c in chunks {
        let times = c.timelines().get(&frame).map(|t| t.times_raw().to_vec());
        for (component, col) in c.components().iter() {
            for row in 0..c.num_rows() {
                if !col.list_array.is_valid(row) {
                    continue;
                }
                let key = (
                    c.entity_path().to_string(),
                    component.to_string(),
                    times.as_ref().map(|t| t[row]),
                );
                out.entry(key).or_default().push(col.list_array.value(row));
            }
        }
    }
    for v in out.values_mut() {
        v.sort_by_cached_key(|a| format!("{a:?}"));
    }
    out
}

pub fn cell_text(cells: &Cells, entity_prefix: &str, component_part: &str) -> Vec<String> {
    cells
        .iter()
        .filter(|((e, c, _), _)| e.starts_with(entity_prefix) && c.contains(component_part))
        .flat_map(|(_, v)| v.iter().map(|a| format!("{a:?}")))
        .collect()
}

/// The cells of run `label` (its subtree), without the step time (wall-clock timing).
pub fn run_cells(all: &Cells, label: &str) -> Vec<(CellKey, Vec<ArrayRef>)> {
    let prefix = format!("/runs/{label}/");
    all.iter()
        // Wall-clock measurements differ from run to run; everything simulated must not.
        .filter(|((e, _, _), _)| {
            e.starts_with(&prefix)
                && !e.ends_with("/stats/step_ms")
                && !e.ends_with("/stats/realtime_factor")
        })
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect()
}

pub fn assert_same_run(a: &Cells, b: &Cells, label: &str) {
    let (a, b) = (run_cells(a, label), run_cells(b, label));
    assert!(a.len() > 100, "{label}: only {} cells", a.len());
    assert_eq!(a.len(), b.len(), "{label}: cell counts differ");
    for ((ka, va), (kb, vb)) in a.iter().zip(&b) {
        assert_eq!(ka, kb, "{label}");
        assert_eq!(va.len(), vb.len(), "{ka:?}");
        for (x, y) in va.iter().zip(vb) {
            assert!(x.to_data() == y.to_data(), "{ka:?} differs");
        }
    }
}

/// The positions of the AWT's active nodes logged for run `label` at frame `frame`.
pub fn node_positions(chunks: &[Chunk], label: &str, frame: i64) -> Vec<[f32; 3]> {
    let path: rerun::EntityPath = format!("/runs/{label}/hair/awt/nodes").into();
    let component = rerun::Points3D::descriptor_positions().component;
    let timeline = TimelineName::from("frame");
    for c in chunks.iter().filter(|c| *c.entity_path() == path) {
        for ((t, _), p) in c
            .iter_component_indices(timeline, component)
            .zip(c.iter_component::<rerun::components::Position3D>(component))
        {
            if t.as_i64() == frame {
                return p.as_slice().iter().map(|q| q.0 .0).collect();
            }
        }
    }
    panic!("no nodes of {label} at frame {frame}")
}
