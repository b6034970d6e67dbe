//! Binary masks and the drawing region Ω of §5.3.
//!
//! Ω is "the non-white pixels, dilated by 10 px, with holes filled". Choices made where the
//! paper is silent:
//! - a pixel is *white* when each channel is ≥ [`WHITE_THRESHOLD`] (250), so the faint
//!   anti-aliasing fringe a renderer leaves on white counts as background;
//! - dilation uses a Euclidean disk (exact distance transform), not a square;
//! - holes are the background components (4-connected) that do not touch the image border.

use image::RgbImage;

/// A channel value at or above which a pixel counts as white paper.
pub const WHITE_THRESHOLD: u8 = 250;
/// The dilation radius of Ω in pixels at 400x400 (§5.3).
pub const REGION_DILATION: f32 = 10.0;

/// A row-major binary image.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` flags, row-major.
    pub data: Vec<bool>,
}

impl Mask {
    /// A mask with every pixel set to `value`.
    pub fn filled(width: usize, height: usize, value: bool) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Whether `(x, y)` is set.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> bool {
        self.data[y * self.width + x]
    }

    /// Whether `(x, y)` is inside the image and set.
    #[inline]
    pub fn at_signed(&self, x: isize, y: isize) -> bool {
        x >= 0
            && y >= 0
            && (x as usize) < self.width
            && (y as usize) < self.height
            && self.data[y as usize * self.width + x as usize]
    }

    /// The number of set pixels.
    pub fn count(&self) -> usize {
        self.data.iter().filter(|&&b| b).count()
    }

    /// Pixel-wise AND.
    pub fn and(&self, other: &Mask) -> Mask {
        debug_assert_eq!((self.width, self.height), (other.width, other.height));
        let data = self
            .data
            .iter()
            .zip(&other.data)
            .map(|(&a, &b)| a && b)
            .collect();
        Mask {
            width: self.width,
            height: self.height,
            data,
        }
    }

    /// Pixel-wise AND NOT.
    pub fn and_not(&self, other: &Mask) -> Mask {
        debug_assert_eq!((self.width, self.height), (other.width, other.height));
        let data = self
            .data
            .iter()
            .zip(&other.data)
            .map(|(&a, &b)| a && !b)
            .collect();
        Mask {
            width: self.width,
            height: self.height,
            data,
        }
    }

    /// Halves both dimensions; a 2x2 block is set when at least two of its pixels are set.
    pub fn half(&self) -> Mask {
        half_mask(self)
    }

