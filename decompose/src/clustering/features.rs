//! The {β, a, b} features of step 1 (eq. 2.2), and the chromaticity variant of (a, b).

use std::borrow::Cow;

use rayon::prelude::*;

use super::ClusteringParams;
use crate::color::linear_to_lab;
use crate::image::{Image, Mask};

fn logistic(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// The {β, a, b} feature of every pixel (eq. 2.2), for pixels inside the mask.
pub fn features(input: &Image, mask: &Mask, params: &ClusteringParams) -> Vec<[f32; 3]> {
    let lab: Vec<[f32; 3]> = (0..input.len())
        .into_par_iter()
        .map(|i| linear_to_lab(input.rgb(i)))
        .collect();
    let rgb: Vec<[f32; 3]> = (0..input.len()).map(|i| input.rgb(i)).collect();
    feature_from_lab(&chroma_source(&lab, &rgb, params), mask, params)
}

/// The Lab triples the features are taken from: Lab itself, or with `chromaticity_features`
/// its (a, b) replaced by the chromaticity of the linear RGB, which a change of illumination
/// intensity (a cast shadow) leaves unchanged while Lab's a, b shrink with lightness.
pub(super) fn chroma_source<'a>(
    lab: &'a [[f32; 3]],
    rgb: &[[f32; 3]],
    params: &ClusteringParams,
) -> Cow<'a, [[f32; 3]]> {
    if !params.chromaticity_features {
        return Cow::Borrowed(lab);
    }
    lab.iter()
        .zip(rgb)
        .map(|(l, c)| {
            let s = (c[0] + c[1] + c[2]).max(1e-6);
            [
                l[0],
                100.0 * (c[0] - c[1]) / s,
                100.0 * (c[0] + c[1] - 2.0 * c[2]) / (3f32.sqrt() * s),
            ]
        })
        .collect()
}

pub(super) fn feature_from_lab(
    lab: &[[f32; 3]],
    mask: &Mask,
    params: &ClusteringParams,
) -> Vec<[f32; 3]> {
    let sel = || {
        lab.iter()
            .enumerate()
            .filter(|(i, _)| mask.at(*i))
            .map(|x| x.1)
    };
    let max_l = sel().map(|p| p[0]).fold(0.0f32, f32::max).max(1e-6);
    let max_ab = sel()
        .map(|p| p[1].abs().max(p[2].abs()))
        .fold(0.0f32, f32::max);
    // A grey image has no chroma; keep β meaningful with a unit floor.
    let lambda = (params.lambda_fraction * max_ab).max(1e-3);
    lab.iter()
        .enumerate()
        .filter(|(i, _)| mask.at(*i))
        .map(|(_, p)| {
            let l = p[0] / max_l;
            let beta = lambda
                * (logistic(params.mu * (l - params.l_max_fraction))
                    - logistic(params.mu * (params.l_min_fraction - l)));
            [beta, p[1], p[2]]
        })
        .collect()
}
