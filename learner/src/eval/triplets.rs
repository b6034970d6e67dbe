//! Triplet accuracy and perplexity (eq. 5.9), raw and by majority vote, with percentile
//! bootstrap intervals.
//!
//! * Accuracy: the fraction of answers the model predicts (`P(q) > ½`); an exact tie
//!   (`P = ½`) counts as half right, so a model without information scores exactly 50%.
//! * Perplexity (eq. 5.9): `2^(−(1/N) Σ log₂ P(q_i))` — 1 for a perfect model, 2 for a coin.
//! * Majority: answers are grouped per tuple and re-oriented to the tuple's first answer (so
//!   `a,b,c,1` and `a,c,b,0` agree); the majority answer is the label, ties are dropped.
//! * Intervals: 2.5/97.5 percentiles of the statistic over resamples with replacement — of
//!   answers for raw scores, of tuples for majority scores. Each resample has its own seeded
//!   generator, so intervals do not depend on the thread count.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::metric::objective::sigmoid;
use crate::triplets::Triplet;
use crate::{Error, Result};

/// Bootstrap settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BootstrapParams {
    /// Resamples (default 1000; 0 disables intervals).
    pub resamples: usize,
    /// Seed (default 0).
    pub seed: u64,
}

impl Default for BootstrapParams {
    fn default() -> Self {
        Self {
            resamples: 1000,
            seed: 0,
        }
    }
}

/// A statistic with its 95% bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// On the full sample.
    pub value: f64,
    /// 2.5th percentile.
    pub low: f64,
    /// 97.5th percentile.
    pub high: f64,
}

/// Accuracy and perplexity of one set of answers.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    /// Triplet accuracy.
    pub accuracy: Estimate,
    /// Perplexity (eq. 5.9).
    pub perplexity: Estimate,
    /// Answers (or majority tuples) scored.
    pub n: usize,
}

/// Raw and majority scores of one predictor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MethodScores {
    /// Every answer.
    pub raw: Scores,
    /// Per-tuple majority answers (`None` if every tuple is tied).
    pub majority: Option<Scores>,
    /// Tuples dropped for a tied vote.
    pub ties_dropped: usize,
}

fn accuracy_term(p: f64) -> f64 {
    if p > 0.5 {
        1.0
    } else if p == 0.5 {
        0.5
    } else {
        0.0
    }
}

