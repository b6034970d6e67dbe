//! `decompose video` and `decompose eval-video` end to end through the real binary, on the
//! committed tiny rendered sequence (`fixtures/video/tiny`: 8 frames of 64×48, exact ground
//! truth and flow) and on broken copies of it.

use std::path::{Path, PathBuf};
use std::process::Command;

use decompose::io::{LoadOptions, load_gray, load_rgb};
use decompose::video::labels_io::load_labels;

mod common;
use common::{decompose, os};

fn tiny() -> PathBuf {
    common::fixture("video/tiny")
}

/// A copy of the fixture's input frames in `dir/frames`.
fn copy_frames(dir: &Path) -> PathBuf {
    let to = dir.join("frames");
    std::fs::create_dir_all(&to).unwrap();
    for e in std::fs::read_dir(tiny().join("input")).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
    to
}

/// `decompose video INPUT --out OUT --linear -q EXTRA…`.
fn run_video(input: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        os("video"),
        input.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--linear"),
        os("-q"),
    ];
    args.extend(extra.iter().map(|a| os(a)));
    decompose(&args)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn video_writes_every_layer_of_every_frame_and_the_product_is_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = run_video(
        &tiny().join("input"),
        &out,
        &["--linear-output", "--depth", "16"],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(names(dir.path()), ["out"], "no partial folder remains");
    let frames: Vec<String> = (0..8).map(|i| format!("{i:06}.png")).collect();
    for sub in ["clusters", "labels"] {
        assert_eq!(names(&out.join(sub)), frames, "{sub}");
    }
    let linear = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["frames"].as_array().unwrap().len(), 8);
    // Step 8 ran on every frame.
    assert_eq!(stats["per_frame_blend"], true);
    // Step 8's weights: the single view's β and the clustering method's β_c.
    let weights = &stats["blend_weights"];
    let (view, clustering) = (weights["view"].as_f64(), weights["clustering"].as_f64());
    assert!(view.is_some_and(|v| v > 0.0 && v < 1.0), "{weights}");
    assert!(
        clustering.is_some_and(|c| c > 0.0 && view.unwrap() + c < 1.0),
        "{weights}"
    );
    for f in stats["frames"].as_array().unwrap() {
        assert!(f["view_ms"].as_f64().unwrap() > 0.0, "{f}");
    }
    // Their wall time is part of the total.
    let views_ms = stats["views_ms"].as_f64().unwrap();
    assert!(views_ms > 0.0 && views_ms < stats["total_ms"].as_f64().unwrap());
    let clusters = stats["clusters"].as_u64().unwrap() as usize;
    // The border levelling ran: touching pairs of clusters exist in a scene of several albedos.
    assert!(
        stats["levels"]["pairs"].as_u64().unwrap() >= 1,
        "{}",
        stats["levels"]
    );
    assert!(
        stats["levels"]["mean_abs_offset"]
            .as_f64()
            .unwrap()
            .is_finite()
    );
    for (i, name) in frames.iter().enumerate() {
        for sub in ["reflectance", "shading"] {
            assert!(out.join(sub).join(name).exists(), "{sub}/{name}");
        }
        // The float TIFFs keep the exact layers: their product is the linear input.
        let tiff = name.replace(".png", ".tiff");
        let r = load_rgb(out.join("reflectance").join(&tiff), linear).unwrap();
        let s = load_gray(out.join("shading").join(&tiff), linear).unwrap();
        let input = load_rgb(tiny().join("input").join(name), linear).unwrap();
        for p in 0..input.len() {
            for c in 0..3 {
                let (got, want) = (r.px(p)[c] * s.px(p)[0], input.px(p)[c]);
                assert!((got - want).abs() <= 1e-5 + 1e-4 * want, "frame {i}");
            }
        }
        // Every pixel has a cluster, among those the stats count.
        let labels = load_labels(out.join("labels").join(name)).unwrap();
        assert_eq!((labels.width, labels.height), (64, 48));
        assert!(labels.data.iter().all(|&l| (l as usize) < clusters));
        let png = image::open(out.join("reflectance").join(name)).unwrap();
        assert!(matches!(png, image::DynamicImage::ImageRgb16(_)));
    }
}

