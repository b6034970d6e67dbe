//! Colour transfer for a video (Ye et al. 2014 §6; the video form of [`crate::edit::transfer`]):
//! the reflectance is histogram-matched, channel by channel, to a source palette.
//!
//! Matching each frame's own histogram would re-decide the mapping every frame (a surface
//! entering the view would shift every other colour). The mapping is fitted **once**, on the
//! assigned reflectance of frame 0, as a monotone piecewise-linear function per channel
//! through [`KNOTS`] quantile pairs (reference quantile → source quantile), and the same
//! function maps every frame: equal input values give equal outputs in every frame, so a
//! cluster whose reflectance does not change does not change colour.
//!
//! Where the reference has a run of equal quantiles (a flat cluster holds much of the mass at
//! one value), the run's knots collapse into one whose output is the mean of the run's source
//! quantiles: the value maps to the average colour the source gives that share of pixels.
//! Values outside frame 0's range map to the ends of the source range. The mapping is fitted on
//! assigned pixels only but, being one fixed function of the value, maps unassigned pixels
//! too (the module's rule for such edits).

use crate::decomposition::{Decomposition, Labels};
use crate::error::{Error, Result};
use crate::image::Image;

use super::Frame;

/// Quantile levels the mapping is fitted at (0, 1/1024, …, 1).
pub const KNOTS: usize = 1025;

/// A monotone piecewise-linear map, constant beyond its ends.
#[derive(Clone, Debug, PartialEq)]
struct Lut {
    xs: Vec<f32>,
    ys: Vec<f32>,
}

impl Lut {
    fn eval(&self, v: f32) -> f32 {
        let n = self.xs.len();
        if v <= self.xs[0] {
            return self.ys[0];
        }
        if v >= self.xs[n - 1] {
            return self.ys[n - 1];
        }
        let k = self.xs.partition_point(|&x| x <= v) - 1;
        let t = (v - self.xs[k]) / (self.xs[k + 1] - self.xs[k]);
        self.ys[k] + t * (self.ys[k + 1] - self.ys[k])
    }
}

/// The `q`-quantile of sorted values, linear between order statistics.
fn quantile(sorted: &[f32], q: f64) -> f32 {
    let pos = q * (sorted.len() - 1) as f64;
    let (lo, t) = (pos.floor() as usize, (pos - pos.floor()) as f32);
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + t * (sorted[hi] - sorted[lo])
}

/// The quantile map from `reference` to `source` values (both sorted, non-empty).
fn fit_lut(reference: &[f32], source: &[f32]) -> Lut {
    let (mut xs, mut ys) = (Vec::with_capacity(KNOTS), Vec::with_capacity(KNOTS));
    let mut k = 0;
    while k < KNOTS {
        let q = |k: usize| k as f64 / (KNOTS - 1) as f64;
        let x = quantile(reference, q(k));
        let (mut sum, mut n) = (0.0f64, 0usize);
        while k < KNOTS && quantile(reference, q(k)) == x {
            sum += quantile(source, q(k)) as f64;
            n += 1;
            k += 1;
        }
        xs.push(x);
        ys.push((sum / n as f64) as f32);
    }
    Lut { xs, ys }
}

/// A per-channel reflectance mapping, fitted once.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourTransfer {
    luts: [Lut; 3],
}

impl ColourTransfer {
    /// Fits the mapping of frame 0's assigned reflectance onto the colours of `source` (a
    /// source image's reflectance, or any image whose colours are the wanted palette; linear
    /// RGB).
    ///
    /// Errors: [`Error::EmptyImage`] for an empty or non-RGB source, [`Error::InvalidParam`]
    /// when frame 0 has no assigned pixel or either side holds a non-finite value.
    pub fn fit(first: &Frame, source: &Image) -> Result<Self> {
        if source.is_empty() || source.channels() != 3 {
            return Err(Error::EmptyImage {
                width: source.width(),
                height: source.height(),
            });
        }
        let assigned: Vec<usize> = (0..first.labels.data.len())
            .filter(|&i| first.labels.data[i] != Labels::NONE)
            .collect();
        if assigned.is_empty() {
            return Err(Error::param(
                "frame 0",
                "no assigned pixel",
                "colour transfer fits on frame 0's clustered pixels",
            ));
        }
        let channel = |c: usize, values: &mut dyn Iterator<Item = f32>| -> Result<Vec<f32>> {
            let mut v: Vec<f32> = values.collect();
            if v.iter().any(|x| !x.is_finite()) {
                return Err(Error::param(
                    "colour transfer",
                    format!("channel {c}"),
                    "reflectance and source must be finite",
                ));
            }
            v.sort_by(f32::total_cmp);
            Ok(v)
        };
        let mut luts = Vec::with_capacity(3);
        for c in 0..3 {
            let reference = channel(c, &mut assigned.iter().map(|&i| first.reflectance.px(i)[c]))?;
            let src = channel(c, &mut (0..source.len()).map(|i| source.px(i)[c]))?;
            luts.push(fit_lut(&reference, &src));
        }
        let [r, g, b]: [Lut; 3] = luts.try_into().expect("three channels");
        Ok(Self { luts: [r, g, b] })
    }

