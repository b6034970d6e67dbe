//! Parameters of the search index and of one query, with the paper's defaults (§5.7.3).

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// How the index is built: the two-level k-means behind the diversity ordering (§5.7.3).
///
/// Changing any of these rebuilds a cached index (they are part of its fingerprint).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SearchParams {
    /// `k1`: clusters of the first level, over all items (§5.7.3, paper default 100). Capped at
    /// the number of items.
    pub k1: usize,
    /// `k2`: clusters of the second level, over the `k1` centres (§5.7.3, paper default 7): the
    /// diversity ordering interleaves these. Capped at `k1`.
    pub k2: usize,
    /// Seed of the k-means++ initialisations; the clustering is a function of the data and this
    /// seed only (not of the thread count).
    pub seed: u64,
    /// Lloyd iterations per level at most (default 100); each level also stops as soon as no
    /// item changes cluster.
    pub max_iterations: usize,
}

impl Default for SearchParams {
    fn default() -> Self {
        Self {
            k1: 100,
            k2: 7,
            seed: 0,
            max_iterations: 100,
        }
    }
}

impl SearchParams {
    /// Checks the values before any work is done.
    pub fn validate(&self) -> Result<()> {
        if self.k1 == 0 {
            return Err(Error::InvalidParameter {
                name: "k1",
                value: self.k1.to_string(),
                reason: "need at least one first-level cluster",
            });
        }
        if self.k2 == 0 {
            return Err(Error::InvalidParameter {
                name: "k2",
                value: self.k2.to_string(),
                reason: "need at least one top-level cluster",
            });
        }
        if self.k2 > self.k1 {
            return Err(Error::InvalidParameter {
                name: "k2",
                value: self.k2.to_string(),
                reason: "cannot exceed k1 (the second level clusters the first level's centres)",
            });
        }
        if self.k1 > u16::MAX as usize {
            return Err(Error::InvalidParameter {
                name: "k1",
                value: self.k1.to_string(),
                reason: "at most 65535 clusters",
            });
        }
        if self.max_iterations == 0 {
            return Err(Error::InvalidParameter {
                name: "max_iterations",
                value: "0".into(),
                reason: "need at least one iteration",
            });
        }
        Ok(())
    }
}

/// Default number of results of a query (the paper's interface showed the top 12 of each
/// search; 50 fills a results page).
pub const DEFAULT_LIMIT: usize = 50;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_papers_and_valid() {
        let p = SearchParams::default();
        assert_eq!((p.k1, p.k2), (100, 7));
        p.validate().unwrap();
    }

    #[test]
    fn bad_values_are_errors() {
        for p in [
            SearchParams {
                k1: 0,
                ..Default::default()
            },
            SearchParams {
                k2: 0,
                ..Default::default()
            },
            SearchParams {
                k1: 5,
                k2: 6,
                ..Default::default()
            },
            SearchParams {
                max_iterations: 0,
                ..Default::default()
            },
        ] {
            assert!(matches!(p.validate(), Err(Error::InvalidParameter { .. })));
        }
    }
}
