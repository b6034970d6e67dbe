//! Training: standardise, choose λ, fit, zero small weights (§5.6).

use sha2::{Digest, Sha256};

use super::cv::{CvParams, CvReport, cross_validate, default_grid, zero_small};
use super::model::{DataInfo, MODEL_FORMAT, Model, fit_scaling, standardise};
use super::objective::{DEFAULT_SMOOTHING, FusedObjective, TripletObjective};
use super::solver::{CurvatureMemory, LbfgsParams, SolverKind, minimise_warm};
use crate::table::FeatureTable;
use crate::triplets::{Triplet, TripletSet};
use crate::{Error, Result};

/// How λ is set.
#[derive(Debug, Clone, PartialEq)]
pub enum LambdaChoice {
    /// This λ.
    Fixed(f64),
    /// Cross-validation over this grid (`None`: [`default_grid`] with `grid_size` values).
    Auto(Option<Vec<f64>>),
}

/// Training parameters; `Default` follows the paper where it says something.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainParams {
    /// λ of eq. 5.8. Default: cross-validated.
    pub lambda: LambdaChoice,
    /// Cross-validation folds. Default 5.
    pub folds: usize,
    /// Size of the default λ grid. Default 8.
    pub grid_size: usize,
    /// λ values the search may add a decade beyond each end of the grid when the choice sits
    /// there ([`cross_validate`]). Default 3 (the default grid then reaches `n · [10⁻⁸, 10²]`).
    pub max_grid_extensions: usize,
    /// Bootstrap resamples for the intervals of the held-out agreement
    /// ([`CvReport::agreement`]). Default 1000.
    pub bootstrap_resamples: usize,
    /// Seed for fold assignment. Default 0.
    pub seed: u64,
    /// Optimiser. Default argmin.
    pub solver: SolverKind,
    /// Stopping rules of the final fit.
    pub lbfgs: LbfgsParams,
    /// Stopping rules of the cross-validation fits. Default: `ftol` 1e-6 — held-out losses of
    /// neighbouring λ differ by ≥ 5·10⁻³ relative near the chosen λ, and solving the folds to
    /// 1e-8 instead moved them by ≤ 4·10⁻⁴ relative (≤ 10⁻⁵ near the chosen λ), never changed
    /// the choice, and cost 30% more passes (dev set, 50,000 triplets).
    pub cv_lbfgs: LbfgsParams,
    /// Weights below this are set to zero after training. Paper (§5.6): 0.02.
    pub zero_threshold: f64,
}

impl Default for TrainParams {
    fn default() -> Self {
        Self {
            lambda: LambdaChoice::Auto(None),
            folds: 5,
            grid_size: 8,
            max_grid_extensions: 3,
            bootstrap_resamples: 1000,
            seed: 0,
            solver: SolverKind::Argmin,
            lbfgs: LbfgsParams::default(),
            cv_lbfgs: LbfgsParams {
                ftol: 1e-6,
                ..LbfgsParams::default()
            },
            zero_threshold: 0.02,
        }
    }
}

impl TrainParams {
    /// Checks ranges.
    pub fn validate(&self) -> Result<()> {
        self.lbfgs.validate()?;
        self.cv_lbfgs.validate()?;
        if let LambdaChoice::Fixed(l) = self.lambda
            && !(l >= 0.0 && l.is_finite())
        {
            return Err(Error::InvalidParameter {
                name: "lambda",
                value: l.to_string(),
                reason: "must be finite and ≥ 0",
            });
        }
        if self.folds < 2 {
            return Err(Error::InvalidParameter {
                name: "folds",
                value: self.folds.to_string(),
                reason: "need at least 2",
            });
        }
        if self.grid_size == 0 {
            return Err(Error::InvalidParameter {
                name: "grid_size",
                value: "0".into(),
                reason: "need at least 1",
            });
        }
        if self.zero_threshold.is_nan() || self.zero_threshold < 0.0 {
            return Err(Error::InvalidParameter {
                name: "zero_threshold",
                value: self.zero_threshold.to_string(),
                reason: "must be ≥ 0",
            });
        }
        Ok(())
    }
}