    /// The mapped reflectance of one value.
    pub fn map(&self, p: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|c| self.luts[c].eval(p[c]))
    }

    /// The edited layers of one frame: mapped reflectance (every pixel, unassigned ones
    /// included), the shading unchanged.
    pub fn apply(&self, frame: &Frame) -> Decomposition {
        frame.edit_all(|_, _, r, s| (self.map(r), s))
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::sequence;
    use super::*;
    use std::collections::HashMap;

    fn source() -> Image {
        // A palette unlike the sequence's: red uniform on [0.1, 0.9], green on [0.05, 0.45],
        // blue constant 0.6.
        Image::from_fn(40, 10, |x, y| {
            let u = (y * 40 + x) as f32 / 399.0;
            [0.1 + 0.8 * u, 0.05 + 0.4 * (1.0 - u), 0.6]
        })
    }

    fn sorted_channel(img: &Image, c: usize, keep: impl Fn(usize) -> bool) -> Vec<f32> {
        let mut v: Vec<f32> = (0..img.len())
            .filter(|&i| keep(i))
            .map(|i| img.px(i)[c])
            .collect();
        v.sort_by(f32::total_cmp);
        v
    }

    #[test]
    fn frame_0_takes_the_source_quantiles() {
        let seq = sequence(false);
        let f0 = seq[0].frame();
        let src = source();
        let t = ColourTransfer::fit(&f0, &src).unwrap();
        let out = t.apply(&f0);
        for c in 0..3 {
            let got = sorted_channel(&out.reflectance, c, |i| {
                seq[0].labels.data[i] != Labels::NONE
            });
            let want = sorted_channel(&src, c, |_| true);
            for q in 1..10 {
                let q = q as f64 / 10.0;
                let (a, b) = (quantile(&got, q), quantile(&want, q));
                assert!((a - b).abs() < 0.01, "channel {c} q {q}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn every_frame_gets_the_same_mapping() {
        let seq = sequence(false);
        let t = ColourTransfer::fit(&seq[0].frame(), &source()).unwrap();
        // Input value (bits) → output value, over every frame: never two outputs for one input.
        let mut seen: HashMap<[u32; 3], [f32; 3]> = HashMap::new();
        let mut repeats = 0;
        for f in &seq {
            let out = t.apply(&f.frame());
            assert_eq!(out.shading, f.shading);
            for (i, &l) in f.labels.data.iter().enumerate() {
                let r = f.reflectance.rgb(i);
                let o = out.reflectance.rgb(i);
                // Unassigned pixels too: the mapping needs no cluster.
                assert_eq!(o, t.map(r));
                if l == Labels::NONE {
                    continue;
                }
                if let Some(prev) = seen.insert(r.map(f32::to_bits), o) {
                    assert_eq!(prev, o);
                    repeats += 1;
                }
            }
        }
        // The moving square's texture moves with it: its values recur in every frame.
        assert!(repeats >= 40, "{repeats}");
    }

    #[test]
    fn flat_runs_collapse_and_bad_sources_are_refused() {
        // Half the reference at one value: it maps to the mean of the lower half of the source.
        let reference = [
            vec![0.5f32; 50],
            (0..50).map(|i| 0.6 + i as f32 * 0.001).collect(),
        ]
        .concat();
        let source: Vec<f32> = (0..100).map(|i| i as f32 / 99.0).collect();
        let lut = fit_lut(&reference, &source);
        assert!((lut.eval(0.5) - 0.25).abs() < 0.01, "{}", lut.eval(0.5));
        assert!(lut.xs.windows(2).all(|w| w[0] < w[1]));
        assert!(lut.ys.windows(2).all(|w| w[0] <= w[1]));
        let seq = sequence(true);
        assert!(ColourTransfer::fit(&seq[0].frame(), &Image::new(0, 0, 3)).is_err());
        assert!(ColourTransfer::fit(&seq[0].frame(), &Image::new(4, 4, 1)).is_err());
    }
}
