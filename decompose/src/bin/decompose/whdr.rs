//! `decompose whdr`: WHDR against IIW judgements.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use indicatif::ProgressBar;

use decompose::metrics;

use crate::common::{load_input, out};
use crate::image_cmd::{DecomposeArgs, run_method};

#[derive(Args)]
pub(crate) struct WhdrArgs {
    /// The IIW photo.
    input: PathBuf,
    /// Its judgement JSON.
    judgements: PathBuf,
    #[command(flatten)]
    opts: DecomposeArgs,
    /// Equality threshold δ.
    #[arg(long, default_value_t = 0.10)]
    delta: f64,
}

pub(crate) fn run_whdr(a: WhdrArgs) -> Result<()> {
    let input = load_input(&a.input, a.opts.linear)?;
    let run = run_method(&input, None, &a.opts, &ProgressBar::hidden())?;
    let json = std::fs::read_to_string(&a.judgements)
        .with_context(|| format!("reading {}", a.judgements.display()))?;
    let v = metrics::whdr(&run.decomposition.reflectance, &json, a.delta)?;
    out(&format!("WHDR({:.2}) = {v:.4}\n", a.delta))?;
    Ok(())
}
