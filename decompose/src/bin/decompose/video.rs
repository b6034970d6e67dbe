//! `decompose video INPUT --out DIR`: the intrinsic-video method (thesis ch. 3) on a folder of
//! frames or a video file. Everything is written into a temporary sibling folder
//! `DIR.partial-…` that is renamed to `DIR` at the end, so a failed run leaves no half-written
//! output.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};
use clap::Args;

use decompose::Progress;
use decompose::io::{self, Depth, Encoding, LoadOptions};
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::video::labels_io::save_labels;
use decompose::video::method::{FrameSink, VideoFrame, VideoParams, decompose_video};

use crate::common::{TempDir, bar, output_format};
use crate::image_cmd::{OutputArgs, StrokeArgs};

#[derive(Args)]
pub(crate) struct VideoArgs {
    /// A folder of frames (PNG, JPEG or TIFF, in natural order of their names) or a video file
    /// (decoded by the system's ffmpeg).
    input: PathBuf,
    /// Output folder: reflectance/, shading/, clusters/, labels/, stats.json.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing non-empty output folder.
    #[arg(long)]
    force: bool,
    /// The frames are already linear (RAW-derived, rendered); otherwise 8/16-bit files are
    /// sRGB-decoded.
    #[arg(long)]
    linear: bool,
    #[command(flatten)]
    output: OutputArgs,
    /// Strokes and local-threshold masks, drawn on the first frame (the first lit one when the
    /// video opens on black).
    #[command(flatten)]
    strokes: StrokeArgs,
    /// Also encode reflectance.mp4 and shading.mp4 (ffmpeg, H.264, yuv420p, CRF 18).
    #[arg(long)]
    video: bool,
    /// Frame rate of the encoded videos.
    #[arg(long, default_value_t = 25.0)]
    fps: f64,
    /// The ffmpeg program (decoding a video input, --video).
    #[arg(long, default_value = "ffmpeg")]
    ffmpeg: PathBuf,
    /// Output the propagated decomposition as the thesis does: no blend with each frame's own
    /// single-image decomposition and no averaging along the flow (step 8).
    #[arg(long)]
    no_blend: bool,
    /// Radius, in 8-bit colour units, of the colour ball over which a propagated pixel's
    /// reflectance is averaged among its cluster's colours; 0 takes the pixel's exact colour,
    /// as the thesis does. The default was chosen on rendered sequences (decompose/README.md).
    #[arg(long, default_value_t = VideoParams::default().propagate.reflectance_radius,
          value_parser = parse_radius)]
    reflectance_radius: f64,
    /// Solve the optical flow only on pyramid levels of at most N pixels and upsample it to
    /// the frames' size (like OpenCV DIS's finest scale); frames of at most N pixels are
    /// unaffected. 262144 (512²) made 800x600 runs 13-25% faster, at a small cost in
    /// flicker (decompose/README.md). Default: every level.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    flow_max_pixels: Option<u64>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// The layer folders of the output.
const FOLDERS: [&str; 4] = ["reflectance", "shading", "clusters", "labels"];

/// Writes every frame's layers as it arrives from the method.
struct PngSink<'a> {
    dir: &'a Path,
    enc: Encoding,
    depth: Depth,
    linear_output: bool,
    /// One shading scale for the whole video, 1 / (the largest shading of the first frame with
    /// light), so that the written shading does not flicker; later frames brighter than that
    /// clip in the PNGs (`--linear-output` keeps every value).
    shading_scale: Option<f32>,
}

