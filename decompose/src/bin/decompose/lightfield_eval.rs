//! `decompose eval-lightfield`: accuracy and angular coherence against rendered ground truth,
//! for the light-field method, the per-view baselines and the ablations.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};

use decompose::clustering::{self, ClusteringParams};
use decompose::lightfield::depth::{EpiParams, epi_disparity};
use decompose::lightfield::eval::{LightFieldScores, evaluate};
use decompose::lightfield::io::load_truth;
use decompose::lightfield::method::{per_view, per_view_retinex};
use decompose::lightfield::propagate::disparity_to_every_view;
use decompose::lightfield::{LightFieldParams, decompose as decompose_lf};

use crate::common::out;

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, PartialOrd, Ord)]
pub(crate) enum LfMethod {
    /// The light-field method (thesis ch. 4).
    Ours,
    /// Zhao et al. Retinex on every view alone.
    Retinex,
    /// Garces 2012 clustering on every view alone.
    Clustering,
    /// Ablation: no 4D filtering.
    No4dFilter,
    /// Ablation: no occlusion cue.
    NoOcclusionCue,
    /// Ablation: no crease cue (as in the thesis).
    NoCreaseCue,
    /// Ablation: with the thesis' white/black cue (off by default).
    WhiteBlackCue,
    /// Ablation: black (unlit) rays as data, as in the thesis.
    NoUnlitFill,
    /// Ablation: unlit rays keep their own view's fill (not the centre view's).
    UnlitOwnFill,
    /// Ablation: the thesis' data term (one weight for every ray).
    ThesisDataTerm,
    /// Option: the centre view's Retinex as the per-view solves' level prior.
    RetinexPrior,
    /// Option: the 4D filter's angular differences along the disparity.
    Shear,
    /// Ablation: the defaults before the ninth session (per-ray data term at γ 1, μ 1e-2; crease
    /// pairs damped like occlusions, unbounded).
    PreviousDefaults,
}

impl LfMethod {
    fn name(self) -> &'static str {
        match self {
            LfMethod::Ours => "ours",
            LfMethod::Retinex => "per-view retinex",
            LfMethod::Clustering => "per-view clustering",
            LfMethod::No4dFilter => "ours, no 4D filter",
            LfMethod::NoOcclusionCue => "ours, no occlusion cue",
            LfMethod::NoCreaseCue => "ours, no crease cue",
            LfMethod::WhiteBlackCue => "ours, with white/black cue",
            LfMethod::NoUnlitFill => "ours, unlit rays as data",
            LfMethod::UnlitOwnFill => "ours, unlit rays filled view by view",
            LfMethod::ThesisDataTerm => "ours, thesis data term",
            LfMethod::RetinexPrior => "ours, centre Retinex prior",
            LfMethod::Shear => "ours, sheared filter",
            LfMethod::PreviousDefaults => "ours, previous defaults",
        }
    }
}

#[derive(Args)]
pub(crate) struct EvalLightFieldArgs {
    /// A scene folder with truth/ (see `decompose::lightfield::io::load_truth`), or a folder
    /// of such scenes.
    #[arg(long)]
    pub(crate) truth: PathBuf,
    /// Methods to run (default: ours, the per-view baselines and the ablations; the options
    /// only when named).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub(crate) methods: Vec<LfMethod>,
    /// Write every figure as JSON.
    #[arg(long)]
    pub(crate) json: Option<PathBuf>,
    /// Ignore the scenes' disparity files: the light-field method gets the disparity estimated
    /// from the epipolar-plane images, as `decompose lightfield` does for a folder without one
    /// (and, as there, no occlusion cue). The scoring still uses the true disparity.
    #[arg(long)]
    pub(crate) estimate_disparity: bool,
}

