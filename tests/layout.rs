//! The source tree against what the docs and the layers say about it: `src/lib.rs`'s module map
//! and README's module table list exactly the modules of the tree, in the layer order below; no
//! source file imports from a layer above its own; a folder whose `mod.rs` lists its files lists
//! all of them; the split threshold has one unit.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, top to bottom: a module may use only the modules after it. Written here once;
/// `src/lib.rs`'s map and README's table are checked against it.
const LAYERS: &[&str] = &[
    "cli",
    "bench",
    "app",
    "web",
    "stream",
    "experiment",
    "render",
    "pipeline",
    "scene",
    "solver",
    "frame",
    "report",
    "files",
    "error",
    "motion",
    "model",
    "style",
    // Below everything that uses them, and using nothing of wisptree's.
    "par",
    "simd",
];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The top-level modules the tree holds: `src/NAME.rs` and `src/NAME/mod.rs`.
fn tree_modules() -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for e in std::fs::read_dir(root().join("src")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_stem().unwrap().to_str().unwrap().to_owned();
        if p.is_dir() && p.join("mod.rs").is_file()
            || p.extension().is_some_and(|x| x == "rs") && name != "lib" && name != "main"
        {
            out.insert(name);
        }
    }
    out
}

/// The modules `src/lib.rs` declares (`pub mod NAME;`), in file order.
fn declared_modules(lib: &str) -> Vec<String> {
    lib.lines()
        .filter_map(|l| {
            let l = l.trim();
            let l = l.strip_prefix("pub ").unwrap_or(l);
            l.strip_prefix("mod ")?
                .strip_suffix(';')
                .map(|n| n.trim().to_owned())
        })
        .collect()
}

/// The first word of each line of the module map, the ```text block of `src/lib.rs`'s docs.
fn lib_map(lib: &str) -> Vec<String> {
    let docs: Vec<&str> = lib
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .map(|l| l.strip_prefix(' ').unwrap_or(l))
        .collect();
    let start = docs
        .iter()
        .position(|l| l.trim() == "```text")
        .expect("src/lib.rs's docs have a ```text module map");
    docs[start + 1..]
        .iter()
        .take_while(|l| l.trim() != "```")
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

/// The module column of README's table under "The modules, in `use` order", without the
/// backticks and a folder's `/`.
fn readme_table(readme: &str) -> Vec<String> {
    let after = readme
        .split_once("The modules, in `use` order")
        .expect("README.md has the module table under \"The modules, in `use` order\"")
        .1;
    after
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2) // the header and the |---| line
        .map(|l| {
            l.split('|')
                .nth(1)
                .unwrap()
                .trim()
                .trim_matches('`')
                .trim_end_matches('/')
                .to_owned()
        })
        .collect()
}

fn layers() -> Vec<String> {
    LAYERS.iter().map(|s| s.to_string()).collect()
}

#[test]
fn the_module_map_lists_every_module_of_the_tree_in_layer_order() {
    let lib = read(&root().join("src/lib.rs"));
    let tree = tree_modules();
    let declared: BTreeSet<String> = declared_modules(&lib).into_iter().collect();
    assert_eq!(
        declared, tree,
        "src/lib.rs's `pub mod` lines against the modules in src/"
    );
    let map = lib_map(&lib);
    assert_eq!(
        map.iter().cloned().collect::<BTreeSet<_>>(),
        tree,
        "src/lib.rs's module map against the modules in src/ (add a line `NAME  what it holds`)"
    );
    assert_eq!(
        LAYERS
            .iter()
            .map(|s| s.to_string())
            .collect::<BTreeSet<_>>(),
        tree,
        "tests/layout.rs's LAYERS against the modules in src/ (place a new module in its layer)"
    );
    assert_eq!(
        map,
        layers(),
        "src/lib.rs's module map is not in the layer order of tests/layout.rs"
    );
}

#[test]
fn readme_lists_every_module_in_layer_order() {
    let readme = read(&root().join("README.md"));
    assert_eq!(
        readme_table(&readme),
        layers(),
        "README.md's module table (How it works) against the layers of tests/layout.rs"
    );
}

/// `text` without its comments (`//` to the end of a line; a `//` inside a string literal cuts
/// the rest of its line too, which can only hide an import, never invent one).
fn code_of(text: &str) -> String {
    text.lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The identifier at the start of `s`.
fn ident(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// The top-level modules that `code` names through `crate::` (also `crate::{a, b::c}`) or through
/// as many `super::` as reach the crate root from a file `depth` modules deep.
fn used_modules(code: &str, depth: usize) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let preceded_by_ident = rest[..i]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_ascii_alphanumeric() || c == '_');
        let after = &rest[i + "crate::".len()..];
        if !preceded_by_ident {
            if let Some(group) = after.strip_prefix('{') {
                // The first identifier of each top-level item of the group.
                let mut level = 0;
                let mut item_start = true;
                for (k, c) in group.char_indices() {
                    match c {
                        '{' => level += 1,
                        '}' if level == 0 => break,
                        '}' => level -= 1,
                        ',' if level == 0 => item_start = true,
                        c if item_start && !c.is_whitespace() => {
                            item_start = false;
                            out.insert(ident(&group[k..]).to_owned());
                        }
                        _ => {}
                    }
                }
            } else {
                out.insert(ident(after).to_owned());
            }
        }
        rest = after;
    }
    let mut rest = code;
    while let Some(i) = rest.find("super::") {
        let mut after = &rest[i..];
        let mut supers = 0;
        while let Some(a) = after.strip_prefix("super::") {
            supers += 1;
            after = a;
        }
        if supers >= depth {
            out.insert(ident(after).to_owned());
        }
        rest = after;
    }
    out
}

