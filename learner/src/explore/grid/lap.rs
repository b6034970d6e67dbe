//! Exact rectangular linear assignment (`n` rows to distinct columns among `m ≥ n`, least total
//! cost), for the IsoMatch baseline (Fried et al. 2015, "IsoMatch: Creating Informative Grid
//! Layouts", which assigns items to grid cells with the Hungarian method).
//!
//! The solver is the shortest-augmenting-path method of Jonker & Volgenant (1987) in the form of
//! Crouse (2016), "On implementing 2D rectangular assignment algorithms", Algorithm 1 (the one
//! behind `scipy.optimize.linear_sum_assignment`): rows are added one at a time; each addition
//! runs Dijkstra on reduced costs `c_ij − u_i − v_j` from the new row to an unassigned column,
//! updates the dual potentials `u, v` so reduced costs stay non-negative, and flips the path.
//! O(n²m) time, O(nm) for the cost matrix the caller holds.

use crate::{Error, Result};

/// The optimal assignment: `col[i]` for row `i`, and its total cost.
#[derive(Clone, Debug, PartialEq)]
pub struct Assignment {
    /// Column of each row.
    pub col: Vec<usize>,
    /// `Σ_i cost[i][col[i]]`.
    pub total: f64,
}

/// Solves `min Σ_i cost[i·m + col[i]]` over injective `col` for a row-major `n × m` matrix.
///
/// Errors: `n > m`, a length that is not `n·m`, or a cost that is not finite.
pub fn linear_assignment(cost: &[f64], n: usize, m: usize) -> Result<Assignment> {
    let bad = |reason: String| Error::BadAssignment {
        rows: n,
        cols: m,
        reason,
    };
    if n > m {
        return Err(bad("more rows than columns".into()));
    }
    if n.checked_mul(m) != Some(cost.len()) {
        return Err(bad(format!("{} costs given", cost.len())));
    }
    if let Some(k) = cost.iter().position(|c| !c.is_finite()) {
        return Err(bad(format!(
            "cost[{}][{}] = {} is not finite",
            k / m,
            k % m,
            cost[k]
        )));
    }
    const NONE: usize = usize::MAX;
    let mut u = vec![0.0f64; n];
    let mut v = vec![0.0f64; m];
    let mut shortest = vec![f64::INFINITY; m];
    let mut path = vec![NONE; m];
    let mut col4row = vec![NONE; n];
    let mut row4col = vec![NONE; m];
    let mut seen_row = vec![false; n];
    let mut seen_col = vec![false; m];
    let mut remaining = vec![0usize; m];
    for current in 0..n {
        // Dijkstra from `current` over the columns not yet reached.
        shortest.iter_mut().for_each(|s| *s = f64::INFINITY);
        seen_row.iter_mut().for_each(|s| *s = false);
        seen_col.iter_mut().for_each(|s| *s = false);
        for (k, r) in remaining.iter_mut().enumerate() {
            *r = m - 1 - k;
        }
        let mut left = m;
        let mut min_val = 0.0f64;
        let mut i = current;
        let sink = loop {
            seen_row[i] = true;
            let row = &cost[i * m..(i + 1) * m];
            let (ui, mut lowest, mut index) = (u[i], f64::INFINITY, NONE);
            for (k, &j) in remaining[..left].iter().enumerate() {
                let r = min_val + row[j] - ui - v[j];
                if r < shortest[j] {
                    path[j] = i;
                    shortest[j] = r;
                }
                // Prefer a free column on ties: the path ends sooner.
                if shortest[j] < lowest || (shortest[j] == lowest && row4col[j] == NONE) {
                    lowest = shortest[j];
                    index = k;
                }
            }
            min_val = lowest;
            let j = remaining[index];
            seen_col[j] = true;
            left -= 1;
            remaining[index] = remaining[left];
            if row4col[j] == NONE {
                break j;
            }
            i = row4col[j];
        };
        // Dual update keeps every reduced cost non-negative and the path's edges tight.
        u[current] += min_val;
        for r in 0..n {
            if seen_row[r] && r != current {
                u[r] += min_val - shortest[col4row[r]];
            }
        }
        for c in 0..m {
            if seen_col[c] {
                v[c] -= min_val - shortest[c];
            }
        }
        let mut j = sink;
        loop {
            let r = path[j];
            row4col[j] = r;
            std::mem::swap(&mut col4row[r], &mut j);
            if r == current {
                break;
            }
        }
    }
    let total = col4row
        .iter()
        .enumerate()
        .map(|(i, &j)| cost[i * m + j])
        .sum();
    Ok(Assignment {
        col: col4row,
        total,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The least total over every injective map of rows to columns.
    fn brute(cost: &[f64], n: usize, m: usize) -> f64 {
        fn go(cost: &[f64], n: usize, m: usize, i: usize, used: &mut [bool], acc: f64) -> f64 {
            if i == n {
                return acc;
            }
            let mut best = f64::INFINITY;
            for j in 0..m {
                if !used[j] {
                    used[j] = true;
                    best = best.min(go(cost, n, m, i + 1, used, acc + cost[i * m + j]));
                    used[j] = false;
                }
            }
            best
        }
        go(cost, n, m, 0, &mut vec![false; m], 0.0)
    }

    #[test]
    fn grid_lap_matches_brute_force_on_small_matrices() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for case in 0..300 {
            let n = rng.random_range(1..=6);
            let m = rng.random_range(n..=7);
            // Small integers make ties common, the hard case for augmenting paths.
            let integers = case % 2 == 0;
            let cost: Vec<f64> = (0..n * m)
                .map(|_| {
                    if integers {
                        rng.random_range(0..4) as f64
                    } else {
                        rng.random_range(-5.0..5.0)
                    }
                })
                .collect();
            let a = linear_assignment(&cost, n, m).unwrap();
            let mut used = vec![false; m];
            for &j in &a.col {
                assert!(!used[j], "column {j} used twice");
                used[j] = true;
            }
            let best = brute(&cost, n, m);
            assert!(
                (a.total - best).abs() < 1e-9,
                "case {case}: {} vs {best}",
                a.total
            );
        }
    }

    #[test]
    fn grid_lap_rejects_bad_problems() {
        assert!(matches!(
            linear_assignment(&[1.0, 2.0], 2, 1),
            Err(Error::BadAssignment { .. })
        ));
        assert!(linear_assignment(&[1.0, 2.0, 3.0], 2, 2).is_err());
        assert!(linear_assignment(&[1.0, f64::NAN, 3.0, 4.0], 2, 2).is_err());
        assert_eq!(
            linear_assignment(&[], 0, 3).unwrap().col,
            Vec::<usize>::new()
        );
    }
}
