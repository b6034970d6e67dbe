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
//! One reflectance scale for the whole light field: its 99.5th percentile channel value over all
//! views is 1 (per-view normalisation would itself be an angular incoherence).

use std::time::Instant;

use rayon::prelude::*;

use super::LightField;
use super::cues::{self, CueParams, PairWeights};
use super::retinex::{ViewSolveInfo, ViewSolveParams, solve_view_with_target};
use super::tvl1::{TvL1Info, TvL1Params, tv_l1};
use crate::decomposition::{Decomposition, SHADING_FLOOR};
use crate::error::{Error, Result};
use crate::progress::{Progress, ProgressFn};

pub use baselines::{per_view, per_view_retinex};

/// Parameters of [`decompose`]. `Default` holds the thesis' values except where the rendered
/// tuning scenes said otherwise (each such field says so, with the figures).
#[derive(Clone, Debug, PartialEq)]
pub struct LightFieldParams {
    /// Step 1: the 4D TV-L1 filter of the input (eq. 4.3, β = 0.05 in the thesis), giving `L̂`.
    /// Default `None` (`L̂ = L`): on the 4 rendered tuning scenes at 256² the thesis' filter
    /// flattens printed textures and small objects before the cues see them: mean LMSE 0.141
    /// with it against 0.064 without, angular incoherence 0.044 against 0.009
    /// (docs/intrinsic-lightfields.md).
    pub input_filter: Option<TvL1Params>,
    /// Step 4: the 4D TV-L1 filter of the Retinex reflectance `R_g1` (eq. 4.3), which makes it
    /// coherent across views, run on `ln ‖R_g1‖₂` (one channel; see `method::coherency`).
    /// β = [`REFLECTANCE_BETA`] instead of the thesis' 0.05, ρ = [`REFLECTANCE_RHO`] and
    /// [`REFLECTANCE_ITERATIONS`] iterations, all chosen on the tuning scenes
    /// (docs/intrinsic-lightfields.md).
    pub reflectance_filter: TvL1Params,
    /// Cue thresholds (eqs. 4.10–4.12).
    pub cues: CueParams,
    /// The per-view Retinex solve.
    pub solve: ViewSolveParams,
    /// Option, off by default: step 4's angular differences follow the disparity
    /// (`tvl1::tv_l1_sheared`) when a disparity is given. On the 8 tuning scenes it changes
    /// the scores by less than the other choices (docs/intrinsic-lightfields.md) at 3–4× the
    /// filter's time.
    pub shear: bool,
    /// What step 3's data term ties each view's log shading to (see [`LevelPrior`]); the
    /// thesis' log intensity by default, chosen by cross-validation.
    pub level_prior: LevelPrior,
    /// Rays with no light (`‖L̂‖ = 0`, e.g. a deep shadow that is black in an 8-bit file) are
    /// treated as missing data: their pairs are damped like occlusions (`ω^occ`) in the
    /// per-view solves and the 4D filter fills their reflectance in from the surface around
    /// them (`method::coherency`). Not in the thesis, which divides by their zero intensity;
    /// `false` is that ablation. On the 8 tuning scenes this is most of the gain in angular
    /// coherence (docs/intrinsic-lightfields.md).
    pub unlit_as_missing: bool,
    /// Ablation switch: `false` skips both 4D filterings (`L̂ = L`, `R̂₁ = R_g1`).
    pub filter_4d: bool,
    /// Ablation switch: `false` drops the occlusion cue (eq. 4.12).
    pub occlusion_cue: bool,
    /// The white/black cue (eq. 4.11). Off by default: leave-one-scene-out cross-validation on
    /// the 8 tuning scenes chose it off in every fold (docs/intrinsic-lightfields.md); `true`
    /// is the thesis.
    pub white_black_cue: bool,
}

/// β of the reflectance filter: 1, chosen with the cues by leave-one-scene-out
/// cross-validation on the 8 rendered tuning scenes between 0.3 and 1 (every fold chose 1:
/// mean LMSE 0.0432 against 0.0462, angular incoherence 0.0051 against 0.0034; per-view
/// Retinex 0.0562 and 0.0263; docs/intrinsic-lightfields.md). The thesis' 0.05 flattens printed
/// textures into the shading (LMSE 0.093 on `scene02`, against Retinex's 0.047).
pub const REFLECTANCE_BETA: f32 = 1.0;

/// ρ of the reflectance filter. With a log-domain signal (contrasts of order 1 rather than 0.1)
/// the filter's primal steps `τ = 1/(16ρ)` must be longer than at the ρ = 10 tuned for images
/// in [0, 1]: on the 4 tuning scenes, 30 iterations at ρ = 3 score like 100 at ρ = 10 (mean
/// LMSE 0.0557 / 0.0553, incoherence 0.0077 / 0.0076, both at the thesis' cue settings) in
/// under a third of the time.
pub const REFLECTANCE_RHO: f32 = 3.0;

