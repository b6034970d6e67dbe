//! Time and scores of the intrinsic-video method (`decompose::video::method`, issue 20) on one
//! rendered sequence with ground truth (`scripts/render_video.py`, `docs/video-data.md`),
//! against per-frame Retinex in the same process.
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example video_method -- SEQUENCE_DIR
//! ```
//!
//! Prints the method's wall time (total, first frame, and the per-stage sums of flow,
//! propagation and completion), CPU seconds and peak RSS, the stopping frames and the mean
//! fractions of pixels by source, then the mean LMSE (grey, 20×20 windows) and the flicker
//! (mean |Δ log luminance| of the reflectance between consecutive frames after warping frame
//! t + 1 onto frame t by the true flow, on the pixels where it is known) of the method and of
//! per-frame Retinex, with per-frame Retinex's time. Given a plain folder of linear frames
//! instead (no `input/` inside), runs the method alone with a sink that keeps nothing and
//! prints its time and peak RSS (memory against length). `PER_FRAME=1` also prints every frame's
//! [`decompose::video::method::FrameStats`]; `SCRATCH=DIR` keeps the scratch folder there;
//! `MERGE_THRESHOLD=V` sets the segment merge threshold (default 0.1); `NO_LEVELS=1` keeps the
//! first frame's cluster levels (no border levelling, as in the thesis); `LEVEL_FLOOR=V` and
//! `LEVEL_ITERATIONS=N` set [`decompose::video::method::BorderLevelParams`]; `EPSILON=V` and
//! `BETA=V` the confidence test of §3.5.2 (`ε`, `β`).

use std::time::Instant;

use decompose::color::luminance;
use decompose::io::LoadOptions;
use decompose::retinex::{RetinexParams, Strokes, decompose as retinex};
use decompose::video::flow::warp;
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::video::method::{OwnedFrame, VideoFrame, VideoParams, decompose_video};
use decompose::video::truth::{VideoTruth, known_mask, load_truth};
use decompose::{Image, Mask};

fn flicker(refl: &[Image], truth: &VideoTruth) -> Result<f64, decompose::Error> {
    let lum = |img: &Image, i: usize| f64::from(luminance(img.rgb(i)).max(1e-6)).ln();
    let (mut sum, mut n) = (0.0, 0usize);
    for t in 0..refl.len() - 1 {
        let f = truth.flow(t)?;
        let known = known_mask(&f);
        let warped = warp(&refl[t + 1], &f)?;
        for i in (0..known.len()).filter(|&i| known[i]) {
            sum += (lum(&warped, i) - lum(&refl[t], i)).abs();
            n += 1;
        }
    }
    Ok(sum / n.max(1) as f64)
}

