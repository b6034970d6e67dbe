//! The search itself: every fold's warm-started λ path, the grid's extensions, the uniform
//! baseline and the out-of-fold agreement (see the [module docs](super)).

use super::agreement::{self, HeldOutAgreement, Scored};
use super::choice::{self, Choice, CvWarning, Edge, mean_and_se};
use super::{
    Baseline, CvParams, CvReport, CvRow, assign_folds, credits, group_of, held_out_scores,
    zero_small,
};
use crate::metric::objective::{DEFAULT_SMOOTHING, FusedObjective, TripletObjective};
use crate::metric::solver::{CurvatureMemory, minimise_warm};
use crate::metric::train::fit_uniform_scale;
use crate::triplets::Triplet;
use crate::{Error, Result};

/// One fold's data and where its λ path stands at both ends of the grid.
struct Fold {
    train: Vec<Triplet>,
    test: Vec<Triplet>,
    /// Solver output at the largest λ fitted so far (the warm start of the next one).
    high: Vec<f64>,
    /// The fold's data term is the same for every λ (only the linear L1 term changes), so the
    /// solver's curvature memory carries over along the path, like the weights.
    memory: CurvatureMemory,
    /// Maximum-likelihood scale of the uniform metric on `train`.
    uniform_scale: f64,
}

/// Scores of one fit: held-out log-loss, accuracy, non-zero weights, the zeroed weights.
type FoldFit = (f64, f64, usize, Vec<f64>);

struct Search<'a> {
    x: &'a [f64],
    dim: usize,
    params: &'a CvParams,
    /// The uniform start of every path.
    w0: &'a [f64],
    folds: Vec<Fold>,
    /// Increasing λ, and per λ the fits of every fold in fold order.
    lambdas: Vec<f64>,
    fits: Vec<Vec<FoldFit>>,
    evaluations: u64,
    done: usize,
}

