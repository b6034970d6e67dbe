//! Algorithm 2 of the thesis (ch. 4): the whole light field decomposed at once.
//!
//! 1. 4D filtering of the light field `L` (eq. 4.3) gives `L̂`; `S₀ = ‖L̂‖₂`, `R₀ = L̂ / S₀`.
//!    Off by default (`L̂ = L`), see [`LightFieldParams::input_filter`] for the measurement.
//! 2. Per view, the albedo cue from `R₀` and the white/black probabilities of `L̂`, and the
//!    occlusion cue from the disparity ([`super::cues`], eqs. 4.10–4.12).
//! 3. Per view, the gradient-domain Retinex solve for the log shading `s` ([`super::retinex`],
//!    eqs. 4.4–4.9), warm started from an already solved neighbouring view: the centre view
//!    first, then ring after ring outwards, the views of one ring in parallel.
//! 4. Global coherency: `R_g1 = L / e^s`, its log norm filtered in 4D to `ln ‖R̂₁‖₂`;
//!    `S_f = ‖L̂‖₂ / ‖R̂₁‖₂`, `R_f = L / S_f` (so `R_f × S_f = L` exactly, on every view).
//!
//! Not in the thesis ([`LightFieldParams`] says why, with the figures): rays with no light are
//! missing data (their pairs damped in step 3, their reflectance filled in by step 4's filter,
//! `method::layers`); creases, where the disparity's slope turns, weighted `ω_crease` and asking
//! for at most a shading step `T_c` ([`super::cues::crease_cue`],
//! [`super::cues::bound_crease_steps`]); step 3's data term weighted per ray by its brightness,
//! with the dark rays tied to the centre view's solution ([`data_term`], γ = 2 by default); and
//! two options, a disparity-sheared filter in step 4 ([`super::tvl1::tv_l1_sheared`]) and Zhao
//! et al.'s centre-view Retinex as step 3's level prior (`method::prior`).
//!
//! One reflectance scale for the whole light field: its 99.5th percentile channel value over all
//! views is 1 (per-view normalisation would itself be an angular incoherence).

use std::time::Instant;

use rayon::prelude::*;

use super::LightField;
use super::cues::{self, PairWeights};
use super::retinex::{ViewSolveInfo, solve_view_with_target};
use super::tvl1::{TvL1Info, tv_l1};
use crate::decomposition::{Decomposition, SHADING_FLOOR};
use crate::error::{Error, Result};
use crate::progress::{Progress, ProgressFn};

pub use baselines::{per_view, per_view_retinex};
pub use data_term::DataTermParams;
pub use params::{
    CENTRE_WEIGHT, DATA_GAMMA, DATA_MU, DEFAULT_DATA_GAMMA, FILTER_ITERATIONS, LevelPrior,
    LightFieldParams, PREVIOUS_REFLECTANCE_BETA, REFLECTANCE_BETA, REFLECTANCE_ITERATIONS,
    REFLECTANCE_RHO,
};

/// The decomposition of every view: `reflectance` (3 channels) × `shading` (1 channel) = `L`.
#[derive(Clone, Debug, PartialEq)]
pub struct LightFieldDecomposition {
    /// Reflectance of every view.
    pub reflectance: LightField,
    /// Shading of every view.
    pub shading: LightField,
}

impl LightFieldDecomposition {
    /// View `index` (row-major) as an image decomposition.
    pub fn view(&self, index: usize) -> Decomposition {
        Decomposition {
            reflectance: self.reflectance.view(index),
            shading: self.shading.view(index),
        }
    }
}

/// What a run did, for `stats.json`.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct LightFieldInfo {
    /// Wall time of each stage, milliseconds, in order.
    pub stage_ms: Vec<(&'static str, f64)>,
    /// The Retinex solve of every view, row-major.
    pub views: Vec<ViewSolveInfo>,
    /// Whether an occlusion cue was used (a disparity was given and the cue is on).
    pub occlusion_cue: bool,
    /// Whether the crease cue was used: with the occlusion cue, when the disparity is precise
    /// enough ([`super::cues::disparity_sees_planes`]).
    pub crease_cue: bool,
    /// Pairs marked as reflectance changes, fraction of all pairs (all views).
    pub albedo_pair_fraction: f64,
    /// Pairs marked as occlusions, fraction of all pairs (all views).
    pub occlusion_pair_fraction: f64,
    /// Rays with no light treated as missing data, fraction of all rays
    /// ([`LightFieldParams::unlit_as_missing`]).
    pub unlit_ray_fraction: f64,
    /// The 4D TV-L1 filter of the reflectance (step 4), unless the filter is off.
    pub reflectance_filter: Option<TvL1Info>,
}