    /// Set pixels within Euclidean distance `radius` of a set pixel (a disk dilation).
    ///
    /// Exact and cheap for the small radii used here: a pixel is covered iff some row offset
    /// `dy` with `|dy| ≤ radius` has a set pixel in row `y + dy` within horizontal distance
    /// `k(dy) = ⌊√(radius² − dy²)⌋`. Rows are packed 64 pixels to a word, each source row is
    /// dilated horizontally once per distinct `k` (7 of them for radius 10) by shift-and-or, and
    /// an output row is the OR of its `2·radius + 1` source rows: a few hundred word operations
    /// per row instead of one compare per pixel and offset.
    pub fn dilate(&self, radius: f32) -> Mask {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return self.clone();
        }
        let r = radius.max(0.0).floor() as usize;
        let r2 = radius * radius;
        // k(dy) for dy = 0..=r; `None` where the disk has no pixel at that offset.
        let reach: Vec<Option<usize>> = (0..=r)
            .map(|dy| {
                let budget = r2 - (dy * dy) as f32;
                (budget >= 0.0).then(|| (budget.sqrt().floor() as usize).min(w))
            })
            .collect();
        let mut distinct: Vec<usize> = reach.iter().flatten().copied().collect();
        distinct.sort_unstable();
        distinct.dedup();
        let source = BitRows::pack(self);
        // widened[d][y]: row y dilated horizontally by distinct[d].
        let widened: Vec<BitRows> = distinct.iter().map(|&k| source.widened(k)).collect();
        let mut out = BitRows::zeros(w, h);
        for y in 0..h {
            for sy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                let Some(k) = reach[sy.abs_diff(y)] else {
                    continue;
                };
                let d = distinct
                    .binary_search(&k)
                    .expect("k is one of the distinct reaches");
                out.or_row(y, &widened[d], sy);
            }
        }
        out.unpack()
    }

    /// Fills holes: unset pixels not 4-connected to the image border through unset pixels.
    ///
    /// A scanline flood fill of the outside from the border: each popped seed fills the whole
    /// horizontal span of open pixels around it and pushes one seed per open span in the rows
    /// above and below, so the stack holds spans, not pixels.
    pub fn fill_holes(&self) -> Mask {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return self.clone();
        }
        // Per pixel: OPEN, SET or OUTSIDE.
        let mut state: Vec<u8> = self.data.iter().map(|&b| b as u8 * SET).collect();
        let mut stack: Vec<(usize, usize)> = Vec::new();
        for x in 0..w {
            stack.push((x, 0));
            stack.push((x, h - 1));
        }
        for y in 0..h {
            stack.push((0, y));
            stack.push((w - 1, y));
        }
        while let Some((x, y)) = stack.pop() {
            let row = &mut state[y * w..(y + 1) * w];
            if row[x] != OPEN {
                continue;
            }
            // The span's ends: the nearest set or already-outside pixel on each side (memchr's
            // vectorised byte search; long spans of background are the common case).
            let left = memchr::memrchr2(SET, OUTSIDE, &row[..x]).map_or(0, |l| l + 1);
            let right = memchr::memchr2(SET, OUTSIDE, &row[x..]).map_or(w, |r| x + r);
            row[left..right].fill(OUTSIDE);
            for ny in [y.wrapping_sub(1), y + 1] {
                if ny < h {
                    push_open_spans(&state[ny * w..(ny + 1) * w], left, right, ny, &mut stack);
                }
            }
        }
        Mask {
            width: w,
            height: h,
            data: state.iter().map(|&s| s != OUTSIDE).collect(),
        }
    }

    /// The inner boundary: set pixels with a 4-neighbour that is unset or outside the image.
    pub fn boundary(&self) -> Mask {
        let (w, h) = (self.width, self.height);
        let mut data = vec![false; w * h];
        for y in 0..h {
            for x in 0..w {
                if self.at(x, y) {
                    let (xi, yi) = (x as isize, y as isize);
                    data[y * w + x] = !(self.at_signed(xi - 1, yi)
                        && self.at_signed(xi + 1, yi)
                        && self.at_signed(xi, yi - 1)
                        && self.at_signed(xi, yi + 1));
                }
            }
        }
        Mask {
            width: w,
            height: h,
            data,
        }
    }
}

/// [`Mask::fill_holes`] state of an unset pixel not (yet) reached from the border.
const OPEN: u8 = 0;
/// [`Mask::fill_holes`] state of a set pixel.
const SET: u8 = 1;
/// [`Mask::fill_holes`] state of an unset pixel reached from the border.
const OUTSIDE: u8 = 2;

/// Pushes `(x, y)` for the first pixel of every run of [`OPEN`] pixels of `row` within
/// `left..right`: one seed per span that the fill must enter from the neighbouring row.
fn push_open_spans(
    row: &[u8],
    left: usize,
    right: usize,
    y: usize,
    stack: &mut Vec<(usize, usize)>,
) {
    // Jumps from run to run with memchr rather than testing every pixel: most of a row is
    // either already outside or set.
    let mut x = left;
    while x < right {
        let Some(start) = memchr::memchr(OPEN, &row[x..right]) else {
            return;
        };
        x += start;
        stack.push((x, y));
        x = memchr::memchr2(SET, OUTSIDE, &row[x..right]).map_or(right, |end| x + end);
    }
}

/// A mask with each row packed into 64-pixel words (bit `x % 64` of word `x / 64` is pixel `x`;
/// the bits past the row's end are zero).
struct BitRows {
    width: usize,
    height: usize,
    words_per_row: usize,
    words: Vec<u64>,
}

