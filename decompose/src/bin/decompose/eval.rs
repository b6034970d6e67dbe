//! `decompose eval`: every method on the MIT intrinsic images.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use indicatif::ProgressBar;

use decompose::io::{self, LoadOptions};
use decompose::metrics::{self, Scores};

use crate::common::{bar, out};
use crate::image_cmd::{DecomposeArgs, Method, run_method};

#[derive(Args)]
pub(crate) struct EvalArgs {
    /// Directory with one folder per object holding original/diffuse/reflectance/shading/mask.
    #[arg(long)]
    mit: PathBuf,
    /// Write the numbers as JSON keyed by method.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Use original.png (with specularities) as input instead of diffuse.png.
    #[arg(long)]
    original: bool,
    /// Methods to run (default: all).
    #[arg(long, value_enum, value_delimiter = ',')]
    methods: Vec<Method>,
}

#[derive(serde::Serialize, Default)]
pub(crate) struct MethodResult {
    objects: BTreeMap<String, Scores>,
    mean: Scores,
    seconds: BTreeMap<String, f64>,
}

pub(crate) fn mean(scores: &BTreeMap<String, Scores>) -> Scores {
    let n = scores.len().max(1) as f64;
    let mut m = Scores::default();
    for s in scores.values() {
        m.lmse += s.lmse / n;
        m.lmse_shading += s.lmse_shading / n;
        m.lmse_reflectance += s.lmse_reflectance / n;
        m.si_mse += s.si_mse / n;
        m.si_mse_shading += s.si_mse_shading / n;
        m.si_mse_reflectance += s.si_mse_reflectance / n;
    }
    m
}

pub(crate) fn run_eval(a: EvalArgs) -> Result<()> {
    let methods = if a.methods.is_empty() {
        vec![Method::Clustering, Method::Retinex, Method::ColorRetinex]
    } else {
        a.methods.clone()
    };
    let mut objects: Vec<PathBuf> = std::fs::read_dir(&a.mit)
        .with_context(|| format!("reading {}", a.mit.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("reflectance.png").exists())
        .collect();
    objects.sort();
    if objects.is_empty() {
        bail!("no MIT object folders under {}", a.mit.display());
    }
    let lin = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let mut results: BTreeMap<&'static str, MethodResult> = BTreeMap::new();
    let pb = bar(false);
    pb.set_length((objects.len() * methods.len()) as u64);
    for obj in &objects {
        let name = obj
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let input_name = if a.original {
            "original.png"
        } else {
            "diffuse.png"
        };
        let input = io::load_rgb(obj.join(input_name), lin)?;
        let gt_r = io::load_rgb(obj.join("reflectance.png"), lin)?;
        let gt_s = io::load_gray(obj.join("shading.png"), lin)?;
        let mask = io::load_mask(obj.join("mask.png"))?;
        for &m in &methods {
            pb.set_message(format!("{name} {}", m.name()));
            let o = DecomposeArgs {
                method: m,
                linear: true,
                mask: None,
                k: decompose::clustering::ClusteringParams::default().k,
                seed: 0,
                strokes: Default::default(),
            };
            let t = Instant::now();
            let run = run_method(&input, Some(&mask), &o, &ProgressBar::hidden())
                .with_context(|| format!("{name}: {}", m.name()))?;
            let secs = t.elapsed().as_secs_f64();
            let d = &run.decomposition;
            let s = metrics::score(&d.reflectance, &d.shading, &gt_r, &gt_s, &mask)?;
            let r = results.entry(m.name()).or_default();
            r.objects.insert(name.clone(), s);
            r.seconds.insert(name.clone(), secs);
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    for r in results.values_mut() {
        r.mean = mean(&r.objects);
    }
    // Table: LMSE per object and method, then si-MSE. Built as a string and written once, so
    // a closed stdout (e.g. `| head`) is an error message, not a panic.
    use std::fmt::Write as _;
    let names: Vec<&str> = methods.iter().map(|m| m.name()).collect();
    let mut table = String::new();
    for (title, pick) in [
        ("LMSE (Grosse et al., 20x20 windows, stride 10)", 0),
        ("scale-invariant MSE (whole image)", 1),
    ] {
        writeln!(table, "\n{title}")?;
        write!(table, "{:<12}", "object")?;
        for n in &names {
            write!(table, " {n:>14}")?;
        }
        writeln!(table)?;
        let mut row = |label: &str, get: &dyn Fn(&MethodResult) -> Option<Scores>| {
            let mut line = format!("{label:<12}");
            for n in &names {
                let v = results
                    .get(n)
                    .and_then(get)
                    .map_or(f64::NAN, |s| if pick == 0 { s.lmse } else { s.si_mse });
                line += &format!(" {v:>14.5}");
            }
            table += &line;
            table.push('\n');
        };
        for obj in results
            .values()
            .next()
            .map(|r| r.objects.keys().cloned().collect::<Vec<_>>())
            .unwrap_or_default()
        {
            row(&obj, &|r: &MethodResult| r.objects.get(&obj).cloned());
        }
        row("mean", &|r: &MethodResult| Some(r.mean.clone()));
    }
    out(&table)?;
    if let Some(p) = a.json {
        std::fs::write(&p, serde_json::to_string_pretty(&results)?)
            .with_context(|| format!("writing {}", p.display()))?;
    }
    Ok(())
}
