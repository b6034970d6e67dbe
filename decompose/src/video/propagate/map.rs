//! MAP propagation of the clusters from frame t to frame t+1 (§3.5.1–3.5.2; see the module docs
//! of `propagate` for the formulas and their reading).

use rayon::prelude::*;

use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::video::flow::Flow;

use super::ball::ReflectanceMemo;
use super::prior::{PRIOR_TABLE_MAX, cluster_boxes, nearest_dist2_in, prior};
use super::tables::{Candidate, ClusterTables, colour8};
use super::{PropagateParams, check_labels};

/// Result of [`propagate`]: frame t+1's labels and reflectance where assigned.
#[derive(Clone, Debug, PartialEq)]
pub struct Propagation {
    /// The cluster of each pixel of frame t+1, [`Labels::NONE`] where unassigned; `count` is
    /// the tables' cluster count.
    pub labels: Labels,
    /// Reflectance (3 channels, linear) of the assigned pixels, read from `𝓘_k`; 0 elsewhere.
    pub reflectance: Image,
    /// The MAP cluster's posterior per pixel (also where it was not confident enough); 0 where
    /// no cluster was a candidate or the pixel has no source in frame t.
    pub posterior: Vec<f32>,
    /// Number of assigned pixels.
    pub assigned: usize,
}

impl Propagation {
    /// Fraction of the frame's pixels that were assigned.
    pub fn assigned_fraction(&self) -> f64 {
        self.assigned as f64 / self.labels.data.len() as f64
    }

    /// `true` where a pixel was assigned (the input of [`super::should_stop`]).
    pub fn assigned_mask(&self) -> Mask {
        let data = self
            .labels
            .data
            .iter()
            .map(|&l| l != Labels::NONE)
            .collect();
        Mask::from_vec(self.labels.width, self.labels.height, data)
            .expect("labels buffer has width * height entries")
    }
}

/// Propagates the clusters of frame t (`prev`, with [`Labels::NONE`] for its unassigned
/// pixels) to frame t+1 (`next`, linear RGB) along `flow` (from t to t+1), by the
/// high-confidence MAP assignment of §3.5.1–3.5.2 with the likelihood of `tables`.
///
/// Errors: [`Error::InvalidParam`] for bad `params` or a label of `prev` not below
/// `tables.cluster_count()`; [`Error::EmptyImage`]; [`Error::ShapeMismatch`] when `next` or
/// `flow` differ in size from `prev`.
pub fn propagate(
    tables: &ClusterTables,
    prev: &Labels,
    next: &Image,
    flow: &Flow,
    params: &PropagateParams,
) -> Result<Propagation> {
    propagate_with(
        tables,
        prev,
        next,
        flow,
        params,
        &mut ReflectanceMemo::new(),
        None,
    )
}

