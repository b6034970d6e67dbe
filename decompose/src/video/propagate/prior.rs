//! The distance prior of eq. 3.7 (see the module docs of `propagate`): `P(k) ∝ D^{-1/2}`,
//! `D` the distance from the flow-warped pixel `p′` to cluster `k`'s nearest pixel in frame t,
//! floored at half a pixel; the clusters' bounding boxes that rule out far clusters at once,
//! and the exact distance transforms (Felzenszwalb & Huttenlocher) over those boxes.

use crate::decomposition::Labels;

/// Eq. 3.7's prior `D^{-1/2}` for a squared distance `d2`, with `D` floored at
/// [`D_FLOOR`] (`D = 0` would be an infinite prior).
pub(super) fn prior(d2: f64) -> f64 {
    d2.max(D_FLOOR * D_FLOOR).powf(-0.25)
}

/// Largest squared distance whose prior is tabulated per call of [`super::propagate_with`].
pub(super) const PRIOR_TABLE_MAX: usize = 1 << 14;

/// Smallest distance `D` (pixels) in the prior of eq. 3.7: `D = 0` (`p′` lands on a pixel of
/// the cluster) would give an infinite prior. `p′` is rounded to the pixel grid, so the
/// distances are only known to about half a pixel; see the module docs of `propagate`.
pub(super) const D_FLOOR: f64 = 0.5;

/// The bounding box of one cluster's pixels in frame t (empty when it has none).
#[derive(Clone, Copy, Debug)]
pub(super) struct SiteBox {
    x0: usize,
    y0: usize,
    x1: usize,
    y1: usize,
}

impl SiteBox {
    const EMPTY: Self = Self {
        x0: usize::MAX,
        y0: usize::MAX,
        x1: 0,
        y1: 0,
    };

    fn is_empty(&self) -> bool {
        self.x0 > self.x1
    }

    /// `true` when `(x, y)` is within `reach` pixels (per axis) of the box.
    pub(super) fn near(&self, x: usize, y: usize, reach: usize) -> bool {
        !self.is_empty()
            && x + reach >= self.x0
            && x <= self.x1 + reach
            && y + reach >= self.y0
            && y <= self.y1 + reach
    }
}

/// The [`SiteBox`] of every cluster of `prev`, in one pass.
pub(super) fn cluster_boxes(prev: &Labels, k_count: usize) -> Vec<SiteBox> {
    let w = prev.width as usize;
    let mut boxes = vec![SiteBox::EMPTY; k_count];
    for (i, &l) in prev.data.iter().enumerate() {
        if l == Labels::NONE || l as usize >= k_count {
            continue;
        }
        let (x, y) = (i % w, i / w);
        let b = &mut boxes[l as usize];
        b.x0 = b.x0.min(x);
        b.y0 = b.y0.min(y);
        b.x1 = b.x1.max(x);
        b.y1 = b.y1.max(y);
    }
    boxes
}

/// Squared Euclidean distance from each requested pixel of frame t (`req[j].1`, row-major) to
/// the nearest pixel labelled `k`, exact up to `reach` pixels (farther answers may be larger
/// than the truth or infinite). Felzenszwalb & Huttenlocher's two-pass distance transform over
/// the requests' bounding box grown by `reach`: a pixel of `k` outside that box is more than
/// `reach` away from every request.
#[cfg(test)]
pub(super) fn nearest_dist2(prev: &Labels, k: u32, req: &[(usize, u32)], reach: usize) -> Vec<f64> {
    let sites = cluster_boxes(prev, k as usize + 1)[k as usize];
    nearest_dist2_in(prev, k, req, reach, &sites)
}

