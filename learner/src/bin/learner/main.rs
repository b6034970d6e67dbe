//! The `learner` command line: style features of clip-art libraries.

mod bench_cmd;
mod features_cmd;
mod render_cmd;

use clap::{Parser, Subcommand};

/// Measure the visual style of clip art (Garces et al., SIGGRAPH 2014).
#[derive(Debug, Parser)]
#[command(name = "learner", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Compute the 169 style features of SVG/PNG/JPEG files, folders and Iconify sets.
    Features(features_cmd::FeaturesArgs),
    /// Render one item exactly as the features see it (optionally with the mask overlaid).
    Render(render_cmd::RenderArgs),
    /// Time rendering and features over a data set, side by side with the Python libraries.
    Bench(bench_cmd::BenchArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Features(args) => features_cmd::run(args),
        Command::Render(args) => render_cmd::run(args),
        Command::Bench(args) => bench_cmd::run(args),
    };
    match result {
        Ok(code) => code,
        Err(error) => {
            eprintln!("error: {error:#}");
            std::process::ExitCode::from(2)
        }
    }
}
