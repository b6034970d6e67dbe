//! The per-view baselines of the evaluation: every view of a light field decomposed on its own
//! by a single-image method.

use rayon::prelude::*;

use crate::decomposition::Decomposition;
use crate::error::Result;
use crate::image::Image;
use crate::lightfield::LightField;

use super::LightFieldDecomposition;

/// Every view decomposed on its own by a single-image method (the per-view baselines of the
/// evaluation), returned as a light-field decomposition.
pub fn per_view(
    lf: &LightField,
    method: impl Fn(&Image) -> Result<Decomposition> + Sync,
) -> Result<LightFieldDecomposition> {
    let views: Vec<Decomposition> = (0..lf.views())
        .into_par_iter()
        .map(|v| method(&lf.view(v)))
        .collect::<Result<_>>()?;
    let reflectance: Vec<Image> = views.iter().map(|d| d.reflectance.clone()).collect();
    let shading: Vec<Image> = views.into_iter().map(|d| d.shading).collect();
    Ok(LightFieldDecomposition {
        reflectance: LightField::from_views(lf.rows(), lf.cols(), &reflectance)?,
        shading: LightField::from_views(lf.rows(), lf.cols(), &shading)?,
    })
}

/// The per-view Retinex baseline: Zhao et al. ([`crate::retinex`], default parameters) on every
/// view alone.
pub fn per_view_retinex(lf: &LightField) -> Result<LightFieldDecomposition> {
    use crate::retinex::{self, RetinexParams, Strokes};
    per_view(lf, |img| {
        retinex::decompose(
            img,
            None,
            &Strokes::default(),
            &RetinexParams::default(),
            &mut |_| {},
        )
        .map(|(d, _)| d)
    })
}
