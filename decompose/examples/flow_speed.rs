//! Speed and accuracy of the TV-L1 flow (issue 20, step 3) on one 800×600 pair: a smooth
//! random texture (a squashed sum of 24 seeded cosines, wavelengths 6–80 px, quantised to
//! 8 bits) and the same texture shifted by (3.3, −1.7) px, evaluated analytically (exact).
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example flow_speed -- [OUT_DIR [PREV NEXT]]
//! ```
//!
//! Prints, per parameter setting, the median wall time of 3 runs, the mean CPU time (all
//! threads; the machine is shared, so wall time alone misleads), the mean endpoint error
//! against the true shift on the interior (16 px border) and the inner iterations per level
//! (coarsest first). With `OUT_DIR`, also writes the pair as `OUT_DIR/prev.png` and
//! `OUT_DIR/next.png` (8-bit grey, exactly the frames timed here), which
//! `scripts/reference/flow_opencv.py --speed OUT_DIR` times OpenCV on. With two more image
//! files (a real frame pair, e.g. two consecutive frames of `vtest.avi`), also prints the
//! settings' times and iterations on them and each setting's mean endpoint distance to the
//! defaults' flow (no ground truth there).

use std::time::Instant;

use decompose::Image;
use decompose::color::srgb_to_linear;
use decompose::io::{self, Depth, Encoding};
use decompose::video::flow::{Flow, TvL1FlowParams, endpoint_error, flow_with_info};

const SHIFT: (f64, f64) = (3.3, -1.7);

/// A smooth random texture (24 waves of 6–80 px), quantised to 8-bit display values so that
/// the PNG written for OpenCV holds exactly these frames.
fn texture(seed: u64) -> impl Fn(f64, f64) -> f32 {
    let t = decompose::synthetic::wave_texture(seed, 24, 6.0..80.0, 0.5);
    move |x, y| srgb_to_linear(((t(x, y) * 255.0).round() / 255.0) as f32)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out_dir = args.first();
    let (w, h) = (800u32, 600u32);
    let t = texture(11);
    let prev = Image::from_fn(w, h, |x, y| [t(x as f64, y as f64)]);
    let next = Image::from_fn(w, h, |x, y| [t(x as f64 - SHIFT.0, y as f64 - SHIFT.1)]);
    let truth = Flow::from_fn(w, h, |_, _| [SHIFT.0 as f32, SHIFT.1 as f32]);
    if let Some(dir) = &out_dir {
        std::fs::create_dir_all(dir)?;
        io::save(
            format!("{dir}/prev.png"),
            &prev,
            Encoding::Srgb,
            Depth::Eight,
        )?;
        io::save(
            format!("{dir}/next.png"),
            &next,
            Encoding::Srgb,
            Depth::Eight,
        )?;
    }

    let d = TvL1FlowParams::default();
    let settings: Vec<(String, TvL1FlowParams)> = vec![
        ("IPOL defaults".into(), d.clone()),
        ("fast()".into(), TvL1FlowParams::fast()),
        (
            "fast(), max_solved_pixels 120000".into(),
            TvL1FlowParams {
                max_solved_pixels: Some(120_000),
                ..TvL1FlowParams::fast()
            },
        ),
        (
            "warps 1, max_iterations 20".into(),
            TvL1FlowParams {
                warps: 1,
                max_iterations: 20,
                ..d.clone()
            },
        ),
        (
            "warps 2, max_iterations 10".into(),
            TvL1FlowParams {
                warps: 2,
                max_iterations: 10,
                ..d.clone()
            },
        ),
    ];
    println!(
        "{w}x{h} shift ({}, {}), {} rayon threads",
        SHIFT.0,
        SHIFT.1,
        rayon::current_num_threads()
    );
    table(&prev, &next, &settings, &truth)?;
    if let (Some(a), Some(b)) = (args.get(1), args.get(2)) {
        let load = |p: &String| io::load_rgb(p, io::LoadOptions::default());
        let (prev, next) = (load(a)?, load(b)?);
        let reference = flow_with_info(&prev, &next, &settings[0].1)?.0;
        println!(
            "\n{a} -> {b} ({}x{}); mean EPE against the defaults' flow",
            prev.width(),
            prev.height()
        );
        table(&prev, &next, &settings, &reference)?;
    }
    Ok(())
}

/// One row per setting: median wall time of 3 runs, mean CPU time, mean EPE to `truth` on
/// the interior (16 px border), inner iterations per level.
fn table(
    prev: &Image,
    next: &Image,
    settings: &[(String, TvL1FlowParams)],
    truth: &Flow,
) -> Result<(), Box<dyn std::error::Error>> {
    println!(
        "{:<30} {:>8} {:>8} {:>9}  iterations per level",
        "setting", "wall s", "CPU s", "mean EPE"
    );
    for (name, p) in settings {
        let mut times = Vec::new();
        let mut last = None;
        let cpu0 = decompose::process::cpu_seconds().unwrap_or(f64::NAN);
        for _ in 0..3 {
            let start = Instant::now();
            let r = flow_with_info(prev, next, p)?;
            times.push(start.elapsed().as_secs_f64());
            last = Some(r);
        }
        let cpu = (decompose::process::cpu_seconds().unwrap_or(f64::NAN) - cpu0) / 3.0;
        times.sort_by(f64::total_cmp);
        let (f, info) = last.expect("three runs");
        let epe = endpoint_error(&f, truth, 16)?;
        println!(
            "{name:<30} {:>8.3} {cpu:>8.2} {epe:>9.4}  {:?}",
            times[1], info.iterations
        );
    }
    Ok(())
}
