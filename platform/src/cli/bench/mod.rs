//! `platform bench`: load benchmarks against the real server on loopback, the server and its
//! clients in this process.
//!
//! * no scenario ([`answers`]): the workers' answer path, closed loop and paced.
//! * `search` ([`search`]): the admin's style search (`GET /api/v1/admin/search`) on a
//!   200,000-item library, next to the same search in process.

pub mod answers;
pub mod search;

use clap::{Args, Subcommand};

#[cfg(test)]
pub(crate) use answers::prepare;

use crate::error::Result;

/// `platform bench [search]`.
#[derive(Debug, Clone, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    /// What to measure (default: the answer path).
    #[command(subcommand)]
    pub scenario: Option<Scenario>,
    /// The answer path's settings.
    #[command(flatten)]
    pub answers: answers::AnswerArgs,
}

/// A benchmark other than the answer path.
#[derive(Debug, Clone, Subcommand)]
pub enum Scenario {
    /// Style search over HTTP (keywords + style sort by 5 canvas items, 48 results with
    /// metadata) on a library of jittered copies of the fixture items, and the same search in
    /// process.
    Search(search::SearchBenchArgs),
}

/// Runs the chosen benchmark and prints its table.
pub async fn run(args: BenchArgs) -> Result<()> {
    match args.scenario {
        Some(Scenario::Search(a)) => search::run(a).await,
        None => answers::run(args.answers).await,
    }
}

/// The `p` quantile of sorted `lat` (NaN when empty).
pub(crate) fn quantile(lat: &[f64], p: f64) -> f64 {
    if lat.is_empty() {
        f64::NAN
    } else {
        lat[((lat.len() as f64 - 1.0) * p).round() as usize]
    }
}