impl Search<'_> {
    /// Fits `lambda` in every fold and puts the result at the `from` end of the table. Upwards
    /// the fit is warm-started from the fold's path (weights and curvature memory); a λ below
    /// the grid starts afresh from the uniform metric, as the grid's first λ did: from the
    /// sparser solution of a larger λ the weights have a long way to grow along directions the
    /// loss barely falls in, and the CV fits' `ftol` stops them short (on a sharp, dense
    /// problem the warm-started fit a decade down scored worse than the λ above it).
    fn fit(&mut self, lambda: f64, from: Edge, on_fit: &mut dyn FnMut(usize, usize)) -> Result<()> {
        let mut fits = Vec::with_capacity(self.folds.len());
        let total = self.done + self.folds.len();
        for fold in &mut self.folds {
            let mut fresh = CurvatureMemory::default();
            let (start, memory) = match from {
                Edge::Lower => (self.w0.to_vec(), &mut fresh),
                Edge::Upper => (fold.high.clone(), &mut fold.memory),
            };
            let obj =
                TripletObjective::new(self.x, self.dim, &fold.train, lambda, DEFAULT_SMOOTHING);
            debug_assert_eq!(obj.dim(), self.dim);
            let (wf, info) = minimise_warm(
                self.params.solver,
                obj,
                start,
                &self.params.lbfgs,
                memory,
                &mut |_, _| {},
            )?;
            self.evaluations += info.evaluations + info.curvature_passes;
            let wz = zero_small(&wf, self.params.zero_threshold);
            let (loss, acc) = held_out_scores(self.x, self.dim, &fold.test, &wz, DEFAULT_SMOOTHING);
            let nonzero = wz.iter().filter(|v| **v > 0.0).count();
            fits.push((loss, acc, nonzero, wz));
            if from == Edge::Upper {
                fold.high = wf;
            }
            self.done += 1;
            on_fit(self.done, total);
        }
        match from {
            Edge::Lower => {
                self.lambdas.insert(0, lambda);
                self.fits.insert(0, fits);
            }
            Edge::Upper => {
                self.lambdas.push(lambda);
                self.fits.push(fits);
            }
        }
        Ok(())
    }

    fn rows(&self) -> Vec<CvRow> {
        self.lambdas
            .iter()
            .zip(&self.fits)
            .map(|(&lambda, s)| {
                let fold_log_loss: Vec<f64> = s.iter().map(|v| v.0).collect();
                let fold_accuracy: Vec<f64> = s.iter().map(|v| v.1).collect();
                let (log_loss, std_error) = mean_and_se(&fold_log_loss);
                let (accuracy, accuracy_std_error) = mean_and_se(&fold_accuracy);
                CvRow {
                    lambda,
                    log_loss,
                    perplexity: log_loss.exp(),
                    accuracy,
                    accuracy_std_error,
                    nonzero: s.iter().map(|v| v.2 as f64).sum::<f64>() / s.len() as f64,
                    std_error,
                    fold_log_loss,
                    fold_accuracy,
                }
            })
            .collect()
    }

    fn baseline(&self) -> Baseline {
        let (fold_log_loss, fold_accuracy): (Vec<f64>, Vec<f64>) = self
            .folds
            .iter()
            .map(|f| {
                let w = vec![f.uniform_scale; self.dim];
                held_out_scores(self.x, self.dim, &f.test, &w, DEFAULT_SMOOTHING)
            })
            .unzip();
        let (log_loss, std_error) = mean_and_se(&fold_log_loss);
        let (accuracy, accuracy_std_error) = mean_and_se(&fold_accuracy);
        Baseline {
            log_loss,
            perplexity: log_loss.exp(),
            accuracy,
            accuracy_std_error,
            std_error,
            fold_log_loss,
            fold_accuracy,
        }
    }

    /// Out-of-fold credits of the learned metric at λ index `li` and of the uniform metric.
    fn agreement(&self, li: usize) -> HeldOutAgreement {
        let by_worker = self.params.by_worker;
        let mut dense = std::collections::HashMap::new();
        let mut scored = Vec::new();
        for (fold, fit) in self.folds.iter().zip(&self.fits[li]) {
            let obj = TripletObjective::new(self.x, self.dim, &fold.test, 0.0, DEFAULT_SMOOTHING);
            let learned = credits(&obj.margins(&fit.3), &fold.test);
            let uniform = credits(
                &obj.margins(&vec![fold.uniform_scale; self.dim]),
                &fold.test,
            );
            for ((t, l), u) in fold.test.iter().zip(learned).zip(uniform) {
                let next = dense.len();
                let group = *dense.entry(group_of(t, by_worker)).or_insert(next);
                scored.push(Scored {
                    group,
                    learned: l,
                    uniform: u,
                });
            }
        }
        agreement::agreement(
            &scored,
            dense.len(),
            if by_worker { "worker" } else { "tuple" },
            self.params.resamples,
            self.params.seed,
        )
    }
}

