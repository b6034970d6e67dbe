//! Cluster levels from shading continuity across cluster borders, over the whole video.
//!
//! Not a step of the thesis' Algorithm 1: the thesis takes every cluster's reflectance level
//! from the first frame's Retinex and keeps it (propagation copies the colour table `𝓘_k`).
//! On the rendered tuning sequences that level is where most of the error is: with each
//! cluster's level set from the truth (an oracle, one log offset per cluster for the whole
//! video), the mean LMSE of `tune/seq00` falls from 0.053 to 0.012. Zhao's Retinex reads
//! achromatic edges (a grey cube on a white floor) as shading, so it gives such a cube a light
//! reflectance and a dark shading, and the video keeps that error in every frame.
//!
//! The correction is the border equation of the clustering method (ch. 2, §2.3: across a
//! border between two different clusters the shading is continuous) applied to the video's
//! own clusters, with the evidence of every frame: the camera, the light and the objects move,
//! so a pair of clusters meets along different borders, under different light, in different
//! frames. For each pair of clusters `(a, b)` that touch (4-neighbours, different labels) we
//! collect `ln S_p − ln S_q` (`p` in `a`, `q` in `b`) over all frames into a histogram and take
//! its median `m_ab` (robust to the borders where the shading really jumps: occlusions, cast
//! shadows that follow a border). The offsets `δ` solve, by iteratively reweighted least
//! squares (an L1 fit, the same robust norm as the clustering method's IRLS),
//!
//! `min Σ_ab n_ab |δ_a − δ_b − m_ab|`,
//!
//! with `n_ab` the number of border samples, and every pixel of cluster `k` gets
//! `S ← S·e^{−δ_k}`, `R ← R·e^{δ_k}` (`R × S = I` stays exact). A cluster's offset is the same
//! in every frame, so the flicker does not change. Each connected group of clusters keeps the
//! level of its largest cluster (the gauge); a cluster that touches no other keeps its own.
//! Then one factor for the whole video puts the first frame's white point (99.5th percentile
//! of the reflectance) back at 1, as before the levelling.
//!
//! The user's strokes on the first frame stay true: two touching clusters inside one
//! constant-shading stroke get equal shading across their border there, and inside one
//! constant-albedo stroke equal reflectance; these pairs weigh [`STROKE_WEIGHT`] times all the
//! border evidence together.
//!
//! Memory: one histogram (512 counts and sums, 4 KiB) per touching pair, whatever the
//! length of the video.

use std::collections::HashMap;

mod histogram;
mod views;

use histogram::Histogram;
pub(crate) use views::ViewLevels;

use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::retinex::Strokes;
use crate::solver::{LinearSystem, SolverParams};

/// Weight of the stroke equations relative to the whole border evidence (which sums to 1).
pub(crate) const STROKE_WEIGHT: f64 = 1e3;

/// Parameters of the border levelling ([`super::VideoParams::levels`]).
#[derive(Clone, Debug, PartialEq)]
pub struct BorderLevelParams {
    /// Reweighting passes of the L1 fit. Default 10.
    pub iterations: usize,
    /// Residual below which an equation's L1 reweighting factor `1 / |residual|` stops growing
    /// (natural-log units). Default 0.1, chosen by leave-one-sequence-out on the four rendered
    /// tuning sequences among 0.005, 0.02, 0.1 and plain least squares, with the thesis' `ε`,
    /// `β` of the time (every fold chose 0.1; the four differ by less than 3% in mean LMSE).
    pub residual_floor: f64,
    /// Whether step 8's single-image decompositions vote on the offsets (module `views`): a
    /// cluster keeps its offset only when it moves the cluster towards the level the single
    /// views give it, else keeps the first frame's level. Needs step 8 with `β > 0`; without
    /// it there is no vote. Default on.
    pub view_vote: bool,
}

impl Default for BorderLevelParams {
    fn default() -> Self {
        Self {
            iterations: 10,
            residual_floor: 0.1,
            view_vote: true,
        }
    }
}

impl BorderLevelParams {
    /// Errors with [`Error::InvalidParam`] naming the first value out of range.
    pub fn validate(&self) -> Result<()> {
        if !(self.residual_floor.is_finite() && self.residual_floor > 0.0) {
            return Err(Error::param(
                "residual_floor",
                self.residual_floor,
                "must be finite and > 0",
            ));
        }
        Ok(())
    }
}

