//! Steps 4 and 5 of the intrinsic-video method (Ye, Garces, Liu, Dai & Gutierrez, "Intrinsic
//! Video and Applications", SIGGRAPH 2014; thesis §3.4–3.5): the first frame's reflectance
//! clusters are carried to the next frame along the optical flow by a maximum-a-posteriori
//! (MAP) assignment, and the propagation stops when too much of a frame is left unassigned.
//!
//! The paper's text was not available while this was written (not in the search corpora);
//! everything here is built from the description in issue 20. Each reading of that
//! description is stated below as "the issue says …; we read it as …".
//!
//! # Cluster tables (§3.4), [`ClusterTables`]
//!
//! Per cluster `k`: `𝓡_k`, the reflectance values of its pixels, and `𝓘_k`, a colour histogram
//! of the input frame's pixels in the cluster with the mean reflectance per colour.
//! - The issue says "𝓡_k (reflectance histogram)"; we keep it as a sparse histogram of the
//!   reflectance quantised to 8-bit sRGB-encoded values (the reflectance, normalised so that its
//!   99.5th percentile is 1 by [`crate::Decomposition`], is clamped to [0, 1], sRGB-encoded and
//!   rounded), plus the exact mean reflectance of the cluster.
//! - The issue says "𝓘_k (colour histogram with the mean reflectance per colour)"; a colour bin
//!   is one 8-bit sRGB-encoded colour (the value a video file stores: frames are linear in this
//!   crate, so they are encoded with the sRGB curve, clamped and rounded), i.e. bins are exact
//!   8-bit colours and the Parzen window below is evaluated exactly on them. Per (colour,
//!   cluster) the table keeps the pixel count and the sum of their reflectance.
//! - [`ClusterTables::update`] adds the pixels of a later frame that have a label (the clustering
//!   update of eq. 3.10 will call it after completion); counts add exactly.
//!
//! # MAP propagation (§3.5.1–3.5.2), [`propagate`]
//!
//! For each pixel `p` of frame t+1 with 8-bit colour `I_p`, over the clusters `k`:
//! - likelihood (eq. 3.6), the Parzen estimate with the unit step `U`:
//!   `P(I_p | k) = (1/|𝓘_k|) Σ_{c ∈ 𝓘_k} U(d − ‖I_p − c‖)`, `d` = 5 in 8-bit sRGB units
//!   ([`PropagateParams::d`]); `U(0) = 1`, so a colour exactly `d` away counts. `𝓘_k` is the
//!   multiset of the cluster's pixel colours, so the sum is the number of the cluster's pixels
//!   whose colour lies in the ball, read from the histogram;
//! - prior (eq. 3.7): the issue says "the distance prior min D^{-1/2} inside an N×N window
//!   around the flow-warped pixel". Taken literally, the minimum of `D^{-1/2}` is reached at
//!   the cluster's *farthest* pixel in the window, which would favour small clusters and not
//!   near ones; we read it as `P(k) ∝ (min_q D(p′, q))^{-1/2}`, the inverse square root of the
//!   distance from `p′` to the nearest pixel `q` of cluster `k` in frame t, where `p′` is `p`
//!   warped back into frame t. Details:
//!   - `p′` solves `p′ + f(p′) = p` for the flow `f` from t to t+1 (our [`Flow`] convention
//!     `next(x + u, y + v) ≈ prev(x, y)`), by the fixed-point iteration `p′ ← p − f(p′)` from
//!     `p′ = p − f(p)`, with two bilinear refinements (exact for a translation); `p′` is then
//!     rounded to the nearest pixel and `D` is measured on frame t's pixel grid;
//!   - a pixel whose `p′` falls outside frame t (revealed at the border, or flow pointing out)
//!     has no source in frame t and is left unassigned for the completion step (§3.6);
//!   - the window: we use the disc of diameter `N` (radius `N/2`) inscribed in the `N×N`
//!     square, so that the minimum is a Euclidean distance transform truncated at `N/2`; a
//!     cluster with no pixel within `N/2` of `p′` is not a candidate;
//!   - `D = 0` (`p′` lands on a pixel of `k`) would give an infinite prior, i.e. the issue,
//!     taken literally, assigns every pixel whose `p′` lands on a cluster to that cluster and
//!     leaves nothing to the confidence test; we read it as `D` floored at half a pixel
//!     (`D_FLOOR` = 0.5 in `prior`), the uncertainty of the rounded `p′`.
//!     A pixel on the boundary between two clusters of the same colour (`p′` on one, the
//!     other 1 px away) then gets priors √2 : 1, a posterior ≈ 0.59 < `ε`, and stays
//!     unassigned. An earlier floor of 1 pixel made every pixel within about 13 px of
//!     another cluster of the same colour and likelihood unassigned (`0.65 / (0.65 + 0.6
//!     D^{-1/2}) < 0.8` below D ≈ 13): on the `bench --video` sequence, where the first
//!     frame's Retinex splits one albedo into several clusters, bands ~25 px wide along those
//!     boundaries filled more than 80% of 30×30 windows, and every frame was a stopping frame
//!     (19 of 19 at 320×240; 6 of 19 with the half-pixel floor);
//!   - frame t's unassigned pixels (label [`Labels::NONE`]) belong to no cluster.
//! - posterior: `P(k | I_p) = P(I_p | k) P(k) / Σ_j P(I_p | j) P(j)` over the candidates (clusters
//!   with a non-zero likelihood and a pixel in the window);
//! - high-confidence assignment (§3.5.2): `p` takes the MAP cluster only when its posterior is
//!   at least `ε` = 0.8 and at least `β` = 2 times the second best (computed on the
//!   unnormalised products, so a ratio of exactly β passes); otherwise it stays unassigned.
//!
//! The reflectance of an assigned pixel is the mean reflectance stored in `𝓘_k` for its exact
//! colour. When cluster `k` never had that exact colour (sub-pixel motion or new shading), the
//! brief asked for the cluster mean; we use instead the count-weighted mean reflectance of `k`'s
//! colours inside the Parzen ball, which is never empty for an assigned pixel (its likelihood is
//! positive) and keeps the shading-dependent variation of the reflectance within a cluster;
//! the cluster mean is [`ClusterTables::mean_reflectance`].
//!
//! With [`PropagateParams::reflectance_radius`] `r > 0` (not in the thesis; the video method's
//! default), every assigned pixel takes the count-weighted mean reflectance of `k`'s bins
//! within distance `r` of its colour instead. Under a moving light one albedo's colour changes
//! from frame to frame, and the exact bin carries the first frame's decomposition error pixel
//! by pixel; a wide ball pools it, and the cluster (which the MAP assignment chose) keeps
//! different albedos apart. The ball's bins are read through a grid of 16³-colour cells per
//! cluster (module `ball`), so a query reads the cells that meet the ball, not its volume.
//!
//! # Stopping condition (§3.5.3), [`should_stop`]
//!
//! The issue says "more than α = 80% unassigned in any M×M window; M = 30, 20, 10 over the
//! three passes". We read "any window" as every position of an `M×M` window lying inside the
//! frame (a frame smaller than `M` in one direction uses its full extent there), and "more
//! than" strictly. Counts come from an integral image, O(pixels).
//!
//! # Cost
//!
//! Likelihoods are computed once per distinct colour of frame t+1. The table's bins are sorted
//! by colour and indexed by (red, green), so the ball of radius `d` is the union of at most
//! `(2d + 1)²` intervals of blue values; the distinct colours that share (red, green) are
//! visited in increasing blue, and each interval slides up its run of bins, so each bin enters
//! and leaves the running integer counts once per such run. The fallback reflectance (no bin of
//! the exact colour) is computed only for the (colour, cluster) pairs an assigned pixel needs,
//! by a scan of the ball. Then distance transforms (Felzenszwalb & Huttenlocher's lower
//! envelope of parabolas) are run per cluster only over the bounding box of the pixels that
//! need them, i.e. those for which the cluster is a candidate but `p′` does not land on it,
//! cut to the bounding box of the cluster's own pixels; a request farther than `N/2` from
//! that box is answered "not in the window" without a transform. (Before that cut, a colour
//! shared by many clusters made each of them transform the whole frame: work clusters ×
//! pixels, which grew with the clusters added by completion.)
//! Work is split with rayon per pixel, per run of colours and per cluster; every value is
//! computed by one task in a fixed order, so the result does not depend on the number of
//! threads.
//!
//! Measured 2026-12-04 with `examples/propagate_speed.rs` (800×600, 50 clusters, ~93k distinct
//! colours in frame t+1, true flow; the 2-core machine was shared, load average ~4):
//! [`propagate`] 0.16–0.25 s wall with 2 threads (load average 2–4), 0.24–0.29 s with one; [`ClusterTables::from_frame`]
//! 0.07–0.10 s (once per video, then one [`ClusterTables::update`] per completed frame);
//! [`should_stop`] 1–2 ms per pass. The scan of the ball per distinct colour, before the
//! sliding, took 0.46 s on one thread; with 8×8×8 grid cells, 0.74 s.

