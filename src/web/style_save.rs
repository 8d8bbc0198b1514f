//! Saving an edited style as RON: into the file's own text where possible, so that its
//! comments stay where the edit did not touch them.
//!
//! The editor only changes the `wisps:` and `copies:` lists of `Generated` hair, so the text
//! is patched there alone: a wisp the edit did not change keeps its text and the comment above
//! it, a changed or new one is written anew, a deleted one goes with its comment. The patched
//! text is parsed back and must give the edited style exactly, else the whole style is written
//! afresh (without comments), which the page says before saving.

use std::path::{Path, PathBuf};

use serde::{de::DeserializeOwned, Serialize};

use super::style_editor::StyleEditor;
use crate::style::Hair;

/// The byte ranges of `text` that are code (not inside a comment or a string literal).
fn code_mask(text: &str) -> Vec<bool> {
    let b = text.as_bytes();
    let mut code = vec![true; b.len()];
    let mut i = 0;
    while i < b.len() {
        let start = i;
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            // RON block comments nest.
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
        } else {
            i += 1;
            continue;
        }
        let end = i.min(b.len());
        code[start..end].iter_mut().for_each(|c| *c = false);
    }
    code
}

/// The list after `key:` (its `[` and matching `]` byte offsets), the first one in code.
fn list_span(text: &str, code: &[bool], key: &str) -> Option<(usize, usize)> {
    let b = text.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut from = 0;
    while let Some(off) = text[from..].find(key) {
        let at = from + off;
        from = at + key.len();
        if !code[at] || (at > 0 && ident(b[at - 1])) || b.get(from).is_some_and(|c| ident(*c)) {
            continue;
        }
        let mut j = from;
        let skip = |j: &mut usize| {
            while *j < b.len() && (!code[*j] || b[*j].is_ascii_whitespace()) {
                *j += 1;
            }
        };
        skip(&mut j);
        if b.get(j) != Some(&b':') {
            continue;
        }
        j += 1;
        skip(&mut j);
        if b.get(j) != Some(&b'[') {
            return None;
        }
        let close = matching(b, code, j)?;
        return Some((j, close));
    }
    None
}

/// The offset of the bracket closing the one at `open`.
fn matching(b: &[u8], code: &[bool], open: usize) -> Option<usize> {
    let mut depth = 0i32;
    for (k, c) in b.iter().enumerate().skip(open) {
        if !code[k] {
            continue;
        }
        match c {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => {
                depth -= 1;
                if depth == 0 {
                    return Some(k);
                }
            }
            _ => {}
        }
    }
    None
}

/// A list's items: (the text before it since the last comma, the item's text), and the text
/// after the last item.
fn items(
    text: &str,
    code: &[bool],
    open: usize,
    close: usize,
) -> Option<(Vec<(String, String)>, String)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut lead_from = open + 1;
    let mut k = open + 1;
    while k < close {
        if !code[k] || b[k].is_ascii_whitespace() {
            k += 1;
            continue;
        }
        if b[k] != b'(' {
            return None;
        }
        let end = matching(b, code, k)?;
        out.push((text[lead_from..k].to_owned(), text[k..=end].to_owned()));
        k = end + 1;
        while k < close && (!code[k] || b[k].is_ascii_whitespace()) {
            k += 1;
        }
        if k < close && b[k] == b',' {
            k += 1;
        }
        lead_from = k;
    }
    Some((out, text[lead_from..close].to_owned()))
}

/// The indentation of the line holding byte `at`.
fn indent_at(text: &str, at: usize) -> String {
    let line = text[..at].rsplit('\n').next().unwrap_or("");
    line.chars().take_while(|c| c.is_whitespace()).collect()
}

/// One value as RON, its lines indented by `indent`.
fn ron_item<T: Serialize>(v: &T, indent: &str) -> Option<String> {
    let cfg = ron::ser::PrettyConfig::new()
        .depth_limit(1)
        .indentor("    ".to_owned());
    let s = ron::ser::to_string_pretty(v, cfg).ok()?;
    Some(s.replace('\n', &format!("\n{indent}")))
}

/// The list `key` rewritten for `new`: items whose value is unchanged keep their text and the
/// comment before them.
fn patch_list<T: Serialize + DeserializeOwned + PartialEq>(
    text: &str,
    key: &str,
    new: &[T],
    name: impl Fn(&T) -> &str,
) -> Option<String> {
    let code = code_mask(text);
    let (open, close) = list_span(text, &code, key)?;
    let (old, tail) = items(text, &code, open, close)?;
    let parsed: Vec<T> = old
        .iter()
        .map(|(_, t)| ron::Options::default().from_str(t).ok())
        .collect::<Option<_>>()?;
    let indent = match old.first() {
        Some((lead, _)) => lead.rsplit('\n').next().unwrap_or("").to_owned(),
        None => format!("{}    ", indent_at(text, open)),
    };
    let mut body = String::new();
    for v in new {
        let same = parsed.iter().position(|p| name(p) == name(v));
        match same {
            Some(i) if parsed[i] == *v => {
                body += &old[i].0;
                body += &old[i].1;
            }
            Some(i) => {
                body += &old[i].0;
                body += &ron_item(v, &indent)?;
            }
            None => {
                body += &format!("\n{indent}");
                body += &ron_item(v, &indent)?;
            }
        }
        body.push(',');
    }
    let tail = if new.is_empty() || tail.contains('\n') {
        tail
    } else {
        format!("\n{}", indent_at(text, open))
    };
    Some(format!("{}{body}{tail}{}", &text[..=open], &text[close..]))
}

