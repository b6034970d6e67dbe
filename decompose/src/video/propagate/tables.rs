//! The per-cluster tables `𝓡_k` and `𝓘_k` of §3.4 (see the module docs of `propagate`).

use std::sync::atomic::{AtomicU64, Ordering};

use rayon::slice::ParallelSliceMut;

use crate::color::srgb_to_linear;
use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::Image;

use super::check_labels;

/// A linear RGB pixel as the 8-bit sRGB-encoded colour a video file would store (clamped to
/// [0, 1], sRGB curve, rounded; non-finite values give 0): the colour space of `𝓘_k` and of
/// the likelihood's `d`.
///
/// Computed by a binary search among the 255 linear values where the rounded code changes,
/// which is 4–5 times faster than evaluating the curve; it agrees with
/// `round(255 · linear_to_srgb(v))` except within rounding error of those 255 values.
pub fn colour8(p: [f32; 3]) -> [u8; 3] {
    let steps = SRGB_STEPS
        .get_or_init(|| std::array::from_fn(|c| srgb_to_linear((c as f32 + 0.5) / 255.0)));
    p.map(|v| {
        if v.is_finite() {
            steps.partition_point(|&t| t <= v) as u8
        } else {
            0
        }
    })
}

/// `SRGB_STEPS[c]`: the linear value at which the 8-bit sRGB code goes from `c` to `c + 1`.
static SRGB_STEPS: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();

/// One exact colour of one cluster in `𝓘_k`.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Entry {
    pub rgb: [u8; 3],
    pub cluster: u32,
    pub count: u64,
    pub refl_sum: [f64; 3],
}

impl Entry {
    fn key(&self) -> u64 {
        key(self.rgb, self.cluster)
    }
}

/// Sort key of an entry: colour, then cluster.
fn key(rgb: [u8; 3], cluster: u32) -> u64 {
    (u64::from(rgb[0]) << 48)
        | (u64::from(rgb[1]) << 40)
        | (u64::from(rgb[2]) << 32)
        | cluster as u64
}

pub(super) fn add3(acc: &mut [f64; 3], v: [f64; 3]) {
    for (a, b) in acc.iter_mut().zip(v) {
        *a += b;
    }
}

/// Per cluster: `|𝓘_k|`, the reflectance sum and `𝓡_k`.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct ClusterStats {
    pub pixels: u64,
    refl_sum: [f64; 3],
    /// `𝓡_k`: (quantised reflectance, count), sorted.
    refl_hist: Vec<([u8; 3], u64)>,
}

/// One cluster's share of the Parzen ball around a colour (see [`ClusterTables::candidates`]).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Candidate {
    pub cluster: u32,
    /// `P(I_p | k)`, eq. 3.6.
    pub likelihood: f64,
    /// Mean reflectance of the exact colour in `𝓘_k` (`None` when it has no such bin; the
    /// reference path [`ClusterTables::candidates`] then gives the mean of `k`'s bins in the
    /// ball).
    pub reflectance: Option<[f32; 3]>,
}

/// The tables `𝓡_k` (reflectance histogram) and `𝓘_k` (colour histogram with the mean
/// reflectance per colour) of every cluster (§3.4).
///
/// The bins of all the `𝓘_k` live in one array sorted by (colour, cluster), indexed by the
/// (red, green) pair, so that the Parzen ball of a colour is read as at most `(2d + 1)²`
/// contiguous runs of blue values. Memory: one entry (40 bytes) per distinct (8-bit colour,
/// cluster) pair seen so far, one (11 bytes) per distinct quantised reflectance per cluster and
/// a 256 KiB index; it grows with the scene's colours, not with the number of frames.
#[derive(Clone, Debug)]
pub struct ClusterTables {
    pub(super) clusters: Vec<ClusterStats>,
    /// Bins of every `𝓘_k`, sorted by [`key`].
    pub(super) entries: Vec<Entry>,
    /// `entries[rg_start[256 r + g]..rg_start[256 r + g + 1]]` have red `r` and green `g`.
    pub(super) rg_start: Vec<u32>,
    /// The blue value of each entry (searched contiguously).
    pub(super) blue: Vec<u8>,
    /// Unique to these contents: a fresh value from a process-wide counter at creation and
    /// at every [`Self::update`] (a clone keeps it, as it keeps the contents). A
    /// [`super::ReflectanceMemo`] is valid for one stamp only.
    pub(super) stamp: u64,
}

/// Equal contents (the stamps are not compared).
impl PartialEq for ClusterTables {
    fn eq(&self, other: &Self) -> bool {
        self.clusters == other.clusters
            && self.entries == other.entries
            && self.rg_start == other.rg_start
            && self.blue == other.blue
    }
}

