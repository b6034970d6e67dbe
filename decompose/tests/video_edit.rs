//! `decompose edit video-*` through the real binary, on a tiny `decompose video`-style folder
//! written here: 3 frames of 16×12, a background cluster (id 0) and a 5×4 square (id 1)
//! moving 3 px right per frame, with the column it uncovers unassigned.
#![cfg(feature = "cli")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use decompose::Image;
use decompose::io::{Depth, Encoding, LoadOptions, save};

const W: u32 = 16;
const H: u32 = 12;
const FRAMES: usize = 3;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_decompose"))
}

fn in_square(t: usize, x: u32, y: u32) -> bool {
    let x0 = 2 + 3 * t as u32;
    (x0..x0 + 5).contains(&x) && (4..8).contains(&y)
}

/// The label file value (cluster id + 1, 0 = unassigned).
fn label_value(t: usize, x: u32, y: u32) -> u16 {
    if in_square(t, x, y) {
        2
    } else if t > 0 && x == 1 + 3 * t as u32 && (4..8).contains(&y) {
        0
    } else {
        1
    }
}

fn save_labels(path: &Path, t: usize, w: u32, h: u32) {
    let data: Vec<u16> = (0..w * h).map(|i| label_value(t, i % w, i / w)).collect();
    image::ImageBuffer::<image::Luma<u16>, _>::from_raw(w, h, data)
        .unwrap()
        .save(path)
        .unwrap();
}

