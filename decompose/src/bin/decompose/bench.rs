//! `decompose bench`: timings of the clustering method.

use std::path::Path;
use std::time::Instant;

use anyhow::Result;
use clap::Args;

use decompose::Image;
use decompose::clustering::{self, ClusteringParams};
use decompose::io::{self, LoadOptions};

use crate::common::out;

#[derive(Args)]
pub(crate) struct BenchArgs {
    /// Repetitions per case (the minimum is reported).
    #[arg(long, default_value_t = 3)]
    repeat: usize,
}

pub(crate) fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

pub(crate) fn run_bench(a: BenchArgs) -> Result<()> {
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
        ("coffee 640x480", coffee.resize(640, 480), 10usize, 0.3),
        ("astronaut 1024x1024", astronaut.resize(1024, 1024), 30, 2.0),
        ("mosaic 1024x1024", mosaic, 30, 2.0),
    ];
    out(&format!(
        "{:<22} {:>4} {:>9} {:>9} {:>10} {:>10} {:>8} {:>11}\n",
        "case", "k", "clusters", "eqs", "best (s)", "target (s)", "ratio", "peak RSS MiB"
    ))?;
    for (name, img, k, target) in cases {
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
        let info = info.unwrap_or_default();
        let eqs = info.equations.boundary + info.equations.reflectance;
        out(&format!(
            "{:<22} {:>4} {:>9} {:>9} {:>10.3} {:>10.1} {:>8.2} {:>11.0}\n",
            name,
            k,
            info.clusters,
            eqs,
            best,
            target,
            best / target,
            peak_rss_mib().unwrap_or(f64::NAN)
        ))?;
    }
    Ok(())
}