impl StyleEditor {
    /// The file's text with the edited wisps and copies, if that gives the edited style
    /// exactly (see the module docs).
    pub(super) fn patched_text(&self) -> Option<String> {
        let Hair::Generated(g) = &self.loaded.style.hair else {
            return None;
        };
        let mut text = patch_list(&self.text, "wisps", &g.wisps, |w| w.name.as_str())?;
        let code = code_mask(&text);
        if list_span(&text, &code, "copies").is_some() {
            text = patch_list(&text, "copies", &g.copies, |c| c.name.as_str())?;
        } else if !g.copies.is_empty() {
            // No `copies:` yet: a new list right after the wisps'.
            let (_, close) = list_span(&text, &code, "wisps")?;
            let indent = indent_at(&text, close);
            let mut list = format!(",\n{indent}copies: [");
            for c in &g.copies {
                list += &format!("\n{indent}    {},", ron_item(c, &format!("{indent}    "))?);
            }
            list += &format!("\n{indent}]");
            let b = text.as_bytes();
            let mut at = close + 1;
            while at < b.len() && b[at].is_ascii_whitespace() {
                at += 1;
            }
            let comma = b.get(at) == Some(&b',');
            let (insert_at, list) = if comma {
                (at + 1, format!("{},", &list[1..]))
            } else {
                (close + 1, list)
            };
            text.insert_str(insert_at, &list);
        }
        let back = crate::scene::parse_style(&self.loaded.path, &text).ok()?;
        (back.style == self.loaded.style).then_some(text)
    }

    /// Saves the edited style: to `to` (a new file, which must not exist), or to its own file
    /// (the old text kept as `NAME.ron.bak`). When the comments cannot be kept, saving needs
    /// `drop_comments`. The saved text loads to the same model, bit for bit (checked before
    /// the file is written). Returns the message for the page.
    pub fn save(&mut self, to: Option<&str>, drop_comments: bool) -> Result<String, String> {
        let target = match (to.map(str::trim).filter(|s| !s.is_empty()), &self.file) {
            (Some(name), _) => new_file(name)?,
            (None, Some(f)) => f.clone(),
            (None, None) => {
                return Err(
                    "a built-in style has no file: name a new .ron file to save it to".to_owned(),
                )
            }
        };
        let (text, kept) = match self.patched_text() {
            Some(t) => (t, true),
            None if drop_comments => (self.full_text()?, false),
            None => {
                return Err(
                    "Saving drops the file's comments: confirm to save without them".to_owned(),
                )
            }
        };
        // The saved text must load to the very model being edited.
        let back = crate::scene::parse_style(&target, &text).map_err(|e| e.to_string())?;
        let model = crate::model::HairModel::from_style(&back).map_err(|e| e.to_string())?;
        if model.point_hash() != self.model_hash {
            return Err("not saved: the written style would not load to the same hair".into());
        }
        let backup = self.back_up(&target)?;
        write_via_temp(&target, &text)?;
        self.file = Some(target.clone());
        self.text = text;
        self.saved = self.loaded.style.clone();
        self.keeps_comments = true;
        self.version += 1;
        Ok(format!(
            "saved {}{}{}",
            target.display(),
            backup
                .map(|b| format!(" (the previous text is in {})", b.display()))
                .unwrap_or_default(),
            if kept {
                ""
            } else {
                "; its comments were dropped"
            }
        ))
    }

    /// The whole style written afresh.
    fn full_text(&self) -> Result<String, String> {
        let cfg = ron::ser::PrettyConfig::new().indentor("    ".to_owned());
        let text = ron::ser::to_string_pretty(&self.loaded.style, cfg)
            .map_err(|e| format!("cannot write the style as RON: {e}"))?;
        Ok(format!(
            "// Written by the Style panel of `wisptree run --web`.\n{text}\n"
        ))
    }

    /// Copies `target` (if it exists) to `NAME.ron.bak`, replacing only a backup this editor
    /// wrote itself.
    fn back_up(&mut self, target: &Path) -> Result<Option<PathBuf>, String> {
        if !target.exists() {
            return Ok(None);
        }
        let mut bak = target.as_os_str().to_owned();
        bak.push(".bak");
        let bak = PathBuf::from(bak);
        if bak.exists() && !self.own_backups.contains(&bak) {
            return Err(format!(
                "not saved: {} exists and wisptree did not write it; move it away (wisptree \
                 keeps one backup and never overwrites a file it did not write)",
                bak.display()
            ));
        }
        std::fs::copy(target, &bak)
            .map_err(|e| format!("not saved: cannot back up {}: {e}", target.display()))?;
        if !self.own_backups.contains(&bak) {
            self.own_backups.push(bak.clone());
        }
        Ok(Some(bak))
    }
}