/// Writes the sequence into `dir` (reflectance/, shading/, labels/, stats.json).
fn write_video_folder(dir: &Path) {
    for sub in ["reflectance", "shading", "labels"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    for t in 0..FRAMES {
        let name = format!("{t:06}.png");
        let r = Image::from_fn(W, H, |x, y| {
            if in_square(t, x, y) {
                [0.8f32, 0.3, 0.2]
            } else {
                [0.2, 0.5, 0.3]
            }
        });
        let s = Image::from_fn(W, H, |x, _| [(0.3 + 0.04 * x as f32) / 0.9]);
        save(
            dir.join("reflectance").join(&name),
            &r,
            Encoding::Srgb,
            Depth::Sixteen,
        )
        .unwrap();
        save(
            dir.join("shading").join(&name),
            &s,
            Encoding::Srgb,
            Depth::Sixteen,
        )
        .unwrap();
        save_labels(&dir.join("labels").join(&name), t, W, H);
    }
    std::fs::write(dir.join("stats.json"), r#"{"shading_scale": 0.9}"#).unwrap();
}

fn mask(path: &Path, f: impl Fn(u32, u32) -> bool) -> PathBuf {
    let m = Image::from_fn(W, H, |x, y| [if f(x, y) { 1.0f32 } else { 0.0 }]);
    save(path, &m, Encoding::Linear, Depth::Eight).unwrap();
    path.to_path_buf()
}

fn run(args: &[&str], dir: &Path, out: &Path) -> Output {
    bin()
        .arg("edit")
        .arg(args[0])
        .arg(dir)
        .arg("--out")
        .arg(out)
        .arg("-q")
        .args(&args[1..])
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn load(p: &Path) -> Image {
    decompose::io::load_rgb(p, LoadOptions::default()).unwrap()
}

#[test]
fn every_video_edit_writes_one_frame_per_input_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("video");
    write_video_folder(&dir);
    let fg = mask(&tmp.path().join("fg.png"), |x, y| x == 4 && y == 5);
    let bg = mask(&tmp.path().join("bg.png"), |x, y| x < 2 && y < 2);
    let (fg, bg) = (fg.display().to_string(), bg.display().to_string());
    let scribble = format!("{fg}=#2050c0");
    let source = tmp.path().join("source.png");
    save(
        &source,
        &Image::from_fn(8, 8, |x, y| [x as f32 / 8.0, y as f32 / 8.0, 0.5]),
        Encoding::Srgb,
        Depth::Eight,
    )
    .unwrap();
    let source = source.display().to_string();
    let cases: Vec<Vec<&str>> = vec![
        vec!["video-segment", "--fg", &fg, "--bg", &bg],
        vec!["video-recolour", "--scribble", &scribble],
        vec!["video-transfer", "--source", &source],
        vec!["video-stylise", "--saturation", "1.2"],
        vec![
            "video-material",
            "--curve",
            "0:0,0.5:0.8,1:1",
            "--clusters",
            "1",
        ],
        vec!["video-material", "--curve", "0:0,1:1", "--region", &fg],
    ];
    for (k, c) in cases.iter().enumerate() {
        let out = tmp.path().join(format!("out{k}"));
        let o = run(c, &dir, &out);
        assert!(o.status.success(), "{c:?}: {}", stderr(&o));
        for t in 0..FRAMES {
            assert!(out.join(format!("{t:06}.png")).exists(), "{c:?} frame {t}");
        }
        assert!(!out.join(format!("{FRAMES:06}.png")).exists());
        let info: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("edit.json")).unwrap()).unwrap();
        assert_eq!(info["edit"], c[0]);
        assert_eq!(info["frames"], FRAMES);
    }
    // Segmentation: the matte is the moving square in every frame.
    let seg = tmp.path().join("out0");
    let info: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(seg.join("edit.json")).unwrap()).unwrap();
    assert_eq!(info["foreground_clusters"], serde_json::json!([1]));
    for t in 0..FRAMES {
        let m = decompose::io::load_mask(seg.join("matte").join(format!("{t:06}.png"))).unwrap();
        for y in 0..H {
            for x in 0..W {
                assert_eq!(
                    m.at((y * W + x) as usize),
                    in_square(t, x, y),
                    "frame {t} ({x}, {y})"
                );
            }
        }
    }
    // Recolouring: the background is the input (R × S with the shading scale restored).
    let rec = load(&tmp.path().join("out1/000002.png"));
    let x = 15;
    let want = 0.5 * (0.3 + 0.04 * x as f32);
    assert!(
        (rec.get(x, 0)[1] - want).abs() < 0.01,
        "{:?} vs {want}",
        rec.get(x, 0)
    );
    // The identity curve on the square's clusters gives back the input.
    let ident = load(&tmp.path().join("out5/000001.png"));
    let p = ident.get(6, 5);
    let want = 0.8 * (0.3 + 0.04 * 6.0);
    assert!((p[0] - want).abs() < 0.01, "{p:?} vs {want}");
}

