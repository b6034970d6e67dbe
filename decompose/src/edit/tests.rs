use super::*;

fn two_tone() -> Decomposition {
    let reflectance = Image::from_fn(8, 4, |x, _| {
        if x < 4 {
            [0.8f32, 0.2, 0.2]
        } else {
            [0.2, 0.2, 0.8]
        }
    });
    let shading = Image::from_fn(8, 4, |x, _| [0.3 + 0.05 * x as f32]);
    Decomposition {
        reflectance,
        shading,
    }
}

#[test]
fn recolour_changes_hue_keeps_shading() {
    let d = two_tone();
    let mask = Mask::from_fn(8, 4, |x, _| x < 4);
    let out = recolour(&d, Some(&mask), 120.0, 1.0).unwrap();
    // Red becomes green inside the mask, blue stays blue outside.
    let p = out.get(0, 0);
    assert!(p[1] > p[0] && p[1] > p[2], "{p:?}");
    let q = out.get(6, 0);
    assert!((q[2] - 0.8 * (0.3 + 0.3)).abs() < 1e-5);
    // Luminance pattern (shading) is kept: value channel × shading.
    assert!((p[1] - 0.8 * 0.3).abs() < 1e-5);
}

#[test]
fn retexture_keeps_shading() {
    let d = two_tone();
    let tex = Image::from_fn(2, 2, |x, y| [(x + y) as f32 * 0.3, 0.5, 0.5]);
    let mask = Mask::from_fn(8, 4, |x, _| x >= 4);
    let out = retexture(&d, &mask, &tex).unwrap();
    let s = d.shading.get(5, 1)[0];
    assert!((out.get(5, 1)[0] - tex.get(1, 1)[0] * s).abs() < 1e-6);
    assert_eq!(out.get(0, 0), &[0.8 * 0.3, 0.2 * 0.3, 0.2 * 0.3][..]);
    assert!(retexture(&d, &Mask::full(2, 2), &tex).is_err());
}

#[test]
fn curve_interpolates_and_stays_monotone() {
    let c = Curve::new(&[(0.0, 0.0), (0.5, 0.8), (1.0, 1.0)]).unwrap();
    assert!((c.eval(0.5) - 0.8).abs() < 1e-6);
    let mut prev = -1.0;
    for i in 0..=100 {
        let v = c.eval(i as f32 / 100.0);
        assert!(v >= prev - 1e-6);
        prev = v;
    }
    assert!(Curve::new(&[(0.0, 0.0)]).is_err());
    assert!(Curve::new(&[(0.5, 0.0), (0.5, 1.0)]).is_err());
}

#[test]
fn relight_identity_curve_is_identity() {
    let d = two_tone();
    let c = Curve::new(&[(0.0, 0.0), (1.0, 1.0)]).unwrap();
    let out = relight(&d, &c);
    let orig = d.reconstruct();
    for (a, b) in out.data().iter().zip(orig.data()) {
        assert!((a - b).abs() < 1e-5);
    }
}

#[test]
fn transfer_takes_source_palette() {
    let d = two_tone();
    let src = Image::from_fn(4, 4, |_, _| [0.1f32, 0.9, 0.1]);
    let out = transfer(&d, &src).unwrap();
    let s = d.shading.get(2, 2)[0];
    assert!((out.get(2, 2)[1] - 0.9 * s).abs() < 1e-6);
}

#[test]
fn stylise_draws_edge_and_flattens() {
    let d = two_tone();
    let out = stylise(&d, &StyliseParams::default()).unwrap();
    // The pixel left of the colour border is darkened by the edge layer.
    let edge = out.get(3, 1)[0];
    let inner = out.get(1, 1)[0];
    assert!(edge < inner * 0.5, "{edge} {inner}");
    let bad = StyliseParams {
        flatten: 2.0,
        ..Default::default()
    };
    assert!(stylise(&d, &bad).is_err());
}

#[test]
fn segment_splits_two_reflectances() {
    let d = two_tone();
    let l = segment(&d.reflectance, None, 2, 0).unwrap();
    assert_ne!(l.data[0], l.data[7]);
    assert_eq!(l.data[0], l.data[3]);
}
