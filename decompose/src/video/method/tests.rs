use std::path::{Path, PathBuf};

use super::complete::{local_decomposition, poisson_blend};
use super::state::{PixelSource, Scratch};
use super::*;
use crate::color::luminance;
use crate::image::{Image, Mask};
use crate::io::save_float_tiff;
use crate::video::frames::FrameOptions;

/// Writes `frames` as float TIFFs (exact linear values) and opens them as a source.
fn source_of(dir: &Path, frames: &[Image]) -> FrameSource {
    for (t, f) in frames.iter().enumerate() {
        save_float_tiff(dir.join(format!("{t:06}.tiff")), f).unwrap();
    }
    FrameSource::open(dir, &FrameOptions::default()).unwrap()
}

/// Albedo palette of the synthetic sequences.
const PALETTE: [[f32; 3]; 4] = [
    [0.8, 0.25, 0.2],
    [0.2, 0.6, 0.3],
    [0.25, 0.3, 0.85],
    [0.85, 0.8, 0.3],
];

/// Blocks of the palette, 8 px wide, in scene coordinates.
fn albedo(x: i32, y: i32) -> [f32; 3] {
    PALETTE[((x.div_euclid(8) + 3 * y.div_euclid(8)).rem_euclid(4)) as usize]
}

/// A smooth light fixed on the screen.
fn shade(x: u32, y: u32, w: u32, h: u32) -> f32 {
    let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
    0.35 + 0.55 * (1.0 - 0.6 * (u - 0.3).powi(2) - 0.8 * (v - 0.4).powi(2))
}

/// `n` frames of `w`×`h`: the albedo blocks move right by `dx` px per frame under a fixed
/// light; returns (frames, true reflectance).
fn translating(n: usize, w: u32, h: u32, dx: i32) -> (Vec<Image>, Vec<Image>) {
    let refl: Vec<Image> = (0..n)
        .map(|t| Image::from_fn(w, h, |x, y| albedo(x as i32 - dx * t as i32, y as i32)))
        .collect();
    let frames = refl
        .iter()
        .map(|r| {
            Image::from_fn(w, h, |x, y| {
                let i = (y * w + x) as usize;
                r.rgb(i).map(|v| v * shade(x, y, w, h))
            })
        })
        .collect();
    (frames, refl)
}

/// The defaults, with segments of at least 16 pixels instead of 256: the test frames have
/// 500–1300 pixels, where `min = 256` would leave two or three clusters of mixed albedos.
fn params() -> VideoParams {
    let mut p = VideoParams::default();
    p.segment.min_size = 16;
    p
}

fn run(frames: &[Image], params: &VideoParams) -> (Vec<OwnedFrame>, VideoStats, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let src_dir = dir.path().join("frames");
    std::fs::create_dir(&src_dir).unwrap();
    let source = source_of(&src_dir, frames);
    let mut out: Vec<OwnedFrame> = Vec::new();
    let stats = decompose_video(
        &source,
        &Strokes::default(),
        params,
        &dir.path().join("scratch"),
        &mut out,
        &mut |_| {},
    )
    .unwrap();
    (out, stats, dir)
}

fn assert_product(frames: &[Image], out: &[OwnedFrame]) {
    assert_eq!(out.len(), frames.len());
    for (t, (f, o)) in frames.iter().zip(out).enumerate() {
        assert_eq!(o.index, t);
        for i in 0..f.len() {
            let s = o.shading.px(i)[0];
            assert!(s.is_finite() && s > 0.0, "frame {t} pixel {i}: shading {s}");
            for c in 0..3 {
                let (p, v) = (o.reflectance.px(i)[c] * s, f.px(i)[c]);
                assert!(
                    (p - v).abs() <= 1e-5 * v.abs().max(1e-3),
                    "frame {t} pixel {i} channel {c}: R×S = {p}, I = {v}"
                );
            }
        }
    }
}

