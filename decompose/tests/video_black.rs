//! `decompose video` on footage that opens on black (black leader, a fade from black): the
//! black frames come out black, the shading PNGs keep the scale of the first lit frame, and
//! `stats.json` says which frames were black; the edits are decided on the first lit frame;
//! `decompose eval-video --real` scores footage with a cut through black. Through the real
//! binary, on the committed tiny sequence (`fixtures/video/tiny`) with black frames put in.

use std::path::{Path, PathBuf};

use decompose::io::{LoadOptions, load_rgb};

mod common;
use common::{decompose, os};

fn tiny_input() -> PathBuf {
    common::fixture("video/tiny/input")
}

/// The fixture's 8 frames as frames 2–9 of `dir/led`, after two black frames of its size.
fn with_black_leader(dir: &Path) -> PathBuf {
    let to = dir.join("led");
    std::fs::create_dir_all(&to).unwrap();
    for t in 0..8 {
        std::fs::copy(
            tiny_input().join(format!("{t:06}.png")),
            to.join(format!("{:06}.png", t + 2)),
        )
        .unwrap();
    }
    for t in 0..2 {
        decompose::io::save_rgb8(to.join(format!("{t:06}.png")), 64, 48, vec![0; 64 * 48 * 3])
            .unwrap();
    }
    to
}

