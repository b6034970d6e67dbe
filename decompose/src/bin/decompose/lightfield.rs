//! `decompose lightfield`: a whole light field (HCI folder or a grid of views) decomposed at
//! once, written under the input's own names, with a contact sheet and an animation.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;

use decompose::Image;
use decompose::io::{Depth, Encoding, LoadOptions, save, save_float_tiff};
use decompose::lightfield::depth::{EpiParams, epi_disparity};
use decompose::lightfield::io::{
    FolderLayout, LightFieldFolder, contact_sheet, load_folder, pfm, write_animation, write_views,
};
use decompose::lightfield::propagate::disparity_to_every_view;
use decompose::lightfield::tvl1::TvL1Params;
use decompose::lightfield::{
    LightField, LightFieldDecomposition, LightFieldInfo, LightFieldParams,
    decompose as decompose_lf,
};
use decompose::progress::Progress;

use crate::common::{bar, output_format};

/// A view grid `ROWSxCOLS`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Grid {
    pub(crate) rows: usize,
    pub(crate) cols: usize,
}

impl std::str::FromStr for Grid {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (r, c) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("{s:?} is not ROWSxCOLS, e.g. 9x9"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<usize>()
                .ok()
                .filter(|&n| (1..=64).contains(&n))
                .ok_or_else(|| format!("{v:?} is not a view count from 1 to 64"))
        };
        Ok(Self {
            rows: parse(r)?,
            cols: parse(c)?,
        })
    }
}

#[derive(Args, Clone)]
pub(crate) struct LightFieldInputArgs {
    /// Folder of views: the HCI benchmark layout (input_Cam000.png …, parameters.cfg), or any
    /// images with --grid.
    pub(crate) input: PathBuf,
    /// View grid ROWSxCOLS for a folder that is not in the HCI layout (files named …_RR_CC.png,
    /// or taken row-major in natural order).
    #[arg(long)]
    pub(crate) grid: Option<Grid>,
    /// The input is already linear; otherwise 8/16-bit files are sRGB-decoded.
    #[arg(long)]
    pub(crate) linear: bool,
    /// Centre-view disparity (PFM, HCI convention); default: the folder's gt_disp_lowres.pfm.
    #[arg(long)]
    pub(crate) disparity: Option<PathBuf>,
    /// β of the 4D TV-L1 filter of the reflectance (eq. 4.3): reflectance structures smaller
    /// than about 2/β pixels are made coherent across views [default: 2 with a disparity file,
    /// 1 without]
    #[arg(long)]
    pub(crate) beta: Option<f32>,
    /// Also filter the input before the cues (the thesis' step 1) with this β (thesis: 0.05).
    #[arg(long)]
    pub(crate) input_beta: Option<f32>,
    /// Ablation: no 4D filtering.
    #[arg(long)]
    pub(crate) no_4d_filter: bool,
    /// Ablation: no occlusion cue (and so no crease cue either).
    #[arg(long)]
    pub(crate) no_occlusion_cue: bool,
    /// Ablation: no crease cue (shading kept continuous where the disparity's slope changes,
    /// as in the thesis).
    #[arg(long)]
    pub(crate) no_crease_cue: bool,
    /// Use the thesis' white/black cue (eq. 4.11; off by default, see the docs).
    #[arg(long)]
    pub(crate) white_black_cue: bool,
    /// Ablation: black (unlit) rays are data, as in the thesis, instead of missing data filled
    /// in from the surface around them.
    #[arg(long)]
    pub(crate) no_unlit_fill: bool,
    /// Ablation: unlit rays keep the fill of their own view instead of taking the centre
    /// view's at the point they show (the default before the twelfth session).
    #[arg(long)]
    pub(crate) unlit_own_fill: bool,
    /// Tie each view's shading levels to Zhao et al.'s Retinex of the centre view, carried to
    /// every view through the disparity, instead of to the intensity (the thesis).
    #[arg(long)]
    pub(crate) retinex_prior: bool,
    /// Take the 4D filter's angular differences along the disparity instead of at a fixed
    /// pixel (3-4x slower filter; see the docs).
    #[arg(long)]
    pub(crate) shear: bool,
    /// No effect: the option for large dark surfaces (the per-ray data term at γ = 2) has been
    /// the default since 2026-12-05; the flag is kept so that scripts using it keep working.
    #[arg(long, conflicts_with = "thesis_data_term")]
    pub(crate) dark_surfaces: bool,
    /// Ablation: the thesis' data term, one weight for every ray (by default dark rays weigh
    /// less and are tied to the centre view's solution).
    #[arg(long)]
    pub(crate) thesis_data_term: bool,
}

/// The disparity source named when the disparity was estimated from the EPIs.
pub(crate) const ESTIMATED: &str = "estimated from the epipolar-plane images";

/// The disparity source named when there is none.
const NONE: &str = "none (without a disparity file the occlusion cue is off)";

/// Whether a disparity source (as [`LightFieldInputArgs::load`] names it) is a file: given
/// with `--disparity` or the folder's own.
fn is_precise(source: &str) -> bool {
    source != ESTIMATED && source != NONE
}