/// [`nearest_dist2`] given the bounding box `sites` of the pixels labelled `k`: the transform
/// runs over the requests' box grown by `reach`, cut to what covers `sites` and the requests
/// (no pixel of `k` lies outside `sites`).
pub(super) fn nearest_dist2_in(
    prev: &Labels,
    k: u32,
    req: &[(usize, u32)],
    reach: usize,
    sites: &SiteBox,
) -> Vec<f64> {
    let w = prev.width as usize;
    let h = prev.height as usize;
    if sites.is_empty() {
        return vec![f64::INFINITY; req.len()];
    }
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for &(_, s) in req {
        let (x, y) = (s as usize % w, s as usize / w);
        x0 = x0.min(x);
        y0 = y0.min(y);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    let (x0, y0) = (
        x0.min(x0.saturating_sub(reach).max(sites.x0)),
        y0.min(y0.saturating_sub(reach).max(sites.y0)),
    );
    let (x1, y1) = (
        x1.max((x1 + reach).min(sites.x1)).min(w - 1),
        y1.max((y1 + reach).min(sites.y1)).min(h - 1),
    );
    let (bw, bh) = (x1 - x0 + 1, y1 - y0 + 1);

    // Vertical pass: squared distance to the nearest site in the same column.
    let mut f = vec![f64::INFINITY; bw * bh];
    let mut last = vec![None::<usize>; bw];
    for by in 0..bh {
        let row = &prev.data[(y0 + by) * w + x0..(y0 + by) * w + x0 + bw];
        for bx in 0..bw {
            if row[bx] == k {
                last[bx] = Some(by);
            }
            if let Some(l) = last[bx] {
                f[by * bw + bx] = ((by - l) * (by - l)) as f64;
            }
        }
    }
    let mut next = vec![None::<usize>; bw];
    for by in (0..bh).rev() {
        let row = &prev.data[(y0 + by) * w + x0..(y0 + by) * w + x0 + bw];
        for bx in 0..bw {
            if row[bx] == k {
                next[bx] = Some(by);
            }
            if let Some(l) = next[bx] {
                let d = ((l - by) * (l - by)) as f64;
                let slot = &mut f[by * bw + bx];
                *slot = slot.min(d);
            }
        }
    }

    // Horizontal pass, only on the rows that hold a request.
    let mut rows: Vec<usize> = req.iter().map(|&(_, s)| s as usize / w - y0).collect();
    rows.sort_unstable();
    rows.dedup();
    let mut out_rows = vec![Vec::new(); bh];
    let (mut v, mut z) = (Vec::new(), Vec::new());
    for by in rows {
        let mut out = vec![0.0; bw];
        lower_envelope(&f[by * bw..(by + 1) * bw], &mut out, &mut v, &mut z);
        out_rows[by] = out;
    }
    req.iter()
        .map(|&(_, s)| {
            let (x, y) = (s as usize % w - x0, s as usize / w - y0);
            out_rows[y][x]
        })
        .collect()
}

/// One-dimensional squared distance transform `out[q] = min_p (q − p)² + f[p]` by the lower
/// envelope of parabolas (Felzenszwalb & Huttenlocher, "Distance Transforms of Sampled
/// Functions", 2012, Algorithm 1), skipping infinite `f`.
fn lower_envelope(f: &[f64], out: &mut [f64], v: &mut Vec<usize>, z: &mut Vec<f64>) {
    v.clear();
    z.clear();
    for (q, &fq) in f.iter().enumerate() {
        if !fq.is_finite() {
            continue;
        }
        let hq = fq + (q * q) as f64;
        loop {
            match v.last() {
                None => {
                    v.push(q);
                    z.push(f64::NEG_INFINITY);
                    break;
                }
                Some(&p) => {
                    let s = (hq - (f[p] + (p * p) as f64)) / (2 * (q - p)) as f64;
                    if s <= *z.last().expect("z and v have equal lengths") {
                        v.pop();
                        z.pop();
                    } else {
                        v.push(q);
                        z.push(s);
                        break;
                    }
                }
            }
        }
    }
    if v.is_empty() {
        out.fill(f64::INFINITY);
        return;
    }
    let mut j = 0;
    for (q, o) in out.iter_mut().enumerate() {
        while j + 1 < v.len() && z[j + 1] < q as f64 {
            j += 1;
        }
        let p = v[j];
        *o = ((q as f64) - p as f64).powi(2) + f[p];
    }
}
