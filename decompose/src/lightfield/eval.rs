//! Accuracy and angular coherence of a light-field decomposition against ground truth.
//!
//! - Accuracy: the Grosse et al. LMSE ([`crate::metrics::score`]) of every view, and its mean.
//! - Angular incoherence: one surface point seen in several views should get one reflectance.
//!   Every view's reflectance is warped onto the centre view through the centre view's true
//!   disparity ([`super::disparity::warp_to`]); a view counts for a centre pixel when the point
//!   is visible in it (the view's own true disparity, warped the same way, agrees within
//!   [`VISIBILITY_TOLERANCE`] on all four bilinear neighbours) and inside it. The incoherence is
//!   the variance across those views of the log grey reflectance, averaged over the centre
//!   pixels seen in at least two views. It is scale invariant (a global factor shifts every log
//!   equally), so a per-view change of scale counts, as it should: a person flicking through
//!   the views sees it.

use rayon::prelude::*;

use super::LightField;
use super::disparity::warp_to;
use super::method::LightFieldDecomposition;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::metrics::{Scores, score};

/// Largest disparity difference (pixels per view step) between a centre pixel and the point a
/// view shows there for the point to count as the same surface.
pub const VISIBILITY_TOLERANCE: f32 = 0.25;

/// Floor of the grey reflectance before the logarithm (relative to the light field's 99.5th
/// percentile, which decompositions put at 1).
const LOG_FLOOR: f32 = 1e-3;

/// Scores of one light-field decomposition.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LightFieldScores {
    /// Mean over the views of the LMSE (Grosse et al.).
    pub lmse: f64,
    /// LMSE of every view, row-major.
    pub lmse_views: Vec<f64>,
    /// Angular incoherence (see the module docs).
    pub incoherence: f64,
    /// Centre-view pixels that entered the incoherence.
    pub incoherence_pixels: usize,
}

/// The true decomposition of a light field, with every view's disparity.
#[derive(Clone, Debug)]
pub struct LightFieldTruth {
    /// True reflectance (3 channels).
    pub reflectance: LightField,
    /// True shading (1 channel).
    pub shading: LightField,
    /// True disparity of every view (1 channel).
    pub disparity: LightField,
    /// Pixels to score in every view (1 channel, non-zero = scored); all when `None`.
    pub mask: Option<LightField>,
}

fn same_shape(a: &LightField, b: &LightField, what: &'static str) -> Result<()> {
    if (a.rows(), a.cols(), a.dims()) != (b.rows(), b.cols(), b.dims()) {
        return Err(Error::param(
            what,
            format!(
                "{}x{} views of {}x{}",
                b.rows(),
                b.cols(),
                b.width(),
                b.height()
            ),
            "must have the grid and view size of the decomposition",
        ));
    }
    Ok(())
}

fn view_mask(truth: &LightFieldTruth, v: usize) -> Result<Mask> {
    match &truth.mask {
        Some(m) => Mask::from_vec(
            m.width(),
            m.height(),
            m.view_data(v).iter().map(|&x| x > 0.0).collect(),
        ),
        None => Ok(Mask::full(
            truth.reflectance.width(),
            truth.reflectance.height(),
        )),
    }
}

/// Scores a decomposition against the truth (see the module docs).
pub fn evaluate(
    est: &LightFieldDecomposition,
    truth: &LightFieldTruth,
) -> Result<LightFieldScores> {
    let r = &est.reflectance;
    for (lf, what) in [
        (&est.shading, "estimated shading"),
        (&truth.reflectance, "true reflectance"),
        (&truth.shading, "true shading"),
        (&truth.disparity, "true disparity"),
    ] {
        same_shape(r, lf, what)?;
    }
    if let Some(m) = &truth.mask {
        same_shape(r, m, "mask")?;
    }
    let lmse_views: Vec<f64> = (0..r.views())
        .into_par_iter()
        .map(|v| {
            let s: Scores = score(
                &r.view(v),
                &est.shading.view(v),
                &truth.reflectance.view(v),
                &truth.shading.view(v),
                &view_mask(truth, v)?,
            )?;
            Ok(s.lmse)
        })
        .collect::<Result<_>>()?;
    let lmse = lmse_views.iter().sum::<f64>() / lmse_views.len().max(1) as f64;
    let (incoherence, incoherence_pixels) =
        angular_incoherence(r, &truth.disparity, truth.mask.as_ref())?;
    Ok(LightFieldScores {
        lmse,
        lmse_views,
        incoherence,
        incoherence_pixels,
    })
}

/// Grey value of a 3-channel (or 1-channel) pixel.
fn grey(p: &[f32]) -> f32 {
    p.iter().sum::<f32>() / p.len() as f32
}

/// The angular incoherence of a reflectance light field (see the module docs) and the number
/// of centre pixels it averages.
pub fn angular_incoherence(
    reflectance: &LightField,
    disparity: &LightField,
    mask: Option<&LightField>,
) -> Result<(f64, usize)> {
    same_shape(reflectance, disparity, "disparity")?;
    let centre = (reflectance.rows() / 2, reflectance.cols() / 2);
    let c_index = reflectance.view_index(centre.0, centre.1);
    let c_disp = disparity.view(c_index);
    let (w, h) = reflectance.dims();
    let n = w as usize * h as usize;
    // Every view warped onto the centre.
    let warped: Vec<(Image, Image)> = (0..reflectance.views())
        .into_par_iter()
        .map(|v| {
            let from = (v / reflectance.cols(), v % reflectance.cols());
            warp_to(reflectance, from, centre, &c_disp)
        })
        .collect::<Result<_>>()?;
    // A bilinear sample shows the centre pixel's surface when the view's own disparity at all
    // four of its neighbours agrees with the centre's (a warped disparity would average across
    // the depth edge and hide a half-occluded sample).
    let per_pixel: Vec<Option<f64>> = (0..n)
        .into_par_iter()
        .map(|p| {
            if let Some(m) = mask
                && m.view_data(c_index)[p] <= 0.0
            {
                return None;
            }
            let d = c_disp.data()[p];
            let (x, y) = ((p % w as usize) as f32, (p / w as usize) as f32);
            let mut logs = Vec::with_capacity(warped.len());
            for (v, (refl, inside)) in warped.iter().enumerate() {
                if inside.data()[p] <= 0.0 {
                    continue;
                }
                let from = (v / reflectance.cols(), v % reflectance.cols());
                let (sx, sy) = super::disparity::corresponding(x, y, d, centre, from);
                let view_disp = disparity.view_data(v);
                let (x0, y0) = (sx.floor().max(0.0) as u32, sy.floor().max(0.0) as u32);
                let visible = [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|&(dx, dy)| {
                    let (xx, yy) = ((x0 + dx).min(w - 1), (y0 + dy).min(h - 1));
                    (view_disp[(yy * w + xx) as usize] - d).abs() <= VISIBILITY_TOLERANCE
                });
                if visible {
                    let g = grey(refl.px(p)).max(LOG_FLOOR);
                    logs.push(g.ln() as f64);
                }
            }
            if logs.len() < 2 {
                return None;
            }
            let mean = logs.iter().sum::<f64>() / logs.len() as f64;
            Some(logs.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / logs.len() as f64)
        })
        .collect();
    let (sum, count) = per_pixel
        .iter()
        .flatten()
        .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
    Ok((if count > 0 { sum / count as f64 } else { 0.0 }, count))
}
