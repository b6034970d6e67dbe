//! Seeded randomness of the mash-up study: which condition an assignment gets, and the order
//! of condition B's results. Both are pure functions of the study's seed and stable names, so a
//! study replays the same way on any machine and any Rust version (no `DefaultHasher`).

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::Condition;
use crate::store::ids::{AssignmentId, ItemId};

/// SplitMix64's finaliser: spreads nearby inputs (seed, seed + 1, …) over the whole range.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// FNV-1a over bytes, then mixed: a stable 64-bit key for a text.
fn text_key(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    mix(h)
}

/// The condition of the `seq`-th assignment (0-based) of a study with `seed`.
///
/// Balanced and blind: assignments come in pairs (0–1, 2–3, …); within each pair the two
/// conditions alternate, in an order drawn from the seed for that pair. After any even number
/// of assignments the two conditions have exactly as many workers, after an odd number they
/// differ by one, and the next condition cannot be guessed from the previous pairs.
pub fn condition_at(seed: u64, seq: u64) -> Condition {
    let pair = seq / 2;
    let first = if mix(seed ^ mix(pair)) & 1 == 0 {
        Condition::A
    } else {
        Condition::B
    };
    if seq.is_multiple_of(2) {
        first
    } else {
        first.other()
    }
}

/// Condition B's order: the same matches as condition A, shuffled with a generator seeded by
/// the study's seed, the assignment and the query, so the same query of the same worker shows
/// the same list again (reproducible) while different workers see different orders.
pub fn random_order(
    seed: u64,
    assignment: AssignmentId,
    q: &str,
    category: Option<&str>,
    ids: &mut [ItemId],
) {
    // The category is keyed apart from the text (a NUL cannot be typed into either).
    let key = format!("{q}\u{0}{}", category.unwrap_or(""));
    let stream = mix(seed) ^ mix(assignment.0 as u64) ^ text_key(&key);
    // Shuffle a sorted copy, so the order does not depend on the order the matches came in.
    ids.sort_unstable();
    ids.shuffle(&mut ChaCha8Rng::seed_from_u64(stream));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_are_balanced_in_every_pair_and_reproducible() {
        for seed in [0, 1, 42, u64::MAX] {
            let seq: Vec<Condition> = (0..200).map(|i| condition_at(seed, i)).collect();
            for pair in seq.chunks(2) {
                assert_ne!(pair[0], pair[1], "seed {seed}: a pair repeats a condition");
            }
            let again: Vec<Condition> = (0..200).map(|i| condition_at(seed, i)).collect();
            assert_eq!(seq, again);
            // Not a fixed alternation: both orders of a pair occur.
            let a_first = seq.chunks(2).filter(|p| p[0] == Condition::A).count();
            assert!(
                (20..=80).contains(&a_first),
                "seed {seed}: {a_first} of 100"
            );
        }
        // Different seeds give different sequences.
        let s0: Vec<_> = (0..64).map(|i| condition_at(0, i)).collect();
        let s1: Vec<_> = (0..64).map(|i| condition_at(1, i)).collect();
        assert_ne!(s0, s1);
    }

    #[test]
    fn random_order_is_a_reproducible_permutation_per_worker_and_query() {
        let original: Vec<ItemId> = (1..=60).map(ItemId).collect();
        let order = |assignment: i64, q: &str, input: &[ItemId]| {
            let mut ids = input.to_vec();
            random_order(7, AssignmentId(assignment), q, Some("animals"), &mut ids);
            ids
        };
        let a = order(10, "cat", &original);
        let mut sorted = a.clone();
        sorted.sort();
        assert_eq!(sorted, original, "not a permutation");
        assert_ne!(a, original, "left in the original order");
        // The same query again, even from a reversed input: the same list.
        let reversed: Vec<ItemId> = original.iter().rev().copied().collect();
        assert_eq!(order(10, "cat", &reversed), a);
        assert_ne!(order(11, "cat", &original), a, "another worker, same order");
        assert_ne!(order(10, "dog", &original), a, "another query, same order");
        let mut no_category = original.clone();
        random_order(7, AssignmentId(10), "cat", None, &mut no_category);
        assert_ne!(no_category, a);
    }
}
