//! The two cues of the light-field Retinex (thesis §4.3, eqs. 4.10–4.12), as weights on the
//! 4-neighbour pairs of one view.
//!
//! - Albedo cue `ω^a ∈ [0, 1]`: how likely the pair straddles a reflectance change. From the
//!   angle between the colour lines (RGB directions) of the two pixels of the filtered
//!   chromaticity `R₀ = L̂ / ‖L̂‖`: shading scales a colour along its line, so only a reflectance
//!   change turns it; `ω^a = 1` when the angle exceeds `θ_a` (eq. 4.10; the thesis' 0.04 rad, 0.005 here by
//!   cross-validation, see [`CueParams::theta_a`]). Black and
//!   white have no reliable colour line (noise; clipping), so the change of their CIELab
//!   probabilities `g^w` (white: L* above `τ₁`, low chroma) and `g^b` (black: L* below `τ₂`)
//!   across the pair is a second albedo cue, `ω^a = max(ω^a, |Δg^w|, |Δg^b|)` (eq. 4.11).
//! - Occlusion cue `ω^occ`: `ω_occ` = 0.01 where the normalised depth jumps by more than
//!   `ΔD_occ` = 0.02 between the two pixels, 1 elsewhere (eq. 4.12): at an occlusion both
//!   layers can change, so the pair's Retinex terms are nearly switched off.
//!
//! Interpretation (the thesis writes the white/black cue per pixel): applied per pixel, a white
//! wall with a light gradient across it would have all its shading pushed into the reflectance;
//! the change across the pair keeps the cue where a white or black region meets another.

use crate::color::linear_to_lab;
use crate::error::{Error, Result};

mod crease;

pub use crease::{bound_crease_steps, crease_cue, disparity_sees_planes};

/// Weights of the horizontal and vertical 4-neighbour pairs of a `width × height` view:
/// `horizontal[y·w + x]` couples `(x, y)`–`(x+1, y)` (last column unused), `vertical[y·w + x]`
/// couples `(x, y)`–`(x, y+1)` (last row unused).
#[derive(Clone, Debug, PartialEq)]
pub struct PairWeights {
    /// View width.
    pub width: usize,
    /// View height.
    pub height: usize,
    /// Pairs to the right neighbour.
    pub horizontal: Vec<f32>,
    /// Pairs to the neighbour below.
    pub vertical: Vec<f32>,
}

impl PairWeights {
    /// Every pair weighted `value`.
    pub fn constant(width: usize, height: usize, value: f32) -> Self {
        Self {
            width,
            height,
            horizontal: vec![value; width * height],
            vertical: vec![value; width * height],
        }
    }

    /// Multiplies by `factor` the weight of every pair with a pixel in `mask` (one flag per
    /// pixel).
    pub fn damp_pairs_touching(&mut self, mask: &[bool], factor: f32) {
        let w = self.width;
        for p in 0..self.width * self.height {
            let x = p % w;
            if x + 1 < w && (mask[p] || mask[p + 1]) {
                self.horizontal[p] *= factor;
            }
            if p + w < mask.len() && (mask[p] || mask[p + w]) {
                self.vertical[p] *= factor;
            }
        }
    }

    /// Every pair's weight becomes the smaller of its own and `other`'s (same size).
    pub fn keep_smaller(&mut self, other: &PairWeights) {
        for (a, b) in self.horizontal.iter_mut().zip(&other.horizontal) {
            *a = a.min(*b);
        }
        for (a, b) in self.vertical.iter_mut().zip(&other.vertical) {
            *a = a.min(*b);
        }
    }

    /// Weights from a function of the two pixel indices of each pair.
    pub fn from_pairs(width: usize, height: usize, f: impl Fn(usize, usize) -> f32) -> Self {
        let mut out = Self::constant(width, height, 0.0);
        for y in 0..height {
            for x in 0..width {
                let p = y * width + x;
                if x + 1 < width {
                    out.horizontal[p] = f(p, p + 1);
                }
                if y + 1 < height {
                    out.vertical[p] = f(p, p + width);
                }
            }
        }
        out
    }
}

