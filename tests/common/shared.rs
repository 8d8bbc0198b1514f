//! What the tests need from outside the repository: the shared folder `../shared` beside the
//! clone (data, papers and tools) and the Rerun CLI it carries. A test that needs one of them
//! finds it relative to the repository, or fails saying how to get it; it never passes by
//! skipping.
#![allow(dead_code)]

use std::path::PathBuf;

/// `../shared`, beside the repository. Panics, saying how to get it, if it is absent.
pub fn shared_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared");
    assert!(
        dir.join("data").is_dir(),
        "{} is missing: this test needs the shared folder (data/, tools/) checked out beside the \
         repository, as CI has it (`bash .ci/run` in a clone with ../shared next to it)",
        dir.display()
    );
    dir
}

/// A file or folder in `../shared` (`shared_path("data/tressfx")`). Panics, saying how to get
/// it, if it is absent.
pub fn shared_path(rel: &str) -> PathBuf {
    let p = shared_dir().join(rel);
    assert!(
        p.exists(),
        "{} is missing from the shared folder beside the repository",
        p.display()
    );
    p
}

/// `../shared/tools/rerun-cli`: the Rerun CLI pinned to the SDK version the crate links. On its
/// first use it installs `rerun-sdk` from PyPI into a Python virtual environment
/// (`~/.cache/rerun-cli-<version>`); `.ci/run` does that once before the tests, so that tests
/// running in parallel do not install it at the same time.
pub fn rerun_cli() -> PathBuf {
    shared_path("tools/rerun-cli")
}