/// Progress of [`train`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrainProgress {
    /// A cross-validation fit finished.
    Cv {
        /// Fits done.
        done: usize,
        /// Fits in total.
        total: usize,
    },
    /// A fit on the whole data along the λ path up to the chosen λ finished.
    Path {
        /// Fits done.
        done: usize,
        /// Fits in total.
        total: usize,
    },
    /// An iteration of the final fit.
    Final {
        /// Iteration.
        iteration: u64,
        /// Objective.
        objective: f64,
    },
}

/// Maximum-likelihood scale `c` of the uniform metric `w = c·1` (no regulariser): the root of
/// `h(t) = dE/dt` for `t = ln c` (`h = c ∇E(c·1)·1`), bracketed by decades from `c = 1` and
/// refined by Illinois false position to `|Δt| < 10⁻⁴` — typically under ten evaluations. The
/// likelihood along the ray is unimodal in practice; if no sign change appears within
/// `c ∈ [10⁻⁸, 10⁸]` the end with the smaller slope magnitude is returned.
pub fn fit_uniform_scale(x: &[f64], dim: usize, triplets: &[Triplet]) -> f64 {
    let obj = TripletObjective::new(x, dim, triplets, 0.0, DEFAULT_SMOOTHING);
    let mut g = vec![0.0; dim];
    let mut h = |t: f64| {
        let c = t.exp();
        obj.eval(&vec![c; dim], &mut g);
        c * g.iter().sum::<f64>()
    };
    let step = 10f64.ln();
    let (mut a, mut ha) = (0.0, h(0.0));
    let dir = if ha > 0.0 { -1.0 } else { 1.0 };
    let (mut b, mut hb) = (a, ha);
    for _ in 0..8 {
        b = a + dir * step;
        hb = h(b);
        if hb.signum() != ha.signum() {
            break;
        }
        (a, ha) = (b, hb);
    }
    if hb.signum() == ha.signum() {
        return if hb.abs() < ha.abs() {
            b.exp()
        } else {
            a.exp()
        };
    }
    // Illinois false position on [a, b] with h(a), h(b) of opposite signs.
    let mut side = 0i8;
    for _ in 0..60 {
        if (b - a).abs() < 1e-4 {
            break;
        }
        let t = (a * hb - b * ha) / (hb - ha);
        let ht = h(t);
        if ht == 0.0 {
            return t.exp();
        }
        if ht.signum() == hb.signum() {
            (b, hb) = (t, ht);
            if side == -1 {
                ha *= 0.5;
            }
            side = -1;
        } else {
            (a, ha) = (t, ht);
            if side == 1 {
                hb *= 0.5;
            }
            side = 1;
        }
    }
    (0.5 * (a + b)).exp()
}

