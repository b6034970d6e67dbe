use super::*;
use crate::synthetic;
use crate::video::truth::UNKNOWN_FLOW;

/// A colour reflectance whose grey value is `g(x, y)` (channels 0.8 g, g, 1.2 g).
fn colour(w: u32, h: u32, g: impl Fn(f64, f64) -> f64) -> Image {
    Image::from_fn(w, h, |x, y| {
        let v = g(x as f64, y as f64) as f32;
        [0.8 * v, v, 1.2 * v]
    })
}

#[test]
fn reflectance_moving_exactly_with_an_integer_flow_does_not_flicker() {
    let (w, h) = (40u32, 30u32);
    let tex = synthetic::wave_texture(3, 6, 4.0..12.0, 2.0);
    // R_t(x, y) = f(x − 2t, y − t): the content moves by (2, 1) per frame.
    let frame = |t: f64| colour(w, h, |x, y| 0.05 + tex(x - 2.0 * t, y - t));
    let flow = Flow::from_fn(w, h, |_, _| [2.0, 1.0]);
    let f = pair_flicker(&log_grey(&frame(0.0)), &log_grey(&frame(1.0)), &flow).unwrap();
    assert!(f.mean < 1e-6, "{}", f.mean);
    // Valid: the warped position is inside, x + 2 ≤ w − 1 and y + 1 ≤ h − 1.
    assert_eq!(f.pixels, (w as usize - 2) * (h as usize - 1));
    // The same frames compared without the flow do flicker.
    let still = pair_flicker(
        &log_grey(&frame(0.0)),
        &log_grey(&frame(1.0)),
        &Flow::zeros(w, h),
    )
    .unwrap();
    assert!(still.mean > 0.05, "{}", still.mean);
}

#[test]
fn sub_pixel_motion_of_an_exponential_ramp_is_exact_in_the_log_domain() {
    // ln R is linear in x and y, so bilinear sampling of the log image is exact.
    let (w, h) = (24u32, 16u32);
    let frame = |t: f64| {
        colour(w, h, |x, y| {
            (0.03 * (x - 0.5 * t) + 0.02 * (y - 0.25 * t)).exp()
        })
    };
    let flow = Flow::from_fn(w, h, |_, _| [0.5, 0.25]);
    let f = pair_flicker(&log_grey(&frame(0.0)), &log_grey(&frame(1.0)), &flow).unwrap();
    assert!(f.mean < 1e-6, "{}", f.mean);
    assert_eq!(f.pixels, (w as usize - 1) * (h as usize - 1));
}

#[test]
fn brightness_change_per_frame_gives_the_hand_computed_flicker() {
    let (w, h) = (10u32, 8u32);
    let base = colour(w, h, |x, y| 0.2 + 0.05 * x + 0.03 * y);
    let scales = [1.0f32, 1.5, 1.2];
    let mut scorer = SequenceScorer::new();
    let zero = Flow::zeros(w, h);
    for (t, k) in scales.iter().enumerate() {
        let r = base.map(|v| v * k);
        let s = Image::new(w, h, 1);
        scorer.push(&r, &s, None, (t > 0).then_some(&zero)).unwrap();
    }
    let s = scorer.finish();
    // |ln 1.5| and |ln(1.2/1.5)|, every pixel valid.
    let pairs = [1.5f64.ln(), (1.2f64 / 1.5).ln().abs()];
    for (got, want) in s.flicker_pairs.iter().zip(pairs) {
        assert!((got.unwrap() - want).abs() < 1e-6, "{got:?} vs {want}");
    }
    assert!((s.flicker - 0.5 * (pairs[0] + pairs[1])).abs() < 1e-6);
    assert_eq!(s.flicker_pixels, 2 * (w * h) as usize);
    assert!(s.lmse.is_nan() && s.lmse_frames.is_empty());
}

