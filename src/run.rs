//! `wisptree run` (in progress).

#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {}

pub fn run(_args: RunArgs) -> anyhow::Result<()> {
    anyhow::bail!("`wisptree run` is not implemented yet")
}
