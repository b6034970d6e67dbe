//! `decompose eval-video`: the per-frame baselines and the video method against rendered
//! ground truth (`--truth`: per-frame LMSE and flicker along the true flow), or on real footage
//! (`--real`: flicker along the estimated flow, and a contact sheet).

mod frames;
mod methods;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;

use decompose::io::LoadOptions;
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::video::score::{SequenceScorer, SequenceScores};
use decompose::video::truth::{VideoTruth, load_truth};

use crate::common::{bar, out};
use crate::contact_sheet::ContactSheet;
use frames::{Flows, first_frames};
use methods::VideoMethod;
use methods::{Runner, run_method, runners};

/// Width of the method column of the printed tables (the longest row name fits).
const NAME_WIDTH: usize = 34;

#[derive(Args)]
pub(crate) struct EvalVideoArgs {
    /// A sequence folder in the layout of docs/video-data.md (input/, reflectance/, shading/,
    /// optional flow/), or a folder of such sequences.
    #[arg(long, required_unless_present = "real", conflicts_with = "real")]
    truth: Option<PathBuf>,
    /// Instead: real footage without ground truth (a folder of frames or a video file):
    /// flicker along the estimated flow and a contact sheet.
    #[arg(long, value_name = "VIDEO_OR_FOLDER")]
    real: Option<PathBuf>,
    /// Methods to run (default: all).
    #[arg(long = "method", value_enum, value_delimiter = ',')]
    methods: Vec<VideoMethod>,
    /// Also the three ablations of the video method (thesis Fig. 3.11): completion on every
    /// frame, no confidence threshold, no optical flow; and the method without its per-frame
    /// blend (step 8, the thesis' output), with the blend of the eighth session (no clustering
    /// member), with the blend of the twelfth session (the weighted mean alone, no median),
    /// with the thesis' first-frame cluster levels (no border levelling), with the levelling
    /// but without the single views' vote on it, with the thesis' confidence test (ε = 0.8,
    /// β = 2), with the faster flow of `decompose video --flow-max-pixels 262144` (the same as
    /// ours up to 512² pixels) and with the thesis' exact colour bins (no colour ball).
    #[arg(long)]
    ablations: bool,
    /// Write every figure (with the per-frame LMSE curves) as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Use only the first N frames of every sequence.
    #[arg(long, value_name = "N")]
    frames: Option<usize>,
    /// --real: the frames are linear (otherwise 8/16-bit files are sRGB-decoded).
    #[arg(long)]
    linear: bool,
    /// Write a contact sheet PNG (input, then each method's reflectance and shading, for a
    /// few frames); with --real the default is contact-sheet.png, with --truth one per
    /// sequence named FILE with the sequence's name inserted.
    #[arg(long, value_name = "FILE")]
    contact_sheet: Option<PathBuf>,
    /// Columns (frames) of the contact sheet.
    #[arg(long, default_value_t = 5)]
    sheet_frames: usize,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

#[derive(serde::Serialize)]
struct Row {
    #[serde(flatten)]
    scores: SequenceScores,
    /// The method's time (scoring excluded), seconds.
    seconds: f64,
    seconds_per_frame: f64,
}

#[derive(serde::Serialize)]
struct SequenceReport {
    frames: usize,
    width: u32,
    height: u32,
    flow: &'static str,
    methods: BTreeMap<String, Row>,
    #[serde(skip_serializing_if = "Option::is_none")]
    contact_sheet: Option<SheetInfo>,
}

#[derive(serde::Serialize)]
struct SheetInfo {
    file: PathBuf,
    frames: Vec<usize>,
    rows: Vec<String>,
}

fn sequences(root: &Path) -> Result<Vec<PathBuf>> {
    if root.join("input").is_dir() {
        return Ok(vec![root.to_path_buf()]);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(root)
        .with_context(|| format!("reading {}", root.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("input").is_dir())
        .collect();
    found.sort();
    if found.is_empty() {
        bail!(
            "{} holds no sequence with an input/ folder (see docs/video-data.md; render some \
             with scripts/render_video.py)",
            root.display()
        );
    }
    Ok(found)
}

fn sheet_path(base: &Path, sequence: &str, several: bool) -> PathBuf {
    if !several {
        return base.to_path_buf();
    }
    let stem = base
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "contact-sheet".into());
    base.with_file_name(format!("{stem}-{sequence}.png"))
}

pub(crate) fn run_eval_video(a: EvalVideoArgs) -> Result<()> {
    let runners = runners(&a.methods, a.ablations);
    let count = a.frames.unwrap_or(usize::MAX);
    if count == 0 {
        bail!("--frames must be at least 1");
    }
    let mut report: BTreeMap<String, SequenceReport> = BTreeMap::new();
    if let Some(real) = &a.real {
        let opts = FrameOptions {
            load: LoadOptions {
                linear: a.linear,
                ..Default::default()
            },
            ..Default::default()
        };
        let source = FrameSource::open(real, &opts)
            .with_context(|| format!("opening {}", real.display()))?;
        let name = real
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "real".into());
        let n = source.len().min(count);
        let flows = Flows::estimate(&source, n, a.quiet)?;
        let sheet = a
            .contact_sheet
            .clone()
            .unwrap_or_else(|| PathBuf::from("contact-sheet.png"));
        let r = evaluate(
            &a,
            &name,
            opts.load,
            &source,
            None,
            &flows,
            &runners,
            Some(sheet),
        )?;
        report.insert(name, r);
    } else if let Some(root) = &a.truth {
        let seqs = sequences(root)?;
        for dir in &seqs {
            let name = dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            let truth = load_truth(dir).with_context(|| format!("reading {}", dir.display()))?;
            let n = truth.len().min(count);
            let flows = if truth.has_flow() {
                Flows::True(&truth)
            } else {
                Flows::estimate(truth.input_frames(), n, a.quiet)?
            };
            let sheet = a
                .contact_sheet
                .as_ref()
                .map(|p| sheet_path(p, &name, seqs.len() > 1));
            let linear = LoadOptions {
                linear: true,
                ..Default::default()
            };
            let r = evaluate(
                &a,
                &name,
                linear,
                truth.input_frames(),
                Some(&truth),
                &flows,
                &runners,
                sheet,
            )?;
            report.insert(name, r);
        }
        if report.len() > 1 {
            let mut table = String::from("\nmean over sequences\n");
            for r in &runners {
                let rows: Vec<&Row> = report
                    .values()
                    .filter_map(|s| s.methods.get(&r.name()))
                    .collect();
                let k = rows.len().max(1) as f64;
                table += &format!(
                    "{:<NAME_WIDTH$} {:>10.5} {:>10.5} {:>10.3}\n",
                    r.name(),
                    rows.iter().map(|r| r.scores.lmse).sum::<f64>() / k,
                    rows.iter().map(|r| r.scores.flicker).sum::<f64>() / k,
                    rows.iter().map(|r| r.seconds_per_frame).sum::<f64>() / k,
                );
            }
            out(&table)?;
        }
    }
    if let Some(p) = &a.json {
        std::fs::write(p, serde_json::to_string_pretty(&report)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}

/// Runs every method on one sequence, prints its table, writes its contact sheet.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    a: &EvalVideoArgs,
    name: &str,
    load: LoadOptions,
    source: &FrameSource,
    truth: Option<&VideoTruth>,
    flows: &Flows<'_>,
    runners: &[Runner],
    sheet_file: Option<PathBuf>,
) -> Result<SequenceReport> {
    let n = source.len().min(a.frames.unwrap_or(usize::MAX));
    let (w, h) = source.size();
    let mut sheet = ContactSheet::new(n, a.sheet_frames, (w, h), 240);
    let mut methods = BTreeMap::new();
    // The truth scored like a method: its flicker is the floor the flow's interpolation
    // (and, on rendered frames, nothing else) leaves.
    let mut rows: Vec<(String, Option<f64>)> = Vec::new();
    if let Some(t) = truth {
        let mut scorer = SequenceScorer::new();
        for i in 0..n {
            let (r, s) = (t.reflectance(i)?, t.shading(i)?);
            let f = if i > 0 { Some(flows.get(i - 1)?) } else { None };
            scorer.push(&r, &s, Some((&r, &s)), f.as_ref())?;
            if sheet.wants(i) {
                sheet.add("input", i, &t.input(i)?);
                sheet.add("truth reflectance", i, &r);
                sheet.add("truth shading", i, &s);
            }
        }
        methods.insert(
            "truth".to_string(),
            Row {
                scores: scorer.finish(),
                seconds: 0.0,
                seconds_per_frame: 0.0,
            },
        );
        rows.push(("truth".into(), None));
    } else {
        for i in 0..n {
            if sheet.wants(i) {
                sheet.add("input", i, &source.frame(i)?);
            }
        }
    }
    let subset = if n < source.len() {
        Some(first_frames(source, n, load)?)
    } else {
        None
    };
    let frames = subset.as_ref().map_or(source, |(_, s)| s);
    let pb = bar(a.quiet);
    pb.set_length((n * runners.len()) as u64);
    for runner in runners {
        let label = runner.name();
        pb.set_message(format!("{name}: {label}"));
        let mut scorer = SequenceScorer::new();
        let ms = run_method(runner, frames, &mut |i, r, s| {
            let t = match truth {
                Some(t) => Some((t.reflectance(i)?, t.shading(i)?)),
                None => None,
            };
            let f = if i > 0 { Some(flows.get(i - 1)?) } else { None };
            scorer.push(r, s, t.as_ref().map(|(a, b)| (a, b)), f.as_ref())?;
            if sheet.wants(i) {
                sheet.add(&format!("{label} reflectance"), i, r);
                sheet.add(&format!("{label} shading"), i, s);
            }
            pb.inc(1);
            Ok(())
        })
        .with_context(|| format!("{name}: {label}"))?;
        let scores = scorer.finish();
        if scores.lmse_frames.iter().any(|v| !v.is_finite()) || !scores.flicker.is_finite() {
            // Reported, not hidden: a NaN in the table would look like "no data".
            eprintln!("warning: {name}: {label} has non-finite figures");
        }
        methods.insert(
            label.clone(),
            Row {
                scores,
                seconds: ms / 1e3,
                seconds_per_frame: ms / 1e3 / n as f64,
            },
        );
        rows.push((label, Some(ms / 1e3 / n as f64)));
    }
    pb.finish_and_clear();
    let mut table = format!(
        "\n{name}: {n} frames of {w}x{h}, flicker along the {}\n{:<NAME_WIDTH$} {:>10} {:>10} {:>10}\n",
        flows.describe(),
        "method",
        "mean LMSE",
        "flicker",
        "s/frame"
    );
    for (label, spf) in &rows {
        let s = &methods[label].scores;
        let lmse = if truth.is_some() {
            format!("{:>10.5}", s.lmse)
        } else {
            format!("{:>10}", "-")
        };
        let spf = spf.map_or_else(|| format!("{:>10}", "-"), |v| format!("{v:>10.3}"));
        table += &format!("{label:<NAME_WIDTH$} {lmse} {:>10.5} {spf}\n", s.flicker);
    }
    let contact_sheet = match sheet_file {
        Some(file) => {
            sheet
                .save(&file)
                .with_context(|| format!("writing {}", file.display()))?;
            table += &format!(
                "contact sheet {} (frames {:?}; rows: {})\n",
                file.display(),
                sheet.frames(),
                sheet.legend().join(", ")
            );
            Some(SheetInfo {
                file,
                frames: sheet.frames().to_vec(),
                rows: sheet.legend(),
            })
        }
        None => None,
    };
    out(&table)?;
    Ok(SequenceReport {
        frames: n,
        width: w,
        height: h,
        flow: flows.describe(),
        methods,
        contact_sheet,
    })
}
