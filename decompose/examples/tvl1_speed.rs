//! Speed and convergence of the 4D TV-L1 filter (issue 21, eq. 4.3) on a realistic light field:
//! a photograph resized to `SIZE²`, shifted by `DISPARITY·(view − centre)` pixels per view of a
//! 9×9 grid (a fronto-parallel plane), plus seeded uniform noise of ±0.02.
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example tvl1_speed -- \
//!     IMAGE [SIZE=512] [ITERATIONS=25,50,100,200] [RHO=1] [DISPARITY=1]
//! ```
//!
//! Prints one row per iteration count: seconds, objective, its excess over the longest run,
//! the convergence measure and the peak resident memory so far (VmHWM).

use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use decompose::io::{self, LoadOptions};
use decompose::lightfield::LightField;
use decompose::lightfield::tvl1::{TvL1Params, tv_l1};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: tvl1_speed IMAGE [SIZE] [ITERS] [RHO] [DISP]")?;
    let size: u32 = args.get(1).map_or(Ok(512), |s| s.parse())?;
    let iters: Vec<usize> = args
        .get(2)
        .map_or("25,50,100,200", String::as_str)
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let rho: f32 = args.get(3).map_or(Ok(1.0), |s| s.parse())?;
    let disparity: f32 = args.get(4).map_or(Ok(1.0), |s| s.parse())?;

    let img = io::load_rgb(
        path,
        LoadOptions {
            linear: true,
            ..Default::default()
        },
    )?
    .resize(size, size);
    let (n, grid) = (size as usize, 9usize);
    let mut lf = LightField::new(grid, grid, size, size, 3);
    let [sr, sc, sy, sx] = lf.strides();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for r in 0..grid {
        for c in 0..grid {
            let dy = (disparity * (r as f32 - 4.0)).round() as isize;
            let dx = (disparity * (c as f32 - 4.0)).round() as isize;
            for y in 0..n {
                for x in 0..n {
                    let ys = (y as isize + dy).clamp(0, n as isize - 1) as u32;
                    let xs = (x as isize + dx).clamp(0, n as isize - 1) as u32;
                    let src = img.get(xs, ys);
                    let p = r * sr + c * sc + y * sy + x * sx;
                    for (dst, &v) in lf.data_mut()[p..p + 3].iter_mut().zip(src) {
                        *dst = v + 0.04 * (rng.random::<f32>() - 0.5);
                    }
                }
            }
        }
    }
    println!(
        "light field 9x9x{size}x{size}x3 ({:.0} MB), rho {rho}, beta 0.05, {} rayon threads, \
         peak RSS before filtering {:.0} MB",
        lf.data().len() as f64 * 4.0 / 1e6,
        rayon::current_num_threads(),
        decompose::process::peak_rss_mib().unwrap_or(f64::NAN)
    );
    let mut rows = Vec::new();
    for &it in &iters {
        let params = TvL1Params {
            rho,
            iterations: it,
            tolerance: 0.0,
            ..TvL1Params::default()
        };
        let (t, cpu) = (
            Instant::now(),
            decompose::process::cpu_seconds().unwrap_or(f64::NAN),
        );
        let (_, info) = tv_l1(&lf, &params)?;
        let wall = t.elapsed().as_secs_f64();
        rows.push((
            it,
            wall,
            decompose::process::cpu_seconds().unwrap_or(f64::NAN) - cpu,
            info,
            decompose::process::peak_rss_mib().unwrap_or(f64::NAN),
        ));
    }
    let best = rows
        .iter()
        .map(|r| r.3.objective)
        .fold(f64::INFINITY, f64::min);
    println!(
        "| iterations | wall s | CPU s | CPU s/iter | objective | excess over best | max change \
         | peak RSS MB |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (it, secs, cpu, info, rss) in rows {
        println!(
            "| {it} | {secs:.2} | {cpu:.2} | {:.3} | {:.6e} | {:.3}% | {:.2e} | {rss:.0} |",
            cpu / it as f64,
            info.objective,
            100.0 * (info.objective - best) / best,
            info.max_change
        );
    }
    Ok(())
}
