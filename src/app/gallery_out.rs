//! The folder `wisptree gallery --out DIR` writes into, and its promise: no file the user made
//! is lost. The folder keeps a manifest (`.wisptree-gallery`) of every file the gallery wrote
//! and a checksum of what it wrote; a later gallery replaces those files as they were, and
//! moves any other file in its way (one the user made, or edited since) aside to `NAME.bak`.

use std::path::{Path, PathBuf};

use crate::error::BadInput;

/// The manifest's file name.
pub const MANIFEST: &str = ".wisptree-gallery";

/// An output folder being written.
pub struct OutDir {
    /// The folder.
    pub dir: PathBuf,
    /// What an earlier gallery wrote here: (file name, checksum).
    earlier: Vec<(String, u64)>,
    /// What this one wrote.
    written: Vec<(String, u64)>,
    /// Files moved aside to `.bak`.
    pub moved_aside: Vec<PathBuf>,
}

impl OutDir {
    /// Opens `dir` for writing: creates it if needed, checks it can be written, reads the
    /// manifest of an earlier gallery. A path that is a file, or that cannot be created or
    /// written, is bad input naming `--out`.
    pub fn open(dir: &Path) -> anyhow::Result<OutDir> {
        let bad = |what: String| BadInput(format!("--out {}: {what}", dir.display()));
        if dir.exists() && !dir.is_dir() {
            return Err(bad("not a folder (give a new or empty folder)".into()).into());
        }
        std::fs::create_dir_all(dir).map_err(|e| bad(format!("cannot create the folder: {e}")))?;
        let manifest = dir.join(MANIFEST);
        let earlier = match std::fs::read_to_string(&manifest) {
            Ok(text) => parse_manifest(&text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(bad(format!("cannot read {MANIFEST}: {e}")).into()),
        };
        // Can it be written? Opening the manifest to append touches nothing in it.
        std::fs::OpenOptions::new()
            .append(true)
            .create(true)
            .open(&manifest)
            .map_err(|e| bad(format!("cannot write into the folder: {e}")))?;
        Ok(OutDir {
            dir: dir.to_owned(),
            earlier,
            written: Vec::new(),
            moved_aside: Vec::new(),
        })
    }

    /// Writes `bytes` as `name` in the folder: over the file an earlier gallery wrote, if it
    /// is unchanged; any other file of that name is first moved aside to `name.bak`.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> anyhow::Result<PathBuf> {
        let path = self.dir.join(name);
        if let Ok(old) = std::fs::read(&path) {
            let ours = self
                .earlier
                .iter()
                .chain(&self.written)
                .any(|(n, sum)| n == name && *sum == checksum(&old));
            if !ours {
                if let Some(bak) = crate::files::move_aside(&path).context_out(&self.dir)? {
                    self.moved_aside.push(bak);
                }
            }
        }
        std::fs::write(&path, bytes)
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())))?;
        self.written.retain(|(n, _)| n != name);
        self.written.push((name.to_owned(), checksum(bytes)));
        Ok(path)
    }

    /// Writes the manifest: the files of this gallery, and those of the earlier one still
    /// there unchanged (a later gallery may replace them too).
    pub fn finish(&self) -> anyhow::Result<()> {
        let mut text = String::from(
            "# files written by `wisptree gallery` (name, FNV-1a 64 of the bytes written): a \
             later gallery replaces them; any other file is moved aside to NAME.bak\n",
        );
        for (n, sum) in &self.written {
            text.push_str(&format!("{sum:016x} {n}\n"));
        }
        for (n, sum) in &self.earlier {
            let kept = !self.written.iter().any(|(w, _)| w == n)
                && std::fs::read(self.dir.join(n)).is_ok_and(|b| checksum(&b) == *sum);
            if kept {
                text.push_str(&format!("{sum:016x} {n}\n"));
            }
        }
        let path = self.dir.join(MANIFEST);
        std::fs::write(&path, text)
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())).into())
    }
}

/// The manifest's lines: a hexadecimal checksum, a space, a file name; others are ignored.
fn parse_manifest(text: &str) -> Vec<(String, u64)> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .filter_map(|l| {
            let (sum, name) = l.split_once(' ')?;
            let sum = u64::from_str_radix(sum, 16).ok()?;
            // Only plain names: a manifest edited to name `../x` must not reach outside.
            let plain = !name.is_empty() && !name.contains(['/', '\\']) && name != "..";
            plain.then(|| (name.to_owned(), sum))
        })
        .collect()
}

/// FNV-1a, 64 bits: tells "the bytes the gallery wrote" from "edited since", nothing more.
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// Adds `--out DIR` to an error's message.
trait ContextOut<T> {
    fn context_out(self, dir: &Path) -> anyhow::Result<T>;
}

impl<T> ContextOut<T> for anyhow::Result<T> {
    fn context_out(self, dir: &Path) -> anyhow::Result<T> {
        self.map_err(|e| e.context(format!("--out {}", dir.display())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_the_user_made_is_kept_as_bak_and_the_gallerys_own_files_are_replaced() {
        let dir = std::env::temp_dir().join(format!("wisptree-out-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("index.html"), "mine").unwrap();
        let mut out = OutDir::open(&dir).unwrap();
        out.write("index.html", b"gallery 1").unwrap();
        out.finish().unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("index.html.bak")).unwrap(),
            "mine"
        );
        // A second gallery replaces its own file without a backup.
        std::fs::remove_file(dir.join("index.html.bak")).unwrap();
        let mut out = OutDir::open(&dir).unwrap();
        out.write("index.html", b"gallery 2").unwrap();
        out.finish().unwrap();
        assert!(!dir.join("index.html.bak").exists());
        // Edited since: moved aside again.
        std::fs::write(dir.join("index.html"), "edited").unwrap();
        let mut out = OutDir::open(&dir).unwrap();
        out.write("index.html", b"gallery 3").unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("index.html.bak")).unwrap(),
            "edited"
        );
        // And with a backup already there, it refuses rather than lose either.
        std::fs::write(dir.join("index.html"), "edited again").unwrap();
        assert!(out.write("index.html", b"gallery 4").is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
