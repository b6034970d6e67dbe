//! `learner bench search`: the style search on a 200,000-item library — index build time and
//! memory, query latencies on one core — and the same exact query in numpy and faiss
//! (scripts/bench/search_numpy.py) side by side, as ratios.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::metric::Model;
use learner::metric::model::fit_scaling;
use learner::search::texts::{read_item_texts, texts_for};
use learner::search::{ItemText, Query, SearchIndex, SearchParams, Weighting};
use learner::table::{FeatureTable, read_features};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Arguments of `learner bench search`.
#[derive(Debug, Args)]
pub struct BenchSearchArgs {
    /// Features of real items (default: the development set, after `scripts/fetch-dev-data` and
    /// `learner features`).
    #[arg(long, default_value = ".cache/dev-features.csv")]
    pub features: PathBuf,
    /// The metric; without it, uniform weights.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Labels CSV with the items' keywords.
    #[arg(long, default_value = ".cache/style-data/dev/labels.csv")]
    pub tags: PathBuf,
    /// Library size: the real items, then jittered copies of them up to this many.
    #[arg(long, default_value_t = 200_000)]
    pub items: usize,
    /// Jitter of a copy: uniform noise with this many standard deviations of each feature.
    #[arg(long, default_value_t = 0.05)]
    pub jitter: f64,
    /// Queries timed per measurement.
    #[arg(long, default_value_t = 300)]
    pub queries: usize,
    /// Keywords of the keyword + style measurement (≤ 20,000 hits is the budget's case).
    #[arg(long, default_value = "face")]
    pub keywords: String,
    /// The Python side (numpy, faiss).
    #[arg(long, default_value = "scripts/bench/search_numpy.py")]
    pub python_script: PathBuf,
    /// Skip the Python side.
    #[arg(long)]
    pub no_python: bool,
    /// Seed of the copies and of the query draw.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Write the figures as JSON here too.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Internal: load the index folder, answer one query, print load time and peak memory.
    #[arg(long, hide = true)]
    pub measure_load: Option<PathBuf>,
}

const K: usize = 50;

