//! The (a, b) chroma scatter plot of thesis Figs. 2.3 and 2.13, drawn without a plotting
//! library: one dot per (subsampled) pixel, coloured by its cluster or its own colour.

use crate::color::{linear_to_lab, linear_to_srgb};
use crate::decomposition::{Labels, label_colour};
use crate::image::{Image, Mask};

/// Renders the scatter of CIELab (a, b) of the masked pixels of `input` into a `size`×`size`
/// RGB byte buffer: white background, grey axes through a = b = 0, at most 100,000 dots.
pub fn ab_scatter(input: &Image, mask: &Mask, labels: Option<&Labels>, size: u32) -> Vec<u8> {
    let size = size.max(16) as usize;
    let mut out = vec![255u8; size * size * 3];
    let idx: Vec<usize> = (0..input.len()).filter(|&i| mask.at(i)).collect();
    let step = idx.len().div_ceil(100_000).max(1);
    let pts: Vec<(usize, [f32; 3])> = idx
        .iter()
        .step_by(step)
        .map(|&i| (i, linear_to_lab(input.rgb(i))))
        .collect();
    let range = pts
        .iter()
        .map(|(_, l)| l[1].abs().max(l[2].abs()))
        .fold(1.0f32, f32::max)
        * 1.1;
    let to_px = |v: f32| (((v / range) * 0.5 + 0.5) * (size - 1) as f32).round() as usize;
    let mut put = |x: usize, y: usize, c: [u8; 3]| {
        if x < size && y < size {
            let o = (y * size + x) * 3;
            out[o..o + 3].copy_from_slice(&c);
        }
    };
    let mid = to_px(0.0);
    for t in 0..size {
        put(mid, t, [190; 3]);
        put(t, mid, [190; 3]);
    }
    for (i, lab) in pts {
        let c = match labels {
            Some(l) => label_colour(l.data[i]),
            None => input
                .rgb(i)
                .map(|v| (linear_to_srgb(v) * 255.0).round() as u8),
        };
        // a grows to the right, b grows upwards.
        let (x, y) = (to_px(lab[1]), size - 1 - to_px(lab[2]));
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            put(x + dx, y + dy, c);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn red_lands_right_of_centre() {
        let img = Image::from_fn(2, 1, |_, _| [0.8f32, 0.05, 0.05]);
        let buf = ab_scatter(&img, &Mask::full(2, 1), None, 64);
        let dark_right = (0..64).any(|y| {
            (40..64).any(|x| {
                let o = (y * 64 + x) * 3;
                buf[o] > 150 && buf[o + 1] < 100
            })
        });
        assert!(dark_right);
    }
}
