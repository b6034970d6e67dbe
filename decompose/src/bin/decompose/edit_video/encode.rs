//! `--video`: the edited frames encoded by the system's ffmpeg, run as a subprocess.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};

/// Encodes `dir/%06d.png` into `target` through a temporary file beside it.
pub(crate) fn encode_video(dir: &Path, target: &Path, fps: f32) -> Result<PathBuf> {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .context("--video needs a file name")?;
    let ext = target
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mp4".into());
    let parent = target
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let tmp = parent.join(format!(".{name}.partial-{}.{ext}", std::process::id()));
    let out = Command::new("ffmpeg")
        .args([
            "-nostdin",
            "-hide_banner",
            "-loglevel",
            "error",
            "-y",
            "-framerate",
        ])
        .arg(fps.to_string())
        .arg("-i")
        .arg(dir.join("%06d.png"))
        // yuv420p (what players expect) needs even sides.
        .args([
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
            "-pix_fmt",
            "yuv420p",
        ])
        .arg(&tmp)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output();
    let out = match out {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("--video needs ffmpeg on PATH (e.g. `apt-get install ffmpeg`)")
        }
        Err(e) => return Err(e).context("running ffmpeg"),
    };
    if !out.status.success() {
        let _ = std::fs::remove_file(&tmp);
        let err = String::from_utf8_lossy(&out.stderr);
        bail!(
            "ffmpeg could not write {}: {}",
            target.display(),
            err.lines().last().unwrap_or("no message")
        );
    }
    Ok(tmp)
}