/// Runs `learner bench search`.
pub fn run(a: &BenchSearchArgs) -> Result<()> {
    if let Some(dir) = &a.measure_load {
        return measure_load(dir);
    }
    if !a.features.is_file() {
        bail!(
            "{} not found: run scripts/fetch-dev-data and `learner features .cache/style-data/dev \
             --out .cache/dev-features.csv`, or name a features file",
            a.features.display()
        );
    }
    let t = Instant::now();
    let real = read_features(&a.features)?;
    let read_s = t.elapsed().as_secs_f64();
    let weighting = match &a.model {
        Some(p) => Weighting::from_model(&Model::load(p)?, &real)?,
        None => Weighting::uniform(&real),
    };
    let labels = if a.tags.is_file() {
        Some(read_item_texts(&a.tags)?)
    } else {
        eprintln!(
            "{} not found: items get their id's words only",
            a.tags.display()
        );
        None
    };
    let (table, texts) = replicate(&real, labels.as_ref(), a.items, a.jitter, a.seed)?;
    let copies = table.len() - real.len();
    eprintln!("indexing {} items…", table.len());

    let dir = tempfile::tempdir()?;
    let folder = dir.path().join("index");
    let params = SearchParams::default();
    let t = Instant::now();
    let index = SearchIndex::build_in(&folder, &table, texts, &weighting, &params, &mut |_| {})?;
    let built_s = t.elapsed().as_secs_f64();
    index.save(&folder, None)?;
    let build_s = t.elapsed().as_secs_f64();
    let info = index.build_info().clone();
    let style_mb = file_mb(&folder.join("style.bin"));
    let keywords_mb = dir_mb(&folder.join("keywords"));
    let load = Command::new(std::env::current_exe()?)
        .args(["bench", "search", "--measure-load"])
        .arg(&folder)
        .output()
        .context("cannot measure the load in a child process")?;
    let load: serde_json::Value = serde_json::from_slice(&load.stdout).with_context(|| {
        format!(
            "child process: {}",
            String::from_utf8_lossy(&load.stderr).trim()
        )
    })?;

    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed.wrapping_add(1));
    let rows: Vec<usize> = (0..a.queries)
        .map(|_| rng.random_range(0..table.len()))
        .collect();
    let canvases: Vec<Vec<String>> = (0..a.queries)
        .map(|_| {
            (0..5)
                .map(|_| table.ids()[rng.random_range(0..table.len())].clone())
                .collect()
        })
        .collect();

    let mut lines: Vec<(String, Latency, &str)> = Vec::new();
    let mut ours_rows: Vec<Vec<u32>> = Vec::new();
    let by_example = one.install(|| {
        time_queries(rows.len(), |i| {
            let q = Query {
                examples: vec![table.row(rows[i]).to_vec()],
                limit: K,
                ..Query::default()
            };
            let r = index.search(&q)?;
            ours_rows.push(r.hits.iter().map(|h| h.row).collect());
            Ok(r.matched)
        })
    })?;
    ours_rows.remove(0); // the untimed warm-up run
    lines.push((
        format!("exact query by example, top {K} of {}", table.len()),
        by_example,
        "p50 ≤ 10, p99 ≤ 20",
    ));
    let by_example_all = time_queries(rows.len().min(100), |i| {
        let q = Query {
            examples: vec![table.row(rows[i]).to_vec()],
            limit: K,
            ..Query::default()
        };
        Ok(index.search(&q)?.matched)
    })?;
    lines.push((
        format!("  the same on all {} threads", rayon::current_num_threads()),
        by_example_all,
        "",
    ));
    let canvas_all = one.install(|| {
        time_queries(rows.len().min(100), |i| {
            let q = Query {
                near: canvases[i].clone(),
                limit: K,
                ..Query::default()
            };
            Ok(index.search(&q)?.matched)
        })
    })?;
    lines.push((
        format!("canvas of 5 items, top {K} of {}", table.len()),
        canvas_all,
        "",
    ));
    let hits = index.keywords().search(Some(&a.keywords), None)?.len();
    let keyword_only = one.install(|| {
        time_queries(rows.len(), |_| {
            Ok(index.keywords().search(Some(&a.keywords), None)?.len())
        })
    })?;
    let keyword_canvas = one.install(|| {
        time_queries(rows.len(), |i| {
            let q = Query {
                keywords: Some(a.keywords.clone()),
                near: canvases[i].clone(),
                limit: K,
                ..Query::default()
            };
            Ok(index.search(&q)?.matched)
        })
    })?;
    lines.push((
        format!("keywords \"{}\" ({hits} hits) + 5-item canvas", a.keywords),
        keyword_canvas,
        "≤ 5",
    ));
    lines.push(("  of which the keyword search".into(), keyword_only, ""));
    let diverse = one.install(|| {
        time_queries(rows.len().min(50), |_| {
            let q = Query {
                diverse: true,
                limit: K,
                ..Query::default()
            };
            Ok(index.search(&q)?.matched)
        })
    })?;
    lines.push((
        format!("diversity order of all {} items", table.len()),
        diverse,
        "",
    ));
    let diverse_keywords = one.install(|| {
        time_queries(rows.len(), |_| {
            let q = Query {
                keywords: Some(a.keywords.clone()),
                diverse: true,
                limit: K,
                ..Query::default()
            };
            Ok(index.search(&q)?.matched)
        })
    })?;
    lines.push((
        format!("keywords \"{}\" in diversity order", a.keywords),
        diverse_keywords,
        "",
    ));

    outln!(
        "library: {} items = {} real ({}) + {copies} copies with uniform jitter of {} standard \
         deviations per feature (seed {})",
        table.len(),
        real.len(),
        a.features.display(),
        a.jitter,
        a.seed
    )?;
    outln!(
        "metric: {}; {} of {} features weigh → {} floats per row",
        a.model
            .as_ref()
            .map_or("none (uniform weights)".to_string(), |p| p
                .display()
                .to_string()),
        info.active_dims,
        real.dim(),
        index.matrix().stride()
    )?;
    outln!(
        "index build on {} threads: {:.1} s (projection {:.1} s, keywords {:.1} s, two-level \
         k-means {:.1} s, writing {:.1} s); reading the real CSV took {read_s:.1} s",
        rayon::current_num_threads(),
        build_s,
        info.projection_seconds,
        info.keywords_seconds,
        info.clustering_seconds,
        build_s - built_s
    )?;
    let d = index.diversity().info();
    outln!(
        "  k-means: {} clusters in {} iterations ({}), {} top clusters of sizes {:?}",
        d.level1.k,
        d.level1.iterations,
        if d.level1.converged {
            "converged"
        } else {
            "iteration limit"
        },
        d.level2.k,
        d.top_sizes
    )?;
    outln!(
        "index size: style.bin {style_mb:.1} MB, keywords/ {keywords_mb:.1} MB; a process that \
         loads it and answers a query peaks at {:.1} MB resident (load {:.2} s)",
        load["peak_rss_kb"].as_f64().unwrap_or(f64::NAN) / 1024.0,
        load["load_seconds"].as_f64().unwrap_or(f64::NAN)
    )?;
    outln!(
        "\n{:<52} {:>8} {:>8} {:>8}  {}",
        "query (one thread unless said)",
        "p50 ms",
        "p99 ms",
        "mean ms",
        "target"
    )?;
    for (name, l, target) in &lines {
        outln!(
            "{name:<52} {:>8.2} {:>8.2} {:>8.2}  {target}",
            l.p50,
            l.p99,
            l.mean
        )?;
    }
    let mut report = serde_json::json!({
        "items": table.len(), "real_items": real.len(), "jitter": a.jitter, "seed": a.seed,
        "active_dims": info.active_dims, "stride": index.matrix().stride(),
        "build_seconds": build_s, "build": info, "style_mb": style_mb, "keywords_mb": keywords_mb,
        "load": load, "keyword_hits": hits,
        "queries": lines.iter().map(|(n, l, _)| serde_json::json!({"name": n, "p50_ms": l.p50, "p99_ms": l.p99, "mean_ms": l.mean})).collect::<Vec<_>>(),
    });
    if !a.no_python {
        match python_side_by_side(a, &index, &table, &rows, &ours_rows, &by_example) {
            Ok(py) => report["python"] = py,
            Err(e) => eprintln!("\nPython comparison skipped: {e:#}"),
        }
    }
    if let Some(path) = &a.json {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}

