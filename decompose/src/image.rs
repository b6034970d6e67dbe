//! In-memory image buffers: linear floating-point planes and boolean masks.

use crate::error::{Error, Result};

/// A floating-point image with `channels` interleaved channels per pixel, row-major.
///
/// Values are linear (proportional to light) unless a function says otherwise.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    width: u32,
    height: u32,
    channels: usize,
    data: Vec<f32>,
}

impl Image {
    /// A zero-filled image.
    pub fn new(width: u32, height: u32, channels: usize) -> Self {
        Self {
            width,
            height,
            channels,
            data: vec![0.0; width as usize * height as usize * channels],
        }
    }

    /// Wraps an interleaved buffer; errors when its length is not `width·height·channels`.
    pub fn from_vec(width: u32, height: u32, channels: usize, data: Vec<f32>) -> Result<Self> {
        let expected = width as usize * height as usize * channels;
        if data.len() != expected || channels == 0 {
            return Err(Error::param(
                "data.len()",
                data.len(),
                "must equal width * height * channels (channels > 0)",
            ));
        }
        Ok(Self {
            width,
            height,
            channels,
            data,
        })
    }

    /// Builds an image from a function of (x, y) returning one pixel.
    pub fn from_fn<const C: usize>(
        width: u32,
        height: u32,
        f: impl Fn(u32, u32) -> [f32; C],
    ) -> Self {
        let mut data = Vec::with_capacity(width as usize * height as usize * C);
        for y in 0..height {
            for x in 0..width {
                data.extend_from_slice(&f(x, y));
            }
        }
        Self {
            width,
            height,
            channels: C,
            data,
        }
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
    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.width as usize * self.height as usize
    }
    /// True when the image has no pixel.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The interleaved samples.
    pub fn data(&self) -> &[f32] {
        &self.data
    }
    /// The interleaved samples, mutable.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }
    /// Consumes the image, returning its samples.
    pub fn into_vec(self) -> Vec<f32> {
        self.data
    }
    /// The samples of pixel number `i` (row-major index).
    pub fn px(&self, i: usize) -> &[f32] {
        &self.data[i * self.channels..(i + 1) * self.channels]
    }
    /// The samples of pixel number `i`, mutable.
    pub fn px_mut(&mut self, i: usize) -> &mut [f32] {
        &mut self.data[i * self.channels..(i + 1) * self.channels]
    }
    /// The samples of pixel (x, y).
    pub fn get(&self, x: u32, y: u32) -> &[f32] {
        self.px(y as usize * self.width as usize + x as usize)
    }
    /// Pixel `i` as RGB (a single channel is repeated).
    pub fn rgb(&self, i: usize) -> [f32; 3] {
        let p = self.px(i);
        if self.channels >= 3 {
            [p[0], p[1], p[2]]
        } else {
            [p[0]; 3]
        }
    }
    /// Largest sample.
    pub fn max(&self) -> f32 {
        self.data.iter().copied().fold(0.0, f32::max)
    }
    /// A new image applying `f` to every sample.
    pub fn map(&self, f: impl Fn(f32) -> f32) -> Self {
        Self {
            width: self.width,
            height: self.height,
            channels: self.channels,
            data: self.data.iter().map(|&v| f(v)).collect(),
        }
    }
    /// Resamples to `width`×`height` with bilinear interpolation (pixel centres aligned). A
    /// target with a zero side gives an empty image.
    pub fn resize(&self, width: u32, height: u32) -> Self {
        let mut out = Self::new(width, height, self.channels);
        if self.is_empty() {
            return out;
        }
        let (sx, sy) = (
            self.width as f32 / width.max(1) as f32,
            self.height as f32 / height.max(1) as f32,
        );
        let c = self.channels;
        for y in 0..height {
            let fy = ((y as f32 + 0.5) * sy - 0.5).clamp(0.0, (self.height - 1) as f32);
            let (y0, ty) = (fy.floor() as u32, fy.fract());
            let y1 = (y0 + 1).min(self.height - 1);
            for x in 0..width {
                let fx = ((x as f32 + 0.5) * sx - 0.5).clamp(0.0, (self.width - 1) as f32);
                let (x0, tx) = (fx.floor() as u32, fx.fract());
                let x1 = (x0 + 1).min(self.width - 1);
                let i = (y as usize * width as usize + x as usize) * c;
                for ch in 0..c {
                    let a = self.get(x0, y0)[ch] * (1.0 - tx) + self.get(x1, y0)[ch] * tx;
                    let b = self.get(x0, y1)[ch] * (1.0 - tx) + self.get(x1, y1)[ch] * tx;
                    out.data[i + ch] = a * (1.0 - ty) + b * ty;
                }
            }
        }
        out
    }

    /// Errors with [`Error::ShapeMismatch`] unless `other` has this image's size.
    pub fn check_dims(&self, other: (u32, u32)) -> Result<()> {
        if self.dims() != other {
            return Err(Error::ShapeMismatch {
                expected: self.dims(),
                got: other,
            });
        }
        Ok(())
    }
}

/// A boolean mask: `true` marks pixels to decompose or evaluate.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    width: u32,
    height: u32,
    data: Vec<bool>,
}

impl Mask {
    /// A mask selecting every pixel.
    pub fn full(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            data: vec![true; width as usize * height as usize],
        }
    }
    /// Wraps a row-major buffer; errors when its length is not `width·height`.
    pub fn from_vec(width: u32, height: u32, data: Vec<bool>) -> Result<Self> {
        if data.len() != width as usize * height as usize {
            return Err(Error::param(
                "mask.len()",
                data.len(),
                "must equal width * height",
            ));
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }
    /// Builds a mask from a predicate on (x, y).
    pub fn from_fn(width: u32, height: u32, f: impl Fn(u32, u32) -> bool) -> Self {
        let mut data = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Self {
            width,
            height,
            data,
        }
    }
    /// (width, height).
    pub fn dims(&self) -> (u32, u32) {
        (self.width, self.height)
    }
    /// The row-major flags.
    pub fn data(&self) -> &[bool] {
        &self.data
    }
    /// Whether pixel `i` is selected.
    pub fn at(&self, i: usize) -> bool {
        self.data[i]
    }
    /// Number of selected pixels.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }
}

/// Resolves an optional mask against an image size: `None` selects everything; a mask of
/// another size is an error.
pub fn resolve_mask(dims: (u32, u32), mask: Option<&Mask>) -> Result<Mask> {
    match mask {
        None => Ok(Mask::full(dims.0, dims.1)),
        Some(m) => {
            if m.dims() != dims {
                return Err(Error::ShapeMismatch {
                    expected: dims,
                    got: m.dims(),
                });
            }
            if m.count() == 0 {
                return Err(Error::EmptyMask);
            }
            Ok(m.clone())
        }
    }
}

/// The 4-connected neighbours of pixel `p` (row-major) in a `w × h` image.
pub(crate) fn neighbours4(w: usize, h: usize, p: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (p % w, p / w);
    [
        (x > 0).then(|| p - 1),
        (x + 1 < w).then(|| p + 1),
        (y > 0).then(|| p - w),
        (y + 1 < h).then(|| p + w),
    ]
    .into_iter()
    .flatten()
}
