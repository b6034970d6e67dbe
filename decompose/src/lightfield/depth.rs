//! Disparity from epipolar-plane images by the structure tensor (Wanner & Goldluecke, "Globally
//! consistent depth labeling of 4D light fields", CVPR 2012; "Variational light field analysis
//! for disparity estimation and super-resolution", PAMI 2014; the local estimate) — step 1 of the
//! thesis's Algorithm 2 when no disparity is given.
//!
//! An epipolar-plane image (EPI) `S(x, s)` is one image row `y` of the views of one grid row,
//! `s` the view's column. A scene point traces a line in it whose slope is its disparity (HCI
//! convention, [`super::disparity`]: `x + s·d = const`). The structure tensor
//! `J = G_outer ∗ (∇S ∇Sᵀ)`, with `∇S = (S_x, S_s)` taken after smoothing at the inner scale,
//! gives the line's orientation: with `J = [[J_xx, J_xs], [J_xs, J_ss]]`, the dominant gradient
//! makes the angle `θ = ½·atan2(2J_xs, J_xx − J_ss)` with the `x` axis and the line runs across
//! it, so `d = tan θ` (for `S = f(x + s·d)`: `J_xs/J_xx = d`, `J_ss/J_xx = d²`, `θ = atan d`).
//! Its reliability is the coherence `r = √((J_ss − J_xx)² + 4J_xs²) / (J_xx + J_ss)` ∈ [0, 1].
//! Vertical EPIs (one image column of the views of one grid column) give a second estimate the
//! same way (`y + t·d = const`); per pixel the estimate with the higher coherence is kept (the
//! direction along which the EPI shows clean lines; a coherence-weighted mean would blend in the
//! other direction's failures at edges parallel to it). Colour channels are summed into one
//! tensor, as in the authors' code.
//!
//! Deliberate choices: derivatives are Gaussian-weighted least-squares slopes and smoothing is a
//! Gaussian-weighted mean, both with the kernel truncated at the image and grid borders and
//! renormalised (an angular axis has only 5–9 samples, so mirrored borders would bias the
//! slope). Large disparities are handled by refocusing: the EPIs are sheared by whole-pixel
//! disparities ([`EpiParams::shears`]), the residual slope is measured, and per pixel the most
//! coherent estimate whose residual is within [`EpiParams::max_residual`] is kept. No global
//! optimisation (the papers' variational / labelling step) is done here.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::image::Image;

use super::LightField;

/// Parameters of [`epi_disparity`]. The scales are those of the authors' reference code
/// (`structureTensor2D(lf, inner_scale=0.6, outer_scale=1.3)`, Sven Wanner's `mypy.lightfield`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpiParams {
    /// Inner scale (pixels and views): standard deviation of the Gaussian under which the EPI's
    /// gradient `(S_x, S_s)` is taken (default 0.6).
    pub inner_scale: f32,
    /// Outer scale: standard deviation of the Gaussian that integrates the gradient products into
    /// the structure tensor `J` (default 1.3).
    pub outer_scale: f32,
    /// Refocusing: the EPIs are also sheared by every integer disparity in `−shears..=shears`
    /// and each estimate adds its shear back, so that a slope of 1.5 px/view is measured as a
    /// small residual around 1 or 2, where the local line model holds (the authors' code runs
    /// the estimate on light fields shifted by a given disparity, its `shift` argument). 0 is
    /// the plain method (default 2: disparities up to about ±3 px/view, beyond the HCI range).
    pub shears: u32,
    /// Largest `|d − shear|` (pixels per view) an estimate may have; beyond it the estimate's
    /// coherence is 0, so a better-focused shear or the other EPI direction wins (default 1.0).
    pub max_residual: f32,
}

impl Default for EpiParams {
    fn default() -> Self {
        Self {
            inner_scale: 0.6,
            outer_scale: 1.3,
            shears: 2,
            max_residual: 1.0,
        }
    }
}

