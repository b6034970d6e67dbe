//! `decompose image`: one image through one of the three methods, every output file.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use indicatif::ProgressBar;

use decompose::clustering::{self, ClusteringParams};
use decompose::color_retinex::{self, ColorRetinexParams};
use decompose::io;
use decompose::retinex::{self, RetinexParams, Strokes};
use decompose::{Decomposition, Image, Labels, Mask, Progress, plot};

use crate::common::{bar, load_input, load_masks, output_format};

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub(crate) enum Method {
    Clustering,
    Retinex,
    ColorRetinex,
}

impl Method {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Method::Clustering => "clustering",
            Method::Retinex => "retinex",
            Method::ColorRetinex => "color-retinex",
        }
    }
}

#[derive(Args, Clone)]
pub(crate) struct DecomposeArgs {
    /// Method.
    #[arg(long, value_enum, default_value = "clustering")]
    pub(crate) method: Method,
    /// The input is already linear (RAW-derived); otherwise 8/16-bit files are sRGB-decoded.
    #[arg(long)]
    pub(crate) linear: bool,
    /// Mask image: decompose only where it is white.
    #[arg(long)]
    pub(crate) mask: Option<PathBuf>,
    /// k-means segments k (clustering).
    #[arg(long, default_value_t = decompose::clustering::ClusteringParams::default().k)]
    pub(crate) k: usize,
    /// Random seed (clustering).
    #[arg(long, default_value_t = 0)]
    pub(crate) seed: u64,
    #[command(flatten)]
    pub(crate) strokes: StrokeArgs,
}

/// User strokes (§3.4): masks the size of the image (of the first frame for a video).
#[derive(Args, Clone, Default)]
pub(crate) struct StrokeArgs {
    /// Constant-albedo stroke masks (retinex, video), repeatable.
    #[arg(long = "albedo-stroke")]
    pub(crate) albedo_strokes: Vec<PathBuf>,
    /// Constant-shading stroke masks (retinex, video), repeatable.
    #[arg(long = "shading-stroke")]
    pub(crate) shading_strokes: Vec<PathBuf>,
    /// Regions using the local chroma threshold T' (retinex, video), repeatable.
    #[arg(long = "local-threshold")]
    pub(crate) local_threshold: Vec<PathBuf>,
}

impl StrokeArgs {
    pub(crate) fn load(&self) -> Result<Strokes> {
        Ok(Strokes {
            constant_albedo: load_masks(&self.albedo_strokes)?,
            constant_shading: load_masks(&self.shading_strokes)?,
            local_threshold: load_masks(&self.local_threshold)?,
        })
    }
}

/// How decomposition layers are written.
#[derive(Args, Clone)]
pub(crate) struct OutputArgs {
    /// Bits per sample of the reflectance and shading PNGs.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(8..=16))]
    pub(crate) depth: u8,
    /// Write linear values instead of display gamma (sRGB), and also the reflectance and
    /// shading as TIFFs: 32-bit float, unclipped and unscaled, so that their product is the
    /// input.
    #[arg(long)]
    pub(crate) linear_output: bool,
}

