use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::error::Error;
use crate::image::{Image, Mask};
use crate::video::flow::Flow;

const W: u32 = 64;
const H: u32 = 48;

/// The synthetic scene at a real position: three flat reflectances in vertical bands and a
/// vertical shading ramp attached to the scene. Returns (label, reflectance, shading).
fn scene(x: i32, y: i32) -> (u32, [f32; 3], f32) {
    let (label, r) = if x < 20 {
        (0, [0.8, 0.2, 0.2])
    } else if x < 44 {
        (1, [0.2, 0.7, 0.3])
    } else {
        (2, [0.2, 0.3, 0.9])
    };
    (label, r, 0.3 + 0.6 * y as f32 / 60.0)
}

/// Frame of the scene seen shifted by `(dx, dy)`: pixel (x, y) shows scene(x − dx, y − dy).
fn frame(dx: i32, dy: i32) -> (Image, Image, Labels) {
    let input = Image::from_fn(W, H, |x, y| {
        let (_, r, s) = scene(x as i32 - dx, y as i32 - dy);
        r.map(|v| v * s)
    });
    let refl = Image::from_fn(W, H, |x, y| scene(x as i32 - dx, y as i32 - dy).1);
    let data = (0..H)
        .flat_map(|y| (0..W).map(move |x| scene(x as i32 - dx, y as i32 - dy).0))
        .collect();
    let labels = Labels {
        width: W,
        height: H,
        data,
        count: 3,
    };
    (input, refl, labels)
}

