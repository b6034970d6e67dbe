use std::path::{Path, PathBuf};

use proptest::prelude::*;

use super::*;
use crate::io::{LoadOptions, load_rgb};

const COLOURS: [[f32; 3]; 6] = [
    [0.9, 0.1, 0.1],
    [0.1, 0.8, 0.2],
    [0.1, 0.2, 0.9],
    [0.9, 0.9, 0.2],
    [0.5, 0.5, 0.5],
    [0.2, 0.9, 0.9],
];

/// A 60×40 image of six flat rectangles (20×20 each, 3 × 2) and its true partition.
fn rectangles() -> (Image, Labels) {
    let (w, h) = (60u32, 40u32);
    let cell = |x: u32, y: u32| (y / 20 * 3 + x / 20) as usize;
    let img = Image::from_fn(w, h, |x, y| COLOURS[cell(x, y)]);
    let truth = relabel(w as usize, h as usize, |i| {
        cell(i as u32 % w, i as u32 / w) as u32
    });
    (img, truth)
}

fn sizes(l: &Labels) -> Vec<usize> {
    let mut s = vec![0; l.count];
    for &v in &l.data {
        s[v as usize] += 1;
    }
    s
}

/// Labels are `0..count`, all used, numbered by first appearance.
fn assert_contiguous(l: &Labels) {
    let mut next = 0u32;
    for &v in &l.data {
        assert!(v <= next, "label {v} appears before {next}");
        if v == next {
            next += 1;
        }
    }
    assert_eq!(next as usize, l.count);
}

/// Every label forms one 8-connected piece.
fn assert_connected(l: &Labels) {
    let (w, h) = (l.width as usize, l.height as usize);
    let mut seen = vec![false; w * h];
    let mut pieces = 0;
    for start in 0..w * h {
        if seen[start] {
            continue;
        }
        pieces += 1;
        seen[start] = true;
        let mut stack = vec![start];
        while let Some(p) = stack.pop() {
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = ny as usize * w + nx as usize;
                    if !seen[q] && l.data[q] == l.data[p] {
                        seen[q] = true;
                        stack.push(q);
                    }
                }
            }
        }
    }
    assert_eq!(pieces, l.count, "some label is split into several pieces");
}

#[test]
fn flat_rectangles_without_smoothing_give_the_exact_partition() {
    let (img, truth) = rectangles();
    let p = FelzenszwalbParams {
        sigma: 0.0,
        ..Default::default()
    };
    let l = felzenszwalb(&img, &p).unwrap();
    assert_eq!(l.count, 6);
    assert_eq!(l.data, truth.data);
}

#[test]
fn flat_rectangles_with_smoothing_keep_their_count_and_interiors() {
    // σ = 0.8 blurs each boundary over the kernel radius (3 px): the blurred strips join one
    // another along the boundaries and then a neighbouring rectangle (scikit-image gives the
    // same map). Pixels farther than 3 px from a boundary must keep their rectangle's segment,
    // one segment per rectangle.
    let (img, truth) = rectangles();
    let p = FelzenszwalbParams {
        min_size: 100,
        ..Default::default()
    };
    let l = felzenszwalb(&img, &p).unwrap();
    assert_eq!(l.count, 6);
    let centre = |cell: usize| l.data[(cell / 3 * 20 + 10) * 60 + cell % 3 * 20 + 10];
    let mut centres: Vec<u32> = (0..6).map(centre).collect();
    for y in 0..40usize {
        for x in 0..60usize {
            let (dx, dy) = (x % 20, y % 20);
            let near_x = (x >= 20 && dx < 3) || (x < 40 && dx >= 17);
            let near_y = (y >= 20 && dy < 3) || (y < 20 && dy >= 17);
            if !near_x && !near_y {
                let cell = truth.data[y * 60 + x] as usize;
                assert_eq!(l.data[y * 60 + x], centre(cell), "({x}, {y})");
            }
        }
    }
    centres.sort_unstable();
    centres.dedup();
    assert_eq!(centres.len(), 6, "two rectangles share a segment");
}