/// Mean |Δ log luminance| of the reflectance between consecutive frames, after moving frame
/// t + 1 back by the true shift `dx` (pixels whose source leaves the frame are skipped).
fn flicker(refl: &[&Image], dx: i32) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    let lum = |img: &Image, i: usize| f64::from(luminance(img.rgb(i)).max(1e-6)).ln();
    for pair in refl.windows(2) {
        let (w, h) = pair[0].dims();
        for y in 0..h as i32 {
            for x in 0..w as i32 {
                let x1 = x + dx;
                if !(0..w as i32).contains(&x1) {
                    continue;
                }
                let i0 = (y * w as i32 + x) as usize;
                let i1 = (y * w as i32 + x1) as usize;
                sum += (lum(pair[1], i1) - lum(pair[0], i0)).abs();
                n += 1;
            }
        }
    }
    sum / n as f64
}

fn per_frame_retinex(frames: &[Image]) -> Vec<crate::Decomposition> {
    frames
        .iter()
        .map(|f| {
            crate::retinex::decompose(
                f,
                None,
                &Strokes::default(),
                &RetinexParams::default(),
                &mut |_| {},
            )
            .unwrap()
            .0
        })
        .collect()
}

#[test]
fn product_and_bookkeeping_hold_on_every_frame() {
    let (frames, _) = translating(6, 32, 24, 1);
    let (out, stats, dir) = run(&frames, &params());
    assert_product(&frames, &out);
    assert_eq!(stats.frames.len(), 6);
    let scratch = Scratch::new(&dir.path().join("scratch")).unwrap();
    for (t, fs) in stats.frames.iter().enumerate() {
        let total = fs.assigned_by_propagation + fs.completed + fs.residual;
        assert!((total - 1.0).abs() < 1e-12, "frame {t}: {fs:?}");
        // The final state on disk: one source per pixel, none unassigned, and the counts
        // are the reported fractions.
        let st = scratch.load_state(t, (32, 24)).unwrap();
        let count = |k| st.source.iter().filter(|&&s| s == k).count() as f64 / st.len() as f64;
        assert_eq!(count(PixelSource::Unassigned), 0.0);
        assert_eq!(count(PixelSource::Propagation), fs.assigned_by_propagation);
        assert_eq!(count(PixelSource::Completion), fs.completed);
        assert_eq!(count(PixelSource::Residual), fs.residual);
        assert!(st.labels.iter().all(|&l| (l as usize) < stats.clusters));
        assert_eq!(out[t].clusters.data, st.labels);
    }
    assert_eq!(stats.frames[0].completed, 1.0);
    // The motion is one pixel a frame: propagation assigns nearly everything after frame 0.
    for fs in &stats.frames[1..] {
        assert!(fs.assigned_by_propagation > 0.8, "{fs:?}");
    }
}

/// Blocks of distinct colours (a hue walk by the golden angle) with a white block that enters
/// from the left at frame 1; the blocks move right by one pixel a frame under a fixed light.
fn white_enters(n: usize, w: u32, h: u32) -> (Vec<Image>, Vec<Image>) {
    let albedo = |x: i32, y: i32| {
        let (bx, by) = (x.div_euclid(8), y.div_euclid(8));
        if bx == -1 && by == 1 {
            return [0.95f32; 3];
        }
        let k = (bx + 7 * by).rem_euclid(40) as f32;
        let hue = (k * 137.5) % 360.0;
        let v = 0.35 + 0.25 * ((k * 0.618) % 1.0);
        crate::color::hsv_to_rgb([hue, 0.6, v])
    };
    let refl: Vec<Image> = (0..n)
        .map(|t| Image::from_fn(w, h, |x, y| albedo(x as i32 - t as i32, y as i32)))
        .collect();
    let frames = refl
        .iter()
        .map(|r| {
            Image::from_fn(w, h, |x, y| {
                r.rgb((y * w + x) as usize).map(|v| v * shade(x, y, w, h))
            })
        })
        .collect();
    (frames, refl)
}

#[test]
fn flicker_is_well_below_per_frame_retinex() {
    // Per-frame Retinex re-anchors its scale on the white block once it is seen; the method
    // keeps the first frame's.
    let (frames, truth) = white_enters(8, 32, 24);
    let (out, _, _dir) = run(&frames, &params());
    let ours = flicker(&out.iter().map(|o| &o.reflectance).collect::<Vec<_>>(), 1);
    let base = per_frame_retinex(&frames);
    let theirs = flicker(&base.iter().map(|d| &d.reflectance).collect::<Vec<_>>(), 1);
    let exact = flicker(&truth.iter().collect::<Vec<_>>(), 1);
    assert!(exact < 1e-9);
    assert!(
        ours < 0.5 * theirs,
        "flicker: ours {ours:.4}, per-frame Retinex {theirs:.4}"
    );
}

