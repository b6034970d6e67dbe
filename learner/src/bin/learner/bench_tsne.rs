//! `learner bench tsne`: t-SNE (learner::explore::tsne) of seeded clustered points or real
//! style rows, timed, and openTSNE on the same points (scripts/bench/tsne_python.py) in the same
//! run; both embeddings measured by the same code (learner::explore::tsne::quality).

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::explore::tsne::quality::{self, kl_divergence, knn_preservation, trustworthiness};
use learner::explore::tsne::{TsneParams, affinities, approximate_knn_recall, tsne};
use learner::metric::Model;
use learner::search::{StyleMatrix, Weighting};
use learner::table::read_features;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Arguments of `learner bench tsne`.
#[derive(Debug, Args)]
pub struct BenchTsneArgs {
    /// Points to embed.
    #[arg(long, default_value_t = 20_000)]
    points: usize,
    /// Coordinates per point (seeded data only).
    #[arg(long, default_value_t = 40)]
    dim: usize,
    /// Clusters of the seeded data (centres N(0, 4²) per coordinate, points N(centre, 1)).
    #[arg(long, default_value_t = 30)]
    clusters: usize,
    /// Seed of the data, of both t-SNE runs and of the quality sample.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Threads for both sides (rayon here, n_jobs for openTSNE).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Real rows instead: a features CSV, projected to the style space `√w ⊙ x̂` of `--model`
    /// (as the search index stores them). Rows beyond the file's are copies with a jitter of
    /// 2% of each dimension's spread.
    #[arg(long, requires = "model")]
    features: Option<PathBuf>,
    /// The metric model for `--features`.
    #[arg(long, requires = "features")]
    model: Option<PathBuf>,
    /// Perplexity (both sides).
    #[arg(long, default_value_t = 30.0)]
    perplexity: f64,
    /// Iterations in all, early exaggeration included (both sides).
    #[arg(long, default_value_t = 750)]
    n_iter: usize,
    /// Points in the sample the quality is measured on.
    #[arg(long, default_value_t = 5_000)]
    sample: usize,
    /// openTSNE's negative-gradient method: auto (its default: FFT from 10,000 points), bh or
    /// fft.
    #[arg(long, default_value = "auto")]
    python_method: String,
    /// Skip the openTSNE side.
    #[arg(long)]
    no_python: bool,
    /// Also measure the approximate neighbours' recall against the exact search (O(n²)).
    #[arg(long)]
    knn_recall: bool,
    /// The Python side.
    #[arg(long, default_value = "scripts/bench/tsne_python.py")]
    python_script: PathBuf,
}

fn proc_kb(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find(|l| l.starts_with(key))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse::<f64>().ok())
        .unwrap_or(f64::NAN)
}

/// User + system CPU seconds of this process so far (all threads; `/proc/self/stat` fields 14
/// and 15, in clock ticks of 1/100 s as on every Linux x86-64 kernel).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map(|(_, rest)| rest.split_whitespace().collect())
        .unwrap_or_default();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (ticks(11) + ticks(12)) / 100.0
}

fn normal(rng: &mut ChaCha8Rng) -> f32 {
    let u: f32 = 1.0 - rng.random::<f32>();
    let v: f32 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
}

