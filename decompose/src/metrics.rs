//! Error measures: the local MSE of Grosse et al. (ICCV 2009), whole-image scale-invariant MSE,
//! and the WHDR of Bell et al. (SIGGRAPH 2014) for IIW judgements.

use std::path::Path;

use crate::error::{Error, Result};
use crate::image::{Image, Mask};

/// Sums over one window (or the whole image) for the scale-optimal squared error.
#[derive(Default)]
struct Acc {
    ge: f64,
    ee: f64,
    gg: f64,
}

impl Acc {
    /// Σ m (g − α e)² with the optimal α = Σ g e / Σ e² (α = 0 when the estimate is ~0,
    /// as in the reference implementation's 1e-5 guard).
    fn sse(&self) -> f64 {
        let alpha = if self.ee > 1e-5 {
            self.ge / self.ee
        } else {
            0.0
        };
        (self.gg - 2.0 * alpha * self.ge + alpha * alpha * self.ee).max(0.0)
    }
}

fn check(gt: &Image, est: &Image, mask: &Mask) -> Result<()> {
    gt.check_dims(est.dims())?;
    gt.check_dims(mask.dims())?;
    if gt.channels() != est.channels() {
        return Err(Error::param(
            "channels",
            est.channels(),
            "estimate and ground truth need the same channels",
        ));
    }
    Ok(())
}

/// Local MSE (Grosse et al. 2009): windows of `window`×`window` pixels shifted by `stride`; in
/// each window the estimate is scaled by its least-squares optimal factor, the masked squared
/// errors are summed over windows, and the sum is divided by the masked Σ gt² accumulated over
/// the same windows. All channels of a window share one scale.
pub fn lmse(gt: &Image, est: &Image, mask: &Mask, window: usize, stride: usize) -> Result<f64> {
    check(gt, est, mask)?;
    if window == 0 || stride == 0 {
        return Err(Error::param(
            "window/stride",
            window.min(stride),
            "must be > 0",
        ));
    }
    let (w, h, c) = (gt.width() as usize, gt.height() as usize, gt.channels());
    let (mut ssq, mut total) = (0.0, 0.0);
    let starts = |n: usize| {
        (0..)
            .map(move |k| k * stride)
            .take_while(move |s| s + window <= n)
    };
    for y0 in starts(h) {
        for x0 in starts(w) {
            let mut a = Acc::default();
            for y in y0..y0 + window {
                for x in x0..x0 + window {
                    let i = y * w + x;
                    if !mask.at(i) {
                        continue;
                    }
                    for ch in 0..c {
                        let (g, e) = (gt.px(i)[ch] as f64, est.px(i)[ch] as f64);
                        a.ge += g * e;
                        a.ee += e * e;
                        a.gg += g * g;
                    }
                }
            }
            ssq += a.sse();
            total += a.gg;
        }
    }
    Ok(if total > 0.0 { ssq / total } else { 0.0 })
}

/// Scale-invariant MSE over the whole masked image: mean of (gt − α·est)² with one optimal α.
pub fn si_mse(gt: &Image, est: &Image, mask: &Mask) -> Result<f64> {
    check(gt, est, mask)?;
    let mut a = Acc::default();
    let mut n = 0usize;
    for i in 0..gt.len() {
        if !mask.at(i) {
            continue;
        }
        for ch in 0..gt.channels() {
            let (g, e) = (gt.px(i)[ch] as f64, est.px(i)[ch] as f64);
            a.ge += g * e;
            a.ee += e * e;
            a.gg += g * g;
            n += 1;
        }
    }
    Ok(if n > 0 { a.sse() / n as f64 } else { 0.0 })
}

/// The mean of an image's channels (the MIT benchmark scores grey images).
pub fn grey(img: &Image) -> Image {
    let mut out = Image::new(img.width(), img.height(), 1);
    let c = img.channels() as f32;
    for i in 0..img.len() {
        out.px_mut(i)[0] = img.px(i).iter().sum::<f32>() / c;
    }
    out
}

/// Scores of one decomposition against MIT-style ground truth.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Scores {
    /// LMSE of the shading.
    pub lmse_shading: f64,
    /// LMSE of the (grey) reflectance.
    pub lmse_reflectance: f64,
    /// Their mean: the benchmark's LMSE.
    pub lmse: f64,
    /// Scale-invariant MSE of the shading.
    pub si_mse_shading: f64,
    /// Scale-invariant MSE of the (grey) reflectance.
    pub si_mse_reflectance: f64,
    /// Their mean.
    pub si_mse: f64,
}

/// Scores estimated reflectance and shading against ground truth, on grey images (the
/// convention of the published MIT tables), 20×20 windows with stride 10.
pub fn score(
    est_reflectance: &Image,
    est_shading: &Image,
    gt_reflectance: &Image,
    gt_shading: &Image,
    mask: &Mask,
) -> Result<Scores> {
    let (er, es, gr, gs) = (
        grey(est_reflectance),
        grey(est_shading),
        grey(gt_reflectance),
        grey(gt_shading),
    );
    let lmse_shading = lmse(&gs, &es, mask, 20, 10)?;
    let lmse_reflectance = lmse(&gr, &er, mask, 20, 10)?;
    let si_mse_shading = si_mse(&gs, &es, mask)?;
    let si_mse_reflectance = si_mse(&gr, &er, mask)?;
    Ok(Scores {
        lmse_shading,
        lmse_reflectance,
        lmse: 0.5 * (lmse_shading + lmse_reflectance),
        si_mse_shading,
        si_mse_reflectance,
        si_mse: 0.5 * (si_mse_shading + si_mse_reflectance),
    })
}