/// A tiny Gaussian elimination with partial pivoting (the dense reference).
fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, p);
        b.swap(c, p);
        let (top, bottom) = a.split_at_mut(c + 1);
        let pivot = &top[c];
        for (r, row) in bottom.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            for (v, pv) in row[c..].iter_mut().zip(&pivot[c..]) {
                *v -= f * pv;
            }
            b[c + 1 + r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

#[test]
fn completion_equation_matches_a_dense_solve() {
    // 6×4: two albedos (a chroma edge at x = 3) under a ramp; the right column is known.
    let (w, h) = (6usize, 4usize);
    let input = Image::from_fn(w as u32, h as u32, |x, y| {
        let a = if x < 3 {
            [0.7, 0.3, 0.2]
        } else {
            [0.2, 0.4, 0.7]
        };
        let s = 0.3 + 0.1 * x as f32 + 0.05 * y as f32;
        a.map(|v| v * s)
    });
    let region = Mask::full(w as u32, h as u32);
    let known: Vec<f64> = (0..w * h)
        .map(|p| {
            if p % w == w - 1 {
                -0.5 + 0.1 * (p / w) as f64
            } else {
                f64::NAN
            }
        })
        .collect();
    let params = RetinexParams::default();
    let lambda_c = 1000.0;
    let s = local_decomposition(&input, &region, &known, &params, lambda_c).unwrap();

    // Dense normal equations of eq. 3.8, written out independently.
    let n = w * h;
    let logy = |p: usize| f64::from(luminance(input.rgb(p))).ln();
    let unit = |p: usize| {
        let c = input.rgb(p).map(f64::from);
        let m = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        c.map(|v| v / m)
    };
    let mut a = vec![vec![0.0; n]; n];
    let mut b = vec![0.0; n];
    let mut add = |terms: &[(usize, f64)], rhs: f64, wt: f64| {
        for &(i, ci) in terms {
            b[i] += wt * ci * rhs;
            for &(j, cj) in terms {
                a[i][j] += wt * ci * cj;
            }
        }
    };
    for (p, &known_p) in known.iter().enumerate() {
        for q in [
            (p % w + 1 < w).then_some(p + 1),
            (p + w < n).then_some(p + w),
        ]
        .into_iter()
        .flatten()
        {
            add(&[(p, 1.0), (q, -1.0)], 0.0, params.lambda_l);
            let (u, v) = (unit(p), unit(q));
            let d2: f64 = (0..3).map(|c| (u[c] - v[c]).powi(2)).sum();
            if d2 < params.t {
                add(
                    &[(p, 1.0), (q, -1.0)],
                    logy(p) - logy(q),
                    params.lambda_l * params.omega,
                );
            }
        }
        if known_p.is_finite() {
            add(&[(p, 1.0)], known_p, lambda_c);
        }
    }
    let x = dense_solve(a, b);
    for p in 0..n {
        assert!(
            (s[p] - x[p]).abs() < 1e-6,
            "pixel {p}: {} vs {}",
            s[p],
            x[p]
        );
    }
    // The known column is held (λ_c = 1000 against unit smoothness weights).
    for p in (0..n).filter(|p| known[*p].is_finite()) {
        assert!(
            (s[p] - known[p]).abs() < 0.01,
            "pixel {p}: {} vs {}",
            s[p],
            known[p]
        );
    }
}

#[test]
fn poisson_blend_holds_the_dirichlet_boundary_exactly() {
    let (w, h) = (9usize, 7usize);
    // A hole inside and one on the image border.
    let hole: Vec<bool> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            ((2..6).contains(&x) && (2..5).contains(&y)) || (x == 8 && y < 3)
        })
        .collect();
    let field = |p: usize| ((p % w) as f64 * 0.37).sin() + ((p / w) as f64 * 0.21).cos();
    let guidance: Vec<f64> = (0..w * h)
        .map(|p| field(p) + 5.0 + 0.1 * ((p * 7919) % 13) as f64)
        .collect();
    let boundary: Vec<f64> = (0..w * h)
        .map(|p| if hole[p] { f64::NAN } else { field(p) })
        .collect();
    let solver = crate::solver::SolverParams::default();
    let s = poisson_blend(w, h, &hole, &guidance, &boundary, &solver).unwrap();
    for p in 0..w * h {
        if !hole[p] {
            assert_eq!(
                s[p].to_bits(),
                boundary[p].to_bits(),
                "boundary pixel {p} moved"
            );
        }
    }
    // Inside: the discrete Poisson equation Σ_q (s_p − s_q) = Σ_q (g_p − g_q).
    for p in (0..w * h).filter(|&p| hole[p]) {
        let (x, y) = (p % w, p / w);
        let nb = [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < h).then(|| p + w),
        ];
        let res: f64 = nb
            .into_iter()
            .flatten()
            .map(|q| (s[p] - s[q]) - (guidance[p] - guidance[q]))
            .sum();
        assert!(res.abs() < 1e-7, "pixel {p}: Poisson residual {res}");
    }
    // A guidance that is the boundary's own field up to a constant is reproduced exactly.
    let shifted: Vec<f64> = (0..w * h).map(|p| field(p) + 3.0).collect();
    let s = poisson_blend(w, h, &hole, &shifted, &boundary, &solver).unwrap();
    for p in (0..w * h).filter(|&p| hole[p]) {
        assert!((s[p] - field(p)).abs() < 1e-7, "pixel {p}");
    }
}