fn close(a: [f32; 3], b: [f32; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn zero_flow_reassigns_every_pixel_with_its_reflectance() {
    let (input, refl, labels) = frame(0, 0);
    let tables = ClusterTables::from_frame(&input, &refl, &labels).unwrap();
    let p = propagate(
        &tables,
        &labels,
        &input,
        &Flow::zeros(W, H),
        &PropagateParams::default(),
    )
    .unwrap();
    assert_eq!(p.labels, labels);
    assert_eq!(p.assigned, (W * H) as usize);
    assert_eq!(p.assigned_fraction(), 1.0);
    for i in 0..(W * H) as usize {
        assert!(close(p.reflectance.rgb(i), refl.rgb(i)), "pixel {i}");
        assert_eq!(p.posterior[i], 1.0);
    }
}

#[test]
fn translation_with_true_flow_reassigns_all_but_the_revealed_border() {
    let (dx, dy) = (3, 2);
    let (input0, refl0, labels0) = frame(0, 0);
    let (input1, refl1, labels1) = frame(dx, dy);
    let tables = ClusterTables::from_frame(&input0, &refl0, &labels0).unwrap();
    let flow = Flow::from_fn(W, H, |_, _| [dx as f32, dy as f32]);
    let p = propagate(
        &tables,
        &labels0,
        &input1,
        &flow,
        &PropagateParams::default(),
    )
    .unwrap();
    for y in 0..H as i32 {
        for x in 0..W as i32 {
            let i = (y * W as i32 + x) as usize;
            if x < dx || y < dy {
                assert_eq!(p.labels.data[i], Labels::NONE, "revealed ({x}, {y})");
            } else {
                assert_eq!(p.labels.data[i], labels1.data[i], "({x}, {y})");
                assert!(close(p.reflectance.rgb(i), refl1.rgb(i)), "({x}, {y})");
            }
        }
    }
    let revealed = (dx as u32 * H + dy as u32 * W - (dx * dy) as u32) as usize;
    assert_eq!(p.assigned, (W * H) as usize - revealed);
    // With a zero flow instead, p′ lands on the wrong band next to the band edges; the
    // colour likelihood still rules the other clusters out, so no pixel gets a wrong label.
    let p0 = propagate(
        &tables,
        &labels0,
        &input1,
        &Flow::zeros(W, H),
        &PropagateParams::default(),
    )
    .unwrap();
    for (i, &l) in p0.labels.data.iter().enumerate() {
        assert!(l == Labels::NONE || l == labels1.data[i], "pixel {i}");
    }
}

#[test]
fn a_colour_far_from_every_cluster_stays_unassigned() {
    let (input, refl, labels) = frame(0, 0);
    let tables = ClusterTables::from_frame(&input, &refl, &labels).unwrap();
    let mut next = input.clone();
    // A yellow patch: no cluster has a colour within d of it.
    for y in 10..20 {
        for x in 5..15 {
            let i = y * W as usize + x;
            next.px_mut(i).copy_from_slice(&[0.9, 0.9, 0.0]);
        }
    }
    let p = propagate(
        &tables,
        &labels,
        &next,
        &Flow::zeros(W, H),
        &PropagateParams::default(),
    )
    .unwrap();
    for y in 0..H as usize {
        for x in 0..W as usize {
            let i = y * W as usize + x;
            let inside = (10..20).contains(&y) && (5..15).contains(&x);
            if inside {
                assert_eq!(p.labels.data[i], Labels::NONE);
                assert_eq!(p.posterior[i], 0.0);
            } else {
                assert_eq!(p.labels.data[i], labels.data[i]);
            }
        }
    }
}

#[test]
fn the_parzen_radius_is_inclusive_and_in_8_bit_units() {
    let input = Image::from_fn(2, 1, |x, _| {
        let v = crate::color::srgb_to_linear(if x == 0 { 100.0 } else { 200.0 } / 255.0);
        [v, v, v]
    });
    let labels = Labels {
        width: 2,
        height: 1,
        data: vec![0, 1],
        count: 2,
    };
    let t = ClusterTables::from_frame(&input, &input, &labels).unwrap();
    assert_eq!(t.colour_count(0, [100, 100, 100]), 1);
    // (103, 104, 100) is exactly 5 away: counted; (103, 104, 101) is √26 away: not.
    assert_eq!(t.likelihoods([103, 104, 100], 5.0), vec![(0, 1.0)]);
    assert_eq!(t.likelihoods([103, 104, 101], 5.0), vec![]);
    assert_eq!(t.likelihoods([150, 150, 150], 5.0), vec![]);
    assert_eq!(
        t.likelihoods([150, 150, 150], 87.0),
        vec![(0, 1.0), (1, 1.0)]
    );
}

/// Two clusters of one flat colour, split at x = 32: only the distance prior separates them.
fn twins() -> (Image, Labels, ClusterTables) {
    let input = Image::from_fn(W, H, |_, _| [0.5, 0.5, 0.5]);
    let data = (0..H)
        .flat_map(|_| (0..W).map(|x| u32::from(x >= 32)))
        .collect();
    let labels = Labels {
        width: W,
        height: H,
        data,
        count: 2,
    };
    let tables = ClusterTables::from_frame(&input, &input, &labels).unwrap();
    (input, labels, tables)
}

/// Distance from column x to the other twin cluster.
fn twin_distance(x: u32) -> u32 {
    if x < 32 { 32 - x } else { x - 31 }
}

#[test]
fn the_distance_prior_disambiguates_clusters_of_one_colour() {
    let (input, labels, tables) = twins();
    let p = propagate(
        &tables,
        &labels,
        &input,
        &Flow::zeros(W, H),
        &PropagateParams::default(),
    )
    .unwrap();
    for x in 0..W {
        let d = twin_distance(x);
        let i = (10 * W + x) as usize;
        // Equal likelihoods (1 each), own prior (1/2)^{-1/2} (D floored at half a pixel):
        // posterior 1 / (1 + (2D)^{-1/2}), ≥ 0.8 from D = 8 on; beyond N/2 = 25 the other
        // cluster is out of the window and the posterior is 1.
        let expected = if d > 25 {
            1.0
        } else {
            1.0 / (1.0 + (2.0 * d as f64).powf(-0.5))
        };
        assert!((p.posterior[i] as f64 - expected).abs() < 1e-6, "x = {x}");
        if d >= 8 {
            assert_eq!(p.labels.data[i], labels.data[i], "x = {x}");
        } else {
            assert_eq!(p.labels.data[i], Labels::NONE, "x = {x}");
        }
    }
}

#[test]
fn confidence_thresholds_epsilon_and_beta() {
    let (input, labels, tables) = twins();
    let run = |epsilon: f64, beta: f64| {
        let params = PropagateParams {
            epsilon,
            beta,
            ..PropagateParams::default()
        };
        propagate(&tables, &labels, &input, &Flow::zeros(W, H), &params).unwrap()
    };
    // x = 28: D = 4, posterior 1/(1 + 8^{-1/2}) = 0.739 (own prior √2, D floored at 1/2),
    // ratio √8 = 2.83.
    let i = (5 * W + 28) as usize;
    let p = run(0.8, 2.0);
    assert!((p.posterior[i] - 0.7388).abs() < 1e-4);
    assert_eq!(p.labels.data[i], Labels::NONE);
    assert_eq!(run(0.7, 2.0).labels.data[i], 0);
    // x = 30: D = 2, ratio √4 = 2 (passes β = 2); x = 31: D = 1, ratio √2 (fails).
    let p = run(0.5, 2.0);
    assert_eq!(p.labels.data[(5 * W + 30) as usize], 0);
    assert_eq!(p.labels.data[(5 * W + 31) as usize], Labels::NONE);
    assert_eq!(run(0.5, 1.4).labels.data[(5 * W + 31) as usize], 0);
    // x = 32 lands on the right twin, D = 1 to the left one: the mirror image.
    assert_eq!(
        run(0.5, 2.0).labels.data[(5 * W + 32) as usize],
        Labels::NONE
    );
}

#[test]
fn the_window_size_limits_the_prior() {
    let (input, labels, tables) = twins();
    // With N = 10 the other cluster is a candidate only within 5 pixels.
    let params = PropagateParams {
        n: 10,
        ..PropagateParams::default()
    };
    let p = propagate(&tables, &labels, &input, &Flow::zeros(W, H), &params).unwrap();
    for x in 0..W {
        let i = (7 * W + x) as usize;
        let d = twin_distance(x);
        assert_eq!(p.posterior[i] == 1.0, d > 5, "x = {x}");
    }
}

#[test]
fn unassigned_pixels_of_frame_t_belong_to_no_cluster() {
    let (input, mut labels, tables) = twins();
    // Frame t lost the right cluster's pixels near the seam: the left one is alone within
    // reach of x < 32 − 20.
    for y in 0..H {
        for x in 32..52 {
            labels.data[(y * W + x) as usize] = Labels::NONE;
        }
    }
    let p = propagate(
        &tables,
        &labels,
        &input,
        &Flow::zeros(W, H),
        &PropagateParams::default(),
    )
    .unwrap();
    let i = (3 * W + 31) as usize;
    assert_eq!(p.labels.data[i], 0);
    assert!((p.posterior[i] as f64 - 1.0 / (1.0 + 42f64.powf(-0.5))).abs() < 1e-6);
}

fn brute_force_stop(mask: &Mask, m: u32, alpha: f64) -> bool {
    let (w, h) = mask.dims();
    let (mw, mh) = (m.min(w), m.min(h));
    for y0 in 0..=h - mh {
        for x0 in 0..=w - mw {
            let mut c = 0;
            for y in y0..y0 + mh {
                for x in x0..x0 + mw {
                    c += usize::from(!mask.at((y * w + x) as usize));
                }
            }
            if c as f64 > alpha * (mw * mh) as f64 {
                return true;
            }
        }
    }
    false
}

#[test]
fn stopping_condition_matches_brute_force_on_random_masks() {
    let mut rng = ChaCha8Rng::seed_from_u64(20);
    let mut seen = [0usize; 2];
    for trial in 0..120 {
        let (w, h) = (rng.random_range(1..40u32), rng.random_range(1..40u32));
        // Clumped masks: a random rectangle of holes over a sprinkle, so that both answers
        // occur.
        let p = rng.random_range(0.0..0.6);
        let (rx, ry) = (rng.random_range(0..w), rng.random_range(0..h));
        let (rw, rh) = (rng.random_range(0..w), rng.random_range(0..h));
        let mask = Mask::from_fn(w, h, |x, y| {
            let hole = x >= rx && x < rx + rw && y >= ry && y < ry + rh;
            !hole && ((x * 7919 + y * 104_729 + trial) % 100) as f64 >= p * 100.0
        });
        for m in [1, 3, 10, 30] {
            for alpha in [0.0, 0.5, 0.8, 1.0] {
                let fast = should_stop(&mask, m, alpha).unwrap();
                assert_eq!(
                    fast,
                    brute_force_stop(&mask, m, alpha),
                    "{w}x{h} m {m} α {alpha}"
                );
                seen[usize::from(fast)] += 1;
            }
        }
    }
    assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
}

#[test]
fn stopping_condition_on_a_hole() {
    // A 10×10 fully unassigned hole: stops for M ≤ 11 (81% of 11×11 is 98 < 100), not for 12.
    let mask = Mask::from_fn(64, 48, |x, y| {
        !((20..30).contains(&x) && (5..15).contains(&y))
    });
    assert!(should_stop(&mask, 10, 0.8).unwrap());
    assert!(should_stop(&mask, 11, 0.8).unwrap());
    assert!(!should_stop(&mask, 12, 0.8).unwrap());
    assert!(!should_stop(&mask, 30, 0.8).unwrap());
    assert!(!should_stop(&Mask::full(5, 5), 30, 0.0).unwrap());
}

#[test]
fn update_adds_counts_exactly() {
    let (input0, refl0, labels0) = frame(0, 0);
    let (input1, refl1, mut labels1) = frame(5, 1);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for l in &mut labels1.data {
        if rng.random_bool(0.3) {
            *l = Labels::NONE;
        }
    }
    // One pixel of a new, fourth cluster.
    labels1.data[100] = 3;
    labels1.count = 4;
    let before = ClusterTables::from_frame(&input0, &refl0, &labels0).unwrap();
    let mut after = before.clone();
    after.update(&input1, &refl1, &labels1).unwrap();
    assert_eq!(after.cluster_count(), 4);
    for k in 0..4u32 {
        let added = labels1.data.iter().filter(|&&l| l == k).count() as u64;
        assert_eq!(after.pixels(k), before.pixels(k) + added, "k = {k}");
        let hist_total: u64 = after
            .reflectance_histogram(k)
            .unwrap()
            .iter()
            .map(|e| e.1)
            .sum();
        assert_eq!(hist_total, after.pixels(k));
        let colour_total: u64 = after.colour_histogram(k).iter().map(|e| e.1).sum();
        assert_eq!(colour_total, after.pixels(k));
    }
    // Per colour bin, exactly the new pixels of that colour, and the bin's mean reflectance.
    let mut expected = std::collections::BTreeMap::new();
    for (i, &l) in labels1.data.iter().enumerate() {
        if l != Labels::NONE {
            *expected.entry((l, colour8(input1.rgb(i)))).or_insert(0u64) += 1;
        }
    }
    for (&(k, c), &n) in &expected {
        assert_eq!(after.colour_count(k, c), before.colour_count(k, c) + n);
    }
    assert_eq!(after.mean_reflectance(3), Some(refl1.rgb(100)));
    assert_eq!(
        after.colour_reflectance(3, colour8(input1.rgb(100))),
        Some(refl1.rgb(100))
    );
    assert_eq!(before.mean_reflectance(3), None);
    // The flat bands keep their exact reflectance.
    assert!(close(after.mean_reflectance(0).unwrap(), [0.8, 0.2, 0.2]));
}

#[test]
fn result_does_not_depend_on_the_thread_count() {
    let (input0, refl0, labels0) = frame(0, 0);
    let (input1, _, _) = frame(2, -1);
    let tables = ClusterTables::from_frame(&input0, &refl0, &labels0).unwrap();
    let flow = Flow::from_fn(W, H, |x, y| [1.8 + 0.01 * x as f32, -0.9 + 0.01 * y as f32]);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                propagate(
                    &tables,
                    &labels0,
                    &input1,
                    &flow,
                    &PropagateParams::default(),
                )
                .unwrap()
            })
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn bad_inputs_are_errors() {
    let (input, refl, labels) = frame(0, 0);
    let tables = ClusterTables::from_frame(&input, &refl, &labels).unwrap();
    let params = PropagateParams::default();
    let flow = Flow::zeros(W, H);
    let small = Image::new(W - 1, H, 3);
    assert!(matches!(
        ClusterTables::from_frame(&small, &refl, &labels),
        Err(Error::ShapeMismatch { .. })
    ));
    assert!(matches!(
        ClusterTables::from_frame(&input, &small, &labels),
        Err(Error::ShapeMismatch { .. })
    ));
    assert!(matches!(
        propagate(&tables, &labels, &small, &flow, &params),
        Err(Error::ShapeMismatch { .. })
    ));
    assert!(matches!(
        propagate(&tables, &labels, &input, &Flow::zeros(W, H + 1), &params),
        Err(Error::ShapeMismatch { .. })
    ));
    let empty = Labels {
        width: 0,
        height: 0,
        data: vec![],
        count: 0,
    };
    let nothing = Image::new(0, 0, 3);
    assert!(matches!(
        ClusterTables::from_frame(&nothing, &nothing, &empty),
        Err(Error::EmptyImage { .. })
    ));
    assert!(matches!(
        propagate(&tables, &empty, &nothing, &Flow::zeros(0, 0), &params),
        Err(Error::EmptyImage { .. })
    ));
    assert!(matches!(
        should_stop(&Mask::full(0, 3), 10, 0.8),
        Err(Error::EmptyImage { .. })
    ));
    assert!(matches!(
        should_stop(&Mask::full(3, 3), 0, 0.8),
        Err(Error::InvalidParam { name: "m", .. })
    ));
    assert!(matches!(
        should_stop(&Mask::full(3, 3), 3, 1.5),
        Err(Error::InvalidParam { name: "alpha", .. })
    ));
    // A label beyond the tables' clusters, a label beyond Labels::count, a NaN reflectance.
    let mut wrong = labels.clone();
    wrong.data[7] = 3;
    assert!(matches!(
        propagate(&tables, &wrong, &input, &flow, &params),
        Err(Error::InvalidParam { name: "label", .. })
    ));
    assert!(matches!(
        ClusterTables::from_frame(&input, &refl, &wrong),
        Err(Error::InvalidParam { name: "label", .. })
    ));
    let mut nan = refl.clone();
    nan.px_mut(W as usize + 2)[1] = f32::NAN;
    assert!(matches!(
        ClusterTables::from_frame(&input, &nan, &labels),
        Err(Error::NonFinite { x: 2, y: 1 })
    ));
    for bad in [
        PropagateParams {
            d: -1.0,
            ..params.clone()
        },
        PropagateParams {
            n: 0,
            ..params.clone()
        },
        PropagateParams {
            epsilon: 0.0,
            ..params.clone()
        },
        PropagateParams {
            epsilon: 1.2,
            ..params.clone()
        },
        PropagateParams {
            beta: 0.5,
            ..params.clone()
        },
        PropagateParams {
            alpha: -0.1,
            ..params.clone()
        },
        PropagateParams {
            m: 0,
            ..params.clone()
        },
    ] {
        assert!(matches!(
            propagate(&tables, &labels, &input, &flow, &bad),
            Err(Error::InvalidParam { .. })
        ));
    }
}

#[test]
fn colour8_is_the_rounded_srgb_code() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let mut off = 0;
    for _ in 0..20_000 {
        let v: f32 = rng.random_range(-0.1..1.1);
        let exact = (crate::color::linear_to_srgb(v) * 255.0).round() as u8;
        let got = colour8([v; 3])[0];
        if got != exact {
            // Only at a code boundary, within rounding.
            let code = (crate::color::linear_to_srgb(v) * 255.0 - 0.5).round();
            assert!(((crate::color::linear_to_srgb(v) * 255.0) - 0.5 - code).abs() < 1e-4);
            off += 1;
        }
    }
    assert!(off < 5, "{off}");
    for c in 0..=255u8 {
        let v = crate::color::srgb_to_linear(c as f32 / 255.0);
        assert_eq!(colour8([v; 3]), [c; 3]);
    }
    assert_eq!(colour8([f32::NAN, f32::INFINITY, 2.0]), [0, 0, 255]);
}

