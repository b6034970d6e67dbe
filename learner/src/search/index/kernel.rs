//! The distance loops of the exact scan, compiled for the widest vector unit the CPU has
//! ([`crate::simd`]). Every path adds up in the same order, so every path gives the same bits.

/// Row padding: the scan's inner loop works on this many `f32` lanes at a time (two AVX2
/// registers, so two independent accumulator chains).
pub const LANES: usize = 16;

/// Rows per group: their lane sums are stored, then reduced (see [`squared_distances`]).
const GROUP: usize = 64;

crate::simd::vectorised_fn! {
    /// Squared Euclidean distance from `q` to each row of `rows` (rows of `q.len()` floats, a
    /// multiple of [`LANES`]), into `out`.
    pub(crate) fn squared_distances<'a>(rows: &'a [f32], q: &'a [f32], out: &'a mut [f32]) -> () {
        keys_with(rows, |i| i, &[q], out);
    }
}

crate::simd::vectorised_fn! {
    /// The value rows are ranked by, for the rows `rows` of `data` (row-major, `q.len()` floats
    /// per row; one key per listed row) against the `references`: the squared distance for one reference (the same
    /// order as the distance, one square root less per row), the mean distance for several.
    /// One pass over the rows: each group of rows is compared with every reference while it
    /// is in the L1 cache, and candidate rows are read where they are (no gathered copy).
    pub(crate) fn ranking_keys<'a>(
        data: &'a [f32],
        rows: &'a [u32],
        references: &'a [Vec<f32>],
        keys: &'a mut [f32],
    ) -> () {
        keys_with(data, |i| rows[i] as usize, references, keys);
    }
}

/// [`ranking_keys`] with row `i` of the output at row `at(i)` of `data`.
#[inline(always)]
fn keys_with<Q: AsRef<[f32]>>(
    data: &[f32],
    at: impl Fn(usize) -> usize,
    references: &[Q],
    keys: &mut [f32],
) {
    let Some(first) = references.first() else {
        return;
    };
    let stride = first.as_ref().len();
    let single = references.len() == 1;
    // Two passes over each group: the lane sums of each row are stored, then reduced.
    // Reducing each row's sums right away made LLVM's SLP vectoriser grow its tree from the
    // reduction's 2-wide last step up into the loop, which then ran on `xmm` pairs of lanes;
    // spilling them with a barrier instead stalled on store-to-load forwarding. Either cost
    // ~3x the scan (perf on `learner bench search`). The arithmetic, hence every bit of the
    // result, is the same.
    let mut sums = [[0.0f32; LANES]; GROUP];
    for (g, keys) in keys.chunks_mut(GROUP).enumerate() {
        let base = g * GROUP;
        for (j, q) in references.iter().enumerate() {
            let q = q.as_ref();
            for (i, s) in sums[..keys.len()].iter_mut().enumerate() {
                let r = at(base + i) * stride;
                *s = lane_sums(&data[r..r + stride], q);
            }
            if single {
                for (s, k) in sums.iter().zip(keys.iter_mut()) {
                    *k = reduce_lanes(s);
                }
            } else if j == 0 {
                for (s, k) in sums.iter().zip(keys.iter_mut()) {
                    *k = reduce_lanes(s).sqrt();
                }
            } else {
                for (s, k) in sums.iter().zip(keys.iter_mut()) {
                    *k += reduce_lanes(s).sqrt();
                }
            }
        }
        if !single {
            let m = references.len() as f32;
            for k in keys.iter_mut() {
                *k /= m;
            }
        }
    }
}

/// The [`LANES`] partial sums of `(a − b)²` over rows padded to [`LANES`], lane `l` over
/// elements `l`, `l + LANES`, …; with [`reduce_lanes`], `‖a − b‖²` in an order that does not
/// depend on the vector width, so every path gives the same bits.
#[inline(always)]
fn lane_sums(a: &[f32], b: &[f32]) -> [f32; LANES] {
    let mut acc = [0.0f32; LANES];
    let (a, _) = a.as_chunks::<LANES>();
    let (b, _) = b.as_chunks::<LANES>();
    for (x, y) in a.iter().zip(b) {
        for l in 0..LANES {
            let d = x[l] - y[l];
            acc[l] += d * d;
        }
    }
    acc
}

/// The partial sums added up in a fixed tree order.
#[inline(always)]
fn reduce_lanes(acc: &[f32; LANES]) -> f32 {
    let mut half = [0.0f32; LANES / 2];
    for l in 0..LANES / 2 {
        half[l] = acc[l] + acc[l + LANES / 2];
    }
    let q = [
        half[0] + half[4],
        half[1] + half[5],
        half[2] + half[6],
        half[3] + half[7],
    ];
    (q[0] + q[2]) + (q[1] + q[3])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-pass keys of several references equal the previous two-step computation (a
    /// squared-distance pass per reference over a gathered copy of the rows, then the mean of
    /// the square roots) bit for bit, on the dispatched and the baseline paths, for a row list
    /// and a run of rows that are not multiples of the group size.
    #[test]
    fn one_pass_keys_are_the_separate_passes_bit_for_bit() {
        let (stride, n) = (48, 300);
        let data: Vec<f32> = (0..n * stride)
            .map(|i| ((i * 7919) % 1000) as f32 / 100.0 - 5.0)
            .collect();
        let row = |r: usize| data[r * stride..(r + 1) * stride].to_vec();
        let refs: Vec<Vec<f32>> = (0..5).map(|r| row(r * 31 + 3)).collect();
        let list: Vec<u32> = (0..n as u32).filter(|i| i % 3 != 1).collect();
        let gathered: Vec<f32> = list.iter().flat_map(|&r| row(r as usize)).collect();
        let mut want = vec![0.0f32; list.len()];
        let mut d = vec![0.0f32; list.len()];
        for q in &refs {
            squared_distances(&gathered, q, &mut d);
            for (w, d) in want.iter_mut().zip(&d) {
                *w += d.sqrt();
            }
        }
        for w in &mut want {
            *w /= refs.len() as f32;
        }
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut got = vec![0.0f32; list.len()];
        ranking_keys(&data, &list, &refs, &mut got);
        assert_eq!(bits(&got), bits(&want));
        crate::simd::tests::baseline_only(|| ranking_keys(&data, &list, &refs, &mut got));
        assert_eq!(bits(&got), bits(&want));

        let mut one = vec![0.0f32; 100];
        let run: Vec<u32> = (50..150).collect();
        ranking_keys(&data, &run, &refs[..1], &mut one);
        let mut sd = vec![0.0f32; 100];
        squared_distances(&data[50 * stride..150 * stride], &refs[0], &mut sd);
        assert_eq!(bits(&one), bits(&sd));
        assert!(one.iter().all(|v| v.is_finite() && *v >= 0.0));
    }
}
