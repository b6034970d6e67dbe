//! Clusters as connected regions: 8-connected components of the segments, the border graph
//! between them, and the two merging steps of §2.3.2.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use crate::decomposition::Labels;

/// A multiplicative hasher for the (u32, u32) border keys: SipHash is needlessly slow here and
/// the keys are not attacker-controlled.
#[derive(Default)]
pub(crate) struct PairHasher(u64);

impl Hasher for PairHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(26) ^ v).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }
}

/// Hash map keyed by region pairs.
pub(crate) type PairMap<V> = HashMap<(u32, u32), V, BuildHasherDefault<PairHasher>>;

/// Union–find over region ids.
pub(crate) struct Dsu(Vec<u32>);

impl Dsu {
    pub(crate) fn new(n: usize) -> Self {
        Self((0..n as u32).collect())
    }
    pub(crate) fn find(&mut self, mut i: u32) -> u32 {
        while self.0[i as usize] != i {
            let g = self.0[self.0[i as usize] as usize];
            self.0[i as usize] = g;
            i = g;
        }
        i
    }
    /// Joins two sets; the smaller id becomes the root so results do not depend on call order.
    pub(crate) fn union(&mut self, a: u32, b: u32) -> bool {
        let (a, b) = (self.find(a), self.find(b));
        if a == b {
            return false;
        }
        let (lo, hi) = (a.min(b), a.max(b));
        self.0[hi as usize] = lo;
        true
    }
}

/// Labels the 8-connected components of equal `seg` values (NONE stays NONE).
pub(crate) fn components8(seg: &[u32], w: usize, h: usize) -> (Vec<u32>, usize) {
    let mut out = vec![Labels::NONE; seg.len()];
    let mut count = 0u32;
    let mut stack = Vec::new();
    for start in 0..seg.len() {
        if seg[start] == Labels::NONE || out[start] != Labels::NONE {
            continue;
        }
        let s = seg[start];
        out[start] = count;
        stack.push(start);
        while let Some(p) = stack.pop() {
            let (x, y) = ((p % w) as isize, (p / w) as isize);
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if seg[q] == s && out[q] == Labels::NONE {
                        out[q] = count;
                        stack.push(q);
                    }
                }
            }
        }
        count += 1;
    }
    (out, count as usize)
}

/// Per-region sums.
#[derive(Clone, Debug, Default)]
pub(crate) struct Region {
    pub pixels: usize,
    pub sum_rgb: [f64; 3],
    pub sum_ab: [f64; 2],
    pub sum_y: f64,
}

impl Region {
    pub(crate) fn mean_ab(&self) -> [f64; 2] {
        let n = self.pixels.max(1) as f64;
        [self.sum_ab[0] / n, self.sum_ab[1] / n]
    }
    pub(crate) fn mean_y(&self) -> f64 {
        self.sum_y / self.pixels.max(1) as f64
    }
}

/// Border statistics between two regions over their 4-neighbour pixel pairs.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Border {
    pub pairs: usize,
    /// Σ over pairs of the Euclidean RGB distance.
    pub sum_diff: f64,
}

/// Pixel data the graph needs.
pub(crate) struct PixelData<'a> {
    pub w: usize,
    pub h: usize,
    pub rgb: &'a [[f32; 3]],
    pub ab: &'a [[f32; 2]],
    pub y: &'a [f32],
}

/// Borders keyed by (smaller, larger) region id, sorted.
pub(crate) type Borders = Vec<((u32, u32), Border)>;

/// Region sums and the sorted list of borders.
pub(crate) fn graph(labels: &[u32], count: usize, px: &PixelData) -> (Vec<Region>, Borders) {
    let mut regions = vec![Region::default(); count];
    let mut borders: PairMap<Border> = PairMap::default();
    // Pixel pairs of one border come in runs (a horizontal border gives one vertical pair per
    // pixel along the row): each direction sums its current run and touches the map only when
    // the pair of regions changes.
    let mut runs = [((Labels::NONE, Labels::NONE), Border::default()); 2];
    let flush = |borders: &mut PairMap<Border>, run: &mut ((u32, u32), Border)| {
        if run.1.pairs > 0 {
            let b = borders.entry(run.0).or_default();
            b.pairs += run.1.pairs;
            b.sum_diff += run.1.sum_diff;
            run.1 = Border::default();
        }
    };
    for (p, &l) in labels.iter().enumerate() {
        if l == Labels::NONE {
            continue;
        }
        let r = &mut regions[l as usize];
        r.pixels += 1;
        for c in 0..3 {
            r.sum_rgb[c] += px.rgb[p][c] as f64;
        }
        r.sum_ab[0] += px.ab[p][0] as f64;
        r.sum_ab[1] += px.ab[p][1] as f64;
        r.sum_y += px.y[p] as f64;
        let x = p % px.w;
        let mut visit = |q: usize, run: &mut ((u32, u32), Border)| {
            let m = labels[q];
            if m != Labels::NONE && m != l {
                let key = (l.min(m), l.max(m));
                let d = (0..3)
                    .map(|c| (px.rgb[p][c] - px.rgb[q][c]).powi(2))
                    .sum::<f32>()
                    .sqrt();
                if run.0 != key {
                    flush(&mut borders, run);
                    run.0 = key;
                }
                run.1.pairs += 1;
                run.1.sum_diff += d as f64;
            }
        };
        let [right, down] = &mut runs;
        if x + 1 < px.w {
            visit(p + 1, right);
        }
        if p + px.w < px.w * px.h {
            visit(p + px.w, down);
        }
    }
    for run in &mut runs {
        flush(&mut borders, run);
    }
    let mut borders: Vec<_> = borders.into_iter().collect();
    borders.sort_unstable_by_key(|b| b.0);
    (regions, borders)
}