#[test]
fn no_source_file_imports_from_a_layer_above_its_own() {
    let rank: BTreeMap<&str, usize> = LAYERS.iter().enumerate().map(|(i, m)| (*m, i)).collect();
    let src = root().join("src");
    let mut wrong = Vec::new();
    for file in rust_files(&src) {
        let rel = file.strip_prefix(&src).unwrap();
        let parts: Vec<&str> = rel.iter().map(|p| p.to_str().unwrap()).collect();
        if parts.len() == 1 && (parts[0] == "lib.rs" || parts[0] == "main.rs") {
            continue;
        }
        let own = parts[0].trim_end_matches(".rs");
        let Some(&own_rank) = rank.get(own) else {
            panic!("src/{}: module `{own}` is not in LAYERS", rel.display());
        };
        // Modules from the crate root to this file's: src/a/b.rs is a::b, src/a/mod.rs is a.
        let depth = parts.len() - usize::from(parts.last() == Some(&"mod.rs"));
        let shown = format!("src/{}", rel.display());
        for m in used_modules(&code_of(&read(&file)), depth) {
            let Some(&r) = rank.get(m.as_str()) else {
                continue; // not a top-level module (a path inside this one, or `crate::` alone)
            };
            if r < own_rank {
                wrong.push(format!(
                    "{shown} (layer `{own}`) uses `{m}`, a layer above it"
                ));
            }
        }
    }
    assert!(
        wrong.is_empty(),
        "imports against the layer order (tests/layout.rs's LAYERS):\n{}",
        wrong.join("\n")
    );
}

#[test]
fn the_import_scan_sees_every_form_of_path() {
    let code = "use crate::{frame::Frame, model::{A, B}, style};\n\
                let x = crate::report::Stats::default();\n\
                use super::super::motion::Motion;\n\
                fn f(a: mycrate::web::X) {}";
    let got = used_modules(&code_of(code), 2);
    let want: BTreeSet<String> = ["frame", "model", "style", "report", "motion"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    assert_eq!(got, want);
    // One `super::` from src/a/b.rs stays inside `a`.
    assert!(used_modules("use super::motion::X;", 2).is_empty());
    // Comments are not imports.
    assert!(used_modules(&code_of("/// see [`crate::model`]\n"), 1).is_empty());
}

/// The bullet list of files in a `mod.rs`'s docs (`//! * `name.rs`: …`), if it has one.
fn listed_files(mod_rs: &str) -> BTreeSet<String> {
    mod_rs
        .lines()
        .filter_map(|l| l.strip_prefix("//! * `"))
        .filter_map(|l| l.split_once('`'))
        .map(|(name, _)| name)
        .filter(|name| name.ends_with(".rs"))
        .map(str::to_owned)
        .collect()
}

#[test]
fn a_folder_that_lists_its_files_lists_all_of_them() {
    let mut checked = 0;
    for file in rust_files(&root().join("src")) {
        if file.file_name().unwrap() != "mod.rs" {
            continue;
        }
        let listed = listed_files(&read(&file));
        if listed.is_empty() {
            continue;
        }
        let dir = file.parent().unwrap();
        let present: BTreeSet<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file() && p.extension().is_some_and(|x| x == "rs"))
            .map(|p| p.file_name().unwrap().to_str().unwrap().to_owned())
            .collect();
        assert_eq!(listed, present, "the file list in {}", file.display());
        checked += 1;
    }
    // solver/awt/collide/mod.rs lists its files.
    assert!(checked >= 1);
}

#[test]
fn the_split_threshold_has_one_unit_everywhere() {
    // N·m·kg⁻¹ (the page, README, the style schema); m²/s² was a second spelling of it.
    for file in rust_files(&root().join("src")) {
        let text = read(&file);
        assert!(
            !text.contains("m²/s²"),
            "{}: write the split threshold's unit as N·m·kg⁻¹",
            file.display()
        );
    }
}

/// Issue 26 §2: a file a reader can hold in mind. A file past this is split by concern.
const MAX_LINES: usize = 650;

#[test]
fn no_source_file_is_over_650_lines() {
    let long: Vec<String> = rust_files(&root().join("src"))
        .into_iter()
        .filter_map(|f| {
            let n = read(&f).lines().count();
            (n > MAX_LINES).then(|| format!("{} ({n} lines)", f.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "split these by concern (at most {MAX_LINES} lines): {long:?}"
    );
}