#[derive(Args)]
pub(crate) struct LightFieldArgs {
    #[command(flatten)]
    pub(crate) input: LightFieldInputArgs,
    /// Output folder (created; must not exist or be empty unless --force).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Replace an existing, non-empty output folder.
    #[arg(long)]
    pub(crate) force: bool,
    /// Bits per sample of the written views.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(8..=16))]
    pub(crate) depth: u8,
    /// Write linear values instead of display gamma, and also 32-bit float TIFFs per view.
    #[arg(long)]
    pub(crate) linear_output: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub(crate) quiet: bool,
}

impl LightFieldInputArgs {
    /// The method's parameters. Without a disparity file (`estimated`: none, or one estimated
    /// from the EPIs) they are [`LightFieldParams::without_precise_disparity`]: no occlusion cue
    /// (on the 8 rendered tuning scenes it costs accuracy with the EPI estimate, mean LMSE
    /// 0.0547 against 0.0519 without) and the thesis' data term (docs/intrinsic-lightfields.md).
    pub(crate) fn params(&self, estimated: bool) -> LightFieldParams {
        let mut p = if self.dark_surfaces {
            LightFieldParams::dark_surfaces()
        } else if self.thesis_data_term {
            LightFieldParams::thesis_data_term()
        } else {
            LightFieldParams::default()
        };
        p.input_filter = self.input_beta.map(|beta| TvL1Params {
            beta,
            iterations: decompose::lightfield::method::FILTER_ITERATIONS,
            ..Default::default()
        });
        p.filter_4d = !self.no_4d_filter;
        if estimated {
            p = p.without_precise_disparity();
        }
        if let Some(beta) = self.beta {
            p.reflectance_filter.beta = beta;
        }
        p.occlusion_cue &= !self.no_occlusion_cue;
        if self.no_crease_cue {
            p.cues.crease_step = None;
        }
        p.white_black_cue = self.white_black_cue;
        p.unlit_as_missing = !self.no_unlit_fill;
        p.unlit_from_centre &= !self.unlit_own_fill;
        if self.retinex_prior {
            p.level_prior = decompose::lightfield::method::LevelPrior::CentreRetinex;
        }
        p.shear = self.shear;
        p
    }

    /// Whether any enabled step needs a disparity.
    fn needs_disparity(&self) -> bool {
        self.retinex_prior || (self.shear && !self.no_4d_filter)
    }

    /// Reads the views and the centre-view disparity: the given file, else the folder's
    /// `gt_disp_lowres.pfm`, else estimated from the epipolar-plane images when the caller
    /// (`caller_needs_it`, e.g. an edit carrying a region) or an enabled option needs one.
    /// Also says which ([`ESTIMATED`] for the estimate).
    pub(crate) fn load(
        &self,
        caller_needs_it: bool,
    ) -> Result<(LightFieldFolder, Option<Image>, &'static str)> {
        let layout = self.grid.map(|g| FolderLayout::Grid {
            rows: g.rows,
            cols: g.cols,
        });
        let opts = LoadOptions {
            linear: self.linear,
            ..Default::default()
        };
        let folder = load_folder(&self.input, layout, opts)
            .with_context(|| format!("reading the light field {}", self.input.display()))?;
        let disparity: (Option<Image>, &'static str) = match &self.disparity {
            Some(p) => {
                let d = pfm::read(p).with_context(|| format!("reading {}", p.display()))?;
                if d.dims() != folder.field.dims() || d.channels() != 1 {
                    bail!(
                        "disparity {} is {}x{} with {} channel(s); the views are {}x{}",
                        p.display(),
                        d.width(),
                        d.height(),
                        d.channels(),
                        folder.field.width(),
                        folder.field.height()
                    );
                }
                (Some(d), "given (--disparity)")
            }
            None => match &folder.disparity {
                Some(d) => (Some(d.clone()), "the folder's gt_disp_lowres.pfm"),
                None if !caller_needs_it && !self.needs_disparity() => (None, NONE),
                None => {
                    let (d, _) = epi_disparity(&folder.field, &EpiParams::default())
                        .context("estimating disparity from the epipolar-plane images")?;
                    (Some(d), ESTIMATED)
                }
            },
        };
        Ok((folder, disparity.0, disparity.1))
    }

    /// Decomposes with a progress bar; `disparity_source` as returned by [`Self::load`].
    pub(crate) fn run(
        &self,
        folder: &LightFieldFolder,
        disparity: Option<&Image>,
        disparity_source: &str,
        quiet: bool,
    ) -> Result<(LightFieldDecomposition, LightFieldInfo)> {
        let lf = &folder.field;
        let every = disparity
            .map(|d| disparity_to_every_view(d, lf.rows(), lf.cols()))
            .transpose()?;
        let pb = bar(quiet);
        let mut report = |p: Progress| {
            pb.set_position((p.fraction * 100.0) as u64);
            pb.set_message(p.stage);
        };
        let params = self.params(!is_precise(disparity_source));
        let out = decompose_lf(lf, every.as_ref(), &params, &mut report)?;
        pb.finish_and_clear();
        Ok(out)
    }
}

