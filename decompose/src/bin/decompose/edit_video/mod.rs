//! `decompose edit video-*`: the video edits of `decompose::video::edit` on the output folder
//! of `decompose video`. Each edit is decided once (strokes and colours on the first lit frame
//! — frame 0 unless the video opens on black frames, `stats.json`'s `first_lit_frame` — and
//! the cluster table of the whole video) and applied to every frame through its labels; the
//! edited frames go to `OUT/000000.png …` (display-gamma PNG), with `OUT/edit.json` recording
//! what was decided, and optionally a video through the system's ffmpeg. The folder is
//! written under a temporary name and moved into place at the end.

mod encode;
mod folder;

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use decompose::color::srgb_to_linear;
use decompose::io::{self, Depth, Encoding};
use decompose::video::edit::material::MaterialEdit;
use decompose::video::edit::recolour::{ClusterRecolour, Scribble};
use decompose::video::edit::segment::StrokeSegmentation;
use decompose::video::edit::stylise::VideoStylise;
use decompose::video::edit::transfer::ColourTransfer;
use decompose::video::edit::{ClusterMeans, Frame, clusters_touched};
use decompose::{Image, Mask};

use crate::common::load_input;
use crate::edit::{StyliseArgs, parse_curve};
use crate::lightfield::StagedFolder;
use encode::encode_video;
use folder::{FrameLayers, VideoFolder, frame_name};

#[derive(Args)]
pub(crate) struct VideoEditIo {
    /// Output folder of `decompose video` (reflectance/, shading/, labels/, stats.json).
    dir: PathBuf,
    /// Output folder for the edited frames 000000.png …; must not exist or be empty unless
    /// --force.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing, non-empty output folder.
    #[arg(long)]
    force: bool,
    /// Also encode the edited frames into this video file (.mp4, .mkv, .webm) with the
    /// system's ffmpeg.
    #[arg(long)]
    video: Option<PathBuf>,
    /// Frame rate of --video.
    #[arg(long, default_value_t = 25.0)]
    fps: f32,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Subcommand)]
pub(crate) enum VideoEdit {
    /// Cut out the clusters chosen by foreground/background strokes on the first lit frame
    /// (frame 0 unless the video opens on black); writes the cutout frames and
    /// matte/000000.png ….
    #[command(name = "video-segment")]
    Segment {
        #[command(flatten)]
        io: VideoEditIo,
        /// Foreground stroke mask on the first lit frame (white = stroke); repeatable.
        #[arg(long, required = true)]
        fg: Vec<PathBuf>,
        /// Background stroke mask on the first lit frame; repeatable.
        #[arg(long, required = true)]
        bg: Vec<PathBuf>,
    },
    /// Recolour the clusters under scribbles on the first lit frame: each MASK=COLOUR (sRGB
    /// hex, e.g. strokes.png=#3060c0) maps its clusters' mean reflectance to that colour.
    #[command(name = "video-recolour")]
    Recolour {
        #[command(flatten)]
        io: VideoEditIo,
        /// A scribble mask on the first lit frame and its target reflectance, MASK=#rrggbb;
        /// repeatable.
        #[arg(long, required = true)]
        scribble: Vec<String>,
    },
    /// Histogram-match the reflectance to the colours of a source image (mapping fitted on
    /// the first lit frame, the same for every frame).
    #[command(name = "video-transfer")]
    Transfer {
        #[command(flatten)]
        io: VideoEditIo,
        /// Source image: a reflectance (e.g. `decompose image`'s reflectance.png) or any image
        /// whose colours are the wanted palette.
        #[arg(long)]
        source: PathBuf,
    },
    /// Saturation change, shading flattened towards the first lit frame's mean, and edges on
    /// cluster boundaries.
    #[command(name = "video-stylise")]
    Stylise {
        #[command(flatten)]
        io: VideoEditIo,
        #[command(flatten)]
        style: StyliseArgs,
    },
    /// Remap the shading of chosen clusters (or all) through a curve "x:y,x:y,..." in units of
    /// the first lit frame's largest shading.
    #[command(name = "video-material")]
    Material {
        #[command(flatten)]
        io: VideoEditIo,
        /// Control points, e.g. "0:0,0.5:0.8,1:1".
        #[arg(long)]
        curve: String,
        /// Cluster ids to edit, e.g. "3,7" (the labels/ values minus one).
        #[arg(long, value_delimiter = ',', conflicts_with = "region")]
        clusters: Vec<u32>,
        /// Region on the first lit frame (mask): edit the clusters it touches.
        #[arg(long)]
        region: Option<PathBuf>,
    },
}

