//! Style search over a clip-art library, as in the mash-up interface of Garces et al. 2014
//! (§5.7.3): keyword search, then the hits ordered by style under the learned metric (§5.5).
//!
//! * [`index`]: items as rows of `√w ⊙ x̂` (`f32`, zero-weight features dropped), so the
//!   learned distance is plain L2, and an exact scan for the nearest items (recall 1.0; no
//!   approximate index is needed at 200,000 items).
//! * [`keywords`]: tantivy over names, tags and keywords: BM25, prefix and fuzzy words, a
//!   category facet.
//! * [`diversity`] (with `kmeans`): the two-level k-means and the interleaved order shown
//!   when the canvas is empty.
//! * [`texts`]: the words of each item from a labels CSV.
//! * [`cache`]: the index saved in a folder and reused while its sources are unchanged.
//! * [`params`]: [`SearchParams`] with the paper's defaults.
//!
//! A query picks its order from what it has: reference items or example drawings (the items
//! on the canvas, "more like this", an upload) order by mean distance `d` to them; otherwise
//! [`Query::diverse`] deals across style clusters; otherwise keyword relevance (BM25).
//!
//! ```
//! use learner::search::{Query, SearchIndex, SearchParams, Weighting, ItemText};
//! use learner::table::FeatureTable;
//!
//! let table = FeatureTable::new(
//!     vec!["ink".into(), "colour".into()],
//!     vec!["a/dog.svg".into(), "b/dog.svg".into(), "b/cat.svg".into()],
//!     vec![0.0, 1.0, 5.0, 0.0, 5.0, 0.2],
//! )?;
//! let texts: Vec<ItemText> = table.ids().iter().map(|id| ItemText::from_id(id)).collect();
//! let weighting = Weighting::uniform(&table);
//! let index = SearchIndex::build(&table, texts, &weighting, &SearchParams::default(), None, &mut |_| {})?;
//! // The dogs, most like b/cat.svg first.
//! let query = Query { keywords: Some("dog".into()), near: vec!["b/cat.svg".into()], ..Query::default() };
//! let hits = index.search(&query)?;
//! assert_eq!(hits.hits[0].id, "b/dog.svg");
//! # Ok::<(), learner::Error>(())
//! ```

pub mod cache;
pub mod diversity;
pub mod index;
pub mod keywords;
pub(crate) mod kmeans;
pub mod params;
mod query;
#[cfg(test)]
mod tests;
pub mod texts;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use serde::{Deserialize, Serialize};

pub use diversity::{ClusterId, Diversity, DiversityInfo, Level};
pub use index::{StyleMatrix, Weighting};
pub use keywords::{ItemText, KeywordIndex};
pub use kmeans::KMeansInfo;
pub use params::{DEFAULT_LIMIT, SearchParams};
pub use query::{Hit, Order, Query, SearchResults};

use crate::table::FeatureTable;
use crate::{Error, Result};

/// A search index: the style matrix, the clustering and the keyword index of one library.
#[derive(Debug)]
pub struct SearchIndex {
    ids: Vec<String>,
    rows: HashMap<String, u32>,
    feature_names: Vec<String>,
    uniform: bool,
    matrix: StyleMatrix,
    diversity: Diversity,
    keywords: KeywordIndex,
    keywords_dir: Option<PathBuf>,
    build: BuildInfo,
}

/// How an index was built.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BuildInfo {
    /// Items.
    pub items: usize,
    /// Features with a positive weight (the dimensions stored).
    pub active_dims: usize,
    /// True when built without a model (uniform weights).
    pub uniform: bool,
    /// The build's parameters.
    pub params: SearchParams,
    /// Seconds spent projecting the features.
    pub projection_seconds: f64,
    /// Seconds spent on the keyword index.
    pub keywords_seconds: f64,
    /// Seconds spent clustering.
    pub clustering_seconds: f64,
}

