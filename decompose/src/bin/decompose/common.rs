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

/// A folder removed with its content when dropped, unless [`TempDir::keep`] is called.
pub(crate) struct TempDir {
    path: Option<PathBuf>,
}

impl TempDir {
    /// A new empty folder named `{prefix}{pid}-{n}` (the first `n` that is free) inside
    /// `parent`.
    pub(crate) fn new(parent: &Path, prefix: &str) -> Result<Self> {
        let pid = std::process::id();
        for n in 0u32.. {
            let path = parent.join(format!("{prefix}{pid}-{n}"));
            match std::fs::create_dir(&path) {
                Ok(()) => return Ok(Self { path: Some(path) }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
                Err(e) => {
                    return Err(e).with_context(|| format!("creating {}", path.display()));
                }
            }
        }
        unreachable!("u32 range exhausted")
    }

    pub(crate) fn path(&self) -> &Path {
        self.path.as_deref().unwrap_or(Path::new(""))
    }

    /// Keeps the folder on drop (it has been moved to its final place).
    pub(crate) fn keep(mut self) -> PathBuf {
        self.path.take().unwrap_or_default()
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if let Some(p) = &self.path {
            // Best effort: a failure leaves a clearly named folder behind.
            let _ = std::fs::remove_dir_all(p);
        }
    }
}
