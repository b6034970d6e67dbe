//! Tests of the stroke features, with a brute-force reference SWT.

use super::*;
use image::{Rgb, RgbImage};
use std::collections::HashSet;

/// A 400x400 canvas whose grey level at `(x, y)` is `f(x, y)`.
fn canvas(f: impl Fn(i32, i32) -> u8) -> RgbImage {
    RgbImage::from_fn(400, 400, |x, y| Rgb([f(x as i32, y as i32); 3]))
}

fn prepared(f: impl Fn(i32, i32) -> u8) -> Prepared {
    Prepared::new(canvas(f)).expect("non-blank canvas")
}

/// Per-scale, per-kind statistics of the fast path.
fn fast_stats(p: &Prepared) -> [[WidthStats; 2]; SCALES] {
    let mut ws = Workspace::default();
    let mut out = [[WidthStats::default(); 2]; SCALES];
    for_each_scale(p, |s, input| out[s] = ws.measure(input));
    out
}

fn features(p: &Prepared) -> [f64; COUNT] {
    let mut out = [f64::NAN; COUNT];
    compute(p, &mut out);
    out
}

/// A vertical black bar `w` px wide centred on x = 200, rows `top..bottom`.
fn bar(w: i32, top: i32, bottom: i32) -> impl Fn(i32, i32) -> u8 {
    let left = 200 - w / 2;
    move |x, y| {
        if (left..left + w).contains(&x) && (top..bottom).contains(&y) {
            0
        } else {
            255
        }
    }
}

fn dist(x: i32, y: i32) -> f64 {
    ((x as f64 - 200.0).powi(2) + (y as f64 - 200.0).powi(2)).sqrt()
}

/// A black ring of line width 8 and outer radius 120, optionally with a black bar 4 px wide and
/// 100 px tall in its hole.
fn ring(with_bar: bool) -> impl Fn(i32, i32) -> u8 {
    move |x, y| {
        let d = dist(x, y);
        let in_bar = with_bar && (198..202).contains(&x) && (150..250).contains(&y);
        if (112.0..120.0).contains(&d) || in_bar {
            0
        } else {
            255
        }
    }
}

fn bicycle() -> Prepared {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/style/emojione-monotone/bicycle.svg"
    );
    let svg = std::fs::read(path).expect("fixture");
    Prepared::new(crate::render::render_svg(&svg).expect("renders")).expect("not blank")
}

#[test]
fn catalogue_names_are_unique_prefixed_and_documented() {
    let cat = catalogue();
    assert_eq!(cat.len(), COUNT);
    let names: HashSet<_> = cat.iter().map(|f| f.name).collect();
    assert_eq!(names.len(), COUNT);
    for f in &cat {
        assert!(f.name.starts_with("stroke_"), "{}", f.name);
        assert_eq!(f.family, Family::Stroke);
        assert!(
            f.doc.contains("§5.3") && f.doc.contains("Epshtein"),
            "{}",
            f.doc
        );
    }
    assert_eq!(cat[0].name, "stroke_outer_width_mean_1x");
    assert_eq!(cat[14].name, "stroke_inner_width_std_0_25x");
}

#[test]
fn compute_writes_catalogue_order() {
    let p = prepared(ring(true));
    let stats = fast_stats(&p);
    let f = features(&p);
    for s in 0..SCALES {
        assert_eq!(f[s], stats[s][OUTER].mean);
        assert_eq!(f[SCALES + s], stats[s][OUTER].std);
        assert_eq!(f[2 * SCALES + s], stats[s][INNER].mean);
        assert_eq!(f[3 * SCALES + s], stats[s][INNER].std);
    }
    assert!(f.iter().all(|v| v.is_finite()));
}

#[test]
fn bar_width_is_measured_at_full_and_half_scale() {
    for w in [6, 12] {
        let stats = fast_stats(&prepared(bar(w, 50, 350)));
        let (full, half) = (stats[0][OUTER], stats[1][OUTER]);
        assert!((full.mean - w as f64).abs() < 1.0, "w={w} 1x: {full:?}");
        assert!((half.mean - w as f64).abs() < 1.0, "w={w} 0.5x: {half:?}");
        assert!(full.pixels >= (w as usize) * 280, "w={w}: {full:?}");
        // Every edge of a lone bar is on the contour.
        for (s, per_kind) in stats.iter().enumerate() {
            assert_eq!(per_kind[INNER], WidthStats::default(), "w={w} scale {s}");
        }
    }
}