impl BitRows {
    fn zeros(width: usize, height: usize) -> Self {
        let words_per_row = width.div_ceil(64);
        Self {
            width,
            height,
            words_per_row,
            words: vec![0; words_per_row * height],
        }
    }

    fn pack(mask: &Mask) -> Self {
        let mut rows = Self::zeros(mask.width, mask.height);
        for (row, words) in mask
            .data
            .chunks_exact(mask.width)
            .zip(rows.words.chunks_exact_mut(rows.words_per_row))
        {
            for (chunk, word) in row.chunks(64).zip(words) {
                *word = chunk
                    .chunks(8)
                    .enumerate()
                    .fold(0, |acc, (byte, eight)| acc | pack_byte(eight) << (8 * byte));
            }
        }
        rows
    }

    fn unpack(&self) -> Mask {
        let mut data = Vec::with_capacity(self.width * self.height);
        for words in self.words.chunks_exact(self.words_per_row) {
            let mut left = self.width;
            for byte in words.iter().flat_map(|word| word.to_le_bytes()) {
                let take = left.min(8);
                data.extend_from_slice(&UNPACKED_BYTES[byte as usize][..take]);
                left -= take;
            }
        }
        Mask {
            width: self.width,
            height: self.height,
            data,
        }
    }

    /// Every row dilated horizontally by `k` pixels. The reach grows by shifted copies of
    /// itself (0 → 1 → 3 → 7 → …), so `k` costs about log₂ k shift-and-or sweeps.
    fn widened(&self, k: usize) -> Self {
        let mut out = Self {
            width: self.width,
            height: self.height,
            words_per_row: self.words_per_row,
            words: self.words.clone(),
        };
        let mut scratch = vec![0u64; self.words_per_row];
        let mut padded = Vec::new();
        for row in out.words.chunks_exact_mut(self.words_per_row) {
            if row.iter().all(|&word| word == 0) {
                continue;
            }
            let mut reach = 0;
            while reach < k {
                let step = (reach + 1).min(k - reach);
                scratch.copy_from_slice(row);
                or_shifted(row, &scratch, step, &mut padded);
                reach += step;
            }
            clear_tail(row, self.width);
        }
        out
    }

    /// Row `y` of `self` |= row `sy` of `other`.
    fn or_row(&mut self, y: usize, other: &BitRows, sy: usize) {
        let n = self.words_per_row;
        let src = &other.words[sy * n..(sy + 1) * n];
        for (dst, &word) in self.words[y * n..(y + 1) * n].iter_mut().zip(src) {
            *dst |= word;
        }
    }
}

/// Up to eight pixels as the low bits of a byte (pixel `j` → bit `j`). Each `bool` is one byte
/// holding 0 or 1, so the multiplication gathers byte `j` into bit `56 + j` without carries.
#[inline]
fn pack_byte(eight: &[bool]) -> u64 {
    let mut bytes = [0u8; 8];
    for (b, &set) in bytes.iter_mut().zip(eight) {
        *b = set as u8;
    }
    u64::from_le_bytes(bytes).wrapping_mul(0x0102_0408_1020_4080) >> 56
}

/// `UNPACKED_BYTES[b][j]` is bit `j` of `b`.
const UNPACKED_BYTES: [[bool; 8]; 256] = {
    let mut table = [[false; 8]; 256];
    let mut b = 0;
    while b < 256 {
        let mut j = 0;
        while j < 8 {
            table[b][j] = b >> j & 1 == 1;
            j += 1;
        }
        b += 1;
    }
    table
};

