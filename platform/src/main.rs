//! `platform`: the rating-study server and its command line (see `platform --help`).

use std::process::ExitCode;

use clap::Parser;
use platform::error::AppError;

fn main() -> ExitCode {
    let cli = platform::cli::Cli::parse();
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(platform::cli::run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader went away (`| head`): like other Unix tools, stop without a message.
        Err(AppError::Stdout(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        // One line, the message a user can act on: an error is not a crash, so no backtrace
        // even when RUST_BACKTRACE is set in the environment.
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
