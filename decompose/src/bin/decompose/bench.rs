//! `decompose bench`: timings of the clustering method, with `--lightfield` of the light-field
//! method against per-view Retinex in the same run, and with `--video` of the video method
//! (module `bench_video`).

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use decompose::Image;
use decompose::clustering::{self, ClusteringParams};
use decompose::io::{self, LoadOptions};
use decompose::process::{cpu_seconds, peak_rss_mib};
use decompose::video::method::VideoParams;

use crate::common::out;

#[derive(Args)]
pub(crate) struct BenchArgs {
    /// Repetitions per case (the minimum is reported).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Instead: a 9x9 light field of SIZE² views (the synthetic card in front of a wall),
    /// decomposed by the light-field method (per-stage split) and by per-view Retinex.
    #[arg(long, value_name = "SIZE")]
    lightfield: Option<u32>,
    /// Instead: the video method on an N-frame sequence (default 100; a synthetic one unless
    /// --video-input is given): amortised frames/s, per-stage split, peak RSS, and the
    /// per-frame Retinex and clustering baselines in the same run.
    #[arg(long, value_name = "N", num_args = 0..=1, default_missing_value = "100")]
    video: Option<usize>,
    /// --video: frame size of the synthetic sequence.
    #[arg(long, default_value = "800x600", value_name = "WxH")]
    video_size: String,
    /// --video: a folder of linear frames (or a video file) instead of the synthetic sequence.
    #[arg(long, value_name = "PATH")]
    video_input: Option<std::path::PathBuf>,
    /// --video: frames the per-frame baselines are timed on (the first ones).
    #[arg(long, default_value_t = 10)]
    baseline_frames: usize,
    /// --video: the video method's flow solved on levels of at most N pixels, as `decompose
    /// video --flow-max-pixels N` (default: every level).
    #[arg(long, value_name = "N", requires = "video",
          value_parser = clap::value_parser!(u64).range(1..))]
    flow_max_pixels: Option<u64>,
}

pub(crate) fn run_bench(a: BenchArgs) -> Result<()> {
    if let Some(size) = a.lightfield {
        return bench_lightfield(size);
    }
    if let Some(n) = a.video {
        let size = crate::bench_video::parse_size(&a.video_size)?;
        let mut params = VideoParams::default();
        params.flow.max_solved_pixels = a.flow_max_pixels.map(|n| n as usize);
        return crate::bench_video::bench_video(
            n,
            size,
            a.video_input.as_ref(),
            a.baseline_frames,
            &params,
        );
    }
    let astronaut = io::decode_rgb(
        include_bytes!("../../../../fixtures/photos/astronaut.jpg"),
        Path::new("astronaut.jpg"),
        LoadOptions::default(),
    )?;
    let coffee = io::decode_rgb(
        include_bytes!("../../../../fixtures/photos/coffee.jpg"),
        Path::new("coffee.jpg"),
        LoadOptions::default(),
    )?;
    let chelsea = io::decode_rgb(
        include_bytes!("../../../../fixtures/photos/chelsea.jpg"),
        Path::new("chelsea.jpg"),
        LoadOptions::default(),
    )?;
    // A busier 1024x1024 image: the three photos and a mirrored astronaut as 512x512 quadrants.
    let quads = [
        astronaut.resize(512, 512),
        coffee.resize(512, 512),
        chelsea.resize(512, 512),
        astronaut.resize(512, 512),
    ];
    let mosaic = Image::from_fn(1024, 1024, |x, y| {
        let q = &quads[(y / 512 * 2 + x / 512) as usize];
        let (qx, qy) = if y >= 512 && x >= 512 {
            (511 - x % 512, y % 512)
        } else {
            (x % 512, y % 512)
        };
        let p = q.get(qx, qy);
        [p[0], p[1], p[2]]
    });
    let cases = [
        // (name, image, k, k of the thesis-era defaults, target)
        ("coffee 640x480", coffee.resize(640, 480), 10, 10usize, 0.3),
        (
            "astronaut 1024x1024",
            astronaut.resize(1024, 1024),
            30,
            30,
            2.0,
        ),
        ("mosaic 1024x1024", mosaic, 30, 30, 2.0),
    ];
    out(&format!(
        "{:<22} {:>4} {:>9} {:>9} {:>10} {:>10} {:>8} {:>11} {:>13} {:>10}\n",
        "case",
        "k",
        "clusters",
        "eqs",
        "best (s)",
        "target (s)",
        "ratio",
        "peak RSS MiB",
        "previous (s)",
        "ours/prev"
    ))?;
    for (name, img, k, previous_k, target) in cases {
        let params = ClusteringParams {
            k,
            ..Default::default()
        };
        // Reset the peak-RSS high-water mark (Linux ≥ 4.0) so each case reports its own peak.
        let _ = std::fs::write("/proc/self/clear_refs", "5");
        let mut best = f64::INFINITY;
        let mut info = None;
        for _ in 0..a.repeat.max(1) {
            let t = Instant::now();
            let out = clustering::decompose(&img, None, &params, &mut |_| {})?;
            best = best.min(t.elapsed().as_secs_f64());
            info = Some(out.info);
        }
        let peak = peak_rss_mib().unwrap_or(f64::NAN);
        // The same case with the defaults before issue 19's changes (Lab chroma, λ = 0.2,
        // k = 10 at the default size, merges at D = 0.01, one plain least-squares solve, 16
        // reflectance partners, the thesis' gauge for groups).
        let plain = ClusteringParams {
            k: previous_k,
            chromaticity_features: false,
            lambda_fraction: 0.2,
            robust_iterations: 0,
            merge_threshold: 0.01,
            max_reflectance_partners: 16,
            reflectance_within_groups: false,
            group_highlight_quantile: None,
            ..params.clone()
        };
        let mut best_plain = f64::INFINITY;
        for _ in 0..a.repeat.max(1) {
            let t = Instant::now();
            clustering::decompose(&img, None, &plain, &mut |_| {})?;
            best_plain = best_plain.min(t.elapsed().as_secs_f64());
        }
        let info = info.unwrap_or_default();
        let eqs = info.equations.boundary + info.equations.reflectance;
        out(&format!(
            "{:<22} {:>4} {:>9} {:>9} {:>10.3} {:>10.1} {:>8.2} {:>11.0} {:>13.3} {:>10.2}\n",
            name,
            k,
            info.clusters,
            eqs,
            best,
            target,
            best / target,
            peak,
            best_plain,
            best / best_plain
        ))?;
    }
    Ok(())
}