/// Checks a light field for decomposition: RGB, finite, non-negative, not black.
fn check(lf: &LightField, disparity: Option<&LightField>) -> Result<()> {
    if lf.channels() != 3 {
        return Err(Error::param(
            "channels",
            lf.channels(),
            "a light field to decompose must be RGB",
        ));
    }
    let mut max = 0.0f32;
    for &v in lf.data() {
        if !v.is_finite() || v < 0.0 {
            return Err(Error::param(
                "light field",
                v,
                "values must be finite and non-negative",
            ));
        }
        max = max.max(v);
    }
    if max <= 1e-6 {
        return Err(Error::AllBlackLightField { max });
    }
    if let Some(d) = disparity {
        if (d.rows(), d.cols(), d.dims(), d.channels()) != (lf.rows(), lf.cols(), lf.dims(), 1) {
            return Err(Error::param(
                "disparity",
                format!(
                    "{}x{} views of {}x{}x{}",
                    d.rows(),
                    d.cols(),
                    d.width(),
                    d.height(),
                    d.channels()
                ),
                "must hold one channel per pixel of every view of the light field",
            ));
        }
        if let Some(v) = d.data().iter().find(|v| !v.is_finite()) {
            return Err(Error::param("disparity", v, "values must be finite"));
        }
    }
    Ok(())
}

/// Per-pixel 2-norm of a 3-channel light field.
fn norms(lf: &LightField) -> Vec<f32> {
    lf.data()
        .par_chunks_exact(3)
        .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
        .collect()
}

/// The value at quantile `q` of the per-pixel maximum channel (positive values only).
fn channel_max_quantile(data: &[f32], q: f64) -> f32 {
    let mut v: Vec<f32> = data
        .chunks_exact(3)
        .map(|p| p[0].max(p[1]).max(p[2]))
        .filter(|v| *v > 0.0)
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    let k = ((v.len() - 1) as f64 * q).round() as usize;
    *v.select_nth_unstable_by(k, f32::total_cmp).1
}

/// Views grouped by their Chebyshev distance from the centre view, with for every view of ring
/// `k ≥ 1` its neighbour one step towards the centre (in ring `k − 1`).
fn rings(rows: usize, cols: usize) -> Vec<Vec<(usize, Option<usize>)>> {
    let (rc, cc) = (rows / 2, cols / 2);
    let ring = |r: usize, c: usize| r.abs_diff(rc).max(c.abs_diff(cc));
    let step = |v: usize, centre: usize| match v.cmp(&centre) {
        std::cmp::Ordering::Less => v + 1,
        std::cmp::Ordering::Equal => v,
        std::cmp::Ordering::Greater => v - 1,
    };
    let count = (0..rows)
        .flat_map(|r| (0..cols).map(move |c| ring(r, c)))
        .max()
        .unwrap_or(0);
    let mut out = vec![Vec::new(); count + 1];
    for r in 0..rows {
        for c in 0..cols {
            let k = ring(r, c);
            let parent = (k > 0).then(|| step(r, rc) * cols + step(c, cc));
            out[k].push((r * cols + c, parent));
        }
    }
    out
}

