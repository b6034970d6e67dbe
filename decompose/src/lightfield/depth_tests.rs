use std::path::{Path, PathBuf};

use super::*;
use crate::io::{LoadOptions, load_rgb};
use crate::lightfield::disparity::{corresponding, warp_to};

/// A smooth texture on a plane: sums of sines with periods of 9 to 31 pixels, so that the views
/// can be sampled exactly at any sub-pixel position.
fn texture(x: f32, y: f32, k: usize) -> f32 {
    let t = k as f32;
    0.5 + 0.15 * (0.7 * x + 0.3 * y + t).sin()
        + 0.1 * (0.23 * x - 0.41 * y + 2.0 * t).sin()
        + 0.1 * (0.5 * y + 0.11 * x + 0.5 * t).cos()
        + 0.05 * (0.2 * x * (1.0 + 0.1 * t)).sin()
}

/// A `n×n` light field of `size²` RGB views whose pixel `(x, y)` in view `(r, c)` shows
/// `scene(cx, cy)` where `(cx, cy)` is that pixel's centre-view position at disparity
/// `disparity(cx, cy)`, found by [`corresponding`] from a guess and refined (fixed point).
fn light_field(
    n: usize,
    size: u32,
    scene: impl Fn(f32, f32, usize) -> f32 + Sync,
    disparity_at_view: impl Fn(f32, f32, (usize, usize)) -> f32 + Sync,
) -> LightField {
    let c0 = n / 2;
    let views: Vec<Image> = (0..n * n)
        .map(|i| {
            let (r, c) = (i / n, i % n);
            Image::from_fn(size, size, |x, y| {
                let d = disparity_at_view(x as f32, y as f32, (r, c));
                let (cx, cy) = corresponding(x as f32, y as f32, d, (r, c), (c0, c0));
                [scene(cx, cy, 0), scene(cx, cy, 1), scene(cx, cy, 2)]
            })
        })
        .collect();
    LightField::from_views(n, n, &views).unwrap()
}

fn mean_abs_error(
    est: &Image,
    truth: impl Fn(u32, u32) -> f32,
    keep: impl Fn(u32, u32) -> bool,
) -> f32 {
    let (w, h) = est.dims();
    let (mut sum, mut count) = (0.0f64, 0usize);
    for y in 0..h {
        for x in 0..w {
            if keep(x, y) {
                sum += (est.get(x, y)[0] - truth(x, y)).abs() as f64;
                count += 1;
            }
        }
    }
    assert!(count > 0);
    (sum / count as f64) as f32
}

#[test]
fn fronto_parallel_plane_disparity_is_recovered() {
    for d in [0.6f32, -1.1, 0.0] {
        let lf = light_field(9, 40, texture, |_, _, _| d);
        let (est, coherence) = epi_disparity(&lf, &EpiParams::default()).unwrap();
        // The outer kernel (radius 4) and the inner one (radius 2) see the image border within
        // 6 pixels; the interior is what the method is about.
        let interior = |x: u32, y: u32| (6..34).contains(&x) && (6..34).contains(&y);
        let mae = mean_abs_error(&est, |_, _| d, interior);
        assert!(mae < 0.05, "d = {d}: mean abs error {mae}");
        let coh = mean_abs_error(&coherence, |_, _| 0.0, interior);
        assert!(coh > 0.9, "d = {d}: mean coherence {coh}");
    }
}

