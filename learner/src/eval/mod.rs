//! Evaluating a learned metric: triplet accuracy and perplexity (eq. 5.9 of Garces et al. 2014)
//! and retrieval metrics (2016 exploration paper, §6.4.1), each beside two baselines.
//!
//! Baselines:
//! * **uniform**: `w = c·1` on the same standardised features, with `c` the model's
//!   [`Model::uniform_scale`] (maximum likelihood on the training triplets; accuracy and
//!   rankings do not depend on `c`, perplexity does, and an unfitted `c = 1` would make it
//!   look needlessly bad);
//! * **random**: the chance predictor `P(q) = ½` for every answer — what random guessing earns
//!   in expectation: accuracy exactly 0.5 (ties count half) and perplexity exactly 2.

pub mod rank;
pub mod report;
pub mod triplets;

use std::collections::HashMap;

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::metric::Model;
use crate::metric::objective::TripletObjective;
use crate::table::{FeatureTable, Label};
use crate::triplets::Triplet;
use crate::{Error, Result};
use rank::{RankScores, rank_queries};
use triplets::{BootstrapParams, MethodScores, probabilities, score};

/// Triplet scores of the model and the baselines.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// The learned metric.
    pub learned: MethodScores,
    /// Uniform weights.
    pub uniform: MethodScores,
    /// Chance.
    pub random: MethodScores,
}

/// `P(q = 1)` for every triplet under weights `w` on the model's standardisation of `table`.
pub fn predict(
    model: &Model,
    table: &FeatureTable,
    triplets: &[Triplet],
    w: &[f64],
) -> Result<Vec<f64>> {
    let std = model.standardise(table)?;
    let obj = TripletObjective::new(&std.x, std.dim, triplets, 0.0, model.smoothing);
    Ok(probabilities(&obj.margins(w)))
}

/// Accuracy and perplexity, raw and majority, with bootstrap intervals, for the model, uniform
/// weights and chance.
pub fn evaluate(
    model: &Model,
    table: &FeatureTable,
    triplets: &[Triplet],
    params: &BootstrapParams,
) -> Result<EvalReport> {
    let learned = predict(model, table, triplets, &model.weights)?;
    let uniform = predict(
        model,
        table,
        triplets,
        &vec![model.uniform_scale; model.weights.len()],
    )?;
    let chance = vec![0.5; triplets.len()];
    Ok(EvalReport {
        learned: score(triplets, &learned, params)?,
        uniform: score(triplets, &uniform, params)?,
        random: score(triplets, &chance, params)?,
    })
}

/// Ranking table of the learned and the uniform metric.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankReport {
    /// The learned metric.
    pub learned: RankScores,
    /// Uniform weights.
    pub uniform: RankScores,
    /// Items ranked (labelled items present in the features file).
    pub items: usize,
    /// Labelled items missing from the features file (ignored).
    pub missing: usize,
    /// Distinct style labels.
    pub styles: usize,
}

/// Ranks the labelled items of `table` by the model's distance and by the uniform distance.
/// With `max_queries`, a seeded random subset of items serve as queries (all items are still
/// ranked for each).
pub fn rank(
    model: &Model,
    table: &FeatureTable,
    labels: &[Label],
    max_queries: Option<usize>,
    seed: u64,
) -> Result<RankReport> {
    let std = model.standardise(table)?;
    let mut rows = Vec::new();
    let mut classes = Vec::new();
    let mut style_ids: HashMap<&str, u32> = HashMap::new();
    let mut missing = 0;
    for l in labels {
        match table.index_of(&l.id) {
            Some(i) => {
                rows.push(i);
                let n = style_ids.len() as u32;
                classes.push(*style_ids.entry(l.style.as_str()).or_insert(n));
            }
            None => missing += 1,
        }
    }
    if rows.len() < 3 || style_ids.len() < 2 {
        return Err(Error::NotEnoughData {
            what: "ranking (labelled items in the features file, in two styles)",
            needed: 3,
            got: rows.len(),
        });
    }
    let scaled = |w: &[f64]| -> (Vec<f64>, usize) {
        let keep: Vec<usize> = (0..w.len()).filter(|&k| w[k] > 0.0).collect();
        let mut y = Vec::with_capacity(rows.len() * keep.len());
        for &i in &rows {
            let x = &std.x[i * std.dim..(i + 1) * std.dim];
            y.extend(keep.iter().map(|&k| x[k] * w[k].sqrt()));
        }
        (y, keep.len())
    };
    let mut queries: Vec<usize> = (0..rows.len()).collect();
    if let Some(m) = max_queries
        && m < queries.len()
    {
        queries.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        queries.truncate(m);
        queries.sort_unstable();
    }
    let (yl, dl) = scaled(&model.weights);
    let (yu, du) = scaled(&vec![1.0; model.weights.len()]);
    let learned = if dl == 0 {
        // Every weight zeroed: all distances tie; rank by index like any tie.
        rank_queries(&vec![0.0; rows.len()], 1, &classes, &queries)
    } else {
        rank_queries(&yl, dl, &classes, &queries)
    };
    Ok(RankReport {
        learned,
        uniform: rank_queries(&yu, du, &classes, &queries),
        items: rows.len(),
        missing,
        styles: style_ids.len(),
    })
}