/// The real items, then copies with uniform noise of `jitter` standard deviations per feature
/// (variance-matched: half-width `jitter·σ·√3`), named `<id>#<copy>` with the original's words.
fn replicate(
    real: &FeatureTable,
    labels: Option<&std::collections::HashMap<String, ItemText>>,
    items: usize,
    jitter: f64,
    seed: u64,
) -> Result<(FeatureTable, Vec<ItemText>)> {
    let base = texts_for(real.ids(), labels);
    if items <= real.len() {
        let ids = real.ids()[..items].to_vec();
        let values = real.values()[..items * real.dim()].to_vec();
        let texts = base[..items].to_vec();
        return Ok((
            FeatureTable::new(real.names().to_vec(), ids, values)?,
            texts,
        ));
    }
    let (_, sd) = fit_scaling(real, &[]);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut ids = real.ids().to_vec();
    let mut values = real.values().to_vec();
    let mut texts = base.clone();
    ids.reserve(items - real.len());
    values.reserve((items - real.len()) * real.dim());
    for i in real.len()..items {
        let src = i % real.len();
        ids.push(format!("{}#{}", real.ids()[src], i / real.len()));
        for (v, s) in real.row(src).iter().zip(&sd) {
            values.push(v + rng.random_range(-1.0..1.0) * jitter * s * 3f64.sqrt());
        }
        texts.push(base[src].clone());
    }
    Ok((
        FeatureTable::new(real.names().to_vec(), ids, values)?,
        texts,
    ))
}

/// Latency percentiles in milliseconds.
#[derive(Debug, Clone, Copy)]
struct Latency {
    p50: f64,
    p99: f64,
    mean: f64,
}