#[test]
fn two_planes_with_an_occlusion_boundary() {
    // A far plane (d = −0.5) behind a near square (d = +1.0) covering centre-view x, y in
    // [14, 30): the front surface is tested in every view first.
    let (far, near) = (-0.5f32, 1.0f32);
    let in_square = |cx: f32, cy: f32| (14.0..30.0).contains(&cx) && (14.0..30.0).contains(&cy);
    let lf = light_field(9, 44, texture, |x, y, view| {
        let (cx, cy) = corresponding(x, y, near, view, (4, 4));
        if in_square(cx, cy) { near } else { far }
    });
    let (est, _) = epi_disparity(&lf, &EpiParams::default()).unwrap();
    let truth = |x: u32, y: u32| {
        if in_square(x as f32, y as f32) {
            near
        } else {
            far
        }
    };
    // Away from the boundary: more than 5 pixels (outer + inner kernel radius) from the square's
    // edge in the centre view and 6 from the image border.
    let away = |x: u32, y: u32| {
        let (x, y) = (x as f32 + 0.5, y as f32 + 0.5);
        let inside = (14.0..30.0).contains(&x) && (14.0..30.0).contains(&y);
        let dist = if inside {
            (x - 14.0).min(30.0 - x).min(y - 14.0).min(30.0 - y)
        } else {
            let dx = (14.0 - x).max(x - 30.0).max(0.0);
            let dy = (14.0 - y).max(y - 30.0).max(0.0);
            dx.max(dy)
        };
        dist > 5.0 && (6.0..38.0).contains(&x) && (6.0..38.0).contains(&y)
    };
    let mae = mean_abs_error(&est, truth, away);
    assert!(mae < 0.05, "mean abs error away from the boundary {mae}");
    // On the square's interior alone (the near plane), also accurate.
    let mae_near = mean_abs_error(&est, truth, |x, y| {
        away(x, y) && in_square(x as f32, y as f32)
    });
    assert!(mae_near < 0.05, "near plane: {mae_near}");
}

#[test]
fn bad_params_and_grids_are_refused() {
    let lf = light_field(3, 8, texture, |_, _, _| 0.0);
    let bad = EpiParams {
        inner_scale: 0.0,
        ..EpiParams::default()
    };
    assert!(epi_disparity(&lf, &bad).is_err());
    assert!(epi_disparity_view(&lf, (3, 0), &EpiParams::default()).is_err());
    let views: Vec<Image> = (0..4).map(|_| Image::new(8, 8, 3)).collect();
    let small = LightField::from_views(2, 2, &views).unwrap();
    assert!(epi_disparity(&small, &EpiParams::default()).is_err());
    // A single grid row still works (horizontal EPIs only).
    let row: Vec<Image> = lf.to_views()[3..6].to_vec();
    let one_row = LightField::from_views(1, 3, &row).unwrap();
    assert!(epi_disparity(&one_row, &EpiParams::default()).is_ok());
}

// ---- the committed rendered fixture (scripts/render_lightfields.py --tiny) ----

/// Width and height of the fixture's views.
const S: u32 = 48;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/lightfield/tiny")
}

fn read_pfm(path: &Path) -> Image {
    crate::lightfield::io::pfm::read(path).unwrap()
}

fn load_fixture(sub: &str, linear: bool) -> LightField {
    let views: Vec<Image> = (0..25)
        .map(|i| {
            let opts = LoadOptions {
                linear,
                ..LoadOptions::default()
            };
            load_rgb(
                fixture().join(sub).join(format!("input_Cam{i:03}.png")),
                opts,
            )
            .unwrap()
        })
        .collect();
    LightField::from_views(5, 5, &views).unwrap()
}

