//! The representative styles of a library (§6.5.1) as a stored job: the request is checked
//! before anything is stored (unknown labels, κ/τ that prune every branch, a model of another
//! library are 4xx answers), then `learner::explore::taxonomy` runs on the rows of the search
//! index's style space of the chosen items.

use std::sync::Arc;

use learner::explore::taxonomy::Stage;
use learner::explore::{StyleLibrary, TaxonomyParams, taxonomy};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::jobs::{self, JobKey, Kind, Progress};
use super::{LabelCount, MAX_LABELS, UNLABELLED, label_counts, resolve, text};
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::cache::{Built, Key};
use crate::store::ids::{ExplorationId, ItemId};

/// A taxonomy request.
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TaxonomyRequest {
    /// The library (its name).
    #[schema(max_length = 200)]
    pub library: String,
    /// `uniform`, a model id, or omitted: the newest trained model over the library.
    pub model: Option<String>,
    /// The semantic labels (style labels) whose items are explored; every branch kept must
    /// hold more than τ items of each. Empty: every item, κ alone prunes.
    #[serde(default)]
    pub labels: Vec<String>,
    /// κ: a kept branch holds more than κ items (default 20).
    pub kappa: Option<usize>,
    /// τ: a kept branch holds more than τ items of every label (default 2).
    pub tau: Option<usize>,
}

/// The stored parameters (canonical: labels sorted, each once).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct TaxonomyJobParams {
    /// Required labels.
    pub labels: Vec<String>,
    /// κ.
    pub kappa: usize,
    /// τ.
    pub tau: usize,
}

/// One representative style.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Representative {
    /// The representative item (the member nearest the branch's mean).
    pub id: ItemId,
    /// Its name.
    pub name: String,
    /// Items in the branch.
    pub count: usize,
    /// Items of each label in the branch.
    pub labels: Vec<LabelCount>,
    /// The branch's items.
    pub members: Vec<ItemId>,
}

/// A finished taxonomy.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct TaxonomyResult {
    /// Items clustered.
    pub items: usize,
    /// Items in no kept branch.
    pub unassigned: usize,
    /// k-means centres Ward ran on, for a library too large to cluster exactly.
    pub kmeans_centres: Option<usize>,
    /// The representative styles, the largest first.
    pub representatives: Vec<Representative>,
}

/// Checks `req`, then returns the stored job for it: the finished or running one with the same
/// parameters, or a new one started here (`true`).
pub async fn start(state: &AppState, req: &TaxonomyRequest) -> Result<(ExplorationId, bool)> {
    let (library, model) = resolve(&state.db, &req.library, req.model.as_deref()).await?;
    if req.labels.len() > MAX_LABELS {
        return Err(AppError::BadRequest(format!(
            "labels: at most {MAX_LABELS}"
        )));
    }
    let mut labels = req
        .labels
        .iter()
        .map(|l| text("labels", l))
        .collect::<Result<Vec<_>>>()?;
    labels.retain(|l| !l.is_empty());
    labels.sort();
    labels.dedup();
    let defaults = TaxonomyParams::default();
    let params = TaxonomyParams {
        kappa: req.kappa.unwrap_or(defaults.kappa),
        tau: req.tau.unwrap_or(defaults.tau),
        ..defaults
    };
    let counts = label_counts(&state.db, library).await?;
    check(&counts, &labels, &params)?;
    let total: usize = counts.iter().map(|c| c.count).sum();
    let key = JobKey {
        library,
        model,
        kind: Kind::Taxonomy,
        params: serde_json::to_string(&TaxonomyJobParams {
            labels: labels.clone(),
            kappa: params.kappa,
            tau: params.tau,
        })
        .map_err(AppError::internal)?,
        library_items: total as i64,
    };
    let (id, new) = jobs::find_or_create(&state.db, &key).await?;
    if new {
        let cache = state.search.clone();
        let db = state.db.clone();
        jobs::spawn(
            state.clone(),
            id,
            async move { cache.get(&db, Key { library, model }).await },
            move |built: Arc<Built>, progress: &Progress| {
                let result = compute(&built, &labels, &params, progress)?;
                serde_json::to_value(result).map_err(AppError::internal)
            },
        );
    }
    Ok((id, new))
}

/// The checks `learner::explore::taxonomy` would make after clustering, made first from the
/// label counts so that a bad request stores nothing: every label exists, and the root branch
/// (the whole selection) passes κ and τ — when it does not, no branch does (a branch holds at
/// most its parent's items), which is the learner's `PrunedEverything`.
pub fn check(counts: &[LabelCount], labels: &[String], params: &TaxonomyParams) -> Result<()> {
    let items = check_labels(counts, labels)?;
    let count_of = |l: &str| counts.iter().find(|c| c.label == l).map(|c| c.count);
    let root_kept =
        items > params.kappa && labels.iter().all(|l| count_of(l).unwrap_or(0) > params.tau);
    if !root_kept {
        let per_label = labels
            .iter()
            .map(|l| format!(", {} of them `{l}`", count_of(l).unwrap_or(0)))
            .collect();
        let e = learner::Error::PrunedEverything {
            kappa: params.kappa,
            tau: params.tau,
            items,
            per_label,
        };
        return Err(AppError::BadRequest(e.to_string()));
    }
    Ok(())
}

