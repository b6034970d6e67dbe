//! Unit tests of the border levelling.

use super::histogram::{BINS, Histogram, RANGE};
use super::*;
use crate::image::Mask;

/// Two clusters side by side, the right one's shading `e^{−step}` of the left one's on
/// every frame: the left cluster's offset is `step` relative to the right one's, and then the
/// shading is continuous across the border.
#[test]
fn a_step_at_a_cluster_border_becomes_reflectance() {
    let (w, h) = (8usize, 4usize);
    let labels: Vec<u32> = (0..w * h).map(|i| u32::from(i % w >= 3)).collect();
    let mut ev = BorderEvidence::default();
    let step = 0.7f64;
    let mut shading: Vec<f32> = labels
        .iter()
        .map(|&l| {
            if l == 0 {
                0.8
            } else {
                (0.8 * (-step).exp()) as f32
            }
        })
        .collect();
    ev.add_frame(w, &labels, &shading);
    let delta = ev.offsets(2, &BorderLevelParams::default()).unwrap();
    // Cluster 1 is the larger (5 columns against 3): the gauge keeps its level.
    assert!(delta[1].abs() < 1e-12, "{delta:?}");
    assert!((delta[0] - step).abs() < 1e-6, "{delta:?}");
    apply(&labels, &mut shading, &delta);
    let (s0, s1) = (shading[2], shading[3]);
    assert!((s0 / s1 - 1.0).abs() < 0.02, "{s0} {s1}");
}

/// One border of three with a real shading jump (an occlusion): the L1 fit follows the
/// consistent majority of the loop, least squares would split the disagreement.
#[test]
fn the_l1_fit_ignores_one_inconsistent_border() {
    let mut ev = BorderEvidence::default();
    // Pairs (0,1): 0.3, (1,2): 0.2, and (0,2): 1.5 with fewer samples (0.5 would close the
    // loop), written as one-row frames.
    for (a, b, d, n) in [(0u32, 1u32, 0.3f64, 50), (1, 2, 0.2, 50), (0, 2, 1.5, 20)] {
        for _ in 0..n {
            ev.add_frame(2, &[a, b], &[1.0, (-d).exp() as f32]);
        }
    }
    // Make cluster 2 the largest (gauge).
    ev.add_frame(40, &[2; 40], &[1.0; 40]);
    let l1 = BorderLevelParams {
        residual_floor: 1e-3,
        ..Default::default()
    };
    let d = ev.offsets(3, &l1).unwrap();
    assert_eq!(d[2], 0.0);
    let res = [d[0] - d[1] - 0.3, d[1] - d[2] - 0.2, d[0] - d[2] - 1.5];
    // The L1 optimum puts the whole loop error (1.0) on the least-sampled border; least
    // squares would spread it over all three.
    assert!(res[0].abs() < 0.03 && res[1].abs() < 0.03, "{res:?}");
    assert!((res[2] + 1.0).abs() < 0.03, "{res:?}");
}

/// A stroke outweighs the border evidence: the border says a step of 0.5 between the two
/// clusters in many frames, a constant-shading stroke across the same border says none;
/// a constant-albedo stroke over two clusters of reflectance ratio 2 makes them equal.
#[test]
fn strokes_outweigh_the_borders() {
    let labels = [0u32, 1];
    let shading = [1.0f32, (-0.5f64).exp() as f32];
    let both = Mask::from_fn(2, 1, |_, _| true);
    let mut ev = BorderEvidence::default();
    for _ in 0..1000 {
        ev.add_frame(2, &labels, &shading);
    }
    let flat = [0.6f32, 0.6];
    let lum = [0.3f32, 0.3];
    let shading_stroke = Strokes {
        constant_shading: vec![both.clone()],
        ..Default::default()
    };
    ev.add_strokes(2, &labels, &flat, &lum, &shading_stroke);
    let d = ev.offsets(2, &BorderLevelParams::default()).unwrap();
    assert!((d[0] - d[1]).abs() < 0.01, "{d:?}");

    // Reflectance lum(I)/S: 0.3/0.6 = 0.5 in cluster 0, 0.6/0.6 = 1 in cluster 1.
    let mut ev = BorderEvidence::default();
    let lum = [0.3f32, 0.6];
    ev.add_frame(2, &labels, &flat);
    let albedo_stroke = Strokes {
        constant_albedo: vec![both],
        ..Default::default()
    };
    ev.add_strokes(2, &labels, &flat, &lum, &albedo_stroke);
    let d = ev.offsets(2, &BorderLevelParams::default()).unwrap();
    let (r0, r1) = (0.5 * d[0].exp(), d[1].exp());
    assert!((r0 / r1 - 1.0).abs() < 0.01, "{d:?}: {r0} {r1}");
    // Both clusters are the stroke's, so the single views do not vote on them.
    assert!(ev.in_strokes(0) && ev.in_strokes(1) && !ev.in_strokes(2));
    let mut unstroked = BorderEvidence::default();
    unstroked.add_frame(2, &labels, &flat);
    assert!(!unstroked.in_strokes(0));
}

