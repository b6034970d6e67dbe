//! `learner bench features`: per-image cost of rendering and of each feature family over a real data set,
//! the parallel throughput, and the same pipeline in Python (scikit-image, mahotas) side by side.

use std::path::PathBuf;
use std::process::{Command, ExitCode};
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::Args;
use indicatif::ProgressBar;
use learner::features::{self, FeatureVector, Prepared, colour, glcm, lbp, shading, swt};
use learner::input;
use rayon::prelude::*;

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Folders, files or Iconify sets to sample (default: the development set fetched by
    /// scripts/fetch-dev-data into .cache/style-data/dev).
    inputs: Vec<PathBuf>,
    /// How many items to time, spread evenly over the inputs.
    #[arg(long, default_value_t = 1000)]
    limit: usize,
    /// Also time the Python pipeline (scripts/bench/features_python.py) on this many of them.
    #[arg(long, default_value_t = 40)]
    python: usize,
    /// The Python reference script.
    #[arg(long, default_value = "scripts/bench/features_python.py")]
    python_script: PathBuf,
    /// Write the figures as JSON here too.
    #[arg(long)]
    json: Option<PathBuf>,
}

const STAGES: [&str; 8] = [
    "read", "render", "prepare", "colour", "shading", "lbp", "glcm", "swt",
];

pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    let inputs = if args.inputs.is_empty() {
        vec![PathBuf::from(".cache/style-data/dev")]
    } else {
        args.inputs
    };
    let discovery = input::discover(&inputs, None)?;
    if discovery.items.is_empty() {
        bail!("no items under {inputs:?}: run scripts/fetch-dev-data first or name a folder");
    }
    let step = (discovery.items.len() as f64 / args.limit.max(1) as f64).max(1.0);
    let sample: Vec<&input::Item> = (0..args.limit.min(discovery.items.len()))
        .map(|i| &discovery.items[(i as f64 * step) as usize])
        .collect();
    eprintln!(
        "timing {} of {} items on one thread…",
        sample.len(),
        discovery.items.len()
    );

    // Single-threaded, stage by stage.
    let mut totals = [Duration::ZERO; STAGES.len()];
    let mut canvases = Vec::new();
    let mut failed = 0usize;
    let bar = ProgressBar::new(sample.len() as u64);
    for item in &sample {
        bar.inc(1);
        let t0 = Instant::now();
        let bytes = match &item.source {
            input::Source::SvgFile(p) | input::Source::RasterFile(p) => std::fs::read(p)?,
            input::Source::SvgText(s) => s.clone().into_bytes(),
        };
        let t1 = Instant::now();
        let rendered = match &item.source {
            input::Source::RasterFile(_) => learner::render::render_raster(&bytes),
            _ => learner::render::render_svg(&bytes),
        };
        let t2 = Instant::now();
        let Ok(canvas) = rendered else {
            failed += 1;
            continue;
        };
        let Ok(p) = Prepared::new(canvas) else {
            failed += 1;
            continue;
        };
        let t3 = Instant::now();
        let mut out: FeatureVector = [0.0; features::FEATURE_COUNT];
        let mut stage_times = Vec::with_capacity(5);
        let mut last = t3;
        let mut time = |f: &mut dyn FnMut()| {
            f();
            let now = Instant::now();
            stage_times.push(now - last);
            last = now;
        };
        let (c, rest) = out.split_at_mut(colour::COUNT);
        time(&mut || colour::compute(&p, c));
        let (s, rest) = rest.split_at_mut(shading::COUNT);
        time(&mut || shading::compute(&p, s));
        let (l, rest) = rest.split_at_mut(lbp::COUNT);
        time(&mut || lbp::compute(&p, l));
        let (g, rest) = rest.split_at_mut(glcm::COUNT);
        time(&mut || glcm::compute(&p, g));
        time(&mut || swt::compute(&p, rest));
        totals[0] += t1 - t0;
        totals[1] += t2 - t1;
        totals[2] += t3 - t2;
        for (k, d) in stage_times.iter().enumerate() {
            totals[3 + k] += *d;
        }
        std::hint::black_box(&out);
        if canvases.len() < args.python {
            canvases.push(p.image.clone());
        }
    }
    bar.finish_and_clear();
    let n = (sample.len() - failed).max(1) as f64;
    let ms = |d: Duration| d.as_secs_f64() * 1e3 / n;
    let render_ms = ms(totals[1]);
    let features_ms: f64 = totals[2..].iter().map(|&d| ms(d)).sum();

    // All cores, the whole pipeline as `learner features` runs it.
    let t = Instant::now();
    let ok = sample
        .par_iter()
        .filter(|item| item.render().and_then(features::extract).is_ok())
        .count();
    let parallel_s = t.elapsed().as_secs_f64();
    let items_per_s = ok as f64 / parallel_s;

    outln!(
        "\nper image, one thread ({} items, {failed} failed)",
        sample.len()
    )?;
    outln!("{:<28} {:>10}", "stage", "ms/image")?;
    for (name, d) in STAGES.iter().zip(totals) {
        outln!("{name:<28} {:>10.3}", ms(d))?;
    }
    outln!("{:<28} {:>10.3}", "render (a)", render_ms)?;
    outln!(
        "{:<28} {:>10.3}",
        "render + 169 features (b)",
        render_ms + features_ms
    )?;
    outln!(
        "{:<28} {:>10.2}",
        "features / render",
        features_ms / render_ms
    )?;
    outln!(
        "{:<28} {:>10.2}",
        "(b) / (a)",
        (render_ms + features_ms) / render_ms
    )?;
    outln!(
        "\nall {} threads: {items_per_s:.1} items/s → 200,000 items in {:.1} min",
        rayon::current_num_threads(),
        200_000.0 / items_per_s / 60.0
    )?;

    let mut report = serde_json::json!({
        "items": sample.len(), "failed": failed,
        "ms_per_image": STAGES.iter().zip(totals).map(|(k, d)| (k.to_string(), serde_json::json!(ms(d)))).collect::<serde_json::Map<_, _>>(),
        "render_ms": render_ms, "features_ms": features_ms,
        "parallel_items_per_s": items_per_s, "threads": rayon::current_num_threads(),
    });
    if args.python > 0 {
        match python_side_by_side(&args.python_script, &canvases, &totals, n) {
            Ok(py) => report["python"] = py,
            Err(e) => eprintln!("\nPython comparison skipped: {e:#}"),
        }
    }
    if let Some(path) = args.json {
        std::fs::write(&path, serde_json::to_string_pretty(&report)?)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs the Python pipeline on the same renderings and prints per-family ratios.
fn python_side_by_side(
    script: &std::path::Path,
    canvases: &[image::RgbImage],
    totals: &[Duration; STAGES.len()],
    n: f64,
) -> anyhow::Result<serde_json::Value> {
    if !script.is_file() {
        bail!(
            "{} not found (run from the workspace root)",
            script.display()
        );
    }
    let dir = tempfile::tempdir()?;
    for (i, c) in canvases.iter().enumerate() {
        c.save(dir.path().join(format!("{i:05}.png")))?;
    }
    let out = dir.path().join("python.json");
    eprintln!("timing the Python pipeline on {} items…", canvases.len());
    let status = Command::new("python3")
        .arg(script)
        .arg(dir.path())
        .arg("--json")
        .arg(&out)
        .status()
        .context("cannot run python3")?;
    if !status.success() {
        bail!(
            "{} failed ({status}); it needs numpy, scipy, scikit-image and mahotas",
            script.display()
        );
    }
    let py: serde_json::Value = serde_json::from_slice(&std::fs::read(&out)?)?;
    let per = &py["seconds_per_image"];
    outln!("\nside by side with Python (numpy/scipy/scikit-image/mahotas), one core, ms/image")?;
    outln!(
        "{:<10} {:>10} {:>10} {:>10}",
        "family",
        "rust",
        "python",
        "speed-up"
    )?;
    let mut rust_total = 0.0;
    let mut py_total = 0.0;
    let mut py_total_without_swt = 0.0;
    let mut rust_total_without_swt = 0.0;
    for (k, name) in STAGES.iter().enumerate().skip(2) {
        let r = totals[k].as_secs_f64() * 1e3 / n;
        let p = per[*name].as_f64().unwrap_or(f64::NAN) * 1e3;
        outln!("{name:<10} {r:>10.3} {p:>10.3} {:>9.1}x", p / r)?;
        rust_total += r;
        py_total += p;
        if *name != "swt" {
            rust_total_without_swt += r;
            py_total_without_swt += p;
        }
    }
    outln!(
        "{:<10} {rust_total:>10.3} {py_total:>10.3} {:>9.1}x",
        "all",
        py_total / rust_total
    )?;
    outln!(
        "{:<10} {rust_total_without_swt:>10.3} {py_total_without_swt:>10.3} {:>9.1}x",
        "all - swt",
        py_total_without_swt / rust_total_without_swt
    )?;
    outln!("(Python versions: {})", py["versions"])?;
    Ok(py)
}