impl EpiParams {
    fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("inner_scale", self.inner_scale),
            ("outer_scale", self.outer_scale),
            ("max_residual", self.max_residual),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::param(name, v, "must be finite and > 0"));
            }
        }
        if self.shears > 16 {
            return Err(Error::param("shears", self.shears, "at most 16"));
        }
        Ok(())
    }
}

/// Disparity of the centre view (`(rows/2, cols/2)`, HCI's `input_Cam040` for 9×9) from the
/// structure tensor of its horizontal and vertical EPIs. Returns the 1-channel disparity
/// (pixels per view step, HCI convention) and the 1-channel coherence of the estimate kept.
/// See [`epi_disparity_view`] for the errors.
pub fn epi_disparity(lf: &LightField, params: &EpiParams) -> Result<(Image, Image)> {
    epi_disparity_view(lf, (lf.rows() / 2, lf.cols() / 2), params)
}

/// [`epi_disparity`] for any view `(row, col)`: its horizontal EPIs come from the views of grid
/// row `row`, its vertical ones from the views of grid column `col`.
///
/// Errors on invalid params, a view outside the grid, or a grid with fewer than 3 views in both
/// directions (an EPI needs at least 3 to show a slope; a direction with fewer is skipped).
pub fn epi_disparity_view(
    lf: &LightField,
    view: (usize, usize),
    params: &EpiParams,
) -> Result<(Image, Image)> {
    params.validate()?;
    let (row, col) = view;
    if row >= lf.rows() || col >= lf.cols() {
        return Err(Error::param(
            "view",
            format!("({row}, {col})"),
            "outside the camera grid",
        ));
    }
    if lf.rows() < 3 && lf.cols() < 3 {
        return Err(Error::param(
            "grid",
            format!("{}x{}", lf.rows(), lf.cols()),
            "EPI disparity needs at least 3 views in one direction",
        ));
    }
    let (w, h) = (lf.width() as usize, lf.height() as usize);
    let n = w * h;
    let mut disparity = vec![0.0f32; n];
    let mut coherence = vec![0.0f32; n];
    if lf.cols() >= 3 {
        let views: Vec<&[f32]> = (0..lf.cols())
            .map(|c| lf.view_data(lf.view_index(row, c)))
            .collect();
        let (d, r) = horizontal(&views, w, h, lf.channels(), col, params);
        disparity = d;
        coherence = r;
    }
    if lf.rows() >= 3 {
        // A vertical EPI is a horizontal one of the transposed views: `y + t·d = const` has the
        // same form as `x + s·d = const`.
        let transposed: Vec<Vec<f32>> = (0..lf.rows())
            .map(|r| transpose(lf.view_data(lf.view_index(r, col)), w, h, lf.channels()))
            .collect();
        let views: Vec<&[f32]> = transposed.iter().map(Vec::as_slice).collect();
        let (d, r) = horizontal(&views, h, w, lf.channels(), row, params);
        let (d, r) = (transpose(&d, h, w, 1), transpose(&r, h, w, 1));
        let first = lf.cols() < 3;
        for i in 0..n {
            if first || r[i] > coherence[i] {
                disparity[i] = d[i];
                coherence[i] = r[i];
            }
        }
    }
    Ok((
        Image::from_vec(w as u32, h as u32, 1, disparity)?,
        Image::from_vec(w as u32, h as u32, 1, coherence)?,
    ))
}

/// `(row-major data of size w×h×ch)ᵀ`, i.e. an `h×w` image.
fn transpose(data: &[f32], w: usize, h: usize, ch: usize) -> Vec<f32> {
    let mut out = vec![0.0; data.len()];
    for y in 0..h {
        for x in 0..w {
            let (src, dst) = ((y * w + x) * ch, (x * h + y) * ch);
            out[dst..dst + ch].copy_from_slice(&data[src..src + ch]);
        }
    }
    out
}