#[derive(Args)]
pub(crate) struct ImageArgs {
    /// Input image (PNG, JPEG or TIFF; 8 or 16 bits, or 32-bit float TIFF).
    input: PathBuf,
    /// Output directory (created).
    #[arg(long)]
    out_dir: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
    #[command(flatten)]
    output: OutputArgs,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

pub(crate) struct Run {
    pub(crate) decomposition: Decomposition,
    pub(crate) clusters: Option<Labels>,
    pub(crate) stats: serde_json::Value,
}

pub(crate) fn run_method(
    input: &Image,
    mask: Option<&Mask>,
    o: &DecomposeArgs,
    pb: &ProgressBar,
) -> Result<Run> {
    let mut report = |p: Progress| {
        pb.set_position((p.fraction * 100.0) as u64);
        pb.set_message(p.stage);
    };
    let t = Instant::now();
    let run = match o.method {
        Method::Clustering => {
            let params = ClusteringParams {
                k: o.k,
                seed: o.seed,
                ..Default::default()
            };
            let out = clustering::decompose(input, mask, &params, &mut report)?;
            Run {
                decomposition: out.decomposition,
                clusters: Some(out.clusters),
                stats: serde_json::to_value(&out.info)?,
            }
        }
        Method::Retinex => {
            let strokes = o.strokes.load()?;
            let (d, info) = retinex::decompose(
                input,
                mask,
                &strokes,
                &RetinexParams::default(),
                &mut report,
            )?;
            Run {
                decomposition: d,
                clusters: None,
                stats: serde_json::to_value(&info)?,
            }
        }
        Method::ColorRetinex => {
            let (d, info) =
                color_retinex::decompose(input, mask, &ColorRetinexParams::default(), &mut report)?;
            Run {
                decomposition: d,
                clusters: None,
                stats: serde_json::json!({ "solver": info }),
            }
        }
    };
    let mut run = run;
    run.stats["method"] = o.method.name().into();
    run.stats["wall_ms"] = (t.elapsed().as_secs_f64() * 1e3).into();
    Ok(run)
}

pub(crate) fn run_image(a: ImageArgs) -> Result<()> {
    let input = load_input(&a.input, a.opts.linear)?;
    let mask = a
        .opts
        .mask
        .as_ref()
        .map(|p| io::load_mask(p).with_context(|| format!("reading mask {}", p.display())))
        .transpose()?;
    if let (Some(m), Some(p)) = (&mask, &a.opts.mask) {
        input
            .check_dims(m.dims())
            .with_context(|| format!("mask {} does not fit the image", p.display()))?;
    }
    let pb = bar(a.quiet);
    let run = run_method(&input, mask.as_ref(), &a.opts, &pb)?;
    pb.finish_and_clear();
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("creating {}", a.out_dir.display()))?;
    let (enc, depth) = output_format(a.output.linear_output, a.output.depth);
    let d = &run.decomposition;
    io::save(
        a.out_dir.join("reflectance.png"),
        &d.reflectance,
        enc,
        depth,
    )?;
    // Shading is written relative to its maximum inside the mask so it fits the file's range.
    // Outside the mask the shading is black in the file (the library keeps 1 there).
    let full = Mask::full(input.width(), input.height());
    let m = mask.as_ref().unwrap_or(&full);
    let mut shading = d.shading.clone();
    for i in 0..shading.len() {
        if !m.at(i) {
            shading.px_mut(i)[0] = 0.0;
        }
    }
    let smax = shading.max().max(f32::MIN_POSITIVE);
    io::save(
        a.out_dir.join("shading.png"),
        &shading.map(|v| v / smax),
        enc,
        depth,
    )?;
    // The PNGs clip the brightest 0.5% of reflectance values (the decomposition's scale puts
    // its 99.5th percentile at 1) and scale the shading to its maximum; the float TIFFs keep
    // every value, so reflectance.tiff × shading.tiff = the linear input inside the mask.
    if a.output.linear_output {
        io::save_float_tiff(a.out_dir.join("reflectance.tiff"), &d.reflectance)?;
        io::save_float_tiff(a.out_dir.join("shading.tiff"), &d.shading)?;
    }
    if let Some(c) = &run.clusters {
        io::save_rgb8(
            a.out_dir.join("clusters.png"),
            c.width,
            c.height,
            c.false_colour(),
        )?;
    }
    let size = 512;
    io::save_rgb8(
        a.out_dir.join("scatter.png"),
        size,
        size,
        plot::ab_scatter(&input, m, run.clusters.as_ref(), size),
    )?;
    let mut stats = run.stats;
    stats["input"] = a.input.display().to_string().into();
    stats["width"] = input.width().into();
    stats["height"] = input.height().into();
    stats["shading_scale"] = smax.into();
    stats["output_encoding"] = if a.output.linear_output {
        "linear"
    } else {
        "srgb"
    }
    .into();
    std::fs::write(
        a.out_dir.join("stats.json"),
        serde_json::to_string_pretty(&stats)?,
    )?;
    Ok(())
}
