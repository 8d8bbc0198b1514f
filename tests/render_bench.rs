//! `wisptree bench --render`: the renderer's timing table and its JSON (numbers are not
//! asserted, only their presence and shape).

use std::process::Command;

#[test]
fn bench_render_writes_one_row_per_scene() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("r.json");
    let out = Command::new(env!("CARGO_BIN_EXE_wisptree"))
        .args(["bench", "--render", "--quick", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = v["render"].as_array().expect("a render array");
    let scenes: Vec<&str> = rows.iter().map(|r| r["scene"].as_str().unwrap()).collect();
    assert_eq!(scenes, ["long", "long_curly", "zhang_16k"]);
    for r in rows {
        assert_eq!(r["width"], 640);
        assert_eq!(r["height"], 480);
        assert!(r["fps_1_thread"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["fps_2_threads"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["fps_1_thread_mean"].as_f64().unwrap() > 0.0, "{r}");
        assert!(r["fps_2_threads_mean"].as_f64().unwrap() > 0.0, "{r}");
    }
    let zhang = &rows[2];
    assert_eq!(zhang["strands"], 16215);
    assert!(zhang["segments"].as_u64().unwrap() > 350_000, "{zhang}");
    // Every Long strand of the model is rendered, not the display subset.
    assert_eq!(rows[0]["strands"], 12797);
}