/// The light-field method and per-view Retinex on one synthetic 9×9 light field.
fn bench_lightfield(size: u32) -> Result<()> {
    use decompose::lightfield::method::per_view_retinex;
    use decompose::lightfield::synthetic::card_in_front_of_a_wall;
    use decompose::lightfield::{LightFieldParams, decompose as decompose_lf};
    if !(16..=2048).contains(&size) {
        anyhow::bail!("--lightfield SIZE must be between 16 and 2048, got {size}");
    }
    let (lf, truth) = card_in_front_of_a_wall(9, 9, size, size, 1);
    out(&format!("9x9 views of {size}x{size}, 2 threads\n"))?;
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let cpu = cpu_seconds();
    let t = Instant::now();
    let (_, info) = decompose_lf(
        &lf,
        Some(&truth.disparity),
        &LightFieldParams::default(),
        &mut |_| {},
    )?;
    let ours = t.elapsed().as_secs_f64();
    for (stage, ms) in &info.stage_ms {
        out(&format!("  {stage:<28} {:>8.2} s\n", ms / 1e3))?;
    }
    let ours_cpu = cpu.zip(cpu_seconds()).map(|(a, b)| b - a);
    out(&format!(
        "light-field method           {ours:>8.2} s   CPU {:>7.2} s   peak RSS {:.0} MiB\n",
        ours_cpu.unwrap_or(f64::NAN),
        peak_rss_mib().unwrap_or(f64::NAN)
    ))?;
    let _ = std::fs::write("/proc/self/clear_refs", "5");
    let cpu = cpu_seconds();
    let t = Instant::now();
    per_view_retinex(&lf)?;
    let zhao = t.elapsed().as_secs_f64();
    let zhao_cpu = cpu.zip(cpu_seconds()).map(|(a, b)| b - a);
    out(&format!(
        "per-view Retinex (81 views)  {zhao:>8.2} s   CPU {:>7.2} s   peak RSS {:.0} MiB\n\
         ratio (ours / per-view)      {:>8.2}     CPU {:>7.2}\n",
        zhao_cpu.unwrap_or(f64::NAN),
        peak_rss_mib().unwrap_or(f64::NAN),
        ours / zhao,
        ours_cpu.zip(zhao_cpu).map_or(f64::NAN, |(a, b)| a / b)
    ))?;
    Ok(())
}