/// SHA-256 over the triplets and the feature rows they reference (canonical binary form).
pub fn data_hash(table: &FeatureTable, triplets: &[Triplet]) -> String {
    let mut h = Sha256::new();
    let mut used: Vec<u32> = triplets.iter().flat_map(|t| [t.a, t.b, t.c]).collect();
    used.sort_unstable();
    used.dedup();
    for name in table.names() {
        h.update(name.as_bytes());
        h.update([0]);
    }
    for &i in &used {
        h.update(table.ids()[i as usize].as_bytes());
        h.update([0]);
        for v in table.row(i as usize) {
            h.update(v.to_le_bytes());
        }
    }
    for t in triplets {
        for i in [t.a, t.b, t.c] {
            h.update(table.ids()[i as usize].as_bytes());
            h.update([0]);
        }
        h.update([t.q as u8]);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// Trains a metric on `set` (triplets over rows of `table`). `progress` reports CV fits and
/// final-fit iterations; the library never prints.
pub fn train(
    table: &FeatureTable,
    set: &TripletSet,
    params: &TrainParams,
    progress: &mut dyn FnMut(TrainProgress),
) -> Result<Model> {
    params.validate()?;
    let triplets = &set.triplets;
    if triplets.is_empty() {
        return Err(Error::NotEnoughData {
            what: "training triplets",
            needed: 1,
            got: 0,
        });
    }
    let mut used: Vec<usize> = triplets
        .iter()
        .flat_map(|t| [t.a as usize, t.b as usize, t.c as usize])
        .collect();
    used.sort_unstable();
    used.dedup();
    let (mean, scale) = fit_scaling(table, &used);
    let std = standardise(table, &mean, &scale);
    let dim = std.dim;
    let uniform_scale = fit_uniform_scale(&std.x, dim, triplets);
    let w0 = vec![uniform_scale; dim];

    let (lambda, cv): (f64, Option<CvReport>) = match &params.lambda {
        LambdaChoice::Fixed(l) => (*l, None),
        LambdaChoice::Auto(grid) => {
            let grid = grid
                .clone()
                .unwrap_or_else(|| default_grid(triplets.len(), params.grid_size));
            let report = cross_validate(
                &std.x,
                dim,
                triplets,
                &w0,
                &CvParams {
                    folds: params.folds,
                    grid,
                    by_worker: set.has_workers,
                    seed: params.seed,
                    solver: params.solver,
                    lbfgs: params.cv_lbfgs,
                    zero_threshold: params.zero_threshold,
                    max_extensions: params.max_grid_extensions,
                    resamples: params.bootstrap_resamples,
                },
                &mut |done, total| progress(TrainProgress::Cv { done, total }),
            )?;
            (report.chosen, Some(report))
        }
    };
    // With a cross-validated λ the final fit walks the same path as every fold did: the
    // searched λ below the chosen one in increasing order, each warm-started from the last
    // (weights and curvature memory), with the folds' stopping rule. Eq. 5.8 is not convex
    // (the distances are square roots), and started cold from the uniform metric at a large λ
    // the fit can fall to a different, much sparser optimum than the one the held-out scores
    // describe (the issue-16 demo: 5 weights in every fold at λ = 76.5, none in the final fit).
    let mut memory = CurvatureMemory::default();
    let mut start = w0;
    if let Some(cv) = &cv {
        let path: Vec<f64> = cv
            .rows
            .iter()
            .map(|r| r.lambda)
            .filter(|&l| l < lambda)
            .collect();
        for (i, &l) in path.iter().enumerate() {
            let obj = TripletObjective::new(&std.x, dim, triplets, l, DEFAULT_SMOOTHING);
            let (w, _) = minimise_warm(
                params.solver,
                obj,
                start,
                &params.cv_lbfgs,
                &mut memory,
                &mut |_, _| {},
            )?;
            start = w;
            progress(TrainProgress::Path {
                done: i + 1,
                total: path.len(),
            });
        }
    }
    let obj = TripletObjective::new(&std.x, dim, triplets, lambda, DEFAULT_SMOOTHING);
    debug_assert_eq!(obj.dim(), dim);
    let (raw, info) = minimise_warm(
        params.solver,
        obj,
        start,
        &params.lbfgs,
        &mut memory,
        &mut |iteration, objective| {
            progress(TrainProgress::Final {
                iteration,
                objective,
            })
        },
    )?;
    let weights = zero_small(&raw, params.zero_threshold);
    Ok(Model {
        format: MODEL_FORMAT,
        feature_names: table.names().to_vec(),
        mean,
        scale,
        nonzero: weights.iter().filter(|v| **v > 0.0).count(),
        weights,
        raw_weights: raw,
        lambda,
        zero_threshold: params.zero_threshold,
        smoothing: DEFAULT_SMOOTHING,
        uniform_scale,
        cv,
        solver: info,
        data: DataInfo {
            sha256: data_hash(table, triplets),
            items: used.len(),
            triplets: triplets.len(),
            skipped: set.skipped,
        },
    })
}