/// `row |= bits << step | bits >> step` across word boundaries, towards higher and lower pixel
/// indices alike; bits shifted past either end are dropped (the caller clears the tail).
/// `padded` is scratch.
fn or_shifted(row: &mut [u64], bits: &[u64], step: usize, padded: &mut Vec<u64>) {
    let n = bits.len();
    let (whole, part) = (step / 64, step % 64);
    if whole == 0 && part > 0 {
        // Steps under 64 px (every step for radii under 127): each word takes bits from itself
        // and its two neighbours, without the padded copy.
        for (i, out) in row.iter_mut().enumerate() {
            let below = if i > 0 { bits[i - 1] >> (64 - part) } else { 0 };
            let above = if i + 1 < n {
                bits[i + 1] << (64 - part)
            } else {
                0
            };
            *out |= (bits[i] << part) | below | (bits[i] >> part) | above;
        }
        return;
    }
    // `bits` with `whole + 1` zero words on each side, so every read below is in bounds.
    let margin = whole + 1;
    padded.clear();
    padded.resize(n + 2 * margin, 0);
    padded[margin..margin + n].copy_from_slice(bits);
    for (i, out) in row.iter_mut().enumerate() {
        let at = i + margin;
        // Pixel x moves to x + step (towards higher words), and to x − step.
        let (up, down) = if part == 0 {
            (padded[at - whole], padded[at + whole])
        } else {
            (
                padded[at - whole] << part | padded[at - whole - 1] >> (64 - part),
                padded[at + whole] >> part | padded[at + whole + 1] << (64 - part),
            )
        };
        *out |= up | down;
    }
}

/// Zeroes the bits past pixel `width − 1` in the row's last word.
fn clear_tail(row: &mut [u64], width: usize) {
    if let Some(last) = row.last_mut()
        && !width.is_multiple_of(64)
    {
        *last &= (1u64 << (width % 64)) - 1;
    }
}

crate::simd::vectorised_fn! {
/// [`Mask::half`].
fn half_mask<'a>(mask: &'a Mask) -> Mask {
    let (w, h) = (mask.width / 2, mask.height / 2);
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let top = &mask.data[2 * y * mask.width..][..2 * w];
        let bottom = &mask.data[(2 * y + 1) * mask.width..][..2 * w];
        data.extend(
            top.chunks_exact(2)
                .zip(bottom.chunks_exact(2))
                .map(|(t, b)| t[0] as u8 + t[1] as u8 + b[0] as u8 + b[1] as u8 >= 2),
        );
    }
    Mask {
        width: w,
        height: h,
        data,
    }
}
}

/// Whether an RGB pixel is white paper (every channel ≥ [`WHITE_THRESHOLD`]).
#[inline(always)]
pub fn is_white(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c >= WHITE_THRESHOLD)
}

crate::simd::vectorised_fn! {
/// The non-white pixels of an image.
pub fn non_white<'a>(image: &'a RgbImage) -> Mask {
    Mask {
        width: image.width() as usize,
        height: image.height() as usize,
        data: image
            .as_raw()
            .chunks_exact(3)
            .map(|p| !is_white([p[0], p[1], p[2]]))
            .collect(),
    }
}
}

/// The drawing region Ω of §5.3: non-white pixels, dilated by [`REGION_DILATION`] px, holes
/// filled. An all-white image yields an empty region.
pub fn drawing_region(image: &RgbImage) -> Mask {
    non_white(image).dilate(REGION_DILATION).fill_holes()
}

/// The silhouette: non-white pixels with holes filled (no dilation). Its boundary is the
/// external contour used by the contour-only LBP and the outer stroke widths.
pub fn silhouette(image: &RgbImage) -> Mask {
    non_white(image).fill_holes()
}