#[test]
fn wide_bar_is_measured_at_every_scale() {
    let stats = fast_stats(&prepared(bar(48, 40, 360)));
    for (s, per_kind) in stats.iter().enumerate() {
        let o = per_kind[OUTER];
        assert!((o.mean - 48.0).abs() < 2.0, "scale {s}: {o:?}");
    }
}

#[test]
fn full_height_bar_has_uniform_width() {
    let stats = fast_stats(&prepared(bar(10, 0, 400)));
    let o = stats[0][OUTER];
    assert!((o.mean - 10.0).abs() < 0.5, "{o:?}");
    assert!(o.std < 0.25, "{o:?}");
}

#[test]
fn ring_is_outer_and_a_bar_in_its_hole_is_inner() {
    let ring_only = fast_stats(&prepared(ring(false)));
    let o = ring_only[0][OUTER];
    assert!((o.mean - 8.0).abs() < 1.0, "{o:?}");
    assert!(o.std < 1.0, "{o:?}");
    // Rays cast outward from the ring's inner edge end on the contour: outer, not inner.
    assert_eq!(ring_only[0][INNER], WidthStats::default());

    let with_bar = fast_stats(&prepared(ring(true)));
    let i = with_bar[0][INNER];
    assert!((i.mean - 4.0).abs() < 1.0, "{i:?}");
    // The bar adds nothing to the outer statistics.
    assert_eq!(with_bar[0][OUTER], o);
}

#[test]
fn stroke_inside_a_filled_shape_is_inner() {
    let p = prepared(|x, y| {
        if (198..203).contains(&x) && (120..280).contains(&y) {
            0
        } else if dist(x, y) < 150.0 {
            180
        } else {
            255
        }
    });
    let stats = fast_stats(&p);
    let (o, i) = (stats[0][OUTER], stats[0][INNER]);
    assert!((i.mean - 5.0).abs() < 1.0, "{i:?}");
    // Outer rays cross the grey disc: chords, far wider than the bar.
    assert!(o.mean > 40.0, "{o:?}");
}

#[test]
fn filled_shape_has_no_inner_widths() {
    let p = prepared(|x, y| if dist(x, y) < 100.0 { 40 } else { 255 });
    let f = features(&p);
    assert!(f.iter().all(|v| v.is_finite()));
    assert!(f[2 * SCALES..].iter().all(|&v| v == 0.0), "{f:?}");
    assert!(f[0] > 50.0, "{f:?}");
}

#[test]
fn same_input_same_output() {
    let p = bicycle();
    let a = features(&p);
    let b = features(&p);
    assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
    assert!(a.iter().all(|v| v.is_finite()));
    assert!(a[0] > 0.0, "{a:?}");
}

