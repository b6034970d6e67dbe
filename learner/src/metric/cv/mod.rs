//! Choosing λ of eq. 5.8 by k-fold cross-validation over a log grid (§5.6: "λ chosen by
//! cross-validation").
//!
//! * Folds are **grouped**: by worker when the triplets name workers (a worker's answers share
//!   their biases, so splitting them across folds would leak), otherwise by tuple (several
//!   answers to one question must not sit on both sides). Groups are shuffled with the seed and
//!   dealt greedily to the fold with the fewest triplets so far, which balances fold sizes.
//! * The default grid is relative to the training-set size, `λ = n_train · r` for eight `r`
//!   log-spaced in `[10⁻⁵, 10⁻¹]`: eq. 5.8 sums over triplets, so a fixed λ would mean less and
//!   less as data grows. An explicit grid is used as given.
//! * Each fold walks the grid in increasing λ, warm-starting from the previous solution (the
//!   first from the uniform metric); held-out scores use the weights *after* the 0.02 zeroing
//!   that the final model applies. The chosen λ minimises the mean held-out log-loss (the log of
//!   eq. 5.9's perplexity), which is smoother than accuracy, under the **one-standard-error
//!   rule** (Hastie, Tibshirani & Friedman, ESL §7.10) guarded against the uniform metric
//!   ([`choice`]): near the optimum the loss curve is flat, and the plain minimum keeps spurious
//!   small weights (on the simulated crowd: 8 non-zero instead of the true 6 at equal held-out
//!   loss to four digits); the paper wants a sparse, interpretable metric, but not one that is
//!   no better than uniform weights.
//! * The grid **grows** when it does not bracket the choice: while the minimum sits at the
//!   lower end, or the choice or the minimum at the upper end, one more λ a decade beyond that
//!   end is fitted in every fold (warm-started from the fold's solution at that end), at most
//!   [`CvParams::max_extensions`] times per end. A choice still at an end is reported
//!   ([`CvReport::at_edge`], [`CvWarning::AtEdge`]).
//! * The uniform metric `w = c·1`, `c` fitted on each fold's training part, is scored on the
//!   same held-out answers ([`CvReport::uniform`]), and the out-of-fold predictions at the
//!   chosen λ give the held-out agreement of both metrics with bootstrap intervals
//!   ([`agreement`]).

pub mod agreement;
pub mod choice;
mod search;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::objective::{FusedObjective, TripletObjective};
use super::solver::{LbfgsParams, SolverKind};
use crate::triplets::Triplet;
use crate::{Error, Result};
pub use agreement::HeldOutAgreement;
pub use choice::{CvWarning, Edge};
pub use search::cross_validate;

/// One λ of the search.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CvRow {
    /// The λ.
    pub lambda: f64,
    /// Mean held-out `−log P(q)` per triplet, averaged over folds.
    pub log_loss: f64,
    /// Held-out perplexity `exp(log_loss)` (eq. 5.9).
    pub perplexity: f64,
    /// Held-out accuracy, averaged over folds.
    pub accuracy: f64,
    /// Standard error of `accuracy` over folds (0 in reports written before it existed).
    #[serde(default)]
    pub accuracy_std_error: f64,
    /// Non-zero weights after zeroing, averaged over folds.
    pub nonzero: f64,
    /// Standard error of `log_loss` over folds (`sd / √k`).
    pub std_error: f64,
    /// Per-fold held-out log-loss.
    pub fold_log_loss: Vec<f64>,
    /// Per-fold held-out accuracy.
    #[serde(default)]
    pub fold_accuracy: Vec<f64>,
}

/// The uniform metric `w = c·1` on the same held-out answers (`c` fitted on each fold's
/// training part by maximum likelihood).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    /// Mean held-out `−log P(q)` per triplet, averaged over folds.
    pub log_loss: f64,
    /// `exp(log_loss)`.
    pub perplexity: f64,
    /// Held-out accuracy, averaged over folds.
    pub accuracy: f64,
    /// Standard error of `accuracy` over folds.
    pub accuracy_std_error: f64,
    /// Standard error of `log_loss` over folds.
    pub std_error: f64,
    /// Per-fold held-out log-loss.
    pub fold_log_loss: Vec<f64>,
    /// Per-fold held-out accuracy.
    pub fold_accuracy: Vec<f64>,
}