/// Decomposes a light field (Algorithm 2; see the module docs). `disparity`, one channel per
/// view, feeds the occlusion cue; without it the cue is off.
pub fn decompose(
    lf: &LightField,
    disparity: Option<&LightField>,
    params: &LightFieldParams,
    progress: ProgressFn,
) -> Result<(LightFieldDecomposition, LightFieldInfo)> {
    check(lf, disparity)?;
    params.reflectance_filter.validate()?;
    params.data_term.validate()?;
    params.cues.validate()?;
    if let Some(f) = &params.input_filter {
        f.validate()?;
    }
    let mut info = LightFieldInfo::default();
    let mut clock = Instant::now();
    let mut lap = |info: &mut LightFieldInfo, stage: &'static str| {
        info.stage_ms
            .push((stage, clock.elapsed().as_secs_f64() * 1e3));
        clock = Instant::now();
    };
    let (w, h) = (lf.width() as usize, lf.height() as usize);
    let n = w * h;

    // Step 1: 4D filtering; S₀ = ‖L̂‖₂ and R₀ = L̂ / S₀ (only R₀'s direction is used).
    progress(Progress {
        stage: "4D filtering of the light field",
        fraction: 0.0,
    });
    // Borrowed when step 1 is off: no copy of the light field.
    let filtered: std::borrow::Cow<LightField> = match (&params.input_filter, params.filter_4d) {
        (Some(f), true) => std::borrow::Cow::Owned(tv_l1(lf, f)?.0),
        _ => std::borrow::Cow::Borrowed(lf),
    };
    lap(&mut info, "filter light field");
    let s0 = norms(&filtered);
    let floor = s0.iter().copied().fold(0.0f32, f32::max) * SHADING_FLOOR;
    let log_i: Vec<f32> = s0.par_iter().map(|v| v.max(floor).ln()).collect();
    // White = 1 for the CIELab probabilities.
    let white = channel_max_quantile(filtered.data(), 0.995);

    // Rays with no light (black, e.g. a deep shadow in an 8-bit file) carry no information:
    // their pairs are cut from the per-view solves like occlusions, and the 4D filter fills
    // their reflectance in from the surface around them.
    // `None` when there is none (or the option is off): no mask to pass around or test.
    let unlit: Option<Vec<bool>> = if params.unlit_as_missing {
        let mask: Vec<bool> = s0.par_iter().map(|&l| l <= 0.0).collect();
        let count = mask.iter().filter(|&&u| u).count();
        info.unlit_ray_fraction = count as f64 / mask.len() as f64;
        (count > 0).then_some(mask)
    } else {
        None
    };

    // Steps 2–3: cues and the per-view solves, ring by ring.
    let use_occlusion = params.occlusion_cue && disparity.is_some();
    info.occlusion_cue = use_occlusion;
    let range = disparity.map(|d| {
        d.data()
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)))
    });
    // The crease cue, with the occlusion cue, when the disparity is precise enough to see planes
    // (its centre view is enough to tell).
    let centre = lf.view_index(lf.rows() / 2, lf.cols() / 2);
    let crease_step = match (use_occlusion, disparity, params.cues.crease_step) {
        (true, Some(d), Some(step)) => {
            cues::disparity_sees_planes(w, h, d.view_data(centre), step).then_some(step)
        }
        _ => None,
    };
    info.crease_cue = crease_step.is_some();
    let source = weights::CueSource {
        filtered: &filtered,
        white,
        disparity: disparity.zip(range).filter(|_| use_occlusion),
        crease_step,
        log_intensity: &log_i,
        unlit: unlit.as_deref(),
        params,
    };
    // The data term's target of every ray, when not the thesis' log intensity.
    let mut prior: Option<Vec<f32>> = match (disparity, params.level_prior) {
        (Some(d), LevelPrior::CentreRetinex) => {
            Some(prior::centre_retinex_prior(&filtered, d, &log_i)?)
        }
        _ => None,
    };
    // The data term's weight of every ray, when not the thesis' one weight (`data_term`).
    let mut data_weight = data_term::ray_weights(&log_i, floor.ln(), params.data_term.gamma);
    let tie_disparity = match disparity {
        Some(d) if params.data_term.centre_weight > 0.0 && lf.views() > 1 => Some(d),
        _ => None,
    };
    let mut log_s = vec![0.0f32; lf.views() * n];
    let mut solves = vec![ViewSolveInfo::default(); lf.views()];
    let mut marked = (0.0f64, 0.0f64);
    let ring_list = rings(lf.rows(), lf.cols());
    let total_views = lf.views() as f32;
    let mut done = 0usize;
    for (ring_index, ring) in ring_list.iter().enumerate() {
        progress(Progress {
            stage: "Retinex solve of every view",
            fraction: 0.3 + 0.5 * done as f32 / total_views,
        });
        let results: Vec<(usize, Vec<f32>, ViewSolveInfo, f64, f64)> = ring
            .par_iter()
            .map(|&(v, parent)| {
                let view_i = &log_i[v * n..(v + 1) * n];
                let (albedo, occlusion) = source.view(v);
                let start = match parent {
                    Some(p) => &log_s[p * n..(p + 1) * n],
                    None => view_i,
                };
                let target = prior.as_ref().map_or(view_i, |t| &t[v * n..(v + 1) * n]);
                let (s, solve) = solve_view_with_target(
                    view_i,
                    target,
                    data_weight.as_ref().map(|d| &d[v * n..(v + 1) * n]),
                    &albedo,
                    &occlusion,
                    start,
                    &params.solve,
                );
                let frac = |pw: &PairWeights, f: &dyn Fn(f32) -> bool| {
                    pw.horizontal[..]
                        .iter()
                        .chain(&pw.vertical)
                        .filter(|&&x| f(x))
                        .count() as f64
                };
                let a = frac(&albedo, &|x| x > 0.5);
                let o = frac(&occlusion, &|x| x < 1.0);
                (v, s, solve, a, o)
            })
            .collect();
        for (v, s, solve, a, o) in results {
            log_s[v * n..(v + 1) * n].copy_from_slice(&s);
            solves[v] = solve;
            marked.0 += a;
            marked.1 += o;
        }
        done += ring.len();
        // After the centre view: tie the other views' dark rays to its solution.
        if let (0, Some(d)) = (ring_index, tie_disparity) {
            let centre_s = &log_s[centre * n..(centre + 1) * n];
            let (carried, seen) = prior::carry_from_centre(lf, d, centre_s, &log_i)?;
            let weights = data_weight.get_or_insert_with(|| vec![1.0; log_i.len()]);
            let targets = prior.get_or_insert_with(|| log_i.clone());
            data_term::tie_to_centre(
                weights,
                targets,
                &carried,
                &seen,
                params.data_term.centre_weight,
            );
        }
    }
    let pairs = (lf.views() * 2 * n) as f64;
    info.albedo_pair_fraction = marked.0 / pairs;
    info.occlusion_pair_fraction = marked.1 / pairs;
    info.views = solves;
    lap(&mut info, "cues and Retinex solves");

    // Step 4: global coherency.
    progress(Progress {
        stage: "4D filtering of the reflectance",
        fraction: 0.8,
    });
    let log_norm_l: Vec<f32> = if params.input_filter.is_some() && params.filter_4d {
        norms(lf).par_iter().map(|v| v.max(floor).ln()).collect()
    } else {
        log_i
    };
    let (log_r_hat, filter_info) = coherency::filtered_log_reflectance(
        lf,
        &log_norm_l,
        &log_s,
        params.filter_4d.then_some(&params.reflectance_filter),
        unlit.as_deref(),
        disparity.filter(|_| params.shear),
    )?;
    info.reflectance_filter = filter_info;
    lap(&mut info, "filter reflectance");
    let mut log_r_hat = log_r_hat;
    if params.unlit_from_centre
        && let (Some(unlit), Some(disparity)) = (unlit.as_deref(), disparity)
    {
        unlit::share_centre_fill(lf, disparity, unlit, &mut log_r_hat)?;
    }
    let (reflectance, shading_data) = layers::compose(lf, &s0, &log_r_hat, unlit.as_deref());
    let shading = LightField::from_vec(
        lf.rows(),
        lf.cols(),
        lf.width(),
        lf.height(),
        1,
        shading_data,
    )?;
    lap(&mut info, "layers");
    progress(Progress {
        stage: "done",
        fraction: 1.0,
    });
    Ok((
        LightFieldDecomposition {
            reflectance,
            shading,
        },
        info,
    ))
}

mod baselines;
mod coherency;
pub mod data_term;
mod layers;
mod params;
mod prior;
#[cfg(test)]
mod tests;
mod unlit;
mod weights;
