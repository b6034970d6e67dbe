//! The per-cluster tables `𝓡_k` and `𝓘_k` of §3.4 (see the module docs of `propagate`).

use std::collections::BTreeMap;

use crate::color::linear_to_srgb;
use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::Image;

use super::check_labels;

/// Width, in 8-bit units, of the cells of the colour grid that indexes the table entries. With
/// 8 a Parzen ball of radius 5 (11 values per channel) meets at most 3 cells per channel.
const CELL: usize = 8;
/// Cells per channel.
const CELLS: usize = 256 / CELL;

/// A linear RGB pixel as the 8-bit sRGB-encoded colour a video file would store (clamped to
/// [0, 1], sRGB curve, rounded): the colour space of `𝓘_k` and of the likelihood's `d`.
pub fn colour8(p: [f32; 3]) -> [u8; 3] {
    p.map(|v| (linear_to_srgb(v) * 255.0).round() as u8)
}

/// One exact colour of one cluster in `𝓘_k`.
#[derive(Clone, Debug, PartialEq)]
struct Entry {
    rgb: [u8; 3],
    cluster: u32,
    count: u64,
    refl_sum: [f64; 3],
}

/// Per cluster: `|𝓘_k|`, the reflectance sum and `𝓡_k`.
#[derive(Clone, Debug, Default, PartialEq)]
struct ClusterStats {
    pixels: u64,
    refl_sum: [f64; 3],
    refl_hist: BTreeMap<[u8; 3], u64>,
}

/// One cluster's share of the Parzen ball around a colour (see [`ClusterTables::candidates`]).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Candidate {
    pub cluster: u32,
    /// `P(I_p | k)`, eq. 3.6.
    pub likelihood: f64,
    /// Mean reflectance of the exact colour in `𝓘_k`, else of `k`'s colours in the ball.
    pub reflectance: [f32; 3],
}

/// The tables `𝓡_k` (reflectance histogram) and `𝓘_k` (colour histogram with the mean
/// reflectance per colour) of every cluster (§3.4).
///
/// Memory: one entry (~48 bytes) per distinct (8-bit colour, cluster) pair seen so far, plus
/// one per distinct quantised reflectance per cluster; it grows with the scene's colours, not
/// with the number of frames.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterTables {
    clusters: Vec<ClusterStats>,
    /// `CELLS³` cells of the colour grid, each sorted by (colour, cluster).
    cells: Vec<Vec<Entry>>,
}

fn add3(acc: &mut [f64; 3], v: [f64; 3]) {
    for (a, b) in acc.iter_mut().zip(v) {
        *a += b;
    }
}

fn cell_of(c: [u8; 3]) -> usize {
    let [r, g, b] = c.map(|v| v as usize / CELL);
    (r * CELLS + g) * CELLS + b
}

impl ClusterTables {
    /// Empty tables for `clusters` clusters.
    pub fn new(clusters: usize) -> Self {
        Self {
            clusters: vec![ClusterStats::default(); clusters],
            cells: vec![Vec::new(); CELLS * CELLS * CELLS],
        }
    }

    /// The tables of the first frame: every labelled pixel of `clusters` with its colour in
    /// `input` (linear RGB, one or three channels) and its value in `reflectance` (linear RGB).
    ///
    /// Errors: [`Error::EmptyImage`], [`Error::ShapeMismatch`] when the three sizes differ,
    /// [`Error::NonFinite`] for a NaN or infinite reflectance, [`Error::InvalidParam`] for a
    /// label not below `clusters.count`.
    pub fn from_frame(input: &Image, reflectance: &Image, clusters: &Labels) -> Result<Self> {
        let mut t = Self::new(clusters.count);
        t.update(input, reflectance, clusters)?;
        Ok(t)
    }

    /// Adds the labelled pixels of another frame (pixels labelled [`Labels::NONE`] are
    /// skipped); labels at or beyond [`Self::cluster_count`] add new, empty-until-now
    /// clusters. The same errors as [`Self::from_frame`]; on error nothing is added.
    pub fn update(&mut self, input: &Image, reflectance: &Image, labels: &Labels) -> Result<()> {
        check_labels(labels)?;
        let dims = (labels.width, labels.height);
        input.check_dims(dims)?;
        reflectance.check_dims(dims)?;
        let w = labels.width as usize;
        for (i, &l) in labels.data.iter().enumerate() {
            if l == Labels::NONE {
                continue;
            }
            if l as usize >= labels.count {
                return Err(Error::param(
                    "label",
                    l,
                    "must be below Labels::count (or Labels::NONE)",
                ));
            }
            if !reflectance.rgb(i).iter().all(|v| v.is_finite()) {
                return Err(Error::NonFinite {
                    x: (i % w) as u32,
                    y: (i / w) as u32,
                });
            }
        }
        if labels.count > self.clusters.len() {
            self.clusters.resize(labels.count, ClusterStats::default());
        }
        // Sequential, in row-major order: the sums are the same whatever the thread count.
        for (i, &l) in labels.data.iter().enumerate() {
            if l == Labels::NONE {
                continue;
            }
            let r = reflectance.rgb(i);
            let rf = r.map(f64::from);
            let stats = &mut self.clusters[l as usize];
            stats.pixels += 1;
            add3(&mut stats.refl_sum, rf);
            *stats.refl_hist.entry(colour8(r)).or_insert(0) += 1;
            let rgb = colour8(input.rgb(i));
            let cell = &mut self.cells[cell_of(rgb)];
            let pos = match cell.binary_search_by_key(&(rgb, l), |e| (e.rgb, e.cluster)) {
                Ok(pos) => pos,
                Err(pos) => {
                    cell.insert(
                        pos,
                        Entry {
                            rgb,
                            cluster: l,
                            count: 0,
                            refl_sum: [0.0; 3],
                        },
                    );
                    pos
                }
            };
            let e = &mut cell[pos];
            e.count += 1;
            add3(&mut e.refl_sum, rf);
        }
        Ok(())
    }