impl PngSink<'_> {
    fn write(&mut self, f: VideoFrame<'_>) -> decompose::Result<()> {
        let name = format!("{:06}", f.index);
        let file = |sub: &str, ext: &str| self.dir.join(sub).join(format!("{name}.{ext}"));
        io::save(
            file("reflectance", "png"),
            f.reflectance,
            self.enc,
            self.depth,
        )?;
        // Black frames (shading 0) before the first lit one leave the scale unset.
        let largest = f.shading.max();
        if self.shading_scale.is_none() && largest > 0.0 {
            self.shading_scale = Some(1.0 / largest);
        }
        let scale = self.shading_scale.unwrap_or(1.0);
        io::save(
            file("shading", "png"),
            &f.shading.map(|v| v * scale),
            self.enc,
            self.depth,
        )?;
        if self.linear_output {
            io::save_float_tiff(file("reflectance", "tiff"), f.reflectance)?;
            io::save_float_tiff(file("shading", "tiff"), f.shading)?;
        }
        let c = f.clusters;
        io::save_rgb8(file("clusters", "png"), c.width, c.height, c.false_colour())?;
        save_labels(file("labels", "png"), c)
    }
}

impl FrameSink for PngSink<'_> {
    fn frame(&mut self, f: VideoFrame<'_>) -> decompose::Result<()> {
        self.write(f)
    }
}

