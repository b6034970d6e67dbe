//! `learner index` and `learner search`: keyword search over a library ordered by the learned
//! style metric (§5.7.3). The index is kept in a folder next to the features
//! (`features.csv.search/`) and rebuilt when the features, labels, model or clustering
//! parameters change.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use learner::features;
use learner::metric::Model;
use learner::search::cache::{self, Fingerprint, Sources};
use learner::search::texts::{read_item_texts, texts_for};
use learner::search::{
    BuildProgress, Level, Order, Query, SearchIndex, SearchParams, SearchResults, Weighting,
};
use learner::table::{FeatureTable, read_features};

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

/// The saved index when it matches its sources, otherwise a new one (saved).
fn open_or_build(lib: &LibraryArgs, params: &SearchParams) -> Result<SearchIndex> {
    let dir = lib.dir();
    if dir.join(cache::STYLE_FILE).is_file() {
        match SearchIndex::load(&dir) {
            Ok((index, stored)) => {
                let now = Fingerprint::of(lib.sources(), params, stored.as_ref())?;
                match stored.as_ref().and_then(|s| s.staleness(&now)) {
                    None if stored.is_some() => return Ok(index),
                    reason => {
                        let reason = reason.unwrap_or("it records no sources");
                        eprintln!("rebuilding the index in {}: {reason}", dir.display());
                    }
                }
            }
            Err(e) => eprintln!("rebuilding the index in {}: {e}", dir.display()),
        }
    }
    build_and_save(lib, params)
}

/// Builds into `<dir>.partial` and moves it into place, so an interrupted build never leaves
/// a half-written index that looks complete.
fn build_and_save(lib: &LibraryArgs, params: &SearchParams) -> Result<SearchIndex> {
    let dir = lib.dir();
    let fingerprint = Fingerprint::of(lib.sources(), params, None)?;
    let (table, weighting, texts) = read_library(lib)?;
    // One partial folder per process: two searches that find the index stale at the same
    // time each build their own and the last rename wins.
    let mut partial = dir.as_os_str().to_os_string();
    partial.push(format!(".partial-{}", std::process::id()));
    let partial = PathBuf::from(partial);
    if partial.exists() {
        std::fs::remove_dir_all(&partial)
            .with_context(|| format!("cannot remove {}", partial.display()))?;
    }
    let bar = build_bar(lib.quiet, table.len());
    let index = SearchIndex::build_in(&partial, &table, texts, &weighting, params, &mut |p| {
        show(&bar, p)
    })?;
    bar.finish_and_clear();
    index.save(&partial, Some(&fingerprint))?;
    if dir.exists() {
        // Another process may remove it first: only a failure that leaves it is an error.
        if let Err(e) = std::fs::remove_dir_all(&dir)
            && dir.exists()
        {
            return Err(e).with_context(|| format!("cannot replace {}", dir.display()));
        }
    }
    if let Err(e) = std::fs::rename(&partial, &dir) {
        // Another process put its index (built from the same sources) there first: use that
        // one, since this one's keyword files live in the folder about to be removed.
        if !dir.join(cache::STYLE_FILE).is_file() {
            return Err(e).with_context(|| format!("cannot move the index into {}", dir.display()));
        }
        drop(index);
        let _ = std::fs::remove_dir_all(&partial);
        return Ok(SearchIndex::load(&dir)?.0);
    }
    Ok(index)
}

/// The features, the weighting (model or uniform) and the words of each item.
pub fn read_library(
    lib: &LibraryArgs,
) -> Result<(FeatureTable, Weighting, Vec<learner::search::ItemText>)> {
    let table = read_features(&lib.features)?;
    let weighting = match &lib.model {
        Some(path) => {
            let model = Model::load(path)?;
            Weighting::from_model(&model, &table)
                .with_context(|| format!("{} against {}", path.display(), lib.features.display()))?
        }
        None => Weighting::uniform(&table),
    };
    let labels = lib.tags.as_deref().map(read_item_texts).transpose()?;
    if let Some(labels) = &labels {
        let unlisted = table
            .ids()
            .iter()
            .filter(|id| !labels.contains_key(*id))
            .count();
        if unlisted > 0 && !lib.quiet {
            eprintln!(
                "{unlisted} of {} items are not in {}: they are found by their id's words only",
                table.len(),
                lib.tags.as_deref().unwrap_or(Path::new("")).display()
            );
        }
    }
    let texts = texts_for(table.ids(), labels.as_ref());
    Ok((table, weighting, texts))
}

