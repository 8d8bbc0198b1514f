//! `wisptree styles`: the built-in hairstyles, and `--write NAME` to get one as a file.

use std::path::PathBuf;

use anyhow::Context as _;

use crate::error::BadInput;
use crate::style::builtin::{builtin, builtin_names, BUILTIN_STYLES};

/// `wisptree styles` arguments.
#[derive(Debug, clap::Args)]
pub struct StylesArgs {
    /// Write the built-in style NAME to a file (`NAME.ron` in the current directory, or --out)
    /// to edit it; `wisptree run --style NAME.ron` then watches it.
    #[arg(long, value_name = "NAME")]
    pub write: Option<String>,
    /// Where --write writes (refuses to overwrite an existing file).
    #[arg(long, value_name = "PATH", requires = "write")]
    pub out: Option<PathBuf>,
}

/// `wisptree styles`.
pub fn styles(a: &StylesArgs) -> anyhow::Result<()> {
    let Some(name) = &a.write else {
        println!("built-in styles (use with --style NAME; `--write NAME` gives a file to edit):");
        for b in &BUILTIN_STYLES {
            println!("  {:<12} {}", b.name, b.description);
        }
        println!("the TressFX ponytail is a file: styles/ponytail.ron in the source tree");
        return Ok(());
    };
    let b = builtin(name).ok_or_else(|| {
        BadInput(format!(
            "--write {name}: not a built-in style (built-in: {})",
            builtin_names()
        ))
    })?;
    let path = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("{}.ron", b.name)));
    if path.exists() {
        return Err(BadInput(format!(
            "{}: already exists; not overwriting it (choose another with --out)",
            path.display()
        ))
        .into());
    }
    std::fs::write(&path, b.text).with_context(|| format!("writing {}", path.display()))?;
    println!(
        "wrote {}; run it with: wisptree run --style {}",
        path.display(),
        path.display()
    );
    Ok(())
}