#[test]
fn distance_transform_matches_brute_force() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for _ in 0..30 {
        let (w, h) = (rng.random_range(1..30u32), rng.random_range(1..30u32));
        let n = (w * h) as usize;
        let density = rng.random_range(0.0..0.2);
        let data = (0..n)
            .map(|_| {
                if rng.random_bool(density) {
                    0
                } else if rng.random_bool(0.1) {
                    Labels::NONE
                } else {
                    1
                }
            })
            .collect();
        let labels = Labels {
            width: w,
            height: h,
            data,
            count: 2,
        };
        let reach = rng.random_range(1..20usize);
        let req: Vec<(usize, u32)> = (0..rng.random_range(1..10))
            .map(|j| (j, rng.random_range(0..n as u32)))
            .collect();
        let got = prior::nearest_dist2(&labels, 0, &req, reach);
        for (&(_, s), &d2) in req.iter().zip(&got) {
            let (sx, sy) = ((s % w) as i64, (s / w) as i64);
            let best = (0..n)
                .filter(|&q| labels.data[q] == 0)
                .map(|q| {
                    let (qx, qy) = ((q as u32 % w) as i64, (q as u32 / w) as i64);
                    ((qx - sx).pow(2) + (qy - sy).pow(2)) as f64
                })
                .fold(f64::INFINITY, f64::min);
            if best <= (reach * reach) as f64 {
                assert_eq!(d2, best, "{w}x{h} reach {reach} at ({sx}, {sy})");
            } else {
                assert!(d2 > (reach * reach) as f64, "{d2} vs {best}");
            }
        }
    }
}

