//! The in-memory light field: one contiguous buffer, views row-major.

use crate::error::{Error, Result};
use crate::image::Image;

/// A 4D light field: `rows × cols` views (angular coordinates `(u, v)` = `(row, col)`), each
/// `width × height` pixels with `channels` interleaved channels.
///
/// Stored as one buffer indexed `(((row·cols + col)·height + y)·width + x)·channels + k`, so a
/// view is one contiguous slice ([`LightField::view_data`]) and the 4D filters can walk every
/// axis with fixed strides ([`LightField::strides`]). Values are linear unless a function says
/// otherwise.
#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    rows: usize,
    cols: usize,
    width: u32,
    height: u32,
    channels: usize,
    data: Vec<f32>,
}

impl LightField {
    /// A zero-filled light field.
    pub fn new(rows: usize, cols: usize, width: u32, height: u32, channels: usize) -> Self {
        let len = rows * cols * width as usize * height as usize * channels;
        Self {
            rows,
            cols,
            width,
            height,
            channels,
            data: vec![0.0; len],
        }
    }

    /// Builds a light field from its views in row-major order; errors when the count is not
    /// `rows·cols`, a view is empty, or views differ in size or channel count (the error names
    /// the first view that differs from view 0).
    pub fn from_views(rows: usize, cols: usize, views: &[Image]) -> Result<Self> {
        if rows == 0 || cols == 0 {
            return Err(Error::param(
                "grid",
                format!("{rows}x{cols}"),
                "a light field needs at least one row and one column of views",
            ));
        }
        if views.len() != rows * cols {
            return Err(Error::param("views", views.len(), "must equal rows * cols"));
        }
        let first = &views[0];
        let (width, height) = first.dims();
        if width == 0 || height == 0 {
            return Err(Error::EmptyImage { width, height });
        }
        let channels = first.channels();
        let mut data = Vec::with_capacity(views.len() * first.len());
        for view in views {
            view.check_dims((width, height))?;
            if view.channels() != channels {
                return Err(Error::param(
                    "channels",
                    view.channels(),
                    "every view must have the channel count of the first",
                ));
            }
            data.extend_from_slice(view.data());
        }
        Ok(Self {
            rows,
            cols,
            width,
            height,
            channels,
            data,
        })
    }

    /// Wraps a buffer laid out as described on the type; errors on a wrong length.
    pub fn from_vec(
        rows: usize,
        cols: usize,
        width: u32,
        height: u32,
        channels: usize,
        data: Vec<f32>,
    ) -> Result<Self> {
        let expected = rows * cols * width as usize * height as usize * channels;
        if data.len() != expected || channels == 0 {
            return Err(Error::param(
                "data.len()",
                data.len(),
                "must equal rows * cols * width * height * channels (channels > 0)",
            ));
        }
        Ok(Self {
            rows,
            cols,
            width,
            height,
            channels,
            data,
        })
    }

    /// Views per column of the grid (angular `u`).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Views per row of the grid (angular `v`).
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of views, `rows·cols`.
    pub fn views(&self) -> usize {
        self.rows * self.cols
    }

    /// Width of every view.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height of every view.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// `(width, height)` of every view.
    pub fn dims(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Channels per pixel.
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Pixels per view.
    pub fn view_pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The whole buffer.
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// The whole buffer, mutable.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    /// Consumes the light field, returning its buffer.
    pub fn into_vec(self) -> Vec<f32> {
        self.data
    }

    /// Element strides of the axes `(row, col, y, x)` in [`LightField::data`]; the channel
    /// stride is 1.
    pub fn strides(&self) -> [usize; 4] {
        let x = self.channels;
        let y = x * self.width as usize;
        let col = y * self.height as usize;
        let row = col * self.cols;
        [row, col, y, x]
    }

    /// Index of view `(row, col)` in row-major order.
    pub fn view_index(&self, row: usize, col: usize) -> usize {
        row * self.cols + col
    }

    /// The buffer of view `index` (row-major).
    pub fn view_data(&self, index: usize) -> &[f32] {
        let n = self.view_pixels() * self.channels;
        &self.data[index * n..(index + 1) * n]
    }

    /// The buffer of view `index`, mutable.
    pub fn view_data_mut(&mut self, index: usize) -> &mut [f32] {
        let n = self.view_pixels() * self.channels;
        &mut self.data[index * n..(index + 1) * n]
    }

    /// A copy of view `index` (row-major) as an image.
    pub fn view(&self, index: usize) -> Image {
        Image::from_vec(
            self.width,
            self.height,
            self.channels,
            self.view_data(index).to_vec(),
        )
        .expect("a view slice has the view's length")
    }

    /// Every view as an image, row-major.
    pub fn to_views(&self) -> Vec<Image> {
        (0..self.views()).map(|i| self.view(i)).collect()
    }

    /// The light field with its angular axes swapped (view `(r, c)` becomes `(c, r)`); the 4D
    /// filters must commute with this.
    pub fn angular_transpose(&self) -> Self {
        let mut out = Self::new(self.cols, self.rows, self.width, self.height, self.channels);
        for r in 0..self.rows {
            for c in 0..self.cols {
                let src = self.view_index(r, c);
                let dst = out.view_index(c, r);
                out.view_data_mut(dst).copy_from_slice(self.view_data(src));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numbered(rows: usize, cols: usize, w: u32, h: u32, ch: usize) -> LightField {
        let n = rows * cols * w as usize * h as usize * ch;
        LightField::from_vec(rows, cols, w, h, ch, (0..n).map(|i| i as f32).collect()).unwrap()
    }

    #[test]
    fn strides_address_the_documented_layout() {
        let lf = numbered(2, 3, 4, 5, 3);
        let [sr, sc, sy, sx] = lf.strides();
        let (r, c, y, x, k) = (1, 2, 3, 1, 2);
        let i = r * sr + c * sc + y * sy + x * sx + k;
        assert_eq!(i, ((((r * 3 + c) * 5 + y) * 4 + x) * 3) + k);
        assert_eq!(
            lf.view(lf.view_index(r, c)).get(x as u32, y as u32)[k],
            i as f32
        );
    }

    #[test]
    fn views_round_trip_and_transpose_twice_is_identity() {
        let lf = numbered(2, 3, 4, 5, 3);
        let back = LightField::from_views(2, 3, &lf.to_views()).unwrap();
        assert_eq!(back, lf);
        let t = lf.angular_transpose();
        assert_eq!((t.rows(), t.cols()), (3, 2));
        assert_eq!(
            t.view_data(t.view_index(2, 1)),
            lf.view_data(lf.view_index(1, 2))
        );
        assert_eq!(t.angular_transpose(), lf);
    }

    #[test]
    fn mismatched_views_are_refused() {
        let a = Image::new(4, 4, 3);
        let b = Image::new(4, 5, 3);
        assert!(matches!(
            LightField::from_views(1, 2, &[a.clone(), b]),
            Err(Error::ShapeMismatch { .. })
        ));
        assert!(LightField::from_views(1, 2, std::slice::from_ref(&a)).is_err());
        assert!(LightField::from_views(1, 2, &[a, Image::new(4, 4, 1)]).is_err());
    }
}
