//! Parameters of the clustering method, with the thesis' defaults and symbols.

use crate::error::{Error, Result};
use crate::solver::SolverParams;

/// Parameters of [`super::decompose`]. `Default` gives the values of the thesis (ch. 2).
#[derive(Clone, Debug, PartialEq)]
pub struct ClusteringParams {
    /// `k`: number of chroma segments found by k-means, §2.3.1. Paper default 10; default 30,
    /// chosen by leave-one-object-out cross-validation (`examples/mit_cv.rs`, see
    /// `docs/intrinsic-clustering.md`).
    pub k: usize,
    /// `μ`: steepness of the logistic steps that build the luminance feature β, eq. 2.2.
    /// Paper default 1e5 (an effectively hard step).
    pub mu: f32,
    /// `λ` as a fraction of the largest chroma feature over the image: magnitude of β, eq. 2.2.
    /// Paper 0.2; default 0.5 (cross-validated with `k` and the chroma features).
    pub lambda_fraction: f32,
    /// `L_min` as a fraction of max(L*): darker pixels get β = −λ, eq. 2.2. Default 0.15.
    pub l_min_fraction: f32,
    /// `L_max` as a fraction of max(L*): brighter pixels get β = +λ, eq. 2.2. Default 0.95.
    pub l_max_fraction: f32,
    /// `p`: clusters with fewer pixels are merged into the neighbour of closest mean chroma,
    /// §2.3.2. Default 10.
    pub min_cluster_pixels: usize,
    /// Clusters with fewer pixels than this many times their border pixel pairs (strips about
    /// this many pixels wide: the mixed-colour fringe between two albedos) join the adjacent
    /// cluster of closest chroma. Not in the thesis; 0 (default) disables it: on the MIT
    /// development objects it helped `dinosaur` but hurt the mean (0.0387 against 0.0340).
    pub thin_ratio: f32,
    /// Clusters with fewer pixels than this many times their border pixel pairs (fringe
    /// strips) are bridged: the clusters on both sides get direct border equations across the
    /// strip and the strip's own borders are down-weighted. Not in the thesis; 0 disables it.
    /// Default 0.8: mean LMSE on the MIT development objects 0.0305 without, 0.0293 / 0.0269 /
    /// 0.0260 / 0.0252 / 0.0273 at 0.5 / 0.6 / 0.7 / 0.8 / 1.0 (`dinosaur` 0.112 → 0.028,
    /// `teabag2` 0.075 → 0.103).
    pub bridge_ratio: f32,
    /// Pixels next to a border skipped before sampling the border window (mixed, anti-aliased
    /// pixels), where the cluster is thick enough. Not in the thesis (0 there). Default 2: mean
    /// LMSE on the MIT development objects 0.0411 with 0, 0.0340 with 1, 0.0302 with 2 or 3.
    pub border_skip: usize,
    /// Border equations are weighted by (border pixel pairs)^this: 0 weighs every border alike
    /// as the thesis does, 0.5 (default) lets long borders count more.
    pub border_weight_exponent: f32,
    /// Use the median of the per-pair log-luminance steps along a border instead of their mean
    /// (robust to the few mixed pixels of an albedo edge; the thesis averages). Default true
    /// (MIT development mean LMSE 0.0333 against 0.0340 with the mean).
    pub border_median: bool,
    /// `D` as a fraction of the image's largest value: adjacent clusters whose mean RGB
    /// difference across their border is below it are merged, §2.3.2. Paper 0.01; default 0
    /// (no merge): with the robust solve, merging lost on both development sets.
    pub merge_threshold: f32,
    /// Half-window (pixels on each side) over which luminance is averaged at a border for the
    /// continuity equations, eq. 2.5. Default 3.
    pub border_window: usize,
    /// `T_L`: same-segment clusters whose mean luminances differ by less than this fraction of
    /// the image's maximum luminance get reflectance equations, eq. 2.7. Default 0.05.
    pub t_l: f32,
    /// Reflectance equations (eq. 2.7) only between clusters that are linked by borders: a
    /// group of clusters cut off from the rest (an object isolated by the mask) keeps its own
    /// gauge instead of taking its level from an unrelated surface of similar chroma and mean
    /// luminance. Not in the thesis (false: all same-segment pairs). Default true, with
    /// `group_highlight_quantile` (chosen together in every cross-validation fold).
    pub reflectance_within_groups: bool,
    /// Level of the groups of clusters that no equation links to the largest one: `None`
    /// keeps the gauge (eq. 2.8: mean `ln f = 0` per group); `Some(q)` matches the q-quantile
    /// of each group's shading to the largest group's. Not in the thesis. Default `Some(0.98)`
    /// (with `reflectance_within_groups`): on the rendered tuning scenes the mean LMSE is
    /// 0.0152 in-sample and 0.0179 cross-validated, against 0.0200 and 0.0231 before; MIT
    /// objects are single groups and do not change.
    pub group_highlight_quantile: Option<f32>,
    /// Same-segment reflectance equations per cluster are limited to this many partners nearest
    /// in luminance (the paper links all qualifying pairs; see the module docs). Default 4:
    /// these non-local equations are what fills in the Cholesky factor (1 MP mosaic of
    /// `decompose bench`: the three solves take ~7 ms without them, ~140 ms with 16 partners,
    /// ~80–115 ms with 4), and 4 scores as 8 and 16 did on both development sets (MIT 0.0198
    /// against 0.0197; rendered tuning 0.0152 against 0.0153); 2 loses on MIT (0.0202).
    pub max_reflectance_partners: usize,
    /// Side of the median filter applied to the shading at cluster borders, §2.4. Default 5.
    pub median_size: usize,
    /// Iteratively reweighted least-squares passes after the first solve, L1 loss (0: plain
    /// least squares, as in the thesis). Default 2: the robust solve was chosen in every
    /// cross-validation fold; 2 passes score as 3 did (MIT 0.0197 against 0.0192, rendered
    /// tuning scenes 0.0199 against 0.0201) at two thirds of the extra solves.
    pub robust_iterations: usize,
    /// Scale `δ` of the robust loss, in log-shading units. Default 0.1 (0.02–0.4 all within
    /// 0.0005 of each other on the development sets).
    pub robust_delta: f32,
    /// Cauchy loss instead of L1 (off: it lost on the rendered development scenes).
    pub robust_cauchy: bool,
    /// Cluster on the chromaticity of the linear RGB, `(R − G, (R + G − 2B)/√3) / (R + G + B)`
    /// scaled by 100, instead of Lab (a, b) as the thesis does. Lab's a, b shrink with
    /// lightness, so a cast shadow on a coloured floor lands in another segment and its border
    /// equations put the shadow into the reflectance; chromaticity does not change with the
    /// light's intensity. Default true (cross-validated).
    pub chromaticity_features: bool,
    /// Independent k-means seedings; the lowest objective wins ([`crate::kmeans`]). Default 1.
    pub kmeans_restarts: usize,
    /// Seed of the k-means initialisation.
    pub seed: u64,
    /// Linear solver settings.
    pub solver: SolverParams,
}