#[test]
fn likelihoods_match_a_brute_force_parzen_sum() {
    let mut rng = ChaCha8Rng::seed_from_u64(36);
    // Colours in a small cube so that balls hold many bins, several clusters, two updates.
    let (w, h) = (40u32, 30u32);
    let mut tables = ClusterTables::new(0);
    let mut all: Vec<([u8; 3], u32)> = Vec::new();
    for _ in 0..2 {
        let values: Vec<f32> = (0..3 * w * h)
            .map(|_| crate::color::srgb_to_linear(rng.random_range(90.0..115.0) / 255.0))
            .collect();
        let input = Image::from_vec(w, h, 3, values).unwrap();
        let data: Vec<u32> = (0..w * h)
            .map(|_| {
                if rng.random_bool(0.1) {
                    Labels::NONE
                } else {
                    rng.random_range(0..4)
                }
            })
            .collect();
        for (i, &l) in data.iter().enumerate() {
            if l != Labels::NONE {
                all.push((colour8(input.rgb(i)), l));
            }
        }
        let labels = Labels {
            width: w,
            height: h,
            data,
            count: 4,
        };
        tables.update(&input, &input, &labels).unwrap();
    }
    for _ in 0..200 {
        let c = [0; 3].map(|_| rng.random_range(85..120u8));
        let d = rng.random_range(0.0..9.0f64);
        let mut expected = Vec::new();
        for k in 0..4u32 {
            let size = all.iter().filter(|e| e.1 == k).count();
            let inside = all
                .iter()
                .filter(|e| {
                    e.1 == k
                        && (0..3)
                            .map(|j| (e.0[j] as f64 - c[j] as f64).powi(2))
                            .sum::<f64>()
                            <= d * d
                })
                .count();
            assert_eq!(tables.pixels(k), size as u64);
            if inside > 0 {
                expected.push((k, inside as f64 / size as f64));
            }
        }
        assert_eq!(tables.likelihoods(c, d), expected, "colour {c:?}, d {d}");
    }
}

