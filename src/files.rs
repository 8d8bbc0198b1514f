//! Never lose a user's file: a file about to be replaced is first moved aside to `NAME.bak`.
//! Used wherever wisptree writes a file a user named or may have made: recordings (`--save`,
//! `bench --rrd`), JSON reports (`--json`), and the pictures and pages written into a folder
//! the user names (`experiment --out`, `gallery --out`). Below every module that writes one.

use std::path::{Path, PathBuf};

use crate::error::BadInput;

/// Refuses (bad input, naming both files) what [`move_aside`] would refuse, without moving
/// anything: for a command to say so before its work rather than after it.
pub fn check_move_aside(path: &Path) -> anyhow::Result<()> {
    backup_of(path).map(|_| ())
}

/// If `path` exists, renames it to `path.bak` and returns that name; refuses (bad input,
/// naming both files) if `path.bak` exists too, or if `path` is a folder.
pub fn move_aside(path: &Path) -> anyhow::Result<Option<PathBuf>> {
    let Some(bak) = backup_of(path)? else {
        return Ok(None);
    };
    std::fs::rename(path, &bak).map_err(|e| {
        BadInput(format!(
            "cannot move {} aside to {}: {e}",
            path.display(),
            bak.display()
        ))
    })?;
    Ok(Some(bak))
}

/// Where an existing `path` would go (`None` if there is no file), or why it cannot.
fn backup_of(path: &Path) -> anyhow::Result<Option<PathBuf>> {
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
    Ok(Some(bak))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_existing_file_is_moved_aside_once_and_a_second_backup_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let path = dir.join("out.json");
        // Nothing there: nothing to move.
        assert_eq!(move_aside(&path).unwrap(), None);
        std::fs::write(&path, "first").unwrap();
        check_move_aside(&path).unwrap();
        let bak = move_aside(&path).unwrap().expect("moved aside");
        assert_eq!(bak, dir.join("out.json.bak"));
        assert_eq!(std::fs::read_to_string(&bak).unwrap(), "first");
        assert!(!path.exists());
        std::fs::write(&path, "second").unwrap();
        for refused in [
            check_move_aside(&path).unwrap_err(),
            move_aside(&path).unwrap_err(),
        ] {
            let msg = refused.to_string();
            assert!(
                msg.contains("out.json.bak") && msg.contains("move one of them away"),
                "{msg}"
            );
            assert!(refused.downcast_ref::<BadInput>().is_some());
        }
        // Both files are as they were.
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "second");
        assert_eq!(std::fs::read_to_string(&bak).unwrap(), "first");
    }
}
