//! The triplets of a tuple pool: uniform random main triplets, and triplets with a known answer
//! (controls, practice) drawn from the library's style groups.

use std::collections::{BTreeMap, HashMap, HashSet};

use rand::Rng;
use rand::seq::IndexedRandom;

use crate::store::ids::ItemId;
use crate::studies::library::ItemInfo;

/// A tuple to insert.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NewTuple {
    /// Reference.
    pub a: ItemId,
    /// First candidate (the expected answer of controls and training).
    pub b: ItemId,
    /// Second candidate.
    pub c: ItemId,
}

/// The distinct triplets of `n` items: an anchor and an unordered pair of two others,
/// n·(n−1)·(n−2)/2.
pub fn distinct_triplets(n: usize) -> u128 {
    let n = n as u128;
    if n < 3 { 0 } else { n * (n - 1) * (n - 2) / 2 }
}

/// Uniform random triplets over `items`: three distinct items, no triplet twice (B and C
/// unordered). Returns fewer than `count` only when the library has fewer distinct triplets
/// ([`distinct_triplets`]; [`super::create`] refuses such a count).
pub fn random_triplets(items: &[ItemId], count: usize, rng: &mut impl Rng) -> Vec<NewTuple> {
    let n = items.len();
    if n < 3 {
        return Vec::new();
    }
    let count = (count as u128).min(distinct_triplets(n)) as usize;
    let mut seen = HashSet::with_capacity(count);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let a = rng.random_range(0..n);
        let b = rng.random_range(0..n);
        let c = rng.random_range(0..n);
        if a == b || a == c || b == c {
            continue;
        }
        if seen.insert((a, b.min(c), b.max(c))) {
            out.push(NewTuple {
                a: items[a],
                b: items[b],
                c: items[c],
            });
        }
    }
    out
}

/// Triplets with a known answer from style groups: A and B from one group, C from one of the
/// groups farthest from it (mean feature vectors, the farther half). Empty when fewer than two
/// groups have items (at least two in A's group).
pub fn style_triplets(
    items: &[ItemInfo],
    features: &HashMap<ItemId, Vec<f64>>,
    count: usize,
    rng: &mut impl Rng,
) -> Vec<NewTuple> {
    let mut groups: BTreeMap<&str, Vec<ItemId>> = BTreeMap::new();
    for item in items {
        if let Some(style) = &item.style {
            groups.entry(style.as_str()).or_default().push(item.id);
        }
    }
    let names: Vec<&str> = groups.keys().copied().collect();
    if names.len() < 2 || !groups.values().any(|g| g.len() >= 2) {
        return Vec::new();
    }
    let centroid = |g: &[ItemId]| -> Vec<f64> {
        let dim = g.iter().find_map(|i| features.get(i)).map_or(0, Vec::len);
        let mut sum = vec![0.0; dim];
        for f in g.iter().filter_map(|i| features.get(i)) {
            for (s, v) in sum.iter_mut().zip(f) {
                *s += v;
            }
        }
        sum.iter().map(|s| s / g.len().max(1) as f64).collect()
    };
    let centroids: Vec<Vec<f64>> = names.iter().map(|n| centroid(&groups[n])).collect();
    // For each group, the other groups sorted by decreasing distance; keep the farther half.
    let far: Vec<Vec<usize>> = (0..names.len())
        .map(|g| {
            let mut others: Vec<(f64, usize)> = (0..names.len())
                .filter(|&o| o != g)
                .map(|o| {
                    let d: f64 = centroids[g]
                        .iter()
                        .zip(&centroids[o])
                        .map(|(x, y)| (x - y) * (x - y))
                        .sum();
                    (d, o)
                })
                .collect();
            others.sort_by(|x, y| y.0.total_cmp(&x.0));
            let keep = others.len().div_ceil(2);
            others.into_iter().take(keep).map(|(_, o)| o).collect()
        })
        .collect();
    let eligible: Vec<usize> = (0..names.len())
        .filter(|&g| groups[names[g]].len() >= 2)
        .collect();
    let mut seen = HashSet::new();
    let mut out = Vec::with_capacity(count);
    let mut attempts = 0;
    while out.len() < count && attempts < count * 50 {
        attempts += 1;
        let Some(&g) = eligible.choose(rng) else {
            break;
        };
        let members = &groups[names[g]];
        let pair: Vec<ItemId> = members.choose_multiple(rng, 2).copied().collect();
        let Some(&o) = far[g].choose(rng) else { break };
        let Some(&c) = groups[names[o]].choose(rng) else {
            continue;
        };
        let t = NewTuple {
            a: pair[0],
            b: pair[1],
            c,
        };
        if seen.insert((t.a, t.b, t.c)) {
            out.push(t);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use rand::SeedableRng;

    use super::*;

    #[test]
    fn random_triplets_are_distinct_and_capped() {
        let items: Vec<ItemId> = (1..=4).map(ItemId).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let t = random_triplets(&items, 1000, &mut rng);
        // 4 * 3 * 2 / 2 = 12 distinct triplets with B, C unordered.
        assert_eq!(t.len(), 12);
        for x in &t {
            assert!(x.a != x.b && x.a != x.c && x.b != x.c);
        }
        assert!(random_triplets(&items[..2], 5, &mut rng).is_empty());
    }

    #[test]
    fn style_triplets_pair_a_with_b_from_one_group() {
        let items: Vec<ItemInfo> = (1..=8)
            .map(|i| ItemInfo {
                id: ItemId(i),
                name: format!("i{i}"),
                style: Some(if i <= 4 { "x" } else { "y" }.into()),
            })
            .collect();
        let style: HashMap<ItemId, &str> = items
            .iter()
            .map(|i| (i.id, i.style.as_deref().unwrap_or("")))
            .collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let t = style_triplets(&items, &HashMap::new(), 20, &mut rng);
        assert_eq!(t.len(), 20);
        for x in t {
            assert_eq!(style[&x.a], style[&x.b]);
            assert_ne!(style[&x.a], style[&x.c]);
            assert_ne!(x.a, x.b);
        }
    }

    #[test]
    fn distinct_triplets_count_an_anchor_and_an_unordered_pair() {
        assert_eq!(distinct_triplets(2), 0);
        assert_eq!(distinct_triplets(3), 3);
        assert_eq!(distinct_triplets(64), 124_992);
    }
}
