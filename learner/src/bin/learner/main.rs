//! The `learner` command line (temporary main wiring only the metric subcommands; the lead
//! merges it with the `features`, `render` and `bench` wiring).

mod metric_cmds;

use clap::{Parser, Subcommand};

/// Clip-art style features and the learned style metric (Garces et al. 2014).
#[derive(Debug, Parser)]
#[command(name = "learner", version)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Write a simulated crowd (features, triplets, ground truth).
    Simulate(metric_cmds::SimulateArgs),
    /// Split labels into train/test by held-out styles and concepts.
    Split(metric_cmds::SplitArgs),
    /// Generate labelled-group triplets.
    Triplets(metric_cmds::TripletsArgs),
    /// Learn the metric.
    Train(metric_cmds::TrainArgs),
    /// Triplet accuracy and perplexity.
    Eval(metric_cmds::EvalArgs),
    /// Ranking metrics by style label.
    Rank(metric_cmds::RankArgs),
    /// Figures and index.html.
    Report(metric_cmds::ReportArgs),
    /// Metric benchmark (argmin vs nlopt vs SciPy).
    Bench(metric_cmds::BenchMetricArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Cmd::Simulate(a) => metric_cmds::run_simulate(&a),
        Cmd::Split(a) => metric_cmds::run_split(&a),
        Cmd::Triplets(a) => metric_cmds::run_triplets(&a),
        Cmd::Train(a) => metric_cmds::run_train(&a),
        Cmd::Eval(a) => metric_cmds::run_eval(&a),
        Cmd::Rank(a) => metric_cmds::run_rank(&a),
        Cmd::Report(a) => metric_cmds::run_report(&a),
        Cmd::Bench(a) => metric_cmds::bench_metric(&a),
    }
}
