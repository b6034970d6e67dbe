//! Step 8 (module `fusion`): the blend, the average along the flow, and the step in the method.

use super::super::fusion::{average_along_flow, blend, clustering_shading, working_size};
use super::*;
use crate::video::flow::Flow;

/// `ln` of a ramp, so that every pixel differs.
fn ramp(w: usize, h: usize, scale: f32) -> Vec<f32> {
    (0..w * h).map(|p| scale * (p as f32 / 7.0).sin()).collect()
}

#[test]
fn the_average_follows_an_integer_flow_exactly() {
    // Frame t is frame t − 1 moved 2 px right, 1 px down: the point p of frame t came from
    // p + (−2, −1).
    let (w, h) = (12usize, 9usize);
    let flow = Flow::from_fn(w as u32, h as u32, |_, _| [-2.0, -1.0]);
    let prev_d = ramp(w, h, 1.0);
    let prev_i: Vec<f32> = ramp(w, h, 0.5);
    // This frame's intensity is the moved previous one: the gate passes wherever the
    // predecessor is inside the frame.
    let log_i: Vec<f32> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            if x >= 2 && y >= 1 {
                prev_i[(y - 1) * w + x - 2]
            } else {
                0.3
            }
        })
        .collect();
    let d = ramp(w, h, -0.7);
    let alpha = 0.25;
    let out = average_along_flow(&prev_d, &prev_i, &d, &log_i, &flow, alpha, 1e-4).unwrap();
    for p in 0..w * h {
        let (x, y) = (p % w, p / w);
        let expected = if x >= 2 && y >= 1 {
            (1.0 - alpha) * prev_d[(y - 1) * w + x - 2] + alpha * d[p]
        } else {
            d[p] // the predecessor is outside the frame
        };
        assert!((out[p] - expected).abs() < 1e-6, "pixel ({x}, {y})");
    }
}

#[test]
fn the_gate_and_unlit_pixels_stop_the_average() {
    let (w, h) = (6usize, 4usize);
    let flow = Flow::zeros(w as u32, h as u32);
    let prev_d = vec![1.0f32; w * h];
    let mut prev_i = vec![0.0f32; w * h];
    prev_i[3] = f32::NAN; // unlit before
    let mut log_i = vec![0.0f32; w * h];
    log_i[5] = 0.2; // the light changed by more than the gate
    log_i[7] = 0.05; // by less
    log_i[9] = f32::NAN; // unlit now
    let d = vec![0.0f32; w * h];
    let out = average_along_flow(&prev_d, &prev_i, &d, &log_i, &flow, 0.5, 0.1).unwrap();
    assert_eq!(out[3], 0.0);
    assert_eq!(out[5], 0.0);
    assert_eq!(out[7], 0.5);
    assert_eq!(out[9], 0.0);
    assert_eq!(out[0], 0.5);
    // A flow of another size is an error, not a panic.
    let small = Flow::zeros(3, 3);
    assert!(average_along_flow(&prev_d, &prev_i, &d, &log_i, &small, 0.5, 0.1).is_err());
}

#[test]
fn the_blend_is_on_the_propagated_scale_and_keeps_stroked_pixels() {
    let n = 50;
    let s: Vec<f32> = (0..n).map(|p| 0.2 + p as f32 / 60.0).collect();
    let v: Vec<f32> = (0..n).map(|p| 0.5 + ((p * 7) % 11) as f32 / 20.0).collect();
    let log_i = vec![0.0f32; n];
    let a = blend(&s, &[(&v, 0.6)], 0.0, &log_i, None);
    // The view's own scale does not matter: it is moved to the propagated one.
    let v7: Vec<f32> = v.iter().map(|x| 7.0 * x).collect();
    let b = blend(&s, &[(&v7, 0.6)], 0.0, &log_i, None);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-5, "{x} {y}");
    }
    // β = 0 is the propagated shading; β = 1 the view's, whose median log ratio to the
    // propagated one is then 0.
    let zero = blend(&s, &[(&v, 0.0)], 0.0, &log_i, None);
    assert!(blend(&s, &[], 0.0, &log_i, None) == zero);
    assert!(zero.iter().zip(&s).all(|(z, s)| (z - s.ln()).abs() < 1e-6));
    let one = blend(&s, &[(&v, 1.0)], 0.0, &log_i, None);
    let mut ratio: Vec<f32> = one.iter().zip(&s).map(|(o, s)| o - s.ln()).collect();
    ratio.sort_by(f32::total_cmp);
    assert!(ratio[n / 2].abs() < 1e-6, "median {}", ratio[n / 2]);
    // Kept pixels are the propagated shading.
    let keep: Vec<bool> = (0..n).map(|p| p < 10).collect();
    let kept = blend(&s, &[(&v, 0.6)], 0.0, &log_i, Some(&keep));
    for p in 0..n {
        let expected = if p < 10 { s[p].ln() } else { a[p] };
        assert!((kept[p] - expected).abs() < 1e-6);
    }
    // Two members: each moved to the propagated scale on its own, then weighted; the
    // propagated shading keeps 1 − 0.4 − 0.1.
    let c: Vec<f32> = (0..n).map(|p| 3.0 + ((p * 3) % 7) as f32).collect();
    let both = blend(&s, &[(&v, 0.4), (&c, 0.1)], 0.0, &log_i, None);
    let (bv, bc) = (
        blend(&s, &[(&v, 1.0)], 0.0, &log_i, None),
        blend(&s, &[(&c, 1.0)], 0.0, &log_i, None),
    );
    for p in 0..n {
        let expected = 0.5 * s[p].ln() + 0.4 * bv[p] + 0.1 * bc[p];
        assert!(
            (both[p] - expected).abs() < 1e-5,
            "{p}: {} {expected}",
            both[p]
        );
    }
}

