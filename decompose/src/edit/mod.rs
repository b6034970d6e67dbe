//! Editing applications built on a decomposition (thesis §2.6 and §3.8): every edit changes
//! one layer and recomposes `I' = R' × S'` (linear RGB).

use crate::color::{hsv_to_rgb, linear_to_lab, rgb_to_hsv};
use crate::decomposition::{Decomposition, Labels};
use crate::error::{Error, Result};
use crate::image::{Image, Mask, resolve_mask};
use crate::kmeans::{KMeansParams, kmeans};

/// `R × S` for a 3-channel reflectance and a 1-channel shading of the same size.
pub(crate) fn compose(refl: &Image, shading: &Image) -> Image {
    let mut out = refl.clone();
    for i in 0..out.len() {
        let s = shading.px(i)[0];
        out.px_mut(i).iter_mut().for_each(|v| *v *= s);
    }
    out
}

/// Recolouring: rotates the reflectance hue by `hue_degrees` and scales its saturation by
/// `saturation` (clamped to [0, 1]) inside `mask` (None: everywhere); the shading is kept.
pub fn recolour(
    d: &Decomposition,
    mask: Option<&Mask>,
    hue_degrees: f32,
    saturation: f32,
) -> Result<Image> {
    if !(hue_degrees.is_finite() && saturation.is_finite() && saturation >= 0.0) {
        return Err(Error::param(
            "saturation/hue",
            format!("{saturation}/{hue_degrees}"),
            "must be finite, saturation >= 0",
        ));
    }
    let mask = resolve_mask(d.reflectance.dims(), mask)?;
    let mut r = d.reflectance.clone();
    for i in 0..r.len() {
        if mask.at(i) {
            let [h, s, v] = rgb_to_hsv(r.rgb(i));
            let q = hsv_to_rgb([h + hue_degrees, (s * saturation).clamp(0.0, 1.0), v]);
            r.px_mut(i).copy_from_slice(&q);
        }
    }
    Ok(compose(&r, &d.shading))
}

/// Retexturing: the reflectance inside `mask` is replaced by `texture` (linear RGB, tiled from
/// the image origin); the shading is kept, so the texture follows the original lighting.
pub fn retexture(d: &Decomposition, mask: &Mask, texture: &Image) -> Result<Image> {
    let mask = resolve_mask(d.reflectance.dims(), Some(mask))?;
    if texture.is_empty() || texture.channels() != 3 {
        return Err(Error::EmptyImage {
            width: texture.width(),
            height: texture.height(),
        });
    }
    let mut r = d.reflectance.clone();
    let w = r.width() as usize;
    for i in 0..r.len() {
        if mask.at(i) {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            let t = texture.get(x % texture.width(), y % texture.height());
            r.px_mut(i).copy_from_slice(t);
        }
    }
    Ok(compose(&r, &d.shading))
}

/// A tone curve through control points, interpolated with monotone cubic Hermite splines
/// (Fritsch–Carlson), as the shading curves of the material edits in thesis §3.8.
#[derive(Clone, Debug, PartialEq)]
pub struct Curve {
    xs: Vec<f32>,
    ys: Vec<f32>,
    slopes: Vec<f32>,
}

impl Curve {
    /// Builds the curve; needs at least two points with distinct, finite x.
    pub fn new(points: &[(f32, f32)]) -> Result<Self> {
        let mut pts: Vec<(f32, f32)> = points.to_vec();
        if pts.len() < 2 || pts.iter().any(|p| !p.0.is_finite() || !p.1.is_finite()) {
            return Err(Error::param(
                "curve",
                pts.len(),
                "needs at least two finite control points",
            ));
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.windows(2).any(|w| w[1].0 <= w[0].0) {
            return Err(Error::param(
                "curve",
                "duplicate x",
                "control x values must differ",
            ));
        }
        let (xs, ys): (Vec<f32>, Vec<f32>) = pts.into_iter().unzip();
        let n = xs.len();
        let secant: Vec<f32> = (0..n - 1)
            .map(|k| (ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k]))
            .collect();
        let mut m = vec![0.0f32; n];
        m[0] = secant[0];
        m[n - 1] = secant[n - 2];
        for k in 1..n - 1 {
            m[k] = if secant[k - 1] * secant[k] <= 0.0 {
                0.0
            } else {
                (secant[k - 1] + secant[k]) / 2.0
            };
        }
        for k in 0..n - 1 {
            if secant[k] == 0.0 {
                m[k] = 0.0;
                m[k + 1] = 0.0;
                continue;
            }
            let (a, b) = (m[k] / secant[k], m[k + 1] / secant[k]);
            let s = a * a + b * b;
            if s > 9.0 {
                let t = 3.0 / s.sqrt();
                m[k] = t * a * secant[k];
                m[k + 1] = t * b * secant[k];
            }
        }
        Ok(Self { xs, ys, slopes: m })
    }

