//! The method on synthetic sequences: invariants, bookkeeping, scratch files, bad inputs.

use super::*;

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
    (lit(&refl), refl)
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
    (lit(&refl), refl)
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
    let spread = |out: &[OwnedFrame]| shading_spread(&out[0], &region);
    let with = spread(&out);
    // Without the stroke, more of the light's fall-off shows there.
    let (out, _, _d) = run(&frames, &params());
    let without = spread(&out);
    assert!(
        with < 0.5 * without,
        "relative spread of the shading under the stroke: {with} with, {without} without"
    );
}
