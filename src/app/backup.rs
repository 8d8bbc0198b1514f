//! Never lose a user's file: a file about to be replaced is first moved aside to `NAME.bak`.
//! Used by the commands that write pictures and pages into a folder the user names
//! (`experiment --out`, `gallery --out`).

use std::path::{Path, PathBuf};

use crate::error::BadInput;

/// If `path` exists, renames it to `path.bak` and returns that name; refuses (bad input,
/// naming both files) if `path.bak` exists too, or if `path` is a folder.
pub fn move_aside(path: &Path) -> anyhow::Result<Option<PathBuf>> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(BadInput(format!("{}: {e}", path.display())).into()),
    };
    if meta.is_dir() {
        return Err(BadInput(format!(
            "{} is a folder where a file is to be written: move it away",
            path.display()
        ))
        .into());
    }
    let mut bak = path.as_os_str().to_owned();
    bak.push(".bak");
    let bak = PathBuf::from(bak);
    if std::fs::symlink_metadata(&bak).is_ok() {
        return Err(BadInput(format!(
            "{} exists and so does {}: move one of them away (wisptree keeps one backup, \
             never overwrites a file it did not write)",
            path.display(),
            bak.display()
        ))
        .into());
    }
    std::fs::rename(path, &bak).map_err(|e| {
        BadInput(format!(
            "cannot move {} aside to {}: {e}",
            path.display(),
            bak.display()
        ))
    })?;
    Ok(Some(bak))
}
