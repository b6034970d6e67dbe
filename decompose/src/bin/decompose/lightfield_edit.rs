//! `decompose edit-lightfield`: one edit applied coherently to every view of a light field.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::{Args, Subcommand};

use decompose::io::{self, Depth, Encoding};
use decompose::lightfield::edit::{recolour, region_to_every_view, relight};
use decompose::lightfield::io::{contact_sheet, write_views};
use decompose::lightfield::propagate::disparity_to_every_view;

use crate::edit::{HueSaturation, parse_curve};
use crate::lightfield::{LightFieldInputArgs, StagedFolder};

#[derive(Args)]
pub(crate) struct LightFieldEditIo {
    #[command(flatten)]
    input: LightFieldInputArgs,
    /// Output folder for the edited views (input names, display-gamma PNG), plus a contact
    /// sheet; must not exist or be empty unless --force.
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing, non-empty output folder.
    #[arg(long)]
    force: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Subcommand)]
pub(crate) enum LightFieldEdit {
    /// Turn the reflectance hue / scale its saturation inside a region drawn on the centre view
    /// (carried to every view by the disparity), or everywhere.
    Recolour {
        #[command(flatten)]
        io: LightFieldEditIo,
        /// Region on the centre view (mask image, white = edit).
        #[arg(long)]
        region: Option<PathBuf>,
        #[command(flatten)]
        colour: HueSaturation,
    },
    /// Remap the shading of every view through one curve "x:y,x:y,..." (x, y in [0, 1] of the
    /// light field's shading maximum).
    Relight {
        #[command(flatten)]
        io: LightFieldEditIo,
        /// Control points, e.g. "0:0,0.5:0.8,1:1".
        #[arg(long)]
        curve: String,
    },
}

pub(crate) fn run_edit_lightfield(e: LightFieldEdit) -> Result<()> {
    let io_args = match &e {
        LightFieldEdit::Recolour { io, .. } | LightFieldEdit::Relight { io, .. } => io,
    };
    let curve = match &e {
        LightFieldEdit::Relight { curve, .. } => Some(parse_curve(curve)?),
        LightFieldEdit::Recolour { .. } => None,
    };
    // A recolouring region drawn on the centre view is carried to the others by the disparity.
    let carries_region = matches!(
        &e,
        LightFieldEdit::Recolour {
            region: Some(_),
            ..
        }
    );
    let (folder, disparity, disparity_source) = io_args.input.load(carries_region)?;
    let lf = &folder.field;
    let region = match &e {
        LightFieldEdit::Recolour {
            region: Some(path), ..
        } => {
            let mask =
                io::load_mask(path).with_context(|| format!("reading {}", path.display()))?;
            lf.view(0)
                .check_dims(mask.dims())
                .with_context(|| format!("region {} does not fit the views", path.display()))?;
            let disparity = disparity.as_ref().context(
                "carrying a region to every view needs a disparity: give --disparity or a folder \
                 with gt_disp_lowres.pfm",
            )?;
            Some(region_to_every_view(
                &mask,
                &disparity_to_every_view(disparity, lf.rows(), lf.cols())?,
            )?)
        }
        _ => None,
    };
    let staged = StagedFolder::new(&io_args.out, io_args.force)?;
    let (d, _) = io_args
        .input
        .run(&folder, disparity.as_ref(), disparity_source, io_args.quiet)?;
    let edited = match (&e, curve) {
        (LightFieldEdit::Recolour { colour, .. }, _) => {
            recolour(&d, region.as_ref(), colour.hue, colour.saturation)?
        }
        (LightFieldEdit::Relight { .. }, Some(curve)) => relight(&d, &curve)?,
        (LightFieldEdit::Relight { .. }, None) => unreachable!("the curve was parsed above"),
    };
    // The input's own range (an edit that brightens past 1 is clipped, as `decompose edit`
    // does), so that an unedited pixel writes back as the input.
    let scale = 1.0;
    write_views(
        &staged.staging,
        &folder.names,
        &edited,
        scale,
        Encoding::Srgb,
        Depth::Eight,
    )?;
    contact_sheet(&edited, scale, 1800)
        .save(staged.staging.join("edited_sheet.png"))
        .context("writing edited_sheet.png")?;
    staged.finish()
}