/// A folder of frames without ground truth (no `input/` inside): the method alone, frames
/// read as linear and dropped by the sink as they come, to measure time and peak RSS.
fn frames_only(dir: &str) -> Result<(), Box<dyn std::error::Error>> {
    let opts = FrameOptions {
        load: LoadOptions {
            linear: true,
            ..Default::default()
        },
        ..Default::default()
    };
    let source = FrameSource::open(dir, &opts)?;
    let scratch = tempfile_dir()?;
    let t0 = Instant::now();
    let mut sink = |_: VideoFrame<'_>| Ok(());
    let stats = decompose_video(
        &source,
        &Strokes::default(),
        &VideoParams::default(),
        &scratch,
        &mut sink,
        &mut |_| {},
    )?;
    let wall = t0.elapsed().as_secs_f64();
    std::fs::remove_dir_all(&scratch)?;
    let (w, h) = source.size();
    println!(
        "{dir}: {} frames of {w}x{h}: {wall:.1} s ({:.3} s/frame), peak RSS {:.0} MiB, {} stopping frames, {} clusters",
        source.len(),
        wall / source.len() as f64,
        decompose::process::peak_rss_mib().unwrap_or(f64::NAN),
        stats.stopping_frames.len(),
        stats.clusters,
    );
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args()
        .nth(1)
        .ok_or("usage: video_method SEQUENCE_DIR")?;
    if !std::path::Path::new(&dir).join("input").is_dir() {
        return frames_only(&dir);
    }
    let truth = load_truth(&dir)?;
    let (w, h) = truth.size();
    let n = truth.len();
    let keep = std::env::var_os("SCRATCH");
    let scratch = match &keep {
        Some(d) => std::path::PathBuf::from(d),
        None => tempfile_dir()?,
    };
    let mut params = VideoParams::default();
    if std::env::var_os("NO_LEVELS").is_some() {
        params.levels = None;
    }
    if let (Some(l), Some(v)) = (params.levels.as_mut(), std::env::var_os("LEVEL_FLOOR")) {
        l.residual_floor = v.to_string_lossy().parse()?;
    }
    if let (Some(l), Some(v)) = (params.levels.as_mut(), std::env::var_os("LEVEL_ITERATIONS")) {
        l.iterations = v.to_string_lossy().parse()?;
    }
    if let Some(v) = std::env::var_os("EPSILON") {
        params.propagate.epsilon = v.to_string_lossy().parse()?;
    }
    if let Some(v) = std::env::var_os("BETA") {
        params.propagate.beta = v.to_string_lossy().parse()?;
    }
    if let Some(v) = std::env::var_os("MERGE_THRESHOLD") {
        params.merge.threshold = v.to_string_lossy().parse()?;
    }
    let mut out: Vec<OwnedFrame> = Vec::new();
    let cpu0 = decompose::process::cpu_seconds();
    let t0 = Instant::now();
    let stats = decompose_video(
        truth.input_frames(),
        &Strokes::default(),
        &params,
        &scratch,
        &mut out,
        &mut |_| {},
    )?;
    let wall = t0.elapsed().as_secs_f64();
    let cpu = decompose::process::cpu_seconds()
        .zip(cpu0)
        .map(|(a, b)| a - b);
    if keep.is_none() {
        std::fs::remove_dir_all(&scratch)?;
    }
    let sum = |f: fn(&decompose::video::method::FrameStats) -> f64| {
        stats.frames.iter().map(f).sum::<f64>()
    };
    println!("{dir}: {n} frames of {w}x{h}");
    println!(
        "method: {wall:.2} s wall ({:.3} s/frame), CPU {:.1} s, peak RSS {:.0} MiB",
        wall / n as f64,
        cpu.unwrap_or(f64::NAN),
        decompose::process::peak_rss_mib().unwrap_or(f64::NAN)
    );
    println!(
        "  first frame {:.0} ms; flow {:.0} ms, propagation {:.0} ms, completion+residual {:.0} ms (frames 1..)",
        stats.first_frame_ms,
        sum(|f| f.flow_ms),
        sum(|f| f.propagate_ms),
        sum(|f| f.complete_ms) - stats.first_frame_ms,
    );
    println!(
        "  stopping frames {:?}, clusters {}; mean fractions: propagation {:.3}, completion {:.3}, residual {:.3}",
        stats.stopping_frames,
        stats.clusters,
        sum(|f| f.assigned_by_propagation) / n as f64,
        sum(|f| f.completed) / n as f64,
        sum(|f| f.residual) / n as f64,
    );
    if std::env::var_os("PER_FRAME").is_some() {
        for f in &stats.frames {
            println!(
                "  frame {:2}: propagation {:.3} completion {:.3} residual {:.3}; flow {:.0} ms, propagation {:.0} ms, completion {:.0} ms",
                f.index,
                f.assigned_by_propagation,
                f.completed,
                f.residual,
                f.flow_ms,
                f.propagate_ms,
                f.complete_ms
            );
        }
    }

    let mask = Mask::full(w, h);
    let score = |r: &Image, s: &Image, t: usize| -> Result<f64, decompose::Error> {
        let (gr, gs) = (truth.reflectance(t)?, truth.shading(t)?);
        Ok(decompose::metrics::score(r, s, &gr, &gs, &mask)?.lmse)
    };
    let mut ours_lmse = 0.0;
    let mut ours_each = Vec::with_capacity(n);
    for o in &out {
        ours_each.push(score(&o.reflectance, &o.shading, o.index)?);
        ours_lmse += ours_each[o.index] / n as f64;
    }
    let ours: Vec<Image> = out.into_iter().map(|o| o.reflectance).collect();
    let ours_flicker = flicker(&ours, &truth)?;
    drop(ours);

    let t1 = Instant::now();
    let (mut base_lmse, mut base) = (0.0, Vec::with_capacity(n));
    for (t, ours_t) in ours_each.iter().enumerate() {
        let img = truth.input(t)?;
        let (d, _) = retinex(
            &img,
            None,
            &Strokes::default(),
            &RetinexParams::default(),
            &mut |_| {},
        )?;
        let l = score(&d.reflectance, &d.shading, t)?;
        if std::env::var_os("PER_FRAME").is_some() {
            println!("  frame {t:2}: LMSE method {ours_t:.4}, per-frame Retinex {l:.4}");
        }
        base_lmse += l / n as f64;
        base.push(d.reflectance);
    }
    let base_wall = t1.elapsed().as_secs_f64();
    let base_flicker = flicker(&base, &truth)?;
    println!("mean LMSE: method {ours_lmse:.4}, per-frame Retinex {base_lmse:.4}");
    println!("flicker:   method {ours_flicker:.4}, per-frame Retinex {base_flicker:.4}");
    println!(
        "per-frame Retinex (with scoring): {base_wall:.2} s ({:.3} s/frame)",
        base_wall / n as f64
    );
    Ok(())
}

/// A fresh scratch folder under the system's temporary folder.
fn tempfile_dir() -> std::io::Result<std::path::PathBuf> {
    let dir = std::env::temp_dir().join(format!("video-method-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}
