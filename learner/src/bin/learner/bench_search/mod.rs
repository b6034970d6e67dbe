//! `learner bench search`: the style search on a 200,000-item library — index build time and
//! memory, query latencies on one core — and the same exact query in numpy and faiss
//! (scripts/bench/search_numpy.py) side by side, as ratios.

mod data;
mod outside;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::metric::Model;
use learner::search::texts::read_item_texts;
use learner::search::{Query, SearchIndex, SearchParams, Weighting};
use learner::table::read_features;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use data::{Latency, dir_mb, file_mb, proc_kb, replicate, time_queries};
use outside::{measure_load, python_side_by_side};

/// Arguments of `learner bench search`.
#[derive(Debug, Args)]
pub struct BenchSearchArgs {
    /// Features of real items (default: the development set, `.cache/dev-features.csv` after
    /// `scripts/fetch-dev-data` and `learner features`, or else the 200 fixture icons'
    /// committed features).
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// The metric; without it, uniform weights.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Labels CSV with the items' keywords (default: the development set's, or the fixture
    /// set's with the fixture features).
    #[arg(long)]
    pub tags: Option<PathBuf>,
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
    let (features, tags) = sources(a)?;
    let t = Instant::now();
    let real = read_features(&features)?;
    let read_s = t.elapsed().as_secs_f64();
    let weighting = match &a.model {
        Some(p) => Weighting::from_model(&Model::load(p)?, &real)?,
        None => Weighting::uniform(&real),
    };
    let labels = if tags.is_file() {
        Some(read_item_texts(&tags)?)
    } else {
        eprintln!(
            "{} not found: items get their id's words only",
            tags.display()
        );
        None
    };
    let (table, texts) = replicate(&real, labels.as_ref(), a.items, a.jitter, a.seed)?;
    let copies = table.len() - real.len();
    eprintln!("indexing {} items…", table.len());

    let dir = tempfile::tempdir()?;
    let folder = dir.path().join("index");
    let params = SearchParams::default();
    // The build's own memory: the peak resident size during the build above what the process
    // held before it (the 200,000-row f64 table and its words, which a real library also
    // holds while reading its features CSV). Writing 5 to clear_refs resets the peak (Linux).
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let rss_before_kb = proc_kb("VmRSS:");
    let t = Instant::now();
    let index = SearchIndex::build_in(&folder, &table, texts, &weighting, &params, &mut |_| {})?;
    let built_s = t.elapsed().as_secs_f64();
    index.save(&folder, None)?;
    let build_s = t.elapsed().as_secs_f64();
    let build_peak_mb = (proc_kb("VmHWM:") - rss_before_kb) / 1024.0;
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
        features.display(),
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
    outln!(
        "  build memory: peak {build_peak_mb:.0} MB resident above the loaded features table \
         (target ≤ 200 MB)"
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
        "build_seconds": build_s, "build_peak_mb": build_peak_mb, "build": info, "style_mb": style_mb, "keywords_mb": keywords_mb,
        "load": load, "keyword_hits": hits,
        "queries": lines.iter().map(|(n, l, _)| serde_json::json!({"name": n, "p50_ms": l.p50, "p99_ms": l.p99, "mean_ms": l.mean})).collect::<Vec<_>>(),
    });
    if !a.no_python {
        report["python"] = python_side_by_side(a, &index, &table, &rows, &ours_rows, &by_example)?;
    }
    if let Some(path) = &a.json {
        std::fs::write(path, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(())
}

/// The features and labels to replicate: as given, else the development set, else the fixture
/// set (so the bench runs on a fresh checkout, on 200 real icons instead of 17,458).
fn sources(a: &BenchSearchArgs) -> Result<(PathBuf, PathBuf)> {
    const DEV: (&str, &str) = (
        ".cache/dev-features.csv",
        ".cache/style-data/dev/labels.csv",
    );
    const FIXTURE: (&str, &str) = (
        "learner/tests/data/metric/fixture-features.csv",
        "fixtures/style/labels.csv",
    );
    let features = match &a.features {
        Some(f) => f.clone(),
        None if Path::new(DEV.0).is_file() => DEV.0.into(),
        None if Path::new(FIXTURE.0).is_file() => {
            eprintln!(
                "{} not found (scripts/fetch-dev-data, then `learner features`): using the \
                 fixture set's features",
                DEV.0
            );
            FIXTURE.0.into()
        }
        None => bail!(
            "neither {} nor {} found: run from the workspace root or name --features",
            DEV.0,
            FIXTURE.0
        ),
    };
    let tags = a.tags.clone().unwrap_or_else(|| {
        if features == Path::new(FIXTURE.0) {
            FIXTURE.1.into()
        } else {
            DEV.1.into()
        }
    });
    Ok((features, tags))
}
