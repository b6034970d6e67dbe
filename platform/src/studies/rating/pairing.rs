//! Balanced A–B pairs for a composition-rating study made from a mash-up study (§5.7.3): the
//! raters compared compositions of the two search conditions, so each pair is one condition-A
//! and one condition-B composition of the same task, and every composition should be judged
//! about equally often (a composition shown in many pairs would weigh more in the preference
//! rate than one shown once).
//!
//! The construction: shuffle each side with the seed, then take the k-th pair as
//! (A[k mod m], B[(k + ⌊k / L⌋) mod n]) with L = lcm(m, n). Within a block of L consecutive k
//! the pairs are distinct (k ↦ (k mod m, k mod n) is injective below lcm), and block t only
//! reaches the pairs (i, j) with i ≡ j − t (mod gcd(m, n)), so the first m·n pairs are all the
//! combinations, each once. Both sides advance one step per pair, so after any number of pairs
//! the uses of two compositions of one side differ by at most one.

use rand::SeedableRng;
use rand::seq::SliceRandom;

use crate::error::{AppError, Result};

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// `count` distinct (A, B) pairs of `a` × `b`, balanced as the module says, in a seeded random
/// order. A 400 when a side is empty or `count` is more than the m·n distinct pairs.
pub fn balanced_pairs<T: Copy>(a: &[T], b: &[T], count: usize, seed: u64) -> Result<Vec<(T, T)>> {
    let (m, n) = (a.len(), b.len());
    if m == 0 || n == 0 {
        return Err(AppError::BadRequest(format!(
            "{m} condition-A and {n} condition-B compositions: nothing to pair"
        )));
    }
    if count > m * n {
        return Err(AppError::BadRequest(format!(
            "{count} pairs asked, but {m} condition-A × {n} condition-B compositions make only \
             {} distinct pairs",
            m * n
        )));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let (mut a, mut b) = (a.to_vec(), b.to_vec());
    a.shuffle(&mut rng);
    b.shuffle(&mut rng);
    let lcm = m / gcd(m, n) * n;
    let mut pairs: Vec<(T, T)> = (0..count)
        .map(|k| (a[k % m], b[(k + k / lcm) % n]))
        .collect();
    pairs.shuffle(&mut rng);
    Ok(pairs)
}

#[cfg(test)]
mod tests {
    use std::collections::{HashMap, HashSet};

    use super::*;

    #[test]
    fn every_count_gives_distinct_pairs_with_uses_differing_by_at_most_one() {
        for m in 1..=7usize {
            for n in 1..=7usize {
                let a: Vec<u32> = (0..m as u32).collect();
                let b: Vec<u32> = (100..100 + n as u32).collect();
                for count in 0..=m * n {
                    let pairs = balanced_pairs(&a, &b, count, 9).unwrap();
                    assert_eq!(pairs.len(), count);
                    let distinct: HashSet<_> = pairs.iter().collect();
                    assert_eq!(distinct.len(), count, "{m}×{n}, {count}: a pair repeats");
                    for side in [0, 1] {
                        let mut uses: HashMap<u32, usize> = HashMap::new();
                        for p in &pairs {
                            *uses.entry(if side == 0 { p.0 } else { p.1 }).or_default() += 1;
                        }
                        let all = if side == 0 { &a } else { &b };
                        let counts: Vec<usize> = all
                            .iter()
                            .map(|x| uses.get(x).copied().unwrap_or(0))
                            .collect();
                        let (lo, hi) = (counts.iter().min(), counts.iter().max());
                        assert!(
                            hi.unwrap() - lo.unwrap() <= 1,
                            "{m}×{n}, {count}, side {side}: uses {counts:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn pairs_repeat_for_a_seed_and_differ_between_seeds() {
        let a: Vec<u32> = (0..5).collect();
        let b: Vec<u32> = (10..14).collect();
        let one = balanced_pairs(&a, &b, 8, 1).unwrap();
        assert_eq!(one, balanced_pairs(&a, &b, 8, 1).unwrap());
        assert_ne!(one, balanced_pairs(&a, &b, 8, 2).unwrap());
    }

    #[test]
    fn an_empty_side_or_too_many_pairs_is_refused() {
        assert!(balanced_pairs::<u32>(&[], &[1], 1, 0).is_err());
        assert!(balanced_pairs(&[1], &[2, 3], 3, 0).is_err());
        assert!(balanced_pairs(&[1], &[2, 3], 2, 0).is_ok());
    }
}
