//! The crease cue (not in the thesis): where two planes meet, the shading jumps.
//!
//! The disparity tells a crease from a plane. On a plane it is affine in the image (it is
//! proportional to `1/Z`, and `1/Z` is affine on a plane for a pinhole camera), so its slope does
//! not change; across a crease it does ([`crease_cue`]). A crease pair gets the weight
//! `ω_crease` instead of 1, and the shading step it asks for is bounded by `T_c`
//! ([`bound_crease_steps`]).

use super::PairWeights;

/// The change of the disparity's slope across the pair `(p, p + stride)` (`stride` 1: the
/// horizontal pair, `width`: the vertical one), the slopes measured one pixel outside the pair
/// on either side; `None` for a pair at the border, where one side has no slope.
fn slope_change(
    width: usize,
    height: usize,
    disparity: &[f32],
    p: usize,
    stride: usize,
) -> Option<f32> {
    let (x, y) = (p % width, p / width);
    let inside = if stride == 1 {
        x >= 1 && x + 2 < width
    } else {
        y >= 1 && y + 2 < height
    };
    let q = p + stride;
    inside.then(|| {
        let slope_before = disparity[p] - disparity[p - stride];
        let slope_after = disparity[q + stride] - disparity[q];
        (slope_after - slope_before).abs()
    })
}

/// The crease cue of one view: `weight` (`ω_crease`) on the pairs across which the disparity's slope changes
/// by more than `step` (`slope_change`), 1 elsewhere and on the pairs at the border.
pub fn crease_cue(
    width: usize,
    height: usize,
    disparity: &[f32],
    step: f32,
    weight: f32,
) -> PairWeights {
    PairWeights::from_pairs(width, height, |p, q| {
        match slope_change(width, height, disparity, p, q - p) {
            Some(change) if change > step => weight,
            _ => 1.0,
        }
    })
}

/// The slope change of every interior pair of one view ([`slope_change`]).
fn slope_changes(width: usize, height: usize, disparity: &[f32]) -> Vec<f32> {
    (0..width * height)
        .flat_map(|p| {
            let right = slope_change(width, height, disparity, p, 1);
            let down = slope_change(width, height, disparity, p, width);
            right.into_iter().chain(down)
        })
        .collect()
}

/// Whether a view's disparity is precise enough for the crease cue: on at least three quarters
/// of the pairs its slope changes by less than a tenth of `step`. A rendered or benchmark
/// disparity passes by orders of magnitude (75th percentile 3e-7–8e-5 px/px on the rendered
/// scenes and the fixture); an estimate from the epipolar-plane images does not (5.6e-2 on
/// tune/scene04, where the cue would cut 45% of the pairs), and then the cue is left off.
pub fn disparity_sees_planes(width: usize, height: usize, disparity: &[f32], step: f32) -> bool {
    let mut changes = slope_changes(width, height, disparity);
    if changes.is_empty() {
        return true;
    }
    let k = changes.len() * 3 / 4;
    let (_, q75, _) = changes.select_nth_unstable_by(k, f32::total_cmp);
    *q75 < step / 10.0
}

