//! The index of `learner index` and `learner search`: the saved one while its sources are
//! unchanged, else a new one built (with a progress bar) and saved.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use learner::metric::Model;
use learner::search::cache::{self, Fingerprint};
use learner::search::texts::{read_item_texts, texts_for};
use learner::search::{BuildProgress, Level, SearchIndex, SearchParams, Weighting};
use learner::table::{FeatureTable, read_features};

use super::LibraryArgs;

/// The saved index when it matches its sources, otherwise a new one (saved).
pub(super) fn open_or_build(lib: &LibraryArgs, params: &SearchParams) -> Result<SearchIndex> {
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
pub(super) fn build_and_save(lib: &LibraryArgs, params: &SearchParams) -> Result<SearchIndex> {
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

pub(super) fn build_bar(quiet: bool, items: usize) -> ProgressBar {
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

pub(super) fn show(bar: &ProgressBar, p: BuildProgress) {
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