mod ball;
mod map;
mod parzen;
mod prior;
mod stop;
mod tables;
#[cfg(test)]
mod tests;

pub use ball::ReflectanceMemo;
pub use map::{Propagation, propagate, propagate_with};
pub use stop::should_stop;
pub use tables::{ClusterTables, colour8};

use crate::decomposition::Labels;
use crate::error::{Error, Result};
#[cfg(doc)]
use crate::video::flow::Flow;

/// Parameters of [`propagate`] and [`should_stop`]; `Default` holds the values of issue 20
/// (thesis §3.5).
#[derive(Clone, Debug, PartialEq)]
pub struct PropagateParams {
    /// `d`: radius of the Parzen window of the colour likelihood (eq. 3.6), in 8-bit
    /// sRGB-encoded colour units (Euclidean over R, G, B). Default 5.
    pub d: f64,
    /// `N`: side of the window around the flow-warped pixel in which the distance prior looks
    /// for each cluster's nearest pixel (eq. 3.7); used as a disc of diameter `N`. Default 50.
    pub n: u32,
    /// `ε`: smallest posterior of the MAP cluster for a pixel to be assigned (§3.5.2).
    /// Default 0.8.
    pub epsilon: f64,
    /// `β`: smallest ratio of the best to the second best posterior for a pixel to be
    /// assigned (§3.5.2). Default 2.
    pub beta: f64,
    /// `α`: the propagation stops when more than this fraction of some `M×M` window is
    /// unassigned (§3.5.3). Default 0.8.
    pub alpha: f64,
    /// `M`: side of the stopping window (§3.5.3): 30, 20 and 10 over the three passes of
    /// Algorithm 1. Default 30 (the first pass).
    pub m: u32,
    /// Radius, in 8-bit sRGB-encoded colour units, of the colour ball over which an assigned
    /// pixel's reflectance is averaged among its cluster's bins of `𝓘_k` (count-weighted).
    /// 0 takes the bin of the pixel's exact colour, as the thesis does (the Parzen ball of
    /// radius `d` when the cluster has no such bin). Not in the thesis; default 0.
    pub reflectance_radius: f64,
}