/// A still background of two albedos and a square of a new colour entering from the right.
fn entering(n: usize, w: u32, h: u32) -> (Vec<Image>, Vec<Image>) {
    let new = [0.9f32, 0.15, 0.6];
    let refl: Vec<Image> = (0..n)
        .map(|t| {
            let left = w as i32 - 2 * t as i32; // the square's left edge
            Image::from_fn(w, h, |x, y| {
                let (x, y) = (x as i32, y as i32);
                if x >= left && x < left + 16 && (8..24).contains(&y) {
                    new
                } else if y < h as i32 / 2 {
                    PALETTE[1]
                } else {
                    PALETTE[2]
                }
            })
        })
        .collect();
    let frames = refl
        .iter()
        .map(|r| {
            Image::from_fn(w, h, |x, y| {
                r.rgb((y * w + x) as usize).map(|v| v * shade(x, y, w, h))
            })
        })
        .collect();
    (frames, refl)
}

#[test]
fn an_object_entering_the_view_is_completed_with_a_new_cluster() {
    let (w, h, n) = (40u32, 32u32, 14usize);
    let (frames, truth) = entering(n, w, h);
    let (out, stats, _dir) = run(&frames, &params());
    assert_product(&frames, &out);
    assert!(!stats.stopping_frames.is_empty(), "{stats:?}");
    let first = out[0].clusters.data.iter().max().copied().unwrap();
    let last = &out[n - 1];
    let square: Vec<usize> = (0..last.clusters.data.len())
        .filter(|&i| truth[n - 1].rgb(i) == [0.9, 0.15, 0.6])
        .collect();
    assert!(square.len() > 200);
    // The square is a cluster of its own, made after the first frame.
    let inside = square
        .iter()
        .filter(|&&i| last.clusters.data[i] > first)
        .count();
    assert!(
        inside as f64 > 0.9 * square.len() as f64,
        "{inside} of {}",
        square.len()
    );
    // Little of the video is left to the residual fill.
    for fs in &stats.frames {
        assert!(fs.residual < 0.05, "{fs:?}");
    }
}

#[test]
fn a_long_sequence_keeps_its_state_in_scratch_files() {
    let (w, h, n) = (32u32, 24u32, 40usize);
    let (frames, _) = translating(n, w, h, 1);
    let dir = tempfile::tempdir().unwrap();
    let src_dir = dir.path().join("frames");
    std::fs::create_dir(&src_dir).unwrap();
    let source = source_of(&src_dir, &frames);
    drop(frames);
    // A sink that keeps nothing: frames arrive once each, in order.
    let mut next = 0usize;
    let mut sink = |f: VideoFrame<'_>| {
        assert_eq!(f.index, next);
        assert_eq!(f.reflectance.dims(), (w, h));
        next += 1;
        Ok(())
    };
    let scratch = dir.path().join("scratch");
    let stats = decompose_video(
        &source,
        &Strokes::default(),
        &params(),
        &scratch,
        &mut sink,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(next, n);
    assert_eq!(stats.frames.len(), n);
    let names: Vec<String> = std::fs::read_dir(&scratch)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let px = (w * h) as u64;
    for t in 0..n {
        let p = scratch.join(format!("frame_{t:06}.state"));
        assert_eq!(std::fs::metadata(&p).unwrap().len(), 12 + 9 * px, "{p:?}");
    }
    let flows = names.iter().filter(|s| s.ends_with(".flow")).count();
    assert!(flows >= n - 1, "{flows} flow files");
}