/// Checks that every label of `labels` is one of the library's (`counts`) and that they hold
/// at least 2 items; returns how many (every item when `labels` is empty).
pub fn check_labels(counts: &[LabelCount], labels: &[String]) -> Result<usize> {
    let count_of = |l: &str| counts.iter().find(|c| c.label == l).map(|c| c.count);
    let missing: Vec<&str> = labels
        .iter()
        .filter(|l| count_of(l).is_none())
        .map(String::as_str)
        .collect();
    if !missing.is_empty() {
        let known: Vec<String> = counts
            .iter()
            .take(30)
            .map(|c| format!("{} ({})", c.label, c.count))
            .collect();
        return Err(AppError::BadRequest(format!(
            "labels: {} not in this library; its labels are {}",
            missing.join(", "),
            known.join(", ")
        )));
    }
    let items: usize = if labels.is_empty() {
        counts.iter().map(|c| c.count).sum()
    } else {
        labels.iter().filter_map(|l| count_of(l)).sum()
    };
    if items < 2 {
        return Err(AppError::BadRequest(format!(
            "an exploration needs at least 2 items; the labels chosen have {items}"
        )));
    }
    Ok(items)
}

/// The style library of the items of `labels` (every item when empty) in `built`'s style space,
/// with the index row of each of its items.
pub fn style_library(built: &Built, labels: &[String]) -> Result<(StyleLibrary, Vec<usize>)> {
    let label_of = |row: usize| built.styles[row].as_deref().unwrap_or(UNLABELLED);
    let names: Vec<String> = if labels.is_empty() {
        let mut all: Vec<String> = (0..built.ids.len())
            .map(|r| label_of(r).to_owned())
            .collect();
        all.sort();
        all.dedup();
        all
    } else {
        labels.to_vec()
    };
    let matrix = built.index.matrix();
    let dim = matrix.stride();
    let (mut ids, mut points, mut item_labels, mut rows) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for row in 0..built.ids.len() {
        if let Some(l) = names.iter().position(|n| n == label_of(row)) {
            ids.push(built.index.ids()[row].clone());
            points.extend_from_slice(matrix.row(row));
            item_labels.push(l as u32);
            rows.push(row);
        }
    }
    let library = StyleLibrary::new(ids, points, dim, item_labels, names)
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    Ok((library, rows))
}

/// Runs the taxonomy (in a blocking thread).
pub fn compute(
    built: &Built,
    labels: &[String],
    params: &TaxonomyParams,
    progress: &Progress,
) -> Result<TaxonomyResult> {
    let (library, rows) = style_library(built, labels)?;
    let required: Vec<u32> = if labels.is_empty() {
        Vec::new()
    } else {
        (0..labels.len() as u32).collect()
    };
    let t = taxonomy(&library, &required, params, &mut |stage, done, total| {
        let name = match stage {
            Stage::KMeans => "k-means reduction",
            Stage::Ward => "Ward clustering",
            Stage::Representatives => "representatives",
        };
        progress.set(name, done, total);
    })
    .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let item = |i: usize| built.ids[rows[i]];
    let representatives = t
        .representatives
        .iter()
        .map(|&r| {
            let node = &t.nodes[r];
            Representative {
                id: item(node.representative),
                name: library.ids()[node.representative].clone(),
                count: node.count,
                labels: node
                    .label_counts
                    .iter()
                    .map(|&(l, count)| LabelCount {
                        label: library.label_names()[l as usize].clone(),
                        count,
                    })
                    .collect(),
                members: node.members.iter().map(|&i| item(i)).collect(),
            }
        })
        .collect();
    Ok(TaxonomyResult {
        items: t.items,
        unassigned: t.unassigned,
        kmeans_centres: t.reduction.as_ref().map(|r| r.centres),
        representatives,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts() -> Vec<LabelCount> {
        [("dog", 10), ("tree", 3), ("unlabelled", 1)]
            .iter()
            .map(|&(label, count)| LabelCount {
                label: label.into(),
                count,
            })
            .collect()
    }

    fn params(kappa: usize, tau: usize) -> TaxonomyParams {
        TaxonomyParams {
            kappa,
            tau,
            ..TaxonomyParams::default()
        }
    }

    #[test]
    fn the_root_decides_whether_anything_survives_pruning() {
        let labels = vec!["dog".to_owned(), "tree".to_owned()];
        assert!(check(&counts(), &labels, &params(12, 2)).is_ok());
        // 13 items: κ = 13 keeps no branch.
        let e = check(&counts(), &labels, &params(13, 2)).expect_err("κ");
        assert!(e.to_string().contains("prune every branch"), "{e}");
        // 3 `tree` items: τ = 3 keeps no branch; the message gives the counts.
        let e = check(&counts(), &labels, &params(0, 3)).expect_err("τ");
        assert!(e.to_string().contains("3 of them `tree`"), "{e}");
        // No labels: κ alone, over every item.
        assert!(check(&counts(), &[], &params(13, 99)).is_ok());
    }

    #[test]
    fn unknown_labels_are_named_with_the_known_ones() {
        let e = check_labels(&counts(), &["cat".to_owned()]).expect_err("cat");
        let text = e.to_string();
        assert!(
            text.contains("cat not in this library") && text.contains("dog (10)"),
            "{text}"
        );
        let e = check_labels(&counts(), &["unlabelled".to_owned()]).expect_err("one item");
        assert!(e.to_string().contains("at least 2"), "{e}");
    }
}
