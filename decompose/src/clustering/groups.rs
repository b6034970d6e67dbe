//! The level of groups of clusters that no equation links together (objects cut apart by the
//! mask). Not in the thesis, whose gauge (eq. 2.8) fixes the mean `ln f` of each group.

use crate::decomposition::Labels;

/// Sets the level of every group of clusters that no equation links to the largest group (an
/// object cut off by the mask) so that the `q`-quantile of its log shading matches the largest
/// group's: every object is assumed to face the light somewhere about as directly as the main
/// surfaces do. A white object then comes out white and a black one black, where the gauge
/// alone (mean `ln f = 0`, eq. 2.8) makes every isolated single-cluster object white.
pub(super) fn match_group_highlights(
    x: &mut [f64],
    comps: &[usize],
    labels: &[u32],
    y: &[f32],
    y_floor: f64,
    q: f32,
) {
    let n = x.len();
    if comps
        .iter()
        .all(|&c| c == comps.first().copied().unwrap_or(0))
    {
        return; // one group: nothing to level
    }
    let mut per: Vec<Vec<f32>> = vec![Vec::new(); n];
    for (i, &l) in labels.iter().enumerate() {
        if l != Labels::NONE {
            let l = l as usize;
            per[comps[l]].push(((y[i] as f64).max(y_floor).ln() + x[l]) as f32);
        }
    }
    let Some(main) = (0..n).max_by_key(|&c| per[c].len()) else {
        return;
    };
    let quantile = |v: &mut Vec<f32>| -> Option<f64> {
        if v.is_empty() {
            return None;
        }
        let k = ((v.len() - 1) as f32 * q).round() as usize;
        Some(*v.select_nth_unstable_by(k, f32::total_cmp).1 as f64)
    };
    let Some(reference) = quantile(&mut per[main]) else {
        return;
    };
    let shift: Vec<f64> = (0..n)
        .map(|c| {
            if c == main {
                0.0
            } else {
                quantile(&mut per[c]).map_or(0.0, |v| reference - v)
            }
        })
        .collect();
    for (xi, &c) in x.iter_mut().zip(comps) {
        *xi += shift[c];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two groups: the second's q-quantile of log shading (q = 1, then 0) is moved onto the
    /// first's, and the first (the largest) does not move.
    #[test]
    fn isolated_group_takes_the_main_groups_highlight_level() {
        // Clusters 0, 1 form group 0 (4 pixels); cluster 2 is group 2 (2 pixels).
        let labels = [0, 0, 1, 1, 2, 2, Labels::NONE];
        let y = [1.0f32, 1.0, 2.0, 2.0, 0.1, 0.1, 5.0];
        let comps = [0usize, 0, 2];
        let mut x = vec![0.0, 0.0, 0.0];
        match_group_highlights(&mut x, &comps, &labels, &y, 1e-6, 1.0);
        assert_eq!(&x[..2], &[0.0, 0.0]);
        // max ln(f·Y) of group 0 is ln 2; group 2 had ln 0.1.
        assert!((x[2] - (2.0f64.ln() - 0.1f64.ln())).abs() < 1e-6, "{x:?}");
        // Quantile 0: the darkest pixels are matched instead.
        let mut x = vec![0.0, 0.0, 0.0];
        match_group_highlights(&mut x, &comps, &labels, &y, 1e-6, 0.0);
        assert!((x[2] - (1.0f64.ln() - 0.1f64.ln())).abs() < 1e-6, "{x:?}");
    }

    /// A grey floor (albedo 0.5) with a white (0.9) and a black (0.06) ball on it, each cut off
    /// from the floor by a two-pixel unmasked ring, as the masks of the rendered scenes and
    /// the MIT objects cut objects from their surroundings. Every surface is lit head-on
    /// somewhere. Matching highlights recovers the albedo ratios; the thesis' handling (eq. 2.7
    /// across groups, then the gauge of eq. 2.8) does not recover the black ball.
    #[test]
    fn isolated_white_and_black_objects_keep_their_albedo() {
        use crate::image::{Image, Mask};
        let (w, h) = (96u32, 64u32);
        let balls = [(28.0f32, 32.0f32, 0.9f32), (68.0, 32.0, 0.06)];
        let radius = 14.0f32;
        let at_ball = |x: u32, yy: u32| {
            balls.iter().enumerate().find_map(|(b, &(cx, cy, _))| {
                let d = ((x as f32 - cx).powi(2) + (yy as f32 - cy).powi(2)).sqrt();
                (d <= radius + 2.0).then_some((b, d))
            })
        };
        let input = Image::from_fn::<3>(w, h, |x, yy| {
            let (albedo, shading) = match at_ball(x, yy) {
                // A head-on lit ball: shading = cos of the angle to the viewer-side light.
                Some((b, d)) => (
                    balls[b].2,
                    (1.0 - (d / (radius + 2.0)).powi(2))
                        .max(0.0)
                        .sqrt()
                        .max(0.05),
                ),
                // The floor: a smooth falloff from 1 at the left edge.
                None => (0.5, 1.0 - 0.5 * x as f32 / w as f32),
            };
            let v = albedo * shading;
            [v, v, v]
        });
        let mask = Mask::from_fn(w, h, |x, yy| match at_ball(x, yy) {
            Some((_, d)) => d < radius,
            None => true,
        });
        let mean_reflectance = |d: &crate::Decomposition, pick: &dyn Fn(u32, u32) -> bool| {
            let (mut sum, mut n) = (0.0f64, 0usize);
            for yy in 0..h {
                for x in 0..w {
                    let i = (yy * w + x) as usize;
                    if mask.at(i) && pick(x, yy) {
                        sum += d.reflectance.rgb(i)[1] as f64;
                        n += 1;
                    }
                }
            }
            sum / n as f64
        };
        let ratios = |params: &super::super::ClusteringParams| {
            let out = super::super::decompose(&input, Some(&mask), params, &mut |_| {}).unwrap();
            let d = &out.decomposition;
            let floor = mean_reflectance(d, &|x, yy| at_ball(x, yy).is_none());
            let white = mean_reflectance(d, &|x, yy| matches!(at_ball(x, yy), Some((0, _))));
            let black = mean_reflectance(d, &|x, yy| matches!(at_ball(x, yy), Some((1, _))));
            (white / floor, black / floor)
        };
        let (white, black) = ratios(&Default::default());
        assert!(
            (1.4..2.4).contains(&white),
            "white/floor {white} (truth 1.8)"
        );
        assert!(
            (0.06..0.2).contains(&black),
            "black/floor {black} (truth 0.12)"
        );
        let thesis_gauge = super::super::ClusteringParams {
            reflectance_within_groups: false,
            group_highlight_quantile: None,
            ..Default::default()
        };
        let (white, black) = ratios(&thesis_gauge);
        assert!(
            !(0.06..0.2).contains(&black),
            "the thesis' gauge alone should not find the black ball: {white} {black}"
        );
    }
}
