//! Helpers shared by the subcommands: standard output, progress bars, input files.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};

use decompose::io::{self, Depth, Encoding, LoadOptions};
use decompose::{Image, Mask};

/// Writes to stdout, turning a closed pipe into an error instead of a panic.
pub(crate) fn out(text: &str) -> Result<()> {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .context("writing to standard output")
}

pub(crate) fn bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(100);
    if let Ok(style) = ProgressStyle::with_template("{bar:40} {pos:>3}% {msg}") {
        pb.set_style(style);
    }
    pb
}

pub(crate) fn load_input(path: &Path, linear: bool) -> Result<Image> {
    io::load_rgb(
        path,
        LoadOptions {
            linear,
            ..Default::default()
        },
    )
    .with_context(|| format!("reading {}", path.display()))
}

pub(crate) fn load_masks(paths: &[PathBuf]) -> Result<Vec<Mask>> {
    paths
        .iter()
        .map(|p| io::load_mask(p).with_context(|| format!("reading mask {}", p.display())))
        .collect()
}

/// The encoding and bit depth of written images from `--linear-output` and `--depth`.
pub(crate) fn output_format(linear_output: bool, depth: u8) -> (Encoding, Depth) {
    let enc = if linear_output {
        Encoding::Linear
    } else {
        Encoding::Srgb
    };
    let depth = if depth > 8 {
        Depth::Sixteen
    } else {
        Depth::Eight
    };
    (enc, depth)
}