/// Squared Euclidean distance from every pixel to the nearest set pixel (exact, separable
/// lower-envelope algorithm of Felzenszwalb & Huttenlocher 2012). `f32::INFINITY` everywhere for
/// an empty mask.
pub fn squared_distance_to_set(mask: &Mask) -> Vec<f32> {
    let (w, h) = (mask.width, mask.height);
    let inf = 1e20_f64;
    let mut grid: Vec<f64> = mask
        .data
        .iter()
        .map(|&b| if b { 0.0 } else { inf })
        .collect();
    let n = w.max(h);
    let mut scratch = Scratch {
        f: vec![0.0; n],
        out: vec![0.0; n],
        v: vec![0; n],
        z: vec![0.0; n + 1],
    };
    for x in 0..w {
        for y in 0..h {
            scratch.f[y] = grid[y * w + x];
        }
        distance_1d(&mut scratch, h);
        for y in 0..h {
            grid[y * w + x] = scratch.out[y];
        }
    }
    for y in 0..h {
        scratch.f[..w].copy_from_slice(&grid[y * w..(y + 1) * w]);
        distance_1d(&mut scratch, w);
        grid[y * w..(y + 1) * w].copy_from_slice(&scratch.out[..w]);
    }
    grid.iter()
        .map(|&d| {
            if d >= inf * 0.5 {
                f32::INFINITY
            } else {
                d as f32
            }
        })
        .collect()
}

/// Buffers reused across the 1-D transforms of one image.
struct Scratch {
    f: Vec<f64>,
    out: Vec<f64>,
    v: Vec<usize>,
    z: Vec<f64>,
}