/// Parameters of the cues; `Default` holds the thesis' values except where a field says
/// otherwise (`θ_a`, the crease cue).
#[derive(Clone, Debug, PartialEq)]
pub struct CueParams {
    /// `θ_a`: colour-line angle (radians) above which a pair is a reflectance change, eq. 4.10.
    /// Default 0.005. The thesis has 0.04. The default was chosen by leave-one-scene-out
    /// cross-validation on the 4 rendered tuning scenes, over θ_a ∈ {0.001, 0.0025, 0.005,
    /// 0.01, 0.02, 0.04} × μ ∈ {1e-3, 1e-2, 3e-2}: mean LMSE 0.0542 at the thesis' value with
    /// μ = 1e-2, against 0.0460 at 0.005. The cross-validated figure is 0.0477; three of the
    /// four folds chose 0.005. Rendered colours are nearly noise-free, so smaller colour turns
    /// carry information (docs/intrinsic-lightfields.md).
    pub theta_a: f32,
    /// `τ₁`: L*/100 above which a pixel starts to count as white, eq. 4.11. Default 0.85.
    pub tau_white: f32,
    /// `τ₂`: L*/100 below which a pixel starts to count as black, eq. 4.11. Default 0.05.
    pub tau_black: f32,
    /// Chroma (CIELab `√(a²+b²)`) at which a bright pixel stops counting as white. Not given in
    /// the thesis; default 20.
    pub white_chroma: f32,
    /// `ω_occ`: weight of the pairs across an occlusion, eq. 4.12. Default 0.01.
    pub omega_occ: f32,
    /// `ΔD_occ`: jump of the normalised depth (range of the light field mapped to [0, 1]) that
    /// marks an occlusion, eq. 4.12. Default 0.02.
    pub depth_step: f32,
    /// Change of the disparity's slope (pixels of disparity per pixel) across a pair above
    /// which the pair is a crease, weighted `ω_crease` ([`crease_cue`]). Not in
    /// the thesis: at a crease (a wall meeting the floor) the surface normal, and so the
    /// shading, jumps, where the gradient cues would keep the shading smooth; on a plane the
    /// disparity is affine in the image, so its slope does not change. It needs the same
    /// disparity as the occlusion cue and is off with it. `None`: no crease cue. Default 0.01,
    /// chosen by leave-one-scene-out cross-validation on LMSE + incoherence on the 16 rendered
    /// tuning scenes among off / 1e-3 / 1e-2 / 3e-2 (every fold; mean LMSE 0.0378 / 0.0376 /
    /// 0.0370 / 0.0366, incoherence 0.0046 / 0.0024 / 0.0028 / 0.0046;
    /// docs/intrinsic-lightfields.md).
    pub crease_step: Option<f32>,
    /// `ω_crease`: weight of the crease pairs ([`crease_cue`]). Default 0.01 (the occlusion's
    /// `ω_occ`), with `T_c` = 1.1, since the eleventh session. The ninth session had chosen 0.1
    /// with `T_c` 0.7 (with the data term's γ 2 it mended black walls beside white ones), but
    /// that pair also pushed real shading steps at the room's creases (a ceiling at a grazing
    /// light) into the reflectance. Chosen again with the reflectance filter's β 2 over
    /// `ω_crease` ∈ {0.01, 0.03, 0.1} × `T_c` ∈ {none, 0.7, 1.1} on 73 rendered tuning scenes
    /// (`examples/lightfield_cv.rs --crease-current`): leave-one-scene-out on LMSE + incoherence
    /// picks (0.01, 1.1) in every fold, cross-validated 0.0231 / 0.0044 and the goal
    /// met on 71 of 73 held out, against 0.0270 / 0.0050 and 71 for (0.1, 0.7). On 8 fresh
    /// scenes: 0.0172 / 0.0065 against 0.0216 / 0.0070, goal 8 of 8 for both
    /// (docs/intrinsic-lightfields.md, eleventh session).
    pub crease_weight: f32,
    /// `T_c`: the largest log-shading step a crease pair asks for ([`bound_crease_steps`]); the
    /// rest of a larger step goes to the reflectance. Default `Some(1.1)` (a shading ratio of
    /// about 3; see `crease_weight`); `None`: no bound, as before the ninth session.
    pub crease_shading_step: Option<f32>,
}