/// A sibling of `out` to write into, renamed to `out` at the end so that a failed or
/// interrupted run never leaves half-written results under the requested name.
pub(crate) struct StagedFolder {
    pub(crate) staging: PathBuf,
    target: PathBuf,
}

impl StagedFolder {
    pub(crate) fn new(target: &Path, force: bool) -> Result<Self> {
        if target.exists() {
            let empty = target.is_dir() && std::fs::read_dir(target)?.next().is_none();
            if !empty && !force {
                bail!(
                    "{} exists and is not empty; choose a new folder or pass --force to replace it",
                    target.display()
                );
            }
            if !target.is_dir() {
                bail!("{} exists and is not a folder", target.display());
            }
        }
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let parent = target.parent().filter(|p| !p.as_os_str().is_empty());
        let parent = parent.unwrap_or(Path::new("."));
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
        let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging)?;
        }
        std::fs::create_dir(&staging).with_context(|| format!("creating {}", staging.display()))?;
        Ok(Self {
            staging,
            target: target.to_path_buf(),
        })
    }

    /// Moves the finished folder into place (replacing an old one only when allowed by `new`).
    pub(crate) fn finish(self) -> Result<()> {
        if self.target.exists() {
            std::fs::remove_dir_all(&self.target)
                .with_context(|| format!("replacing {}", self.target.display()))?;
        }
        std::fs::rename(&self.staging, &self.target)
            .with_context(|| format!("moving results into {}", self.target.display()))?;
        Ok(())
    }
}

impl Drop for StagedFolder {
    fn drop(&mut self) {
        // Reached with the staging folder still present only when the run failed.
        let _ = std::fs::remove_dir_all(&self.staging);
    }
}

fn max_of(lf: &LightField) -> f32 {
    lf.data()
        .iter()
        .copied()
        .fold(0.0f32, f32::max)
        .max(f32::MIN_POSITIVE)
}

/// Writes a decomposition into `dir`: views, sheets, animation, disparity.
pub(crate) fn write_results(
    dir: &Path,
    folder: &LightFieldFolder,
    d: &LightFieldDecomposition,
    disparity: Option<&Image>,
    enc: Encoding,
    depth: Depth,
    float_tiffs: bool,
) -> Result<f32> {
    let shading_scale = max_of(&d.shading);
    for (sub, lf, scale) in [
        ("reflectance", &d.reflectance, 1.0),
        ("shading", &d.shading, shading_scale),
    ] {
        let sub_dir = dir.join(sub);
        std::fs::create_dir(&sub_dir)?;
        write_views(&sub_dir, &folder.names, lf, scale, enc, depth)?;
        if float_tiffs {
            for (i, name) in folder.names.iter().enumerate() {
                save_float_tiff(
                    sub_dir.join(Path::new(name).with_extension("tiff")),
                    &lf.view(i),
                )?;
            }
        }
        contact_sheet(lf, scale, 1800)
            .save(dir.join(format!("{sub}_sheet.png")))
            .with_context(|| format!("writing {sub}_sheet.png"))?;
    }
    let input_scale = max_of(&folder.field);
    write_animation(
        &dir.join("views.gif"),
        &[
            (&folder.field, input_scale),
            (&d.reflectance, 1.0),
            (&d.shading, shading_scale),
        ],
        320,
        120,
    )?;
    if let Some(disp) = disparity {
        pfm::write(&dir.join("disparity.pfm"), disp)?;
        let (lo, hi) = disp
            .data()
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let span = (hi - lo).max(f32::MIN_POSITIVE);
        save(
            dir.join("disparity.png"),
            &disp.map(|v| (v - lo) / span),
            Encoding::Linear,
            Depth::Eight,
        )?;
    }
    Ok(shading_scale)
}

pub(crate) fn run_lightfield(a: LightFieldArgs) -> Result<()> {
    let (folder, disparity, disparity_source) = a.input.load(false)?;
    let staged = StagedFolder::new(&a.out, a.force)?;
    let started = std::time::Instant::now();
    let (d, info) = a
        .input
        .run(&folder, disparity.as_ref(), disparity_source, a.quiet)?;
    let wall = started.elapsed().as_secs_f64();
    let (enc, depth) = output_format(a.linear_output, a.depth);
    let shading_scale = write_results(
        &staged.staging,
        &folder,
        &d,
        disparity.as_ref(),
        enc,
        depth,
        a.linear_output,
    )?;
    let lf = &folder.field;
    let stats = serde_json::json!({
        "input": a.input.input.display().to_string(),
        "grid": [lf.rows(), lf.cols()],
        "view_size": [lf.width(), lf.height()],
        "disparity": disparity_source,
        "params": format!("{:?}", a.input.params(!is_precise(disparity_source))),
        "wall_ms": wall * 1e3,
        "shading_scale": shading_scale,
        "output_encoding": if a.linear_output { "linear" } else { "srgb" },
        "run": info,
    });
    std::fs::write(
        staged.staging.join("stats.json"),
        serde_json::to_string_pretty(&stats)?,
    )?;
    staged.finish()
}
