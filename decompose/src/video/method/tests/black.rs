//! Black frames — a fade from black, black leader, a cut through black — are ordinary in real
//! footage: they are output black, and the rest of the video is decomposed as without them.

use super::*;

fn black(w: u32, h: u32) -> Image {
    Image::new(w, h, 3)
}

fn is_zero(img: &Image) -> bool {
    img.data().iter().all(|&v| v == 0.0)
}

fn largest_difference(a: &Image, b: &Image) -> f32 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

#[test]
fn black_leader_is_output_black_and_the_rest_as_without_it() {
    let (frames, _) = translating(5, 32, 24, 1);
    let (plain, plain_stats, _d1) = run(&frames, &params());
    let mut led = vec![black(32, 24), black(32, 24)];
    led.extend(frames.iter().cloned());
    let (out, stats, _d2) = run(&led, &params());

    assert_eq!(stats.first_lit_frame, 2);
    assert_eq!(plain_stats.first_lit_frame, 0);
    assert_eq!(out.len(), 7);
    let flags: Vec<bool> = stats.frames.iter().map(|f| f.black).collect();
    assert_eq!(flags, [true, true, false, false, false, false, false]);
    for o in &out[..2] {
        assert!(
            is_zero(&o.reflectance) && is_zero(&o.shading),
            "frame {}",
            o.index
        );
    }
    // The lit frames: the same decomposition as the video without its leader.
    for (o, p) in out[2..].iter().zip(&plain) {
        assert_eq!(o.index, p.index + 2);
        let ds = largest_difference(&o.shading, &p.shading);
        let dr = largest_difference(&o.reflectance, &p.reflectance);
        assert!(
            ds < 1e-5 && dr < 1e-5,
            "frame {}: |ΔS| {ds}, |ΔR| {dr}",
            o.index
        );
    }
    assert_eq!(stats.clusters, plain_stats.clusters);
}

#[test]
fn a_cut_through_black_is_output_black_and_the_video_goes_on() {
    let (mut frames, _) = translating(6, 32, 24, 1);
    frames[3] = black(32, 24);
    let (out, stats, _d) = run(&frames, &params());

    assert_eq!(stats.first_lit_frame, 0);
    let flags: Vec<bool> = stats.frames.iter().map(|f| f.black).collect();
    assert_eq!(flags, [false, false, false, true, false, false]);
    assert!(is_zero(&out[3].reflectance) && is_zero(&out[3].shading));
    for t in [0, 1, 2, 4, 5] {
        assert_product(&frames[t..=t], std::slice::from_ref(&reindexed(&out[t])));
    }
}

/// `frame` as frame 0, for [`assert_product`] on one frame.
fn reindexed(frame: &OwnedFrame) -> OwnedFrame {
    OwnedFrame {
        index: 0,
        ..frame.clone()
    }
}

#[test]
fn an_all_black_video_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let frames = vec![black(16, 12), black(16, 12), black(16, 12)];
    let source = source_of(dir.path(), &frames);
    let mut sink: Vec<OwnedFrame> = Vec::new();
    let err = decompose_video(
        &source,
        &Strokes::default(),
        &params(),
        &dir.path().join("scratch"),
        &mut sink,
        &mut |_| {},
    )
    .unwrap_err();
    assert!(
        matches!(err, Error::AllFramesBlack { frames: 3, .. }),
        "{err}"
    );
    assert!(err.to_string().contains("every frame"), "{err}");
    assert!(sink.is_empty());
}

#[test]
fn strokes_apply_to_the_first_lit_frame() {
    let (lit_frames, _) = translating(2, 24, 16, 1);
    let frames = [vec![black(24, 16)], lit_frames].concat();
    let region = Mask::from_fn(24, 16, |x, y| x < 12 && y < 8);
    let strokes = Strokes {
        constant_shading: vec![region.clone()],
        ..Default::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let source = source_of(dir.path(), &frames);
    let mut out: Vec<OwnedFrame> = Vec::new();
    decompose_video(
        &source,
        &strokes,
        &params(),
        &dir.path().join("scratch"),
        &mut out,
        &mut |_| {},
    )
    .unwrap();
    let spread = |out: &[OwnedFrame]| shading_spread(&out[1], &region);
    let with = spread(&out);
    // Without the stroke, more of the light's fall-off shows there.
    let (out, _, _d) = run(&frames, &params());
    let without = spread(&out);
    assert!(
        with < 0.5 * without,
        "relative spread of the shading under the stroke on frame 1: {with} with, {without} \
         without"
    );
}