impl CueParams {
    /// Checks the crease pairs' weight (in (0, 1]) and shading bound (finite, non-negative).
    pub fn validate(&self) -> Result<()> {
        if !(self.crease_weight > 0.0 && self.crease_weight <= 1.0) {
            return Err(Error::param(
                "crease_weight",
                self.crease_weight,
                "must be in (0, 1]",
            ));
        }
        if let Some(t) = self.crease_shading_step
            && (!t.is_finite() || t < 0.0)
        {
            return Err(Error::param(
                "crease_shading_step",
                t,
                "must be finite and non-negative",
            ));
        }
        Ok(())
    }
}

impl Default for CueParams {
    fn default() -> Self {
        Self {
            theta_a: 0.005,
            tau_white: 0.85,
            tau_black: 0.05,
            white_chroma: 20.0,
            omega_occ: 0.01,
            depth_step: 0.02,
            crease_step: Some(0.01),
            crease_weight: 0.01,
            crease_shading_step: Some(1.1),
        }
    }
}

/// Angle (radians) between two RGB directions; 0 when either is black.
pub fn colour_line_angle(a: [f32; 3], b: [f32; 3]) -> f32 {
    let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let na = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    if na <= f32::MIN_POSITIVE || nb <= f32::MIN_POSITIVE {
        return 0.0;
    }
    (dot / (na * nb)).clamp(-1.0, 1.0).acos()
}

/// `(g^w, g^b)`: the probabilities that a linear RGB pixel (white = 1) is white or black,
/// ramps on CIELab lightness, eq. 4.11: `g^w` rises from 0 at `L*/100 = τ₁` to 1 at 1 and fades
/// with chroma; `g^b` rises from 0 at `τ₂` to 1 at 0.
pub fn white_black(p: [f32; 3], params: &CueParams) -> (f32, f32) {
    let [l, a, b] = linear_to_lab(p);
    let l = l / 100.0;
    let chroma = (a * a + b * b).sqrt();
    let white = ((l - params.tau_white) / (1.0 - params.tau_white)).clamp(0.0, 1.0)
        * (1.0 - chroma / params.white_chroma).clamp(0.0, 1.0);
    let black = ((params.tau_black - l) / params.tau_black).clamp(0.0, 1.0);
    (white, black)
}

/// The albedo cue `ω^a` of one view (eqs. 4.10–4.11). `chroma` is the view of `R₀` (any
/// positive scale per pixel; only directions matter), `intensity_rgb` the view of `L̂` scaled
/// so that white is 1 (for the CIELab probabilities); `white_black_cue` off is the ablation
/// without eq. 4.11.
pub fn albedo_cue(
    width: usize,
    height: usize,
    chroma: &[f32],
    intensity_rgb: &[f32],
    params: &CueParams,
    white_black_cue: bool,
) -> PairWeights {
    let rgb = |buf: &[f32], i: usize| [buf[3 * i], buf[3 * i + 1], buf[3 * i + 2]];
    let wb: Vec<(f32, f32)> = if white_black_cue {
        (0..width * height)
            .map(|i| white_black(rgb(intensity_rgb, i), params))
            .collect()
    } else {
        Vec::new()
    };
    PairWeights::from_pairs(width, height, |p, q| {
        let angle = colour_line_angle(rgb(chroma, p), rgb(chroma, q));
        let mut w = if angle > params.theta_a { 1.0 } else { 0.0 };
        if white_black_cue {
            let ((wp, bp), (wq, bq)) = (wb[p], wb[q]);
            w = f32::max(w, f32::max((wp - wq).abs(), (bp - bq).abs()));
        }
        w
    })
}

