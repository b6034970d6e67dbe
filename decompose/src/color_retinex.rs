//! Color Retinex (Grosse, Johnson, Adelson & Freeman, ICCV 2009), the baseline of the MIT
//! benchmark, solved with the crate's sparse least-squares solver.
//!
//! Every 4-neighbour derivative of the log luminance is attributed to reflectance when the
//! unit-chromaticity change exceeds `threshold_color` or the log-luminance change exceeds
//! `threshold_gray`, and to shading otherwise; the log reflectance is then the least-squares
//! integration of the reflectance derivatives (a Poisson problem), with its free constant per
//! connected piece fixed by zero mean (the final scale is set by
//! [`Decomposition::normalise`]). Shading is `Y / R`.
//!
//! Grosse et al. trained the two thresholds by cross-validation on the MIT training fold. We
//! did the same with a grid search on the twelve MIT development objects (the first fold plus
//! four extras; `examples/mit_sweep.rs`): mean LMSE 0.0355 at (gray 0.075, colour 0.01),
//! 0.0209 at (0.5, 0.03) and 0.0188 at the defaults (1.0, 0.03). A gray threshold this high
//! means nearly every reflectance edge must show a chromaticity change.

use crate::decomposition::{Decomposition, check_input};
use crate::error::{Error, Result};
use crate::grid::Grid;
use crate::image::{Image, Mask, resolve_mask};
use crate::progress::{Progress, ProgressFn};
use crate::solver::{LinearSystem, SolverInfo, SolverParams, zero_mean_per_component};

/// Parameters of [`decompose`].
#[derive(Clone, Debug, PartialEq)]
pub struct ColorRetinexParams {
    /// Log-luminance derivative above which an edge is reflectance regardless of colour.
    /// Default 1.0 (see the module docs for how the defaults were chosen).
    pub threshold_gray: f64,
    /// Unit-chromaticity derivative (Euclidean) above which an edge is reflectance.
    /// Default 0.03.
    pub threshold_color: f64,
    /// Linear solver settings.
    pub solver: SolverParams,
}

impl Default for ColorRetinexParams {
    fn default() -> Self {
        Self {
            threshold_gray: 1.0,
            threshold_color: 0.03,
            solver: SolverParams::default(),
        }
    }
}

/// Decomposes `input` (linear RGB) with Color Retinex.
pub fn decompose(
    input: &Image,
    mask: Option<&Mask>,
    params: &ColorRetinexParams,
    progress: ProgressFn,
) -> Result<(Decomposition, SolverInfo)> {
    for (name, v) in [
        ("threshold_gray", params.threshold_gray),
        ("threshold_color", params.threshold_color),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::param(name, v, "must be finite and >= 0"));
        }
    }
    params.solver.validate()?;
    let mask = resolve_mask(input.dims(), mask)?;
    check_input(input, &mask)?;
    progress(Progress {
        stage: "system",
        fraction: 0.0,
    });
    let g = Grid::new(input, &mask);
    let mut sys = LinearSystem::new(g.pixel.len());
    for (p, q) in g.pairs() {
        let d = g.log_y[p] - g.log_y[q];
        let reflectance_edge =
            d.abs() > params.threshold_gray || g.chroma_dist2(p, q).sqrt() > params.threshold_color;
        let rhs = if reflectance_edge { d } else { 0.0 };
        sys.add(
            &[(g.index[p] as usize, 1.0), (g.index[q] as usize, -1.0)],
            rhs,
            1.0,
        );
    }
    progress(Progress {
        stage: "solve",
        fraction: 0.3,
    });
    let (mut r, info) = sys.solve(&params.solver)?;
    zero_mean_per_component(&mut r, &sys.components());
    let mut shading = Image::new(input.width(), input.height(), 1);
    for (k, &p) in g.pixel.iter().enumerate() {
        shading.px_mut(p)[0] = (g.log_y[p] - r[k]).clamp(-80.0, 80.0).exp() as f32;
    }
    progress(Progress {
        stage: "done",
        fraction: 1.0,
    });
    Ok((Decomposition::from_shading(input, shading, &mask), info))
}
