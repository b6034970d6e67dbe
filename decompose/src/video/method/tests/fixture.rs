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

/// Mean LMSE and flicker of one method on the fixture.
#[derive(Clone, Copy, Debug)]
struct Figures {
    lmse: f64,
    flicker: f64,
}

/// Mean LMSE (`crate::metrics::score`, grey, 20×20 windows) and flicker
/// ([`true_flow_flicker`]) on `fixtures/video/tiny` of the method, per-frame Retinex and
/// per-frame clustering (the two baselines of the issue), in that order.
fn fixture_scores() -> [Figures; 3] {
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
    let clustering = crate::video::baseline::PerFrameMethod::clustering();
    let per_frame_clustering: Vec<crate::Decomposition> = frames
        .iter()
        .map(|f| clustering.decompose(f).unwrap().0)
        .collect();
    let mask = Mask::full(truth.size().0, truth.size().1);
    let figures = |layers: Vec<(Image, Image)>| {
        let lmse = (layers.iter().enumerate())
            .map(|(t, (r, s))| {
                let (gr, gs) = (truth.reflectance(t).unwrap(), truth.shading(t).unwrap());
                crate::metrics::score(r, s, &gr, &gs, &mask).unwrap().lmse
            })
            .sum::<f64>()
            / truth.len() as f64;
        let refl: Vec<Image> = layers.into_iter().map(|(r, _)| r).collect();
        Figures {
            lmse,
            flicker: true_flow_flicker(&refl, &truth),
        }
    };
    let layers = |d: Vec<crate::Decomposition>| -> Vec<(Image, Image)> {
        d.into_iter().map(|d| (d.reflectance, d.shading)).collect()
    };
    [
        figures(
            out.into_iter()
                .map(|o| (o.reflectance, o.shading))
                .collect(),
        ),
        figures(layers(per_frame_retinex(&frames))),
        figures(layers(per_frame_clustering)),
    ]
}

/// Measured 2026-12-04: flicker 0.0275 against 0.0902 for per-frame Retinex; 2026-12-05 with
/// the defaults of that day (border levelling, `ε` = 0.3, `β` = 1): 0.0263; with step 8 (the
/// per-frame blend) 0.0149; with the colour ball of radius 90, 0.0153 (per-frame clustering
/// 0.328).
#[test]
fn flicker_is_below_both_per_frame_methods_on_the_rendered_fixture() {
    let [ours, retinex, clustering] = fixture_scores();
    assert!(
        ours.flicker < 0.5 * retinex.flicker.min(clustering.flicker),
        "flicker: ours {:.4}, per-frame Retinex {:.4}, per-frame clustering {:.4}",
        ours.flicker,
        retinex.flicker,
        clustering.flicker
    );
}

/// The goal on the fixture. Measured: 2026-12-04 (the thesis' levels and `ε`, `β`)
/// 0.0802 against 0.0803 for per-frame Retinex (frame 0 is the same decomposition, 0.0764);
/// 2026-12-05 with the border levelling alone 0.0806 (its offsets there are below 0.01), and
/// with the levelling and `ε` = 0.3, `β` = 1 0.0791, with step 8 (the per-frame blend)
/// 0.0699: below Retinex, not below per-frame clustering (0.0652). With the colour ball of
/// radius 90 (seventh session): 0.0581, below both.
#[test]
fn lmse_is_below_both_per_frame_methods_on_the_rendered_fixture() {
    let [ours, retinex, clustering] = fixture_scores();
    assert!(
        ours.lmse < retinex.lmse.min(clustering.lmse),
        "LMSE: ours {:.4}, per-frame Retinex {:.4}, per-frame clustering {:.4}",
        ours.lmse,
        retinex.lmse,
        clustering.lmse
    );
}