/// The occlusion cue `ω^occ` of one view (eq. 4.12) from its disparity (or depth) map and the
/// light field's disparity range `(min, max)` used to normalise it to [0, 1].
pub fn occlusion_cue(
    width: usize,
    height: usize,
    disparity: &[f32],
    range: (f32, f32),
    params: &CueParams,
) -> PairWeights {
    let span = (range.1 - range.0).max(f32::MIN_POSITIVE);
    PairWeights::from_pairs(width, height, |p, q| {
        if ((disparity[p] - disparity[q]) / span).abs() > params.depth_step {
            params.omega_occ
        } else {
            1.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_lines_see_chroma_changes_not_intensity_changes() {
        let p = CueParams::default();
        // Same direction at any intensity (shading): angle 0.
        assert!(colour_line_angle([0.2, 0.4, 0.1], [0.6, 1.2, 0.3]) < 1e-3);
        // Orthogonal primaries: π/2.
        let right = colour_line_angle([1.0, 0.0, 0.0], [0.0, 0.5, 0.0]);
        assert!((right - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        // A small turn just under and just over θ_a.
        let turn = |t: f32| [t.cos(), t.sin(), 0.0];
        let theta = p.theta_a;
        let chroma: Vec<f32> = [turn(0.0), turn(0.75 * theta), turn(2.0 * theta)]
            .iter()
            .flatten()
            .copied()
            .collect();
        let w = albedo_cue(3, 1, &chroma, &chroma, &p, false);
        assert_eq!(&w.horizontal[..2], &[0.0, 1.0]);
        // Black pixels have no colour line and give no angle cue.
        assert_eq!(colour_line_angle([0.0; 3], [1.0, 0.0, 0.0]), 0.0);
    }

    #[test]
    fn white_and_black_probabilities_follow_lightness_and_chroma() {
        let p = CueParams::default();
        let (w, b) = white_black([1.0; 3], &p);
        assert!(w > 0.999 && b == 0.0, "{w} {b}");
        assert_eq!(white_black([0.0; 3], &p), (0.0, 1.0));
        // Mid grey (L* ≈ 53) is neither; saturated bright red is not white.
        assert_eq!(white_black([0.21; 3], &p), (0.0, 0.0));
        assert_eq!(white_black([1.0, 0.0, 0.0], &p).0, 0.0);
        // A white pixel beside a mid-grey one: same colour line, so only eq. 4.11 marks the
        // pair; the ablation leaves it unmarked.
        let chroma = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let rgb = [1.0, 1.0, 1.0, 0.21, 0.21, 0.21];
        assert!(albedo_cue(2, 1, &chroma, &rgb, &p, true).horizontal[0] > 0.999);
        assert_eq!(
            albedo_cue(2, 1, &chroma, &rgb, &p, false).horizontal[0],
            0.0
        );
    }

    #[test]
    fn occlusion_cue_marks_depth_steps_only() {
        let p = CueParams::default();
        // Disparities 0, 0.01, 0.5, 0.5 over a range of 1: only the middle jump is an occlusion.
        let d = [0.0, 0.01, 0.5, 0.5];
        let w = occlusion_cue(4, 1, &d, (0.0, 1.0), &p);
        assert_eq!(&w.horizontal[..3], &[1.0, 0.01, 1.0]);
        // The same jump on a range 100 times wider is no longer an occlusion.
        let w = occlusion_cue(4, 1, &d, (0.0, 100.0), &p);
        assert_eq!(&w.horizontal[..3], &[1.0, 1.0, 1.0]);
        // Vertical pairs are indexed by the upper pixel.
        let w = occlusion_cue(1, 2, &[0.0, 1.0], (0.0, 1.0), &p);
        assert_eq!(w.vertical[0], 0.01);
    }
}