#[test]
fn tiny_components_join_a_neighbour() {
    // Isolated 2×2 dots of a far colour on a flat background: each dot is its own component
    // after the main pass, and min_size = 20 must fold every one of them.
    let img = Image::from_fn(40, 30, |x, y| {
        if x % 10 < 2 && y % 10 < 2 {
            [1.0, 0.0, 1.0]
        } else {
            [0.2, 0.3, 0.4]
        }
    });
    let p = FelzenszwalbParams {
        sigma: 0.0,
        k: 50.0,
        min_size: 20,
    };
    let without = felzenszwalb(
        &img,
        &FelzenszwalbParams {
            min_size: 1,
            ..p.clone()
        },
    )
    .unwrap();
    assert_eq!(without.count, 13, "12 dots and the background");
    let l = felzenszwalb(&img, &p).unwrap();
    assert_eq!(l.count, 1);
    assert!(sizes(&l).iter().all(|&s| s >= 20));
}

#[test]
fn runs_are_deterministic_across_thread_counts() {
    let img = load_rgb(fixture("chelsea.png"), linear()).unwrap();
    let p = FelzenszwalbParams::default();
    let a = felzenszwalb(&img, &p).unwrap();
    let b = felzenszwalb(&img, &p).unwrap();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let c = pool.install(|| felzenszwalb(&img, &p)).unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
}

#[test]
fn bad_params_and_inputs_are_errors() {
    let img = Image::new(4, 4, 3);
    for p in [
        FelzenszwalbParams {
            sigma: -1.0,
            ..Default::default()
        },
        FelzenszwalbParams {
            k: f64::NAN,
            ..Default::default()
        },
    ] {
        assert!(matches!(
            felzenszwalb(&img, &p),
            Err(Error::InvalidParam { .. })
        ));
    }
    let empty = Image::new(0, 3, 3);
    assert!(matches!(
        felzenszwalb(&empty, &FelzenszwalbParams::default()),
        Err(Error::EmptyImage { .. })
    ));
    let mut nan = Image::new(3, 2, 3);
    nan.data_mut()[3 * 4 + 1] = f32::NAN;
    assert!(matches!(
        felzenszwalb(&nan, &FelzenszwalbParams::default()),
        Err(Error::NonFinite { x: 1, y: 1 })
    ));
}

#[test]
fn an_image_smaller_than_min_size_is_one_segment() {
    let img = Image::from_fn(5, 4, |x, _| [x as f32 / 4.0, 0.0, 0.0]);
    let l = felzenszwalb(&img, &FelzenszwalbParams::default()).unwrap();
    assert_eq!((l.count, l.data.len()), (1, 20));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn segments_are_contiguous_connected_and_large_enough(
        w in 1u32..24,
        h in 1u32..24,
        seed in any::<u64>(),
        min_size in 1usize..40,
        k in 0.0f64..400.0,
        sigma in 0.0f64..1.5,
    ) {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        // Blocky noise: flat patches of random colours, so that segments of many sizes occur.
        let blocks: Vec<[f32; 3]> = (0..64).map(|_| [rng.random(), rng.random(), rng.random()]).collect();
        let img = Image::from_fn(w, h, |x, y| blocks[((y / 3) * 8 + x / 3) as usize % 64]);
        let l = felzenszwalb(&img, &FelzenszwalbParams { sigma, k, min_size }).unwrap();
        assert_contiguous(&l);
        assert_connected(&l);
        let n = (w * h) as usize;
        for s in sizes(&l) {
            prop_assert!(s >= min_size.min(n), "segment of {s} < {min_size}");
        }
    }
}

// ---- adjusted Rand index ----

#[test]
fn adjusted_rand_index_matches_known_values() {
    let lab = |d: &[u32]| Labels {
        width: d.len() as u32,
        height: 1,
        data: d.to_vec(),
        count: *d.iter().max().unwrap() as usize + 1,
    };
    // By hand: index 1 agreeing pair, expected 2·1/6, maximum 1.5: (1 − 1/3)/(1.5 − 1/3) = 4/7.
    let ari = adjusted_rand_index(&lab(&[0, 0, 1, 1]), &lab(&[0, 0, 1, 2])).unwrap();
    assert!((ari - 4.0 / 7.0).abs() < 1e-12, "{ari}");
    // Renaming labels does not matter.
    let ari = adjusted_rand_index(&lab(&[0, 0, 1, 1, 2]), &lab(&[2, 2, 0, 0, 1])).unwrap();
    assert!((ari - 1.0).abs() < 1e-12);
    // Hubert–Arabie by hand: no pair agrees (index 0), expected index 6·3/15 = 1.2, maximum
    // (6 + 3)/2 = 4.5: (0 − 1.2)/(4.5 − 1.2) = −4/11.
    let ari = adjusted_rand_index(&lab(&[0, 0, 0, 1, 1, 1]), &lab(&[0, 1, 2, 0, 1, 2])).unwrap();
    assert!((ari + 4.0 / 11.0).abs() < 1e-12, "{ari}");
}

