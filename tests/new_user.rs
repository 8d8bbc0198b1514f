//! What a new user runs into first (issue 9's findings), each as a test of the real binary:
//! running outside the repository, absurd and degenerate styles, a typo'd tile count, roots
//! inside the body, and a `rerun` on PATH that cannot open a window.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use wisptree::stream::sink::VIEWER_PORT_ENV;

const BIN: &str = env!("CARGO_BIN_EXE_wisptree");

/// Runs the binary in `dir` with `PATH` set to `path`, killing it after `limit` (a hang is a
/// failure, not a wait). Returns exit code, stdout, stderr.
fn run_in(dir: &Path, path: &str, args: &[&str], limit: Duration) -> (i32, String, String) {
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .env("PATH", path)
        // A viewer the user has open on Rerun's default port must not change what the run does.
        .env(VIEWER_PORT_ENV, free_port().to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary starts");
    let t0 = Instant::now();
    loop {
        if let Some(_status) = child.try_wait().unwrap() {
            break;
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "wisptree {args:?} still running after {limit:?}; stderr: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A port of 127.0.0.1 nothing listens on now (the system picks it; it is released at once).
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("a free port");
    l.local_addr().unwrap().port()
}

/// A PATH with the usual system folders but no `rerun`.
const NO_VIEWER_PATH: &str = "/usr/bin:/bin";

fn assert_no_panic(err: &str) {
    assert!(
        !err.contains("panicked") && !err.contains("backtrace"),
        "{err}"
    );
}

#[test]
fn built_in_styles_run_from_any_directory() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &[
            "run",
            "--style",
            "long",
            "--seconds",
            "0.2",
            "--save",
            "out.rrd",
        ],
        Duration::from_secs(120),
    );
    assert_eq!(code, 0, "{err}");
    assert!(dir.path().join("out.rrd").metadata().unwrap().len() > 1000);
    assert!(!err.contains("cannot read"), "{err}");
    // With no flag at all and no viewer on PATH, the default style records to wisptree.rrd.
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["--seconds", "0.1"],
        Duration::from_secs(120),
    );
    assert_eq!(code, 0, "{err}");
    assert!(dir.path().join("wisptree.rrd").is_file(), "{err}");
    assert!(err.contains("no Rerun viewer"), "{err}");
}

#[test]
fn styles_lists_the_built_ins_and_writes_one_that_loads_like_the_name() {
    let dir = tempfile::tempdir().unwrap();
    let (code, out, _) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["styles"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 0);
    for name in ["short", "short_curly", "long", "long_curly"] {
        assert!(
            out.lines().any(|l| l.trim_start().starts_with(name)),
            "{out}"
        );
    }
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["styles", "--write", "short"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 0, "{err}");
    let by_name = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["inspect", "--json", "short"],
        Duration::from_secs(30),
    );
    let by_file = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["inspect", "--json", "short.ron"],
        Duration::from_secs(30),
    );
    let strip = |s: &str| {
        s.lines()
            .filter(|l| !l.contains("\"style\""))
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(strip(&by_name.1), strip(&by_file.1));
    // Writing again refuses to overwrite; an unknown name is bad input.
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["styles", "--write", "short"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["styles", "--write", "afro"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("long_curly"), "{err}");
}

#[test]
fn a_built_in_style_is_not_watched_and_says_how_to_get_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &[
            "run",
            "--style",
            "short",
            "--watch",
            "--seconds",
            "0.1",
            "--save",
            "o.rrd",
        ],
        Duration::from_secs(60),
    );
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("not watched"), "{err}");
    assert!(err.contains("wisptree styles --write short"), "{err}");
}

/// The Short style's text with one substitution.
fn short_with(from: &str, to: &str) -> String {
    let s = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/short.ron"))
        .unwrap();
    assert!(s.contains(from), "fixture: `{from}` not in short.ron");
    s.replacen(from, to, 1)
}