/// Runs the search from starting weights `w0`. `on_fit(done, total)` after every fit (`total`
/// grows when the grid is extended).
pub fn cross_validate(
    x: &[f64],
    dim: usize,
    triplets: &[Triplet],
    w0: &[f64],
    params: &CvParams,
    on_fit: &mut dyn FnMut(usize, usize),
) -> Result<CvReport> {
    if params.grid.is_empty() || params.grid.iter().any(|l| !(*l >= 0.0 && l.is_finite())) {
        return Err(Error::InvalidParameter {
            name: "lambda grid",
            value: format!("{:?}", params.grid),
            reason: "need at least one finite λ ≥ 0",
        });
    }
    let mut grid = params.grid.clone();
    grid.sort_by(f64::total_cmp);
    grid.dedup();
    let fold_of = assign_folds(triplets, params.folds, params.by_worker, params.seed)?;
    let folds = (0..params.folds)
        .map(|f| {
            let (test, train): (Vec<(&Triplet, &usize)>, Vec<_>) =
                triplets.iter().zip(&fold_of).partition(|(_, k)| **k == f);
            let train: Vec<Triplet> = train.into_iter().map(|(t, _)| *t).collect();
            let test: Vec<Triplet> = test.into_iter().map(|(t, _)| *t).collect();
            Fold {
                uniform_scale: fit_uniform_scale(x, dim, &train),
                train,
                test,
                high: w0.to_vec(),
                memory: CurvatureMemory::default(),
            }
        })
        .collect();
    let mut search = Search {
        x,
        dim,
        params,
        w0,
        folds,
        lambdas: Vec::new(),
        fits: Vec::new(),
        evaluations: 0,
        done: 0,
    };
    // The given grid, fold by fold in increasing λ (as before extensions existed), so each
    // fold's path is one warm-started walk.
    for lambda in grid {
        search.fit(lambda, Edge::Upper, on_fit)?;
    }
    let uniform = search.baseline();
    let mut extensions = [0usize; 2];
    let (rows, choice) = loop {
        let rows = search.rows();
        let choice = choice::choose(&rows, Some(&uniform));
        let edge = choice::extension(&rows, &choice);
        match edge {
            Some(Edge::Lower) if extensions[0] < params.max_extensions => {
                extensions[0] += 1;
                search.fit(rows[0].lambda / 10.0, Edge::Lower, on_fit)?;
            }
            Some(Edge::Upper) if extensions[1] < params.max_extensions => {
                extensions[1] += 1;
                let top = rows.last().expect("rows").lambda;
                search.fit(top * 10.0, Edge::Upper, on_fit)?;
            }
            _ => break (rows, choice),
        }
    };
    let Choice {
        chosen,
        minimum,
        one_se,
        beats_uniform,
    } = choice;
    let mut warnings = Vec::new();
    let edge = choice::at_edge(&rows, &choice);
    if let Some(edge) = edge {
        warnings.push(CvWarning::AtEdge {
            edge,
            lambda: match edge {
                Edge::Lower => rows[0].lambda,
                Edge::Upper => rows[rows.len() - 1].lambda,
            },
            extensions: extensions[edge as usize],
        });
    }
    if !beats_uniform {
        let row = rows
            .iter()
            .find(|r| r.lambda == chosen)
            .expect("chosen row");
        warnings.push(CvWarning::NoBetterThanUniform {
            lambda: chosen,
            log_loss: row.log_loss,
            uniform_log_loss: uniform.log_loss,
        });
    } else if chosen != one_se {
        warnings.push(CvWarning::OneSeOverruled { one_se, chosen });
    }
    let li = search
        .lambdas
        .iter()
        .position(|&l| l == chosen)
        .expect("the chosen λ was fitted");
    let agreement = search.agreement(li);
    Ok(CvReport {
        folds: params.folds,
        grouped_by: if params.by_worker { "worker" } else { "tuple" }.into(),
        rows,
        chosen,
        minimum: Some(minimum),
        one_se: Some(one_se),
        extensions,
        at_edge: edge.is_some(),
        warnings,
        uniform: Some(uniform),
        agreement: Some(agreement),
        evaluations: search.evaluations,
    })
}

#[cfg(test)]
mod tests {
    use rand::{Rng, SeedableRng};

    use super::*;
    use crate::metric::cv::default_grid;
    use crate::metric::model::{fit_scaling, standardise};
    use crate::metric::simulate::{SimulationParams, simulate};
    use crate::metric::solver::{LbfgsParams, SolverKind};

