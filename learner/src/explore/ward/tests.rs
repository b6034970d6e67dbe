use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn rows(tree: &Linkage) -> Vec<(usize, usize, f64, usize)> {
    tree.merges()
        .iter()
        .map(|m| (m.a, m.b, m.height, m.size))
        .collect()
}

#[test]
fn ward_four_points_on_a_line() {
    // Two pairs, then the pairs at √(2·2·2/4)·|0.5 − 11| = √2·10.5 (scipy: 14.8492424).
    let tree = ward(&[0.0f64, 1.0, 10.0, 12.0], 1).unwrap();
    let r = rows(&tree);
    assert_eq!((r[0].0, r[0].1, r[0].3), (0, 1, 2));
    assert_eq!((r[1].0, r[1].1, r[1].3), (2, 3, 2));
    assert_eq!((r[2].0, r[2].1, r[2].3), (4, 5, 4));
    assert_eq!(r[0].2, 1.0);
    assert_eq!(r[1].2, 2.0);
    assert!((r[2].2 - 2f64.sqrt() * 10.5).abs() < 1e-12, "{}", r[2].2);
}

#[test]
fn ward_duplicates_merge_at_zero_in_scipys_order() {
    // scipy 1.17.1: [[0,1,0,2],[2,4,0,3],[3,5,6.12372436,4]] and, with the odd point first,
    // [[1,2,0,2],[3,4,0,3],[0,5,6.12372436,4]]; the last height is √(2·3·1/4)·5.
    let last = 1.5f64.sqrt() * 5.0;
    let tree = ward(&[1.0f32, 2.0, 1.0, 2.0, 1.0, 2.0, 4.0, 6.0], 2).unwrap();
    let r = rows(&tree);
    assert_eq!(r[..2], [(0, 1, 0.0, 2), (2, 4, 0.0, 3)]);
    assert_eq!((r[2].0, r[2].1, r[2].3), (3, 5, 4));
    assert!((r[2].2 - last).abs() < 1e-12);
    let tree = ward(&[4.0f64, 6.0, 1.0, 2.0, 1.0, 2.0, 1.0, 2.0], 2).unwrap();
    let r = rows(&tree);
    assert_eq!(r[..2], [(1, 2, 0.0, 2), (3, 4, 0.0, 3)]);
    assert_eq!((r[2].0, r[2].1, r[2].3), (0, 5, 4));
    assert_eq!(tree.cut(2).unwrap(), vec![0, 1, 1, 1]);
}

#[test]
fn ward_f32_and_f64_inputs_give_the_same_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let x32: Vec<f32> = (0..40 * 4).map(|_| rng.random_range(-1.0..1.0)).collect();
    let x64: Vec<f64> = x32.iter().map(|v| f64::from(*v)).collect();
    assert_eq!(ward(&x32, 4).unwrap(), ward(&x64, 4).unwrap());
}

/// The definition, naively: repeatedly merge the pair of clusters whose union least increases
/// the sum of squares, `Δ = n_x·n_y/(n_x+n_y)·‖c_x − c_y‖²`, at height `√(2Δ)`; O(n³).
fn naive_ward(x: &[f64], dim: usize) -> Vec<(usize, usize, f64, usize)> {
    let n = x.len() / dim;
    // (cluster id, size, centroid)
    let mut live: Vec<(usize, usize, Vec<f64>)> = (0..n)
        .map(|i| (i, 1, x[i * dim..(i + 1) * dim].to_vec()))
        .collect();
    let mut out = Vec::new();
    for step in 0..n - 1 {
        let mut best = (f64::INFINITY, 0, 0);
        for p in 0..live.len() {
            for q in p + 1..live.len() {
                let (np, nq) = (live[p].1 as f64, live[q].1 as f64);
                let d2: f64 = live[p]
                    .2
                    .iter()
                    .zip(&live[q].2)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum();
                let delta = np * nq / (np + nq) * d2;
                if delta < best.0 {
                    best = (delta, p, q);
                }
            }
        }
        let (delta, p, q) = best;
        let (b, a) = (live.remove(q), live.remove(p));
        let size = a.1 + b.1;
        let centre =
            a.2.iter()
                .zip(&b.2)
                .map(|(u, v)| (u * a.1 as f64 + v * b.1 as f64) / size as f64)
                .collect();
        out.push((a.0.min(b.0), a.0.max(b.0), (2.0 * delta).sqrt(), size));
        live.push((n + step, size, centre));
    }
    out
}

#[test]
fn ward_nn_chain_matches_the_naive_greedy_definition() {
    for seed in 0..8 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (n, dim) = (10 + 5 * seed as usize, 1 + seed as usize % 4);
        let x: Vec<f64> = (0..n * dim).map(|_| rng.random_range(-5.0..5.0)).collect();
        let fast = rows(&ward(&x, dim).unwrap());
        let slow = naive_ward(&x, dim);
        for (i, (f, s)) in fast.iter().zip(&slow).enumerate() {
            assert_eq!((f.0, f.1, f.3), (s.0, s.1, s.3), "seed {seed}, merge {i}");
            assert!(
                (f.2 - s.2).abs() <= 1e-9 * s.2,
                "seed {seed}, merge {i}: {f:?} {s:?}"
            );
        }
    }
}