#[test]
fn an_absurd_key_strand_coordinate_exits_2_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("huge.ron");
    std::fs::write(
        &p,
        short_with("key_strand: [(0.0185,", "key_strand: [(1e200,"),
    )
    .unwrap();
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["inspect", "huge.ron"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 2, "{err}");
    assert_no_panic(&err);
    assert!(err.contains("huge.ron:"), "{err}");
    assert!(err.contains("hair.wisps[0].key_strand[0]"), "{err}");
}

/// Writes a `.hair` file of `strands` and a style importing it.
fn hair_style(dir: &Path, strands: &[Vec<[f32; 3]>]) -> String {
    wisptree::style::hair_file::write_hair(&dir.join("h.hair"), strands, "test").unwrap();
    let style = "Style(head: (scalp: (center: (0, 1.6, 0), radii: (0.08, 0.1, 0.09))), \
                 hair: Hair((file: \"h.hair\")), \
                 hierarchy: (levels: 2, cross_sections: 6, branching: [2], top_level: 2))";
    std::fs::write(dir.join("imp.ron"), style).unwrap();
    "imp.ron".to_owned()
}

fn strand(x: f32, z: f32) -> Vec<[f32; 3]> {
    (0..8).map(|i| [x, 1.7 - 0.05 * i as f32, z]).collect()
}

#[test]
fn degenerate_imported_strands_exit_2_with_the_reason() {
    type Case = (&'static str, Vec<Vec<[f32; 3]>>, &'static str);
    let cases: Vec<Case> = vec![
        (
            "overflowing coordinate",
            vec![
                strand(0.0, 0.1),
                strand(0.01, 0.1),
                strand(0.02, 0.1),
                vec![[0.03, 1.7, 0.1], [3.0e30, 1.6, 0.1]],
            ],
            "within ±",
        ),
        (
            "zero-length strand",
            vec![
                strand(0.0, 0.1),
                strand(0.01, 0.1),
                strand(0.02, 0.1),
                vec![[0.03, 1.7, 0.1]; 5],
            ],
            "zero length",
        ),
        (
            "duplicate strands",
            vec![
                strand(0.0, 0.1),
                strand(0.01, 0.1),
                strand(0.01, 0.1),
                strand(0.02, 0.1),
            ],
            "identical",
        ),
    ];
    for (what, strands, needle) in cases {
        let dir = tempfile::tempdir().unwrap();
        let style = hair_style(dir.path(), &strands);
        let (code, _, err) = run_in(
            dir.path(),
            NO_VIEWER_PATH,
            &["inspect", &style],
            Duration::from_secs(30),
        );
        assert_eq!(code, 2, "{what}: {err}");
        assert_no_panic(&err);
        assert!(err.contains("imp.ron"), "{what}: {err}");
        assert!(err.contains("`hair`"), "{what}: {err}");
        assert!(err.contains(needle), "{what}: `{needle}` not in {err}");
    }
}

#[test]
fn a_wisp_that_grows_nothing_exits_2_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("sparse.ron");
    // A wisp with no key strand grows nothing.
    let at_key = "key_strand: [(0.0185, 0.0028, -0.0112), (0.0325, -0.0051, -0.0285), (0.0398, -0.0188, -0.0478), (0.0407, -0.0364, -0.0663)]";
    let text = short_with(at_key, "key_strand: []");
    std::fs::write(&p, text).unwrap();
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["inspect", "sparse.ron"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 2, "{err}");
    assert_no_panic(&err);
    assert!(err.contains("sparse.ron:"), "{err}");
    assert!(err.contains("hair.wisps[0].key_strand"), "{err}");
}