// ---- merge by mean colour ----

#[test]
fn merge_joins_close_adjacent_segments_only() {
    // Four vertical bands: 0.50 | 0.51 | 0.90 | 0.50. Bands 0 and 1 are close and adjacent;
    // band 3 has band 0's colour but does not touch it.
    let vals = [0.50f32, 0.51, 0.90, 0.50];
    let img = Image::from_fn(16, 4, |x, _| [vals[x as usize / 4]; 3]);
    let labels = relabel(16, 4, |i| (i % 16 / 4) as u32);
    let m = merge_by_mean(&labels, &img, &MeanMergeParams { threshold: 0.05 }).unwrap();
    assert_eq!(m.count, 3);
    let band = |b: usize| m.data[b * 4];
    assert_eq!(band(0), band(1));
    assert_ne!(band(0), band(3));
    assert_ne!(band(2), band(3));
    // A zero threshold joins nothing; a huge one joins everything connected.
    let none = merge_by_mean(&labels, &img, &MeanMergeParams { threshold: 0.0 }).unwrap();
    assert_eq!(none.data, labels.data);
    let all = merge_by_mean(&labels, &img, &MeanMergeParams { threshold: 10.0 }).unwrap();
    assert_eq!(all.count, 1);
}

#[test]
fn merge_recomputes_means_after_each_join() {
    // Grey segments 0.00 (1 px) – 0.04 (3 px) – 0.08 (1 px); over three equal channels the
    // Euclidean distance is √3 times the grey difference: both pairs are 0.0693 apart.
    let vals = [0.0f32, 0.04, 0.04, 0.04, 0.08];
    let img = Image::from_fn(5, 1, |x, _| [vals[x as usize]; 3]);
    let labels = relabel(5, 1, |i| [0, 1, 1, 1, 2][i]);
    let m = merge_by_mean(&labels, &img, &MeanMergeParams { threshold: 0.05 }).unwrap();
    assert_eq!(m.count, 3);
    // At 0.07 the tie goes to the lower ids: 0 and 1 join, their pixel-weighted mean is 0.03,
    // now 0.05·√3 ≈ 0.087 from segment 2, above the threshold: the chain stops at two.
    let m = merge_by_mean(&labels, &img, &MeanMergeParams { threshold: 0.07 }).unwrap();
    assert_eq!(m.count, 2);
    assert_eq!(m.data, [0, 0, 0, 0, 1]);
}

#[test]
fn reflectance_clusters_segment_then_merge() {
    // The six rectangles with the top-left one's neighbour moved to 0.03 (per channel) from
    // it: segmentation keeps six, the merge at 0.1 joins that pair only.
    let (w, h) = (60u32, 40u32);
    let mut colours = COLOURS;
    colours[1] = [0.93, 0.13, 0.13];
    let img = Image::from_fn(w, h, |x, y| colours[(y / 20 * 3 + x / 20) as usize]);
    let seg = FelzenszwalbParams {
        sigma: 0.0,
        min_size: 100,
        ..Default::default()
    };
    assert_eq!(felzenszwalb(&img, &seg).unwrap().count, 6);
    let c = reflectance_clusters(&img, &seg, &MeanMergeParams::default()).unwrap();
    assert_eq!(c.count, 5);
    assert_eq!(c.data[10 * 60 + 10], c.data[10 * 60 + 30]);
    assert_contiguous(&c);
}

#[test]
fn merge_checks_its_inputs() {
    let img = Image::new(4, 4, 3);
    let labels = relabel(4, 3, |_| 0);
    assert!(matches!(
        merge_by_mean(&labels, &img, &MeanMergeParams::default()),
        Err(Error::ShapeMismatch { .. })
    ));
    let labels = relabel(4, 4, |_| 0);
    assert!(matches!(
        merge_by_mean(&labels, &img, &MeanMergeParams { threshold: -1.0 }),
        Err(Error::InvalidParam { .. })
    ));
}

// ---- scikit-image reference (scripts/reference/felzenszwalb_skimage.py) ----

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../fixtures/video/segment")
        .join(name)
}

fn linear() -> LoadOptions {
    LoadOptions {
        linear: true,
        ..Default::default()
    }
}

