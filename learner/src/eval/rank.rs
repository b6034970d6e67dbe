//! Retrieval metrics of a distance, as in McFee & Lanckriet, "Metric Learning to Rank" (ICML
//! 2010) and the 2016 exploration paper (§6.4.1): every item queries all others, ranked by
//! increasing distance; an item is relevant when it has the query's style label.
//!
//! Per query, with `rel_i ∈ {0, 1}` the relevance at rank `i` (1-based) and `R` the number of
//! relevant items:
//! * AUC: fraction of (relevant, irrelevant) pairs with the relevant one ranked first;
//! * AP: mean over relevant items of the precision at their rank (MAP averages AP);
//! * RR: `1 / rank` of the first relevant item (MRR averages RR);
//! * Prec@k: relevant items in the top `k`, divided by `k`;
//! * NDCG@k: `Σ_{i≤k} rel_i / log₂(i + 1)` divided by its ideal value (`min(k, R)` relevant
//!   items first).
//!
//! Queries with no relevant or no irrelevant item are skipped (AUC is undefined there). Equal
//! distances are ordered by item index, so results are deterministic; real feature data has
//! almost no exact ties.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The seven numbers of the paper's ranking table, averaged over queries.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RankScores {
    /// Area under the ROC curve.
    pub auc: f64,
    /// Mean average precision.
    pub map: f64,
    /// Mean reciprocal rank.
    pub mrr: f64,
    /// Precision at 3.
    pub prec_at_3: f64,
    /// Precision at 10.
    pub prec_at_10: f64,
    /// NDCG at 3.
    pub ndcg_at_3: f64,
    /// NDCG at 10.
    pub ndcg_at_10: f64,
    /// Queries averaged (those with relevant and irrelevant items).
    pub queries: usize,
}

fn ndcg(rel: &[bool], k: usize) -> f64 {
    let r = rel.iter().filter(|&&v| v).count();
    let gain = |i: usize| 1.0 / ((i + 2) as f64).log2();
    let dcg: f64 = rel
        .iter()
        .take(k)
        .enumerate()
        .filter(|(_, v)| **v)
        .map(|(i, _)| gain(i))
        .sum();
    let ideal: f64 = (0..r.min(k)).map(gain).sum();
    dcg / ideal
}

/// Metrics of one ranking (relevance in rank order), or `None` without both kinds of item.
pub fn query_scores(rel: &[bool]) -> Option<RankScores> {
    let r = rel.iter().filter(|&&v| v).count();
    let irr = rel.len() - r;
    if r == 0 || irr == 0 {
        return None;
    }
    let (mut hits, mut ap, mut irrelevant_above, mut correct_pairs) = (0usize, 0.0, 0usize, 0usize);
    for (i, &v) in rel.iter().enumerate() {
        if v {
            hits += 1;
            ap += hits as f64 / (i + 1) as f64;
            correct_pairs += irr - irrelevant_above;
        } else {
            irrelevant_above += 1;
        }
    }
    let first = rel.iter().position(|&v| v).expect("r > 0");
    let prec = |k: usize| rel.iter().take(k).filter(|&&v| v).count() as f64 / k as f64;
    Some(RankScores {
        auc: correct_pairs as f64 / (r * irr) as f64,
        map: ap / r as f64,
        mrr: 1.0 / (first + 1) as f64,
        prec_at_3: prec(3),
        prec_at_10: prec(10),
        ndcg_at_3: ndcg(rel, 3),
        ndcg_at_10: ndcg(rel, 10),
        queries: 1,
    })
}

/// Averages per-query scores.
pub fn average(per_query: &[RankScores]) -> RankScores {
    let n = per_query.len() as f64;
    let mean = |f: fn(&RankScores) -> f64| per_query.iter().map(f).sum::<f64>() / n;
    RankScores {
        auc: mean(|q| q.auc),
        map: mean(|q| q.map),
        mrr: mean(|q| q.mrr),
        prec_at_3: mean(|q| q.prec_at_3),
        prec_at_10: mean(|q| q.prec_at_10),
        ndcg_at_3: mean(|q| q.ndcg_at_3),
        ndcg_at_10: mean(|q| q.ndcg_at_10),
        queries: per_query.len(),
    }
}

/// Ranks all items for each query under the Euclidean distance of rows of `y` (row-major,
/// `dim` columns; scale rows by `sqrt(w)` beforehand for a weighted metric). `labels[i]` is
/// item `i`'s class.
///
/// # Panics
/// If `y.len() != labels.len() * dim` or a query is out of range (internal invariants).
pub fn rank_queries(y: &[f64], dim: usize, labels: &[u32], queries: &[usize]) -> RankScores {
    let n = labels.len();
    assert_eq!(y.len(), n * dim, "row-major matrix shape");
    let per: Vec<RankScores> = queries
        .par_iter()
        .filter_map(|&q| {
            let yq = &y[q * dim..(q + 1) * dim];
            let mut order: Vec<(f64, usize)> = (0..n)
                .filter(|&j| j != q)
                .map(|j| {
                    let yj = &y[j * dim..(j + 1) * dim];
                    let d: f64 = yq.iter().zip(yj).map(|(a, b)| (a - b) * (a - b)).sum();
                    (d, j)
                })
                .collect();
            order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let rel: Vec<bool> = order.iter().map(|&(_, j)| labels[j] == labels[q]).collect();
            query_scores(&rel)
        })
        .collect();
    average(&per)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_query() {
        // Ranking: R I R I I (R relevant). AUC: pairs (R1 > 3 I's) + (R3 > 2 I's) = 5 of 6.
        // AP = (1/1 + 2/3)/2 = 5/6. RR = 1. P@3 = 2/3. P@10 = 2/10.
        // NDCG@3 = (1 + 1/log2 4) / (1 + 1/log2 3) = 1.5 / 1.6309297535714575.
        let s = query_scores(&[true, false, true, false, false]).unwrap();
        assert!((s.auc - 5.0 / 6.0).abs() < 1e-15);
        assert!((s.map - 5.0 / 6.0).abs() < 1e-15);
        assert_eq!(s.mrr, 1.0);
        assert!((s.prec_at_3 - 2.0 / 3.0).abs() < 1e-15);
        assert!((s.prec_at_10 - 0.2).abs() < 1e-15);
        assert!((s.ndcg_at_3 - 1.5 / 1.6309297535714575).abs() < 1e-12);
        assert!((s.ndcg_at_10 - 1.5 / 1.6309297535714575).abs() < 1e-12);
        // I R: RR = 1/2, AUC = 0, AP = 1/2.
        let s = query_scores(&[false, true]).unwrap();
        assert_eq!((s.auc, s.map, s.mrr), (0.0, 0.5, 0.5));
        assert!(query_scores(&[true, true]).is_none());
        assert!(query_scores(&[false]).is_none());
    }

    #[test]
    fn perfect_separation_scores_one() {
        // Two well separated clusters on a line.
        let y = [0.0, 0.1, 0.2, 10.0, 10.1, 10.2];
        let labels = [0, 0, 0, 1, 1, 1];
        let s = rank_queries(&y, 1, &labels, &[0, 1, 2, 3, 4, 5]);
        assert_eq!(s.queries, 6);
        assert_eq!((s.auc, s.map, s.mrr, s.ndcg_at_3), (1.0, 1.0, 1.0, 1.0));
        assert!((s.prec_at_3 - 2.0 / 3.0).abs() < 1e-15);
    }
}
