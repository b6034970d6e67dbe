//! Invariants of the balanced grid and its baselines, checked against brute force and hand cases.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::Error;

fn random_points(n: usize, dim: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n * dim).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// Items at the integer points of an `rows × cols` lattice: the perfect layout is known.
fn lattice(rows: usize, cols: usize) -> Vec<f32> {
    (0..rows * cols)
        .flat_map(|i| [(i / cols) as f32, (i % cols) as f32])
        .collect()
}

/// The least eq. 6.1 over every layout that shows distinct items on distinct nodes (hidden
/// items do not change the cost), by enumeration.
fn brute_optimum(labels: &[u32], cells: usize) -> f64 {
    fn go(
        labels: &[u32],
        cells: usize,
        node: usize,
        used: &mut Vec<bool>,
        shown: &mut Vec<usize>,
        best: &mut f64,
    ) {
        if node == cells {
            let mut grid = Grid::empty(1, cells);
            for (k, &i) in shown.iter().enumerate() {
                if i != usize::MAX {
                    grid.nodes[k].shown = Some(i);
                    grid.nodes[k].state = NodeState::Single;
                }
            }
            for (i, u) in used.iter().enumerate() {
                if !u {
                    grid.nodes[0].hidden.push(i);
                }
            }
            *best = best.min(cost(&grid, labels).unwrap().total);
            return;
        }
        shown.push(usize::MAX);
        go(labels, cells, node + 1, used, shown, best);
        shown.pop();
        for i in 0..labels.len() {
            if !used[i] {
                used[i] = true;
                shown.push(i);
                go(labels, cells, node + 1, used, shown, best);
                shown.pop();
                used[i] = false;
            }
        }
    }
    let mut best = f64::INFINITY;
    go(
        labels,
        cells,
        0,
        &mut vec![false; labels.len()],
        &mut Vec::new(),
        &mut best,
    );
    best
}

#[test]
fn grid_balance_reaches_the_brute_force_optimum_of_eq_6_1() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for case in 0..60 {
        let (rows, cols) = [(2, 2), (2, 3), (1, 4), (3, 2)][case % 4];
        let n = rng.random_range(1..=8);
        let kinds = rng.random_range(1..=3);
        let labels: Vec<u32> = (0..n).map(|_| rng.random_range(0..kinds)).collect();
        let points = random_points(n, 3, case as u64);
        let mut params = SomParams::new(rows, cols);
        params.seed = case as u64;
        params.init = if case % 2 == 0 {
            SomInit::Pca
        } else {
            SomInit::Random
        };
        let (grid, info) =
            balanced_grid(&points, 3, &labels, &params, &BalanceParams::default()).unwrap();
        assert!(grid.holds_each_item_once(n), "case {case}");
        let best = brute_optimum(&labels, rows * cols);
        assert!(
            (info.last.total - best).abs() < 1e-9,
            "case {case}: {:?} vs optimum {best}",
            info.last
        );
        assert_eq!(info.last, cost(&grid, &labels).unwrap());
    }
}

#[test]
fn grid_balance_keeps_every_item_once_and_fills_every_node() {
    for (n, rows, cols, seed) in [
        (50, 5, 5, 1),
        (25, 5, 5, 2),
        (20, 5, 5, 3),
        (300, 8, 12, 4),
        (1, 1, 1, 5),
    ] {
        let points = random_points(n, 4, seed);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let labels: Vec<u32> = (0..n).map(|_| rng.random_range(0..4)).collect();
        let (grid, info) = balanced_grid(
            &points,
            4,
            &labels,
            &SomParams::new(rows, cols),
            &BalanceParams::default(),
        )
        .unwrap();
        assert!(grid.holds_each_item_once(n));
        assert!(grid.nodes.iter().all(|x| x.state != NodeState::Multi));
        let empty = grid.nodes.iter().filter(|x| x.shown.is_none()).count();
        assert_eq!(empty, (rows * cols).saturating_sub(n), "n = {n}");
        assert_eq!(info.last.multi, 0);
        assert!(info.last.total <= info.som.total);
        for x in &grid.nodes {
            assert_eq!(x.state == NodeState::Empty, x.shown.is_none());
            assert!(x.shown.is_some() || x.hidden.is_empty());
        }
    }
}

#[test]
fn grid_paper_steps_alone_keep_items_and_leave_no_multi_node() {
    let points = random_points(200, 3, 9);
    let labels: Vec<u32> = (0..200).map(|i| (i % 3) as u32).collect();
    let map = som(&points, 3, &SomParams::new(10, 10)).unwrap();
    let only_paper = BalanceParams {
        radius: 2,
        grow: false,
        relabel: false,
    };
    let (grid, info) = balance(&points, 3, &labels, &map, &only_paper).unwrap();
    assert!(grid.holds_each_item_once(200));
    assert_eq!(info.after_alg3.multi, 0);
    assert!(info.after_alg4.empty <= info.after_alg3.empty);
    assert_eq!(info.filled_grown, 0);
    assert_eq!(info.relabelled, 0);
}

