//! `learner render`: one item as the features see it.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::Args;
use image::{Rgb, RgbImage};
use learner::features::Prepared;
use learner::iconify::IconSet;

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// An SVG, PNG or JPEG file, or an Iconify icons.json (with --icon).
    input: PathBuf,
    /// The icon's name inside an Iconify set.
    #[arg(long)]
    icon: Option<String>,
    /// Where to write the 400x400 PNG.
    #[arg(long, short)]
    out: PathBuf,
    /// Overlay what the features measure: outside Ω dimmed, Ω's border in blue, the external
    /// contour in green and the Canny edges in red.
    #[arg(long)]
    mask: bool,
}

pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let canvas = match &args.icon {
        Some(name) => {
            let set = IconSet::from_path(&args.input)?;
            let id = format!("{}:{name}", set.prefix);
            let icon = set
                .icons
                .iter()
                .find(|i| i.id == id)
                .with_context(|| format!("no icon '{name}' in {}", args.input.display()))?;
            learner::render::render_svg(icon.svg.as_bytes())?
        }
        None => {
            let found = learner::input::discover(std::slice::from_ref(&args.input), None)?;
            if let Some(e) = found.errors.into_iter().next() {
                bail!("{}: {}", e.location, e.error);
            }
            let item = found
                .items
                .first()
                .context("not an SVG, PNG or JPEG file")?;
            item.render()
                .with_context(|| format!("cannot render {}", args.input.display()))?
        }
    };
    let picture = if args.mask { overlay(canvas)? } else { canvas };
    picture
        .save(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    eprintln!("wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

fn overlay(canvas: RgbImage) -> anyhow::Result<RgbImage> {
    let p = Prepared::new(canvas)?;
    let region_border = p.region.boundary();
    let contour = p.silhouette.boundary();
    let mut out = p.image.clone();
    for (i, px) in out.pixels_mut().enumerate() {
        if p.edges.data[i] {
            *px = Rgb([230, 30, 30]);
        } else if contour.data[i] {
            *px = Rgb([20, 170, 60]);
        } else if region_border.data[i] {
            *px = Rgb([40, 90, 230]);
        } else if !p.region.data[i] {
            px.0 = px.0.map(|c| (c as u16 * 3 / 5) as u8);
        }
    }
    Ok(out)
}
