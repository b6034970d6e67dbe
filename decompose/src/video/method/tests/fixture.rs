//! The committed rendered fixture (fixtures/video/tiny) against per-frame Retinex.

use super::*;

fn true_flow_flicker(refl: &[Image], truth: &crate::video::truth::VideoTruth) -> f64 {
    use crate::video::flow::warp;
    use crate::video::truth::known_mask;
    let lum = |img: &Image, i: usize| f64::from(luminance(img.rgb(i)).max(1e-6)).ln();
    let (mut sum, mut n) = (0.0, 0usize);
    for t in 0..refl.len() - 1 {
        let f = truth.flow(t).unwrap();
        let known = known_mask(&f);
        let warped = warp(&refl[t + 1], &f).unwrap();
        for i in (0..known.len()).filter(|&i| known[i]) {
            sum += (lum(&warped, i) - lum(&refl[t], i)).abs();
            n += 1;
        }
    }
    sum / n as f64
}

/// Mean LMSE (`crate::metrics::score`, grey, 20×20 windows) and flicker
/// ([`true_flow_flicker`]) of the method and of per-frame Retinex on `fixtures/video/tiny`:
/// (ours LMSE, per-frame LMSE, ours flicker, per-frame flicker).
fn fixture_scores() -> (f64, f64, f64, f64) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/video/tiny");
    let truth = crate::video::truth::load_truth(&dir).unwrap();
    let scratch = tempfile::tempdir().unwrap();
    let mut out: Vec<OwnedFrame> = Vec::new();
    decompose_video(
        truth.input_frames(),
        &Strokes::default(),
        &VideoParams::default(),
        scratch.path(),
        &mut out,
        &mut |_| {},
    )
    .unwrap();
    let frames: Vec<Image> = (0..truth.len()).map(|t| truth.input(t).unwrap()).collect();
    assert_product(&frames, &out);
    let base = per_frame_retinex(&frames);
    let mask = Mask::full(truth.size().0, truth.size().1);
    let lmse = |r: &Image, s: &Image, t: usize| {
        let (gr, gs) = (truth.reflectance(t).unwrap(), truth.shading(t).unwrap());
        crate::metrics::score(r, s, &gr, &gs, &mask).unwrap().lmse
    };
    let n = truth.len() as f64;
    let ours_lmse = out
        .iter()
        .map(|o| lmse(&o.reflectance, &o.shading, o.index))
        .sum::<f64>()
        / n;
    let base_lmse = (base.iter().enumerate())
        .map(|(t, d)| lmse(&d.reflectance, &d.shading, t))
        .sum::<f64>()
        / n;
    let ours: Vec<Image> = out.into_iter().map(|o| o.reflectance).collect();
    let theirs: Vec<Image> = base.into_iter().map(|d| d.reflectance).collect();
    (
        ours_lmse,
        base_lmse,
        true_flow_flicker(&ours, &truth),
        true_flow_flicker(&theirs, &truth),
    )
}

/// Measured 2026-12-04: flicker 0.0275 against 0.0902 for per-frame Retinex; 2026-12-05 with
/// the defaults of that day (border levelling, `ε` = 0.3, `β` = 1): 0.0263; with step 8 (the
/// per-frame blend) 0.0149.
#[test]
fn flicker_is_below_per_frame_retinex_on_the_rendered_fixture() {
    let (_, _, ours, theirs) = fixture_scores();
    assert!(
        ours < 0.5 * theirs,
        "flicker: ours {ours:.4}, per-frame Retinex {theirs:.4}"
    );
}

/// The goal on the fixture. Measured: 2026-12-04 (the thesis' levels and `ε`, `β`)
/// 0.0802 against 0.0803 for per-frame Retinex (frame 0 is the same decomposition, 0.0764);
/// 2026-12-05 with the border levelling alone 0.0806 (its offsets there are below 0.01), and
/// with the levelling and `ε` = 0.3, `β` = 1 0.0791, with step 8 (the per-frame blend) 0.0699.
#[test]
fn lmse_is_below_per_frame_retinex_on_the_rendered_fixture() {
    let (ours, theirs, _, _) = fixture_scores();
    assert!(
        ours < theirs,
        "LMSE: ours {ours:.4}, per-frame Retinex {theirs:.4}"
    );
}
