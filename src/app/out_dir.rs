//! A folder a command writes many files into (`gallery --out DIR`, `render --out DIR`,
//! `export --format hair|tfx --out DIR`), and its promise: no file the user made is lost.
//! The folder keeps a manifest per command (`.wisptree-gallery`, `.wisptree-render`,
//! `.wisptree-export`) of every file that command wrote and a checksum of what it wrote; a
//! later run of the command replaces those files as they were, and moves any other file in
//! its way (one the user made, or edited since, or another command's) aside to `NAME.bak`.
//! Each file is added to the manifest as soon as it is written, so a run stopped half-way
//! (Ctrl-C) still has its files replaced, not moved aside, by the next.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::BadInput;

/// An output folder being written.
pub struct OutDir {
    /// The folder.
    pub dir: PathBuf,
    /// The manifest's file name, `.wisptree-COMMAND`.
    manifest: String,
    /// The command, as the manifest's header names it.
    command: &'static str,
    /// What earlier runs of the command wrote here: (file name, checksum).
    earlier: Vec<(String, u64)>,
    /// What this one wrote.
    written: Vec<(String, u64)>,
    /// Files moved aside to `.bak`.
    pub moved_aside: Vec<PathBuf>,
}

impl OutDir {
    /// Opens `dir` for writing by `wisptree COMMAND`: creates it if needed, checks it can be
    /// written, reads the manifest of an earlier run of the command. A path that is a file, or
    /// that cannot be created or written, is bad input naming `--out`.
    pub fn open(dir: &Path, command: &'static str) -> anyhow::Result<OutDir> {
        let manifest_name = format!(".wisptree-{command}");
        let bad = |what: String| BadInput(format!("--out {}: {what}", dir.display()));
        if dir.exists() && !dir.is_dir() {
            return Err(bad("not a folder (give a new or empty folder)".into()).into());
        }
        std::fs::create_dir_all(dir).map_err(|e| bad(format!("cannot create the folder: {e}")))?;
        let manifest = dir.join(&manifest_name);
        let earlier = match std::fs::read_to_string(&manifest) {
            Ok(text) => parse_manifest(&text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(bad(format!("cannot read {manifest_name}: {e}")).into()),
        };
        // Can it be written? Opening the manifest to append touches nothing in it.
        std::fs::OpenOptions::new()
            .append(true)
            .create(true)
            .open(&manifest)
            .map_err(|e| bad(format!("cannot write into the folder: {e}")))?;
        Ok(OutDir {
            dir: dir.to_owned(),
            manifest: manifest_name,
            command,
            earlier,
            written: Vec::new(),
            moved_aside: Vec::new(),
        })
    }

    /// Writes `bytes` as `name` in the folder: over the file an earlier run wrote, if it is
    /// unchanged; any other file of that name is first moved aside to `name.bak`.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> anyhow::Result<PathBuf> {
        let path = self.make_way(name)?;
        std::fs::write(&path, bytes)
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())))?;
        self.record(name, checksum(bytes))?;
        Ok(path)
    }

    /// Refuses, before any work, what [`Self::make_way`] would refuse for one of `names` (a
    /// file in the way whose `NAME.bak` exists too), so that a long run does not stop at its
    /// n-th file.
    pub fn check_names(&self, names: impl IntoIterator<Item = String>) -> anyhow::Result<()> {
        for name in names {
            if let Some(path) = self.in_the_way(&name) {
                crate::files::check_move_aside(&path).context_out(&self.dir)?;
            }
        }
        Ok(())
    }

    /// The path of a file `name` that is there and is not one an earlier run (or this one)
    /// wrote, unchanged since: the file to move aside before writing `name`.
    fn in_the_way(&self, name: &str) -> Option<PathBuf> {
        let path = self.dir.join(name);
        let sum = checksum(&std::fs::read(&path).ok()?);
        let ours = self
            .earlier
            .iter()
            .chain(&self.written)
            .any(|(n, s)| n == name && *s == sum);
        (!ours).then_some(path)
    }

    /// Makes way for a file `name` the caller writes itself (then calls [`Self::written`]):
    /// moves a file of that name aside unless an earlier run wrote it and it is unchanged.
    /// Returns the path to write.
    pub fn make_way(&mut self, name: &str) -> anyhow::Result<PathBuf> {
        if let Some(path) = self.in_the_way(name) {
            if let Some(bak) = crate::files::move_aside(&path).context_out(&self.dir)? {
                self.moved_aside.push(bak);
            }
        }
        Ok(self.dir.join(name))
    }

    /// Records the file `name` the caller wrote after [`Self::make_way`] (reads it back for
    /// its checksum).
    pub fn written(&mut self, name: &str) -> anyhow::Result<()> {
        let path = self.dir.join(name);
        let bytes = std::fs::read(&path)
            .map_err(|e| BadInput(format!("--out: cannot read back {}: {e}", path.display())))?;
        self.record(name, checksum(&bytes))
    }

    /// Adds `name` to this run's files and appends it to the manifest at once.
    fn record(&mut self, name: &str, sum: u64) -> anyhow::Result<()> {
        self.written.retain(|(n, _)| n != name);
        self.written.push((name.to_owned(), sum));
        let path = self.dir.join(&self.manifest);
        std::fs::OpenOptions::new()
            .append(true)
            .create(true)
            .open(&path)
            .and_then(|mut f| writeln!(f, "{sum:016x} {name}"))
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())).into())
    }

    /// Rewrites the manifest compactly: the files of this run, and those of earlier runs
    /// still there unchanged (a later run may replace them too).
    pub fn finish(&self) -> anyhow::Result<()> {
        let mut text = format!(
            "# files written by `wisptree {}` (FNV-1a 64 of the bytes written, name): a later \
             run replaces them; any other file is moved aside to NAME.bak\n",
            self.command
        );
        for (n, sum) in &self.written {
            text.push_str(&format!("{sum:016x} {n}\n"));
        }
        // The earlier runs' lines may name a file more than once (each write appends one):
        // one line per file still as it was written.
        let mut kept: Vec<&str> = Vec::new();
        for (n, sum) in &self.earlier {
            let keep = !self.written.iter().any(|(w, _)| w == n)
                && !kept.contains(&n.as_str())
                && std::fs::read(self.dir.join(n)).is_ok_and(|b| checksum(&b) == *sum);
            if keep {
                kept.push(n);
                text.push_str(&format!("{sum:016x} {n}\n"));
            }
        }
        let path = self.dir.join(&self.manifest);
        std::fs::write(&path, text)
            .map_err(|e| BadInput(format!("--out: cannot write {}: {e}", path.display())).into())
    }

    /// Says on stderr which files in the way were kept as `NAME.bak`: each of a few, or how
    /// many and the first.
    pub fn report_moved_aside(&self) {
        let moved = &self.moved_aside;
        if moved.len() <= 3 {
            for bak in moved {
                eprintln!("kept a file that was in the way as {}", bak.display());
            }
        } else {
            eprintln!(
                "kept {} files that were in the way as NAME.bak ({} and others)",
                moved.len(),
                moved[0].display()
            );
        }
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

/// FNV-1a, 64 bits: tells "the bytes a command wrote" from "edited since", nothing more.
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
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().to_owned();
        std::fs::write(dir.join("index.html"), "mine").unwrap();
        let mut out = OutDir::open(&dir, "gallery").unwrap();
        out.write("index.html", b"gallery 1").unwrap();
        out.finish().unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("index.html.bak")).unwrap(),
            "mine"
        );
        // A second gallery replaces its own file without a backup.
        std::fs::remove_file(dir.join("index.html.bak")).unwrap();
        let mut out = OutDir::open(&dir, "gallery").unwrap();
        out.write("index.html", b"gallery 2").unwrap();
        out.finish().unwrap();
        assert!(!dir.join("index.html.bak").exists());
        // Edited since: moved aside again.
        std::fs::write(dir.join("index.html"), "edited").unwrap();
        let mut out = OutDir::open(&dir, "gallery").unwrap();
        out.write("index.html", b"gallery 3").unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join("index.html.bak")).unwrap(),
            "edited"
        );
        // And with a backup already there, it refuses rather than lose either.
        std::fs::write(dir.join("index.html"), "edited again").unwrap();
        assert!(out.write("index.html", b"gallery 4").is_err());
    }

    #[test]
    fn a_run_stopped_before_finish_still_has_its_files_replaced_by_the_next() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let mut out = OutDir::open(dir, "render").unwrap();
        // Written by the caller itself, then recorded.
        let path = out.make_way("frame_00000.png").unwrap();
        std::fs::write(&path, "frame 0").unwrap();
        out.written("frame_00000.png").unwrap();
        out.write("frame_00001.png", b"frame 1").unwrap();
        drop(out); // no finish: Ctrl-C
        let mut out = OutDir::open(dir, "render").unwrap();
        out.write("frame_00000.png", b"frame 0, again").unwrap();
        out.write("frame_00001.png", b"frame 1, again").unwrap();
        assert!(out.moved_aside.is_empty(), "{:?}", out.moved_aside);
        out.finish().unwrap();
        // The compact manifest: the header and one line per file.
        let text = std::fs::read_to_string(dir.join(".wisptree-render")).unwrap();
        assert_eq!(text.lines().count(), 3, "{text}");
        // Another command's manifest does not vouch for these files.
        let mut other = OutDir::open(dir, "export").unwrap();
        other.write("frame_00000.png", b"exported").unwrap();
        assert_eq!(other.moved_aside, vec![dir.join("frame_00000.png.bak")]);
    }
}