fn run(input: &Path, out: &Path) -> serde_json::Value {
    let o = decompose(&[
        os("video"),
        input.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_str(&std::fs::read_to_string(out.join("stats.json")).unwrap()).unwrap()
}

#[test]
fn black_leader_comes_out_black_and_the_rest_as_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let led = run(&with_black_leader(dir.path()), &dir.path().join("led_out"));
    let plain = run(&tiny_input(), &dir.path().join("plain_out"));

    assert_eq!(led["first_lit_frame"], 2);
    assert_eq!(plain["first_lit_frame"], 0);
    let black: Vec<bool> = led["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["black"].as_bool().unwrap())
        .collect();
    assert_eq!(
        black,
        [
            true, true, false, false, false, false, false, false, false, false
        ]
    );
    // The shading PNGs' scale comes from the first lit frame, as without the leader (from a
    // black frame it would be 1 / 0).
    let (scale, plain_scale) = (
        led["shading_scale"].as_f64().unwrap(),
        plain["shading_scale"].as_f64().unwrap(),
    );
    assert!(
        (scale - plain_scale).abs() <= 1e-6 * plain_scale,
        "{scale} against {plain_scale}"
    );

    let opts = LoadOptions::default();
    let layer = |out: &str, sub: &str, t: usize| {
        load_rgb(
            dir.path().join(out).join(sub).join(format!("{t:06}.png")),
            opts,
        )
        .unwrap()
    };
    for t in 0..2 {
        for sub in ["reflectance", "shading"] {
            let img = layer("led_out", sub, t);
            assert!(img.data().iter().all(|&v| v == 0.0), "{sub} of frame {t}");
        }
    }
    for t in 0..8 {
        for sub in ["reflectance", "shading"] {
            let (a, b) = (layer("led_out", sub, t + 2), layer("plain_out", sub, t));
            let largest = largest_difference(&a, &b);
            // One 8-bit level.
            assert!(
                largest <= 1.0 / 255.0 + 1e-6,
                "{sub} of frame {t}: {largest}"
            );
        }
    }
}

/// The largest difference between two images of one size.
fn largest_difference(a: &decompose::Image, b: &decompose::Image) -> f32 {
    a.data()
        .iter()
        .zip(b.data())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max)
}

#[test]
fn video_edits_are_decided_on_the_first_lit_frame() {
    let dir = tempfile::tempdir().unwrap();
    let led_out = dir.path().join("led_out");
    let plain_out = dir.path().join("plain_out");
    run(&with_black_leader(dir.path()), &led_out);
    run(&tiny_input(), &plain_out);
    let edit = |sub: &str, input: &Path, out: &Path, extra: &[&str]| {
        let mut args = vec![os("edit"), os(sub), input.as_os_str(), os("--out")];
        args.extend([out.as_os_str(), os("-q")]);
        args.extend(extra.iter().map(|a| os(a)));
        let o = decompose(&args);
        assert!(
            o.status.success(),
            "{sub}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let info: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("edit.json")).unwrap()).unwrap();
        info["decided_on_frame"].as_u64().unwrap()
    };
    for (sub, extra) in [
        ("video-stylise", &["--saturation", "1.5"][..]),
        ("video-material", &["--curve", "0:0,0.5:0.8,1:1"][..]),
    ] {
        let (a, b) = (dir.path().join(format!("{sub}-led")), dir.path().join(sub));
        assert_eq!(edit(sub, &led_out, &a, extra), 2, "{sub}");
        assert_eq!(edit(sub, &plain_out, &b, extra), 0, "{sub}");
        let frame = |d: &Path, t: usize| {
            load_rgb(d.join(format!("{t:06}.png")), LoadOptions::default()).unwrap()
        };
        for t in 0..2 {
            assert!(
                frame(&a, t).data().iter().all(|&v| v == 0.0),
                "{sub}: frame {t}"
            );
        }
        for t in 0..8 {
            let d = largest_difference(&frame(&a, t + 2), &frame(&b, t));
            // The edits read 8-bit layers, which may differ by one level (test above).
            assert!(d <= 0.02, "{sub}: frame {t} differs by {d}");
        }
    }
    // A first_lit_frame past the last frame is refused, naming it.
    let stats_path = led_out.join("stats.json");
    let mut stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats_path).unwrap()).unwrap();
    stats["first_lit_frame"] = 99.into();
    std::fs::write(&stats_path, stats.to_string()).unwrap();
    let out = dir.path().join("refused");
    let o = decompose(&[
        os("edit"),
        os("video-stylise"),
        led_out.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("first_lit_frame = 99"), "{err}");
    assert!(!out.exists());
}

#[test]
fn an_all_black_video_is_a_clear_error_and_leaves_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("black");
    std::fs::create_dir_all(&frames).unwrap();
    for t in 0..3 {
        decompose::io::save_rgb8(frames.join(format!("{t:06}.png")), 8, 6, vec![0; 8 * 6 * 3])
            .unwrap();
    }
    let out = dir.path().join("out");
    let o = decompose(&[
        os("video"),
        frames.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("every frame") && err.contains("black"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn eval_video_scores_footage_with_a_cut_through_black() {
    // The fixture with its frame 4 replaced by black: every method outputs that frame black,
    // and the flicker leaves out the two pairs around it.
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("cut");
    std::fs::create_dir_all(&frames).unwrap();
    for t in 0..8 {
        let to = frames.join(format!("{t:06}.png"));
        if t == 4 {
            decompose::io::save_rgb8(&to, 64, 48, vec![0; 64 * 48 * 3]).unwrap();
        } else {
            std::fs::copy(tiny_input().join(format!("{t:06}.png")), &to).unwrap();
        }
    }
    let json = dir.path().join("scores.json");
    let o = decompose(&[
        os("eval-video"),
        os("--real"),
        frames.as_os_str(),
        os("--json"),
        json.as_os_str(),
        os("--contact-sheet"),
        dir.path().join("sheet.png").as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scores: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let text = scores.to_string();
    for method in ["ours", "per-frame retinex", "per-frame clustering"] {
        let m = scores
            .as_object()
            .unwrap()
            .values()
            .find_map(|seq| seq["methods"].get(method))
            .unwrap_or_else(|| panic!("no {method} in {text}"));
        let pairs = m["flicker_pairs"].as_array().unwrap();
        assert_eq!(pairs.len(), 7, "{method}");
        assert!(
            pairs[3].is_null() && pairs[4].is_null(),
            "{method}: {pairs:?}"
        );
        assert!(
            pairs.iter().filter(|p| !p.is_null()).count() == 5,
            "{method}"
        );
        let flicker = m["flicker"].as_f64().unwrap();
        assert!(flicker.is_finite() && flicker > 0.0, "{method}: {flicker}");
    }
}