#[test]
fn the_median_share_mixes_the_per_pixel_median_of_the_members_into_the_mean() {
    let n = 40;
    let s: Vec<f32> = (0..n).map(|p| 0.3 + p as f32 / 50.0).collect();
    let v: Vec<f32> = (0..n).map(|p| 0.5 + ((p * 7) % 11) as f32 / 20.0).collect();
    let c: Vec<f32> = (0..n).map(|p| 2.0 + ((p * 3) % 7) as f32).collect();
    let log_i = vec![0.0f32; n];
    let members = [(&v[..], 0.4), (&c[..], 0.1)];
    let mean = blend(&s, &members, 0.0, &log_i, None);
    let median = blend(&s, &members, 1.0, &log_i, None);
    let half = blend(&s, &members, 0.5, &log_i, None);
    // Each member on the propagated scale on its own (weight 1, no median): its moved log
    // shading; the median of three is then the middle one, found here by sorting.
    let moved_v = blend(&s, &[(&v, 1.0)], 0.0, &log_i, None);
    let moved_c = blend(&s, &[(&c, 1.0)], 0.0, &log_i, None);
    for p in 0..n {
        let mut three = [s[p].ln(), moved_v[p], moved_c[p]];
        three.sort_by(f32::total_cmp);
        assert!(
            (median[p] - three[1]).abs() < 1e-5,
            "{p}: {} {}",
            median[p],
            three[1]
        );
        let expected = 0.5 * mean[p] + 0.5 * three[1];
        assert!((half[p] - expected).abs() < 1e-5, "{p}");
    }
    // The median differs from the mean somewhere (the members disagree), and a member of
    // weight 0 takes no part in it: the median of the propagated shading alone is itself.
    assert!(mean.iter().zip(&median).any(|(a, b)| (a - b).abs() > 1e-3));
    let alone = blend(&s, &[(&v, 0.0)], 1.0, &log_i, None);
    assert!(alone.iter().zip(&s).all(|(a, s)| (a - s.ln()).abs() < 1e-6));
    // Two values (one member): the median is their mean.
    let two = blend(&s, &[(&v, 0.4)], 1.0, &log_i, None);
    for p in 0..n {
        assert!(
            (two[p] - 0.5 * (s[p].ln() + moved_v[p])).abs() < 1e-5,
            "{p}"
        );
    }
}

