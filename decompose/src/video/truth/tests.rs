use std::path::{Path, PathBuf};

use super::*;
use crate::video::flow::{TvL1FlowParams, flow as tvl1_flow};

/// Bounds on TV-L1's endpoint error against the fixture's true flow, measured 2026-12-04:
/// 0.160-0.189 px per pair (mean 0.175), where the zero flow is 0.56-0.61 px off and the true
/// flow with its sign flipped 1.15-1.27 px.
const BOUND_PAIR: f64 = 0.25;
const BOUND_MEAN: f64 = 0.2;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/video/tiny")
}

/// A copy of the fixture in a temporary folder, to break.
fn fixture_copy() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    for sub in ["input", "reflectance", "shading", "flow"] {
        std::fs::create_dir(tmp.path().join(sub)).unwrap();
        for e in std::fs::read_dir(fixture().join(sub)).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), tmp.path().join(sub).join(e.file_name())).unwrap();
        }
    }
    std::fs::copy(
        fixture().join("sequence.json"),
        tmp.path().join("sequence.json"),
    )
    .unwrap();
    tmp
}

fn format_path(e: &Error) -> &Path {
    match e {
        Error::Format { path, .. } => path,
        e => panic!("expected Error::Format, got {e:?}"),
    }
}

#[test]
fn magic_is_the_middlebury_float() {
    assert_eq!(f32::from_le_bytes(*FLO_MAGIC), 202021.25);
}

#[test]
fn flo_round_trip_is_exact() {
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("a.flo");
    let f = Flow::from_fn(5, 3, |x, y| {
        if (x, y) == (2, 1) {
            [UNKNOWN_FLOW, UNKNOWN_FLOW]
        } else {
            [x as f32 * 0.37 - 1.0, -(y as f32) * 1.25 + 0.1]
        }
    });
    write_flo(&path, &f).unwrap();
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 12 + 5 * 3 * 8);
    let g = read_flo(&path).unwrap();
    assert_eq!(f, g);
    assert_eq!(known_mask(&g).iter().filter(|&&k| !k).count(), 1);
    assert!(!known_mask(&g)[5 + 2]);
}

#[test]
fn flo_layout_is_interleaved_rows_top_to_bottom() {
    // Written by hand: 2x1, pixel 0 = (1, 2), pixel 1 = (3, -4).
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("b.flo");
    let mut bytes = b"PIEH".to_vec();
    bytes.extend_from_slice(&2i32.to_le_bytes());
    bytes.extend_from_slice(&1i32.to_le_bytes());
    for v in [1.0f32, 2.0, 3.0, -4.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&path, bytes).unwrap();
    let f = read_flo(&path).unwrap();
    assert_eq!(f.dims(), (2, 1));
    assert_eq!(f.get(0, 0), [1.0, 2.0]);
    assert_eq!(f.get(1, 0), [3.0, -4.0]);
}

#[test]
fn malformed_flo_files_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let good = tmp.path().join("good.flo");
    write_flo(&good, &Flow::zeros(4, 3)).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("magic.flo", [b"PIEX".as_slice(), &bytes[4..]].concat()),
        ("header.flo", bytes[..7].to_vec()),
        ("data.flo", bytes[..bytes.len() - 1].to_vec()),
        ("trailing.flo", [bytes.as_slice(), &[0]].concat()),
        ("size.flo", {
            let mut b = bytes.clone();
            b[4..8].copy_from_slice(&0i32.to_le_bytes());
            b
        }),
        ("negative.flo", {
            let mut b = bytes.clone();
            b[8..12].copy_from_slice(&(-3i32).to_le_bytes());
            b
        }),
    ];
    for (name, b) in cases {
        let path = tmp.path().join(name);
        std::fs::write(&path, b).unwrap();
        let e = read_flo(&path).unwrap_err();
        assert_eq!(format_path(&e), path, "{name}");
        assert!(e.to_string().contains(name), "{e}");
    }
    assert!(matches!(
        read_flo(tmp.path().join("missing.flo")),
        Err(Error::Io { .. })
    ));
    assert!(write_flo(tmp.path().join("empty.flo"), &Flow::zeros(0, 4)).is_err());
}

#[test]
fn known_endpoint_error_skips_unknown_pixels() {
    let truth = Flow::from_fn(3, 1, |x, _| {
        if x == 1 {
            [UNKNOWN_FLOW, 0.0]
        } else {
            [1.0, 0.0]
        }
    });
    let est = Flow::from_fn(3, 1, |x, _| [1.0 + x as f32, 0.0]);
    // Pixels 0 and 2: errors 0 and 2.
    assert_eq!(known_endpoint_error(&est, &truth).unwrap(), (1.0, 2));
    assert!(known_endpoint_error(&Flow::zeros(2, 1), &truth).is_err());
    assert!(!is_known(f32::NAN, 0.0));
    assert!(is_known(-1e8, 1e8));
}