#[test]
fn a_huge_tile_count_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("tiles.ron");
    let s = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("styles/long.ron"))
        .unwrap();
    let at = s.find("tiles: (").expect("long.ron has tiles");
    let end = at + s[at..].find(')').unwrap() + 1;
    let text = format!("{}tiles: (1000, 1){}", &s[..at], &s[end..]);
    std::fs::write(&p, text).unwrap();
    for args in [
        vec!["inspect", "tiles.ron"],
        vec![
            "run",
            "--style",
            "tiles.ron",
            "--seconds",
            "1",
            "--save",
            "t.rrd",
        ],
    ] {
        // (A hang guard, not a timing: the refusal comes before any generation.)
        let (code, _, err) = run_in(dir.path(), NO_VIEWER_PATH, &args, Duration::from_secs(30));
        assert_eq!(code, 2, "{err}");
        assert!(err.contains("tiles.ron:"), "{err}");
        assert!(err.contains(".tiles"), "{err}");
        assert!(err.contains("1000"), "{err}");
    }
    assert!(
        !dir.path().join("t.rrd").exists(),
        "no recording for a refused style"
    );
}

#[test]
fn roots_inside_a_collision_sphere_are_reported_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("swallowed.ron");
    // A body sphere that swallows the whole head: every root is inside it.
    let text = short_with(
        "seed: 1,",
        "seed: 1,\n    head: (body: [(center: (0.0, 1.6, 0.0), radius: 0.3)]),",
    );
    std::fs::write(&p, text).unwrap();
    let (code, _, err) = run_in(
        dir.path(),
        NO_VIEWER_PATH,
        &["inspect", "swallowed.ron"],
        Duration::from_secs(30),
    );
    assert_eq!(code, 0, "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("strand roots are inside body sphere 0"))
        .unwrap_or_else(|| panic!("no warning about roots in sphere 0: {err}"));
    assert!(
        line.contains("radius 0.300 m") && line.contains("mm"),
        "{line}"
    );
    let (n, total): (usize, usize) = {
        let words: Vec<&str> = line.split_whitespace().collect();
        // "warning: N of M strand roots ..."
        (words[1].parse().unwrap(), words[3].parse().unwrap())
    };
    assert_eq!(n, total, "every root is inside: {line}");
}

/// A fake `rerun` in its own folder: a shell script with the given body.
fn fake_rerun(dir: &Path, body: &str) -> String {
    let bin = dir.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    let p = bin.join("rerun");
    std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
    use std::os::unix::fs::PermissionsExt as _;
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
    format!("{}:{NO_VIEWER_PATH}", bin.display())
}

#[test]
fn a_viewer_that_dies_or_never_listens_falls_back_to_a_file() {
    // Nothing listens on the viewer's port: `run_in` moves it to a free one.
    for (what, body, needle) in [
        (
            "exits at once",
            "echo 'no display' >&2; exit 1",
            "exited at once",
        ),
        ("never listens", "sleep 60", "did not start listening"),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let path = fake_rerun(dir.path(), body);
        let (code, _, err) = run_in(
            dir.path(),
            &path,
            &["run", "--style", "short", "--seconds", "0.2"],
            Duration::from_secs(90),
        );
        assert_eq!(code, 0, "{what}: {err}");
        assert!(err.contains(needle), "{what}: {err}");
        let rrd = dir.path().join("wisptree.rrd");
        assert!(
            rrd.metadata().map(|m| m.len() > 1000).unwrap_or(false),
            "{what}: {err}"
        );
        assert!(!err.contains("may be incomplete"), "{what}: {err}");
    }
}

#[test]
fn the_spawned_viewer_is_asked_for_the_port_the_environment_gives() {
    let dir = tempfile::tempdir().unwrap();
    let path = fake_rerun(dir.path(), "echo \"$@\" > args.txt; exit 1");
    let (code, _, err) = run_in(
        dir.path(),
        &path,
        &["run", "--style", "short", "--seconds", "0.1"],
        Duration::from_secs(90),
    );
    assert_eq!(code, 0, "{err}");
    let args = std::fs::read_to_string(dir.path().join("args.txt")).unwrap();
    // `run_in` gives a free port, which is not Rerun's default one.
    assert!(
        args.contains("--port=") && !args.contains("--port=9876"),
        "{args}"
    );
}
