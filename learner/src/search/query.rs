//! A query, validated before any index is touched, and its answer (§5.7.3: keywords restrict,
//! the canvas orders by style, an empty canvas deals across clusters).

use serde::{Deserialize, Serialize};

use super::keywords;
use super::{ClusterId, DEFAULT_LIMIT};
use crate::{Error, Result};

/// A search. Fields combine: keywords and a category restrict the candidates, references
/// order them by style.
#[derive(Debug, Clone, PartialEq)]
pub struct Query {
    /// Words to match in names, tags and keywords (all of them, each exactly, as a prefix or
    /// with a typo). `None`: no keyword restriction.
    pub keywords: Option<String>,
    /// Only items in this category (or its subcategories).
    pub category: Option<String>,
    /// Reference items by id: the canvas, or one item for "more like this". Results are
    /// ordered by their mean distance to the references, and the references themselves are
    /// left out.
    pub near: Vec<String>,
    /// Reference drawings by their raw features (all features, in the index's column order),
    /// e.g. an uploaded example; they count like `near` items.
    pub examples: Vec<Vec<f64>>,
    /// Without references: deal the results across style clusters (§5.7.3's empty canvas)
    /// instead of ordering by keyword relevance.
    pub diverse: bool,
    /// Without references: the matches in a random order drawn from this seed instead of by
    /// relevance or across clusters — the control condition of §5.7.3's mash-up study (B,
    /// "results in random order"). The same seed and matches give the same order.
    pub shuffle: Option<u64>,
    /// Results wanted.
    pub limit: usize,
}

impl Default for Query {
    fn default() -> Self {
        Self {
            keywords: None,
            category: None,
            near: Vec::new(),
            examples: Vec::new(),
            diverse: false,
            shuffle: None,
            limit: DEFAULT_LIMIT,
        }
    }
}

impl Query {
    /// Checks what can be checked without the index: a limit of at least one, something to
    /// search by, keywords holding a searchable word, no diversity order beside references.
    /// [`SearchIndex::search`] calls it; a caller may call it first to refuse a bad query
    /// before opening or building an index.
    pub fn validate(&self) -> Result<()> {
        if self.limit == 0 {
            return Err(Error::InvalidParameter {
                name: "limit",
                value: "0".into(),
                reason: "ask for at least one result",
            });
        }
        let has_refs = !self.near.is_empty() || !self.examples.is_empty();
        if self.diverse && has_refs {
            return Err(Error::InvalidParameter {
                name: "diverse",
                value: "with reference items".into(),
                reason: "the diversity order is for an empty canvas; references order by style",
            });
        }
        if self.shuffle.is_some() && (has_refs || self.diverse) {
            return Err(Error::InvalidParameter {
                name: "shuffle",
                value: if has_refs {
                    "with reference items"
                } else {
                    "with diverse"
                }
                .into(),
                reason: "a random order replaces the style and diversity orders",
            });
        }
        if self.keywords.is_none()
            && self.category.is_none()
            && !has_refs
            && !self.diverse
            && self.shuffle.is_none()
        {
            return Err(Error::EmptyQuery(
                "give keywords, a category, reference items or an example, or ask for the \
                 diversity order",
            ));
        }
        if let Some(text) = &self.keywords
            && keywords::words(text).is_empty()
        {
            return Err(Error::EmptyQuery("the keywords hold no searchable word"));
        }
        Ok(())
    }
}

/// How results were ordered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Order {
    /// By mean distance to the references.
    Style,
    /// Dealt across style clusters.
    Diversity,
    /// By keyword score (BM25), then item order.
    Relevance,
    /// In the seeded random order of [`Query::shuffle`].
    Random,
}

/// One result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hit {
    /// The item's id.
    pub id: String,
    /// Its row in the index.
    pub row: u32,
    /// Mean distance `d` (eq. 5.5) to the references, when there are references.
    pub distance: Option<f64>,
    /// Keyword score, when the query has keywords.
    pub score: Option<f32>,
    /// Its clusters, in the diversity order.
    pub cluster: Option<ClusterId>,
}

/// The answer to a [`Query`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SearchResults {
    /// How they are ordered.
    pub order: Order,
    /// Items that matched the keywords and category (all items without either).
    pub matched: usize,
    /// The first `limit` results, in the order a user sees them.
    pub hits: Vec<Hit>,
}
