//! Video files through the system's `ffmpeg`, run as a subprocess: the `decompose` crate links
//! no codec library. A video is decoded once, when it is opened, into a folder of lossless
//! PNG frames; from then on it is read like any folder of frames. That gives random access
//! (the backward passes of the method revisit frames) with memory bounded by one frame, at the
//! price of disk space: the frames as PNG (0.9–1.05 MB per 800×600 frame of the fixture photos),
//! in a scratch folder that is deleted when the [`super::FrameSource`] is dropped.
//!
//! The command is `ffmpeg -nostdin -loglevel error -i INPUT -map 0:v:0 -vsync passthrough
//! -pix_fmt rgb24 -f image2 DIR/%06d.png`: the first video stream, every decoded frame exactly
//! once (no frame-rate conversion), 8-bit RGB. With `-loglevel error` ffmpeg writes only
//! errors, whose last line goes into [`Error::Ffmpeg`]. `-vsync` rather than its successor
//! `-fps_mode` (ffmpeg ≥ 5.1) so that ffmpeg 4 works too.
//!
//! Sources deeper than 8 bits are reduced to 8. A 16-bit route (`-pix_fmt rgb48be`) was tried
//! and left out: ffmpeg 5.1's conversion of an 8-bit RGB video to it is off by up to 279/65535
//! per sample (not the exact `v·257`), so it could not be tested to read back what was
//! written.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// A folder created for one decoded video, removed with its content on drop.
#[derive(Debug)]
pub(super) struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// A new, empty folder inside `base`, named after the process and a counter.
    pub(super) fn new(base: &Path) -> Result<Self> {
        static COUNTER: AtomicU64 = AtomicU64::new(0);
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        loop {
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let path = base.join(format!(
                "decompose-frames-{}-{nanos:09}-{n}",
                std::process::id()
            ));
            match std::fs::create_dir(&path) {
                Ok(()) => return Ok(Self { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(source) => return Err(Error::Io { path, source }),
            }
        }
    }

    pub(super) fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        // Nothing useful can be done about a failure here; the folder is in a temporary place.
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Decodes the first video stream of `input` into `out/000001.png, 000002.png, …`.
pub(super) fn decode_to_folder(program: &Path, input: &Path, out: &Path) -> Result<()> {
    let mut pattern = OsString::from(out.as_os_str());
    pattern.push(std::path::MAIN_SEPARATOR_STR);
    pattern.push("%06d.png");
    let output = Command::new(program)
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"])
        .arg(input)
        .args([
            "-map",
            "0:v:0",
            "-vsync",
            "passthrough",
            "-pix_fmt",
            "rgb24",
        ])
        .args(["-f", "image2"])
        .arg(pattern)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .map_err(|source| match source.kind() {
            std::io::ErrorKind::NotFound => Error::MissingProgram {
                program: program.display().to_string(),
                hint: "install ffmpeg, e.g. `apt-get install ffmpeg`, to read video files",
            },
            _ => Error::Io {
                path: program.to_path_buf(),
                source,
            },
        })?;
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let last = stderr
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| !l.is_empty())
            .map_or_else(|| format!("exited with {}", output.status), str::to_owned);
        return Err(Error::Ffmpeg {
            path: input.to_path_buf(),
            message: last,
        });
    }
    Ok(())
}