/// The whole search. Fields added after the first release default when reading older JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CvReport {
    /// Number of folds.
    pub folds: usize,
    /// `worker` or `tuple`.
    pub grouped_by: String,
    /// One row per λ, increasing (the grid with its extensions).
    pub rows: Vec<CvRow>,
    /// The λ chosen.
    pub chosen: f64,
    /// The λ of least mean held-out loss.
    #[serde(default)]
    pub minimum: Option<f64>,
    /// The plain one-standard-error rule's λ (before the guard against the uniform metric).
    #[serde(default)]
    pub one_se: Option<f64>,
    /// λ values added beyond the given grid's `[lower, upper]` ends, by a decade each.
    #[serde(default)]
    pub extensions: [usize; 2],
    /// The chosen λ or the minimum is an end of the searched grid: the optimum may lie beyond.
    #[serde(default)]
    pub at_edge: bool,
    /// What a user should know about the choice.
    #[serde(default)]
    pub warnings: Vec<CvWarning>,
    /// The uniform metric on the same held-out answers.
    #[serde(default)]
    pub uniform: Option<Baseline>,
    /// Out-of-fold agreement of the learned (at the chosen λ) and the uniform metric.
    #[serde(default)]
    pub agreement: Option<HeldOutAgreement>,
    /// Passes over the training data in all fits (fused evaluations plus curvature passes).
    #[serde(default)]
    pub evaluations: u64,
}

impl CvReport {
    /// The row of the chosen λ.
    pub fn chosen_row(&self) -> Option<&CvRow> {
        self.rows.iter().find(|r| r.lambda == self.chosen)
    }
}

/// The default grid for `n` training triplets: `n · r`, `r` log-spaced in `[1e-5, 1e-1]`.
pub fn default_grid(n: usize, count: usize) -> Vec<f64> {
    let (lo, hi) = (1e-5f64.ln(), 1e-1f64.ln());
    (0..count)
        .map(|i| {
            let t = if count == 1 {
                0.5
            } else {
                i as f64 / (count - 1) as f64
            };
            n as f64 * (lo + t * (hi - lo)).exp()
        })
        .collect()
}

/// The fold group of a triplet: its worker, or its tuple.
pub(crate) fn group_of(t: &Triplet, by_worker: bool) -> usize {
    if by_worker {
        t.worker.map_or(0, |w| w as usize)
    } else {
        t.tuple as usize
    }
}

/// Fold index (0..k) of every triplet, grouped by worker when `by_worker`, else by tuple.
pub fn assign_folds(
    triplets: &[Triplet],
    k: usize,
    by_worker: bool,
    seed: u64,
) -> Result<Vec<usize>> {
    if k < 2 {
        return Err(Error::InvalidParameter {
            name: "folds",
            value: k.to_string(),
            reason: "need at least 2 folds",
        });
    }
    let group = |t: &Triplet| group_of(t, by_worker);
    let groups = triplets.iter().map(group).max().map_or(0, |m| m + 1);
    let mut sizes = vec![0usize; groups];
    for t in triplets {
        sizes[group(t)] += 1;
    }
    let mut order: Vec<usize> = (0..groups).filter(|&g| sizes[g] > 0).collect();
    if order.len() < k {
        return Err(Error::NotEnoughData {
            what: if by_worker {
                "cross-validation folds (workers)"
            } else {
                "cross-validation folds (tuples)"
            },
            needed: k,
            got: order.len(),
        });
    }
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let mut fold_of_group = vec![0usize; groups];
    let mut load = vec![0usize; k];
    for g in order {
        let f = (0..k).min_by_key(|&f| (load[f], f)).expect("k ≥ 2");
        fold_of_group[g] = f;
        load[f] += sizes[g];
    }
    Ok(triplets.iter().map(|t| fold_of_group[group(t)]).collect())
}

