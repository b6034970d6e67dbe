//! The Gaussian pre-smoothing of the segmentation, written to give the numbers of
//! `scipy.ndimage.gaussian_filter(image, sigma=[σ, σ, 0], mode='reflect', truncate=4.0)`, which
//! is what scikit-image's `felzenszwalb` calls: a sampled, normalised kernel of radius
//! `⌊4σ + 0.5⌋`, borders mirrored with the edge sample repeated (`d c b a | a b c d`), rows
//! filtered before columns, in `f64`.

/// The normalised kernel `exp(−t²/2σ²)`, `|t| ≤ ⌊4σ + 0.5⌋`, or `None` when σ is too small to
/// blur (SciPy skips the axis then).
fn kernel(sigma: f64) -> Option<Vec<f64>> {
    if sigma <= 1e-15 {
        return None;
    }
    let radius = (4.0 * sigma + 0.5) as i64;
    let mut k: Vec<f64> = (-radius..=radius)
        .map(|t| (-0.5 * (t * t) as f64 / (sigma * sigma)).exp())
        .collect();
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    Some(k)
}

/// Index of sample `i` (any integer) in a line of `n` samples under SciPy's `reflect` mode,
/// whose period is `2n`.
fn reflect(i: i64, n: i64) -> usize {
    let m = i.rem_euclid(2 * n);
    (if m < n { m } else { 2 * n - 1 - m }) as usize
}

/// Blurs an interleaved `width × height × channels` buffer channel by channel, along y and
/// then x (SciPy's axis order).
pub(super) fn gaussian(data: &mut [f64], width: usize, height: usize, channels: usize, sigma: f64) {
    let Some(k) = kernel(sigma) else {
        return;
    };
    let index_y =
        |line: usize, y: usize| (y * width + line / channels) * channels + line % channels;
    let index_x =
        |line: usize, x: usize| (line / channels * width + x) * channels + line % channels;
    // Along y (one column of one channel per line), then along x.
    blur_lines(data, &k, width * channels, height, index_y);
    blur_lines(data, &k, height * channels, width, index_x);
}

/// Convolves `lines` lines of `len` samples with the kernel `k`, borders reflected; sample
/// `pos` of line `line` is `data[index(line, pos)]`.
fn blur_lines(
    data: &mut [f64],
    k: &[f64],
    lines: usize,
    len: usize,
    index: impl Fn(usize, usize) -> usize,
) {
    let r = (k.len() / 2) as i64;
    let mut line = Vec::with_capacity(len);
    for l in 0..lines {
        line.clear();
        line.extend((0..len).map(|p| data[index(l, p)]));
        for p in 0..len {
            let mut acc = 0.0;
            for (j, w) in k.iter().enumerate() {
                acc += w * line[reflect(p as i64 + j as i64 - r, len as i64)];
            }
            data[index(l, p)] = acc;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_radius_and_sum_follow_scipy() {
        // σ = 0.8 → radius ⌊3.7⌋ = 3: seven taps.
        let k = kernel(0.8).unwrap();
        assert_eq!(k.len(), 7);
        assert!((k.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        assert!(kernel(0.0).is_none());
    }

    #[test]
    fn reflect_repeats_the_edge_sample() {
        let idx: Vec<usize> = (-3..7).map(|i| reflect(i, 4)).collect();
        assert_eq!(idx, [2, 1, 0, 0, 1, 2, 3, 3, 2, 1]);
        // Radius larger than the line: keeps reflecting.
        assert_eq!(reflect(-5, 2), 0);
        assert_eq!(reflect(9, 2), 1);
    }

    #[test]
    fn blur_matches_scipy_on_an_impulse() {
        // scipy.ndimage.gaussian_filter1d(np.eye(1, 7, 3)[0], 0.8, mode='reflect')[3]
        // = 0.498676452...; the 2-D blur of an impulse is the outer product of the 1-D ones.
        let mut d = vec![0.0; 49];
        d[3 * 7 + 3] = 1.0;
        gaussian(&mut d, 7, 7, 1, 0.8);
        let k = kernel(0.8).unwrap();
        assert!((d[3 * 7 + 3] - k[3] * k[3]).abs() < 1e-15);
        assert!((k[3] - 0.498_676_452).abs() < 1e-9, "{}", k[3]);
        assert!((d.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
}