#[test]
fn degenerate_drawings_do_not_panic() {
    let cases: Vec<Box<dyn Fn(i32, i32) -> u8>> = vec![
        Box::new(|x, y| if (x, y) == (0, 0) { 0 } else { 255 }),
        Box::new(|x, y| if (x, y) == (200, 200) { 0 } else { 255 }),
        Box::new(|x, y| if (x, y) == (399, 399) { 0 } else { 255 }),
        Box::new(|_, _| 0),
        Box::new(|x, _| if x < 3 { 0 } else { 255 }),
        Box::new(|x, y| if (x / 3 + y / 3) % 2 == 0 { 0 } else { 255 }),
        Box::new(|x, y| {
            let h = (x as u32).wrapping_mul(2_654_435_761) ^ (y as u32).wrapping_mul(40_503);
            (h.wrapping_mul(2_246_822_519) >> 24) as u8
        }),
    ];
    for (n, f) in cases.into_iter().enumerate() {
        let v = features(&prepared(f));
        assert!(
            v.iter().all(|x| x.is_finite() && *x >= 0.0),
            "case {n}: {v:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Brute-force reference: every ray's cell sequence from its sorted boundary crossings, f64
// arithmetic, full-image maps and statistics by scanning every pixel.

/// Reference per-kind `(mean, std, pixels, rays)` of one scale, in canvas pixels.
fn reference(input: &ScaleInput) -> [(f64, f64, usize, usize); 2] {
    let (w, h) = (input.width as i64, input.height as i64);
    let idx = |x: i64, y: i64| (y * w + x) as usize;
    let grad = |i: usize| (input.dx[i] as f64, input.dy[i] as f64);
    let mag = |x: i64, y: i64| {
        let (gx, gy) = grad(idx(x.clamp(0, w - 1), y.clamp(0, h - 1)));
        (gx * gx + gy * gy).sqrt()
    };
    let mag_at = |x: f64, y: f64| {
        let x = x.clamp(0.0, (w - 1) as f64);
        let y = y.clamp(0.0, (h - 1) as f64);
        let (x0, y0) = (x.floor() as i64, y.floor() as i64);
        let (fx, fy) = (x - x0 as f64, y - y0 as f64);
        (1.0 - fy) * ((1.0 - fx) * mag(x0, y0) + fx * mag(x0 + 1, y0))
            + fy * ((1.0 - fx) * mag(x0, y0 + 1) + fx * mag(x0 + 1, y0 + 1))
    };
    let refine = |x: i64, y: i64| {
        let (gx, gy) = grad(idx(x, y));
        let m = (gx * gx + gy * gy).sqrt();
        let (nx, ny) = (gx / m, gy / m);
        let (x, y) = (x as f64, y as f64);
        let (a, b, c) = (mag_at(x - nx, y - ny), m, mag_at(x + nx, y + ny));
        let denom = a - 2.0 * b + c;
        let s = if denom < 0.0 {
            ((a - c) / (2.0 * denom)).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        (x + s * nx, y + s * ny)
    };
    let sil = |x: i64, y: i64| x >= 0 && y >= 0 && x < w && y < h && input.silhouette[idx(x, y)];
    let on_contour = |x: i64, y: i64| {
        let near: Vec<bool> = (-2..=2i64)
            .flat_map(|oy| (-2..=2i64).map(move |ox| (ox, oy)))
            .filter(|(ox, oy)| ox * ox + oy * oy <= 4)
            .map(|(ox, oy)| sil(x + ox, y + oy))
            .collect();
        near.contains(&true) && near.contains(&false)
    };
    let cos_limit = (std::f64::consts::PI / 6.0).cos();

    let mut rays: Vec<(usize, Vec<usize>, f64)> = Vec::new();
    for y0 in 0..h {
        for x0 in 0..w {
            if !input.edges[idx(x0, y0)] {
                continue;
            }
            let (gx, gy) = grad(idx(x0, y0));
            let g = (gx * gx + gy * gy).sqrt();
            if g == 0.0 {
                continue;
            }
            let (ux, uy) = (-gx / g, -gy / g);
            // Boundary crossings: x = x0 ± (k + ½), y likewise; at equal t the y crossing first.
            let mut events: Vec<(f64, u8)> = Vec::new();
            for k in 0..(w + h) {
                if ux != 0.0 {
                    events.push(((k as f64 + 0.5) / ux.abs(), 1));
                }
                if uy != 0.0 {
                    events.push(((k as f64 + 0.5) / uy.abs(), 0));
                }
            }
            events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let (mut x, mut y) = (x0, y0);
            let mut cells = vec![idx(x, y)];
            let mut hit = None;
            for &(_, axis) in &events {
                if axis == 1 {
                    x += if ux > 0.0 { 1 } else { -1 };
                } else {
                    y += if uy > 0.0 { 1 } else { -1 };
                }
                if x < 0 || y < 0 || x >= w || y >= h || !input.region[idx(x, y)] {
                    break;
                }
                cells.push(idx(x, y));
                if input.edges[idx(x, y)] && ((x - x0).abs() >= 2 || (y - y0).abs() >= 2) {
                    let (qx, qy) = grad(idx(x, y));
                    let cos = (gx * qx + gy * qy) / (g * (qx * qx + qy * qy).sqrt());
                    if cos < -cos_limit {
                        hit = Some((x, y));
                    }
                    break;
                }
            }
            if let Some((qx, qy)) = hit {
                let (a, b) = (refine(x0, y0), refine(qx, qy));
                let width = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
                let kind = if on_contour(x0, y0) || on_contour(qx, qy) {
                    OUTER
                } else {
                    INNER
                };
                rays.push((kind, cells, width));
            }
        }
    }
    let n = (w * h) as usize;
    let mut maps = [vec![f64::INFINITY; n], vec![f64::INFINITY; n]];
    for (kind, cells, width) in &rays {
        for &c in cells {
            maps[*kind][c] = maps[*kind][c].min(*width);
        }
    }
    for (kind, cells, _) in &rays {
        let mut values: Vec<f64> = cells.iter().map(|&c| maps[*kind][c]).collect();
        values.sort_by(f64::total_cmp);
        let median = values[values.len() / 2];
        for &c in cells {
            maps[*kind][c] = maps[*kind][c].min(median);
        }
    }
    [OUTER, INNER].map(|kind| {
        let values: Vec<f64> = maps[kind]
            .iter()
            .filter(|v| v.is_finite())
            .map(|v| v * input.unit)
            .collect();
        let count = rays.iter().filter(|r| r.0 == kind).count();
        if values.is_empty() {
            return (0.0, 0.0, 0, count);
        }
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / values.len() as f64;
        (mean, var.sqrt(), values.len(), count)
    })
}

fn assert_matches_reference(name: &str, p: &Prepared) {
    let mut ws = Workspace::default();
    for_each_scale(p, |s, input| {
        let fast = ws.measure(input);
        let slow = reference(input);
        for kind in [OUTER, INNER] {
            let (f, r) = (fast[kind], slow[kind]);
            let ctx = format!("{name} scale {s} kind {kind}: fast {f:?} reference {r:?}");
            // f32 against f64 arithmetic: a ray that grazes a pixel corner can take the other
            // cell in one of them, so a pixel in ten thousand may differ; anything more is a bug.
            let tol = 1e-3 * r.0.max(1.0);
            assert!((f.mean - r.0).abs() <= tol, "{ctx}");
            assert!((f.std - r.1).abs() <= tol, "{ctx}");
            assert_eq!(f.rays, r.3, "{ctx}");
            assert!(f.pixels.abs_diff(r.2) <= 1 + r.2 / 10_000, "{ctx}");
        }
    });
}

#[test]
fn matches_brute_force_reference_on_synthetic_drawings() {
    assert_matches_reference("bar", &prepared(bar(7, 30, 370)));
    assert_matches_reference("ring", &prepared(ring(true)));
    assert_matches_reference(
        "discs",
        &prepared(|x, y| {
            let d = dist(x, y);
            if d < 60.0 || (90.0..97.5).contains(&d) {
                30
            } else if d < 150.0 {
                200
            } else {
                255
            }
        }),
    );
}

#[test]
fn matches_brute_force_reference_on_fixture() {
    assert_matches_reference("bicycle", &bicycle());
}

/// The map statistics against hand-computed values, a single width gives a deviation of
/// (almost exactly) zero, and a nearly single width matches a plain two-pass computation.
#[test]
fn map_statistics_are_exact_for_known_values_and_one_width() {
    let mut map = vec![f32::INFINITY; 1003];
    for (k, v) in [(0, 1.0), (9, 2.0), (500, 3.0), (1002, 4.0)] {
        map[k] = v;
    }
    let (count, mean, variance) = summarise(&mut map, 2.0);
    assert_eq!(count, 4);
    assert_eq!(mean, 5.0);
    assert_eq!(variance, 5.0); // (9 + 1 + 1 + 9) / 4 at unit 2
    assert!(map.iter().all(|v| v.is_infinite()), "the map is reset");

    let width = 7.3f32;
    let mut map = vec![f32::INFINITY; 160_000];
    for i in (0..map.len()).step_by(7) {
        map[i] = width;
    }
    let (count, mean, variance) = summarise(&mut map, 1.0);
    assert_eq!(count, 160_000usize.div_ceil(7));
    assert!((mean - f64::from(width)).abs() < 1e-12, "{mean}");
    assert!(variance.sqrt() < 1e-9, "std {}", variance.sqrt());
    // Nearly one width (1 pixel in 100 is 0.01 px wider), against a plain two-pass sum.
    let mut map = vec![f32::INFINITY; 160_000];
    let mut values = Vec::new();
    for (k, i) in (0..map.len()).step_by(7).enumerate() {
        map[i] = if k % 100 == 0 { 7.31 } else { 7.3 };
        values.push(f64::from(map[i]) * 4.0);
    }
    let n = values.len() as f64;
    let expected_mean = values.iter().sum::<f64>() / n;
    let expected_variance = values
        .iter()
        .map(|v| (v - expected_mean).powi(2))
        .sum::<f64>()
        / n;
    let (_, mean, variance) = summarise(&mut map, 4.0);
    assert!((mean - expected_mean).abs() < 1e-12 * expected_mean);
    assert!(
        (variance.sqrt() - expected_variance.sqrt()).abs() < 1e-9,
        "{variance}"
    );
}