/// What the border levelling did, for [`super::VideoStats`].
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LevelSummary {
    /// Pairs of clusters that touch in some frame (equations of the fit).
    pub pairs: usize,
    /// Mean |δ| over the clusters (natural log).
    pub mean_abs_offset: f64,
    /// Time of the fit, milliseconds (the evidence is gathered during the residual fill).
    pub ms: f64,
}

/// The border evidence of the frames seen so far.
#[derive(Clone, Debug, Default)]
pub(crate) struct BorderEvidence {
    /// Per pair `(a, b)` with `a < b`: histogram of `ln S_p − ln S_q`, `p` in `a`, `q` in `b`.
    pairs: HashMap<(u32, u32), Box<Histogram>>,
    /// The same for the pairs inside the first frame's strokes (the required `δ_a − δ_b`).
    strokes: HashMap<(u32, u32), Box<Histogram>>,
    /// Pixels per cluster over all frames (the gauge is each group's largest cluster).
    sizes: Vec<u64>,
}

impl BorderEvidence {
    /// Adds one frame: `labels` per pixel ([`Labels::NONE`] where none), `shading` linear grey.
    pub fn add_frame(&mut self, width: usize, labels: &[u32], shading: &[f32]) {
        let log_s = |i: usize| f64::from(shading[i]).ln();
        let valid = |i: usize| labels[i] != Labels::NONE && shading[i] > 0.0;
        for &l in labels {
            if l == Labels::NONE {
                continue;
            }
            if self.sizes.len() <= l as usize {
                self.sizes.resize(l as usize + 1, 0);
            }
            self.sizes[l as usize] += 1;
        }
        let pairs = &mut self.pairs;
        border_pairs(width, labels, &valid, |i, j| {
            let (a, b) = (labels[i], labels[j]);
            let (key, d) = if a < b {
                ((a, b), log_s(i) - log_s(j))
            } else {
                ((b, a), log_s(j) - log_s(i))
            };
            pairs.entry(key).or_default().add(d);
        });
    }

    /// Adds the first frame's strokes: for touching pixels `p`, `q` of different clusters
    /// inside one constant-shading mask, `δ_a − δ_b = ln S_p − ln S_q` (equal shading after
    /// the offsets); inside one constant-albedo mask, `δ_a − δ_b = ln ρ_q − ln ρ_p` with
    /// `ρ = lum(I) / S` (equal reflectance after the offsets). `input_lum` is the luminance of
    /// the input frame.
    pub fn add_strokes(
        &mut self,
        width: usize,
        labels: &[u32],
        shading: &[f32],
        input_lum: &[f32],
        strokes: &Strokes,
    ) {
        let log_s = |i: usize| f64::from(shading[i]).ln();
        let log_r = |i: usize| f64::from(input_lum[i].max(1e-6)).ln() - log_s(i);
        let valid = |i: usize| labels[i] != Labels::NONE && shading[i] > 0.0;
        let kinds = [
            (&strokes.constant_shading, true),
            (&strokes.constant_albedo, false),
        ];
        for (masks, equal_shading) in kinds {
            for mask in masks.iter() {
                let inside = |i: usize| mask.at(i) && valid(i);
                let pairs = &mut self.strokes;
                border_pairs(width, labels, &inside, |i, j| {
                    // (δ of i's cluster) − (δ of j's cluster):
                    let d = if equal_shading {
                        log_s(i) - log_s(j)
                    } else {
                        log_r(j) - log_r(i)
                    };
                    let (a, b) = (labels[i], labels[j]);
                    let (key, d) = if a < b { ((a, b), d) } else { ((b, a), -d) };
                    pairs.entry(key).or_default().add(d);
                });
            }
        }
    }

    /// Number of touching pairs.
    pub fn pair_count(&self) -> usize {
        self.pairs.len()
    }

    /// Whether cluster `k` takes part in an equation of the user's strokes (its offset is then
    /// the user's, not the single views' to vote on).
    pub fn in_strokes(&self, k: usize) -> bool {
        self.strokes
            .keys()
            .any(|&(a, b)| a as usize == k || b as usize == k)
    }

    /// The cluster with the most pixels over the frames seen so far (`None` before any).
    pub fn largest_cluster(&self) -> Option<usize> {
        (0..self.sizes.len())
            .filter(|&k| self.sizes[k] > 0)
            .max_by_key(|&k| (self.sizes[k], std::cmp::Reverse(k)))
    }