#[test]
fn the_fixture_loads_and_input_is_reflectance_times_shading() {
    let t = load_truth(fixture()).unwrap();
    assert_eq!(t.len(), 8);
    assert_eq!(t.size(), (64, 48));
    assert_eq!(t.name(3), "000003.png");
    let info = t.info().unwrap();
    assert_eq!(info.frames, 8);
    assert_eq!(info.motion.as_deref(), Some("camera"));
    assert!(t.has_flow());
    let mut worst = 0.0f32;
    for i in 0..t.len() {
        let (input, r, s) = (
            t.input(i).unwrap(),
            t.reflectance(i).unwrap(),
            t.shading(i).unwrap(),
        );
        assert_eq!((input.channels(), r.channels(), s.channels()), (3, 3, 1));
        for p in 0..input.len() {
            for c in 0..3 {
                worst = worst.max((r.px(p)[c] * s.px(p)[0] - input.px(p)[c]).abs());
            }
        }
    }
    // Three 16-bit roundings: |Q(R)Q(S) - Q(RS)| stays within 1.5 steps (the script measured
    // 1.25 on this fixture).
    assert!(worst * 65535.0 <= 1.5, "{} 16-bit steps", worst * 65535.0);
    assert!(t.flow(6).is_ok());
    assert!(t.flow(7).is_err());
    assert!(t.input(8).is_err() && t.reflectance(8).is_err() && t.shading(8).is_err());
}

#[test]
fn estimated_flow_matches_the_true_flow_on_the_fixture() {
    // TV-L1 (defaults) on every consecutive pair of the fixture's input, against the true flow
    // on its known pixels; the true flow with its sign flipped (the opposite convention) and
    // the zero flow must both be much further away.
    let t = load_truth(fixture()).unwrap();
    let (w, h) = t.size();
    let (mut sum, mut sum_zero) = (0.0, 0.0);
    for i in 0..t.len() - 1 {
        let truth = t.flow(i).unwrap();
        let est = tvl1_flow(
            &t.input(i).unwrap(),
            &t.input(i + 1).unwrap(),
            &TvL1FlowParams::default(),
        )
        .unwrap();
        let (epe, n) = known_endpoint_error(&est, &truth).unwrap();
        let (zero, _) = known_endpoint_error(&Flow::zeros(w, h), &truth).unwrap();
        let flipped = Flow::from_vecs(
            w,
            h,
            truth
                .u()
                .iter()
                .map(|&u| if is_known(u, 0.0) { -u } else { u })
                .collect(),
            truth
                .v()
                .iter()
                .map(|&v| if is_known(0.0, v) { -v } else { v })
                .collect(),
        )
        .unwrap();
        let (wrong, _) = known_endpoint_error(&est, &flipped).unwrap();
        eprintln!(
            "pair {i}: EPE {epe:.3} px, sign flipped {wrong:.3} px, zero flow {zero:.3} px, \
             {n} known pixels"
        );
        assert!(
            n as f64 > 0.75 * (w * h) as f64,
            "pair {i}: {n} known pixels"
        );
        assert!(epe < BOUND_PAIR, "pair {i}: EPE {epe} px");
        assert!(epe < 0.4 * zero && epe < 0.4 * wrong, "pair {i}");
        sum += epe;
        sum_zero += zero;
    }
    let pairs = (t.len() - 1) as f64;
    eprintln!(
        "mean EPE {:.3} px, zero flow {:.3} px",
        sum / pairs,
        sum_zero / pairs
    );
    assert!(sum / pairs < BOUND_MEAN, "mean EPE {} px", sum / pairs);
}

