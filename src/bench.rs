//! `wisptree bench` (in progress).

#[derive(Debug, Clone, clap::Args)]
pub struct BenchArgs {}

pub fn run(_args: BenchArgs) -> anyhow::Result<()> {
    anyhow::bail!("`wisptree bench` is not implemented yet")
}
