//! The Parzen likelihood of eq. 3.6 read from the tables (see the module docs of
//! `propagate`): a scan of the ball for one colour, and the sliding counts for a run of
//! colours.

use super::tables::{Candidate, ClusterTables, add3};

impl ClusterTables {
    /// The clusters with a non-zero likelihood for `colour`, sorted by cluster, with the
    /// reflectance an assigned pixel of that colour would take.
    pub(super) fn candidates(&self, colour: [u8; 3], d: f64) -> Vec<Candidate> {
        self.candidates_with(colour, d, &mut Scratch::default())
    }

    /// [`Self::candidates`] with reusable buffers.
    pub(super) fn candidates_with(
        &self,
        colour: [u8; 3],
        d: f64,
        scratch: &mut Scratch,
    ) -> Vec<Candidate> {
        let k_count = self.clusters.len();
        if scratch.count.len() < k_count {
            scratch.count.resize(k_count, 0);
            scratch.sum.resize(k_count, [0.0; 3]);
        }
        let reach = d.floor().min(255.0) as i32;
        let d2 = d * d;
        let [r0, g0, b0] = colour.map(i32::from);
        for r in (r0 - reach).max(0)..=(r0 + reach).min(255) {
            let dr2 = (r - r0).pow(2);
            for g in (g0 - reach).max(0)..=(g0 + reach).min(255) {
                let rem = d2 - (dr2 + (g - g0).pow(2)) as f64;
                if rem < 0.0 {
                    continue;
                }
                let hb = half_width(rem);
                let j = r as usize * 256 + g as usize;
                let (s0, s1) = (self.rg_start[j] as usize, self.rg_start[j + 1] as usize);
                let blue = &self.blue[s0..s1];
                let lo = s0 + blue.partition_point(|&b| (b as i32) < b0 - hb);
                let hi = s0 + blue.partition_point(|&b| (b as i32) <= b0 + hb);
                for e in &self.entries[lo..hi] {
                    let k = e.cluster as usize;
                    if scratch.count[k] == 0 {
                        scratch.touched.push(e.cluster);
                    }
                    scratch.count[k] += e.count;
                    add3(&mut scratch.sum[k], e.refl_sum);
                }
            }
        }
        scratch.touched.sort_unstable();
        let out = scratch
            .touched
            .iter()
            .map(|&k| {
                let (count, sum) = (scratch.count[k as usize], scratch.sum[k as usize]);
                let mean = match self.entry(k, colour) {
                    Some(e) => e.refl_sum.map(|v| v / e.count as f64),
                    None => sum.map(|v| v / count as f64),
                };
                Candidate {
                    cluster: k,
                    likelihood: count as f64 / self.clusters[k as usize].pixels as f64,
                    reflectance: Some(mean.map(|v| v as f32)),
                }
            })
            .collect();
        for &k in &scratch.touched {
            scratch.count[k as usize] = 0;
            scratch.sum[k as usize] = [0.0; 3];
        }
        scratch.touched.clear();
        out
    }
}

impl ClusterTables {
    /// The Parzen counts (eq. 3.6 before the division by `|𝓘_k|`) of a run of colours that
    /// share red `r0` and green `g0`, with strictly increasing blues: per colour, (cluster,
    /// number of the cluster's pixels within `d`), sorted by cluster.
    ///
    /// The same numbers as [`Self::candidates`], found by sliding: the ball is the union of
    /// at most `(2d + 1)²` blue intervals, one per (red, green) offset, and as the blue of
    /// the query grows each interval only moves up its run of bins, so each bin enters and
    /// leaves once per run of queries. Counts are integers, so the sliding sums are exact.
    pub(super) fn counts_along_blue(
        &self,
        r0: u8,
        g0: u8,
        blues: &[u8],
        d: f64,
    ) -> Vec<Vec<(u32, u64)>> {
        struct Lane {
            end: usize,
            hb: i32,
            lo: usize,
            hi: usize,
        }
        let reach = d.floor().min(255.0) as i32;
        let d2 = d * d;
        let (r0i, g0i) = (i32::from(r0), i32::from(g0));
        let mut lanes = Vec::new();
        for r in (r0i - reach).max(0)..=(r0i + reach).min(255) {
            for g in (g0i - reach).max(0)..=(g0i + reach).min(255) {
                let rem = d2 - ((r - r0i).pow(2) + (g - g0i).pow(2)) as f64;
                if rem < 0.0 {
                    continue;
                }
                let j = r as usize * 256 + g as usize;
                let (s0, s1) = (self.rg_start[j] as usize, self.rg_start[j + 1] as usize);
                if s0 == s1 {
                    continue;
                }
                lanes.push(Lane {
                    end: s1,
                    hb: half_width(rem),
                    lo: s0,
                    hi: s0,
                });
            }
        }
        let mut count = vec![0u64; self.clusters.len()];
        let mut live: Vec<u32> = Vec::new();
        let mut out = Vec::with_capacity(blues.len());
        for &b0 in blues {
            let b0 = i32::from(b0);
            for lane in &mut lanes {
                let mut lo = lane.lo;
                while lo < lane.end && (self.blue[lo] as i32) < b0 - lane.hb {
                    lo += 1;
                }
                for e in &self.entries[lane.lo..lo.min(lane.hi)] {
                    count[e.cluster as usize] -= e.count;
                }
                let mut hi = lane.hi.max(lo);
                let first_new = hi;
                while hi < lane.end && (self.blue[hi] as i32) <= b0 + lane.hb {
                    hi += 1;
                }
                for e in &self.entries[first_new..hi] {
                    if count[e.cluster as usize] == 0 {
                        live.push(e.cluster);
                    }
                    count[e.cluster as usize] += e.count;
                }
                lane.lo = lo;
                lane.hi = hi;
            }
            live.sort_unstable();
            live.dedup();
            live.retain(|&k| count[k as usize] > 0);
            out.push(live.iter().map(|&k| (k, count[k as usize])).collect());
        }
        out
    }

    /// The count-weighted mean reflectance of cluster `k`'s bins inside the Parzen ball of
    /// `colour` (the fallback when `𝓘_k` has no bin for the exact colour), `None` when the
    /// ball holds none of them.
    pub(super) fn ball_mean(&self, colour: [u8; 3], d: f64, k: u32) -> Option<[f32; 3]> {
        self.candidates(colour, d)
            .into_iter()
            .find(|c| c.cluster == k)
            .and_then(|c| c.reflectance)
    }
}

/// The largest integer `h` with `h² ≤ rem` (`rem ≥ 0`): every bin of the blue interval
/// `[b − h, b + h]` of a (red, green) offset lies in the ball and no other does.
fn half_width(rem: f64) -> i32 {
    let mut hb = rem.sqrt() as i32;
    while ((hb + 1) * (hb + 1)) as f64 <= rem {
        hb += 1;
    }
    while hb > 0 && (hb * hb) as f64 > rem {
        hb -= 1;
    }
    hb
}

/// Per-thread buffers of [`ClusterTables::candidates_with`]: dense per-cluster accumulators
/// (all zero between calls) and the clusters touched.
#[derive(Debug, Default)]
pub(super) struct Scratch {
    count: Vec<u64>,
    sum: Vec<[f64; 3]>,
    touched: Vec<u32>,
}
