//! The per-pair histograms of log-shading steps: bounded memory whatever the number of
//! frames, and a median that is exact when the samples of its bin are equal.

/// Bins of a border histogram, over `ln S_p − ln S_q` in `[−RANGE, RANGE]`.
pub(crate) const BINS: usize = 512;
/// Half-width of the histogram's range (natural log: a factor of e⁴ ≈ 55 either way).
pub(crate) const RANGE: f64 = 4.0;

/// The bin of a sample; samples beyond the range fall in the end bins.
pub(super) fn bin_of(d: f64) -> usize {
    let u = (d + RANGE) / (2.0 * RANGE) * BINS as f64;
    (u.max(0.0) as usize).min(BINS - 1)
}

/// Counts and sums of samples in [`BINS`] bins over `[−RANGE, RANGE]` (values beyond fall in
/// the end bins).
#[derive(Clone, Debug)]
pub(crate) struct Histogram {
    count: [u32; BINS],
    sum: [f32; BINS],
}

impl Default for Histogram {
    fn default() -> Self {
        Self {
            count: [0; BINS],
            sum: [0.0; BINS],
        }
    }
}

impl Histogram {
    pub(super) fn add(&mut self, d: f64) {
        let b = bin_of(d);
        self.count[b] += 1;
        self.sum[b] += d as f32;
    }

    pub(super) fn samples(&self) -> u64 {
        self.count.iter().map(|&c| u64::from(c)).sum()
    }

    /// The median, as the mean of the samples in the bin that holds it (exact when they are
    /// all equal, within a bin's width of `2·RANGE / BINS` otherwise); 0 when empty.
    pub(super) fn median(&self) -> f64 {
        let half = self.samples() as f64 / 2.0;
        let mut below = 0.0;
        for (&c, &s) in self.count.iter().zip(&self.sum) {
            let c = f64::from(c);
            if c > 0.0 && below + c >= half {
                return f64::from(s) / c;
            }
            below += c;
        }
        0.0
    }
}
