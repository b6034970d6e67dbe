//! `learner index` and `learner search`: keyword search over a library ordered by the learned
//! style metric (§5.7.3). The index is kept in a folder next to the features
//! (`features.csv.search/`) and rebuilt when the features, labels, model or clustering
//! parameters change.

//!
//! * `build`: opening the saved index, or building and saving it.
//! * `output`: featurising `--example` drawings, and the printed results.

mod build;
mod output;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use learner::search::cache::{self, Sources};
use learner::search::{Query, SearchIndex, SearchParams};

use build::{build_and_save, build_bar, open_or_build, read_library, show};
use output::{featurise, print_json, print_table};

/// Where a library comes from and how its index is built.
#[derive(Debug, Args)]
pub struct LibraryArgs {
    /// Features CSV, as written by `learner features`.
    #[arg(long)]
    pub features: PathBuf,
    /// The metric (`model.json` of `learner train`). Without it every feature weighs the same
    /// after standardising over the library.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Labels CSV giving the words of each item: `file` (or `id`) plus any of `name`,
    /// `keywords`, `tags`, `category` (or `group`/`subgroup`), like the style data's labels.csv.
    #[arg(long)]
    pub tags: Option<PathBuf>,
    /// Index folder (default: next to the features, `<features>.search`).
    #[arg(long)]
    pub index: Option<PathBuf>,
    /// First-level clusters of the diversity order (§5.7.3).
    #[arg(long, default_value_t = SearchParams::default().k1)]
    pub k1: usize,
    /// Top-level clusters of the diversity order (§5.7.3).
    #[arg(long, default_value_t = SearchParams::default().k2)]
    pub k2: usize,
    /// Seed of the clustering.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long, short)]
    pub jobs: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl LibraryArgs {
    fn params(&self) -> Result<SearchParams> {
        let params = SearchParams {
            k1: self.k1,
            k2: self.k2,
            seed: self.seed,
            ..SearchParams::default()
        };
        params.validate()?;
        Ok(params)
    }

    fn dir(&self) -> PathBuf {
        self.index
            .clone()
            .unwrap_or_else(|| cache::default_dir(&self.features))
    }

    fn sources(&self) -> Sources<'_> {
        Sources {
            features: &self.features,
            labels: self.tags.as_deref(),
            model: self.model.as_deref(),
        }
    }
}

/// `learner index`.
#[derive(Debug, Args)]
pub struct IndexArgs {
    #[command(flatten)]
    pub library: LibraryArgs,
}

/// `learner search`.
#[derive(Debug, Args)]
pub struct SearchArgs {
    #[command(flatten)]
    pub library: LibraryArgs,
    /// Keywords: every word must match a name, tag or keyword (exactly, as a prefix, or with a
    /// typo).
    #[arg(long)]
    pub query: Option<String>,
    /// Only items in this category (or its subcategories).
    #[arg(long)]
    pub category: Option<String>,
    /// Order by mean style distance to these items (the canvas; one item: more like this).
    #[arg(long, value_delimiter = ',')]
    pub near: Vec<String>,
    /// Order by style distance to this drawing (SVG, PNG or JPEG), featurised now.
    #[arg(long)]
    pub example: Vec<PathBuf>,
    /// With nothing to compare to: deal results across style clusters (§5.7.3).
    #[arg(long, conflicts_with_all = ["near", "example"])]
    pub diverse: bool,
    /// Number of results.
    #[arg(long, default_value_t = learner::search::DEFAULT_LIMIT)]
    pub limit: usize,
    /// Print `{"results": [{"id", "distance", "cluster"}, …]}`.
    #[arg(long)]
    pub json: bool,
    /// Build the index in memory for this search only: neither read nor write the folder.
    #[arg(long)]
    pub no_cache: bool,
}

fn pool(jobs: Option<usize>) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .context("cannot start worker threads")
}

/// Runs `learner index`.
pub fn run_index(a: &IndexArgs) -> Result<()> {
    let lib = &a.library;
    let params = lib.params()?;
    let t = Instant::now();
    let index = pool(lib.jobs)?.install(|| build_and_save(lib, &params))?;
    let info = index.build_info();
    let d = index.diversity().info();
    outln!(
        "indexed {} items in {:.1} s → {}",
        index.len(),
        t.elapsed().as_secs_f64(),
        lib.dir().display()
    )?;
    outln!(
        "  {} of {} features weigh (the rest are dropped); {:.0} MB of rows",
        info.active_dims,
        index.feature_names().len(),
        index.matrix().memory_bytes() as f64 / 1e6
    )?;
    outln!(
        "  diversity clusters: {} (k-means: {} iterations{}), then {} of sizes {:?}",
        d.level1.k,
        d.level1.iterations,
        if d.level1.converged {
            ", converged"
        } else {
            ", stopped at the limit"
        },
        d.level2.k,
        d.top_sizes
    )?;
    say_uniform(&index);
    Ok(())
}

/// Runs `learner search`.
pub fn run_search(a: &SearchArgs) -> Result<()> {
    let lib = &a.library;
    let params = lib.params()?;
    // A query that cannot be answered is refused before a 200,000-item index is opened or
    // built; the examples are featurised (and their features checked) once the index is open.
    let mut query = Query {
        keywords: a.query.clone(),
        category: a.category.clone(),
        near: a.near.clone(),
        examples: Vec::new(),
        diverse: a.diverse,
        shuffle: None,
        limit: a.limit,
    };
    let mut check = query.clone();
    if !a.example.is_empty() {
        check.examples = vec![Vec::new()];
    }
    check.validate()?;
    let pool = pool(lib.jobs)?;
    let index = pool.install(|| -> Result<SearchIndex> {
        if a.no_cache {
            let (table, weighting, texts) = read_library(lib)?;
            let bar = build_bar(lib.quiet, table.len());
            let index = SearchIndex::build(&table, texts, &weighting, &params, None, &mut |p| {
                show(&bar, p)
            })?;
            bar.finish_and_clear();
            Ok(index)
        } else {
            open_or_build(lib, &params)
        }
    })?;
    say_uniform(&index);
    for path in &a.example {
        query.examples.push(featurise(path, &index)?);
    }
    let results = pool.install(|| index.search(&query))?;
    if a.json {
        print_json(&results)
    } else {
        print_table(&results, &query)
    }
}

fn say_uniform(index: &SearchIndex) {
    if index.is_uniform() {
        eprintln!(
            "note: no --model: uniform weights on standardised features (every feature counts \
             the same)"
        );
    }
}