    /// Number of clusters.
    pub fn cluster_count(&self) -> usize {
        self.clusters.len()
    }

    /// `|𝓘_k|`: the number of pixels counted in cluster `k` (0 for an unknown cluster).
    pub fn pixels(&self, k: u32) -> u64 {
        self.clusters.get(k as usize).map_or(0, |s| s.pixels)
    }

    /// The mean reflectance of cluster `k`, `None` when it has no pixel.
    pub fn mean_reflectance(&self, k: u32) -> Option<[f32; 3]> {
        let s = self.clusters.get(k as usize)?;
        (s.pixels > 0).then(|| s.refl_sum.map(|v| (v / s.pixels as f64) as f32))
    }

    /// `𝓡_k`: the histogram of cluster `k`'s reflectance, quantised with [`colour8`] (so
    /// clamped to [0, 1]); `None` for an unknown cluster.
    pub fn reflectance_histogram(&self, k: u32) -> Option<&BTreeMap<[u8; 3], u64>> {
        self.clusters.get(k as usize).map(|s| &s.refl_hist)
    }

    /// How many pixels of cluster `k` had the 8-bit colour `rgb` (one bin of `𝓘_k`).
    pub fn colour_count(&self, k: u32, rgb: [u8; 3]) -> u64 {
        self.entry(k, rgb).map_or(0, |e| e.count)
    }

    /// The mean reflectance stored in `𝓘_k` for the 8-bit colour `rgb`, `None` when the bin
    /// is empty.
    pub fn colour_reflectance(&self, k: u32, rgb: [u8; 3]) -> Option<[f32; 3]> {
        self.entry(k, rgb)
            .map(|e| e.refl_sum.map(|v| (v / e.count as f64) as f32))
    }

    /// `𝓘_k` in full: (colour, count, mean reflectance) per non-empty bin, sorted by colour.
    pub fn colour_histogram(&self, k: u32) -> Vec<([u8; 3], u64, [f32; 3])> {
        let mut out: Vec<_> = self
            .cells
            .iter()
            .flatten()
            .filter(|e| e.cluster == k)
            .map(|e| {
                let m = e.refl_sum.map(|v| (v / e.count as f64) as f32);
                (e.rgb, e.count, m)
            })
            .collect();
        out.sort_by_key(|e| e.0);
        out
    }

    /// The Parzen likelihood `P(I | k)` of eq. 3.6 for every cluster with a non-zero value,
    /// as (cluster, likelihood) sorted by cluster: the fraction of `k`'s pixels whose 8-bit
    /// colour is within Euclidean distance `d` (inclusive) of `colour`.
    pub fn likelihoods(&self, colour: [u8; 3], d: f64) -> Vec<(u32, f64)> {
        self.candidates(colour, d)
            .into_iter()
            .map(|c| (c.cluster, c.likelihood))
            .collect()
    }

    fn entry(&self, k: u32, rgb: [u8; 3]) -> Option<&Entry> {
        let cell = &self.cells[cell_of(rgb)];
        cell.binary_search_by_key(&(rgb, k), |e| (e.rgb, e.cluster))
            .ok()
            .map(|pos| &cell[pos])
    }

    /// The clusters with a non-zero likelihood for `colour`, sorted by cluster, with the
    /// reflectance an assigned pixel of that colour would take.
    pub(super) fn candidates(&self, colour: [u8; 3], d: f64) -> Vec<Candidate> {
        struct Acc {
            cluster: u32,
            count: u64,
            sum: [f64; 3],
            exact: Option<[f64; 3]>,
        }
        let reach = d.floor().min(255.0) as i32;
        let d2 = d * d;
        let range = |v: u8| {
            let lo = (v as i32 - reach).max(0) as usize / CELL;
            let hi = (v as i32 + reach).min(255) as usize / CELL;
            lo..=hi
        };
        let mut acc: Vec<Acc> = Vec::new();
        for cr in range(colour[0]) {
            for cg in range(colour[1]) {
                for cb in range(colour[2]) {
                    for e in &self.cells[(cr * CELLS + cg) * CELLS + cb] {
                        let dist2: i32 = (0..3)
                            .map(|c| (e.rgb[c] as i32 - colour[c] as i32).pow(2))
                            .sum();
                        if dist2 as f64 > d2 {
                            continue;
                        }
                        let a = match acc.iter_mut().position(|a| a.cluster == e.cluster) {
                            Some(j) => &mut acc[j],
                            None => {
                                acc.push(Acc {
                                    cluster: e.cluster,
                                    count: 0,
                                    sum: [0.0; 3],
                                    exact: None,
                                });
                                acc.last_mut().expect("just pushed")
                            }
                        };
                        a.count += e.count;
                        add3(&mut a.sum, e.refl_sum);
                        if dist2 == 0 {
                            a.exact = Some(e.refl_sum.map(|v| v / e.count as f64));
                        }
                    }
                }
            }
        }
        acc.sort_by_key(|a| a.cluster);
        acc.into_iter()
            .map(|a| {
                let mean = a.exact.unwrap_or(a.sum.map(|v| v / a.count as f64));
                Candidate {
                    cluster: a.cluster,
                    likelihood: a.count as f64 / self.clusters[a.cluster as usize].pixels as f64,
                    reflectance: mean.map(|v| v as f32),
                }
            })
            .collect()
    }
}