/// A decided edit, applied frame by frame.
enum Decided {
    Segment(StrokeSegmentation),
    Recolour(ClusterRecolour),
    Transfer(ColourTransfer),
    Stylise(VideoStylise),
    Material(MaterialEdit),
}

fn progress(quiet: bool, len: usize) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(len as u64);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos}/{len} frames {msg}") {
        pb.set_style(style);
    }
    pb
}

fn load_frame0_mask(path: &Path, size: (u32, u32)) -> Result<Mask> {
    let m = io::load_mask(path).with_context(|| format!("reading mask {}", path.display()))?;
    if m.dims() != size {
        bail!(
            "mask {} is {:?} pixels but the frames are {:?}",
            path.display(),
            m.dims(),
            size
        );
    }
    Ok(m)
}

/// The union of several masks of one size.
fn union(paths: &[PathBuf], size: (u32, u32)) -> Result<Mask> {
    let mut data = vec![false; size.0 as usize * size.1 as usize];
    for p in paths {
        let m = load_frame0_mask(p, size)?;
        data.iter_mut().zip(m.data()).for_each(|(d, &v)| *d |= v);
    }
    Ok(Mask::from_vec(size.0, size.1, data)?)
}

/// `#rrggbb` (sRGB) as linear RGB.
fn parse_hex(s: &str) -> Result<[f32; 3]> {
    let h = s.trim().trim_start_matches('#');
    if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        bail!("colour {s:?} is not #rrggbb");
    }
    let byte = |k: usize| u8::from_str_radix(&h[k..k + 2], 16).map(|v| v as f32 / 255.0);
    Ok([byte(0)?, byte(2)?, byte(4)?].map(srgb_to_linear))
}

/// The cluster table of the whole video (one pass over reflectance and labels).
fn table(folder: &VideoFolder, pb: &ProgressBar) -> Result<ClusterMeans> {
    pb.set_message("cluster table");
    let mut t = ClusterMeans::new();
    for i in 0..folder.len() {
        let (r, l) = folder.reflectance_and_labels(i)?;
        let shading = Image::new(r.width(), r.height(), 1);
        t.add(&Frame::new(&r, &shading, &l).with_context(|| format!("frame {i}"))?);
        pb.inc(1);
    }
    Ok(t)
}

fn decide(
    e: &VideoEdit,
    folder: &VideoFolder,
    first: &FrameLayers,
    pb: &ProgressBar,
) -> Result<(Decided, serde_json::Value)> {
    let f0 = first.frame()?;
    let size = folder.size();
    Ok(match e {
        VideoEdit::Segment { fg, bg, .. } => {
            let (fg, bg) = (union(fg, size)?, union(bg, size)?);
            let t = table(folder, pb)?;
            let s = StrokeSegmentation::from_strokes(f0.labels, &t, &fg, &bg)?;
            let info = serde_json::json!({
                "foreground_clusters": s.foreground_clusters(),
                "clusters_decided_by_strokes": s.voted(),
            });
            (Decided::Segment(s), info)
        }
        VideoEdit::Recolour { scribble, .. } => {
            let mut scribbles = Vec::new();
            for s in scribble {
                let (mask, colour) = s
                    .rsplit_once('=')
                    .with_context(|| format!("scribble {s:?} is not MASK=#rrggbb"))?;
                scribbles.push(Scribble {
                    mask: load_frame0_mask(Path::new(mask), size)?,
                    target: parse_hex(colour)?,
                });
            }
            let t = table(folder, pb)?;
            let rc = ClusterRecolour::from_scribbles(f0.labels, &t, &scribbles)?;
            let gains: Vec<serde_json::Value> = rc
                .clusters()
                .into_iter()
                .map(|k| serde_json::json!({ "cluster": k, "gain": rc.gain(k) }))
                .collect();
            (
                Decided::Recolour(rc),
                serde_json::json!({ "recoloured": gains }),
            )
        }
        VideoEdit::Transfer { source, .. } => {
            let src = load_input(source, false)?;
            let t = ColourTransfer::fit(&f0, &src)?;
            let info = serde_json::json!({ "source": source.display().to_string() });
            (Decided::Transfer(t), info)
        }
        VideoEdit::Stylise { style, .. } => {
            let s = VideoStylise::fit(&f0, &style.params())?;
            let info = serde_json::json!({ "mean_shading": s.mean_shading() });
            (Decided::Stylise(s), info)
        }
        VideoEdit::Material {
            curve,
            clusters,
            region,
            ..
        } => {
            let curve = parse_curve(curve)?;
            let chosen = match region {
                Some(p) => Some(clusters_touched(f0.labels, &load_frame0_mask(p, size)?)?),
                None if clusters.is_empty() => None,
                None => Some(clusters.clone()),
            };
            if chosen.as_ref().is_some_and(Vec::is_empty) {
                bail!("the region touches no assigned pixel of the first lit frame");
            }
            let m = MaterialEdit::fit(&f0, curve, chosen.as_deref())?;
            let info = serde_json::json!({ "clusters": chosen, "shading_scale": m.scale() });
            (Decided::Material(m), info)
        }
    })
}