/// [`propagate`] keeping the colour-ball reflectances of [`PropagateParams::reflectance_radius`]
/// in `memo` for the next call with the same tables (the result is the same with or without
/// the memo, only faster when frames share colours), and deciding only the pixels marked in
/// `targets` (one flag per pixel of frame t+1; `None`: every pixel). A pixel's decision
/// depends on its own colour and source alone, so each targeted pixel gets the same cluster,
/// reflectance and posterior as with `None`; the others are left unassigned with posterior 0.
/// The later passes and the backward propagation of the video method fill a few percent of a
/// frame, and only those pixels' colours need their likelihoods.
///
/// Errors: those of [`propagate`], and [`Error::ShapeMismatch`] when `targets` does not have
/// one flag per pixel.
pub fn propagate_with(
    tables: &ClusterTables,
    prev: &Labels,
    next: &Image,
    flow: &Flow,
    params: &PropagateParams,
    memo: &mut ReflectanceMemo,
    targets: Option<&[bool]>,
) -> Result<Propagation> {
    params.validate()?;
    check_labels(prev)?;
    let dims = (prev.width, prev.height);
    next.check_dims(dims).map_err(|_| Error::ShapeMismatch {
        expected: dims,
        got: next.dims(),
    })?;
    if flow.dims() != dims {
        return Err(Error::ShapeMismatch {
            expected: dims,
            got: flow.dims(),
        });
    }
    let k_count = tables.cluster_count();
    if let Some(&l) = prev
        .data
        .iter()
        .find(|&&l| l != Labels::NONE && l as usize >= k_count)
    {
        return Err(Error::param(
            "label",
            l,
            "must be below the tables' cluster count (or Labels::NONE)",
        ));
    }
    let (w, h) = (dims.0 as usize, dims.1 as usize);
    let n = w * h;
    if let Some(t) = targets
        && t.len() != n
    {
        return Err(Error::ShapeMismatch {
            expected: dims,
            got: (t.len() as u32, 1),
        });
    }
    let wanted = |i: usize| targets.is_none_or(|t| t[i]);

    let pooled = params.reflectance_radius > 0.0;

    // Likelihoods (eq. 3.6) once per distinct 8-bit colour of the targeted pixels of frame
    // t+1 (`SKIPPED` for the others: colours use the low 24 bits only).
    let packed: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|i| {
            if !wanted(i) {
                return SKIPPED;
            }
            let [r, g, b] = colour8(next.rgb(i));
            u32::from_be_bytes([0, r, g, b])
        })
        .collect();
    let mut distinct = packed.clone();
    distinct.par_sort_unstable();
    distinct.dedup();
    if distinct.last() == Some(&SKIPPED) {
        distinct.pop();
    }
    // Runs of distinct colours that share (red, green), each handled by one task in order.
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for (j, &c) in distinct.iter().enumerate() {
        match runs.last_mut() {
            Some(run) if distinct[run.0] >> 8 == c >> 8 => run.1 = j + 1,
            _ => runs.push((j, j + 1)),
        }
    }
    let per_colour: Vec<Vec<Candidate>> = runs
        .par_iter()
        .flat_map_iter(|&(a, b)| {
            let [_, r, g, _] = distinct[a].to_be_bytes();
            let blues: Vec<u8> = distinct[a..b].iter().map(|&c| c as u8).collect();
            let counts = tables.counts_along_blue(r, g, &blues, params.d);
            counts.into_iter().zip(blues).map(move |(cs, b)| {
                cs.into_iter()
                    .map(|(k, count)| Candidate {
                        cluster: k,
                        likelihood: count as f64 / tables.pixels(k) as f64,
                        // With a colour ball every assigned pixel's reflectance is read
                        // below, once per (colour, cluster); the exact bin is not needed.
                        reflectance: if pooled {
                            None
                        } else {
                            tables.colour_reflectance(k, [r, g, b])
                        },
                    })
                    .collect::<Vec<_>>()
            })
        })
        .collect();
    let colour_index: Vec<u32> = packed
        .par_iter()
        .map(|&c| {
            if c == SKIPPED {
                return SKIPPED;
            }
            distinct
                .binary_search(&c)
                .expect("colour is in its own list") as u32
        })
        .collect();

    // p′, the pixel of frame t that flows onto p (rounded), or NONE when outside frame t (or
    // p is not a target: no slots, so it stays unassigned).
    let source: Vec<u32> = (0..n)
        .into_par_iter()
        .map(|i| {
            if wanted(i) {
                source_pixel(flow, i % w, i / w)
            } else {
                NONE
            }
        })
        .collect();

    // One slot per (pixel, candidate cluster): the squared distance from p′ to the cluster's
    // nearest pixel in frame t. 0 where p′ lands on the cluster; the others are requested
    // from a per-cluster distance transform.
    // A request whose p′ lies farther than the window's reach from the bounding box of the
    // cluster's pixels is answered "no pixel in the window" at once, and each transform only
    // covers the cluster's box (plus its requests): otherwise a colour shared by many
    // clusters makes every one of them run over the whole frame (clusters × pixels).
    let radius = params.n as f64 / 2.0;
    let reach = radius.floor() as usize;
    let boxes = cluster_boxes(prev, k_count);
    let mut offsets = Vec::with_capacity(n + 1);
    offsets.push(0usize);
    let mut dist2: Vec<f64> = Vec::new();
    let mut requests: Vec<Vec<(usize, u32)>> = vec![Vec::new(); k_count];
    for i in 0..n {
        let src = source[i];
        if src != NONE {
            let own = prev.data[src as usize];
            let (sx, sy) = (src as usize % w, src as usize / w);
            for cand in &per_colour[colour_index[i] as usize] {
                if cand.cluster == own {
                    dist2.push(0.0);
                } else {
                    if boxes[cand.cluster as usize].near(sx, sy, reach) {
                        requests[cand.cluster as usize].push((dist2.len(), src));
                    }
                    dist2.push(f64::INFINITY);
                }
            }
        }
        offsets.push(dist2.len());
    }
    let answers: Vec<Vec<f64>> = requests
        .par_iter()
        .enumerate()
        .map(|(k, req)| {
            if req.is_empty() {
                return Vec::new();
            }
            nearest_dist2_in(prev, k as u32, req, reach, &boxes[k])
        })
        .collect();
    for (req, ans) in requests.iter().zip(&answers) {
        for (&(slot, _), &d2) in req.iter().zip(ans) {
            dist2[slot] = d2;
        }
    }

    // Posterior and the confidence test (§3.5.2), per pixel.
    let r2 = radius * radius;
    // The prior of eq. 3.7 for the integer squared distances of the pixel grid, looked up
    // instead of one `powf` per (pixel, candidate); the same values.
    let priors: Vec<f64> = (0..=(r2 as usize).min(PRIOR_TABLE_MAX))
        .map(|d2| prior(d2 as f64))
        .collect();
    let decided: Vec<(u32, Option<[f32; 3]>, f32)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let slots = &dist2[offsets[i]..offsets[i + 1]];
            if slots.is_empty() {
                return (Labels::NONE, None, 0.0);
            }
            let cands = &per_colour[colour_index[i] as usize];
            let (mut sum, mut best, mut second, mut arg) = (0.0f64, 0.0f64, 0.0f64, None);
            for (cand, &d2) in cands.iter().zip(slots) {
                if d2 > r2 {
                    continue;
                }
                let p = match priors.get(d2 as usize) {
                    Some(&p) if d2.fract() == 0.0 => p,
                    _ => prior(d2),
                };
                let score = cand.likelihood * p;
                sum += score;
                if score > best {
                    second = best;
                    best = score;
                    arg = Some(cand);
                } else if score > second {
                    second = score;
                }
            }
            let Some(cand) = arg else {
                return (Labels::NONE, None, 0.0);
            };
            let posterior = best / sum;
            if posterior >= params.epsilon && best >= params.beta * second {
                (cand.cluster, cand.reflectance, posterior as f32)
            } else {
                (Labels::NONE, None, posterior as f32)
            }
        })
        .collect();

    // Assigned pixels whose colour has no bin of its own in 𝓘_k (every assigned pixel, with a
    // colour ball) take the mean reflectance of k's bins inside the ball, computed once per
    // (colour, cluster). The Parzen ball of radius d always holds one of k's bins (the
    // likelihood is positive); a smaller colour ball may not, and then falls back to it.
    let mut missing: Vec<(u32, u32)> = decided
        .par_iter()
        .enumerate()
        .filter(|(_, d)| d.0 != Labels::NONE && d.1.is_none())
        .map(|(i, d)| (colour_index[i], d.0))
        .collect();
    missing.par_sort_unstable();
    missing.dedup();
    let fallback: Vec<[f32; 3]> = if pooled {
        let pairs: Vec<(u32, u32)> = missing
            .iter()
            .map(|&(c, k)| (distinct[c as usize], k))
            .collect();
        memo.means(tables, params.reflectance_radius, params.d, &pairs)
    } else {
        missing
            .par_iter()
            .map(|&(c, k)| {
                let [_, r, g, b] = distinct[c as usize].to_be_bytes();
                tables
                    .ball_mean([r, g, b], params.d, k)
                    .expect("an assigned cluster has a bin in the ball")
            })
            .collect()
    };

    let refl: Vec<[f32; 3]> = decided
        .par_iter()
        .enumerate()
        .map(|(i, &(l, r, _))| match r {
            Some(r) => r,
            None if l != Labels::NONE => {
                let j = missing
                    .binary_search(&(colour_index[i], l))
                    .expect("listed above");
                fallback[j]
            }
            None => [0.0; 3],
        })
        .collect();
    let refl = refl.into_flattened();
    let (labels, posterior): (Vec<u32>, Vec<f32>) =
        decided.into_iter().map(|(l, _, p)| (l, p)).unzip();
    let assigned = labels.iter().filter(|&&l| l != Labels::NONE).count();
    Ok(Propagation {
        labels: Labels {
            width: dims.0,
            height: dims.1,
            data: labels,
            count: k_count,
        },
        reflectance: Image::from_vec(dims.0, dims.1, 3, refl)?,
        posterior,
        assigned,
    })
}