/// Whether `dir` exists and holds anything.
fn non_empty(dir: &Path) -> Result<bool> {
    match std::fs::read_dir(dir) {
        Ok(mut entries) => Ok(entries.next().is_some()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(false),
        Err(e) if e.kind() == std::io::ErrorKind::NotADirectory => {
            bail!("--out {} is a file, not a folder", dir.display())
        }
        Err(e) => Err(e).with_context(|| format!("reading {}", dir.display())),
    }
}

/// Checks that `program` runs (before any work, so a missing ffmpeg is reported at once).
fn check_ffmpeg(program: &Path) -> Result<()> {
    match Command::new(program)
        .arg("-version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
    {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => bail!("{} -version exited with {s}", program.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "--video needs ffmpeg, and {} is not installed or not on PATH (install it, e.g. \
             `apt-get install ffmpeg`, or leave out --video)",
            program.display()
        ),
        Err(e) => Err(e).with_context(|| format!("running {}", program.display())),
    }
}

/// Encodes `frames/%06d.png` into `out` (H.264, yuv420p, CRF 18). yuv420p needs even sides,
/// so an odd width or height is padded by one black pixel.
fn encode(program: &Path, frames: &Path, fps: f64, out: &Path) -> Result<()> {
    let output = Command::new(program)
        .args(["-nostdin", "-hide_banner", "-loglevel", "error", "-y"])
        .args(["-framerate", &fps.to_string(), "-i"])
        .arg(frames.join("%06d.png"))
        .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"])
        .args(["-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18"])
        .arg(out)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
        .with_context(|| format!("running {}", program.display()))?;
    if !output.status.success() {
        let err = String::from_utf8_lossy(&output.stderr);
        bail!(
            "ffmpeg could not encode {}: {}",
            out.display(),
            err.lines().last().unwrap_or("no message").trim()
        );
    }
    Ok(())
}

pub(crate) fn run_video(a: VideoArgs) -> Result<()> {
    if !(a.fps.is_finite() && a.fps > 0.0) {
        bail!("--fps must be > 0, got {}", a.fps);
    }
    if non_empty(&a.out)? && !a.force {
        bail!(
            "{} exists and is not empty (use --force to replace it)",
            a.out.display()
        );
    }
    if a.video {
        check_ffmpeg(&a.ffmpeg)?;
    }
    let strokes = a.strokes.load()?;
    let out_name = a
        .out
        .file_name()
        .with_context(|| format!("--out {} has no folder name", a.out.display()))?
        .to_string_lossy()
        .into_owned();
    let parent = match a.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).with_context(|| format!("creating {}", parent.display()))?;
    let partial = TempDir::new(&parent, &format!("{out_name}.partial-"))?;
    let work = partial.path().join(".work");
    for sub in FOLDERS.iter().copied().chain([".work"]) {
        let d = partial.path().join(sub);
        std::fs::create_dir(&d).with_context(|| format!("creating {}", d.display()))?;
    }
    let opts = FrameOptions {
        load: LoadOptions {
            linear: a.linear,
            ..Default::default()
        },
        ffmpeg: a.ffmpeg.clone(),
        scratch: Some(work.clone()),
    };
    let source = FrameSource::open(&a.input, &opts)
        .with_context(|| format!("reading {}", a.input.display()))?;
    let (w, h) = source.size();
    for (m, p) in strokes
        .constant_albedo
        .iter()
        .zip(&a.strokes.albedo_strokes)
        .chain(
            strokes
                .constant_shading
                .iter()
                .zip(&a.strokes.shading_strokes),
        )
        .chain(
            strokes
                .local_threshold
                .iter()
                .zip(&a.strokes.local_threshold),
        )
    {
        if m.dims() != (w, h) {
            bail!(
                "mask {} is {}x{} but the frames are {w}x{h}",
                p.display(),
                m.dims().0,
                m.dims().1
            );
        }
    }
    let (enc, depth) = output_format(a.output.linear_output, a.output.depth);
    let mut sink = PngSink {
        dir: partial.path(),
        enc,
        depth,
        linear_output: a.output.linear_output,
        shading_scale: None,
    };
    let pb = bar(a.quiet);
    let mut report = |p: Progress| {
        pb.set_position((p.fraction * 100.0) as u64);
        pb.set_message(p.stage);
    };
    let mut params = VideoParams {
        fusion: (!a.no_blend).then(Default::default),
        ..Default::default()
    };
    params.propagate.reflectance_radius = a.reflectance_radius;
    params.flow.max_solved_pixels = a.flow_max_pixels.map(|n| n as usize);
    let stats = decompose_video(
        &source,
        &strokes,
        &params,
        &work.join("state"),
        &mut sink,
        &mut report,
    )?;
    pb.finish_and_clear();
    let frames = source.len();
    drop(source);
    std::fs::remove_dir_all(&work).with_context(|| format!("removing {}", work.display()))?;
    let mut json = serde_json::to_value(&stats)?;
    json["input"] = a.input.display().to_string().into();
    json["frame_count"] = frames.into();
    json["width"] = w.into();
    json["height"] = h.into();
    json["shading_scale"] = sink.shading_scale.map_or(1.0, |s| 1.0 / s).into();
    json["per_frame_blend"] = params.fusion.is_some().into();
    json["blend_weights"] = params.fusion.as_ref().map_or(
        serde_json::Value::Null,
        |f| serde_json::json!({ "view": f.beta, "clustering": f.clustering_weight }),
    );
    json["reflectance_radius"] = params.propagate.reflectance_radius.into();
    json["flow_max_pixels"] = params.flow.max_solved_pixels.into();
    json["output_encoding"] = if a.output.linear_output {
        "linear"
    } else {
        "srgb"
    }
    .into();
    std::fs::write(
        partial.path().join("stats.json"),
        serde_json::to_string_pretty(&json)?,
    )?;
    if a.video {
        for layer in ["reflectance", "shading"] {
            let mp4 = partial.path().join(format!("{layer}.mp4"));
            encode(&a.ffmpeg, &partial.path().join(layer), a.fps, &mp4)?;
        }
    }
    // Only now does the output appear under its name.
    if non_empty(&a.out)? {
        if !a.force {
            bail!(
                "{} appeared during the run and is not empty (use --force to replace it)",
                a.out.display()
            );
        }
        std::fs::remove_dir_all(&a.out).with_context(|| format!("removing {}", a.out.display()))?;
    } else if a.out.is_dir() {
        std::fs::remove_dir(&a.out).with_context(|| format!("removing {}", a.out.display()))?;
    }
    std::fs::rename(partial.path(), &a.out)
        .with_context(|| format!("moving the output to {}", a.out.display()))?;
    partial.keep();
    Ok(())
}

/// A colour-ball radius: a finite number from 0 to 442 (the diagonal of the 8-bit cube).
fn parse_radius(text: &str) -> std::result::Result<f64, String> {
    let r: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a number"))?;
    if r.is_finite() && (0.0..=442.0).contains(&r) {
        Ok(r)
    } else {
        Err(format!("{r} is out of range (0 to 442)"))
    }
}
