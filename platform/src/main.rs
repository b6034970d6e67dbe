//! `platform`: the rating-study server and its command line (see `platform --help`).

use clap::Parser;

fn main() -> anyhow::Result<()> {
    let cli = platform::cli::Cli::parse();
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    match runtime.block_on(platform::cli::run(cli)) {
        // The reader went away (`| head`): like other Unix tools, stop without a message.
        Err(platform::error::AppError::Stdout(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            Ok(())
        }
        other => Ok(other?),
    }
}
