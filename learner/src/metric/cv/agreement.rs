//! Held-out agreement of the learned and the uniform metric with the answers, with intervals.
//!
//! Every answer is predicted once, by the fold model that did not see it (the weights fitted on
//! the other folds at the chosen λ, after zeroing) — the out-of-fold predictions of
//! cross-validation. The uniform metric is scored the same way (its accuracy does not depend on
//! its scale). Intervals are percentile bootstraps over the folds' groups (workers, or tuples),
//! not over answers: one worker's answers share their skill and biases, so resampling answers
//! would understate the uncertainty. Both metrics are scored on the same resample, so the
//! interval of their difference is paired.
//!
//! The λ was chosen on these same folds, so the learned figure is slightly optimistic; with a
//! handful of λ and thousands of answers the selection effect is small next to the interval.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::eval::triplets::Estimate;

/// Out-of-fold agreement at the chosen λ.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutAgreement {
    /// What the bootstrap resamples: `worker` or `tuple` (the folds' groups).
    pub unit: String,
    /// Distinct units.
    pub units: usize,
    /// Answers scored.
    pub answers: usize,
    /// Bootstrap resamples (0: no intervals, `low = high = value`).
    pub resamples: usize,
    /// Fraction of answers the learned metric predicts (ties count half), 95% interval.
    pub learned: Estimate,
    /// The same for uniform weights.
    pub uniform: Estimate,
    /// `learned − uniform`, with the paired 95% interval.
    pub difference: Estimate,
}

impl HeldOutAgreement {
    /// Whether the two 95% intervals are disjoint with the learned metric above.
    pub fn learned_clearly_better(&self) -> bool {
        self.learned.low > self.uniform.high
    }
}

/// Per answer: its group (dense index), and whether the learned and the uniform metric agree
/// with it (1, ½ for a tie, 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// Group index (`0..groups`).
    pub group: usize,
    /// Learned metric's credit.
    pub learned: f64,
    /// Uniform metric's credit.
    pub uniform: f64,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64)
}

/// Agreement with cluster-bootstrap intervals over `groups` groups, `resamples` seeded
/// resamples (sequential: the figures do not depend on the thread count).
pub fn agreement(
    scored: &[Scored],
    groups: usize,
    unit: &str,
    resamples: usize,
    seed: u64,
) -> HeldOutAgreement {
    // (answers, learned credit, uniform credit) per group; empty groups are dropped.
    let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); groups];
    for s in scored {
        let g = &mut sums[s.group];
        g.0 += 1.0;
        g.1 += s.learned;
        g.2 += s.uniform;
    }
    sums.retain(|g| g.0 > 0.0);
    let total = |pick: &mut dyn FnMut() -> usize| {
        let mut acc = (0.0, 0.0, 0.0);
        for _ in 0..sums.len() {
            let g = sums[pick()];
            acc = (acc.0 + g.0, acc.1 + g.1, acc.2 + g.2);
        }
        (acc.1 / acc.0, acc.2 / acc.0)
    };
    let mut i = 0;
    let (learned, uniform) = if sums.is_empty() {
        (f64::NAN, f64::NAN)
    } else {
        total(&mut || {
            i += 1;
            i - 1
        })
    };
    let point = |v: f64| Estimate {
        value: v,
        low: v,
        high: v,
    };
    if resamples == 0 || sums.len() < 2 {
        return HeldOutAgreement {
            unit: unit.into(),
            units: sums.len(),
            answers: scored.len(),
            resamples: 0,
            learned: point(learned),
            uniform: point(uniform),
            difference: point(learned - uniform),
        };
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = sums.len();
    let reps: Vec<(f64, f64)> = (0..resamples)
        .map(|_| total(&mut || rng.random_range(0..n)))
        .collect();
    let interval = |value: f64, mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        Estimate {
            value,
            low: percentile(&v, 0.025),
            high: percentile(&v, 0.975),
        }
    };
    let diffs = reps.iter().map(|r| r.0 - r.1).collect();
    let uniforms = reps.iter().map(|r| r.1).collect();
    HeldOutAgreement {
        unit: unit.into(),
        units: n,
        answers: scored.len(),
        resamples,
        learned: interval(learned, reps.iter().map(|r| r.0).collect()),
        uniform: interval(uniform, uniforms),
        difference: interval(learned - uniform, diffs),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_cover_the_value_and_separate_clear_differences() {
        // 40 workers of 20 answers: learned right 80%, uniform 60%.
        let scored: Vec<Scored> = (0..800)
            .map(|i| Scored {
                group: i / 20,
                learned: if i % 5 == 0 { 0.0 } else { 1.0 },
                uniform: if i % 5 < 2 { 0.0 } else { 1.0 },
            })
            .collect();
        let a = agreement(&scored, 40, "worker", 500, 1);
        assert_eq!((a.units, a.answers), (40, 800));
        assert!((a.learned.value - 0.8).abs() < 1e-12);
        assert!((a.uniform.value - 0.6).abs() < 1e-12);
        assert!((a.difference.value - 0.2).abs() < 1e-12);
        for e in [a.learned, a.uniform, a.difference] {
            assert!(e.low <= e.value && e.value <= e.high, "{e:?}");
        }
        assert!(a.learned_clearly_better());
        // Same seed, same figures.
        assert_eq!(a, agreement(&scored, 40, "worker", 500, 1));
    }

    #[test]
    fn between_group_spread_widens_the_interval() {
        // Half the workers always agree, half never: the answer-level spread is the same as
        // for mixed workers, but the worker-level one is far larger.
        let clustered: Vec<Scored> = (0..400)
            .map(|i| Scored {
                group: i / 20,
                learned: if (i / 20) % 2 == 0 { 1.0 } else { 0.0 },
                uniform: 0.5,
            })
            .collect();
        let mixed: Vec<Scored> = (0..400)
            .map(|i| Scored {
                group: i / 20,
                learned: if i % 2 == 0 { 1.0 } else { 0.0 },
                uniform: 0.5,
            })
            .collect();
        let width = |a: HeldOutAgreement| a.learned.high - a.learned.low;
        let wc = width(agreement(&clustered, 20, "worker", 400, 3));
        let wm = width(agreement(&mixed, 20, "worker", 400, 3));
        assert!(wc > 5.0 * wm.max(1e-3), "clustered {wc}, mixed {wm}");
    }

    #[test]
    fn no_resamples_or_one_group_gives_points() {
        let scored = [Scored {
            group: 0,
            learned: 1.0,
            uniform: 0.0,
        }];
        let a = agreement(&scored, 1, "tuple", 100, 0);
        assert_eq!(a.resamples, 0);
        assert_eq!((a.learned.low, a.learned.high), (1.0, 1.0));
    }
}
