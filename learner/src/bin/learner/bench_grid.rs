//! `learner bench grid`: the balanced grid of Garces et al. 2016 (learner::explore::grid) on seeded
//! synthetic style data — SOM + Algorithms 3–4 timed on 10,000 items into 100×100 — the exact
//! assignment of the IsoMatch baseline timed at 1,000 and 5,000 cells beside scipy's
//! `linear_sum_assignment` on the same matrices (scripts/bench/lap_python.py), and the quality of
//! each layout (balanced, raw SOM, IsoMatch, random): eq. 6.1's terms, Spearman, DPQ16.

use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::explore::grid::{
    BalanceParams, Grid, IsoMatchParams, QualityParams, SomParams, balance, cost, dpq,
    isomatch_cost, layout_spearman, linear_assignment, random_layout, som, som_grid,
};
use learner::explore::{Node, NodeState};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Arguments of `learner bench grid`.
#[derive(Debug, Args)]
pub struct BenchGridArgs {
    /// Items of the headline run.
    #[arg(long, default_value_t = 10_000)]
    items: usize,
    /// Grid rows of the headline run.
    #[arg(long, default_value_t = 100)]
    rows: usize,
    /// Grid columns of the headline run.
    #[arg(long, default_value_t = 100)]
    cols: usize,
    /// Style dimensions of the synthetic data.
    #[arg(long, default_value_t = 16)]
    dim: usize,
    /// Gaussian style clusters of the synthetic data.
    #[arg(long, default_value_t = 12)]
    clusters: usize,
    /// Semantic labels (each cluster leans to one of them).
    #[arg(long, default_value_t = 4)]
    labels: u32,
    /// SOM epochs.
    #[arg(long, default_value_t = 12)]
    epochs: usize,
    /// Seed of the data and of every layout.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Cells of the IsoMatch comparisons (as many items as cells; grids rows×(cells/rows), rows
    /// the largest divisor up to √cells).
    #[arg(long, value_delimiter = ',', default_value = "1000,5000")]
    lap_cells: Vec<usize>,
    /// Skip the scipy side.
    #[arg(long)]
    no_python: bool,
    /// The Python side.
    #[arg(long, default_value = "scripts/bench/lap_python.py")]
    python_script: PathBuf,
}

/// Clustered points: cluster centres uniform in [−1, 1]^dim, items Gaussian-like around them
/// (spread 0.25), the label the cluster's (cluster mod labels) with probability 0.7, else random.
fn data(a: &BenchGridArgs, n: usize, seed: u64) -> (Vec<f32>, Vec<u32>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let centres: Vec<f32> = (0..a.clusters * a.dim)
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    let mut x = Vec::with_capacity(n * a.dim);
    let mut labels = Vec::with_capacity(n);
    for _ in 0..n {
        let c = rng.random_range(0..a.clusters);
        for d in 0..a.dim {
            let noise: f32 = (0..3).map(|_| rng.random_range(-0.25f32..0.25)).sum();
            x.push(centres[c * a.dim + d] + noise);
        }
        labels.push(if rng.random_bool(0.7) {
            c as u32 % a.labels
        } else {
            rng.random_range(0..a.labels)
        });
    }
    (x, labels)
}

fn row(
    name: &str,
    seconds: f64,
    grid: &Grid,
    x: &[f32],
    dim: usize,
    labels: &[u32],
    seed: u64,
) -> Result<()> {
    let c = cost(grid, labels)?;
    let q = QualityParams {
        seed,
        ..QualityParams::default()
    };
    let rho = layout_spearman(x, dim, grid, &q)?;
    let d = dpq(x, dim, grid, &q)?;
    println!(
        "| {name} | {seconds:.3} | {} | {:.1} | {} | {:.1} | {rho:.4} | {d:.4} |",
        c.empty, c.imbalance, c.multi, c.total
    );
    Ok(())
}

fn header(title: &str) {
    println!("\n{title}\n");
    println!("| layout | seconds | empty | label imbalance | multi | eq. 6.1 | Spearman | DPQ16 |");
    println!("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |");
}