/// Where a build is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildProgress {
    /// Projecting the features (`√w ⊙ x̂`).
    Projecting,
    /// Indexing words: items done of all.
    Keywords {
        /// Items indexed.
        done: usize,
        /// All items.
        total: usize,
    },
    /// k-means iteration `iteration` (of at most `max`) at a level.
    Clustering {
        /// Which level.
        level: Level,
        /// The iteration just finished.
        iteration: usize,
        /// The iteration limit.
        max: usize,
    },
}

impl SearchIndex {
    /// Indexes a library: `table`'s rows with `texts[i]` the words of row `i`. The keyword
    /// index lives in `keywords_dir` (an empty or missing folder) or in memory.
    pub fn build(
        table: &FeatureTable,
        texts: Vec<ItemText>,
        weighting: &Weighting,
        params: &SearchParams,
        keywords_dir: Option<&Path>,
        progress: &mut dyn FnMut(BuildProgress),
    ) -> Result<Self> {
        params.validate()?;
        if table.is_empty() {
            return Err(Error::EmptyLibrary);
        }
        if texts.len() != table.len() {
            return Err(Error::InvalidParameter {
                name: "texts",
                value: texts.len().to_string(),
                reason: "need one text per item of the table",
            });
        }
        progress(BuildProgress::Projecting);
        let t = Instant::now();
        let matrix = StyleMatrix::build(table, weighting)?;
        let projection_seconds = t.elapsed().as_secs_f64();

        let t = Instant::now();
        if let Some(dir) = keywords_dir {
            std::fs::create_dir_all(dir).map_err(|source| Error::CannotWrite {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        let total = texts.len();
        let keywords = KeywordIndex::build(&texts, keywords_dir, &mut |done| {
            progress(BuildProgress::Keywords { done, total })
        })?;
        drop(texts);
        let keywords_seconds = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let max = params.max_iterations;
        let diversity = Diversity::build(&matrix, params, &mut |level, iteration| {
            progress(BuildProgress::Clustering {
                level,
                iteration,
                max,
            })
        });
        let clustering_seconds = t.elapsed().as_secs_f64();

        let ids = table.ids().to_vec();
        Ok(Self {
            rows: row_map(&ids),
            build: BuildInfo {
                items: ids.len(),
                active_dims: matrix.active_dims(),
                uniform: weighting.uniform,
                params: *params,
                projection_seconds,
                keywords_seconds,
                clustering_seconds,
            },
            ids,
            feature_names: weighting.feature_names.clone(),
            uniform: weighting.uniform,
            matrix,
            diversity,
            keywords,
            keywords_dir: keywords_dir.map(Path::to_path_buf),
        })
    }

    /// Item ids, by row.
    pub fn ids(&self) -> &[String] {
        &self.ids
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// True without items (never, for a built index).
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The row of an id.
    pub fn row_of(&self, id: &str) -> Option<u32> {
        self.rows.get(id).copied()
    }

    /// Feature names a raw vector must follow.
    pub fn feature_names(&self) -> &[String] {
        &self.feature_names
    }

    /// True when built without a model.
    pub fn is_uniform(&self) -> bool {
        self.uniform
    }

    /// The style matrix.
    pub fn matrix(&self) -> &StyleMatrix {
        &self.matrix
    }

    /// The clustering.
    pub fn diversity(&self) -> &Diversity {
        &self.diversity
    }

    /// The keyword index.
    pub fn keywords(&self) -> &KeywordIndex {
        &self.keywords
    }

    /// How it was built.
    pub fn build_info(&self) -> &BuildInfo {
        &self.build
    }

    /// Heap bytes of the style matrix, the clustering and the ids (the keyword index is
    /// memory-mapped or, in memory, small beside them; measure the process for the whole).
    pub fn memory_bytes(&self) -> usize {
        let ids: usize = self.ids.iter().map(|s| s.capacity() + 24).sum();
        // The id → row map holds a second copy of each id plus a slot.
        self.matrix.memory_bytes() + 2 * ids + self.rows.capacity() * 8 + self.len() * 6
    }

    /// Answers a query.
    pub fn search(&self, query: &Query) -> Result<SearchResults> {
        query.validate()?;
        let has_refs = !query.near.is_empty() || !query.examples.is_empty();
        let mut exclude = Vec::with_capacity(query.near.len());
        let mut references = Vec::with_capacity(query.near.len() + query.examples.len());
        for id in &query.near {
            let row = self.row_of(id).ok_or_else(|| Error::UnknownItem {
                id: id.clone(),
                items: self.len(),
            })?;
            exclude.push(row);
            references.push(self.matrix.row(row as usize).to_vec());
        }
        for raw in &query.examples {
            references.push(self.matrix.project(raw)?);
        }
        let filtered = query.keywords.is_some() || query.category.is_some();
        let hits = if filtered {
            Some(
                self.keywords
                    .search(query.keywords.as_deref(), query.category.as_deref())?,
            )
        } else {
            None
        };
        let matched = hits.as_ref().map_or(self.len(), Vec::len);
        // Hits come in row order: a score is found by bisection.
        let scored = query.keywords.as_ref().and(hits.as_deref());
        let score_of = |row: u32| {
            scored.and_then(|h| h.binary_search_by_key(&row, |x| x.0).ok().map(|i| h[i].1))
        };

        let (order, hits): (Order, Vec<Hit>) = if has_refs {
            let candidates: Option<Vec<u32>> =
                hits.as_ref().map(|h| h.iter().map(|x| x.0).collect());
            let near =
                self.matrix
                    .nearest(&references, candidates.as_deref(), &exclude, query.limit);
            let hits = near
                .into_iter()
                .map(|(row, d)| self.hit(row, Some(d), score_of(row), None))
                .collect();
            (Order::Style, hits)
        } else if query.diverse {
            let all: Vec<(u32, f32)> = match &hits {
                Some(h) if scored.is_some() => h.clone(),
                Some(h) => h.iter().map(|&(r, _)| (r, 0.0)).collect(),
                None => (0..self.len() as u32).map(|r| (r, 0.0)).collect(),
            };
            let dealt = self.diversity.interleave(&all, query.limit);
            let hits = dealt
                .into_iter()
                .map(|(row, c)| self.hit(row, None, score_of(row), Some(c)))
                .collect();
            (Order::Diversity, hits)
        } else if let Some(seed) = query.shuffle {
            // Rows in row order (keyword hits come sorted by row), then a partial
            // Fisher–Yates of the first `limit`: the order depends on the seed and the
            // matches only.
            let mut rows: Vec<u32> = match &hits {
                Some(h) => h.iter().map(|x| x.0).collect(),
                None => (0..self.len() as u32).collect(),
            };
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let take = query.limit.min(rows.len());
            let (first, _) = rows.partial_shuffle(&mut rng, take);
            let hits = first
                .iter()
                .map(|&row| self.hit(row, None, score_of(row), None))
                .collect();
            (Order::Random, hits)
        } else {
            let mut h = hits.clone().unwrap_or_default();
            let by_relevance =
                |a: &(u32, f32), b: &(u32, f32)| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0));
            if h.len() > query.limit {
                h.select_nth_unstable_by(query.limit, by_relevance);
                h.truncate(query.limit);
            }
            h.sort_unstable_by(by_relevance);
            let hits = h
                .into_iter()
                .map(|(row, _)| self.hit(row, None, score_of(row), None))
                .collect();
            (Order::Relevance, hits)
        };
        Ok(SearchResults {
            order,
            matched,
            hits,
        })
    }

    fn hit(
        &self,
        row: u32,
        distance: Option<f64>,
        score: Option<f32>,
        cluster: Option<ClusterId>,
    ) -> Hit {
        Hit {
            id: self.ids[row as usize].clone(),
            row,
            distance,
            score,
            cluster,
        }
    }
}

fn row_map(ids: &[String]) -> HashMap<String, u32> {
    ids.iter()
        .enumerate()
        .map(|(i, id)| (id.clone(), i as u32))
        .collect()
}
