//! The shipped hairstyles, compiled into the binary so that `--style long` works from any
//! directory. The ponytail is not among them: its strands are data files outside the project.

use std::path::{Path, PathBuf};

use super::{LoadedStyle, StyleError};

/// One shipped style.
#[derive(Debug, Clone, Copy)]
pub struct BuiltinStyle {
    /// The name `--style` takes.
    pub name: &'static str,
    /// One line for `wisptree styles`.
    pub description: &'static str,
    /// The RON text, as in `styles/<name>.ron`.
    pub text: &'static str,
}

/// The four styles of the AWT paper's §5.2 table.
pub const BUILTIN_STYLES: [BuiltinStyle; 4] = [
    BuiltinStyle {
        name: "short",
        description: "smooth ear-length bob, 8-15 cm, 2 levels, rigid links (AWT §5.2 \"Short\")",
        text: include_str!("../../styles/short.ron"),
    },
    BuiltinStyle {
        name: "short_curly",
        description: "voluminous bob of curls, 2 levels, soft springs (AWT §5.2 \"Short curly\")",
        text: include_str!("../../styles/short_curly.ron"),
    },
    BuiltinStyle {
        name: "long",
        description:
            "straight 40-60 cm, parted at the centre, 3 levels, rigid links (AWT §5.2 \"Long\")",
        text: include_str!("../../styles/long.ron"),
    },
    BuiltinStyle {
        name: "long_curly",
        description: "40-60 cm ringlets, 3 levels, soft springs (AWT §5.2 \"Long curly\")",
        text: include_str!("../../styles/long_curly.ron"),
    },
];

/// The built-in style called `name`, if any.
pub fn builtin(name: &str) -> Option<&'static BuiltinStyle> {
    BUILTIN_STYLES.iter().find(|b| b.name == name)
}

/// `short, short_curly, long, long_curly`.
pub fn builtin_names() -> String {
    BUILTIN_STYLES
        .iter()
        .map(|b| b.name)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where a style comes from: a built-in name or a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StyleSource {
    /// Compiled in (not watched: there is no file).
    Builtin(&'static str),
    /// A `.ron` file (watched while live).
    File(PathBuf),
}

impl StyleSource {
    /// A built-in name when `spec` is exactly one (`long`), else a path. A file that happens
    /// to be called `long` in the current directory is reached as `./long`.
    pub fn parse(spec: &str) -> StyleSource {
        match builtin(spec) {
            Some(b) => StyleSource::Builtin(b.name),
            None => StyleSource::File(PathBuf::from(spec)),
        }
    }

    /// The file, for a style given by path.
    pub fn file(&self) -> Option<&Path> {
        match self {
            StyleSource::File(p) => Some(p),
            StyleSource::Builtin(_) => None,
        }
    }

    /// Reads, parses and validates the style. A built-in style is named
    /// `<built-in style NAME>` in messages.
    pub fn load(&self) -> Result<LoadedStyle, StyleError> {
        match self {
            StyleSource::File(p) => {
                if !p.exists() {
                    return Err(StyleError::Missing {
                        path: p.clone(),
                        builtins: builtin_names(),
                    });
                }
                super::load(p)
            }
            StyleSource::Builtin(name) => {
                let b = builtin(name).expect("a parsed built-in name exists");
                super::parse(&builtin_path(name), b.text)
            }
        }
    }
}

impl std::fmt::Display for StyleSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StyleSource::File(p) => write!(f, "{}", p.display()),
            StyleSource::Builtin(n) => write!(f, "built-in style `{n}`"),
        }
    }
}

/// The pseudo-path that names a built-in style in messages.
pub fn builtin_path(name: &str) -> PathBuf {
    PathBuf::from(format!("<built-in style {name}>"))
}
