//! Step 8 (module `fusion`): the blend, the average along the flow, and the step in the method.

use super::super::fusion::{average_along_flow, blend};
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
    let a = blend(&s, &v, &log_i, 0.6, None);
    // The view's own scale does not matter: it is moved to the propagated one.
    let v7: Vec<f32> = v.iter().map(|x| 7.0 * x).collect();
    let b = blend(&s, &v7, &log_i, 0.6, None);
    for (x, y) in a.iter().zip(&b) {
        assert!((x - y).abs() < 1e-5, "{x} {y}");
    }
    // β = 0 is the propagated shading; β = 1 the view's, whose median log ratio to the
    // propagated one is then 0.
    let zero = blend(&s, &v, &log_i, 0.0, None);
    assert!(zero.iter().zip(&s).all(|(z, s)| (z - s.ln()).abs() < 1e-6));
    let one = blend(&s, &v, &log_i, 1.0, None);
    let mut ratio: Vec<f32> = one.iter().zip(&s).map(|(o, s)| o - s.ln()).collect();
    ratio.sort_by(f32::total_cmp);
    assert!(ratio[n / 2].abs() < 1e-6, "median {}", ratio[n / 2]);
    // Kept pixels are the propagated shading.
    let keep: Vec<bool> = (0..n).map(|p| p < 10).collect();
    let kept = blend(&s, &v, &log_i, 0.6, Some(&keep));
    for p in 0..n {
        let expected = if p < 10 { s[p].ln() } else { a[p] };
        assert!((kept[p] - expected).abs() < 1e-6);
    }
}

#[test]
fn the_blend_keeps_the_product_and_lowers_the_flicker_of_the_view_alone() {
    // The step on, against the step with β = 1 and no averaging (the single view alone, moved
    // to the video's scale): the product holds on every frame, and averaging along the flow
    // with the propagated shading flickers less than the view alone.
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
            alpha: 1.0,
            ..Default::default()
        }),
        ..params()
    };
    let (alone, _, _d2) = run(&frames, &view_alone);
    assert_product(&frames, &alone);
    let fl = |o: &[OwnedFrame]| flicker(&o.iter().map(|o| &o.reflectance).collect::<Vec<_>>(), 1);
    let (ours, theirs) = (fl(&out), fl(&alone));
    assert!(
        ours < theirs,
        "flicker: blended {ours:.4}, view alone {theirs:.4}"
    );
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
    ] {
        let p = VideoParams {
            fusion: Some(bad),
            ..Default::default()
        };
        assert!(p.validate().is_err());
    }
}
