use std::path::Path;
use std::process::Command;

use super::*;
use crate::io::{Depth, Encoding, save};

/// A small frame whose pixels depend on `seed`, written as 8-bit sRGB PNG.
fn write_frame(path: &Path, w: u32, h: u32, seed: u32) {
    let img = Image::from_fn(w, h, |x, y| {
        let v = |k: u32| ((x * 37 + y * 101 + seed * 53 + k * 17) % 97) as f32 / 96.0;
        [v(0), v(1), v(2)]
    });
    save(path, &img, Encoding::Srgb, Depth::Eight).unwrap();
}

fn opts() -> FrameOptions {
    FrameOptions::default()
}

fn names(src: &FrameSource) -> Vec<String> {
    (0..src.len())
        .map(|i| {
            src.path(i)
                .file_name()
                .unwrap()
                .to_string_lossy()
                .into_owned()
        })
        .collect()
}

#[test]
fn folder_frames_come_in_natural_order() {
    let dir = tempfile::tempdir().unwrap();
    for (name, seed) in [("frame10.png", 10), ("frame2.png", 2), ("frame1.png", 1)] {
        write_frame(&dir.path().join(name), 8, 6, seed);
    }
    // Not frames: another extension, a hidden file, a sub-folder.
    std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
    write_frame(&dir.path().join(".frame0.png"), 8, 6, 0);
    std::fs::create_dir(dir.path().join("sub.png")).unwrap();

    let src = FrameSource::open(dir.path(), &opts()).unwrap();
    assert_eq!(names(&src), ["frame1.png", "frame2.png", "frame10.png"]);
    assert_eq!((src.len(), src.size(), src.is_video()), (3, (8, 6), false));
    let expect = load_rgb(dir.path().join("frame2.png"), LoadOptions::default()).unwrap();
    assert_eq!(src.frame(1).unwrap(), expect);
    assert_eq!(src.iter().filter(|f| f.is_ok()).count(), 3);
}

#[test]
fn an_empty_folder_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("readme.txt"), "no frames here").unwrap();
    let e = FrameSource::open(dir.path(), &opts()).unwrap_err();
    assert!(
        matches!(&e, Error::NoFrames { path } if path == dir.path()),
        "{e:?}"
    );
}

#[test]
fn a_missing_input_is_an_io_error() {
    let dir = tempfile::tempdir().unwrap();
    let e = FrameSource::open(dir.path().join("nothing"), &opts()).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e:?}");
}

#[test]
fn frames_of_another_size_are_named() {
    let dir = tempfile::tempdir().unwrap();
    write_frame(&dir.path().join("a1.png"), 8, 6, 1);
    write_frame(&dir.path().join("a2.png"), 8, 6, 2);
    write_frame(&dir.path().join("a3.png"), 7, 6, 3);
    let e = FrameSource::open(dir.path(), &opts()).unwrap_err();
    match &e {
        Error::FrameSize {
            index: 2,
            path,
            expected: (8, 6),
            got: (7, 6),
        } => assert!(path.ends_with("a3.png")),
        _ => panic!("{e:?}"),
    }
    assert!(e.to_string().contains("a3.png"), "{e}");
}

#[test]
fn an_unreadable_header_is_named_at_open() {
    let dir = tempfile::tempdir().unwrap();
    write_frame(&dir.path().join("f1.png"), 8, 6, 1);
    std::fs::write(dir.path().join("f2.png"), b"this is not a PNG").unwrap();
    let e = FrameSource::open(dir.path(), &opts()).unwrap_err();
    match &e {
        Error::Frame {
            index: 1,
            path,
            source,
        } => {
            assert!(path.ends_with("f2.png"));
            assert!(matches!(**source, Error::Codec { .. }), "{source:?}");
        }
        _ => panic!("{e:?}"),
    }
    assert!(e.to_string().contains("frame 1") && e.to_string().contains("f2.png"));
}