/// Disparity and coherence of view `eval` of a row of views (`views[s]`, each `w×h×ch`) from
/// its horizontal EPIs, one image row at a time (rows are independent: the EPI of row `y` only
/// involves row `y` of every view).
fn horizontal(
    views: &[&[f32]],
    w: usize,
    h: usize,
    ch: usize,
    eval: usize,
    p: &EpiParams,
) -> (Vec<f32>, Vec<f32>) {
    let inner = Kernel::new(p.inner_scale);
    let outer = Kernel::new(p.outer_scale);
    let ns = views.len();
    let rows: Vec<(Vec<f32>, Vec<f32>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut best_d = vec![0.0f32; w];
            let mut best_r = vec![-1.0f32; w];
            let mut epi = vec![0.0f32; ns * w];
            for shear in -(p.shears as i64)..=p.shears as i64 {
                let mut tensor = Tensor::new(ns * w);
                for k in 0..ch {
                    // The EPI of row y, sheared by the integer disparity `shear`
                    // (refocusing): E'(x, s) = E(x − (s − eval)·shear, s), a whole-pixel shift
                    // per view, so no interpolation blurs it. Its lines have slope d − shear.
                    for (s, v) in views.iter().enumerate() {
                        let shift = (s as i64 - eval as i64) * shear;
                        for x in 0..w {
                            let sx = (x as i64 - shift).clamp(0, w as i64 - 1) as usize;
                            epi[s * w + x] = v[(y * w + sx) * ch + k];
                        }
                    }
                    tensor.add_channel(&epi, ns, w, &inner);
                }
                let (jxx, jxs, jss) = tensor.integrate(ns, w, eval, &outer);
                for x in 0..w {
                    let (d, r) = orientation(jxx[x], jxs[x], jss[x], p.max_residual);
                    if r > best_r[x] {
                        best_d[x] = d + shear as f32;
                        best_r[x] = r;
                    }
                }
            }
            (best_d, best_r)
        })
        .collect();
    let mut d = Vec::with_capacity(w * h);
    let mut r = Vec::with_capacity(w * h);
    for (dr, rr) in rows {
        d.extend(dr);
        r.extend(rr);
    }
    (d, r)
}

/// The gradient products of one EPI summed over channels, `ns × w` each.
struct Tensor {
    jxx: Vec<f32>,
    jxs: Vec<f32>,
    jss: Vec<f32>,
    tmp: Vec<f32>,
    sx: Vec<f32>,
    ss: Vec<f32>,
}

impl Tensor {
    fn new(n: usize) -> Self {
        Self {
            jxx: vec![0.0; n],
            jxs: vec![0.0; n],
            jss: vec![0.0; n],
            tmp: vec![0.0; n],
            sx: vec![0.0; n],
            ss: vec![0.0; n],
        }
    }

    /// Adds `∇S ∇Sᵀ` of one channel's EPI, the gradient taken at the inner scale:
    /// `S_x` smooths along `s` then takes the slope along `x`, `S_s` the other way round.
    fn add_channel(&mut self, epi: &[f32], ns: usize, w: usize, inner: &Kernel) {
        inner.apply_s(epi, &mut self.tmp, ns, w, false);
        inner.apply_x(&self.tmp, &mut self.sx, ns, w, true);
        inner.apply_x(epi, &mut self.tmp, ns, w, false);
        inner.apply_s(&self.tmp, &mut self.ss, ns, w, true);
        for i in 0..ns * w {
            self.jxx[i] += self.sx[i] * self.sx[i];
            self.jxs[i] += self.sx[i] * self.ss[i];
            self.jss[i] += self.ss[i] * self.ss[i];
        }
    }

    /// The outer integration, needed at `s = eval` only: along `s` first, then along `x`.
    fn integrate(
        &self,
        ns: usize,
        w: usize,
        eval: usize,
        outer: &Kernel,
    ) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let smooth = |j: &[f32]| {
            let along_s = outer.at_s(j, ns, w, eval);
            let mut out = vec![0.0; w];
            outer.apply_x(&along_s, &mut out, 1, w, false);
            out
        };
        (smooth(&self.jxx), smooth(&self.jxs), smooth(&self.jss))
    }
}

