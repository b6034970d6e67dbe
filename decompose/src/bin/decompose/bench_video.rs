//! `decompose bench --video [N]`: the intrinsic-video method on an N-frame sequence (a
//! synthetic one generated into a scratch folder unless `--video-input` is given), with the
//! per-stage split, peak RSS and the per-frame baselines' time in the same run.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};

use decompose::io::{self, Depth, Encoding, LoadOptions};
use decompose::process::{cpu_seconds, peak_rss_mib};
use decompose::retinex::Strokes;
use decompose::synthetic::{SLIDING_MOTION, sliding_albedo};
use decompose::video::baseline::{PerFrameMethod, per_frame};
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::video::method::{VideoFrame, VideoParams, decompose_video};

use crate::common::{TempDir, out};

/// Writes `n` frames of `w`×`h` of [`sliding_albedo`] into `dir` as 16-bit linear PNGs.
fn synthetic_sequence(dir: &Path, n: usize, w: u32, h: u32) -> Result<()> {
    let frame_at = sliding_albedo(w, h);
    for t in 0..n {
        let frame = frame_at(t);
        io::save(
            dir.join(format!("{t:06}.png")),
            &frame,
            Encoding::Linear,
            Depth::Sixteen,
        )?;
    }
    Ok(())
}

/// Parses `WxH`.
pub(crate) fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s
        .split_once('x')
        .with_context(|| format!("size {s:?} is not WIDTHxHEIGHT"))?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    if !(32..=8192).contains(&w) || !(32..=8192).contains(&h) {
        bail!("size {s}: each side must be 32 to 8192 pixels");
    }
    Ok((w, h))
}

pub(crate) fn bench_video(
    frames: usize,
    size: (u32, u32),
    input: Option<&PathBuf>,
    baseline_frames: usize,
    params: &VideoParams,
) -> Result<()> {
    if frames < 2 {
        bail!("--video N needs at least 2 frames, got {frames}");
    }
    let scratch = TempDir::new(&std::env::temp_dir(), "decompose-bench-video-")?;
    let (source, what) = match input {
        Some(p) => {
            let opts = FrameOptions {
                load: LoadOptions {
                    linear: true,
                    ..Default::default()
                },
                ..Default::default()
            };
            let s =
                FrameSource::open(p, &opts).with_context(|| format!("reading {}", p.display()))?;
            (s, p.display().to_string())
        }
        None => {
            let dir = scratch.path().join("frames");
            std::fs::create_dir(&dir)?;
            let t = Instant::now();
            synthetic_sequence(&dir, frames, size.0, size.1)?;
            out(&format!(
                "generated {frames} synthetic frames of {}x{} in {:.1} s\n",
                size.0,
                size.1,
                t.elapsed().as_secs_f64()
            ))?;
            let opts = FrameOptions {
                load: LoadOptions {
                    linear: true,
                    ..Default::default()
                },
                ..Default::default()
            };
            (
                FrameSource::open(&dir, &opts)?,
                format!("synthetic (albedo sliding {SLIDING_MOTION:?} px/frame)"),
            )
        }
    };
    let n = source.len();
    let (w, h) = source.size();
    let threads = rayon::current_num_threads();
    let flow = params
        .flow
        .max_solved_pixels
        .map_or("every level".to_string(), |m| {
            format!("levels of at most {m} pixels")
        });
    out(&format!(
        "video method on {n} frames of {w}x{h} ({what}), {threads} threads, flow solved on {flow}\n"
    ))?;
    // Reset the peak-RSS high-water mark (Linux ≥ 4.0) so the run reports its own peak.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let cpu = cpu_seconds();
    let t = Instant::now();
    let stats = decompose_video(
        &source,
        &Strokes::default(),
        params,
        &scratch.path().join("state"),
        &mut |_: VideoFrame<'_>| Ok(()),
        &mut |_| {},
    )?;
    let wall = t.elapsed().as_secs_f64();
    let cpu = cpu.zip(cpu_seconds()).map_or(f64::NAN, |(a, b)| b - a);
    let rss = peak_rss_mib().unwrap_or(f64::NAN);
    let sum = |f: &dyn Fn(&decompose::video::method::FrameStats) -> f64| {
        stats.frames.iter().skip(1).map(f).sum::<f64>() / 1e3
    };
    let (flow, prop, complete, view, fusion) = (
        sum(&|f| f.flow_ms),
        sum(&|f| f.propagate_ms),
        sum(&|f| f.complete_ms),
        sum(&|f| f.view_ms),
        sum(&|f| f.fusion_ms),
    );
    let first = stats.first_frame_ms / 1e3;
    // From frame 2 on, the flow to the next frame runs beside the current frame's
    // propagation and completion (`video::method`), so it is not part of the remainder.
    // Step 8's single-image decompositions run after the passes, several frames at a time:
    // their wall time (`views_ms`) is a stage of its own, the sum of their times per frame
    // is what they would take one at a time. Its blend is part of the output.
    let views = stats.views_ms / 1e3;
    let other = (stats.total_ms / 1e3 - first - prop - complete - views - fusion).max(0.0);
    let mut table = String::new();
    table += &format!("{:<44} {:>9} {:>7}\n", "stage", "s", "%");
    let total = stats.total_ms / 1e3;
    for (stage, s) in [
        ("first frame (Retinex + clusters)", first),
        ("optical flow (beside the rest, other core)", flow),
        ("propagation", prop),
        ("completion + residual fill", complete),
        ("step 8: single-image decompositions (wall)", views),
        ("  (the same, summed over the frames)", view),
        ("step 8: blend and average along the flow", fusion),
        ("other (flow wait, I/O, backward reads)", other),
    ] {
        table += &format!("{stage:<44} {s:>9.2} {:>6.1}%\n", 100.0 * s / total);
    }
    table += "(the flow overlaps the other stages, and the single-image decompositions \
              overlap each other, so the shares add up to more than 100%)\n";
    table += &format!(
        "{:<44} {total:>9.2}\n\
         frames/s amortised (first frame included)   {:>9.3}   (target >= 1 at 800x600)\n\
         wall {wall:.2} s, CPU {cpu:.2} s, peak RSS {rss:.0} MiB, {} stopping frames, {} clusters\n",
        "total",
        n as f64 / total,
        stats.stopping_frames.len(),
        stats.clusters
    );
    out(&table)?;
    // The per-frame baselines on the first frames of the same sequence.
    let k = baseline_frames.clamp(1, n);
    out(&format!(
        "\nper-frame baselines on the first {k} frames (same run)\n{:<24} {:>10} {:>12} {:>14}\n",
        "method", "s/frame", "frames/s", "peak RSS MiB"
    ))?;
    let ours = total / n as f64;
    out(&format!(
        "{:<24} {ours:>10.3} {:>12.3} {rss:>14.0}\n",
        "video method",
        1.0 / ours
    ))?;
    for m in [PerFrameMethod::retinex(), PerFrameMethod::clustering()] {
        let _ = std::fs::write("/proc/self/clear_refs", "5");
        let s = per_frame(&source, k, &m, &mut |_| Ok(()), &mut |_| {})?;
        let spf = s.frame_ms.iter().sum::<f64>() / 1e3 / k as f64;
        out(&format!(
            "{:<24} {spf:>10.3} {:>12.3} {:>14.0}\n",
            format!("per-frame {}", m.name()),
            1.0 / spf,
            peak_rss_mib().unwrap_or(f64::NAN)
        ))?;
    }
    Ok(())
}
