//! The trained metric as stored in `model.json`: feature names, standardisation, weights, λ,
//! the cross-validation table, solver info and a hash of the training data.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::cv::CvReport;
use super::objective::sigmoid;
use super::solver::SolverInfo;
use crate::table::{FeatureTable, create, open};
use crate::{Error, Result};

/// Current `model.json` format.
pub const MODEL_FORMAT: u32 = 1;

/// Where the training data came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataInfo {
    /// SHA-256 (hex) over the training triplets and the feature rows they use, in a canonical
    /// binary form (ids, little-endian `f64`s, answers), so it identifies the data, not the file
    /// formatting.
    pub sha256: String,
    /// Items used by the training triplets.
    pub items: usize,
    /// Training triplets.
    pub triplets: usize,
    /// Rows skipped as invalid when reading.
    pub skipped: usize,
}

/// A learned style metric (eqs. 5.5–5.6 over standardised features).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// File format version.
    pub format: u32,
    /// Feature names, in column order.
    pub feature_names: Vec<String>,
    /// Per-feature mean used for standardisation (over the training items).
    pub mean: Vec<f64>,
    /// Per-feature scale (standard deviation; 1 for constant features).
    pub scale: Vec<f64>,
    /// Final weights `w` (after zeroing those below `zero_threshold`).
    pub weights: Vec<f64>,
    /// Weights as the solver returned them.
    pub raw_weights: Vec<f64>,
    /// λ of eq. 5.8.
    pub lambda: f64,
    /// Weights below this were set to zero (paper: 0.02).
    pub zero_threshold: f64,
    /// Number of non-zero weights.
    pub nonzero: usize,
    /// `ε` of the smoothed root.
    pub smoothing: f64,
    /// The scale `c` of the uniform baseline metric `w = c·1`, fitted by maximum likelihood on
    /// the training triplets (accuracy does not depend on `c`, perplexity does).
    pub uniform_scale: f64,
    /// The λ search, when λ was chosen automatically.
    pub cv: Option<CvReport>,
    /// The final fit.
    pub solver: SolverInfo,
    /// The training data.
    pub data: DataInfo,
}

/// Standardised features of a table, in the table's row order, ready for the objective.
#[derive(Debug, Clone, PartialEq)]
pub struct Standardised {
    /// Row-major `(x − mean) / scale`.
    pub x: Vec<f64>,
    /// Columns.
    pub dim: usize,
}

/// Mean and standard deviation of each column over `rows` (all rows when `rows` is empty);
/// constant columns get scale 1 so they standardise to 0 instead of NaN.
pub fn fit_scaling(table: &FeatureTable, rows: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let p = table.dim();
    let all: Vec<usize>;
    let rows = if rows.is_empty() {
        all = (0..table.len()).collect();
        &all
    } else {
        rows
    };
    let n = rows.len() as f64;
    let mut mean = vec![0.0; p];
    for &i in rows {
        for (m, v) in mean.iter_mut().zip(table.row(i)) {
            *m += v / n;
        }
    }
    let mut var = vec![0.0; p];
    for &i in rows {
        for ((s, v), m) in var.iter_mut().zip(table.row(i)).zip(&mean) {
            *s += (v - m) * (v - m) / n;
        }
    }
    let scale = var
        .into_iter()
        .map(|v| {
            let s = v.sqrt();
            if s > 1e-12 { s } else { 1.0 }
        })
        .collect();
    (mean, scale)
}

/// Standardises every row of `table` with `mean` and `scale`.
pub fn standardise(table: &FeatureTable, mean: &[f64], scale: &[f64]) -> Standardised {
    let p = table.dim();
    let mut x = Vec::with_capacity(table.len() * p);
    for i in 0..table.len() {
        x.extend(
            table
                .row(i)
                .iter()
                .zip(mean)
                .zip(scale)
                .map(|((v, m), s)| (v - m) / s),
        );
    }
    Standardised { x, dim: p }
}

impl Model {
    /// Checks that `table` has exactly the model's feature columns, then standardises it.
    pub fn standardise(&self, table: &FeatureTable) -> Result<Standardised> {
        self.check_columns(table.names())?;
        Ok(standardise(table, &self.mean, &self.scale))
    }

    /// Fails with [`Error::FeatureMismatch`], naming the first difference, unless `names` are
    /// exactly the model's feature columns in order.
    pub fn check_columns(&self, names: &[String]) -> Result<()> {
        if names == self.feature_names.as_slice() {
            return Ok(());
        }
        let message = if names.len() != self.feature_names.len() {
            format!(
                "model has {} features, file has {}",
                self.feature_names.len(),
                names.len()
            )
        } else {
            let k = (0..names.len())
                .find(|&k| names[k] != self.feature_names[k])
                .unwrap_or(0);
            format!(
                "column {} is `{}` in the file but `{}` in the model",
                k + 2,
                names[k],
                self.feature_names[k]
            )
        };
        Err(Error::FeatureMismatch { message })
    }

    /// The learned distance (eq. 5.5) between two raw feature vectors.
    pub fn distance(&self, x: &[f64], y: &[f64]) -> f64 {
        weighted_distance(&self.weights, &self.scale, x, y)
    }

    /// `P(x is closer to y than to z)` (eq. 5.6) on raw feature vectors.
    pub fn probability(&self, x: &[f64], y: &[f64], z: &[f64]) -> f64 {
        sigmoid(self.distance(x, z) - self.distance(x, y))
    }

    /// Reads `model.json`.
    pub fn load(path: &Path) -> Result<Self> {
        let model: Model =
            serde_json::from_reader(std::io::BufReader::new(open(path)?)).map_err(|source| {
                Error::Json {
                    path: path.to_path_buf(),
                    source,
                }
            })?;
        let p = model.feature_names.len();
        if [model.mean.len(), model.scale.len(), model.weights.len()] != [p, p, p] {
            return Err(Error::FeatureMismatch {
                message: format!(
                    "{}: {p} names but {} means, {} scales, {} weights",
                    path.display(),
                    model.mean.len(),
                    model.scale.len(),
                    model.weights.len()
                ),
            });
        }
        Ok(model)
    }

    /// Writes `model.json` (pretty-printed).
    pub fn save(&self, path: &Path) -> Result<()> {
        let w = std::io::BufWriter::new(create(path)?);
        serde_json::to_writer_pretty(w, self).map_err(|source| Error::Json {
            path: path.to_path_buf(),
            source,
        })
    }
}

/// `sqrt(Σ w_k ((x_k − y_k) / scale_k)²)` on raw vectors (the mean cancels).
pub fn weighted_distance(w: &[f64], scale: &[f64], x: &[f64], y: &[f64]) -> f64 {
    w.iter()
        .zip(scale)
        .zip(x.iter().zip(y))
        .map(|((w, s), (a, b))| w * ((a - b) / s).powi(2))
        .sum::<f64>()
        .sqrt()
}