/// Weighted Human Disagreement Rate (Bell, Bala & Snavely 2014) of a linear reflectance image
/// against IIW judgements (the JSON of one IIW photo), with equality threshold `delta`
/// (0.10 in the paper). Comparisons with non-opaque points, unknown labels or non-positive
/// weights are skipped, as in the reference `whdr.py`.
pub fn whdr(reflectance: &Image, judgements: &str, delta: f64) -> Result<f64> {
    let fmt = |m: &str| Error::Format {
        path: Path::new("<judgements>").to_path_buf(),
        message: m.to_string(),
    };
    if reflectance.is_empty() {
        return Err(Error::EmptyImage {
            width: reflectance.width(),
            height: reflectance.height(),
        });
    }
    let v: serde_json::Value = serde_json::from_str(judgements).map_err(|e| fmt(&e.to_string()))?;
    let points = v["intrinsic_points"]
        .as_array()
        .ok_or_else(|| fmt("missing intrinsic_points"))?;
    let comparisons = v["intrinsic_comparisons"]
        .as_array()
        .ok_or_else(|| fmt("missing intrinsic_comparisons"))?;
    let mut by_id = std::collections::HashMap::new();
    for p in points {
        if let Some(id) = p["id"].as_i64() {
            by_id.insert(id, p);
        }
    }
    let (w, h) = (reflectance.width() as f64, reflectance.height() as f64);
    let value = |p: &serde_json::Value| -> Option<f64> {
        let (x, y) = (p["x"].as_f64()?, p["y"].as_f64()?);
        let (col, row) = (
            ((x * w) as usize).min(w as usize - 1),
            ((y * h) as usize).min(h as usize - 1),
        );
        let px = reflectance.get(col as u32, row as u32);
        let m = px.iter().map(|&v| v as f64).sum::<f64>() / px.len() as f64;
        Some(m.max(1e-10))
    };
    let (mut err, mut total) = (0.0, 0.0);
    for c in comparisons {
        let Some(darker) = c["darker"].as_str() else {
            continue;
        };
        if !matches!(darker, "1" | "2" | "E") {
            continue;
        }
        let weight = c["darker_score"].as_f64().unwrap_or(0.0);
        if weight <= 0.0 || !weight.is_finite() {
            continue;
        }
        let (Some(p1), Some(p2)) = (
            c["point1"].as_i64().and_then(|i| by_id.get(&i)),
            c["point2"].as_i64().and_then(|i| by_id.get(&i)),
        ) else {
            continue;
        };
        if !(p1["opaque"].as_bool().unwrap_or(false) && p2["opaque"].as_bool().unwrap_or(false)) {
            continue;
        }
        let (Some(l1), Some(l2)) = (value(p1), value(p2)) else {
            continue;
        };
        let predicted = if l2 / l1 > 1.0 + delta {
            "1"
        } else if l1 / l2 > 1.0 + delta {
            "2"
        } else {
            "E"
        };
        if predicted != darker {
            err += weight;
        }
        total += weight;
    }
    Ok(if total > 0.0 { err / total } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: u32, h: u32, s: f32) -> Image {
        Image::from_fn(w, h, |x, y| [s * (1.0 + x as f32 + 0.5 * y as f32)])
    }

    #[test]
    fn lmse_is_scale_invariant_and_zero_on_truth() {
        let g = ramp(40, 30, 1.0);
        let m = Mask::full(40, 30);
        assert!(lmse(&g, &ramp(40, 30, 3.0), &m, 20, 10).unwrap() < 1e-12);
        assert!(si_mse(&g, &ramp(40, 30, 0.2), &m).unwrap() < 1e-10);
    }

    #[test]
    fn lmse_matches_hand_computation() {
        // One 2x2 window: gt = [1,2,3,4], est = [1,1,1,1]: α = 10/4, SSE = 30 − 100/4 = 5.
        let g = Image::from_vec(2, 2, 1, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
        let e = Image::from_vec(2, 2, 1, vec![1.0; 4]).unwrap();
        let v = lmse(&g, &e, &Mask::full(2, 2), 2, 1).unwrap();
        assert!((v - 5.0 / 30.0).abs() < 1e-9, "{v}");
    }

    #[test]
    fn lmse_ignores_masked_pixels() {
        let g = ramp(20, 20, 1.0);
        let mut e = g.clone();
        e.px_mut(0)[0] = 100.0;
        let m = Mask::from_fn(20, 20, |x, y| x + y > 0);
        assert!(lmse(&g, &e, &m, 20, 10).unwrap() < 1e-12);
        assert!(lmse(&g, &e, &Mask::full(20, 20), 20, 10).unwrap() > 1e-3);
    }

    #[test]
    fn whdr_counts_weighted_disagreements() {
        let r = Image::from_fn(2, 1, |x, _| if x == 0 { [0.2f32; 3] } else { [0.8; 3] });
        let j = r#"{"intrinsic_points":[
            {"id":1,"x":0.25,"y":0.5,"opaque":true},
            {"id":2,"x":0.75,"y":0.5,"opaque":true},
            {"id":3,"x":0.75,"y":0.5,"opaque":false}],
          "intrinsic_comparisons":[
            {"point1":1,"point2":2,"darker":"1","darker_score":1.0},
            {"point1":1,"point2":2,"darker":"E","darker_score":3.0},
            {"point1":1,"point2":3,"darker":"2","darker_score":5.0}]}"#;
        let v = whdr(&r, j, 0.1).unwrap();
        assert!((v - 0.75).abs() < 1e-12, "{v}");
        assert!(whdr(&r, "{}", 0.1).is_err());
        assert!(whdr(&Image::new(0, 0, 3), j, 0.1).is_err());
    }
}