#[test]
fn sliding_counts_match_the_ball_scan() {
    let mut rng = ChaCha8Rng::seed_from_u64(77);
    let (w, h) = (50u32, 40u32);
    let values: Vec<f32> = (0..3 * w * h)
        .map(|_| crate::color::srgb_to_linear(rng.random_range(100.0..130.0) / 255.0))
        .collect();
    let input = Image::from_vec(w, h, 3, values).unwrap();
    let labels = Labels {
        width: w,
        height: h,
        data: (0..w * h).map(|_| rng.random_range(0..5)).collect(),
        count: 5,
    };
    let tables = ClusterTables::from_frame(&input, &input, &labels).unwrap();
    for _ in 0..60 {
        let (r, g) = (rng.random_range(95..135u8), rng.random_range(95..135u8));
        let mut blues: Vec<u8> = (0..rng.random_range(1..30))
            .map(|_| rng.random_range(90..140u8))
            .collect();
        blues.sort_unstable();
        blues.dedup();
        let d = [0.0, 1.0, 2.5, 5.0, 7.3][rng.random_range(0..5)];
        let slid = tables.counts_along_blue(r, g, &blues, d);
        for (&b, counts) in blues.iter().zip(&slid) {
            let reference: Vec<(u32, f64)> = tables.likelihoods([r, g, b], d);
            let got: Vec<(u32, f64)> = counts
                .iter()
                .map(|&(k, c)| (k, c as f64 / tables.pixels(k) as f64))
                .collect();
            assert_eq!(got, reference, "({r}, {g}, {b}), d {d}");
        }
    }
}