/// `decompose video` on the fixture into `dir/name` with `--linear-output` and `extra`; it must
/// succeed. Returns the output folder.
fn linear_run(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let o = run_video(
        &tiny().join("input"),
        &out,
        &[&["--linear-output"], extra].concat(),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

#[test]
fn no_blend_gives_the_propagated_decomposition() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| linear_run(dir.path(), name, extra);
    let (blended, thesis) = (run("blended", &[]), run("thesis", &["--no-blend"]));
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(thesis.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["per_frame_blend"], false);
    assert!(stats["blend_weights"].is_null());
    assert_eq!(stats["views_ms"].as_f64().unwrap(), 0.0);
    for f in stats["frames"].as_array().unwrap() {
        assert_eq!(f["view_ms"].as_f64().unwrap(), 0.0, "{f}");
        assert_eq!(f["fusion_ms"].as_f64().unwrap(), 0.0, "{f}");
    }
    // The blend changes the shading of a later frame (the first frame's is the Retinex's
    // blended with the single view, too).
    frame_5_differs(&blended, &thesis, "shading");
}

/// Frame 5's `layer` (the linear TIFF) of two outputs differs by more than 0.1% on more than
/// a tenth of the pixels (first channel).
fn frame_5_differs(a: &Path, b: &Path, layer: &str) {
    let linear = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let load = |out: &Path| load_rgb(out.join(layer).join("000005.tiff"), linear).unwrap();
    let (a, b) = (load(a), load(b));
    let differ = (0..a.len())
        .filter(|&p| (a.px(p)[0] / b.px(p)[0] - 1.0).abs() > 1e-3)
        .count();
    assert!(
        differ > a.len() / 10,
        "{layer}: {differ} of {} pixels differ",
        a.len()
    );
}

/// [`linear_run`], also returning its `stats.json`.
fn run_with_stats(dir: &Path, name: &str, extra: &[&str]) -> (PathBuf, serde_json::Value) {
    let out = linear_run(dir, name, extra);
    let text = std::fs::read_to_string(out.join("stats.json")).unwrap();
    (out, serde_json::from_str(&text).unwrap())
}

#[test]
fn the_reflectance_radius_is_recorded_and_changes_the_reflectance() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let (out, stats) = run_with_stats(dir.path(), name, extra);
        (out, stats["reflectance_radius"].as_f64().unwrap())
    };
    let (pooled, default_radius) = run("pooled", &[]);
    let (exact, zero) = run("exact", &["--reflectance-radius", "0"]);
    assert_eq!(default_radius, 90.0);
    assert_eq!(zero, 0.0);
    // Frame 5 is propagated (frame 0 is the first frame's own decomposition): the colour ball
    // changes its reflectance on many pixels.
    frame_5_differs(&pooled, &exact, "reflectance");
    // Out of range or not a number: a clear error before any work.
    rejects(
        dir.path(),
        "--reflectance-radius",
        &["-1", "nan", "500", "wide"],
    );
}

