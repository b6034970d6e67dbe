//! `learner features`: the 169 features of every item, as CSV or JSON Lines.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use learner::features::{self, FeatureVector};
use learner::input::{self, Item};
use rayon::prelude::*;

/// Output formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `id,<169 feature names>` with one row per item.
    Csv,
    /// One JSON object per line: `{"id", "tags", "features": {name: value}}`.
    Jsonl,
}

#[derive(Debug, Args)]
pub struct FeaturesArgs {
    /// SVG/PNG/JPEG files, folders (searched recursively) and Iconify icons.json files.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Where to write the table.
    #[arg(long, short)]
    out: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    format: Format,
    /// Worker threads (default: all cores).
    #[arg(long, short)]
    jobs: Option<usize>,
    /// Sidecar CSV with `file,keywords` columns giving tags to file items (ids are paths
    /// relative to the input folder).
    #[arg(long)]
    tags: Option<PathBuf>,
    /// Exit with status 1 when any item fails (the others are still written).
    #[arg(long)]
    strict: bool,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

/// Items are featurised in chunks so memory stays flat on libraries of any size while output
/// keeps the input order.
const CHUNK: usize = 512;

pub fn run(args: FeaturesArgs) -> anyhow::Result<ExitCode> {
    let discovery = input::discover(&args.inputs, args.tags.as_deref())?;
    let mut failures: Vec<(String, String)> = discovery
        .errors
        .iter()
        .map(|e| (e.location.clone(), e.error.to_string()))
        .collect();
    if discovery.items.is_empty() {
        report_failures(&failures);
        bail!("no SVG, PNG, JPEG or Iconify items found in the inputs");
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.jobs.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;

    let progress = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(discovery.items.len() as u64).with_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} items  {per_sec}  eta {eta}  {msg}")
                .expect("static template"),
        )
    };
    let mut writer = TableWriter::create(&args.out, args.format)?;
    let mut written = 0usize;
    for chunk in discovery.items.chunks(CHUNK) {
        let results: Vec<learner::Result<FeatureVector>> = pool.install(|| {
            chunk
                .par_iter()
                .map(|item| {
                    let r = item.render().and_then(features::extract);
                    progress.inc(1);
                    r
                })
                .collect()
        });
        for (item, result) in chunk.iter().zip(results) {
            match result {
                Ok(values) => {
                    writer.write(item, &values)?;
                    written += 1;
                }
                Err(e) => failures.push((location(item), e.to_string())),
            }
        }
        progress.set_message(format!("{} failed", failures.len()));
    }
    progress.finish_and_clear();
    writer.finish()?;
    eprintln!("wrote {written} items to {}", args.out.display());
    report_failures(&failures);
    Ok(if args.strict && !failures.is_empty() {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

fn location(item: &Item) -> String {
    match &item.source {
        input::Source::SvgFile(p) | input::Source::RasterFile(p) => p.display().to_string(),
        input::Source::SvgText(_) => item.id.clone(),
    }
}

fn report_failures(failures: &[(String, String)]) {
    if failures.is_empty() {
        return;
    }
    eprintln!("{} item(s) failed:", failures.len());
    for (location, reason) in failures {
        eprintln!("  {location}: {reason}");
    }
}

/// Writes to a temporary file beside the target and renames it into place at the end, so an
/// interrupted run never leaves a truncated table that looks complete.
struct TableWriter {
    out: BufWriter<File>,
    temp: PathBuf,
    target: PathBuf,
    format: Format,
    names: Vec<&'static str>,
}

impl TableWriter {
    fn create(target: &Path, format: Format) -> anyhow::Result<Self> {
        let file_name = target.file_name().context("--out needs a file name")?;
        let temp = target.with_file_name(format!(".{}.partial", file_name.to_string_lossy()));
        let file =
            File::create(&temp).with_context(|| format!("cannot create {}", temp.display()))?;
        let names: Vec<&'static str> = features::catalogue().iter().map(|f| f.name).collect();
        let mut out = BufWriter::new(file);
        if format == Format::Csv {
            writeln!(out, "id,{}", names.join(","))?;
        }
        Ok(Self {
            out,
            temp,
            target: target.to_path_buf(),
            format,
            names,
        })
    }

    fn write(&mut self, item: &Item, values: &FeatureVector) -> anyhow::Result<()> {
        match self.format {
            Format::Csv => {
                write!(self.out, "{}", csv_field(&item.id))?;
                for v in values {
                    write!(self.out, ",{v}")?;
                }
                writeln!(self.out)?;
            }
            Format::Jsonl => {
                let features: serde_json::Map<String, serde_json::Value> = self
                    .names
                    .iter()
                    .zip(values)
                    .map(|(n, v)| (n.to_string(), serde_json::json!(v)))
                    .collect();
                let line =
                    serde_json::json!({ "id": item.id, "tags": item.tags, "features": features });
                writeln!(self.out, "{line}")?;
            }
        }
        Ok(())
    }

    fn finish(self) -> anyhow::Result<()> {
        let file = self.out.into_inner().context("cannot flush output")?;
        file.sync_all()?;
        std::fs::rename(&self.temp, &self.target)
            .with_context(|| format!("cannot move output into place at {}", self.target.display()))
    }
}

/// Quotes a CSV field when it holds a separator, quote or line break.
fn csv_field(s: &str) -> std::borrow::Cow<'_, str> {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\"")).into()
    } else {
        s.into()
    }
}