fn scenes(root: &Path) -> Result<Vec<PathBuf>> {
    if root.join("truth").is_dir() {
        return Ok(vec![root.to_path_buf()]);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(root)
        .with_context(|| format!("reading {}", root.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("truth").is_dir())
        .collect();
    found.sort();
    if found.is_empty() {
        bail!(
            "{} holds no scene with a truth/ folder (render some with scripts/render_lightfields.py)",
            root.display()
        );
    }
    Ok(found)
}

#[derive(serde::Serialize)]
struct Row {
    scores: LightFieldScores,
    seconds: f64,
}

pub(crate) fn run_eval_lightfield(a: EvalLightFieldArgs) -> Result<()> {
    let mut methods = a.methods.clone();
    if methods.is_empty() {
        methods = vec![
            LfMethod::Ours,
            LfMethod::Retinex,
            LfMethod::Clustering,
            LfMethod::No4dFilter,
            LfMethod::NoOcclusionCue,
            LfMethod::NoCreaseCue,
            LfMethod::WhiteBlackCue,
            LfMethod::NoUnlitFill,
            LfMethod::ThesisDataTerm,
        ];
    }
    methods.sort();
    methods.dedup();
    let mut all: BTreeMap<String, BTreeMap<&'static str, Row>> = BTreeMap::new();
    for scene in scenes(&a.truth)? {
        let name = scene
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let (folder, truth) =
            load_truth(&scene).with_context(|| format!("reading {}", scene.display()))?;
        let lf = &folder.field;
        // As a user would: the centre view's disparity from the folder, carried to every view.
        // The folder's disparity, as a user of the HCI benchmark would have it; with
        // --estimate-disparity, the one `decompose lightfield` estimates for a folder without.
        let estimated = if a.estimate_disparity {
            Some(
                epi_disparity(lf, &EpiParams::default())
                    .with_context(|| format!("{name}: estimating disparity from the EPIs"))?
                    .0,
            )
        } else {
            None
        };
        let disparity = estimated
            .as_ref()
            .or(folder.disparity.as_ref())
            .map(|d| disparity_to_every_view(d, lf.rows(), lf.cols()))
            .transpose()?;
        let mut rows = BTreeMap::new();
        for &m in &methods {
            let t = Instant::now();
            // As `decompose lightfield` with an estimated disparity.
            let estimating = a.estimate_disparity;
            let ours = |mut p: LightFieldParams| {
                if estimating {
                    p = p.without_precise_disparity();
                }
                decompose_lf(lf, disparity.as_ref(), &p, &mut |_| {}).map(|(d, _)| d)
            };
            let d = match m {
                LfMethod::Ours => ours(LightFieldParams::default()),
                LfMethod::No4dFilter => ours(LightFieldParams {
                    filter_4d: false,
                    ..Default::default()
                }),
                LfMethod::NoOcclusionCue => ours(LightFieldParams {
                    occlusion_cue: false,
                    ..Default::default()
                }),
                LfMethod::NoCreaseCue => ours({
                    let mut p = LightFieldParams::default();
                    p.cues.crease_step = None;
                    p
                }),
                LfMethod::WhiteBlackCue => ours(LightFieldParams {
                    white_black_cue: true,
                    ..Default::default()
                }),
                LfMethod::NoUnlitFill => ours(LightFieldParams {
                    unlit_as_missing: false,
                    ..Default::default()
                }),
                LfMethod::UnlitOwnFill => ours(LightFieldParams {
                    unlit_from_centre: false,
                    ..Default::default()
                }),
                LfMethod::ThesisDataTerm => ours(LightFieldParams::thesis_data_term()),
                LfMethod::PreviousDefaults => ours(LightFieldParams::previous_defaults()),
                LfMethod::RetinexPrior => ours(LightFieldParams {
                    level_prior: decompose::lightfield::method::LevelPrior::CentreRetinex,
                    ..Default::default()
                }),
                LfMethod::Shear => ours(LightFieldParams {
                    shear: true,
                    ..Default::default()
                }),
                LfMethod::Retinex => per_view_retinex(lf),
                LfMethod::Clustering => per_view(lf, |img| {
                    clustering::decompose(img, None, &ClusteringParams::default(), &mut |_| {})
                        .map(|o| o.decomposition)
                }),
            }
            .with_context(|| format!("{name}: {}", m.name()))?;
            let seconds = t.elapsed().as_secs_f64();
            let scores = evaluate(&d, &truth)?;
            out(&format!(
                "{name:10} {:26} LMSE {:.4}  incoherence {:.5}  {:6.1} s\n",
                m.name(),
                scores.lmse,
                scores.incoherence,
                seconds
            ))?;
            rows.insert(m.name(), Row { scores, seconds });
        }
        all.insert(name, rows);
    }
    if all.len() > 1 {
        out("\nmean over scenes\n")?;
        for &m in &methods {
            let rows: Vec<&Row> = all.values().filter_map(|r| r.get(m.name())).collect();
            let n = rows.len().max(1) as f64;
            out(&format!(
                "{:37} LMSE {:.4}  incoherence {:.5}\n",
                m.name(),
                rows.iter().map(|r| r.scores.lmse).sum::<f64>() / n,
                rows.iter().map(|r| r.scores.incoherence).sum::<f64>() / n
            ))?;
        }
    }
    if let Some(p) = &a.json {
        std::fs::write(p, serde_json::to_string_pretty(&all)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