/// One-dimensional squared distance transform of the first `n` samples of `s.f` into `s.out`
/// (lower envelope of parabolas), in `f64` so the 1e20 "infinity" does not swallow small offsets.
fn distance_1d(s: &mut Scratch, n: usize) {
    let Scratch { f, out, v, z } = s;
    let fv = |i: usize| f[i] + (i * i) as f64;
    let mut k = 0usize;
    v[0] = 0;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    for q in 1..n {
        let mut s = (fv(q) - fv(v[k])) / (2.0 * (q as f64 - v[k] as f64));
        while s <= z[k] {
            k -= 1;
            s = (fv(q) - fv(v[k])) / (2.0 * (q as f64 - v[k] as f64));
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, o) in out[..n].iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = d * d + f[v[k]];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute_force_dist2(mask: &Mask) -> Vec<f32> {
        let mut out = vec![f32::INFINITY; mask.width * mask.height];
        for y in 0..mask.height {
            for x in 0..mask.width {
                for sy in 0..mask.height {
                    for sx in 0..mask.width {
                        if mask.at(sx, sy) {
                            let d = (x as f32 - sx as f32).powi(2) + (y as f32 - sy as f32).powi(2);
                            out[y * mask.width + x] = out[y * mask.width + x].min(d);
                        }
                    }
                }
            }
        }
        out
    }

    proptest! {
        #[test]
        fn distance_transform_matches_brute_force(w in 1usize..12, h in 1usize..12, bits in proptest::collection::vec(any::<bool>(), 144)) {
            let mask = Mask { width: w, height: h, data: bits[..w * h].to_vec() };
            let fast = squared_distance_to_set(&mask);
            let slow = brute_force_dist2(&mask);
            for (a, b) in fast.iter().zip(&slow) {
                prop_assert!((a.is_infinite() && b.is_infinite()) || (a - b).abs() < 1e-3, "{a} vs {b}");
            }
        }
    }

    proptest! {
        #[test]
        fn dilation_matches_the_distance_transform(w in 1usize..30, h in 1usize..30, radius in 0.0f32..12.0, seed in any::<u64>()) {
            let data = (0..w * h).map(|i| (seed.wrapping_mul(i as u64 + 1).rotate_left(17) % 23) == 0).collect();
            let mask = Mask { width: w, height: h, data };
            let dist2 = squared_distance_to_set(&mask);
            let expected: Vec<bool> = dist2.iter().map(|&d| d <= radius * radius).collect();
            prop_assert_eq!(mask.dilate(radius).data, expected);
        }

        /// Rows of several words and radii past 64 px exercise the cross-word and whole-word
        /// shifts of the packed dilation.
        #[test]
        fn wide_dilation_matches_the_distance_transform(w in 60usize..260, h in 1usize..6, radius in 0.0f32..170.0, seed in any::<u64>()) {
            let data = (0..w * h).map(|i| (seed.wrapping_mul(i as u64 + 1).rotate_left(17) % 97) == 0).collect();
            let mask = Mask { width: w, height: h, data };
            let dist2 = squared_distance_to_set(&mask);
            let expected: Vec<bool> = dist2.iter().map(|&d| d <= radius * radius).collect();
            prop_assert_eq!(mask.dilate(radius).data, expected);
        }
    }

    #[test]
    fn dilation_is_a_disk() {
        let mut m = Mask::filled(31, 31, false);
        m.data[15 * 31 + 15] = true;
        let d = m.dilate(10.0);
        assert!(d.at(25, 15) && d.at(15, 5) && !d.at(26, 15));
        assert!(d.at(22, 22) && !d.at(23, 23)); // 7²+7² = 98 ≤ 100 < 128
    }

    #[test]
    fn fill_holes_fills_a_ring_but_not_an_open_shape() {
        let mut ring = Mask::filled(9, 9, false);
        for i in 2..7 {
            for (x, y) in [(i, 2), (i, 6), (2, i), (6, i)] {
                ring.data[y * 9 + x] = true;
            }
        }
        let filled = ring.fill_holes();
        assert!(filled.at(4, 4) && !filled.at(0, 0));
        assert_eq!(filled.count(), 25);
        let mut open = ring.clone();
        open.data[2 * 9 + 4] = false;
        assert_eq!(open.fill_holes(), open);
    }

    /// The per-pixel flood fill that the scanline fill replaced, as its reference.
    fn fill_holes_pixelwise(m: &Mask) -> Mask {
        let (w, h) = (m.width, m.height);
        let mut outside = vec![false; w * h];
        let mut stack: Vec<usize> = (0..w)
            .flat_map(|x| [x, (h - 1) * w + x])
            .chain((0..h).flat_map(|y| [y * w, y * w + w - 1]))
            .collect();
        while let Some(i) = stack.pop() {
            if m.data[i] || outside[i] {
                continue;
            }
            outside[i] = true;
            let (x, y) = (i % w, i / w);
            if x > 0 {
                stack.push(i - 1);
            }
            if x + 1 < w {
                stack.push(i + 1);
            }
            if y > 0 {
                stack.push(i - w);
            }
            if y + 1 < h {
                stack.push(i + w);
            }
        }
        Mask {
            width: w,
            height: h,
            data: outside.iter().map(|&o| !o).collect(),
        }
    }

    proptest! {
        #[test]
        fn scanline_fill_matches_the_pixelwise_fill(w in 1usize..24, h in 1usize..24, density in 1u64..6, seed in any::<u64>()) {
            let data = (0..w * h).map(|i| seed.wrapping_mul(i as u64 * 2 + 1).rotate_left(23) % 7 < density).collect();
            let mask = Mask { width: w, height: h, data };
            prop_assert_eq!(mask.fill_holes(), fill_holes_pixelwise(&mask));
        }

        #[test]
        fn half_is_two_of_four(w in 0usize..13, h in 0usize..13, seed in any::<u64>()) {
            let data = (0..w * h).map(|i| seed.wrapping_mul(i as u64 + 7).rotate_left(11) % 2 == 0).collect();
            let mask = Mask { width: w, height: h, data };
            let half = mask.half();
            prop_assert_eq!((half.width, half.height), (w / 2, h / 2));
            for y in 0..h / 2 {
                for x in 0..w / 2 {
                    let n = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .filter(|(dx, dy)| mask.at(2 * x + dx, 2 * y + dy))
                        .count();
                    prop_assert_eq!(half.at(x, y), n >= 2);
                }
            }
        }
    }

    #[test]
    fn drawing_region_of_white_page_is_empty() {
        let img = RgbImage::from_pixel(40, 40, image::Rgb([255, 255, 255]));
        assert_eq!(drawing_region(&img).count(), 0);
    }

    #[test]
    fn boundary_of_square() {
        let mut m = Mask::filled(6, 6, false);
        for y in 1..5 {
            for x in 1..5 {
                m.data[y * 6 + x] = true;
            }
        }
        assert_eq!(m.boundary().count(), 12);
    }
}