    /// The offsets `δ` (natural log, one per cluster up to `clusters`) of the module docs.
    pub fn offsets(&self, clusters: usize, params: &BorderLevelParams) -> Result<Vec<f64>> {
        params.validate()?;
        let inside =
            |&(a, b, ..): &(u32, u32, f64, u64)| (a as usize) < clusters && (b as usize) < clusters;
        let pairs: Vec<_> = medians(&self.pairs).into_iter().filter(inside).collect();
        let stroke_pairs: Vec<_> = medians(&self.strokes).into_iter().filter(inside).collect();
        let samples: u64 = pairs.iter().map(|p| p.3).sum();
        if (pairs.is_empty() || samples == 0) && stroke_pairs.is_empty() {
            return Ok(vec![0.0; clusters]);
        }
        let mut system = LinearSystem::new(clusters);
        for &(a, b, m, n) in &pairs {
            system.add(
                &[(a as usize, 1.0), (b as usize, -1.0)],
                m,
                n as f64 / samples.max(1) as f64,
            );
        }
        let stroke_samples: u64 = stroke_pairs.iter().map(|p| p.3).sum();
        for &(a, b, m, n) in &stroke_pairs {
            system.add(
                &[(a as usize, 1.0), (b as usize, -1.0)],
                m,
                STROKE_WEIGHT * n as f64 / stroke_samples.max(1) as f64,
            );
        }
        let groups = system.components();
        // A tiny pull towards the first frame's level keeps every group's free scale (and a
        // cluster that touches none) defined; the gauge below then sets it exactly.
        let pixels = self.sizes.iter().sum::<u64>().max(1) as f64;
        for k in 0..clusters {
            let size = self.sizes.get(k).copied().unwrap_or(0) as f64;
            system.add(&[(k, 1.0)], 0.0, 1e-6 * (size / pixels).max(1e-9));
        }
        let floor = params.residual_floor;
        let (mut delta, _) =
            system.solve_irls(&SolverParams::default(), params.iterations, |r: f64| {
                1.0 / r.abs().max(floor)
            })?;
        // Gauge: each group's largest cluster keeps its level.
        let mut largest: HashMap<usize, usize> = HashMap::new();
        for (k, &g) in groups.iter().enumerate() {
            let size = |c: usize| self.sizes.get(c).copied().unwrap_or(0);
            let e = largest.entry(g).or_insert(k);
            if size(k) > size(*e) {
                *e = k;
            }
        }
        let shift: Vec<f64> = groups.iter().map(|g| delta[largest[g]]).collect();
        for (d, s) in delta.iter_mut().zip(shift) {
            *d -= s;
        }
        // A degenerate solve must not put NaN into every frame: keep the first frame's levels.
        if delta.iter().any(|d| !d.is_finite()) {
            return Ok(vec![0.0; clusters]);
        }
        Ok(delta)
    }
}

/// Calls `f(i, j)` for every pair of 4-neighbours (`j` right of or below `i`) with different
/// labels, both `valid`.
fn border_pairs(
    width: usize,
    labels: &[u32],
    valid: &dyn Fn(usize) -> bool,
    mut f: impl FnMut(usize, usize),
) {
    let height = labels.len() / width.max(1);
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            if !valid(i) {
                continue;
            }
            let right = (x + 1 < width).then_some(i + 1);
            let down = (y + 1 < height).then_some(i + width);
            for j in [right, down].into_iter().flatten() {
                if labels[i] != labels[j] && valid(j) {
                    f(i, j);
                }
            }
        }
    }
}

/// Per pair `(a, b, median of ln S_a − ln S_b, samples)` of a histogram map, sorted by pair.
fn medians(map: &HashMap<(u32, u32), Box<Histogram>>) -> Vec<(u32, u32, f64, u64)> {
    let mut out: Vec<_> = map
        .iter()
        .map(|(&(a, b), h)| (a, b, h.median(), h.samples()))
        .collect();
    out.sort_unstable_by_key(|&(a, b, ..)| (a, b));
    out
}

/// Applies the offsets to one frame's shading: `S ← S·e^{−δ_k}` for its cluster `k`.
pub(crate) fn apply(labels: &[u32], shading: &mut [f32], delta: &[f64]) {
    for (s, &l) in shading.iter_mut().zip(labels) {
        if let Some(&d) = delta.get(l as usize) {
            *s *= (-d).exp() as f32;
        }
    }
}

#[cfg(test)]
mod tests;