/// Disparity and coherence from the tensor entries (module docs); an estimate beyond
/// `max_disparity` is clamped and gets coherence 0.
fn orientation(jxx: f32, jxs: f32, jss: f32, max_disparity: f32) -> (f32, f32) {
    let trace = jxx + jss;
    if trace <= f32::EPSILON * 1e3 {
        return (0.0, 0.0);
    }
    let coherence = ((jss - jxx).powi(2) + 4.0 * jxs * jxs).sqrt() / trace;
    let theta = 0.5 * (2.0 * jxs).atan2(jxx - jss);
    let d = theta.tan();
    if !d.is_finite() || d.abs() > max_disparity {
        return (
            if d.is_nan() {
                0.0
            } else {
                d.clamp(-max_disparity, max_disparity)
            },
            0.0,
        );
    }
    (d, coherence.min(1.0))
}

/// A sampled Gaussian `g(t)`, `|t| ≤ ⌈3σ⌉`, applied along one axis of a `ns × w` array either as
/// a weighted mean (smoothing) or as a weighted least-squares slope (derivative), the kernel
/// truncated at the borders and renormalised.
struct Kernel {
    g: Vec<f32>,
    radius: isize,
}

impl Kernel {
    fn new(sigma: f32) -> Self {
        let radius = (3.0 * sigma).ceil().max(1.0) as isize;
        let g = (-radius..=radius)
            .map(|t| (-((t * t) as f32) / (2.0 * sigma * sigma)).exp())
            .collect();
        Self { g, radius }
    }

    /// Smoothing (`slope = false`) or slope of the samples `f(i + t)`, `0 ≤ i + t < len`.
    fn one(&self, len: usize, i: usize, f: impl Fn(usize) -> f32, slope: bool) -> f32 {
        let lo = (-self.radius).max(-(i as isize));
        let hi = self.radius.min(len as isize - 1 - i as isize);
        let (mut sw, mut swt, mut swf, mut swtf, mut swtt) = (0.0f32, 0.0, 0.0, 0.0, 0.0);
        for t in lo..=hi {
            let g = self.g[(t + self.radius) as usize];
            let v = f((i as isize + t) as usize);
            let tf = t as f32;
            sw += g;
            swt += g * tf;
            swf += g * v;
            swtf += g * tf * v;
            swtt += g * tf * tf;
        }
        if !slope {
            return swf / sw;
        }
        // Weighted least squares: Σg(t−m)f / Σg(t−m)², m = Σgt / Σg.
        let m = swt / sw;
        let den = swtt - m * swt;
        if den <= 0.0 {
            0.0
        } else {
            (swtf - m * swf) / den
        }
    }

    fn apply_x(&self, src: &[f32], dst: &mut [f32], ns: usize, w: usize, slope: bool) {
        for s in 0..ns {
            let row = &src[s * w..(s + 1) * w];
            for x in 0..w {
                dst[s * w + x] = self.one(w, x, |i| row[i], slope);
            }
        }
    }

    fn apply_s(&self, src: &[f32], dst: &mut [f32], ns: usize, w: usize, slope: bool) {
        for x in 0..w {
            for s in 0..ns {
                dst[s * w + x] = self.one(ns, s, |i| src[i * w + x], slope);
            }
        }
    }

    /// Smoothing along `s`, evaluated at `s = at` only: a length-`w` row.
    fn at_s(&self, src: &[f32], ns: usize, w: usize, at: usize) -> Vec<f32> {
        (0..w)
            .map(|x| self.one(ns, at, |i| src[i * w + x], false))
            .collect()
    }
}

#[cfg(test)]
#[path = "depth_tests.rs"]
mod tests;