/// Rewrites labels through the union–find roots and compacts them to `0..n`; returns n.
pub(crate) fn relabel(labels: &mut [u32], dsu: &mut Dsu, count: usize) -> usize {
    let mut map = vec![Labels::NONE; count];
    let mut next = 0u32;
    for i in 0..count as u32 {
        let r = dsu.find(i);
        if map[r as usize] == Labels::NONE {
            map[r as usize] = next;
            next += 1;
        }
        map[i as usize] = map[r as usize];
    }
    for l in labels.iter_mut() {
        if *l != Labels::NONE {
            *l = map[*l as usize];
        }
    }
    next as usize
}

/// Merges regions smaller than `min_pixels` into the adjacent region of closest mean chroma,
/// in rounds until none is left that can be merged. Returns the new count and, when the last
/// round merged nothing, the graph of the final labels (so the caller need not rebuild it).
pub(crate) fn merge_small(
    labels: &mut [u32],
    mut count: usize,
    px: &PixelData,
    min_pixels: usize,
) -> (usize, Option<(Vec<Region>, Borders)>) {
    for _round in 0..16 {
        let (regions, borders) = graph(labels, count, px);
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); count];
        for ((a, b), _) in &borders {
            adj[*a as usize].push(*b);
            adj[*b as usize].push(*a);
        }
        let mut dsu = Dsu::new(count);
        let mut merged = false;
        for (i, r) in regions.iter().enumerate() {
            if r.pixels >= min_pixels {
                continue;
            }
            let ab = r.mean_ab();
            let best = adj[i]
                .iter()
                .map(|&j| {
                    let o = regions[j as usize].mean_ab();
                    (j, (ab[0] - o[0]).powi(2) + (ab[1] - o[1]).powi(2))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            if let Some((j, _)) = best {
                merged |= dsu.union(i as u32, j);
            }
        }
        if !merged {
            return (count, Some((regions, borders)));
        }
        count = relabel(labels, &mut dsu, count);
    }
    (count, None)
}

/// Merges thin regions — fewer pixels than `ratio` × their border pixel pairs, i.e. strips
/// about `ratio` pixels wide, typically the anti-aliased fringe between two albedos — into the
/// adjacent region of closest mean chroma. Returns the new count.
pub(crate) fn merge_thin(labels: &mut [u32], count: usize, px: &PixelData, ratio: f64) -> usize {
    if ratio <= 0.0 {
        return count;
    }
    let (regions, borders) = graph(labels, count, px);
    let mut border_total = vec![0usize; count];
    let mut adj: Vec<Vec<(u32, usize)>> = vec![Vec::new(); count];
    for ((a, b), bd) in &borders {
        border_total[*a as usize] += bd.pairs;
        border_total[*b as usize] += bd.pairs;
        adj[*a as usize].push((*b, bd.pairs));
        adj[*b as usize].push((*a, bd.pairs));
    }
    let thin: Vec<bool> = (0..count)
        .map(|i| (regions[i].pixels as f64) < ratio * border_total[i] as f64)
        .collect();
    let mut dsu = Dsu::new(count);
    for (i, r) in regions.iter().enumerate() {
        if !thin[i] {
            continue;
        }
        let ab = r.mean_ab();
        // Prefer thick neighbours, so a fringe never chains into another fringe.
        let best = adj[i]
            .iter()
            .map(|&(j, _)| {
                let o = regions[j as usize].mean_ab();
                let d = (ab[0] - o[0]).powi(2) + (ab[1] - o[1]).powi(2);
                (j, thin[j as usize], d)
            })
            .min_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)).then(a.0.cmp(&b.0)));
        if let Some((j, _, _)) = best {
            dsu.union(i as u32, j);
        }
    }
    relabel(labels, &mut dsu, count)
}

/// Merges adjacent regions whose mean RGB distance across the border is below `threshold`.
pub(crate) fn merge_similar(
    labels: &mut [u32],
    count: usize,
    px: &PixelData,
    threshold: f64,
) -> usize {
    if threshold <= 0.0 {
        return count; // no border's mean distance is below 0
    }
    let (_, borders) = graph(labels, count, px);
    let mut dsu = Dsu::new(count);
    for ((a, b), border) in &borders {
        if border.sum_diff / (border.pairs as f64) < threshold {
            dsu.union(*a, *b);
        }
    }
    relabel(labels, &mut dsu, count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagonal_pixels_are_one_component() {
        let n = Labels::NONE;
        #[rustfmt::skip]
        let seg = [
            0, n, 1,
            n, 0, 1,
            0, n, n,
        ];
        let (l, c) = components8(&seg, 3, 3);
        assert_eq!(c, 2);
        assert_eq!(l[0], l[4]);
        assert_eq!(l[0], l[6]);
        assert_eq!(l[2], l[5]);
        assert_ne!(l[0], l[2]);
    }

    #[test]
    fn small_region_joins_closest_chroma() {
        // 1x5 strip: [A A A] [s] [B]; s (one pixel) has chroma closer to B.
        let ab = [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [9.0, 0.0], [10.0, 0.0]];
        let rgb = [[0.5f32; 3]; 5];
        let y = [0.5f32; 5];
        let px = PixelData {
            w: 5,
            h: 1,
            rgb: &rgb,
            ab: &ab,
            y: &y,
        };
        let mut labels = vec![0, 0, 0, 1, 2];
        let (n, _) = merge_small(&mut labels, 3, &px, 2);
        assert_eq!(n, 2);
        assert_eq!(labels[3], labels[4]);
        assert_ne!(labels[0], labels[3]);
    }
}