#[test]
fn unknown_flow_and_positions_outside_the_frame_are_left_out() {
    let (w, h) = (12u32, 6u32);
    let prev = colour(w, h, |_, _| 0.5);
    // The right half changes brightness, but its flow is unknown; one column flows outside.
    let next = colour(w, h, |x, _| if x >= 6.0 { 0.9 } else { 0.5 });
    let flow = Flow::from_fn(w, h, |x, _| match x {
        0 => [-1.0, 0.0],
        x if x >= 6 => [UNKNOWN_FLOW, UNKNOWN_FLOW],
        _ => [0.0, 0.0],
    });
    let f = pair_flicker(&log_grey(&prev), &log_grey(&next), &flow).unwrap();
    assert_eq!(f.pixels, 5 * h as usize);
    assert_eq!(f.mean, 0.0);
    // A flow that is unknown everywhere gives a pair without a value.
    let unknown = Flow::from_fn(w, h, |_, _| [UNKNOWN_FLOW, UNKNOWN_FLOW]);
    let mut scorer = SequenceScorer::new();
    scorer.push(&prev, &prev, None, None).unwrap();
    scorer.push(&next, &next, None, Some(&unknown)).unwrap();
    let s = scorer.finish();
    assert_eq!(s.flicker_pairs, vec![None]);
    assert!(s.flicker.is_nan());
}

#[test]
fn black_and_nan_reflectance_are_floored() {
    let img = Image::from_vec(2, 1, 3, vec![0.0, 0.0, 0.0, f32::NAN, 1.0, 1.0]).unwrap();
    let l = log_grey(&img);
    assert_eq!(l.data(), &[LOG_FLOOR.ln(), LOG_FLOOR.ln()]);
}

#[test]
fn frame_lmse_is_the_lmse_of_decompose_eval() {
    let g = synthetic::scene(48, 40, 2);
    // An estimate that is off: the reflectance with a ramp, the shading compensating.
    let est_r = Image::from_fn(48, 40, |x, y| {
        let p = g.reflectance.get(x, y);
        let k = 1.0 + 0.01 * x as f32;
        [p[0] * k, p[1] * k, p[2] * k]
    });
    let est_s = Image::from_fn(48, 40, |x, y| {
        [g.shading.get(x, y)[0] / (1.0 + 0.01 * x as f32)]
    });
    let full = Mask::full(48, 40);
    let want = metrics::score(&est_r, &est_s, &g.reflectance, &g.shading, &full)
        .unwrap()
        .lmse;
    let got = frame_lmse(&est_r, &est_s, &g.reflectance, &g.shading).unwrap();
    assert_eq!(got, want);
    assert!(got > 1e-4);
    // The truth up to one scale scores 0.
    let exact = frame_lmse(
        &g.reflectance.map(|v| 2.0 * v),
        &g.shading.map(|v| 0.5 * v),
        &g.reflectance,
        &g.shading,
    )
    .unwrap();
    assert!(exact < 1e-9, "{exact}");
}

#[test]
fn scorer_needs_the_flow_after_the_first_frame_and_matching_sizes() {
    let r = colour(8, 8, |_, _| 0.5);
    let s = Image::new(8, 8, 1);
    let mut scorer = SequenceScorer::new();
    scorer.push(&r, &s, None, None).unwrap();
    assert!(matches!(
        scorer.push(&r, &s, None, None),
        Err(Error::InvalidParam { .. })
    ));
    let small = Flow::zeros(4, 4);
    assert!(matches!(
        scorer.push(&r, &s, None, Some(&small)),
        Err(Error::ShapeMismatch { .. })
    ));
}

#[test]
fn pairs_with_a_black_frame_are_left_out() {
    let (w, h) = (6u32, 4u32);
    let lit = Image::from_fn::<3>(w, h, |x, _| [0.2 + 0.1 * x as f32; 3]);
    let brighter = lit.map(|v| 2.0 * v);
    let black = Image::new(w, h, 3);
    let still = Flow::zeros(w, h);
    let mut scorer = SequenceScorer::new();
    for r in [&lit, &black, &lit, &brighter] {
        let t = scorer.frames();
        scorer.push(r, r, None, (t > 0).then_some(&still)).unwrap();
    }
    let s = scorer.finish();
    // lit → black and black → lit have nothing to compare; lit → brighter is ln 2.
    assert_eq!(s.flicker_pairs.len(), 3);
    assert_eq!(&s.flicker_pairs[..2], &[None, None]);
    assert!((s.flicker_pairs[2].unwrap() - 2f64.ln()).abs() < 1e-5);
    assert!((s.flicker - 2f64.ln()).abs() < 1e-5);
    assert_eq!(s.flicker_pixels, (w * h) as usize);
}
