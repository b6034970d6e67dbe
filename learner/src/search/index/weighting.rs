//! The weights and standardisation of eq. 5.5: a trained model's, or uniform weights over the
//! library's own standardisation (the "uniform" baseline of §5.6).

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::metric::Model;
use crate::metric::model::fit_scaling;
use crate::table::FeatureTable;

/// Where the weights and the standardisation come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Weighting {
    /// Feature names, in the table's column order.
    pub feature_names: Vec<String>,
    /// Per-feature mean of the standardisation.
    pub mean: Vec<f64>,
    /// Per-feature scale of the standardisation.
    pub scale: Vec<f64>,
    /// The weights `w` of eq. 5.5.
    pub weights: Vec<f64>,
    /// True when there was no model: `w = 1` on features standardised over the library.
    pub uniform: bool,
}

impl Weighting {
    /// The model's standardisation and weights, after checking that `table` has exactly the
    /// model's feature columns.
    pub fn from_model(model: &Model, table: &FeatureTable) -> Result<Self> {
        model.check_columns(table.names())?;
        Ok(Self {
            feature_names: model.feature_names.clone(),
            mean: model.mean.clone(),
            scale: model.scale.clone(),
            weights: model.weights.clone(),
            uniform: false,
        })
    }

    /// No model: every feature weighs 1 after standardising with the library's own mean and
    /// standard deviation (the "uniform" baseline of §5.6).
    pub fn uniform(table: &FeatureTable) -> Self {
        let (mean, scale) = fit_scaling(table, &[]);
        Self {
            feature_names: table.names().to_vec(),
            mean,
            scale,
            weights: vec![1.0; table.dim()],
            uniform: true,
        }
    }
}