#[test]
fn a_truncated_frame_is_named_when_read() {
    // A valid header with its pixel data cut off: open succeeds (it reads headers only), the
    // frame fails when decoded, naming itself.
    let dir = tempfile::tempdir().unwrap();
    write_frame(&dir.path().join("f1.png"), 8, 6, 1);
    let p2 = dir.path().join("f2.png");
    write_frame(&p2, 8, 6, 2);
    let bytes = std::fs::read(&p2).unwrap();
    std::fs::write(&p2, &bytes[..bytes.len() / 2]).unwrap();
    let src = FrameSource::open(dir.path(), &opts()).unwrap();
    assert!(src.frame(0).is_ok());
    let e = src.frame(1).unwrap_err();
    assert!(
        matches!(&e, Error::Frame { index: 1, path, .. } if path.ends_with("f2.png")),
        "{e:?}"
    );
    assert!(matches!(src.frame(2), Err(Error::InvalidParam { .. })));
}

fn ffmpeg(args: &[&std::ffi::OsStr]) {
    let out = Command::new("ffmpeg")
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-y"])
        .args(args)
        .output()
        .expect("ffmpeg must be installed for these tests (scripts/test installs it)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Three 16×12 frames encoded losslessly (FFV1 in Matroska) by ffmpeg.
fn tiny_video(dir: &Path) -> std::path::PathBuf {
    for i in 1..=3 {
        write_frame(&dir.join(format!("src{i}.png")), 16, 12, i);
    }
    let video = dir.join("tiny.mkv");
    ffmpeg(&[
        "-framerate".as_ref(),
        "5".as_ref(),
        "-i".as_ref(),
        dir.join("src%d.png").as_os_str(),
        "-c:v".as_ref(),
        "ffv1".as_ref(),
        video.as_os_str(),
    ]);
    video
}

#[test]
fn a_lossless_video_reads_back_the_exact_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let video = tiny_video(dir.path());
    let scratch = dir.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    for linear in [false, true] {
        let load = LoadOptions {
            linear,
            ..Default::default()
        };
        let o = FrameOptions {
            load,
            scratch: Some(scratch.clone()),
            ..opts()
        };
        let src = FrameSource::open(&video, &o).unwrap();
        assert_eq!((src.len(), src.size(), src.is_video()), (3, (16, 12), true));
        for i in 0..3 {
            let expect = load_rgb(dir.path().join(format!("src{}.png", i + 1)), load).unwrap();
            assert_eq!(src.frame(i).unwrap(), expect, "frame {i}, linear {linear}");
        }
        // The decoded frames live in a sub-folder of `scratch`, removed with the source.
        let decoded = src.path(0).parent().unwrap().to_path_buf();
        assert!(decoded.starts_with(&scratch) && decoded.is_dir());
        drop(src);
        assert!(!decoded.exists());
    }
}

#[test]
fn a_file_that_is_not_a_video_gives_ffmpegs_message() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.mp4");
    std::fs::write(&p, "just some text, not a video\n").unwrap();
    let scratch = dir.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    let o = FrameOptions {
        scratch: Some(scratch.clone()),
        ..opts()
    };
    let e = FrameSource::open(&p, &o).unwrap_err();
    match &e {
        Error::Ffmpeg { path, message } => {
            assert_eq!(path, &p);
            // ffmpeg 5–7 say "x.mp4: Invalid data found when processing input".
            assert!(message.contains("Invalid data"), "{message}");
        }
        _ => panic!("{e:?}"),
    }
    // No scratch folder is left behind.
    assert_eq!(std::fs::read_dir(&scratch).unwrap().count(), 0);
}

#[test]
fn a_missing_ffmpeg_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("clip.mp4");
    std::fs::write(&p, "x").unwrap();
    let o = FrameOptions {
        ffmpeg: dir.path().join("no-such-ffmpeg"),
        scratch: Some(dir.path().to_path_buf()),
        ..opts()
    };
    let e = FrameSource::open(&p, &o).unwrap_err();
    assert!(
        matches!(&e, Error::MissingProgram { program, .. } if program.ends_with("no-such-ffmpeg")),
        "{e:?}"
    );
}
