//! `platform`: the rating-study server and its command line (see `platform --help`).

use clap::Parser;

fn main() -> anyhow::Result<()> {
    let cli = platform::cli::Cli::parse();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    runtime.block_on(platform::cli::run(cli))?;
    Ok(())
}