#[test]
fn video_option_encodes_with_ffmpeg() {
    if Command::new("ffmpeg").arg("-version").output().is_err() {
        eprintln!("ffmpeg not installed; skipped");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("video");
    write_video_folder(&dir);
    let out = tmp.path().join("styl");
    let mp4 = tmp.path().join("styl.mp4");
    let o = run(
        &["video-stylise", "--video", mp4.to_str().unwrap()],
        &dir,
        &out,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::metadata(&mp4).unwrap().len() > 0);
    let leftovers: Vec<_> = std::fs::read_dir(tmp.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("partial"))
        .collect();
    assert!(leftovers.is_empty());
}

/// Runs video-stylise on a broken folder; asserts a failure naming `needle` and no output.
fn assert_refused(dir: &Path, needle: &str) {
    let out = dir.parent().unwrap().join("refused");
    let o = run(&["video-stylise"], dir, &out);
    assert!(!o.status.success(), "{needle}: should fail");
    let msg = stderr(&o);
    assert!(msg.contains(needle), "expected {needle:?} in: {msg}");
    assert!(!out.exists(), "{needle}: no output folder after a failure");
    let partial = std::fs::read_dir(dir.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .any(|e| e.file_name().to_string_lossy().contains("partial"));
    assert!(!partial, "{needle}: a staging folder was left behind");
}

#[test]
fn bad_folders_are_clear_errors_and_leave_no_output() {
    let fresh = || {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("video");
        write_video_folder(&dir);
        (tmp, dir)
    };
    let tmp = tempfile::tempdir().unwrap();
    assert_refused(&tmp.path().join("nothing"), "is not a folder");

    let (_t, dir) = fresh();
    std::fs::remove_dir_all(dir.join("labels")).unwrap();
    assert_refused(&dir, "labels is missing");

    let (_t, dir) = fresh();
    std::fs::remove_file(dir.join("shading/000002.png")).unwrap();
    assert_refused(&dir, "3 reflectance frames but 2 shading frames");

    let (_t, dir) = fresh();
    std::fs::rename(dir.join("labels/000002.png"), dir.join("labels/000009.png")).unwrap();
    assert_refused(&dir, "frame 2");

    let (_t, dir) = fresh();
    for t in 0..FRAMES {
        save_labels(&dir.join("labels").join(format!("{t:06}.png")), t, 8, 6);
    }
    assert_refused(&dir, "labels frames are (8, 6) pixels");

    let (_t, dir) = fresh();
    save_labels(&dir.join("labels/000001.png"), 1, 8, 6);
    assert_refused(&dir, "000001.png");

    let (_t, dir) = fresh();
    let rgb = Image::from_fn(W, H, |_, _| [0.5f32, 0.2, 0.1]);
    save(
        dir.join("labels/000000.png"),
        &rgb,
        Encoding::Srgb,
        Depth::Eight,
    )
    .unwrap();
    assert_refused(&dir, "a label file is a 16-bit grey PNG");

    let (_t, dir) = fresh();
    std::fs::write(dir.join("stats.json"), "{ not json").unwrap();
    assert_refused(&dir, "stats.json is not valid JSON");

    // A frame whose header reads but whose pixels do not: the failure comes mid-run, after
    // the staging folder exists; it must be removed.
    let (_t, dir) = fresh();
    let p = dir.join("reflectance/000002.png");
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    assert_refused(&dir, "000002.png");
}

#[test]
fn bad_edit_arguments_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("video");
    write_video_folder(&dir);
    let out = tmp.path().join("o");
    let small = tmp.path().join("small.png");
    save(&small, &Image::new(4, 4, 1), Encoding::Linear, Depth::Eight).unwrap();
    let small = small.display().to_string();
    let on_none = mask(&tmp.path().join("none.png"), |_, _| false);
    let on_none = on_none.display().to_string();
    let bg = mask(&tmp.path().join("bg.png"), |x, y| x < 2 && y < 2);
    let bg = bg.display().to_string();
    let short_hex = format!("{bg}=#12345");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["video-segment", "--fg", &small, "--bg", &bg],
            "(4, 4) pixels",
        ),
        (
            vec!["video-segment", "--fg", &on_none, "--bg", &bg],
            "strokes",
        ),
        (vec!["video-recolour", "--scribble", &bg], "MASK=#rrggbb"),
        (vec!["video-recolour", "--scribble", &short_hex], "#rrggbb"),
        (vec!["video-material", "--curve", "0:0"], "curve"),
        (vec!["video-stylise", "--flatten", "2"], "flatten"),
    ];
    for (c, needle) in cases {
        let o = run(&c, &dir, &out);
        assert!(!o.status.success(), "{c:?}");
        assert!(stderr(&o).contains(needle), "{c:?}: {}", stderr(&o));
        assert!(!out.exists());
    }
    // An existing, non-empty output folder is kept unless --force.
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("keep.txt"), "x").unwrap();
    let o = run(&["video-stylise"], &dir, &out);
    assert!(!o.status.success() && stderr(&o).contains("--force"));
    assert!(out.join("keep.txt").exists());
    let o = run(&["video-stylise", "--force"], &dir, &out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!out.join("keep.txt").exists() && out.join("000000.png").exists());
}