/// Bounds the log-shading step that each crease pair (weight below 1 in `crease`) asks for to
/// `max_step` (`T_c`) in size. Of the pair's log-intensity step `Δi = i_p − i_q` the shading takes
/// `(1 − ω^a)·Δi` (eqs. 4.4–4.9); where that is larger than `T_c`, `ω^a` is raised to
/// `1 − T_c/|Δi|`, so the shading takes `±T_c` and the rest of the step goes to the reflectance.
///
/// Why: across a crease between two lit faces the shading changes by the ratio of their
/// cosines to the light, which is seldom more than about 3 (`T_c` = 1.1 by default; the ninth
/// session's 0.7, a ratio of 2, also cut real steps, such as a ceiling at a grazing light); a
/// larger achromatic step, as where a white wall meets a black one, is mostly reflectance.
/// Without the bound the pair asks for the whole step in the shading, and a region that creases
/// enclose gets its level from the data term alone, which pulls it towards a uniform
/// reflectance: the black wall comes out grey (docs/intrinsic-lightfields.md, ninth and
/// eleventh sessions).
pub fn bound_crease_steps(
    albedo: &mut PairWeights,
    crease: &PairWeights,
    log_intensity: &[f32],
    max_step: f32,
) {
    let w = albedo.width;
    let n = w * albedo.height;
    for (weights, creases, stride) in [
        (&mut albedo.horizontal, &crease.horizontal, 1),
        (&mut albedo.vertical, &crease.vertical, w),
    ] {
        for p in 0..n {
            if creases[p] >= 1.0 || p + stride >= n || (stride == 1 && p % w + 1 == w) {
                continue;
            }
            let step = (log_intensity[p] - log_intensity[p + stride]).abs();
            if (1.0 - weights[p]) * step > max_step {
                weights[p] = 1.0 - max_step / step;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crease_cue_marks_slope_changes_not_planes() {
        let (w, h) = (24, 4);
        // A tilted plane (disparity affine in x and y): no crease anywhere.
        let plane: Vec<f32> = (0..w * h)
            .map(|p| 1.0 + 0.003 * (p % w) as f32 + 0.002 * (p / w) as f32)
            .collect();
        // Every real pair's weight (entries past the last column or row are unused).
        let pairs = |c: &PairWeights| -> Vec<f32> {
            (0..w * h)
                .flat_map(|p| {
                    let right = (p % w + 1 < w).then(|| c.horizontal[p]);
                    let down = (p + w < w * h).then(|| c.vertical[p]);
                    right.into_iter().chain(down)
                })
                .collect()
        };
        let c = crease_cue(w, h, &plane, 1e-3, 0.01);
        assert!(pairs(&c).iter().all(|&x| x == 1.0));
        // Two planes meeting in a vertical crease at x = 10: exactly the two horizontal pairs
        // that touch the crease pixel are cut, in every row; no vertical pair.
        let vee: Vec<f32> = (0..w * h)
            .map(|p| 0.01 * ((p % w) as f32 - 10.0).abs())
            .collect();
        let c = crease_cue(w, h, &vee, 1e-3, 0.01);
        for p in 0..w * h {
            let x = p % w;
            let want = if x == 9 || x == 10 { 0.01 } else { 1.0 };
            if x + 1 < w {
                assert_eq!(c.horizontal[p], want, "pair ({x}, {})", x + 1);
            }
            if p + w < w * h {
                assert_eq!(c.vertical[p], 1.0);
            }
        }
        // A gentler crease than the step is not one.
        let c = crease_cue(w, h, &vee, 0.05, 0.01);
        assert!(pairs(&c).iter().all(|&x| x == 1.0));
        // Both are precise disparities; noise of a tenth of the step on most pairs is not.
        assert!(disparity_sees_planes(w, h, &plane, 1e-3));
        assert!(disparity_sees_planes(w, h, &vee, 1e-3));
        let noisy: Vec<f32> = plane
            .iter()
            .enumerate()
            .map(|(p, d)| d + 2e-4 * ((p * 7919 % 13) as f32 - 6.0))
            .collect();
        assert!(!disparity_sees_planes(w, h, &noisy, 1e-3));
        assert!(disparity_sees_planes(2, 2, &[0.0; 4], 1e-3));
        // keep_smaller takes the pairwise minimum.
        let mut occ = PairWeights::constant(w, h, 1.0);
        occ.vertical[0] = 0.5;
        occ.keep_smaller(&crease_cue(w, h, &vee, 1e-3, 0.01));
        assert_eq!(
            (occ.vertical[0], occ.horizontal[9], occ.horizontal[3]),
            (0.5, 0.01, 1.0)
        );
    }

    #[test]
    fn crease_steps_beyond_the_bound_go_to_the_reflectance() {
        let (w, h) = (4, 2);
        // A vertical crease between x = 1 and x = 2 (horizontal pairs at x = 1), nothing else.
        let mut crease = PairWeights::constant(w, h, 1.0);
        crease.horizontal[1] = 0.1;
        crease.horizontal[w + 1] = 0.1;
        // Row 0 steps by ln 10 across the crease, row 1 by ln 1.5; the pair at x = 0 of row 0
        // steps by ln 10 too, but is no crease.
        let ten = 10f32.ln();
        let log_i = vec![ten, 0.0, -ten, -ten, 0.0, 0.0, -(1.5f32).ln(), 0.0];
        let mut albedo = PairWeights::constant(w, h, 0.0);
        albedo.vertical[3] = 1.0;
        let before = albedo.clone();
        let t = 2f32.ln();
        bound_crease_steps(&mut albedo, &crease, &log_i, t);
        // The shading's share of the crease step is now exactly T_c.
        let share = (1.0 - albedo.horizontal[1]) * ten;
        assert!((share - t).abs() < 1e-5, "{share}");
        // Within the bound, and off the crease, nothing changes.
        assert_eq!(albedo.horizontal[w + 1], 0.0);
        assert_eq!(albedo.horizontal[0], 0.0);
        assert_eq!(albedo.vertical, before.vertical);
        // A pair already called a reflectance change stays one.
        let mut all = PairWeights::constant(w, h, 1.0);
        bound_crease_steps(&mut all, &crease, &log_i, t);
        assert_eq!(all, PairWeights::constant(w, h, 1.0));
    }
}