/// `decompose video` with `FLAG=value` for each bad value: a clear error naming the flag, no
/// panic, no output folder.
fn rejects(dir: &Path, flag: &str, bad_values: &[&str]) {
    let input = tiny().join("input");
    for bad in bad_values {
        let out = dir.join(format!("bad{bad}"));
        let arg = format!("{flag}={bad}");
        let o = run_video(&input, &out, &[arg.as_str()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{bad}");
        assert!(err.contains(flag), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists());
    }
}

/// `--flow-max-pixels N`: recorded in `stats.json`; a cap at the frames' size (64×48 = 3072)
/// changes nothing, one below it (the flow solved at 32×24 and upsampled) changes the
/// propagated frames (frame 0 too, through the levels and step 8, which see the whole video);
/// 0 or not a number is a clear error.
#[test]
fn the_flow_cap_is_recorded_and_only_acts_on_larger_frames() {
    let dir = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let (out, stats) = run_with_stats(dir.path(), name, extra);
        (out, stats["flow_max_pixels"].clone())
    };
    let (full, none) = run("full", &[]);
    let (roomy, at_size) = run("roomy", &["--flow-max-pixels", "3072"]);
    let (coarse, small) = run("coarse", &["--flow-max-pixels", "1000"]);
    assert!(none.is_null(), "{none}");
    assert_eq!(at_size.as_u64(), Some(3072));
    assert_eq!(small.as_u64(), Some(1000));
    let linear = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let frames = |out: &Path| -> Vec<Vec<f32>> {
        (0..8)
            .map(|t| {
                let path = out.join("reflectance").join(format!("{t:06}.tiff"));
                load_rgb(path, linear).unwrap().into_vec()
            })
            .collect()
    };
    let (full, roomy, coarse) = (frames(&full), frames(&roomy), frames(&coarse));
    // (Compared as booleans: a failing `assert_eq!` would print 8 frames of floats.)
    assert!(
        full == roomy,
        "a cap at the frames' size must change nothing"
    );
    let changed = (1..8).filter(|&t| full[t] != coarse[t]).count();
    assert!(
        changed >= 4,
        "the coarse flow changed {changed} of 7 propagated frames"
    );
    rejects(dir.path(), "--flow-max-pixels", &["0", "-5", "big"]);
}

#[test]
fn existing_output_is_kept_unless_forced() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "mine").unwrap();
    let run = |force: bool| {
        let extra: &[&str] = if force { &["--force"] } else { &[] };
        run_video(&tiny().join("input"), &out, extra)
    };
    let o = run(false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        err.contains("not empty") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(names(&out), ["keep.txt"]);
    let o = run(true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.join("keep.txt").exists());
    assert!(out.join("stats.json").exists());
    assert_eq!(names(dir.path()), ["out"]);
}

/// Runs `decompose video` on `input` (made inside a fresh folder by `make`) with the `extra`
/// arguments; the run must fail with an error containing every `needle` and leave nothing but
/// what `make` made behind.
fn fails_naming(make: impl Fn(&Path) -> PathBuf, extra: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let input = make(dir.path());
    let before = names(dir.path());
    let out = dir.path().join("out");
    // `{dir}` in an extra argument stands for the fresh folder.
    let extra: Vec<String> = extra
        .iter()
        .map(|s| s.replace("{dir}", &dir.path().to_string_lossy()))
        .collect();
    let extra: Vec<&str> = extra.iter().map(String::as_str).collect();
    let o = run_video(&input, &out, &extra);
    let err = String::from_utf8_lossy(&o.stderr);
    eprintln!("{err}");
    assert!(!o.status.success(), "should fail: {needles:?}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in {err:?}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        names(dir.path()),
        before,
        "no output or partial folder may remain"
    );
}

#[test]
fn bad_inputs_fail_naming_the_frame_and_leave_no_output() {
    // An empty folder.
    fails_naming(
        |d| {
            let p = d.join("empty");
            std::fs::create_dir(&p).unwrap();
            p
        },
        &[],
        &["no frames", "empty"],
    );
    // A frame of another size.
    fails_naming(
        |d| {
            let f = copy_frames(d);
            image::RgbImage::new(40, 48)
                .save(f.join("000005.png"))
                .unwrap();
            f
        },
        &[],
        &["frame 5", "000005.png", "(40, 48)"],
    );
    // A frame that is not an image at all.
    fails_naming(
        |d| {
            let f = copy_frames(d);
            std::fs::write(f.join("000003.png"), b"not a png").unwrap();
            f
        },
        &[],
        &["frame 3", "000003.png"],
    );
    // A frame whose header is fine but whose data is cut off: found only when the method
    // reaches it, after the first frames' layers were written.
    fails_naming(
        |d| {
            let f = copy_frames(d);
            let p = f.join("000006.png");
            let bytes = std::fs::read(&p).unwrap();
            std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
            f
        },
        &[],
        &["frame 6", "000006.png"],
    );
    // A file that is not a video.
    fails_naming(
        |d| {
            let p = d.join("clip.mp4");
            std::fs::write(&p, b"this is text, not a video").unwrap();
            p
        },
        &[],
        &["clip.mp4"],
    );
    // --video without the encoder.
    fails_naming(
        |_| tiny().join("input"),
        &["--video", "--ffmpeg", "/nonexistent/ffmpeg"],
        &["/nonexistent/ffmpeg", "not installed"],
    );
    // A stroke mask of another size.
    fails_naming(
        |d| {
            let p = d.join("mask.png");
            image::GrayImage::from_pixel(10, 10, image::Luma([255]))
                .save(&p)
                .unwrap();
            tiny().join("input")
        },
        &["--albedo-stroke", "{dir}/mask.png"],
        &["mask.png", "10x10", "64x48"],
    );
}