#[test]
fn the_convention_matches_the_rendered_fixture() {
    // Warp every view to the centre through the true centre disparity scaled by a factor: with
    // the right convention the photometric error is smallest at factor 1, and far larger with
    // the signs flipped (factor −1). Pixels whose point is hidden in the source view (its own
    // disparity at the landing point differs) or that land outside it are skipped.
    let lf = load_fixture("truth/input", true);
    let disp = read_pfm(&fixture().join("gt_disp_lowres.pfm"));
    let centre = lf.view(lf.view_index(2, 2));
    let factors = [-1.0f32, 0.0, 0.8, 1.0, 1.2];
    let mut errors = [0.0f64; 5];
    let mut count = 0usize;
    for i in 0..25 {
        let from = (i / 5, i % 5);
        if from == (2, 2) {
            continue;
        }
        let own = read_pfm(&fixture().join(format!("truth/disparity/input_Cam{i:03}.pfm")));
        let warped: Vec<(Image, Image)> = factors
            .iter()
            .map(|f| warp_to(&lf, from, (2, 2), &disp.map(|d| d * f)).unwrap())
            .collect();
        for y in 0..S {
            for x in 0..S {
                let d = disp.get(x, y)[0];
                let (sx, sy) = corresponding(x as f32, y as f32, d, (2, 2), from);
                let j = (y * S + x) as usize;
                if warped[3].1.px(j)[0] == 0.0 {
                    continue;
                }
                let mut seen = [0.0f32];
                crate::lightfield::disparity::sample_bilinear(&own, sx, sy, &mut seen);
                if (seen[0] - d).abs() > 0.05 {
                    continue; // occluded in `from`, or at a depth edge
                }
                for k in 0..3 {
                    let c = centre.px(j)[k] as f64;
                    for (e, (w, _)) in errors.iter_mut().zip(&warped) {
                        *e += (w.px(j)[k] as f64 - c).abs();
                    }
                }
                count += 3;
            }
        }
    }
    let errors = errors.map(|e| e / count as f64);
    eprintln!(
        "warp to centre, mean abs error at disparity × {factors:?}: {errors:.5?} ({count} samples)"
    );
    // 24 views, 3 channels: at least half of all samples must be usable.
    assert!(
        count > 24 * 3 * (S * S) as usize / 2,
        "too few unoccluded samples: {count}"
    );
    let right = errors[3];
    for (f, e) in factors.iter().zip(errors) {
        if *f != 1.0 {
            assert!(right < e, "factor {f} fits better: {e} vs {right}");
        }
    }
    // The floor at factor 1 is bilinear interpolation of 48-pixel views whose textures alias
    // (0.0071 measured, the image mean being about 0.1); flipping the signs gives 0.035.
    assert!(
        right < errors[0] / 3.0,
        "flipped signs: {} vs {right}",
        errors[0]
    );
}

#[test]
fn epi_disparity_on_the_rendered_fixture() {
    // Read through the crate's HCI folder reader: the fixture's layout must be what it expects.
    let folder =
        crate::lightfield::io::load_folder(&fixture(), None, LoadOptions::default()).unwrap();
    let params = folder.parameters.as_ref().unwrap();
    assert_eq!((params.num_cams_x, params.num_cams_y), (5, 5));
    assert_eq!(params.resolution, Some((S, S)));
    let lf = folder.field;
    assert_eq!(lf, load_fixture("", false));
    let truth = folder.disparity.unwrap();
    let (est, coherence) = epi_disparity(&lf, &EpiParams::default()).unwrap();
    // Textured pixels: centre-view luminance gradient above 0.01 per pixel and coherence above
    // 0.5, 5 pixels from the image border.
    let centre = lf.view(lf.view_index(2, 2));
    let lum = |x: u32, y: u32| {
        let p = centre.get(x, y);
        (p[0] + p[1] + p[2]) / 3.0
    };
    let mut errors = Vec::new();
    let mut all = Vec::new();
    for y in 5..S - 5 {
        for x in 5..S - 5 {
            let e = (est.get(x, y)[0] - truth.get(x, y)[0]).abs();
            all.push(e);
            let gx = lum(x + 1, y) - lum(x - 1, y);
            let gy = lum(x, y + 1) - lum(x, y - 1);
            if (gx * gx + gy * gy).sqrt() / 2.0 > 0.01 && coherence.get(x, y)[0] > 0.5 {
                errors.push(e);
            }
        }
    }
    let median = |v: &mut Vec<f32>| {
        v.sort_by(|a, b| a.total_cmp(b));
        v[v.len() / 2]
    };
    let textured = errors.len();
    let (m_tex, m_all) = (median(&mut errors), median(&mut all));
    eprintln!(
        "fixture EPI disparity: median abs error {m_tex:.4} px on {textured} textured pixels, {m_all:.4} on all"
    );
    assert!(textured > 500, "only {textured} textured pixels");
    // Measured 0.088 px (0.12 on all pixels). The views are 48 pixels wide, so the printed
    // textures reach 1–3 pixel periods and alias across the 5 views while most of the back wall
    // sits at −1.4 px/view; on alias-free synthetic planes the error is below 0.05 (tests
    // above). 0.12 still fails on a sign or scale error (errors of 1–3 px).
    assert!(m_tex < 0.12, "median abs error on textured pixels {m_tex}");
}
