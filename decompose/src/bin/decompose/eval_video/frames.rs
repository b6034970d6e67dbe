//! The frames and flows `eval-video` scores along.

use anyhow::{Context, Result};

use decompose::io::LoadOptions;
use decompose::video::flow::{self, Flow, TvL1FlowParams};
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::video::truth::{VideoTruth, read_flo, write_flo};

use crate::common::{TempDir, bar};

/// The flow between consecutive frames: the truth's, or estimated once (TV-L1 on the input
/// frames) into a scratch folder of `.flo` files shared by every method.
pub(super) enum Flows<'a> {
    True(&'a VideoTruth),
    Estimated(TempDir),
}

impl Flows<'_> {
    pub(super) fn estimate(
        source: &FrameSource,
        count: usize,
        quiet: bool,
    ) -> Result<Flows<'static>> {
        let dir = TempDir::new(&std::env::temp_dir(), "decompose-eval-flow-")?;
        let pb = bar(quiet);
        pb.set_length(count.saturating_sub(1) as u64);
        pb.set_message("estimating flow");
        let params = TvL1FlowParams::default();
        let mut prev = source.frame(0)?;
        for i in 1..count {
            let next = source.frame(i)?;
            let f = flow::flow(&prev, &next, &params)
                .with_context(|| format!("estimating the flow from frame {} to {i}", i - 1))?;
            write_flo(dir.path().join(format!("{:06}.flo", i - 1)), &f)?;
            prev = next;
            pb.inc(1);
        }
        pb.finish_and_clear();
        Ok(Flows::Estimated(dir))
    }

    /// The flow from frame `index` to `index + 1`.
    pub(super) fn get(&self, index: usize) -> Result<Flow> {
        Ok(match self {
            Flows::True(t) => t.flow(index)?,
            Flows::Estimated(dir) => read_flo(dir.path().join(format!("{index:06}.flo")))?,
        })
    }

    pub(super) fn describe(&self) -> &'static str {
        match self {
            Flows::True(_) => "true flow",
            Flows::Estimated(_) => "estimated flow (TV-L1)",
        }
    }
}

/// The first `n` frames of `source` as a source of their own: a scratch folder of symbolic
/// links to their files (every method, the video method included, then sees only them).
pub(super) fn first_frames(
    source: &FrameSource,
    n: usize,
    load: LoadOptions,
) -> Result<(TempDir, FrameSource)> {
    let dir = TempDir::new(&std::env::temp_dir(), "decompose-eval-frames-")?;
    for i in 0..n {
        let from = std::fs::canonicalize(source.path(i))
            .with_context(|| format!("reading {}", source.path(i).display()))?;
        let name = from
            .file_name()
            .map(|n| n.to_os_string())
            .unwrap_or_default();
        std::os::unix::fs::symlink(&from, dir.path().join(name))
            .with_context(|| format!("linking {}", from.display()))?;
    }
    let opts = FrameOptions {
        load,
        ..Default::default()
    };
    let subset = FrameSource::open(dir.path(), &opts)?;
    Ok((dir, subset))
}