fn next_stamp() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl ClusterTables {
    /// Empty tables for `clusters` clusters.
    pub fn new(clusters: usize) -> Self {
        Self {
            clusters: vec![ClusterStats::default(); clusters],
            entries: Vec::new(),
            rg_start: vec![0; 256 * 256 + 1],
            blue: Vec::new(),
            stamp: next_stamp(),
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
        let refl = |i: usize| reflectance.rgb(i).map(f64::from);

        // Sums run in row-major pixel order (sorting by (key, pixel) fixes it), so the
        // tables are the same whatever the thread count.
        let mut colour_keys: Vec<(u64, u32)> = Vec::new();
        let mut refl_keys: Vec<(u64, u32)> = Vec::new();
        for (i, &l) in labels.data.iter().enumerate() {
            if l == Labels::NONE {
                continue;
            }
            let stats = &mut self.clusters[l as usize];
            stats.pixels += 1;
            add3(&mut stats.refl_sum, refl(i));
            colour_keys.push((key(colour8(input.rgb(i)), l), i as u32));
            refl_keys.push((key(colour8(reflectance.rgb(i)), l), i as u32));
        }
        colour_keys.par_sort_unstable();
        refl_keys.par_sort_unstable();

        let mut fresh: Vec<Entry> = Vec::new();
        for &(k, i) in &colour_keys {
            if fresh.last().is_none_or(|e| e.key() != k) {
                let [_, r, g, b, ..] = k.to_be_bytes();
                fresh.push(Entry {
                    rgb: [r, g, b],
                    cluster: k as u32,
                    count: 0,
                    refl_sum: [0.0; 3],
                });
            }
            let e = fresh.last_mut().expect("just pushed");
            e.count += 1;
            add3(&mut e.refl_sum, refl(i as usize));
        }
        self.entries = merge_sorted(
            std::mem::take(&mut self.entries),
            fresh,
            Entry::key,
            |a, b| {
                a.count += b.count;
                add3(&mut a.refl_sum, b.refl_sum);
            },
        );
        self.rg_start.fill(0);
        for e in &self.entries {
            self.rg_start[e.rgb[0] as usize * 256 + e.rgb[1] as usize + 1] += 1;
        }
        for j in 1..self.rg_start.len() {
            self.rg_start[j] += self.rg_start[j - 1];
        }
        self.blue = self.entries.iter().map(|e| e.rgb[2]).collect();

        // 𝓡_k: group the sorted (reflectance, cluster) keys per cluster, then merge.
        let mut per_cluster: Vec<Vec<([u8; 3], u64)>> = vec![Vec::new(); self.clusters.len()];
        for &(k, _) in &refl_keys {
            let [_, r, g, b, ..] = k.to_be_bytes();
            let hist = &mut per_cluster[k as u32 as usize];
            match hist.last_mut() {
                Some(last) if last.0 == [r, g, b] => last.1 += 1,
                _ => hist.push(([r, g, b], 1)),
            }
        }
        for (stats, fresh) in self.clusters.iter_mut().zip(per_cluster) {
            if !fresh.is_empty() {
                stats.refl_hist = merge_sorted(
                    std::mem::take(&mut stats.refl_hist),
                    fresh,
                    |e| e.0,
                    |a, b| a.1 += b.1,
                );
            }
        }
        self.stamp = next_stamp();
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
    /// clamped to [0, 1]), as (value, count) sorted by value; `None` for an unknown cluster.
    pub fn reflectance_histogram(&self, k: u32) -> Option<&[([u8; 3], u64)]> {
        self.clusters
            .get(k as usize)
            .map(|s| s.refl_hist.as_slice())
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
        self.entries
            .iter()
            .filter(|e| e.cluster == k)
            .map(|e| {
                let m = e.refl_sum.map(|v| (v / e.count as f64) as f32);
                (e.rgb, e.count, m)
            })
            .collect()
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

    fn rg_run(&self, r: u8, g: u8) -> &[Entry] {
        let j = r as usize * 256 + g as usize;
        &self.entries[self.rg_start[j] as usize..self.rg_start[j + 1] as usize]
    }

    pub(super) fn entry(&self, k: u32, rgb: [u8; 3]) -> Option<&Entry> {
        let run = self.rg_run(rgb[0], rgb[1]);
        run.binary_search_by_key(&key(rgb, k), Entry::key)
            .ok()
            .map(|pos| &run[pos])
    }
}

/// Merges two lists sorted by `key` (unique keys within each), combining equal keys with
/// `join(old, new)`.
fn merge_sorted<T, K: Ord>(
    old: Vec<T>,
    new: Vec<T>,
    key: impl Fn(&T) -> K,
    join: impl Fn(&mut T, T),
) -> Vec<T> {
    if old.is_empty() {
        return new;
    }
    let mut out = Vec::with_capacity(old.len() + new.len());
    let mut new = new.into_iter().peekable();
    for mut o in old {
        while let Some(n) = new.next_if(|n| key(n) < key(&o)) {
            out.push(n);
        }
        if let Some(n) = new.next_if(|n| key(n) == key(&o)) {
            join(&mut o, n);
        }
        out.push(o);
    }
    out.extend(new);
    out
}
