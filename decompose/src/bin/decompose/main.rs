//! `decompose`: intrinsic images from the command line. A thin layer over the library: parses
//! arguments into validated parameters, draws progress, writes files. One module per
//! subcommand.

mod bench;
mod bench_video;
mod common;
mod contact_sheet;
mod edit;
mod edit_video;
mod eval;
mod eval_video;
mod image_cmd;
mod lightfield;
mod lightfield_edit;
mod lightfield_eval;
mod video;
mod whdr;

use anyhow::Result;
use clap::{Parser, Subcommand};

use bench::{BenchArgs, run_bench};
use edit::{EditCommand, run_edit};
use eval::{EvalArgs, run_eval};
use eval_video::{EvalVideoArgs, run_eval_video};
use image_cmd::{ImageArgs, run_image};
use lightfield::{LightFieldArgs, run_lightfield};
use lightfield_edit::{LightFieldEdit, run_edit_lightfield};
use lightfield_eval::{EvalLightFieldArgs, run_eval_lightfield};
use video::{VideoArgs, run_video};
use whdr::{WhdrArgs, run_whdr};

#[derive(Parser)]
#[command(
    version,
    about = "Intrinsic images: reflectance and shading from one photograph"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Decompose one image and write reflectance, shading, cluster map, scatter plot, stats.
    Image(ImageArgs),
    /// Decompose a video (folder of frames or video file) coherently over time: reflectance,
    /// shading, clusters and labels per frame, stats, optionally MP4s.
    Video(VideoArgs),
    /// Decompose a light field (HCI folder or --grid of views) coherently across its views.
    Lightfield(LightFieldArgs),
    /// Edit every view of a light field coherently (recolour from one region, relight with one
    /// curve).
    #[command(subcommand)]
    EditLightfield(LightFieldEdit),
    /// Score the light-field method, the per-view baselines and the ablations against rendered
    /// ground truth (accuracy and angular coherence).
    EvalLightfield(EvalLightFieldArgs),
    /// Evaluate every method on the MIT intrinsic images (LMSE and scale-invariant MSE).
    Eval(EvalArgs),
    /// Score the video method, the per-frame baselines and the ablations on rendered sequences
    /// with ground truth (per-frame LMSE, temporal flicker), or on real footage (flicker,
    /// contact sheet).
    EvalVideo(EvalVideoArgs),
    /// Editing applications on a decomposition (images; `video-*`: a `decompose video`
    /// output folder).
    #[command(subcommand)]
    Edit(EditCommand),
    /// WHDR of a decomposition against IIW judgements (Bell et al. 2014).
    Whdr(WhdrArgs),
    /// Time the clustering method at 640x480 (k=10) and 1024x1024 (k=30), or with --lightfield
    /// / --video the light-field or video method against per-view / per-frame baselines.
    Bench(BenchArgs),
}

fn main() -> std::process::ExitCode {
    // One line with the whole cause chain; no backtrace noise even when RUST_BACKTRACE is set.
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Image(a) => run_image(a),
        Command::Eval(a) => run_eval(a),
        Command::EvalVideo(a) => run_eval_video(a),
        Command::Video(a) => run_video(a),
        Command::Lightfield(a) => run_lightfield(a),
        Command::EvalLightfield(a) => run_eval_lightfield(a),
        Command::EditLightfield(e) => run_edit_lightfield(e),
        Command::Edit(e) => run_edit(e),
        Command::Whdr(a) => run_whdr(a),
        Command::Bench(a) => run_bench(a),
    }
}