#[test]
fn missing_and_mismatched_files_are_named() {
    // A missing reflectance frame.
    let tmp = fixture_copy();
    let gone = tmp.path().join("reflectance/000003.png");
    std::fs::remove_file(&gone).unwrap();
    match load_truth(tmp.path()).unwrap_err() {
        Error::Frame { index, path, .. } => assert_eq!((index, path), (3, gone)),
        e => panic!("{e:?}"),
    }

    // A shading frame of another size.
    let tmp = fixture_copy();
    let odd = tmp.path().join("shading/000002.png");
    crate::io::save(
        &odd,
        &Image::new(10, 10, 1),
        crate::io::Encoding::Linear,
        crate::io::Depth::Sixteen,
    )
    .unwrap();
    match load_truth(tmp.path()).unwrap_err() {
        Error::FrameSize {
            index, path, got, ..
        } => assert_eq!((index, path, got), (2, odd, (10, 10))),
        e => panic!("{e:?}"),
    }

    // A flow file with a bad magic number, one missing, one too many.
    let tmp = fixture_copy();
    let bad = tmp.path().join("flow/000001.flo");
    let mut bytes = std::fs::read(&bad).unwrap();
    bytes[0] = b'X';
    std::fs::write(&bad, bytes).unwrap();
    match load_truth(tmp.path()).unwrap_err() {
        Error::Frame {
            index,
            path,
            source,
        } => {
            assert_eq!((index, &path), (1, &bad));
            assert_eq!(format_path(&source), bad);
        }
        e => panic!("{e:?}"),
    }
    let tmp = fixture_copy();
    let gone = tmp.path().join("flow/000006.flo");
    std::fs::remove_file(&gone).unwrap();
    match load_truth(tmp.path()).unwrap_err() {
        Error::Frame { index, path, .. } => assert_eq!((index, path), (6, gone)),
        e => panic!("{e:?}"),
    }
    let tmp = fixture_copy();
    std::fs::copy(
        tmp.path().join("flow/000000.flo"),
        tmp.path().join("flow/000007.flo"),
    )
    .unwrap();
    assert_eq!(
        format_path(&load_truth(tmp.path()).unwrap_err()),
        tmp.path().join("flow")
    );

    // sequence.json disagreeing with the frames, and malformed.
    let tmp = fixture_copy();
    let json = tmp.path().join("sequence.json");
    std::fs::write(&json, r#"{"frames": 9, "width": 64, "height": 48}"#).unwrap();
    assert_eq!(format_path(&load_truth(tmp.path()).unwrap_err()), json);
    std::fs::write(&json, "{").unwrap();
    assert_eq!(format_path(&load_truth(tmp.path()).unwrap_err()), json);

    // No flow and no sequence.json: still a valid layout.
    std::fs::remove_file(&json).unwrap();
    std::fs::remove_dir_all(tmp.path().join("flow")).unwrap();
    let t = load_truth(tmp.path()).unwrap();
    assert!(!t.has_flow() && t.info().is_none() && t.flow(0).is_err());

    // No input at all.
    let empty = tempfile::tempdir().unwrap();
    assert!(matches!(
        load_truth(empty.path()),
        Err(Error::NoFrames { .. })
    ));
}

/// The rendered data set (`python3 scripts/render_video.py`, git-ignored), when present: every
/// sequence loads, R × S = input on every frame, and TV-L1's endpoint error against the true
/// flow per sequence (the figures of `docs/video-data.md`). Run with
/// `cargo test -p decompose --lib video::truth::tests::rendered -- --ignored --nocapture`.
#[test]
#[ignore = "needs .cache/rendered-video (scripts/render_video.py); minutes"]
fn rendered_sequences() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../.cache/rendered-video");
    let mut seqs: Vec<PathBuf> = ["tune", "test"]
        .iter()
        .filter_map(|s| std::fs::read_dir(root.join(s)).ok())
        .flatten()
        .map(|e| e.unwrap().path())
        .collect();
    seqs.sort();
    assert!(!seqs.is_empty(), "nothing under {}", root.display());
    for dir in seqs {
        let t = load_truth(&dir).unwrap();
        let (w, h) = t.size();
        let mut worst = 0.0f32;
        let (mut epe, mut zero, mut known) = (0.0, 0.0, 0.0);
        let mut prev = t.input(0).unwrap();
        for i in 0..t.len() {
            let (input, r, s) = (
                t.input(i).unwrap(),
                t.reflectance(i).unwrap(),
                t.shading(i).unwrap(),
            );
            for p in 0..input.len() {
                for c in 0..3 {
                    worst = worst.max((r.px(p)[c] * s.px(p)[0] - input.px(p)[c]).abs());
                }
            }
            if i > 0 {
                let truth = t.flow(i - 1).unwrap();
                let est = tvl1_flow(&prev, &input, &TvL1FlowParams::default()).unwrap();
                let (e, n) = known_endpoint_error(&est, &truth).unwrap();
                epe += e;
                zero += known_endpoint_error(&Flow::zeros(w, h), &truth).unwrap().0;
                known += n as f64 / (w * h) as f64;
            }
            prev = input;
        }
        let pairs = (t.len() - 1) as f64;
        let info = t.info().unwrap();
        eprintln!(
            "{}: {} frames {}x{}, moving {}; |RS - I| <= {:.2} 16-bit steps; TV-L1 EPE {:.3} px, \
             zero flow {:.3} px, known {:.1}%",
            dir.display(),
            t.len(),
            w,
            h,
            info.motion.as_deref().unwrap_or("?"),
            worst * 65535.0,
            epe / pairs,
            zero / pairs,
            100.0 * known / pairs
        );
        assert!(worst * 65535.0 <= 1.5);
    }
}
