//! The 5×5 median of the shading at cluster borders (§2.4).

use rayon::prelude::*;

use crate::decomposition::Labels;
use crate::image::Image;

/// Replaces the shading of pixels on a cluster border (a 4-neighbour in another cluster) by the
/// median of the in-mask shading in a `size`×`size` window (§2.4).
pub(super) fn median_at_borders(
    s: &Image,
    labels: &[u32],
    w: usize,
    h: usize,
    size: usize,
) -> Image {
    let r = (size / 2) as isize;
    let border: Vec<usize> = (0..labels.len())
        .filter(|&p| {
            let l = labels[p];
            if l == Labels::NONE {
                return false;
            }
            let (x, y) = (p % w, p / w);
            (x + 1 < w && labels[p + 1] != l && labels[p + 1] != Labels::NONE)
                || (x > 0 && labels[p - 1] != l && labels[p - 1] != Labels::NONE)
                || (y + 1 < h && labels[p + w] != l && labels[p + w] != Labels::NONE)
                || (y > 0 && labels[p - w] != l && labels[p - w] != Labels::NONE)
        })
        .collect();
    let values: Vec<(usize, f32)> = border
        .par_iter()
        .map_init(
            || Vec::with_capacity(size * size),
            |win, &p| {
                let (x, y) = ((p % w) as isize, (p / w) as isize);
                win.clear();
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (nx, ny) = (x + dx, y + dy);
                        if nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize {
                            let q = ny as usize * w + nx as usize;
                            if labels[q] != Labels::NONE {
                                win.push(s.px(q)[0]);
                            }
                        }
                    }
                }
                let m = win.len() / 2;
                let (_, v, _) = win.select_nth_unstable_by(m, f32::total_cmp);
                (p, *v)
            },
        )
        .collect();
    let mut out = s.clone();
    for (p, v) in values {
        out.px_mut(p)[0] = v;
    }
    out
}
