//! The pair weights of one view's solve (step 2 of Algorithm 2): the albedo cue `ω^a`, and
//! `ω^occ` from the occlusion cue, the crease cue (not in the thesis; `ω_crease`, with its
//! shading step bounded by `T_c` through `ω^a`) and the pairs touching unlit rays.

use super::super::LightField;
use super::super::cues::{self, PairWeights};
use super::LightFieldParams;

/// What every view's cues are computed from.
pub(super) struct CueSource<'a> {
    /// `L̂`, the (possibly 4D-filtered) light field.
    pub filtered: &'a LightField,
    /// `L̂`'s white (its 99.5th percentile channel value), for the CIELab probabilities.
    pub white: f32,
    /// Every view's disparity and the light field's disparity range, when the occlusion cue
    /// (and with it the crease cue) is used.
    pub disparity: Option<(&'a LightField, (f32, f32))>,
    /// The crease cue's step, when the cue is used ([`cues::crease_cue`]).
    pub crease_step: Option<f32>,
    /// `ln ‖L̂‖₂` of every ray (views-major), for the bound on the crease pairs' shading steps
    /// ([`cues::bound_crease_steps`]).
    pub log_intensity: &'a [f32],
    /// Rays with no light (views-major), when there are any.
    pub unlit: Option<&'a [bool]>,
    /// The cues' switches and parameters.
    pub params: &'a LightFieldParams,
}

impl CueSource<'_> {
    /// `(ω^a, ω^occ)` of view `v`.
    pub fn view(&self, v: usize) -> (PairWeights, PairWeights) {
        let (w, h) = (
            self.filtered.width() as usize,
            self.filtered.height() as usize,
        );
        let n = w * h;
        let params = self.params;
        let rgb = self.filtered.view_data(v);
        let scaled: Vec<f32> = rgb.iter().map(|x| x / self.white).collect();
        let mut albedo = cues::albedo_cue(w, h, rgb, &scaled, &params.cues, params.white_black_cue);
        let mut occlusion = match self.disparity {
            Some((d, range)) => {
                let mut occ = cues::occlusion_cue(w, h, d.view_data(v), range, &params.cues);
                if let Some(step) = self.crease_step {
                    let crease =
                        cues::crease_cue(w, h, d.view_data(v), step, params.cues.crease_weight);
                    if let Some(max_step) = params.cues.crease_shading_step {
                        let log_i = &self.log_intensity[v * n..(v + 1) * n];
                        cues::bound_crease_steps(&mut albedo, &crease, log_i, max_step);
                    }
                    occ.keep_smaller(&crease);
                }
                occ
            }
            None => PairWeights::constant(w, h, 1.0),
        };
        if let Some(unlit) = self.unlit {
            occlusion.damp_pairs_touching(&unlit[v * n..(v + 1) * n], params.cues.omega_occ);
        }
        (albedo, occlusion)
    }
}