/// Iterations of the reflectance filter: 30. The filter starts from `u⁰ = R_g1` and is stopped
/// early on purpose. Run to convergence, its minimiser flattens more than the tuning scenes
/// reward. At ρ = 1, 30 iterations give LMSE 0.0717 against 0.0557 at ρ = 3, for the same
/// incoherence (0.0075).
pub const REFLECTANCE_ITERATIONS: usize = 30;

/// Iterations of the optional input filter (step 1): 100 at ρ = 10.
pub const FILTER_ITERATIONS: usize = 100;

impl Default for LightFieldParams {
    fn default() -> Self {
        Self {
            input_filter: None,
            reflectance_filter: TvL1Params {
                beta: REFLECTANCE_BETA,
                rho: REFLECTANCE_RHO,
                iterations: REFLECTANCE_ITERATIONS,
                ..Default::default()
            },
            cues: CueParams::default(),
            solve: ViewSolveParams::default(),
            shear: false,
            level_prior: LevelPrior::Intensity,
            unlit_as_missing: true,
            filter_4d: true,
            occlusion_cue: true,
            white_black_cue: false,
        }
    }
}

/// The target of the per-view solves' data term `μ (s − t)²` (eq. 4.4's weak term).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LevelPrior {
    /// The thesis: `t = i`, the log intensity, with weight `ViewSolveParams::mu`.
    Intensity,
    /// Zhao et al.'s Retinex of the centre view, carried to every view through the disparity
    /// (`method::prior`), weight `ViewSolveParams::mu`.
    CentreRetinex,
}

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
        return Err(Error::AllBlack { max });
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
    let unlit: Vec<bool> = s0
        .par_iter()
        .map(|&l| params.unlit_as_missing && l <= 0.0)
        .collect();
    info.unlit_ray_fraction = unlit.iter().filter(|&&u| u).count() as f64 / unlit.len() as f64;

    // Steps 2–3: cues and the per-view solves, ring by ring.
    let use_occlusion = params.occlusion_cue && disparity.is_some();
    info.occlusion_cue = use_occlusion;
    let range = disparity.map(|d| {
        d.data()
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)))
    });
    // The data term's target of every ray, when not the thesis' log intensity.
    let prior: Option<Vec<f32>> = match (disparity, params.level_prior) {
        (Some(d), LevelPrior::CentreRetinex) => {
            Some(prior::centre_retinex_prior(&filtered, d, &log_i)?)
        }
        _ => None,
    };
    let mut log_s = vec![0.0f32; lf.views() * n];
    let mut solves = vec![ViewSolveInfo::default(); lf.views()];
    let mut marked = (0.0f64, 0.0f64);
    let ring_list = rings(lf.rows(), lf.cols());
    let total_views = lf.views() as f32;
    let mut done = 0usize;
    for ring in &ring_list {
        progress(Progress {
            stage: "Retinex solve of every view",
            fraction: 0.3 + 0.5 * done as f32 / total_views,
        });
        let results: Vec<(usize, Vec<f32>, ViewSolveInfo, f64, f64)> = ring
            .par_iter()
            .map(|&(v, parent)| {
                let view_i = &log_i[v * n..(v + 1) * n];
                let rgb = filtered.view_data(v);
                let scaled: Vec<f32> = rgb.iter().map(|x| x / white).collect();
                let albedo =
                    cues::albedo_cue(w, h, rgb, &scaled, &params.cues, params.white_black_cue);
                let mut occlusion = match (use_occlusion, disparity, range) {
                    (true, Some(d), Some(range)) => {
                        cues::occlusion_cue(w, h, d.view_data(v), range, &params.cues)
                    }
                    _ => PairWeights::constant(w, h, 1.0),
                };
                occlusion.damp_pairs_touching(&unlit[v * n..(v + 1) * n], params.cues.omega_occ);
                let start = match parent {
                    Some(p) => &log_s[p * n..(p + 1) * n],
                    None => view_i,
                };
                let target = prior.as_ref().map_or(view_i, |t| &t[v * n..(v + 1) * n]);
                let (s, solve) = solve_view_with_target(
                    view_i,
                    target,
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
        &unlit,
        disparity.filter(|_| params.shear),
    )?;
    info.reflectance_filter = filter_info;
    lap(&mut info, "filter reflectance");
    let (reflectance, shading_data) = layers::compose(lf, &s0, &log_r_hat, params.unlit_as_missing);
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
mod layers;
mod prior;
#[cfg(test)]
mod tests;
