//! Ground truth for `decompose eval-lightfield`: a light-field folder in the HCI layout with a
//! `truth/` folder beside the views, one file per view under the view's own name:
//!
//! ```text
//! SCENE/input_Cam000.png …           the views as users have them (8-bit sRGB)
//! SCENE/parameters.cfg, gt_disp_lowres.pfm
//! SCENE/truth/input/input_Cam000.png …        linear 16-bit input (= reflectance × shading)
//! SCENE/truth/reflectance/input_Cam000.png …  linear 16-bit reflectance
//! SCENE/truth/shading/input_Cam000.png …      linear 16-bit grey shading
//! SCENE/truth/disparity/input_Cam000.pfm …    every view's disparity (HCI convention)
//! SCENE/truth/mask/input_Cam000.png …         optional: white = scored
//! ```
//!
//! `scripts/render_lightfields.py` writes this layout.

use std::path::Path;

use super::{FolderLayout, LightFieldFolder, load_folder, pfm};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{LoadOptions, load_gray, load_mask};
use crate::lightfield::LightField;
use crate::lightfield::eval::LightFieldTruth;

/// Reads a scene with ground truth: the linear input (from `truth/input/`) with the scene's
/// names and parameters, and the truth.
pub fn load_truth(scene: &Path) -> Result<(LightFieldFolder, LightFieldTruth)> {
    let linear = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let hci = load_folder(scene, Some(FolderLayout::Hci), LoadOptions::default())?;
    let truth = scene.join("truth");
    let grid = FolderLayout::Grid {
        rows: hci.field.rows(),
        cols: hci.field.cols(),
    };
    let mut input = load_folder(&truth.join("input"), Some(grid), linear)?;
    let reflectance = load_folder(&truth.join("reflectance"), Some(grid), linear)?;
    if input.names != hci.names || reflectance.names != hci.names {
        return Err(Error::Format {
            path: truth.clone(),
            message: "truth/input and truth/reflectance must hold one file per view, named as \
                      the views"
                .into(),
        });
    }
    let (rows, cols) = (hci.field.rows(), hci.field.cols());
    let per_view = |sub: &str, ext: &str, read: &dyn Fn(&Path) -> Result<Image>| {
        let views: Vec<Image> = hci
            .names
            .iter()
            .map(|n| {
                let path = truth.join(sub).join(Path::new(n).with_extension(ext));
                let img = read(&path)?;
                if img.dims() != hci.field.dims() {
                    return Err(Error::Format {
                        path,
                        message: format!(
                            "is {}x{}, the views are {}x{}",
                            img.width(),
                            img.height(),
                            hci.field.width(),
                            hci.field.height()
                        ),
                    });
                }
                Ok(img)
            })
            .collect::<Result<_>>()?;
        LightField::from_views(rows, cols, &views)
    };
    let shading = per_view("shading", "png", &|p| load_gray(p, linear))?;
    let disparity = per_view("disparity", "pfm", &|p| {
        let d = pfm::read(p)?;
        if d.channels() != 1 {
            return Err(Error::Format {
                path: p.to_path_buf(),
                message: "a disparity map has one channel (Pf)".into(),
            });
        }
        Ok(d)
    })?;
    let mask = if truth.join("mask").is_dir() {
        Some(per_view("mask", "png", &|p| {
            let m = load_mask(p)?;
            let data = m
                .data()
                .iter()
                .map(|&b| if b { 1.0 } else { 0.0 })
                .collect();
            Image::from_vec(m.dims().0, m.dims().1, 1, data)
        })?)
    } else {
        None
    };
    input.parameters = hci.parameters;
    input.disparity = hci.disparity;
    input.names = hci.names;
    Ok((
        input,
        LightFieldTruth {
            reflectance: reflectance.field,
            shading,
            disparity,
            mask,
        },
    ))
}