pub fn run(a: &BenchGridArgs) -> Result<()> {
    if a.items == 0 || a.dim == 0 || a.clusters == 0 || a.labels == 0 {
        bail!("--items, --dim, --clusters and --labels must be at least 1");
    }
    println!(
        "learner bench grid: {} threads, synthetic data ({} clusters in {} dims, {} labels), seed {}",
        rayon::current_num_threads(),
        a.clusters,
        a.dim,
        a.labels,
        a.seed
    );
    // Headline: SOM + Algorithms 3–4.
    let (x, labels) = data(a, a.items, a.seed);
    let mut sp = SomParams::new(a.rows, a.cols);
    sp.epochs = a.epochs;
    sp.seed = a.seed;
    let start = Instant::now();
    let map = som(&x, a.dim, &sp)?;
    let t_som = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let (grid, info) = balance(&x, a.dim, &labels, &map, &BalanceParams::default())?;
    let t_balance = start.elapsed().as_secs_f64();
    println!(
        "\nSOM {}x{} on {} items: {t_som:.3} s ({} epochs, quantisation error {:.4}); Algorithms 3-4: {t_balance:.3} s; total {:.3} s",
        a.rows,
        a.cols,
        a.items,
        a.epochs,
        map.quantisation_error,
        t_som + t_balance
    );
    println!(
        "eq. 6.1 total: SOM {:.1} -> Alg. 3 {:.1} -> Alg. 4 (5x5) {:.1} -> final {:.1}; filled 5x5 {}, grown {}, label moves {}",
        info.som.total,
        info.after_alg3.total,
        info.after_alg4.total,
        info.last.total,
        info.filled,
        info.filled_grown,
        info.relabelled
    );
    header(&format!(
        "Quality, {} items on {}x{} (IsoMatch: assignment too large here)",
        a.items, a.rows, a.cols
    ));
    row(
        "balanced (SOM + Alg. 3-4)",
        t_som + t_balance,
        &grid,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;
    row(
        "raw SOM",
        t_som,
        &som_grid(&x, a.dim, &map)?,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;
    let start = Instant::now();
    let random = random_layout(a.items, a.rows, a.cols, a.seed)?;
    row(
        "random",
        start.elapsed().as_secs_f64(),
        &random,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;

    for &cells in &a.lap_cells {
        compare(a, cells)?;
    }
    Ok(())
}

/// All four layouts of `cells` items on a grid of `cells` nodes, and the LAP beside scipy's.
fn compare(a: &BenchGridArgs, cells: usize) -> Result<()> {
    let rows = (1..=(cells as f64).sqrt() as usize)
        .rev()
        .find(|r| cells.is_multiple_of(*r))
        .context("cells ≥ 1")?;
    let cols = cells / rows;
    let (x, labels) = data(a, cells, a.seed.wrapping_add(cells as u64));
    let mut ip = IsoMatchParams::new(rows, cols);
    ip.seed = a.seed;
    ip.isomap.seed = a.seed;
    let start = Instant::now();
    let (placed, c) = isomatch_cost(&x, a.dim, &ip)?;
    let t_embed = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let assignment = linear_assignment(&c, placed.len(), cells)?;
    let t_lap = start.elapsed().as_secs_f64();
    let mut iso = Grid {
        rows,
        cols,
        nodes: (0..cells)
            .map(|k| Node {
                row: k / cols,
                col: k % cols,
                shown: None,
                hidden: Vec::new(),
                state: NodeState::Empty,
            })
            .collect(),
    };
    for (k, &cell) in assignment.col.iter().enumerate() {
        iso.nodes[cell].shown = Some(placed[k]);
        iso.nodes[cell].state = NodeState::Single;
    }
    println!(
        "\nIsoMatch on {cells} items, {rows}x{cols}: Isomap + costs {t_embed:.3} s; our assignment {t_lap:.3} s, total {:.6e}",
        assignment.total
    );
    if !a.no_python {
        let file = tempfile::NamedTempFile::new()?;
        let bytes: Vec<u8> = c.iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(file.path(), bytes)?;
        let out = Command::new("python3")
            .arg(&a.python_script)
            .arg(file.path())
            .arg(placed.len().to_string())
            .arg(cells.to_string())
            .arg("1")
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
            "scipy {} linear_sum_assignment: {seconds:.3} s, total {:.6e}; ratio ours / scipy {:.2}",
            theirs["scipy"].as_str().unwrap_or("?"),
            theirs["total"].as_f64().unwrap_or(f64::NAN),
            t_lap / seconds
        );
    }
    let mut sp = SomParams::new(rows, cols);
    sp.epochs = a.epochs;
    sp.seed = a.seed;
    let start = Instant::now();
    let map = som(&x, a.dim, &sp)?;
    let t_som = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let (grid, _) = balance(&x, a.dim, &labels, &map, &BalanceParams::default())?;
    let t_balance = start.elapsed().as_secs_f64();
    header(&format!("Quality, {cells} items on {rows}x{cols}"));
    row(
        "balanced (SOM + Alg. 3-4)",
        t_som + t_balance,
        &grid,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;
    row(
        "raw SOM",
        t_som,
        &som_grid(&x, a.dim, &map)?,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;
    row(
        "IsoMatch (Isomap + LAP)",
        t_embed + t_lap,
        &iso,
        &x,
        a.dim,
        &labels,
        a.seed,
    )?;
    let random = random_layout(cells, rows, cols, a.seed)?;
    row("random", 0.0, &random, &x, a.dim, &labels, a.seed)?;
    Ok(())
}