#[test]
fn the_blend_keeps_the_product_and_lowers_the_flicker_of_each_single_image_member() {
    // The step on, against the step with one member's weight 1 and no averaging (the single
    // view alone, the clustering method alone, each moved to the video's scale): the product
    // holds on every frame, and averaging along the flow with the propagated shading flickers
    // less than either member alone.
    let (frames, _) = translating(8, 32, 24, 1);
    let on = params();
    let (out, stats, _d) = run(&frames, &on);
    assert_product(&frames, &out);
    assert!(
        stats
            .frames
            .iter()
            .all(|f| f.view_ms > 0.0 && f.fusion_ms > 0.0)
    );
    let view_alone = VideoParams {
        fusion: Some(FusionParams {
            beta: 1.0,
            clustering_weight: 0.0,
            alpha: 1.0,
            median_share: 0.0,
            ..Default::default()
        }),
        ..params()
    };
    let clustering_alone = VideoParams {
        fusion: Some(FusionParams {
            beta: 0.0,
            clustering_weight: 1.0,
            alpha: 1.0,
            median_share: 0.0,
            ..Default::default()
        }),
        ..params()
    };
    let (alone, _, _d2) = run(&frames, &view_alone);
    assert_product(&frames, &alone);
    let (clustering, _, _d4) = run(&frames, &clustering_alone);
    assert_product(&frames, &clustering);
    let fl = |o: &[OwnedFrame]| flicker(&o.iter().map(|o| &o.reflectance).collect::<Vec<_>>(), 1);
    let ours = fl(&out);
    for (name, theirs) in [("view", fl(&alone)), ("clustering", fl(&clustering))] {
        assert!(
            ours < theirs,
            "flicker: blended {ours:.4}, {name} alone {theirs:.4}"
        );
    }
    // Off: the thesis' output, no time spent.
    let (off, stats, _d3) = run(
        &frames,
        &VideoParams {
            fusion: None,
            ..params()
        },
    );
    assert_product(&frames, &off);
    assert!(
        stats
            .frames
            .iter()
            .all(|f| f.view_ms == 0.0 && f.fusion_ms == 0.0)
    );
}

#[test]
fn fusion_parameters_are_checked() {
    for bad in [
        FusionParams {
            beta: 1.5,
            ..Default::default()
        },
        FusionParams {
            alpha: 0.0,
            ..Default::default()
        },
        FusionParams {
            gate: f32::NAN,
            ..Default::default()
        },
        FusionParams {
            median_share: 1.5,
            ..Default::default()
        },
        FusionParams {
            clustering_weight: -0.1,
            ..Default::default()
        },
        FusionParams {
            beta: 0.8,
            clustering_weight: 0.3,
            ..Default::default()
        },
    ] {
        let p = VideoParams {
            fusion: Some(bad),
            ..Default::default()
        };
        assert!(p.validate().is_err());
    }
}

#[test]
fn the_clustering_member_runs_at_most_at_its_working_size() {
    // The cap keeps the aspect and never exceeds the pixel budget; a frame that fits is
    // decomposed as it is.
    assert_eq!(working_size(320, 240, 320 * 240), (320, 240));
    assert_eq!(working_size(800, 600, 320 * 240), (320, 240));
    assert_eq!(working_size(100, 50, 1_000_000), (100, 50));
    for (w, h, max) in [
        (1000u32, 10u32, 100usize),
        (7, 1000, 50),
        (640, 480, 12_345),
        (3, 3, 1),
    ] {
        let (sw, sh) = working_size(w, h, max);
        assert!(
            sw >= 1 && sh >= 1 && sw as usize * sh as usize <= max,
            "{w}x{h} → {sw}x{sh}"
        );
        let (a, b) = (w as f64 / h as f64, sw as f64 / sh as f64);
        assert!(
            sw == 1 || sh == 1 || (a / b - 1.0).abs() < 0.25,
            "{w}x{h} → {sw}x{sh}"
        );
    }
    // Below the cap the member is the clustering method's own shading; above it, a shading of
    // the frame's size that follows the full-size one (the same smooth light and flat albedos).
    let (frames, _) = translating(1, 48, 36, 0);
    let fusion = FusionParams::default();
    let full = clustering_shading(&frames[0], &fusion).unwrap();
    let own = crate::clustering::decompose(&frames[0], None, &fusion.clustering, &mut |_| {})
        .unwrap()
        .decomposition
        .shading
        .into_vec();
    assert_eq!(full, own);
    let capped = clustering_shading(
        &frames[0],
        &FusionParams {
            clustering_max_pixels: 24 * 18,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(capped.len(), full.len());
    let log_ratio: Vec<f32> = capped
        .iter()
        .zip(&full)
        .map(|(c, f)| (c / f).ln())
        .collect();
    let mean = log_ratio.iter().sum::<f32>() / log_ratio.len() as f32;
    let spread = log_ratio.iter().map(|r| (r - mean).abs()).sum::<f32>() / log_ratio.len() as f32;
    assert!(spread < 0.15, "mean |log ratio − mean| {spread}");
    let bad = VideoParams {
        fusion: Some(FusionParams {
            clustering_max_pixels: 0,
            ..Default::default()
        }),
        ..Default::default()
    };
    assert!(bad.validate().is_err());
}
