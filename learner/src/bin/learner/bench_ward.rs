//! `learner bench ward`: Ward clustering (learner::explore::ward) of seeded random points, timed,
//! and scipy's `linkage(X, 'ward')` on the same points (scripts/bench/ward_python.py) as a ratio.

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::explore::ward;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Arguments of `learner bench ward`.
#[derive(Debug, Args)]
pub struct BenchWardArgs {
    /// Points to cluster.
    #[arg(long, default_value_t = 10_000)]
    points: usize,
    /// Coordinates per point.
    #[arg(long, default_value_t = 37)]
    dim: usize,
    /// Seed of the standard-normal-like points (uniform in [−1, 1]).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Timed runs of each side; the best is reported.
    #[arg(long, default_value_t = 3)]
    runs: usize,
    /// Skip the scipy side.
    #[arg(long)]
    no_python: bool,
    /// The Python side.
    #[arg(long, default_value = "scripts/bench/ward_python.py")]
    python_script: PathBuf,
}

pub fn run(a: &BenchWardArgs) -> Result<()> {
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let x: Vec<f64> = (0..a.points.saturating_mul(a.dim))
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let mut best = Duration::MAX;
    let mut heights = 0.0;
    for _ in 0..a.runs {
        let start = Instant::now();
        let tree = ward(&x, a.dim)?;
        best = best.min(start.elapsed());
        heights = tree.merges().iter().map(|m| m.height).sum::<f64>();
    }
    let ours = best.as_secs_f64();
    println!(
        "ward, {} points x {} dims, {} threads: {ours:.3} s (best of {}); sum of heights {heights:.9e}",
        a.points,
        a.dim,
        rayon::current_num_threads(),
        a.runs
    );
    if a.no_python {
        return Ok(());
    }
    let file = tempfile::NamedTempFile::new()?;
    let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(file.path(), bytes)?;
    let out = Command::new("python3")
        .arg(&a.python_script)
        .arg(file.path())
        .arg(a.dim.to_string())
        .arg(a.runs.to_string())
        .output()
        .with_context(|| format!("running {}", a.python_script.display()))?;
    if !out.status.success() {
        bail!(
            "{} failed: {}",
            a.python_script.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let theirs: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let seconds = theirs["seconds"]
        .as_f64()
        .context("no seconds from python")?;
    println!(
        "scipy {} linkage(X, 'ward'): {seconds:.3} s (best of {}); sum of heights {:.9e}",
        theirs["scipy"].as_str().unwrap_or("?"),
        a.runs,
        theirs["heights_sum"].as_f64().unwrap_or(f64::NAN)
    );
    println!("ratio ours / scipy: {:.2}", ours / seconds);
    Ok(())
}