    /// Evaluates the curve; constant beyond the end points.
    pub fn eval(&self, x: f32) -> f32 {
        let n = self.xs.len();
        if x <= self.xs[0] {
            return self.ys[0];
        }
        if x >= self.xs[n - 1] {
            return self.ys[n - 1];
        }
        let k = self.xs.partition_point(|&v| v <= x) - 1;
        let h = self.xs[k + 1] - self.xs[k];
        let t = (x - self.xs[k]) / h;
        let (t2, t3) = (t * t, t * t * t);
        (2.0 * t3 - 3.0 * t2 + 1.0) * self.ys[k]
            + (t3 - 2.0 * t2 + t) * h * self.slopes[k]
            + (-2.0 * t3 + 3.0 * t2) * self.ys[k + 1]
            + (t3 - t2) * h * self.slopes[k + 1]
    }

    /// Evaluates the curve, continued beyond the end points along the end slopes instead of
    /// held constant: a value past the range the control points were drawn for (a frame
    /// brighter than the one the curve was set on) keeps its order, and the identity points
    /// give the identity everywhere.
    pub fn eval_extended(&self, x: f32) -> f32 {
        let n = self.xs.len();
        if x < self.xs[0] {
            return self.ys[0] + (x - self.xs[0]) * self.slopes[0];
        }
        if x > self.xs[n - 1] {
            return self.ys[n - 1] + (x - self.xs[n - 1]) * self.slopes[n - 1];
        }
        self.eval(x)
    }
}

/// Relighting / material edit: the shading, normalised by its maximum, is remapped through
/// `curve`; the reflectance is kept.
pub fn relight(d: &Decomposition, curve: &Curve) -> Image {
    let max = d.shading.max().max(f32::MIN_POSITIVE);
    let s = d.shading.map(|v| curve.eval(v / max).max(0.0) * max);
    compose(&d.reflectance, &s)
}

/// Colour transfer: each reflectance channel is histogram-matched to the reflectance of a
/// source image (quantile mapping), then recombined with the original shading.
pub fn transfer(d: &Decomposition, source_reflectance: &Image) -> Result<Image> {
    if source_reflectance.is_empty() || source_reflectance.channels() != 3 {
        return Err(Error::EmptyImage {
            width: source_reflectance.width(),
            height: source_reflectance.height(),
        });
    }
    let r = &d.reflectance;
    let mut out = r.clone();
    for c in 0..3 {
        let mut src: Vec<f32> = (0..source_reflectance.len())
            .map(|i| source_reflectance.px(i)[c])
            .collect();
        src.sort_by(f32::total_cmp);
        let mut order: Vec<usize> = (0..r.len()).collect();
        order.sort_by(|&a, &b| r.px(a)[c].total_cmp(&r.px(b)[c]));
        let n = order.len();
        for (rank, &i) in order.iter().enumerate() {
            let q = if n > 1 {
                rank as f64 / (n - 1) as f64
            } else {
                0.5
            };
            let j = (q * (src.len() - 1) as f64).round() as usize;
            out.px_mut(i)[c] = src[j];
        }
    }
    Ok(compose(&out, &d.shading))
}