#[test]
fn clusters_that_touch_nothing_keep_their_level() {
    let mut ev = BorderEvidence::default();
    ev.add_frame(2, &[0, 1], &[1.0, 0.5]);
    ev.add_frame(1, &[2], &[0.3]);
    let d = ev.offsets(4, &BorderLevelParams::default()).unwrap();
    assert_eq!(d[2], 0.0);
    assert_eq!(d[3], 0.0);
    assert!((d[0] - d[1] - 2f64.ln()).abs() < 0.02, "{d:?}");
}

#[test]
fn the_median_of_a_histogram() {
    let mut h = Histogram::default();
    for d in [-0.5, 0.1, 0.1, 0.1, 2.0, 9.0] {
        h.add(d);
    }
    assert_eq!(h.samples(), 6);
    assert!((h.median() - 0.1).abs() < 1e-6, "{}", h.median());
    h.add(0.105);
    h.add(0.11);
    let m = h.median();
    assert!((m - 0.1).abs() < 2.0 * RANGE / BINS as f64, "{m}");
    assert_eq!(Histogram::default().median(), 0.0);
    assert!(
        BorderLevelParams {
            residual_floor: 0.0,
            ..Default::default()
        }
        .validate()
        .is_err()
    );
}

/// Four clusters in a row of pixels: 0 (the largest), 1 and 2, and 3 with no single-view
/// shading. The single view puts cluster 1's shading `e^{−0.5}` below the propagated one and
/// agrees on cluster 2, on another white point (twice the shading everywhere).
fn view_levels() -> ViewLevels {
    let labels: Vec<u32> = [0, 0, 0, 0, 1, 1, 2, 2, 3].to_vec();
    let shading = vec![0.5f32; labels.len()];
    let view: Vec<f32> = labels
        .iter()
        .map(|&l| match l {
            1 => (1.0 * (-0.5f64).exp()) as f32,
            3 => 0.0,
            _ => 1.0,
        })
        .collect();
    let mut views = ViewLevels::default();
    views.add_frame(&labels, &shading, &view);
    views
}

#[test]
fn the_single_views_keep_an_offset_that_moves_towards_their_level() {
    let views = view_levels();
    // Cluster 1: the view's level is +0.5, the levelling's +0.6 moves towards it and stays.
    // Cluster 2: the view agrees with the first frame's level, so +0.4 goes back to 0.
    // Cluster 3: never lit in the view, keeps its offset.
    let mut delta = vec![0.0, 0.6, 0.4, 0.3];
    views.vote(&mut delta, 0, |_| false);
    assert_eq!(delta, [0.0, 0.6, 0.0, 0.3]);
    // A cluster of the user's strokes keeps its offset whatever the views say.
    let mut delta = vec![0.0, 0.6, 0.4, 0.3];
    views.vote(&mut delta, 0, |k| k == 2);
    assert_eq!(delta, [0.0, 0.6, 0.4, 0.3]);
    // Relative to the reference cluster: the same with every offset shifted.
    let mut shifted = vec![0.2, 0.8, 0.6, 0.5];
    views.vote(&mut shifted, 0, |_| false);
    assert_eq!(shifted, [0.2, 0.8, 0.2, 0.5]);
    // An offset in the other direction, or past twice the view's level, goes back.
    for d1 in [-0.1, 1.05] {
        let mut delta = vec![0.0, d1, 0.0, 0.0];
        views.vote(&mut delta, 0, |_| false);
        assert_eq!(delta[1], 0.0, "{d1}");
    }
}

#[test]
fn without_single_views_nothing_changes() {
    let mut delta = vec![0.0, 0.6, 0.4];
    ViewLevels::default().vote(&mut delta, 0, |_| false);
    assert_eq!(delta, [0.0, 0.6, 0.4]);
}