#[test]
fn a_colour_without_its_own_bin_takes_the_ball_mean() {
    // Cluster 0 holds two colours (codes 100 and 104 in every channel) with reflectances
    // 0.2 and 0.4, three pixels and one; a pixel of code 102 has no bin but both are within
    // d = 5 (distance 2√3): it takes (3·0.2 + 0.4)/4 = 0.25.
    let lin = |c: f32| crate::color::srgb_to_linear(c / 255.0);
    let codes = [100.0, 100.0, 100.0, 104.0];
    let input = Image::from_fn(4, 1, |x, _| [lin(codes[x as usize]); 3]);
    let refl = Image::from_fn(4, 1, |x, _| [if x < 3 { 0.2 } else { 0.4 }; 3]);
    let labels = Labels {
        width: 4,
        height: 1,
        data: vec![0; 4],
        count: 1,
    };
    let tables = ClusterTables::from_frame(&input, &refl, &labels).unwrap();
    let next = Image::from_fn(4, 1, |x, _| [lin(if x == 1 { 102.0 } else { 100.0 }); 3]);
    let p = propagate(
        &tables,
        &labels,
        &next,
        &Flow::zeros(4, 1),
        &PropagateParams::default(),
    )
    .unwrap();
    assert_eq!(p.labels.data, vec![0; 4]);
    assert!(
        close(p.reflectance.rgb(1), [0.25; 3]),
        "{:?}",
        p.reflectance.rgb(1)
    );
    assert!(close(p.reflectance.rgb(0), [0.2; 3]));
}