/// The points (row-major) and their dimension.
fn points(a: &BenchTsneArgs) -> Result<(Vec<f32>, usize, String)> {
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    if let (Some(features), Some(model)) = (&a.features, &a.model) {
        let table = read_features(features)?;
        let weighting = Weighting::from_model(&Model::load(model)?, &table)?;
        let m = StyleMatrix::build(&table, &weighting)?;
        let dim = m.active_dims();
        let real: Vec<f32> = (0..m.len())
            .flat_map(|i| m.row(i)[..dim].to_vec())
            .collect();
        let rows = m.len();
        let spread: Vec<f32> = (0..dim)
            .map(|d| {
                let mean = (0..rows).map(|i| real[i * dim + d]).sum::<f32>() / rows as f32;
                ((0..rows)
                    .map(|i| (real[i * dim + d] - mean).powi(2))
                    .sum::<f32>()
                    / rows as f32)
                    .sqrt()
            })
            .collect();
        let x = (0..a.points)
            .flat_map(|i| {
                let row = &real[(i % rows) * dim..(i % rows + 1) * dim];
                let copy = i >= rows;
                row.iter()
                    .zip(&spread)
                    .map(|(&v, &s)| {
                        if copy {
                            v + 0.02 * s * normal(&mut rng)
                        } else {
                            v
                        }
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        let what = format!(
            "{} style rows ({} real, {}) x {dim}",
            a.points,
            rows.min(a.points),
            features.display()
        );
        return Ok((x, dim, what));
    }
    let centres: Vec<f32> = (0..a.clusters * a.dim)
        .map(|_| 4.0 * normal(&mut rng))
        .collect();
    let x = (0..a.points)
        .flat_map(|i| {
            let c = (i * 7919) % a.clusters.max(1);
            (0..a.dim)
                .map(|d| centres[c * a.dim + d] + normal(&mut rng))
                .collect::<Vec<_>>()
        })
        .collect();
    Ok((
        x,
        a.dim,
        format!(
            "{} seeded points in {} clusters x {}",
            a.points, a.clusters, a.dim
        ),
    ))
}

struct Side {
    name: String,
    seconds: f64,
    cpu_seconds: f64,
    kl_own: f64,
    peak_mb: f64,
    y: Vec<[f32; 2]>,
}

pub fn run(a: &BenchTsneArgs) -> Result<()> {
    if a.threads == 0 {
        bail!("--threads must be at least 1");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads)
        .build()?;
    let (x, dim, what) = points(a)?;
    let n = x.len() / dim;
    let params = TsneParams {
        perplexity: a.perplexity,
        n_iter: a.n_iter,
        early_exaggeration_iter: a.n_iter.min(250),
        seed: a.seed,
        ..TsneParams::default()
    };
    eprintln!("{what}; ours on {} threads…", a.threads);
    let t = Instant::now();
    let cpu = cpu_seconds();
    let (y, info) = pool.install(|| tsne(&x, dim, &params, &mut |_, _| {}))?;
    let ours = Side {
        name: format!("learner t-SNE ({:?}, {:?} kNN)", info.method, info.knn),
        seconds: t.elapsed().as_secs_f64(),
        cpu_seconds: cpu_seconds() - cpu,
        kl_own: info.kl_divergence,
        peak_mb: proc_kb("VmHWM:") / 1024.0,
        y,
    };
    eprintln!(
        "  affinities {:.2} s, start {:.2} s, descent {:.2} s",
        info.affinity_seconds, info.init_seconds, info.optimise_seconds
    );
    if a.knn_recall {
        let t = Instant::now();
        let recall = pool.install(|| approximate_knn_recall(&x, dim, &params))?;
        println!(
            "approximate kNN recall (k = {}) against the exact search: {recall:.4} ({:.1} s for both searches)",
            params.neighbours(),
            t.elapsed().as_secs_f64()
        );
    }
    let mut sides = vec![ours];
    if !a.no_python {
        sides.push(python(a, &x, dim, &params)?);
    }
    // Quality on a seeded sample (the measures are quadratic), by the same code for both.
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed ^ 0x5eed);
    let s = a.sample.min(n);
    let mut chosen: Vec<usize> = (0..n).collect();
    for i in 0..s {
        let j = rng.random_range(i..n);
        chosen.swap(i, j);
    }
    chosen.truncate(s);
    chosen.sort_unstable();
    let xs: Vec<f32> = chosen
        .iter()
        .flat_map(|&i| x[i * dim..(i + 1) * dim].to_vec())
        .collect();
    let exact_kl = n <= quality::MAX_POINTS;
    let p = if exact_kl {
        Some(pool.install(|| affinities(&x, dim, &params))?)
    } else {
        None
    };
    println!(
        "t-SNE of {what}: perplexity {}, {} iterations (250 exaggerated ×12), {} threads; quality on {s} sampled points",
        a.perplexity, a.n_iter, a.threads
    );
    println!(
        "| | time (s) | CPU (s) | KL (own) | KL (our P, exact Z) | T(10) | kNN kept (10) | peak RSS (MB) |"
    );
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
    for side in &sides {
        let ys: Vec<[f32; 2]> = chosen.iter().map(|&i| side.y[i]).collect();
        let (t10, kept) = pool.install(|| -> Result<(f64, f64)> {
            Ok((
                trustworthiness(&xs, dim, &ys, 10)?,
                knn_preservation(&xs, dim, &ys, 10)?,
            ))
        })?;
        let kl = match &p {
            Some(p) => format!("{:.4}", pool.install(|| kl_divergence(p, &side.y))?),
            None => "—".into(),
        };
        println!(
            "| {} | {:.1} | {:.1} | {:.4} | {kl} | {t10:.4} | {kept:.4} | {:.0} |",
            side.name, side.seconds, side.cpu_seconds, side.kl_own, side.peak_mb
        );
    }
    if sides.len() == 2 {
        println!(
            "ratio ours / openTSNE: time {:.2}, CPU {:.2}",
            sides[0].seconds / sides[1].seconds,
            sides[0].cpu_seconds / sides[1].cpu_seconds
        );
    }
    Ok(())
}

fn python(a: &BenchTsneArgs, x: &[f32], dim: usize, params: &TsneParams) -> Result<Side> {
    let input = tempfile::NamedTempFile::new()?;
    let output = tempfile::NamedTempFile::new()?;
    let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(input.path(), bytes)?;
    eprintln!("openTSNE ({}, n_jobs={})…", a.python_method, a.threads);
    let out = Command::new("python3")
        .arg(&a.python_script)
        .arg(input.path())
        .arg(dim.to_string())
        .arg(output.path())
        .arg(params.perplexity.to_string())
        .arg(params.n_iter.to_string())
        .arg(params.early_exaggeration_iter.to_string())
        .arg(params.early_exaggeration.to_string())
        .arg(a.threads.to_string())
        .arg(a.seed.to_string())
        .arg(&a.python_method)
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
    let raw = std::fs::read(output.path())?;
    let y: Vec<[f32; 2]> = raw
        .chunks_exact(8)
        .map(|c| {
            [
                f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                f32::from_le_bytes([c[4], c[5], c[6], c[7]]),
            ]
        })
        .collect();
    if y.len() != x.len() / dim {
        bail!("openTSNE returned {} points for {}", y.len(), x.len() / dim);
    }
    Ok(Side {
        name: format!(
            "openTSNE {} ({})",
            theirs["opentsne"].as_str().unwrap_or("?"),
            theirs["method"].as_str().unwrap_or("?")
        ),
        seconds: theirs["seconds"]
            .as_f64()
            .context("no seconds from python")?,
        cpu_seconds: theirs["cpu_seconds"].as_f64().unwrap_or(f64::NAN),
        kl_own: theirs["kl_divergence"].as_f64().unwrap_or(f64::NAN),
        peak_mb: theirs["maxrss_kb"].as_f64().unwrap_or(f64::NAN) / 1024.0,
        y,
    })
}