/// Parameters of [`stylise`].
#[derive(Clone, Debug, PartialEq)]
pub struct StyliseParams {
    /// Reflectance saturation factor (>1 more vivid, <1 duller). Default 1.4.
    pub saturation: f32,
    /// Shading flattening in [0, 1]: 0 keeps it, 1 makes it its mean. Default 0.6.
    pub flatten: f32,
    /// Darkening of the edge layer in [0, 1]. Default 0.8.
    pub edge_strength: f32,
    /// Log-reflectance gradient above which a pixel is an edge. Default 0.3.
    pub edge_threshold: f32,
}

impl StyliseParams {
    /// Checks the ranges documented on the fields.
    pub(crate) fn validate(&self) -> Result<()> {
        let unit = |v: f32| v.is_finite() && (0.0..=1.0).contains(&v);
        let valid = unit(self.flatten)
            && unit(self.edge_strength)
            && self.saturation.is_finite()
            && self.saturation >= 0.0
            && self.edge_threshold.is_finite();
        if valid {
            Ok(())
        } else {
            Err(Error::param(
                "stylise",
                format!("{self:?}"),
                "flatten and edge_strength in [0, 1], saturation >= 0",
            ))
        }
    }
}

/// Scales the HSV saturation of a colour by `factor` (clamped to [0, 1]), keeping hue and value.
pub(crate) fn saturate(p: [f32; 3], factor: f32) -> [f32; 3] {
    let [h, s, v] = rgb_to_hsv(p);
    hsv_to_rgb([h, (s * factor).clamp(0.0, 1.0), v])
}

impl Default for StyliseParams {
    fn default() -> Self {
        Self {
            saturation: 1.4,
            flatten: 0.6,
            edge_strength: 0.8,
            edge_threshold: 0.3,
        }
    }
}

/// Stylisation: reflectance saturation change, flattened shading, and dark lines where the
/// reflectance changes (a cartoon-like look, thesis §2.6).
pub fn stylise(d: &Decomposition, p: &StyliseParams) -> Result<Image> {
    p.validate()?;
    let r = &d.reflectance;
    let (w, h) = (r.width() as usize, r.height() as usize);
    let mean_s = d.shading.data().iter().map(|&v| v as f64).sum::<f64>() / r.len().max(1) as f64;
    let mut out = Image::new(r.width(), r.height(), 3);
    let lr = |i: usize, c: usize| (r.px(i)[c].max(1e-4)).ln();
    for i in 0..r.len() {
        let q = saturate(r.rgb(i), p.saturation);
        let sh = (1.0 - p.flatten) * d.shading.px(i)[0] + p.flatten * mean_s as f32;
        let (x, y) = (i % w, i / w);
        let mut g = 0.0f32;
        for c in 0..3 {
            if x + 1 < w {
                g = g.max((lr(i + 1, c) - lr(i, c)).abs());
            }
            if y + 1 < h {
                g = g.max((lr(i + w, c) - lr(i, c)).abs());
            }
        }
        let edge = if g > p.edge_threshold {
            1.0 - p.edge_strength
        } else {
            1.0
        };
        out.px_mut(i).copy_from_slice(&q.map(|v| v * sh * edge));
    }
    Ok(out)
}

/// Segmentation by reflectance: k-means on the CIELab values of the reflectance inside `mask`.
pub fn segment(reflectance: &Image, mask: Option<&Mask>, k: usize, seed: u64) -> Result<Labels> {
    let mask = resolve_mask(reflectance.dims(), mask)?;
    let pts: Vec<[f32; 3]> = (0..reflectance.len())
        .filter(|&i| mask.at(i))
        .map(|i| linear_to_lab(reflectance.rgb(i).map(|v| v.clamp(0.0, 1.0))))
        .collect();
    let (labels, _, _) = kmeans(
        &pts,
        &KMeansParams {
            k,
            seed,
            ..Default::default()
        },
    )?;
    let mut data = vec![Labels::NONE; reflectance.len()];
    let mut it = labels.into_iter();
    for (i, d) in data.iter_mut().enumerate() {
        if mask.at(i) {
            *d = it.next().unwrap_or(0);
        }
    }
    Ok(Labels {
        width: reflectance.width(),
        height: reflectance.height(),
        data,
        count: k,
    })
}

#[cfg(test)]
mod tests;