/// `(accuracy, perplexity)` from the probabilities each answer was given.
pub fn accuracy_perplexity(p_answer: &[f64]) -> (f64, f64) {
    let n = p_answer.len() as f64;
    let acc = p_answer.iter().map(|&p| accuracy_term(p)).sum::<f64>() / n;
    let mean_log2 = p_answer
        .iter()
        .map(|&p| p.max(f64::MIN_POSITIVE).log2())
        .sum::<f64>()
        / n;
    (acc, (-mean_log2).exp2())
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// Scores with intervals from `p_answer` (probability given to each unit's answer).
pub fn bootstrap_scores(p_answer: &[f64], params: &BootstrapParams) -> Scores {
    let (acc, ppl) = accuracy_perplexity(p_answer);
    let n = p_answer.len();
    if params.resamples == 0 || n == 0 {
        let e = |v| Estimate {
            value: v,
            low: v,
            high: v,
        };
        return Scores {
            accuracy: e(acc),
            perplexity: e(ppl),
            n,
        };
    }
    let reps: Vec<(f64, f64)> = (0..params.resamples)
        .into_par_iter()
        .map(|r| {
            let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
            rng.set_stream(r as u64 + 1);
            let sample: Vec<f64> = (0..n).map(|_| p_answer[rng.random_range(0..n)]).collect();
            accuracy_perplexity(&sample)
        })
        .collect();
    let mut accs: Vec<f64> = reps.iter().map(|r| r.0).collect();
    let mut ppls: Vec<f64> = reps.iter().map(|r| r.1).collect();
    accs.sort_by(f64::total_cmp);
    ppls.sort_by(f64::total_cmp);
    Scores {
        accuracy: Estimate {
            value: acc,
            low: percentile(&accs, 0.025),
            high: percentile(&accs, 0.975),
        },
        perplexity: Estimate {
            value: ppl,
            low: percentile(&ppls, 0.025),
            high: percentile(&ppls, 0.975),
        },
        n,
    }
}

/// Majority labels: per tuple, `(representative answer index, majority q in that answer's
/// orientation)`, and the number of tied tuples.
pub fn majority(triplets: &[Triplet]) -> (Vec<(usize, bool)>, usize) {
    let tuples = triplets
        .iter()
        .map(|t| t.tuple as usize + 1)
        .max()
        .unwrap_or(0);
    // votes[t] = (first answer index, votes agreeing with the first answer's orientation, total)
    let mut votes: Vec<Option<(usize, i64)>> = vec![None; tuples];
    for (i, t) in triplets.iter().enumerate() {
        let entry = votes[t.tuple as usize].get_or_insert((i, 0));
        let first = &triplets[entry.0];
        // Does this answer say "a closer to first.b"?
        let closer_to_b = if t.b == first.b { t.q } else { !t.q };
        entry.1 += if closer_to_b == first.q { 1 } else { -1 };
    }
    let mut out = Vec::new();
    let mut ties = 0;
    for v in votes.into_iter().flatten() {
        match v.1.cmp(&0) {
            std::cmp::Ordering::Greater => out.push((v.0, triplets[v.0].q)),
            std::cmp::Ordering::Less => out.push((v.0, !triplets[v.0].q)),
            std::cmp::Ordering::Equal => ties += 1,
        }
    }
    (out, ties)
}

/// Raw and majority scores for a predictor giving `P(q = 1)` = `p_one[i]` to answer `i`.
pub fn score(
    triplets: &[Triplet],
    p_one: &[f64],
    params: &BootstrapParams,
) -> Result<MethodScores> {
    if triplets.is_empty() || triplets.len() != p_one.len() {
        return Err(Error::NotEnoughData {
            what: "triplets to evaluate",
            needed: 1.max(p_one.len()),
            got: triplets.len(),
        });
    }
    let raw: Vec<f64> = triplets
        .iter()
        .zip(p_one)
        .map(|(t, &p)| if t.q { p } else { 1.0 - p })
        .collect();
    let (maj, ties) = majority(triplets);
    let maj_p: Vec<f64> = maj
        .iter()
        .map(|&(i, q)| if q { p_one[i] } else { 1.0 - p_one[i] })
        .collect();
    Ok(MethodScores {
        raw: bootstrap_scores(&raw, params),
        majority: (!maj_p.is_empty()).then(|| {
            bootstrap_scores(
                &maj_p,
                &BootstrapParams {
                    seed: params.seed ^ 0x5eed,
                    ..*params
                },
            )
        }),
        ties_dropped: ties,
    })
}

/// `P(q = 1)` from margins `d(A, C) − d(A, B)`.
pub fn probabilities(margins: &[f64]) -> Vec<f64> {
    margins.iter().map(|&m| sigmoid(m)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(a: u32, b: u32, c: u32, q: bool, tuple: u32) -> Triplet {
        Triplet {
            a,
            b,
            c,
            q,
            worker: None,
            tuple,
        }
    }

    #[test]
    fn hand_computed_accuracy_and_perplexity() {
        // P given to the answers: 0.8, 0.5, 0.25 → accuracy (1 + 0.5 + 0)/3,
        // perplexity 2^(−(log2 0.8 + log2 0.5 + log2 0.25)/3) = (0.8·0.5·0.25)^(−1/3) = 10^(1/3).
        let (acc, ppl) = accuracy_perplexity(&[0.8, 0.5, 0.25]);
        assert!((acc - 0.5).abs() < 1e-15);
        assert!((ppl - 10f64.powf(1.0 / 3.0)).abs() < 1e-12);
        let (acc, ppl) = accuracy_perplexity(&[0.5; 7]);
        assert_eq!((acc, ppl), (0.5, 2.0));
    }

    #[test]
    fn majority_orients_and_drops_ties() {
        let ts = [
            t(0, 1, 2, true, 0),
            t(0, 2, 1, false, 0), // same opinion, flipped orientation
            t(0, 1, 2, false, 0),
            t(3, 4, 5, true, 1),
            t(3, 4, 5, false, 1), // tie
        ];
        let (m, ties) = majority(&ts);
        assert_eq!((m, ties), (vec![(0, true)], 1));
        let s = score(&ts, &[0.9, 0.1, 0.9, 0.6, 0.6], &BootstrapParams::default()).unwrap();
        let maj = s.majority.unwrap();
        assert_eq!((maj.n, maj.accuracy.value), (1, 1.0));
        assert!((maj.perplexity.value - 1.0 / 0.9).abs() < 1e-12);
        // Raw: answers get 0.9, 0.9, 0.1, 0.6, 0.4 → 3 of 5 right.
        assert!((s.raw.accuracy.value - 0.6).abs() < 1e-12);
    }

    #[test]
    fn bootstrap_interval_brackets_value_and_is_deterministic() {
        let p: Vec<f64> = (0..500)
            .map(|i| if i % 4 == 0 { 0.3 } else { 0.8 })
            .collect();
        let a = bootstrap_scores(&p, &BootstrapParams::default());
        assert!(a.accuracy.low < 0.75 && 0.75 < a.accuracy.high);
        assert!(a.accuracy.high - a.accuracy.low < 0.1);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| bootstrap_scores(&p, &BootstrapParams::default()));
        assert_eq!(a, b);
    }
}