#[test]
fn ward_rejects_bad_inputs_with_clear_errors() {
    assert!(matches!(
        ward::<f64>(&[], 2),
        Err(Error::NotEnoughData {
            needed: 2,
            got: 0,
            ..
        })
    ));
    assert!(matches!(
        ward(&[1.0f64, 2.0], 2),
        Err(Error::NotEnoughData {
            needed: 2,
            got: 1,
            ..
        })
    ));
    assert!(matches!(
        ward(&[1.0f64, 2.0], 0),
        Err(Error::InvalidParameter { name: "dim", .. })
    ));
    assert!(matches!(
        ward(&[1.0f64, 2.0, 3.0], 2),
        Err(Error::NotAMatrix { len: 3, dim: 2 })
    ));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -2e100] {
        let e = ward(&[0.0, 1.0, 2.0, bad], 2).unwrap_err();
        assert!(
            matches!(
                e,
                Error::BadCoordinate {
                    row: 1,
                    column: 1,
                    ..
                }
            ),
            "{bad}: {e}"
        );
    }
    assert!(matches!(
        ward(&[0.0f32, f32::NAN], 1),
        Err(Error::BadCoordinate {
            row: 1,
            column: 0,
            ..
        })
    ));
    let e = ward(&vec![0.0f32; MAX_POINTS + 1], 1).unwrap_err();
    assert!(matches!(e, Error::TooManyPoints { n, limit: MAX_POINTS, .. } if n == MAX_POINTS + 1));
    let text = e.to_string();
    assert!(
        text.contains("40001 points") && text.contains("at most 40000"),
        "{text}"
    );
}

#[test]
fn ward_condensed_index_is_the_upper_triangle_row_by_row() {
    let n = 5;
    let mut k = 0;
    for i in 0..n {
        for j in i + 1..n {
            assert_eq!(at(n, i, j), k);
            assert_eq!(at(n, j, i), k);
            k += 1;
        }
    }
}

#[test]
fn ward_weighted_equals_ward_on_the_items_after_their_groups_merge() {
    // Each of 12 seeded centres repeated `w` times: exact Ward on the 12·w̄ items merges every
    // group of duplicates at height 0 first, then must make the weighted tree's merges.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let dim = 3;
    let centres: Vec<f64> = (0..12 * dim).map(|_| rng.random_range(-5.0..5.0)).collect();
    let weights: Vec<usize> = (0..12).map(|_| rng.random_range(1..5)).collect();
    let mut items = Vec::new();
    for (c, &w) in weights.iter().enumerate() {
        for _ in 0..w {
            items.extend_from_slice(&centres[c * dim..(c + 1) * dim]);
        }
    }
    let full = ward(&items, dim).unwrap();
    let weighted = ward_weighted(&centres, dim, &weights).unwrap();
    let items_n = items.len() / dim;
    let zero_merges = items_n - 12;
    let upper: Vec<f64> = full.merges()[zero_merges..]
        .iter()
        .map(|m| m.height)
        .collect();
    assert!(full.merges()[..zero_merges].iter().all(|m| m.height == 0.0));
    let heights: Vec<f64> = weighted.merges().iter().map(|m| m.height).collect();
    assert_eq!(upper.len(), heights.len());
    for (a, b) in upper.iter().zip(&heights) {
        assert!((a - b).abs() <= 1e-9 * a.max(1.0), "{a} vs {b}");
    }
    // The same partitions: group label of every item in the full tree's cut.
    let mut group = Vec::new();
    for (c, &w) in weights.iter().enumerate() {
        group.extend(std::iter::repeat_n(c, w));
    }
    for k in [2, 3, 5, 12] {
        let by_item = full.cut(k).unwrap();
        let by_centre = weighted.cut(k).unwrap();
        let mut relabel = std::collections::HashMap::new();
        for (item, &g) in group.iter().enumerate() {
            let seen = relabel.entry(by_centre[g]).or_insert(by_item[item]);
            assert_eq!(*seen, by_item[item], "k = {k}");
        }
    }
    // Unit weights are plain Ward.
    assert_eq!(
        ward_weighted(&centres, dim, &[1; 12]).unwrap(),
        ward(&centres, dim).unwrap()
    );
    assert!(matches!(
        ward_weighted(&centres, dim, &[1; 11]),
        Err(Error::InvalidParameter {
            name: "weights",
            ..
        })
    ));
    let mut zero = vec![1; 12];
    zero[3] = 0;
    assert!(matches!(
        ward_weighted(&centres, dim, &zero),
        Err(Error::InvalidParameter {
            name: "weights",
            ..
        })
    ));
}
