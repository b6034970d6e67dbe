//! Seeded randomness of the mash-up study: which condition an assignment gets, and the seed of
//! condition B's random order. Both are pure functions of the study's seed and stable names, so a
//! study replays the same way on any machine and any Rust version (no `DefaultHasher`).

use super::Condition;
use crate::store::ids::AssignmentId;

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

/// The seed of condition B's order for one search (`learner::search::Query::shuffle`): drawn
/// from the study's seed, the assignment and the query, so the same query of the same worker
/// shows the same list again (reproducible) while different workers and queries see different
/// orders. `q` and `category` as the search reads them (trimmed; `None` for no category).
pub fn shuffle_seed(seed: u64, assignment: AssignmentId, q: &str, category: Option<&str>) -> u64 {
    // The category is keyed apart from the text (a NUL cannot be typed into either); "no
    // category" differs from every category.
    let key = match category {
        Some(c) => format!("{q}\u{0}{c}"),
        None => format!("{q}\u{0}\u{0}"),
    };
    mix(seed) ^ mix(assignment.0 as u64).rotate_left(21) ^ text_key(&key)
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
    fn shuffle_seeds_differ_per_worker_query_and_category_and_repeat() {
        let s = |seed, a, q: &str, c: Option<&str>| shuffle_seed(seed, AssignmentId(a), q, c);
        let base = s(7, 10, "cat", Some("animals"));
        assert_eq!(base, s(7, 10, "cat", Some("animals")));
        for other in [
            s(8, 10, "cat", Some("animals")),
            s(7, 11, "cat", Some("animals")),
            s(7, 10, "dog", Some("animals")),
            s(7, 10, "cat", None),
            s(7, 10, "cat", Some("")),
            s(7, 10, "cat\u{0}animals", None),
        ] {
            assert_ne!(base, other);
        }
    }
}