impl Default for ClusteringParams {
    fn default() -> Self {
        Self {
            k: 30,
            mu: 1e5,
            lambda_fraction: 0.5,
            l_min_fraction: 0.15,
            l_max_fraction: 0.95,
            min_cluster_pixels: 10,
            thin_ratio: 0.0,
            bridge_ratio: 0.8,
            border_weight_exponent: 0.5,
            border_median: true,
            border_skip: 2,
            merge_threshold: 0.0,
            border_window: 3,
            t_l: 0.05,
            max_reflectance_partners: 4,
            reflectance_within_groups: true,
            group_highlight_quantile: Some(0.98),
            median_size: 5,
            robust_iterations: 2,
            robust_delta: 0.1,
            robust_cauchy: false,
            chromaticity_features: true,
            kmeans_restarts: 1,
            seed: 0,
            solver: SolverParams::default(),
        }
    }
}

impl ClusteringParams {
    /// Checks every range; called by [`super::decompose`].
    pub fn validate(&self) -> Result<()> {
        if self.k == 0 || self.k > 1000 {
            return Err(Error::param("k", self.k, "must be in 1..=1000"));
        }
        let unit = |name, v: f32| {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(())
            } else {
                Err(Error::param(name, v, "must be in [0, 1]"))
            }
        };
        unit("lambda_fraction", self.lambda_fraction)?;
        unit("l_min_fraction", self.l_min_fraction)?;
        unit("l_max_fraction", self.l_max_fraction)?;
        unit("merge_threshold", self.merge_threshold)?;
        unit("t_l", self.t_l)?;
        if self.l_min_fraction >= self.l_max_fraction {
            return Err(Error::param(
                "l_min_fraction",
                self.l_min_fraction,
                "must be below l_max_fraction",
            ));
        }
        if !(self.thin_ratio.is_finite() && self.thin_ratio >= 0.0) {
            return Err(Error::param(
                "thin_ratio",
                self.thin_ratio,
                "must be finite and >= 0",
            ));
        }
        if !(self.border_weight_exponent.is_finite()
            && (0.0..=2.0).contains(&self.border_weight_exponent))
        {
            return Err(Error::param(
                "border_weight_exponent",
                self.border_weight_exponent,
                "must be in [0, 2]",
            ));
        }
        if !(self.bridge_ratio.is_finite() && self.bridge_ratio >= 0.0) {
            return Err(Error::param(
                "bridge_ratio",
                self.bridge_ratio,
                "must be finite and >= 0",
            ));
        }
        if self.border_skip > 10 {
            return Err(Error::param(
                "border_skip",
                self.border_skip,
                "must be <= 10",
            ));
        }
        if !(self.mu.is_finite() && self.mu > 0.0) {
            return Err(Error::param("mu", self.mu, "must be finite and > 0"));
        }
        if self.border_window == 0 || self.border_window > 50 {
            return Err(Error::param(
                "border_window",
                self.border_window,
                "must be in 1..=50",
            ));
        }
        if self.median_size.is_multiple_of(2) || self.median_size > 31 {
            return Err(Error::param(
                "median_size",
                self.median_size,
                "must be odd and <= 31",
            ));
        }
        self.solver.validate()
    }
}