/// Marks a pixel without a source in frame t.
const NONE: u32 = u32::MAX;
/// Marks a pixel that is not a target, in place of its packed colour and colour index.
const SKIPPED: u32 = u32::MAX;

/// The row-major index of the pixel of frame t that the flow carries onto `(x, y)` of frame
/// t+1: `p′ = p − f(p′)` by fixed-point iteration, rounded; [`NONE`] when outside the frame.
pub(super) fn source_pixel(flow: &Flow, x: usize, y: usize) -> u32 {
    let (w, h) = (flow.width() as usize, flow.height() as usize);
    let (px, py) = (x as f32, y as f32);
    let i = y * w + x;
    let (mut sx, mut sy) = (px - flow.u()[i], py - flow.v()[i]);
    for _ in 0..2 {
        if !(sx.is_finite() && sy.is_finite()) {
            return NONE;
        }
        let (u, v) = bilinear(flow, sx, sy);
        sx = px - u;
        sy = py - v;
    }
    let (rx, ry) = (sx.round(), sy.round());
    if !(rx >= 0.0 && ry >= 0.0 && rx <= (w - 1) as f32 && ry <= (h - 1) as f32) {
        return NONE;
    }
    (ry as usize * w + rx as usize) as u32
}

/// The flow at a real position, bilinear, with the border replicated.
fn bilinear(flow: &Flow, x: f32, y: f32) -> (f32, f32) {
    let (w, h) = (flow.width() as usize, flow.height() as usize);
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |d: &[f32]| {
        let top = d[y0 * w + x0] * (1.0 - fx) + d[y0 * w + x1] * fx;
        let bottom = d[y1 * w + x0] * (1.0 - fx) + d[y1 * w + x1] * fx;
        top * (1.0 - fy) + bottom * fy
    };
    (at(flow.u()), at(flow.v()))
}