    /// Nearly deterministic answers from a dense metric (every feature counts, the answers
    /// follow `w*` with its margins ×100): any L1 penalty only blurs the metric, so the best
    /// held-out loss lies at λ ≈ n·10⁻⁷, two decades below the default grid's `n·10⁻⁵`.
    fn sharp_dense_problem() -> (Vec<f64>, usize, Vec<Triplet>) {
        let mut sim = simulate(&SimulationParams {
            items: 200,
            dim: 5,
            support: 5,
            triplets: 2000,
            raters_per_tuple: 3,
            workers: 30,
            spammer_fraction: 0.0,
            seed: 2,
        })
        .unwrap();
        let p: Vec<f64> = sim
            .triplets
            .iter()
            .map(|t| sim.true_probability(t.a, t.b, t.c))
            .collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for (t, p) in sim.triplets.iter_mut().zip(p) {
            let margin = 100.0 * (p / (1.0 - p)).ln();
            t.q = rng.random_bool(crate::metric::objective::sigmoid(margin));
        }
        let rows: Vec<usize> = (0..sim.table.len()).collect();
        let (mean, scale) = fit_scaling(&sim.table, &rows);
        let std = standardise(&sim.table, &mean, &scale);
        (std.x, std.dim, sim.triplets)
    }

    fn search(max_extensions: usize) -> (CvReport, Vec<f64>) {
        let (x, dim, triplets) = sharp_dense_problem();
        let c = fit_uniform_scale(&x, dim, &triplets);
        let grid = default_grid(triplets.len(), 8);
        let params = CvParams {
            folds: 5,
            grid: grid.clone(),
            by_worker: true,
            seed: 0,
            solver: SolverKind::Argmin,
            lbfgs: LbfgsParams {
                ftol: 1e-6,
                ..LbfgsParams::default()
            },
            zero_threshold: 0.02,
            max_extensions,
            resamples: 200,
        };
        let mut calls = 0;
        let report = cross_validate(&x, dim, &triplets, &vec![c; dim], &params, &mut |_, _| {
            calls += 1
        })
        .unwrap();
        assert_eq!(calls, report.rows.len() * 5, "one progress call per fit");
        (report, grid)
    }

    #[test]
    fn grid_grows_below_the_default_grid_until_the_optimum_is_bracketed() {
        let (cv, grid) = search(3);
        let lowest = grid[0];
        // The old search could only take a λ of the given grid.
        assert!(
            cv.chosen < lowest / 5.0,
            "chosen {} not below the default grid (from {lowest})",
            cv.chosen
        );
        assert!(
            cv.extensions[0] >= 2 && cv.extensions[1] == 0,
            "{:?}",
            cv.extensions
        );
        assert_eq!(cv.rows.len(), grid.len() + cv.extensions[0]);
        let min = cv.minimum.unwrap();
        assert!(
            min > cv.rows[0].lambda,
            "minimum {min} still at the lower end"
        );
        assert!(!cv.at_edge, "{:?}", cv.warnings);
        assert!(cv.warnings.is_empty(), "{:?}", cv.warnings);
        // The extended rows are a decade apart, below the grid.
        for w in cv.rows[..=cv.extensions[0]].windows(2) {
            assert!((w[1].lambda / w[0].lambda - 10.0).abs() < 1e-9);
        }
        // The learned metric beats uniform weights on the held-out answers.
        let a = cv.agreement.as_ref().unwrap();
        assert_eq!(a.answers, 2000);
        assert!(a.learned.value > a.uniform.value, "{a:?}");
        assert!(cv.chosen_row().unwrap().log_loss < cv.uniform.as_ref().unwrap().log_loss);
    }

    #[test]
    fn a_choice_at_the_searched_edge_is_reported() {
        let (cv, grid) = search(1);
        assert_eq!(cv.extensions, [1, 0]);
        assert_eq!(cv.rows[0].lambda, grid[0] / 10.0);
        assert_eq!(cv.minimum, Some(cv.rows[0].lambda));
        assert!(cv.at_edge);
        assert!(
            cv.warnings.iter().any(|w| matches!(
                w,
                CvWarning::AtEdge {
                    edge: Edge::Lower,
                    extensions: 1,
                    ..
                }
            )),
            "{:?}",
            cv.warnings
        );
        // Without extensions the grid is kept as given (and the edge still reported).
        let (cv, grid) = search(0);
        assert_eq!(cv.rows.len(), grid.len());
        assert!(cv.at_edge && cv.chosen >= grid[0]);
    }
}