/// A new file's path from the page: a `.ron` name that does not exist yet, in a folder that
/// does.
fn new_file(name: &str) -> Result<PathBuf, String> {
    if name.len() > 400 || name.contains('\0') {
        return Err("not a file name".to_owned());
    }
    let p = PathBuf::from(name);
    if p.extension().is_none_or(|e| e != "ron") {
        return Err(format!("{name}: a style file's name ends in .ron"));
    }
    if std::fs::symlink_metadata(&p).is_ok() {
        return Err(format!(
            "{name} exists: name a new file (Save without a name writes the style's own file)"
        ));
    }
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(format!("{}: no such folder", dir.display()));
    }
    Ok(p)
}

/// Writes `text` to a temporary file beside `target` and renames it over `target`, so that a
/// watcher never reads half a file.
fn write_via_temp(target: &Path, text: &str) -> Result<(), String> {
    let mut tmp = target.as_os_str().to_owned();
    tmp.push(".saving~");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, target))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            format!("not saved: writing {}: {e}", target.display())
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::style::builtin::{StyleSource, BUILTIN_STYLES};
    use crate::style::edit::Edit;

    fn editor(text: &str, file: Option<PathBuf>) -> StyleEditor {
        let loaded = crate::scene::parse_style(Path::new("test.ron"), text).unwrap();
        let model = crate::model::HairModel::from_style(&loaded).unwrap();
        StyleEditor::new(loaded, &model, text.to_owned(), file).unwrap()
    }

    fn first_wisp(e: &StyleEditor) -> String {
        match &e.loaded.style.hair {
            Hair::Generated(g) => g.wisps[0].name.clone(),
            _ => unreachable!(),
        }
    }

    #[test]
    fn edits_of_every_built_in_style_keep_its_comments_and_load_back_exactly() {
        for b in BUILTIN_STYLES {
            let (loaded, _) = crate::scene::load_model(&StyleSource::Builtin(b.name)).unwrap();
            let mut e = editor(b.text, None);
            assert_eq!(e.loaded.style, loaded.style);
            let w = first_wisp(&e);
            e.apply(Edit::Move {
                wisp: w.clone(),
                point: 1,
                delta: [0.0, 0.003, 0.001],
            })
            .unwrap();
            e.apply(Edit::Mirror { wisp: w }).unwrap();
            e.apply(Edit::Create {
                azimuth: 180.0,
                elevation: 20.0,
            })
            .unwrap();
            let text = e.patched_text().unwrap_or_else(|| panic!("{}", b.name));
            for c in b.text.lines().filter(|l| l.trim_start().starts_with("//")) {
                assert!(text.contains(c), "{}: lost {c:?}", b.name);
            }
            // The whole style written afresh loads back too (saving without comments).
            let full = e.full_text().unwrap();
            let back = crate::scene::parse_style(Path::new("x.ron"), &full).unwrap();
            assert_eq!(back.style, e.loaded.style, "{}", b.name);
        }
    }

    #[test]
    fn a_text_that_cannot_be_patched_saves_only_when_dropping_its_comments_is_agreed() {
        let short = BUILTIN_STYLES[0].text;
        // Struct names before the wisps: valid RON, but not the layout the patch reads.
        let text = short.replace(
            "        (\n            name:",
            "        Wisp(\n            name:",
        );
        assert_ne!(text, short);
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("named.ron");
        std::fs::write(&file, &text).unwrap();
        let mut e = editor(&text, Some(file.clone()));
        let w = first_wisp(&e);
        e.apply(Edit::Shape {
            wisp: w,
            radius: None,
            density: None,
            tip_spread: Some(0.02),
        })
        .unwrap();
        assert!(!e.view().save_keeps_comments);
        let refused = e.save(None, false).unwrap_err();
        assert!(
            refused.contains("Saving drops the file's comments"),
            "{refused}"
        );
        assert_eq!(
            std::fs::read_to_string(&file).unwrap(),
            text,
            "nothing written"
        );
        let msg = e.save(None, true).unwrap();
        assert!(msg.contains("comments were dropped"), "{msg}");
        let back = crate::scene::load_style(&file).unwrap();
        assert_eq!(back.style, e.loaded.style);
        assert_eq!(
            std::fs::read_to_string(dir.path().join("named.ron.bak")).unwrap(),
            text
        );
        // A backup wisptree did not write is never replaced.
        let mut other = editor(&text, Some(file.clone()));
        let dropped = std::fs::read_to_string(&file).unwrap();
        assert!(other.apply(Edit::Undo {}).is_err());
        other
            .apply(Edit::Delete {
                wisp: "back_upper".into(),
            })
            .unwrap();
        let e2 = other.save(None, true).unwrap_err();
        assert!(e2.contains("did not write it"), "{e2}");
        assert_eq!(std::fs::read_to_string(&file).unwrap(), dropped);
    }
}
