//! The pair weights of one view's solve (step 2 of Algorithm 2): the albedo cue `ω^a`, and
//! `ω^occ` from the occlusion cue, the crease cue (not in the thesis) and the pairs touching
//! unlit rays, all damped alike.

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
        let albedo = cues::albedo_cue(w, h, rgb, &scaled, &params.cues, params.white_black_cue);
        let mut occlusion = match self.disparity {
            Some((d, range)) => {
                let mut occ = cues::occlusion_cue(w, h, d.view_data(v), range, &params.cues);
                if let Some(step) = self.crease_step {
                    let crease =
                        cues::crease_cue(w, h, d.view_data(v), step, params.cues.omega_occ);
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