impl Default for PropagateParams {
    fn default() -> Self {
        Self {
            d: 5.0,
            n: 50,
            epsilon: 0.8,
            beta: 2.0,
            alpha: 0.8,
            m: 30,
            reflectance_radius: 0.0,
        }
    }
}

impl PropagateParams {
    /// The window side `M` of each of the three passes (§3.5.3).
    pub const PASS_WINDOWS: [u32; 3] = [30, 20, 10];

    /// Errors with [`Error::InvalidParam`] naming the first value out of range.
    pub fn validate(&self) -> Result<()> {
        if !(self.d.is_finite() && self.d >= 0.0) {
            return Err(Error::param("d", self.d, "must be finite and >= 0"));
        }
        if self.n == 0 {
            return Err(Error::param("n", self.n, "must be >= 1"));
        }
        if !(self.epsilon > 0.0 && self.epsilon <= 1.0) {
            return Err(Error::param("epsilon", self.epsilon, "must be in (0, 1]"));
        }
        if !(self.beta.is_finite() && self.beta >= 1.0) {
            return Err(Error::param("beta", self.beta, "must be finite and >= 1"));
        }
        if !(self.reflectance_radius.is_finite() && self.reflectance_radius >= 0.0) {
            return Err(Error::param(
                "reflectance_radius",
                self.reflectance_radius,
                "must be finite and >= 0",
            ));
        }
        check_alpha_m(self.alpha, self.m)
    }
}

/// Validation shared with [`should_stop`].
fn check_alpha_m(alpha: f64, m: u32) -> Result<()> {
    if !(0.0..=1.0).contains(&alpha) {
        return Err(Error::param("alpha", alpha, "must be in [0, 1]"));
    }
    if m == 0 {
        return Err(Error::param("m", m, "must be >= 1"));
    }
    Ok(())
}

/// Errors unless the labels cover a non-empty frame with a consistent buffer.
fn check_labels(labels: &Labels) -> Result<()> {
    if labels.width == 0 || labels.height == 0 {
        return Err(Error::EmptyImage {
            width: labels.width,
            height: labels.height,
        });
    }
    let n = labels.width as usize * labels.height as usize;
    if labels.data.len() != n {
        return Err(Error::param(
            "labels.data.len()",
            labels.data.len(),
            "must equal width * height",
        ));
    }
    Ok(())
}