#[test]
fn eval_video_gives_finite_figures_for_the_per_frame_baselines_on_the_fixture() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("scores.json");
    let sheet = dir.path().join("sheet.png");
    let o = decompose(&[
        os("eval-video"),
        os("--truth"),
        tiny().as_os_str(),
        os("--method"),
        os("retinex,clustering"),
        os("--json"),
        json.as_os_str(),
        os("--contact-sheet"),
        sheet.as_os_str(),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let methods = &v["tiny"]["methods"];
    for m in ["per-frame retinex", "per-frame clustering"] {
        let lmse = methods[m]["lmse"].as_f64().unwrap();
        let flicker = methods[m]["flicker"].as_f64().unwrap();
        assert!(lmse.is_finite() && lmse > 0.0 && lmse < 1.0, "{m}: {lmse}");
        assert!(flicker.is_finite() && flicker > 0.0, "{m}: {flicker}");
        assert_eq!(methods[m]["lmse_frames"].as_array().unwrap().len(), 8);
        assert_eq!(methods[m]["flicker_pairs"].as_array().unwrap().len(), 7);
        // The per-frame methods flicker more than the truth does along the true flow.
        assert!(
            flicker > methods["truth"]["flicker"].as_f64().unwrap(),
            "{m}"
        );
    }
    assert_eq!(methods["truth"]["lmse"].as_f64().unwrap(), 0.0);
    // Input, truth reflectance and shading, then two rows per method; five frames.
    let img = image::open(&sheet).unwrap();
    assert_eq!(img.height(), 7 * (48 + 4) + 4);
    assert_eq!(img.width(), 5 * (64 + 4) + 4);
}

#[test]
fn eval_video_on_footage_without_truth_uses_the_estimated_flow() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("scores.json");
    let sheet = dir.path().join("sheet.png");
    let o = decompose(&[
        os("eval-video"),
        os("--real"),
        tiny().join("input").as_os_str(),
        os("--linear"),
        os("--frames"),
        os("4"),
        os("--method"),
        os("retinex"),
        os("--json"),
        json.as_os_str(),
        os("--contact-sheet"),
        sheet.as_os_str(),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let r = &v["input"];
    assert_eq!(r["frames"], 4);
    assert_eq!(r["flow"], "estimated flow (TV-L1)");
    let m = &r["methods"]["per-frame retinex"];
    assert!(m["flicker"].as_f64().unwrap().is_finite());
    assert!(m["lmse_frames"].as_array().unwrap().is_empty());
    assert!(sheet.exists());
}

#[test]
fn video_flag_encodes_both_layers_when_ffmpeg_is_installed() {
    let has_ffmpeg = Command::new("ffmpeg")
        .arg("-version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_ffmpeg {
        eprintln!("skipped: no ffmpeg on PATH");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = decompose(&[
        os("video"),
        tiny().join("input").as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--linear"),
        os("--video"),
        os("--fps"),
        os("10"),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for layer in ["reflectance", "shading"] {
        let mp4 = out.join(format!("{layer}.mp4"));
        let probe = Command::new("ffprobe")
            .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
            .args([
                "-show_entries",
                "stream=codec_name,pix_fmt,nb_read_frames,r_frame_rate",
            ])
            .args(["-of", "default=noprint_wrappers=1"])
            .arg(&mp4)
            .output();
        let Ok(probe) = probe else {
            assert!(std::fs::metadata(&mp4).unwrap().len() > 0);
            continue;
        };
        let text = String::from_utf8_lossy(&probe.stdout);
        for want in [
            "codec_name=h264",
            "pix_fmt=yuv420p",
            "nb_read_frames=8",
            "r_frame_rate=10/1",
        ] {
            assert!(text.contains(want), "{layer}: {want} not in {text}");
        }
    }
}