#[test]
fn grid_som_is_the_same_for_any_thread_count() {
    let points = random_points(500, 6, 4);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| som(&points, 6, &SomParams::new(7, 9)).unwrap())
    };
    let (a, b) = (run(1), run(3));
    assert_eq!(a.bmu, b.bmu);
    assert_eq!(a.weights, b.weights);
}

#[test]
fn grid_som_orders_a_lattice() {
    // A SOM of the size of a lattice, trained on it, keeps neighbours together.
    let points = lattice(8, 8);
    for init in [SomInit::Pca, SomInit::Random] {
        let mut p = SomParams::new(8, 8);
        p.init = init;
        p.epochs = 30;
        let map = som(&points, 2, &p).unwrap();
        let grid = som_grid(&points, 2, &map).unwrap();
        let rho = layout_spearman(&points, 2, &grid, &QualityParams::default()).unwrap();
        assert!(rho > 0.9, "{init:?}: Spearman {rho}");
        assert!(
            map.quantisation_error < 0.5,
            "{init:?}: {}",
            map.quantisation_error
        );
    }
}

#[test]
fn grid_quality_of_a_perfect_layout_is_one() {
    let (rows, cols) = (6, 7);
    let points = lattice(rows, cols);
    let mut grid = Grid::empty(rows, cols);
    for (k, node) in grid.nodes.iter_mut().enumerate() {
        node.shown = Some(k);
        node.state = NodeState::Single;
    }
    let q = QualityParams::default();
    assert!((layout_spearman(&points, 2, &grid, &q).unwrap() - 1.0).abs() < 1e-12);
    assert!((dpq(&points, 2, &grid, &q).unwrap() - 1.0).abs() < 1e-12);
    let shuffled = random_layout(rows * cols, rows, cols, 1).unwrap();
    let rho = layout_spearman(&points, 2, &shuffled, &q).unwrap();
    let d = dpq(&points, 2, &shuffled, &q).unwrap();
    assert!(
        rho.abs() < 0.2 && d < 0.5,
        "random layout: Spearman {rho}, DPQ {d}"
    );
}

#[test]
fn grid_isomatch_recovers_a_lattice() {
    let (rows, cols) = (6, 8);
    let points = lattice(rows, cols);
    let grid = isomatch(&points, 2, &IsoMatchParams::new(rows, cols)).unwrap();
    assert!(grid.holds_each_item_once(rows * cols));
    let q = QualityParams::default();
    let rho = layout_spearman(&points, 2, &grid, &q).unwrap();
    let d = dpq(&points, 2, &grid, &q).unwrap();
    assert!(rho > 0.99 && d > 0.95, "Spearman {rho}, DPQ {d}");
    // More items than cells: the extra items are hidden, none lost.
    let points = random_points(40, 3, 2);
    let grid = isomatch(&points, 3, &IsoMatchParams::new(5, 6)).unwrap();
    assert!(grid.holds_each_item_once(40));
    assert_eq!(grid.nodes.iter().filter(|x| x.shown.is_some()).count(), 30);
}

#[test]
fn grid_random_layout_places_every_item_once() {
    for (n, rows, cols) in [(0, 2, 2), (3, 2, 2), (4, 2, 2), (11, 2, 2)] {
        let grid = random_layout(n, rows, cols, 5).unwrap();
        assert!(grid.holds_each_item_once(n));
        assert_eq!(
            grid.nodes.iter().filter(|x| x.shown.is_some()).count(),
            n.min(4)
        );
    }
}

#[test]
fn grid_spearman_matches_hand_values() {
    // Perfectly monotone, and reversed with ties: ranks [1, 2.5, 2.5, 4] against [4, 3, 2, 1].
    assert!((spearman(&[1.0, 2.0, 3.0], &[10.0, 20.0, 30.0]).unwrap() - 1.0).abs() < 1e-15);
    let rho = spearman(&[1.0, 2.0, 2.0, 3.0], &[4.0, 3.0, 2.0, 1.0]).unwrap();
    assert!((rho + 0.9486832980505138).abs() < 1e-12, "{rho}");
    assert!(matches!(
        spearman(&[1.0, 1.0], &[1.0, 2.0]),
        Err(Error::ZeroVariance { .. })
    ));
    assert!(spearman(&[1.0], &[1.0]).is_err());
    assert!(spearman(&[1.0, 2.0], &[1.0]).is_err());
}