fn build_bar(quiet: bool, items: usize) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(items as u64).with_style(
        ProgressStyle::with_template("{spinner} indexing {msg:28} [{bar:30}] {pos}/{len}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    bar
}

fn show(bar: &ProgressBar, p: BuildProgress) {
    match p {
        BuildProgress::Projecting => bar.set_message("projecting features"),
        BuildProgress::Keywords { done, total } => {
            bar.set_message("keywords");
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
        BuildProgress::Clustering {
            level,
            iteration,
            max,
        } => {
            bar.set_message(match level {
                Level::Items => "k-means over the items",
                Level::Centres => "k-means over the centres",
            });
            bar.set_length(max as u64);
            bar.set_position(iteration as u64);
        }
    }
}

/// The features of a drawing, in the index's column order.
fn featurise(path: &Path, index: &SearchIndex) -> Result<Vec<f64>> {
    let names: Vec<&str> = features::catalogue().iter().map(|f| f.name).collect();
    if index.feature_names() != names.as_slice() {
        bail!(
            "--example needs a library of the {} features of `learner features`; {} has {} other \
             columns",
            names.len(),
            "this index",
            index.feature_names().len()
        );
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let canvas = match ext.as_str() {
        "svg" => learner::render::render_svg(&learner::input::read_limited(
            path,
            learner::render::MAX_SVG_BYTES,
        )?),
        "png" | "jpg" | "jpeg" => learner::render::render_raster(&learner::input::read_limited(
            path,
            learner::render::MAX_RASTER_BYTES,
        )?),
        _ => bail!(
            "--example {}: expected an .svg, .png, .jpg or .jpeg file",
            path.display()
        ),
    }
    .with_context(|| format!("--example {}", path.display()))?;
    let values =
        features::extract(canvas).with_context(|| format!("--example {}", path.display()))?;
    Ok(values.to_vec())
}

fn print_json(results: &SearchResults) -> Result<()> {
    let rows: Vec<serde_json::Value> = results
        .hits
        .iter()
        .map(|h| {
            // `distance` only when there are references (mean eq.-5.5 distance to them),
            // `cluster` only in the diversity order: absent rather than null.
            let mut row = serde_json::json!({ "id": h.id });
            if let Some(d) = h.distance {
                row["distance"] = serde_json::json!(d);
            }
            if let Some(s) = h.score {
                row["score"] = serde_json::json!(s);
            }
            if let Some(c) = h.cluster {
                row["cluster"] = serde_json::json!(c.top);
                row["subcluster"] = serde_json::json!(c.leaf);
            }
            row
        })
        .collect();
    let out = serde_json::json!({
        "order": results.order,
        "matched": results.matched,
        "results": rows,
    });
    outln!("{out}")
}

fn print_table(results: &SearchResults, query: &Query) -> Result<()> {
    let refs = query.near.len() + query.examples.len();
    let order = match results.order {
        Order::Style if refs == 1 => "by style distance to the reference".to_string(),
        Order::Style => format!("by mean style distance to the {refs} references"),
        Order::Diversity => "dealt across style clusters".to_string(),
        Order::Relevance => "by keyword relevance".to_string(),
    };
    eprintln!(
        "{} matched, first {} {order}",
        results.matched,
        results.hits.len()
    );
    for (rank, h) in results.hits.iter().enumerate() {
        let mut line = format!("{:>4}  ", rank + 1);
        if let Some(d) = h.distance {
            line.push_str(&format!("{d:>10.4}  "));
        }
        if let Some(c) = h.cluster {
            line.push_str(&format!("{:>2}/{:<3}  ", c.top, c.leaf));
        }
        line.push_str(&h.id);
        outln!("{line}")?;
    }
    Ok(())
}