#[test]
fn bad_inputs_are_errors() {
    let (frames, _) = translating(2, 16, 12, 1);
    let dir = tempfile::tempdir().unwrap();
    let source = source_of(dir.path(), &frames);
    let scratch: PathBuf = dir.path().join("scratch");
    let call = |strokes: &Strokes, params: &VideoParams| {
        decompose_video(
            &source,
            strokes,
            params,
            &scratch,
            &mut Vec::new(),
            &mut |_| {},
        )
    };
    let strokes = Strokes {
        constant_albedo: vec![Mask::full(15, 12)],
        ..Default::default()
    };
    assert!(matches!(
        call(&strokes, &VideoParams::default()),
        Err(Error::ShapeMismatch {
            expected: (16, 12),
            got: (15, 12)
        })
    ));
    for (params, name) in [
        (
            VideoParams {
                lambda_c: 0.0,
                ..Default::default()
            },
            "lambda_c",
        ),
        (
            VideoParams {
                lambda_c: f64::NAN,
                ..Default::default()
            },
            "lambda_c",
        ),
        (
            VideoParams {
                completion_margin: 0,
                ..Default::default()
            },
            "completion_margin",
        ),
    ] {
        match call(&Strokes::default(), &params) {
            Err(Error::InvalidParam { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    let mut p = VideoParams::default();
    p.propagate.epsilon = 2.0;
    assert!(matches!(
        call(&Strokes::default(), &p),
        Err(Error::InvalidParam {
            name: "epsilon",
            ..
        })
    ));
    // A scratch path that is a file.
    let file = dir.path().join("000000.tiff");
    assert!(matches!(
        decompose_video(
            &source,
            &Strokes::default(),
            &VideoParams::default(),
            &file,
            &mut Vec::new(),
            &mut |_| {}
        ),
        Err(Error::Io { .. })
    ));
}

#[test]
fn ablations_keep_the_invariants() {
    let (frames, _) = translating(5, 24, 16, 1);
    for ablation in [
        Ablation {
            complete_every_frame: true,
            ..Default::default()
        },
        Ablation {
            no_confidence_threshold: true,
            ..Default::default()
        },
        Ablation {
            no_optical_flow: true,
            ..Default::default()
        },
    ] {
        let params = VideoParams {
            ablation: ablation.clone(),
            ..params()
        };
        let (out, stats, _dir) = run(&frames, &params);
        assert_product(&frames, &out);
        for fs in &stats.frames {
            let total = fs.assigned_by_propagation + fs.completed + fs.residual;
            assert!((total - 1.0).abs() < 1e-12, "{ablation:?}: {fs:?}");
        }
        if ablation.complete_every_frame {
            assert!(
                stats.frames[1..].iter().all(|f| f.residual == 0.0),
                "{stats:?}"
            );
        }
    }
}

/// Mean |Δ log luminance| of the reflectance between consecutive frames after warping frame
/// t + 1 onto frame t by the true flow, over the pixels where the flow is known.
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

/// Measured 2026-12-04: flicker 0.0275 against 0.0902 for per-frame Retinex.
#[test]
fn flicker_is_below_per_frame_retinex_on_the_rendered_fixture() {
    let (_, _, ours, theirs) = fixture_scores();
    assert!(
        ours < 0.5 * theirs,
        "flicker: ours {ours:.4}, per-frame Retinex {theirs:.4}"
    );
}

/// The goal, reached on the fixture by a hair: measured 2026-12-04, mean LMSE 0.0802
/// against 0.0803 for per-frame Retinex (frame 0 is the same decomposition, 0.0764). It failed
/// (0.0806) when completion took every unassigned pixel of a stopping frame.
#[test]
fn lmse_is_below_per_frame_retinex_on_the_rendered_fixture() {
    let (ours, theirs, _, _) = fixture_scores();
    assert!(
        ours < theirs,
        "LMSE: ours {ours:.4}, per-frame Retinex {theirs:.4}"
    );
}

#[test]
fn the_completed_region_is_the_unassigned_part_of_the_tripping_windows() {
    use super::passes::stop_region;
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for trial in 0..30 {
        let (w, h) = (rng.random_range(3..20usize), rng.random_range(3..16usize));
        let m = rng.random_range(1..8u32);
        let alpha = rng.random_range(0.3..0.95);
        // Assigned everywhere but a few random rectangles.
        let mut data = vec![true; w * h];
        for _ in 0..rng.random_range(0..4) {
            let (x0, y0) = (rng.random_range(0..w), rng.random_range(0..h));
            let (x1, y1) = (rng.random_range(x0..w), rng.random_range(y0..h));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    data[y * w + x] = rng.random_bool(0.05);
                }
            }
        }
        let mask = Mask::from_vec(w as u32, h as u32, data.clone()).unwrap();
        let got = stop_region(&mask, m, alpha).unwrap();
        // Brute force: every window inside the frame (clipped to it when smaller).
        let (mw, mh) = ((m as usize).min(w), (m as usize).min(h));
        let mut expect = vec![false; w * h];
        let mut any = false;
        for y0 in 0..=h - mh {
            for x0 in 0..=w - mw {
                let cells = || (y0..y0 + mh).flat_map(|y| (x0..x0 + mw).map(move |x| y * w + x));
                let unassigned = cells().filter(|&i| !data[i]).count();
                if unassigned as f64 > alpha * (mw * mh) as f64 {
                    any = true;
                    for i in cells().filter(|&i| !data[i]) {
                        expect[i] = true;
                    }
                }
            }
        }
        assert_eq!(got.is_some(), any, "trial {trial}");
        if let Some(got) = got {
            assert_eq!(
                got, expect,
                "trial {trial}: {w}x{h}, m = {m}, alpha = {alpha}"
            );
        }
    }
}

#[test]
fn one_frame_and_progress() {
    let (frames, _) = translating(1, 16, 12, 1);
    let (out, stats, _dir) = run(&frames, &params());
    assert_product(&frames, &out);
    assert_eq!(stats.frames.len(), 1);
    assert_eq!(stats.frames[0].completed, 1.0);

    // Progress goes from 0 to 1 without going back.
    let (frames, _) = translating(4, 16, 12, 1);
    let dir = tempfile::tempdir().unwrap();
    let source = source_of(dir.path(), &frames);
    let mut seen: Vec<f32> = Vec::new();
    decompose_video(
        &source,
        &Strokes::default(),
        &params(),
        &dir.path().join("scratch"),
        &mut Vec::new(),
        &mut |p| seen.push(p.fraction),
    )
    .unwrap();
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
    assert!(
        seen[0] >= 0.0 && (seen.last().unwrap() - 1.0).abs() < 1e-6,
        "{seen:?}"
    );
}

#[test]
fn first_frame_strokes_reach_the_retinex() {
    let (frames, _) = translating(2, 24, 16, 1);
    let dir = tempfile::tempdir().unwrap();
    let source = source_of(dir.path(), &frames);
    let region = Mask::from_fn(24, 16, |x, y| x < 12 && y < 8);
    let strokes = Strokes {
        constant_shading: vec![region.clone()],
        ..Default::default()
    };
    let mut out: Vec<OwnedFrame> = Vec::new();
    let scratch = dir.path().join("scratch");
    decompose_video(
        &source,
        &strokes,
        &params(),
        &scratch,
        &mut out,
        &mut |_| {},
    )
    .unwrap();
    let spread = |out: &[OwnedFrame]| {
        let (lo, hi) = (0..region.data().len())
            .filter(|&i| region.at(i))
            .map(|i| out[0].shading.px(i)[0])
            .fold((f32::MAX, 0.0f32), |(a, b), v| (a.min(v), b.max(v)));
        hi / lo - 1.0
    };
    let with = spread(&out);
    // Without the stroke, more of the light's fall-off shows there.
    let (out, _, _d) = run(&frames, &params());
    let without = spread(&out);
    assert!(
        with < 0.5 * without,
        "relative spread of the shading under the stroke: {with} with, {without} without"
    );
}