#[test]
fn grid_cost_counts_eq_6_1_terms() {
    // Two labels with 3 and 1 items on a 2×2 grid: 4 slots, label 1 has one item so its share
    // is 1 and label 0 takes the other 3.
    let labels = [0, 0, 0, 1];
    let mut grid = Grid::empty(2, 2);
    grid.nodes[0].shown = Some(0);
    grid.nodes[0].hidden = vec![1, 2, 3];
    grid.nodes[0].state = NodeState::Multi;
    let c = cost(&grid, &labels).unwrap();
    // Shown: label 0 once (ideal 3), label 1 never (ideal 1): imbalance 2 + 1.
    assert_eq!((c.empty, c.multi, c.imbalance, c.total), (3, 1, 3.0, 7.0));
    // Eight items of three labels (5, 2, 1) on 4 slots: shares t = 1.5, 1.5, 1.
    let shares = super::cost::ideal_shares(&[0, 0, 0, 0, 0, 1, 1, 2], 4);
    assert_eq!(shares[&2], (1.0, 1));
    assert_eq!(shares[&0], (1.5, 2));
    assert_eq!(shares[&1], (1.5, 1));
    assert!(cost(&grid, &[0, 0]).is_err());
}

#[test]
fn grid_rejects_bad_inputs() {
    let p = random_points(10, 2, 1);
    assert!(matches!(
        som(&p, 2, &SomParams::new(0, 3)),
        Err(Error::BadGridShape { .. })
    ));
    assert!(matches!(
        som(&p, 2, &SomParams::new(501, 500)),
        Err(Error::BadGridShape { .. })
    ));
    assert!(matches!(
        random_layout(3, 3, 0, 1),
        Err(Error::BadGridShape { .. })
    ));
    let mut bad = p.clone();
    bad[5] = f32::NAN;
    assert!(matches!(
        som(&bad, 2, &SomParams::new(2, 2)),
        Err(Error::BadCoordinate {
            row: 2,
            column: 1,
            ..
        })
    ));
    assert!(matches!(
        som(&p[..5], 2, &SomParams::new(2, 2)),
        Err(Error::NotAMatrix { .. })
    ));
    assert!(matches!(
        som(&[], 2, &SomParams::new(2, 2)),
        Err(Error::NotEnoughData { .. })
    ));
    let mut sp = SomParams::new(2, 2);
    sp.epochs = 0;
    assert!(matches!(
        som(&p, 2, &sp),
        Err(Error::InvalidParameter { name: "epochs", .. })
    ));
    sp = SomParams::new(2, 2);
    sp.alpha0 = 1.5;
    assert!(som(&p, 2, &sp).is_err());
    sp = SomParams::new(2, 2);
    sp.sigma0 = Some(f64::NAN);
    assert!(som(&p, 2, &sp).is_err());
    let map = som(&p, 2, &SomParams::new(2, 2)).unwrap();
    assert!(matches!(
        balance(&p, 2, &[0; 9], &map, &BalanceParams::default()),
        Err(Error::LengthMismatch {
            expected: 10,
            got: 9,
            ..
        })
    ));
    assert!(balance(&p[..8], 2, &[0; 4], &map, &BalanceParams::default()).is_err());
    assert!(matches!(
        isomatch(&p[..4], 2, &IsoMatchParams::new(2, 2)),
        Err(Error::NotEnoughData { .. })
    ));
    assert!(matches!(
        isomatch(
            &random_points(6000, 2, 1),
            2,
            &IsoMatchParams::new(100, 100)
        ),
        Err(Error::BadGridShape { .. })
    ));
    let grid = random_layout(10, 3, 3, 1).unwrap();
    assert!(
        dpq(
            &p,
            2,
            &grid,
            &QualityParams {
                p: 0.0,
                ..QualityParams::default()
            }
        )
        .is_err()
    );
    assert!(layout_spearman(&p[..8], 2, &grid, &QualityParams::default()).is_err());
}

#[test]
fn grid_exports_ids_and_labels() {
    let grid = random_layout(5, 2, 2, 3).unwrap();
    let ids: Vec<String> = (0..5).map(|i| format!("item{i}")).collect();
    let labels: Vec<String> = (0..5).map(|i| format!("l{}", i % 2)).collect();
    let out = grid.export(&ids, &labels).unwrap();
    let json = serde_json::to_value(&out).unwrap();
    assert_eq!(json["rows"], 2);
    let node = &json["nodes"][0];
    for key in ["row", "col", "id", "label", "state", "hidden"] {
        assert!(node.get(key).is_some(), "{key} missing");
    }
    assert_eq!(node["state"], "single");
    let hidden: usize = out.nodes.iter().map(|x| x.hidden.len()).sum();
    assert_eq!(hidden, 1);
    assert!(grid.export(&ids[..4], &labels[..4]).is_err());
    assert!(grid.export(&ids, &labels[..4]).is_err());
}
