use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::explore::library::StyleLibrary;
use crate::{Error, Result};

/// Blob A = {0, 1, 2.5} (dog, dog, tree), blob B = {10, 11, 13, 14} (dog, tree, tree, sun) and
/// an outlier at 100 (dog): Ward joins A, B, then A ∪ B, then the outlier (no tied heights).
fn line() -> StyleLibrary {
    let x = [0.0f32, 1.0, 2.5, 10.0, 11.0, 13.0, 14.0, 100.0];
    let labels = vec![0, 0, 1, 0, 1, 1, 2, 0];
    let ids = (0..8).map(|i| format!("item{i}")).collect();
    let names = ["dog", "tree", "sun"].map(String::from).to_vec();
    StyleLibrary::new(ids, x.to_vec(), 1, labels, names).unwrap()
}

fn run(library: &StyleLibrary, required: &[u32], kappa: usize, tau: usize) -> Result<Taxonomy> {
    let params = TaxonomyParams {
        kappa,
        tau,
        ..TaxonomyParams::default()
    };
    taxonomy(library, required, &params, &mut |_, _, _| {})
}

fn members(t: &Taxonomy) -> Vec<Vec<usize>> {
    t.representatives
        .iter()
        .map(|&r| t.nodes[r].members.clone())
        .collect()
}

#[test]
fn explore_taxonomy_prunes_small_branches_and_keeps_the_blobs() {
    let lib = line();
    let t = run(&lib, &[], 2, 0).unwrap();
    // Root, the split A ∪ B, then the two representative styles B (larger) and A.
    assert_eq!(t.nodes.len(), 4);
    assert_eq!(t.nodes[0].count, 8);
    assert_eq!(t.nodes[0].children, vec![1]);
    assert_eq!(t.nodes[1].count, 7);
    assert_eq!(members(&t), vec![vec![3, 4, 5, 6], vec![0, 1, 2]]);
    assert_eq!(t.unassigned, 1);
    assert!(t.reduction.is_none());
    // A's centroid is 7/6: item 1. B's is 12, as near 11 as 13: the lower item, 4.
    assert_eq!(t.nodes[t.representatives[1]].representative, 1);
    assert_eq!(t.nodes[t.representatives[0]].representative, 4);
    assert_eq!(
        t.nodes[t.representatives[0]].label_counts,
        vec![(1, 2), (0, 1), (2, 1)]
    );
    // Heights are Ward's: B joins at √(2·2·2/4)·3 = 3·√2.
    let b = &t.nodes[t.representatives[0]];
    assert!((b.height - 3.0 * 2f64.sqrt()).abs() < 1e-9, "{}", b.height);
}

#[test]
fn explore_taxonomy_requires_every_requested_label() {
    let lib = line();
    // Dog and tree: both blobs hold one of each (τ = 0).
    let t = run(&lib, &[0, 1], 2, 0).unwrap();
    assert_eq!(members(&t), vec![vec![3, 4, 5, 6], vec![0, 1, 2]]);
    // Two trees each (τ = 1): only B; the chain root → A ∪ B → B is shown as root → B.
    let t = run(&lib, &[1], 2, 1).unwrap();
    assert_eq!(members(&t), vec![vec![3, 4, 5, 6]]);
    assert_eq!(t.nodes.len(), 2);
    assert_eq!(t.nodes[0].children, vec![1]);
    assert_eq!(t.unassigned, 4);
    // Sun: B only.
    let t = run(&lib, &[2], 2, 0).unwrap();
    assert_eq!(members(&t), vec![vec![3, 4, 5, 6]]);
}

#[test]
fn explore_taxonomy_errors_when_kappa_or_tau_prune_everything() {
    let lib = line();
    let err = run(&lib, &[], 8, 0).unwrap_err();
    assert!(
        matches!(err, Error::PrunedEverything { items: 8, .. }),
        "{err}"
    );
    let err = run(&lib, &[2], 2, 1).unwrap_err().to_string();
    assert!(
        err.contains("1 of them `sun`") && err.contains("τ = 1"),
        "{err}"
    );
    assert!(matches!(
        run(&lib, &[3], 2, 0),
        Err(Error::InvalidParameter {
            name: "required",
            ..
        })
    ));
    let one = lib.subset(&[0]).unwrap();
    assert!(matches!(
        run(&one, &[], 0, 0),
        Err(Error::NotEnoughData { .. })
    ));
    for params in [
        TaxonomyParams {
            max_exact: 1,
            ..TaxonomyParams::default()
        },
        TaxonomyParams {
            centres: 1,
            ..TaxonomyParams::default()
        },
        TaxonomyParams {
            kmeans_iterations: 0,
            ..TaxonomyParams::default()
        },
    ] {
        assert!(matches!(
            taxonomy(&lib, &[], &params, &mut |_, _, _| {}),
            Err(Error::InvalidParameter { .. })
        ));
    }
}

/// Three separated blobs of 30 points in 3-D with seeded noise.
fn blobs() -> StyleLibrary {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let centres = [[0.0f32, 0.0, 0.0], [20.0, 0.0, 0.0], [0.0, 20.0, 5.0]];
    let mut x = Vec::new();
    let mut labels = Vec::new();
    for (b, c) in centres.iter().enumerate() {
        for i in 0..30 {
            x.extend(c.iter().map(|v| v + rng.random_range(-1.0f32..1.0)));
            labels.push(((b + i) % 2) as u32);
        }
    }
    let ids = (0..90).map(|i| format!("i{i}")).collect();
    StyleLibrary::new(ids, x, 3, labels, vec!["a".into(), "b".into()]).unwrap()
}

#[test]
fn explore_taxonomy_on_kmeans_centres_says_so_and_loses_no_item() {
    let lib = blobs();
    // κ = 29: a whole blob (30) is kept, none of its sub-branches is.
    let exact = TaxonomyParams {
        kappa: 29,
        ..TaxonomyParams::default()
    };
    let reduced = TaxonomyParams {
        max_exact: 50,
        centres: 12,
        ..exact
    };
    let mut stages = Vec::new();
    let a = taxonomy(&lib, &[0, 1], &exact, &mut |_, _, _| {}).unwrap();
    let b = taxonomy(&lib, &[0, 1], &reduced, &mut |s, _, _| stages.push(s)).unwrap();
    assert!(a.reduction.is_none());
    let r = b.reduction.expect("reduced");
    assert!(r.centres <= 12 && r.centres >= 3, "{r:?}");
    assert!(stages.contains(&Stage::KMeans) && stages.contains(&Stage::Ward));
    // Both find the three blobs, every item in exactly one.
    for t in [&a, &b] {
        let mut all: Vec<usize> = members(t).concat();
        all.sort_unstable();
        assert_eq!(all, (0..90).collect::<Vec<_>>());
        let mut blobs: Vec<Vec<usize>> = members(t)
            .iter()
            .map(|m| {
                let mut v: Vec<usize> = m.iter().map(|i| i / 30).collect();
                v.dedup();
                v
            })
            .collect();
        blobs.sort();
        assert_eq!(blobs, vec![vec![0], vec![1], vec![2]]);
        assert_eq!(t.unassigned, 0);
    }
    // Deterministic for a seed.
    let again = taxonomy(&lib, &[0, 1], &reduced, &mut |_, _, _| {}).unwrap();
    assert_eq!(again, b);
}
