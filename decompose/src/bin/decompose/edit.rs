//! `decompose edit`: the editing applications.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use indicatif::ProgressBar;

use decompose::Image;
use decompose::edit::{self, Curve, StyliseParams};
use decompose::io::{self, Depth, Encoding};

use crate::common::load_input;
use crate::edit_video::{VideoEdit, run_edit_video};
use crate::image_cmd::{DecomposeArgs, Run, run_method};

#[derive(Args)]
pub(crate) struct EditIo {
    /// Input image.
    input: PathBuf,
    /// Output image (display gamma PNG).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
}

/// The recolouring of `decompose edit recolour` and `decompose edit-lightfield recolour`.
#[derive(Args, Clone, Copy)]
pub(crate) struct HueSaturation {
    /// Hue rotation in degrees.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(crate) hue: f32,
    /// Saturation factor.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) saturation: f32,
}

/// The stylisation of `decompose edit stylise` and `decompose edit video-stylise`.
#[derive(Args, Clone, Copy)]
pub(crate) struct StyliseArgs {
    /// Saturation factor.
    #[arg(long, default_value_t = 1.4)]
    saturation: f32,
    /// Shading flattening in [0, 1].
    #[arg(long, default_value_t = 0.6)]
    flatten: f32,
    /// Edge darkening in [0, 1].
    #[arg(long, default_value_t = 0.8)]
    edges: f32,
}

impl StyliseArgs {
    pub(crate) fn params(&self) -> StyliseParams {
        StyliseParams {
            saturation: self.saturation,
            flatten: self.flatten,
            edge_strength: self.edges,
            ..Default::default()
        }
    }
}

#[derive(Subcommand)]
pub(crate) enum EditCommand {
    /// Rotate the reflectance hue / scale its saturation (inside --region or everywhere).
    Recolour {
        #[command(flatten)]
        io: EditIo,
        /// Region to recolour (mask image).
        #[arg(long)]
        region: Option<PathBuf>,
        #[command(flatten)]
        colour: HueSaturation,
    },
    /// Replace the reflectance inside --region by a tiled texture, keeping the shading.
    Retexture {
        #[command(flatten)]
        io: EditIo,
        /// Region (mask image).
        #[arg(long)]
        region: PathBuf,
        /// Texture image.
        #[arg(long)]
        texture: PathBuf,
    },
    /// Remap the shading through a curve of control points "x:y,x:y,..." in [0, 1].
    Relight {
        #[command(flatten)]
        io: EditIo,
        /// Control points, e.g. "0:0,0.5:0.8,1:1".
        #[arg(long)]
        curve: String,
    },
    /// Histogram-match the reflectance to that of a source image.
    Transfer {
        #[command(flatten)]
        io: EditIo,
        /// Source image (decomposed with the same method).
        #[arg(long)]
        source: PathBuf,
    },
    /// Saturation change, flattened shading and an edge layer.
    Stylise {
        #[command(flatten)]
        io: EditIo,
        #[command(flatten)]
        style: StyliseArgs,
    },
    /// Segment by reflectance clusters; writes a false-colour label map.
    Segment {
        #[command(flatten)]
        io: EditIo,
        /// Number of reflectance segments.
        #[arg(long, default_value_t = 6)]
        segments: usize,
    },
    /// The video edits (`video-*`) on the output folder of `decompose video`.
    #[command(flatten)]
    Video(VideoEdit),
}

pub(crate) fn decompose_file(io_args: &EditIo) -> Result<(Image, Run)> {
    let input = load_input(&io_args.input, io_args.opts.linear)?;
    let mask = io_args.opts.mask.as_ref().map(io::load_mask).transpose()?;
    let run = run_method(&input, mask.as_ref(), &io_args.opts, &ProgressBar::hidden())?;
    Ok((input, run))
}

pub(crate) fn parse_curve(s: &str) -> Result<Curve> {
    let mut pts = Vec::new();
    for item in s.split(',') {
        let (x, y) = item
            .split_once(':')
            .with_context(|| format!("curve point {item:?} is not x:y"))?;
        pts.push((x.trim().parse::<f32>()?, y.trim().parse::<f32>()?));
    }
    Ok(Curve::new(&pts)?)
}

pub(crate) fn save_edit(path: &Path, img: &Image) -> Result<()> {
    // Edits can brighten beyond 1; keep the input's range by clamping at write time.
    io::save(path, img, Encoding::Srgb, Depth::Eight)
        .with_context(|| format!("writing {}", path.display()))
}

pub(crate) fn run_edit(e: EditCommand) -> Result<()> {
    match e {
        EditCommand::Video(v) => run_edit_video(v),
        EditCommand::Recolour {
            io: a,
            region,
            colour,
        } => {
            let (_, run) = decompose_file(&a)?;
            let region = region.map(io::load_mask).transpose()?;
            let out = edit::recolour(
                &run.decomposition,
                region.as_ref(),
                colour.hue,
                colour.saturation,
            )?;
            save_edit(&a.out, &out)
        }
        EditCommand::Retexture {
            io: a,
            region,
            texture,
        } => {
            let (_, run) = decompose_file(&a)?;
            let region = io::load_mask(region)?;
            let tex = load_input(&texture, false)?;
            save_edit(&a.out, &edit::retexture(&run.decomposition, &region, &tex)?)
        }
        EditCommand::Relight { io: a, curve } => {
            let curve = parse_curve(&curve)?;
            let (_, run) = decompose_file(&a)?;
            save_edit(&a.out, &edit::relight(&run.decomposition, &curve))
        }
        EditCommand::Transfer { io: a, source } => {
            let (_, run) = decompose_file(&a)?;
            let src = load_input(&source, a.opts.linear)?;
            let src_run = run_method(&src, None, &a.opts, &ProgressBar::hidden())?;
            let out = edit::transfer(&run.decomposition, &src_run.decomposition.reflectance)?;
            save_edit(&a.out, &out)
        }
        EditCommand::Stylise { io: a, style } => {
            let (_, run) = decompose_file(&a)?;
            save_edit(&a.out, &edit::stylise(&run.decomposition, &style.params())?)
        }
        EditCommand::Segment { io: a, segments } => {
            let (_, run) = decompose_file(&a)?;
            let mask = a.opts.mask.as_ref().map(io::load_mask).transpose()?;
            let l = edit::segment(
                &run.decomposition.reflectance,
                mask.as_ref(),
                segments,
                a.opts.seed,
            )?;
            io::save_rgb8(&a.out, l.width, l.height, l.false_colour())?;
            Ok(())
        }
    }
}