impl Decided {
    /// Writes frame `i`'s result into `dir`.
    fn write(&self, dir: &Path, i: usize, f: &Frame) -> Result<()> {
        let path = dir.join(frame_name(i));
        let img = match self {
            Decided::Segment(s) => {
                let matte = s.mask(f.labels);
                let m = Image::from_vec(
                    matte.dims().0,
                    matte.dims().1,
                    1,
                    matte
                        .data()
                        .iter()
                        .map(|&v| f32::from(u8::from(v)))
                        .collect(),
                )?;
                io::save(
                    dir.join("matte").join(frame_name(i)),
                    &m,
                    Encoding::Linear,
                    Depth::Eight,
                )?;
                s.cutout(f)
            }
            Decided::Recolour(e) => e.apply(f).reconstruct(),
            Decided::Transfer(e) => e.apply(f).reconstruct(),
            Decided::Stylise(e) => e.apply(f).reconstruct(),
            Decided::Material(e) => e.apply(f).reconstruct(),
        };
        // Edits can brighten beyond 1: clamped at write time, as `decompose edit` does.
        io::save(&path, &img, Encoding::Srgb, Depth::Eight)
            .with_context(|| format!("writing {}", path.display()))
    }
}

pub(crate) fn run_edit_video(e: VideoEdit) -> Result<()> {
    let io_args = match &e {
        VideoEdit::Segment { io, .. }
        | VideoEdit::Recolour { io, .. }
        | VideoEdit::Transfer { io, .. }
        | VideoEdit::Stylise { io, .. }
        | VideoEdit::Material { io, .. } => io,
    };
    if !(io_args.fps.is_finite() && io_args.fps > 0.0) {
        bail!("--fps {} must be positive", io_args.fps);
    }
    let folder = VideoFolder::open(&io_args.dir)?;
    let n = folder.len();
    let needs_table = matches!(e, VideoEdit::Segment { .. } | VideoEdit::Recolour { .. });
    let pb = progress(io_args.quiet, if needs_table { 2 * n } else { n });
    let key = folder.first_lit();
    let first = folder
        .frame(key)
        .with_context(|| format!("reading frame {key}, the first lit frame"))?;
    let (decided, info) = decide(&e, &folder, &first, &pb)?;
    let staged = StagedFolder::new(&io_args.out, io_args.force)?;
    if matches!(decided, Decided::Segment(_)) {
        std::fs::create_dir(staged.staging.join("matte"))?;
    }
    pb.set_message("editing");
    for i in 0..n {
        let layers = if i == key {
            None
        } else {
            Some(folder.frame(i)?)
        };
        let layers = layers.as_ref().unwrap_or(&first);
        decided.write(&staged.staging, i, &layers.frame()?)?;
        pb.inc(1);
    }
    let mut info = info;
    info["edit"] = match &e {
        VideoEdit::Segment { .. } => "video-segment",
        VideoEdit::Recolour { .. } => "video-recolour",
        VideoEdit::Transfer { .. } => "video-transfer",
        VideoEdit::Stylise { .. } => "video-stylise",
        VideoEdit::Material { .. } => "video-material",
    }
    .into();
    info["frames"] = n.into();
    info["decided_on_frame"] = key.into();
    info["input"] = io_args.dir.display().to_string().into();
    std::fs::write(
        staged.staging.join("edit.json"),
        serde_json::to_string_pretty(&info)?,
    )?;
    let video = match &io_args.video {
        Some(target) => {
            pb.set_message("encoding");
            Some((encode_video(&staged.staging, target, io_args.fps)?, target))
        }
        None => None,
    };
    pb.finish_and_clear();
    if let Err(err) = staged.finish() {
        if let Some((tmp, _)) = &video {
            let _ = std::fs::remove_file(tmp);
        }
        return Err(err);
    }
    if let Some((tmp, target)) = video {
        std::fs::rename(&tmp, target)
            .with_context(|| format!("moving the video into {}", target.display()))?;
    }
    Ok(())
}
