//! A contact sheet: a grid of thumbnails, one column per chosen frame and one row per layer
//! (input, then each method's reflectance and shading), for people to look at flicker.

use std::path::Path;

use anyhow::Result;

use decompose::Image;
use decompose::io::{self, Depth, Encoding};

/// Gap between thumbnails, pixels.
const GAP: u32 = 4;

pub(crate) struct ContactSheet {
    /// The frames shown, in column order.
    frames: Vec<usize>,
    thumb: (u32, u32),
    /// Row titles, the row's display scale and its thumbnails (one slot per column).
    rows: Vec<(String, f32, Vec<Option<Image>>)>,
}

impl ContactSheet {
    /// `columns` frames spread evenly over `len` frames (first and last included), thumbnails
    /// at most `max_width` pixels wide with the frames' aspect ratio.
    pub(crate) fn new(len: usize, columns: usize, size: (u32, u32), max_width: u32) -> Self {
        let columns = columns.clamp(1, len.max(1));
        let frames: Vec<usize> = if columns == 1 {
            vec![0]
        } else {
            (0..columns)
                .map(|c| c * (len - 1) / (columns - 1))
                .collect()
        };
        let tw = size.0.min(max_width).max(1);
        let th = ((size.1 as u64 * tw as u64) / size.0.max(1) as u64).max(1) as u32;
        Self {
            frames,
            thumb: (tw, th),
            rows: Vec::new(),
        }
    }

    /// Whether frame `index` has a column.
    pub(crate) fn wants(&self, index: usize) -> bool {
        self.frames.contains(&index)
    }

    /// Puts a linear image (1 or 3 channels) into row `title` at the column of frame `index`
    /// (ignored when the frame has no column). Every row has one display scale, set by its
    /// first image (its 99.5th percentile sample is shown white; brighter ones clip): a layer
    /// whose scale changes from frame to frame looks brighter or darker, as in a video.
    pub(crate) fn add(&mut self, title: &str, index: usize, img: &Image) {
        let Some(col) = self.frames.iter().position(|&f| f == index) else {
            return;
        };
        let thumb = img.resize(self.thumb.0, self.thumb.1);
        let thumb = if thumb.channels() == 1 {
            Image::from_fn(thumb.width(), thumb.height(), |x, y| {
                let v = thumb.get(x, y)[0];
                [v, v, v]
            })
        } else {
            thumb
        };
        let n = self.frames.len();
        let row = match self.rows.iter().position(|(t, _, _)| t == title) {
            Some(r) => r,
            None => {
                self.rows.push((
                    title.to_string(),
                    1.0 / percentile(&thumb, 0.995),
                    vec![None; n],
                ));
                self.rows.len() - 1
            }
        };
        let scale = self.rows[row].1;
        self.rows[row].2[col] = Some(thumb.map(|v| v * scale));
    }

    /// The row titles, top to bottom.
    pub(crate) fn legend(&self) -> Vec<String> {
        self.rows.iter().map(|(t, _, _)| t.clone()).collect()
    }

    /// The frames shown, left to right.
    pub(crate) fn frames(&self) -> &[usize] {
        &self.frames
    }

    /// Writes the sheet as an 8-bit sRGB PNG.
    pub(crate) fn save(&self, path: &Path) -> Result<()> {
        let (tw, th) = self.thumb;
        let cols = self.frames.len() as u32;
        let rows = self.rows.len().max(1) as u32;
        let (w, h) = (cols * (tw + GAP) + GAP, rows * (th + GAP) + GAP);
        let mut canvas = Image::from_fn(w, h, |_, _| [0.05f32, 0.05, 0.05]);
        for (r, (_, _, thumbs)) in self.rows.iter().enumerate() {
            for (c, t) in thumbs.iter().enumerate() {
                let Some(t) = t else { continue };
                let (x0, y0) = (GAP + c as u32 * (tw + GAP), GAP + r as u32 * (th + GAP));
                for y in 0..th {
                    for x in 0..tw {
                        let i = ((y0 + y) * w + x0 + x) as usize;
                        canvas.px_mut(i).copy_from_slice(t.get(x, y));
                    }
                }
            }
        }
        io::save(path, &canvas, Encoding::Srgb, Depth::Eight)?;
        Ok(())
    }
}

/// The `q` quantile of an image's finite samples (1 when there is none or it is not positive).
fn percentile(img: &Image, q: f64) -> f32 {
    let mut v: Vec<f32> = img
        .data()
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    if v.is_empty() {
        return 1.0;
    }
    let k = ((v.len() - 1) as f64 * q).round() as usize;
    let (_, p, _) = v.select_nth_unstable_by(k, f32::total_cmp);
    if *p > 0.0 { *p } else { 1.0 }
}