#[test]
fn the_warped_position_inverts_a_smooth_flow() {
    // f(x, y) = (2 + 0.05 x, −1 + 0.03 y): the pixel of frame t landing on (x, y) is
    // ((x − 2) / 1.05, (y + 1) / 1.03).
    let flow = Flow::from_fn(W, H, |x, y| [2.0 + 0.05 * x as f32, -1.0 + 0.03 * y as f32]);
    let mut checked = 0;
    for y in 0..H as usize {
        for x in 0..W as usize {
            let (sx, sy) = ((x as f64 - 2.0) / 1.05, (y as f64 + 1.0) / 1.03);
            let near_half = |v: f64| (v - v.floor() - 0.5).abs() < 0.02;
            if near_half(sx) || near_half(sy) {
                continue;
            }
            let (rx, ry) = (sx.round(), sy.round());
            let got = map::source_pixel(&flow, x, y);
            if rx < 0.0 || ry < 0.0 || rx > (W - 1) as f64 || ry > (H - 1) as f64 {
                assert_eq!(got, u32::MAX, "({x}, {y})");
            } else {
                assert_eq!(
                    got as usize,
                    ry as usize * W as usize + rx as usize,
                    "({x}, {y})"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 2500, "{checked}");
}

#[test]
fn the_colour_ball_mean_matches_a_brute_force_sum() {
    // Colours spread over a wide cube (balls of radius up to 60 meet many grid cells, some
    // cut by the ball's surface), five clusters, two updates so bins accumulate.
    let mut rng = ChaCha8Rng::seed_from_u64(91);
    let (w, h) = (40u32, 30u32);
    let mut tables = ClusterTables::new(0);
    // (colour, cluster, reflectance) of every labelled pixel.
    let mut all: Vec<([u8; 3], u32, [f32; 3])> = Vec::new();
    for _ in 0..2 {
        let values: Vec<f32> = (0..3 * w * h)
            .map(|_| crate::color::srgb_to_linear(rng.random_range(40.0..200.0) / 255.0))
            .collect();
        let input = Image::from_vec(w, h, 3, values).unwrap();
        let refl_values: Vec<f32> = (0..3 * w * h)
            .map(|_| rng.random_range(0.05..1.0))
            .collect();
        let refl = Image::from_vec(w, h, 3, refl_values).unwrap();
        let data: Vec<u32> = (0..w * h)
            .map(|_| {
                if rng.random_bool(0.1) {
                    Labels::NONE
                } else {
                    rng.random_range(0..5)
                }
            })
            .collect();
        for (i, &l) in data.iter().enumerate() {
            if l != Labels::NONE {
                all.push((colour8(input.rgb(i)), l, refl.rgb(i)));
            }
        }
        let labels = Labels {
            width: w,
            height: h,
            data,
            count: 5,
        };
        tables.update(&input, &refl, &labels).unwrap();
    }
    let index = ball::BallIndex::new(&tables);
    let mut empty = 0;
    for _ in 0..300 {
        let c = [0; 3].map(|_| rng.random_range(20..230u8));
        let radius = rng.random_range(0.0..60.0f64);
        let k = rng.random_range(0..5u32);
        let (mut n, mut sum) = (0u64, [0.0f64; 3]);
        for (rgb, l, r) in &all {
            let d2: f64 = (0..3).map(|j| (rgb[j] as f64 - c[j] as f64).powi(2)).sum();
            if *l == k && d2 <= radius * radius {
                n += 1;
                for j in 0..3 {
                    sum[j] += f64::from(r[j]);
                }
            }
        }
        let got = index.mean(&tables, c, radius, k);
        if n == 0 {
            empty += 1;
            assert_eq!(got, None, "colour {c:?}, radius {radius}, cluster {k}");
        } else {
            let want = sum.map(|v| (v / n as f64) as f32);
            let got = got.unwrap_or_else(|| panic!("{c:?} {radius} {k}: no mean"));
            assert!(
                got.iter().zip(&want).all(|(a, b)| (a - b).abs() < 1e-5),
                "colour {c:?}, radius {radius}, cluster {k}: {got:?} against {want:?}"
            );
        }
    }
    // Both outcomes were exercised.
    assert!(empty > 10 && empty < 290, "{empty} empty balls of 300");
    // A cluster the tables do not have.
    assert_eq!(index.mean(&tables, [100; 3], 50.0, 5), None);
}

#[test]
fn a_colour_ball_pools_the_reflectance_of_a_cluster() {
    // Cluster 0 holds codes 100 (three pixels, reflectance 0.2) and 120 (one, 0.4); cluster 1
    // holds code 110 (reflectance 0.9), 10 away from both, which must not enter cluster 0's
    // mean. With the exact bin a pixel of code 100 keeps 0.2; with a ball of radius 40 (the
    // distance 20√3 ≈ 34.6 between 100 and 120 is inside) it takes (3·0.2 + 0.4)/4 = 0.25.
    let lin = |c: f32| crate::color::srgb_to_linear(c / 255.0);
    let codes = [100.0, 100.0, 100.0, 120.0, 110.0];
    let input = Image::from_fn(5, 1, |x, _| [lin(codes[x as usize]); 3]);
    let refl = Image::from_fn(5, 1, |x, _| [[0.2, 0.2, 0.2, 0.4, 0.9][x as usize]; 3]);
    let labels = Labels {
        width: 5,
        height: 1,
        data: vec![0, 0, 0, 0, 1],
        count: 2,
    };
    let tables = ClusterTables::from_frame(&input, &refl, &labels).unwrap();
    let run = |radius: f64| {
        let params = PropagateParams {
            reflectance_radius: radius,
            ..PropagateParams::default()
        };
        propagate(&tables, &labels, &input, &Flow::zeros(5, 1), &params).unwrap()
    };
    let exact = run(0.0);
    let pooled = run(40.0);
    assert_eq!(exact.labels.data, labels.data);
    assert_eq!(pooled.labels.data, labels.data);
    assert!(close(exact.reflectance.rgb(0), [0.2; 3]));
    assert!(
        close(pooled.reflectance.rgb(0), [0.25; 3]),
        "{:?}",
        pooled.reflectance.rgb(0)
    );
    assert!(close(pooled.reflectance.rgb(3), [0.25; 3]));
    assert!(close(pooled.reflectance.rgb(4), [0.9; 3]));
    // A ball smaller than the Parzen radius still gives every assigned pixel a reflectance:
    // code 102 (no bin of its own; code 100 is 2√3 ≈ 3.5 away) with a ball of radius 1 holds
    // no bin and falls back to the Parzen ball of d = 5, which holds code 100 only.
    let next = Image::from_fn(5, 1, |x, _| {
        [lin(if x == 0 { 102.0 } else { codes[x as usize] }); 3]
    });
    let small = PropagateParams {
        reflectance_radius: 1.0,
        ..PropagateParams::default()
    };
    let p = propagate(&tables, &labels, &next, &Flow::zeros(5, 1), &small).unwrap();
    assert_eq!(p.labels.data[0], 0);
    assert!(
        close(p.reflectance.rgb(0), [0.2; 3]),
        "{:?}",
        p.reflectance.rgb(0)
    );
    // Out of range.
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let params = PropagateParams {
            reflectance_radius: bad,
            ..PropagateParams::default()
        };
        assert!(matches!(
            propagate(&tables, &labels, &input, &Flow::zeros(5, 1), &params),
            Err(Error::InvalidParam { .. })
        ));
    }
}

#[test]
fn the_reflectance_memo_never_changes_the_result() {
    // Random colours, so that many (colour, cluster) pairs repeat between the two frames and
    // the memo answers them; then the tables change, and the memo must not answer from the
    // old tables.
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let (w, h) = (48u32, 36u32);
    let random_frame = |rng: &mut ChaCha8Rng| {
        let values: Vec<f32> = (0..3 * w * h)
            .map(|_| crate::color::srgb_to_linear(rng.random_range(60.0..140.0) / 255.0))
            .collect();
        Image::from_vec(w, h, 3, values).unwrap()
    };
    let input0 = random_frame(&mut rng);
    let refl0 = Image::from_vec(
        w,
        h,
        3,
        (0..3 * w * h).map(|_| rng.random_range(0.1..0.9)).collect(),
    )
    .unwrap();
    let labels = Labels {
        width: w,
        height: h,
        data: (0..w * h).map(|_| rng.random_range(0..4)).collect(),
        count: 4,
    };
    let mut tables = ClusterTables::from_frame(&input0, &refl0, &labels).unwrap();
    let params = PropagateParams {
        reflectance_radius: 30.0,
        epsilon: 0.3,
        beta: 1.0,
        ..PropagateParams::default()
    };
    let flow = Flow::zeros(w, h);
    let mut memo = ReflectanceMemo::new();
    let same =
        |a: &Propagation, b: &Propagation| a.labels == b.labels && a.reflectance == b.reflectance;
    for next in [&input0, &input0] {
        let with = propagate_with(&tables, &labels, next, &flow, &params, &mut memo, None).unwrap();
        assert!(with.assigned > 100, "{} assigned", with.assigned);
        assert!(same(
            &with,
            &propagate(&tables, &labels, next, &flow, &params).unwrap()
        ));
    }
    let kept = memo.len();
    assert!(kept > 100, "{kept} pairs in the memo");
    // New pixels change the ball means of the same pairs.
    let refl1 = Image::from_vec(w, h, 3, vec![0.95; (3 * w * h) as usize]).unwrap();
    tables.update(&input0, &refl1, &labels).unwrap();
    let with = propagate_with(&tables, &labels, &input0, &flow, &params, &mut memo, None).unwrap();
    let fresh = propagate(&tables, &labels, &input0, &flow, &params).unwrap();
    assert!(same(&with, &fresh));
    // Another radius with the same tables starts afresh too.
    let wider = PropagateParams {
        reflectance_radius: 60.0,
        ..params.clone()
    };
    let with = propagate_with(&tables, &labels, &input0, &flow, &wider, &mut memo, None).unwrap();
    assert!(same(
        &with,
        &propagate(&tables, &labels, &input0, &flow, &wider).unwrap()
    ));
    // A clone of the tables is equal to them, and an update makes them differ.
    let mut copy = tables.clone();
    assert!(copy == tables);
    copy.update(&input0, &refl0, &labels).unwrap();
    assert!(copy != tables);
}

#[test]
fn targeted_pixels_get_the_same_decision_as_a_full_propagation() {
    // Random colours and labels, a flow that moves by a pixel and a half, and a random third of
    // the pixels as targets: each target decides as in the full propagation, every other pixel
    // is left unassigned with posterior 0.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let (w, h) = (40u32, 30u32);
    let n = (w * h) as usize;
    let frame = |rng: &mut ChaCha8Rng| {
        let values: Vec<f32> = (0..3 * n)
            .map(|_| crate::color::srgb_to_linear(rng.random_range(40.0..160.0) / 255.0))
            .collect();
        Image::from_vec(w, h, 3, values).unwrap()
    };
    let (input0, input1) = (frame(&mut rng), frame(&mut rng));
    let refl0 = Image::from_vec(
        w,
        h,
        3,
        (0..3 * n).map(|_| rng.random_range(0.1..0.9)).collect(),
    )
    .unwrap();
    let labels = Labels {
        width: w,
        height: h,
        data: (0..n).map(|_| rng.random_range(0..5)).collect(),
        count: 5,
    };
    let tables = ClusterTables::from_frame(&input0, &refl0, &labels).unwrap();
    let flow = Flow::from_fn(w, h, |_, _| [1.5, -0.5]);
    let targets: Vec<bool> = (0..n).map(|_| rng.random_bool(0.3)).collect();
    // The thesis' exact colour bins, and a colour ball.
    for radius in [0.0, 30.0] {
        let params = PropagateParams {
            epsilon: 0.3,
            beta: 1.0,
            reflectance_radius: radius,
            ..PropagateParams::default()
        };
        targets_decide_as_in_full(&tables, &labels, &input1, &flow, &params, &targets);
    }
}

fn targets_decide_as_in_full(
    tables: &ClusterTables,
    labels: &Labels,
    input1: &Image,
    flow: &Flow,
    params: &PropagateParams,
    targets: &[bool],
) {
    let n = targets.len();
    let only = |targets: &[bool]| {
        propagate_with(
            tables,
            labels,
            input1,
            flow,
            params,
            &mut ReflectanceMemo::new(),
            Some(targets),
        )
    };
    let full = propagate(tables, labels, input1, flow, params).unwrap();
    assert!(full.assigned > n / 4, "{} assigned", full.assigned);
    let part = only(targets).unwrap();
    let mut assigned = 0;
    for (i, &t) in targets.iter().enumerate() {
        if t {
            assert_eq!(part.labels.data[i], full.labels.data[i], "pixel {i}");
            assert_eq!(
                part.reflectance.rgb(i),
                full.reflectance.rgb(i),
                "pixel {i}"
            );
            assert_eq!(part.posterior[i], full.posterior[i], "pixel {i}");
            assigned += usize::from(full.labels.data[i] != Labels::NONE);
        } else {
            assert_eq!(part.labels.data[i], Labels::NONE, "pixel {i}");
            assert_eq!(part.posterior[i], 0.0, "pixel {i}");
        }
    }
    assert_eq!(part.assigned, assigned);
    assert!(assigned > 50, "{assigned} targets assigned");
    // One flag per pixel, or an error.
    assert!(matches!(
        only(&targets[1..]),
        Err(Error::ShapeMismatch { .. })
    ));
}