fn load_labels(name: &str) -> Labels {
    let img = image::open(fixture(name)).unwrap().to_luma16();
    let (w, h) = img.dimensions();
    let data: Vec<u32> = img.into_raw().into_iter().map(u32::from).collect();
    let count = *data.iter().max().unwrap() as usize + 1;
    Labels {
        width: w,
        height: h,
        data,
        count,
    }
}

fn reference() -> serde_json::Value {
    let text = std::fs::read_to_string(fixture("reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

/// Our segment count must be within this many segments (or 5 %, whichever is larger) of
/// scikit-image's, and the adjusted Rand index at least `MIN_ARI`. The implementations follow
/// the same conventions, so they agree exactly on these fixtures; the slack only absorbs
/// rounding (scikit-image keeps the inner thresholds in single precision).
const COUNT_SLACK: usize = 1;
const MIN_ARI: f64 = 0.99;

#[test]
fn matches_scikit_image_on_photographs() {
    let refs = reference();
    for (name, entry) in refs["images"].as_object().unwrap() {
        let img = load_rgb(fixture(&format!("{name}.png")), linear()).unwrap();
        for case in entry["felzenszwalb"].as_array().unwrap() {
            let p = FelzenszwalbParams {
                sigma: case["sigma"].as_f64().unwrap(),
                k: case["scale"].as_f64().unwrap(),
                min_size: case["min_size"].as_u64().unwrap() as usize,
            };
            let ours = felzenszwalb(&img, &p).unwrap();
            let theirs = load_labels(case["labels"].as_str().unwrap());
            assert_eq!(theirs.count as u64, case["segments"].as_u64().unwrap());
            let ari = adjusted_rand_index(&ours, &theirs).unwrap();
            let slack = COUNT_SLACK.max(theirs.count / 20);
            eprintln!(
                "{name} K={} σ={} min={}: ours {} skimage {} ARI {ari:.6}",
                p.k, p.sigma, p.min_size, ours.count, theirs.count
            );
            assert!(
                ours.count.abs_diff(theirs.count) <= slack && ari >= MIN_ARI,
                "{name} {p:?}: {} segments against scikit-image's {}, ARI {ari}",
                ours.count,
                theirs.count
            );
        }
    }
}

#[test]
fn merge_matches_scikit_image_rag_merging() {
    // Both merges start from scikit-image's segmentation of the setting, so only the
    // merge is compared.
    let refs = reference();
    for (name, entry) in refs["images"].as_object().unwrap() {
        let img = load_rgb(fixture(&format!("{name}.png")), linear()).unwrap();
        let base = load_labels(&format!("{name}_fh_50_0.8_256.png"));
        for case in entry["merge"].as_array().unwrap() {
            let t = case["threshold"].as_f64().unwrap();
            let ours = merge_by_mean(&base, &img, &MeanMergeParams { threshold: t }).unwrap();
            let theirs = load_labels(case["labels"].as_str().unwrap());
            let ari = adjusted_rand_index(&ours, &theirs).unwrap();
            eprintln!(
                "{name} merge {t:.4}: ours {} skimage {} (from {}) ARI {ari:.6}",
                ours.count, theirs.count, base.count
            );
            assert!(
                ours.count == theirs.count && ari >= MIN_ARI,
                "{name} threshold {t}: {} clusters against scikit-image's {}, ARI {ari}",
                ours.count,
                theirs.count
            );
        }
    }
}

#[test]
fn grid_lists_every_8_neighbour_pair_once() {
    for (w, h) in [(1usize, 1usize), (1, 4), (5, 1), (4, 3), (7, 6)] {
        let grid = Grid { w, h };
        let n: usize = grid.blocks().iter().sum();
        let mut got: Vec<(u32, u32)> = (0..n as u32)
            .map(|i| {
                let (p, q) = grid.ends(i);
                (p.min(q), p.max(q))
            })
            .collect();
        got.sort_unstable();
        let mut want = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let p = (y * w + x) as u32;
                for (dx, dy) in [(1i64, 0i64), (0, 1), (1, 1), (-1, 1)] {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx >= 0 && nx < w as i64 && ny < h as i64 {
                        let q = (ny as usize * w + nx as usize) as u32;
                        want.push((p.min(q), p.max(q)));
                    }
                }
            }
        }
        want.sort_unstable();
        assert_eq!(got, want, "{w}x{h}");
    }
}