fn time_queries(n: usize, mut f: impl FnMut(usize) -> Result<usize>) -> Result<Latency> {
    // One untimed run warms caches and the allocator.
    std::hint::black_box(f(0)?);
    let mut ms = Vec::with_capacity(n);
    for i in 0..n {
        let t = Instant::now();
        std::hint::black_box(f(i)?);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
    Ok(Latency {
        p50: at(0.5),
        p99: at(0.99),
        mean: ms.iter().sum::<f64>() / ms.len() as f64,
    })
}

fn file_mb(path: &Path) -> f64 {
    std::fs::metadata(path).map_or(f64::NAN, |m| m.len() as f64 / 1e6)
}

fn dir_mb(path: &Path) -> f64 {
    walkdir::WalkDir::new(path)
        .into_iter()
        .filter_map(|e| e.ok())
        .filter_map(|e| e.metadata().ok())
        .filter(|m| m.is_file())
        .map(|m| m.len() as f64 / 1e6)
        .sum()
}

/// In a fresh process: load the index, answer one query, report the time and peak memory.
fn measure_load(dir: &Path) -> Result<()> {
    let t = Instant::now();
    let (index, _) = SearchIndex::load(dir)?;
    let load_seconds = t.elapsed().as_secs_f64();
    let r = index.search(&Query {
        near: vec![index.ids()[0].clone()],
        keywords: Some("face".into()),
        ..Query::default()
    })?;
    std::hint::black_box(r);
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let kb = |key: &str| {
        status
            .lines()
            .find(|l| l.starts_with(key))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|v| v.parse::<f64>().ok())
    };
    outln!(
        "{}",
        serde_json::json!({
            "load_seconds": load_seconds,
            "peak_rss_kb": kb("VmHWM:"),
            "rss_kb": kb("VmRSS:"),
            "heap_estimate_bytes": index.memory_bytes(),
        })
    )
}

/// Writes the pre-scaled matrix and the projected queries, runs the Python script, prints
/// the comparison.
fn python_side_by_side(
    a: &BenchSearchArgs,
    index: &SearchIndex,
    table: &FeatureTable,
    rows: &[usize],
    ours: &[Vec<u32>],
    our_latency: &Latency,
) -> Result<serde_json::Value> {
    if !a.python_script.is_file() {
        bail!(
            "{} not found (run from the workspace root)",
            a.python_script.display()
        );
    }
    let dir = tempfile::tempdir()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join("matrix.f32"))?);
    for v in index.matrix().data() {
        w.write_all(&v.to_le_bytes())?;
    }
    w.flush()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(dir.path().join("queries.f32"))?);
    for &r in rows {
        for v in index.matrix().project(table.row(r))? {
            w.write_all(&v.to_le_bytes())?;
        }
    }
    w.flush()?;
    std::fs::write(
        dir.path().join("ours.json"),
        serde_json::to_vec(&serde_json::json!({
            "n": index.len(), "stride": index.matrix().stride(), "k": K, "rows": ours,
        }))?,
    )?;
    eprintln!("timing numpy and faiss on the same matrix and queries…");
    let out = Command::new("python3")
        .arg(&a.python_script)
        .arg(dir.path())
        .args(["--k", &K.to_string()])
        .env("OMP_NUM_THREADS", "1")
        .env("OPENBLAS_NUM_THREADS", "1")
        .env("MKL_NUM_THREADS", "1")
        .output()
        .context("cannot run python3")?;
    if !out.status.success() {
        bail!(
            "{} failed ({}): {}",
            a.python_script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let py: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    outln!(
        "\nside by side: exact top {K} by example over the same pre-scaled matrix, one query at a \
         time, one thread"
    )?;
    outln!(
        "{:<36} {:>8} {:>8} {:>14} {:>16}",
        "engine",
        "p50 ms",
        "p99 ms",
        "p50 / ours",
        "top-50 overlap"
    )?;
    outln!(
        "{:<36} {:>8.2} {:>8.2} {:>14} {:>16}",
        "stylekit (f32 scan, bounded heap)",
        our_latency.p50,
        our_latency.p99,
        "1.0x",
        "—"
    )?;
    for (key, name) in [
        ("numpy_gemv", "numpy ‖x‖²−2x·q+‖q‖², argpartition"),
        ("numpy_direct", "numpy Σ(x−q)², argpartition"),
        ("faiss_flat_l2", "faiss IndexFlatL2"),
    ] {
        let e = &py[key];
        if let Some(reason) = e["skipped"].as_str() {
            outln!("{name:<36} skipped: {reason}")?;
            continue;
        }
        let p50 = e["p50"].as_f64().unwrap_or(f64::NAN);
        outln!(
            "{name:<36} {p50:>8.2} {:>8.2} {:>13.1}x {:>15.1}%",
            e["p99"].as_f64().unwrap_or(f64::NAN),
            p50 / our_latency.p50,
            e["agreement"].as_f64().unwrap_or(f64::NAN) * 100.0
        )?;
    }
    outln!("(versions: {})", py["versions"])?;
    Ok(py)
}
