//! The parameters of the TV-L1 flow, with the symbols and defaults of Sánchez, Meinhardt-Llopis
//! & Facciolo (IPOL 2013, §4 "Parameters" and their reference implementation).

use crate::error::{Error, Result};

/// Parameters of [`flow`](super::flow): the symbols of Zach, Pock & Bischof (2007) as used by
/// the IPOL description. `Default` is the IPOL defaults; [`TvL1FlowParams::fast`] trades
/// accuracy for speed (the video pipeline's setting).
#[derive(Clone, Debug, PartialEq)]
pub struct TvL1FlowParams {
    /// `λ`: weight of the L1 data term `λ|ρ(u)|` against the total variation of the flow
    /// (intensities normalised to [0, 255]). Smaller gives smoother flow. IPOL default 0.15.
    pub lambda: f32,
    /// `τ`: time step of the dual (Chambolle) iteration. Convergence is proved for τ < 1/8;
    /// IPOL notes that τ ≤ 1/4 works in practice and uses 0.25. Must be in (0, 0.25].
    pub tau: f32,
    /// `θ`: coupling of the relaxation `(u − v)² / 2θ` between the flow `u` and the auxiliary
    /// field `v`; small θ keeps them close. IPOL default 0.3.
    pub theta: f32,
    /// `ε`: stopping threshold. The inner iteration at a warp stops once the mean over pixels
    /// of `|uⁿ⁺¹ − uⁿ|²` falls to `ε²` (IPOL's criterion). IPOL default 0.01.
    pub epsilon: f32,
    /// `N_scales`: number of pyramid levels requested. Capped so that the coarsest level keeps
    /// a diagonal of at least 16 pixels (IPOL's rule). IPOL default 5.
    pub scales: usize,
    /// `η`: zoom factor between consecutive pyramid levels, in (0, 1). IPOL default 0.5.
    pub zoom: f32,
    /// `N_warps`: number of times the second image is re-warped (and the data term
    /// re-linearised, eq. of `ρ`) at each level. IPOL default 5.
    pub warps: usize,
    /// Cap on the inner iterations per warp (IPOL's `MAX_ITERATIONS`, 300).
    pub max_iterations: usize,
    /// Largest pyramid level solved, in pixels; `None` (the default, IPOL) solves every level
    /// down to the frames' own size. With `Some(n)` the levels with more than `n` pixels are
    /// not solved: the flow of the finest level solved is upsampled (bicubic, times the size
    /// ratio) to the frames' size, as OpenCV's DIS flow does below its `finest_scale`. Skipping
    /// the finest level halves the time of [`Self::fast`] on an 800×600 pair (module docs,
    /// "Accuracy and speed") and loses detail finer than about two pixels. The coarsest level
    /// is always solved.
    pub max_solved_pixels: Option<usize>,
}

impl Default for TvL1FlowParams {
    fn default() -> Self {
        Self {
            lambda: 0.15,
            tau: 0.25,
            theta: 0.3,
            epsilon: 0.01,
            scales: 5,
            zoom: 0.5,
            warps: 5,
            max_iterations: 300,
            max_solved_pixels: None,
        }
    }
}

impl TvL1FlowParams {
    /// The video setting: 3 warps of at most 30 inner iterations, the rest as [`Default`]. It
    /// bounds the finest level's work at 90 iterations (the defaults allow 1500) and costs
    /// about 20% less on ordinary pairs, for a small loss of accuracy (module docs, "Accuracy
    /// and speed").
    pub fn fast() -> Self {
        Self {
            warps: 3,
            max_iterations: 30,
            ..Self::default()
        }
    }

    /// Errors with [`Error::InvalidParam`] naming the first field out of range.
    pub fn validate(&self) -> Result<()> {
        let positive = |name, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::param(name, v, "must be finite and > 0"))
            }
        };
        positive("lambda", self.lambda)?;
        positive("theta", self.theta)?;
        positive("epsilon", self.epsilon)?;
        if !(self.tau > 0.0 && self.tau <= 0.25) {
            return Err(Error::param(
                "tau",
                self.tau,
                "must be in (0, 0.25] for the dual iteration to converge",
            ));
        }
        if !(self.zoom > 0.0 && self.zoom < 1.0) {
            return Err(Error::param("zoom", self.zoom, "must be in (0, 1)"));
        }
        for (name, v) in [
            ("scales", self.scales),
            ("warps", self.warps),
            ("max_iterations", self.max_iterations),
        ] {
            if v == 0 {
                return Err(Error::param(name, v, "must be at least 1"));
            }
        }
        if self.max_solved_pixels == Some(0) {
            return Err(Error::param(
                "max_solved_pixels",
                0,
                "must be at least 1 (None solves every level)",
            ));
        }
        Ok(())
    }
}
