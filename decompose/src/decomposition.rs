//! The result type shared by every method: `I = R × S`.

use crate::image::{Image, Mask};

/// An intrinsic decomposition: reflectance (RGB) and shading (grey), both linear, with
/// `reflectance × shading == input` for every pixel and channel up to rounding.
///
/// The product is exact by construction: each method estimates the shading, floors it at a tiny
/// positive value (so that near-black pixels give neither NaN nor Inf, the thesis' "dragon"
/// problem, §2.5) and divides. Outside the mask the input passes through as reflectance with
/// unit shading.
#[derive(Clone, Debug, PartialEq)]
pub struct Decomposition {
    /// Reflectance, 3 channels, scaled so that its 99.5th percentile channel value inside the
    /// mask is 1 (the decomposition is only defined up to a scale).
    pub reflectance: Image,
    /// Shading, 1 channel.
    pub shading: Image,
}

/// Relative shading floor: shading is never below this fraction of the input's largest value.
pub const SHADING_FLOOR: f32 = 1e-4;

impl Decomposition {
    /// Builds a decomposition from an estimated shading: floors it, divides, and normalises the
    /// reflectance scale. Non-finite shading values are treated as the floor.
    ///
    /// # Panics
    /// When the three images differ in size (an internal invariant of the methods).
    pub fn from_shading(input: &Image, mut shading: Image, mask: &Mask) -> Self {
        assert_eq!(input.dims(), shading.dims());
        assert_eq!(input.dims(), mask.dims());
        let floor = (input.max() * SHADING_FLOOR).max(f32::MIN_POSITIVE);
        let mut refl = Image::new(input.width(), input.height(), 3);
        for i in 0..input.len() {
            if !mask.at(i) {
                shading.px_mut(i)[0] = 1.0;
                refl.px_mut(i).copy_from_slice(&input.rgb(i));
                continue;
            }
            let s = shading.px(i)[0];
            let s = if s.is_finite() { s.max(floor) } else { floor };
            shading.px_mut(i)[0] = s;
            let p = input.rgb(i);
            refl.px_mut(i).copy_from_slice(&p.map(|v| v / s));
        }
        let mut d = Self {
            reflectance: refl,
            shading,
        };
        d.normalise(mask);
        d
    }

    /// Rescales so the 99.5th percentile of the per-pixel maximum reflectance channel inside the
    /// mask is 1, moving the inverse factor into the shading (the product is unchanged).
    pub fn normalise(&mut self, mask: &Mask) {
        let Some(q) = white_point(&self.reflectance, |i| mask.at(i)) else {
            return;
        };
        for i in 0..self.reflectance.len() {
            if mask.at(i) {
                self.reflectance.px_mut(i).iter_mut().for_each(|r| *r /= q);
                self.shading.px_mut(i)[0] *= q;
            }
        }
    }

    /// `R × S`, which should equal the input.
    pub fn reconstruct(&self) -> Image {
        let mut out = self.reflectance.clone();
        for i in 0..out.len() {
            let s = self.shading.px(i)[0];
            out.px_mut(i).iter_mut().for_each(|v| *v *= s);
        }
        out
    }
}

/// The white point of [`Decomposition::normalise`]: the 99.5th percentile of the per-pixel
/// largest reflectance channel over the pixels where `inside(i)`, if positive and finite.
pub(crate) fn white_point(reflectance: &Image, inside: impl Fn(usize) -> bool) -> Option<f32> {
    let mut v: Vec<f32> = (0..reflectance.len())
        .filter(|&i| inside(i))
        .map(|i| reflectance.px(i).iter().copied().fold(0.0, f32::max))
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    if v.is_empty() {
        return None;
    }
    let k = ((v.len() - 1) as f64 * 0.995).round() as usize;
    let (_, q, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    (q.is_finite() && *q > 0.0).then_some(*q)
}

/// Per-pixel labels (clusters or segments); [`Labels::NONE`] marks pixels outside the mask.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Labels {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major labels.
    pub data: Vec<u32>,
    /// Number of distinct labels (labels are `0..count`).
    pub count: usize,
}

impl Labels {
    /// The label of pixels outside the mask.
    pub const NONE: u32 = u32::MAX;

    /// A false-colour rendering (8-bit RGB bytes), one stable colour per label, black outside.
    pub fn false_colour(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.data.len() * 3);
        for &l in &self.data {
            out.extend_from_slice(&label_colour(l));
        }
        out
    }
}

/// A stable, well-spread colour for a label (golden-angle hue walk).
pub fn label_colour(l: u32) -> [u8; 3] {
    if l == Labels::NONE {
        return [0, 0, 0];
    }
    let h = (l as f32 * 137.507_77).rem_euclid(360.0);
    let s = 0.55 + 0.45 * ((l / 7) % 2) as f32;
    let v = 0.65 + 0.35 * ((l / 3) % 2) as f32;
    crate::color::hsv_to_rgb([h, s, v]).map(|c| (c * 255.0).round() as u8)
}

/// Checks an input image for a method: non-empty, finite, and not black inside the mask.
pub(crate) fn check_input(input: &Image, mask: &Mask) -> crate::Result<()> {
    use crate::Error;
    if input.is_empty() {
        return Err(Error::EmptyImage {
            width: input.width(),
            height: input.height(),
        });
    }
    if input.channels() != 3 {
        return Err(Error::param(
            "channels",
            input.channels(),
            "input must be RGB",
        ));
    }
    input.check_dims(mask.dims())?;
    let mut max = 0.0f32;
    for i in 0..input.len() {
        let p = input.px(i);
        for &v in p {
            if !v.is_finite() {
                let w = input.width();
                return Err(Error::NonFinite {
                    x: (i % w as usize) as u32,
                    y: (i / w as usize) as u32,
                });
            }
        }
        if mask.at(i) {
            max = max.max(p[0]).max(p[1]).max(p[2]);
        }
    }
    if mask.count() == 0 {
        return Err(Error::EmptyMask);
    }
    if max <= 1e-6 {
        return Err(Error::AllBlack { max });
    }
    Ok(())
}