/// Zeroes weights below `threshold` (the paper's post-processing, §5.6).
pub fn zero_small(w: &[f64], threshold: f64) -> Vec<f64> {
    w.iter()
        .map(|&v| if v < threshold { 0.0 } else { v })
        .collect()
}

/// Held-out mean log-loss and accuracy of weights `w` (exact ties count half).
pub fn held_out_scores(
    x: &[f64],
    dim: usize,
    test: &[Triplet],
    w: &[f64],
    smoothing: f64,
) -> (f64, f64) {
    let obj = TripletObjective::new(x, dim, test, 0.0, smoothing);
    let margins = obj.margins(w);
    let mut g = vec![0.0; dim];
    let loss = obj.eval(w, &mut g) / test.len() as f64;
    let correct: f64 = margins
        .iter()
        .zip(test)
        .map(|(&m, t)| {
            let z = if t.q { m } else { -m };
            if z > 0.0 {
                1.0
            } else if z == 0.0 {
                0.5
            } else {
                0.0
            }
        })
        .sum();
    (loss, correct / test.len() as f64)
}

/// Credit of each answer under margins `m` (`P(q = 1) = σ(m)`): 1 when predicted, ½ for an
/// exact tie, 0 otherwise.
pub(crate) fn credits(margins: &[f64], test: &[Triplet]) -> Vec<f64> {
    margins
        .iter()
        .zip(test)
        .map(|(&m, t)| {
            let z = if t.q { m } else { -m };
            if z > 0.0 {
                1.0
            } else if z == 0.0 {
                0.5
            } else {
                0.0
            }
        })
        .collect()
}

/// What the search needs besides the data.
#[derive(Debug, Clone, PartialEq)]
pub struct CvParams {
    /// Number of folds (default 5).
    pub folds: usize,
    /// The λ values, increasing.
    pub grid: Vec<f64>,
    /// Group folds by worker (else by tuple).
    pub by_worker: bool,
    /// Shuffling seed (also seeds the agreement bootstrap).
    pub seed: u64,
    /// Solver.
    pub solver: SolverKind,
    /// Stopping rules.
    pub lbfgs: LbfgsParams,
    /// Weights below this are zeroed before scoring.
    pub zero_threshold: f64,
    /// At most this many λ a decade beyond each end of the grid (module docs). Default in
    /// [`TrainParams`](super::train::TrainParams): 3; 0 keeps the grid as given.
    pub max_extensions: usize,
    /// Bootstrap resamples of the held-out agreement's intervals (0: none). Default 1000.
    pub resamples: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(a: u32, worker: Option<u32>, tuple: u32) -> Triplet {
        Triplet {
            a,
            b: a + 1,
            c: a + 2,
            q: true,
            worker,
            tuple,
        }
    }

    #[test]
    fn folds_keep_groups_together_and_balance() {
        let ts: Vec<Triplet> = (0..100).map(|i| t(i, Some(i % 10), i / 2)).collect();
        let f = assign_folds(&ts, 5, true, 3).unwrap();
        for i in 0..100 {
            for j in 0..100 {
                if ts[i].worker == ts[j].worker {
                    assert_eq!(f[i], f[j]);
                }
            }
        }
        for k in 0..5 {
            assert_eq!(f.iter().filter(|&&v| v == k).count(), 20);
        }
        let g = assign_folds(&ts, 5, false, 3).unwrap();
        assert!((0..100).step_by(2).all(|i| g[i] == g[i + 1]));
        assert_eq!(g, assign_folds(&ts, 5, false, 3).unwrap());
        assert!(matches!(
            assign_folds(&ts[..4], 5, true, 0),
            Err(Error::NotEnoughData { got: 4, .. })
        ));
    }

    #[test]
    fn default_grid_spans_four_decades() {
        let g = default_grid(1000, 8);
        assert_eq!(g.len(), 8);
        assert!((g[0] - 0.01).abs() < 1e-12 && (g[7] - 100.0).abs() < 1e-9);
        assert!(
            g.windows(2)
                .all(|w| (w[1] / w[0] - 10f64.powf(4.0 / 7.0)).abs() < 1e-9)
        );
    }
}
