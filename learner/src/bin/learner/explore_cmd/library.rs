//! The arguments every exploration command shares, and the library they load: features, the
//! metric, each item's semantic label and the labels to keep.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use learner::explore::{StyleLibrary, read_item_labels};
use learner::metric::Model;
use learner::search::{StyleMatrix, Weighting};
use learner::table::read_features;

#[derive(Debug, Args)]
pub struct LibraryArgs {
    /// Features CSV, as written by `learner features`.
    #[arg(long)]
    pub features: PathBuf,
    /// The metric (`model.json` of `learner train`). Without it every feature weighs the same
    /// after standardising over the library.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// The semantic label of each item: a CSV with `id` (or `file`) and `label` columns (or
    /// `category`, `concept`, `group`; see --label-column). Items it does not list are
    /// "unlabelled".
    #[arg(long)]
    pub item_labels: Option<PathBuf>,
    /// The column of --item-labels that holds the label.
    #[arg(long, requires = "item_labels")]
    pub label_column: Option<String>,
    /// Keep only the items of these labels (comma-separated), e.g. `--labels dog,tree,sky`.
    #[arg(long, value_delimiter = ',', requires = "item_labels")]
    pub labels: Vec<String>,
    /// The items the features were computed from (folders, files or Iconify sets, as given to
    /// `learner features`), for the thumbnails of the contact sheet.
    #[arg(long = "items")]
    pub items: Vec<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, short)]
    pub jobs: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl LibraryArgs {
    /// Sets the thread pool, then reads and projects the library.
    pub fn load(&self) -> Result<StyleLibrary> {
        if let Some(jobs) = self.jobs {
            if jobs == 0 {
                bail!("--jobs must be at least 1");
            }
            // Ignored when a pool already exists (a second command in one process).
            let _ = rayon::ThreadPoolBuilder::new()
                .num_threads(jobs)
                .build_global();
        }
        let table = read_features(&self.features)?;
        let weighting = match &self.model {
            Some(path) => {
                let model = Model::load(path)?;
                Weighting::from_model(&model, &table).with_context(|| {
                    format!("{} against {}", path.display(), self.features.display())
                })?
            }
            None => Weighting::uniform(&table),
        };
        let matrix = StyleMatrix::build(&table, &weighting)?;
        let item_labels = self
            .item_labels
            .as_deref()
            .map(|p| read_item_labels(p, self.label_column.as_deref()))
            .transpose()?;
        if let (Some(labels), Some(path)) = (&item_labels, &self.item_labels) {
            let unlisted = table
                .ids()
                .iter()
                .filter(|id| !labels.contains_key(*id))
                .count();
            if unlisted == table.len() {
                bail!(
                    "none of the {} items of {} is listed in {}: do the ids match (`{}`)?",
                    table.len(),
                    self.features.display(),
                    path.display(),
                    table.ids()[0]
                );
            }
            if unlisted > 0 && !self.quiet {
                eprintln!(
                    "{unlisted} of {} items are not in {}: they are labelled `{}`",
                    table.len(),
                    path.display(),
                    learner::explore::library::UNLABELLED
                );
            }
        }
        let keep = (!self.labels.is_empty()).then_some(self.labels.as_slice());
        Ok(StyleLibrary::from_matrix(
            &table,
            &matrix,
            item_labels.as_ref(),
            keep,
        )?)
    }

    /// The label indices a selection must hold: every kept label when --labels was given.
    pub fn required(&self, library: &StyleLibrary) -> Vec<u32> {
        if self.labels.is_empty() {
            Vec::new()
        } else {
            (0..library.label_names().len() as u32).collect()
        }
    }
}

/// `RESULT.png` beside `RESULT.json`.
pub fn sheet_path(out: &Path) -> PathBuf {
    out.with_extension("png")
}
