//! Speed of the per-view Retinex solve of the light-field method (issue 21, step 5): Jacobi
//! against multigrid preconditioned conjugate gradients on one view, from a cold start (the log
//! intensity, as for the centre view) and a warm start (the solved neighbouring view, as for
//! every other view).
//!
//! ```text
//! nice -n 5 cargo run --release -p decompose --example retinex_multigrid -- \
//!     [SIZE=512] [HCI_SCENE_FOLDER] [--sweep]
//! ```
//!
//! Without a folder the views are those of `lightfield::synthetic::card_in_front_of_a_wall`
//! (a textured card in front of a textured wall, occlusion cue along the card's outline); with a
//! rendered scene folder that has `truth/` (scripts/render_lightfields.py) its linear views and
//! true disparities are upscaled (nearest) to `SIZE`. The cues are computed as in
//! `lightfield::method`. Columns: iterations, final relative residual, levels, wall and thread
//! CPU milliseconds, and the largest difference to a solve at tolerance 1e-10; the `setup` rows
//! stop before the first iteration (normal equations, hierarchy, first residual). `--sweep` adds
//! multigrid variants: θ = 0 aggregates across occlusions, V-cycles with over-correction α,
//! two smoothing steps, other coarsest sizes.

use std::path::Path;
use std::time::Instant;

use decompose::lightfield::cues::{self, CueParams, PairWeights};
use decompose::lightfield::io::load_truth;
use decompose::lightfield::retinex::{
    Cycle, MultigridParams, Preconditioner, ViewSolveInfo, ViewSolveParams, solve_view,
};
use decompose::lightfield::synthetic::card_in_front_of_a_wall;

/// CPU nanoseconds of the calling thread (/proc/thread-self/schedstat).
fn thread_cpu_ns() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .unwrap_or(f64::NAN)
}

/// One view's inputs to `solve_view`.
struct View {
    log_i: Vec<f32>,
    albedo: PairWeights,
    occlusion: PairWeights,
}

/// The cues and log intensity of a view as `lightfield::method` computes them.
fn view(w: usize, h: usize, rgb: &[f32], disparity: &[f32], range: (f32, f32)) -> View {
    let p = CueParams::default();
    let norm: Vec<f32> = rgb
        .chunks_exact(3)
        .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
        .collect();
    let max = norm.iter().copied().fold(0.0f32, f32::max);
    let log_i = norm.iter().map(|v| v.max(max * 1e-3).ln()).collect();
    let mut sorted: Vec<f32> = rgb.to_vec();
    sorted.sort_by(f32::total_cmp);
    let white = sorted[(sorted.len() as f64 * 0.995) as usize].max(1e-6);
    let scaled: Vec<f32> = rgb.iter().map(|x| x / white).collect();
    // The cues are part of the method's "cues and Retinex solves" stage too.
    let c = thread_cpu_ns();
    let albedo = cues::albedo_cue(w, h, rgb, &scaled, &p, true);
    let occlusion = cues::occlusion_cue(w, h, disparity, range, &p);
    println!(
        "cues of one view: {:.1} CPU ms",
        (thread_cpu_ns() - c) / 1e6
    );
    View {
        log_i,
        albedo,
        occlusion,
    }
}

/// Nearest-neighbour upscaling of a `w × h × c` buffer by `k`.
fn upscale(data: &[f32], w: usize, h: usize, c: usize, k: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(data.len() * k * k);
    for y in 0..h * k {
        for x in 0..w * k {
            let p = (y / k) * w + x / k;
            out.extend_from_slice(&data[p * c..(p + 1) * c]);
        }
    }
    out
}

/// The centre view and its right neighbour at `size²`.
fn views(size: usize, scene: Option<&Path>) -> Result<(View, View), Box<dyn std::error::Error>> {
    let (lf, disparity) = match scene {
        None => {
            let (lf, truth) = card_in_front_of_a_wall(9, 9, size as u32, size as u32, 1);
            (lf, truth.disparity)
        }
        Some(dir) => {
            let (folder, truth) = load_truth(dir)?;
            (folder.field, truth.disparity)
        }
    };
    let (w, h) = (lf.width() as usize, lf.height() as usize);
    let k = (size / w).max(1);
    let range = disparity
        .data()
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    let centre = lf.view_index(lf.rows() / 2, lf.cols() / 2);
    let make = |v: usize| {
        let rgb = upscale(lf.view_data(v), w, h, 3, k);
        let d = upscale(disparity.view_data(v), w, h, 1, k);
        view(w * k, h * k, &rgb, &d, range)
    };
    Ok((make(centre), make(centre + 1)))
}

fn solve(v: &View, start: &[f32], params: &ViewSolveParams) -> (Vec<f32>, ViewSolveInfo, f64, f64) {
    let (t, c) = (Instant::now(), thread_cpu_ns());
    let (s, info) = solve_view(&v.log_i, &v.albedo, &v.occlusion, start, params);
    (
        s,
        info,
        t.elapsed().as_secs_f64() * 1e3,
        (thread_cpu_ns() - c) / 1e6,
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let sweep = args.iter().any(|a| a == "--sweep");
    let rest: Vec<&String> = args.iter().filter(|a| *a != "--sweep").collect();
    let size: usize = rest.first().map_or(Ok(512), |s| s.parse())?;
    let scene = rest.get(1).map(Path::new);
    let (centre, right) = views(size, scene)?;
    let n = centre.log_i.len();
    let occluded = right
        .occlusion
        .horizontal
        .iter()
        .chain(&right.occlusion.vertical);
    println!(
        "view of {n} pixels ({}), occlusion pairs {:.2}%",
        scene.map_or("synthetic card".into(), |p| p.display().to_string()),
        100.0 * occluded.filter(|&&o| o < 1.0).count() as f64 / (2 * n) as f64
    );

    let tight = |preconditioner| ViewSolveParams {
        tolerance: 1e-10,
        preconditioner,
        ..Default::default()
    };
    let (parent, ..) = solve(&centre, &centre.log_i, &tight(Preconditioner::default()));
    let (reference, ..) = solve(&right, &parent, &tight(Preconditioner::default()));

    let mut variants = vec![
        ("Jacobi".to_string(), Preconditioner::Jacobi),
        ("multigrid".to_string(), Preconditioner::default()),
    ];
    if sweep {
        for (cycle, a, nu, c, strength) in [
            (Cycle::K, 1.0, 1, 1024, 0.0),
            (Cycle::V, 1.0, 1, 1024, 0.1),
            (Cycle::V, 1.5, 1, 1024, 0.1),
            (Cycle::K, 1.5, 1, 1024, 0.1),
            (Cycle::K, 1.0, 2, 1024, 0.1),
            (Cycle::K, 1.0, 1, 256, 0.1),
            (Cycle::K, 1.0, 1, 4096, 0.1),
        ] {
            let mg = MultigridParams {
                over_correction: a,
                smoothing_steps: nu,
                coarsest_size: c,
                cycle,
                strength,
            };
            let name = format!("{cycle:?} α={a} ν={nu} ≤{c} θ={strength}");
            variants.push((name, Preconditioner::Multigrid(mg)));
        }
    }
    println!(
        "{:<30} {:<5} {:>6} {:>9} {:>6} {:>9} {:>9} {:>10}",
        "preconditioner", "start", "iters", "residual", "levels", "wall ms", "CPU ms", "max |Δs|"
    );
    for (name, preconditioner) in variants {
        let params = ViewSolveParams {
            preconditioner,
            ..Default::default()
        };
        // Set-up alone: the normal equations, the hierarchy, the first residual.
        let setup = ViewSolveParams {
            max_iterations: 0,
            ..params.clone()
        };
        let (.., wall, cpu) = solve(&right, &right.log_i, &setup);
        println!(
            "{name:<30} setup {:>6} {:>9} {:>6} {wall:>9.1} {cpu:>9.1}",
            0, "", ""
        );
        for (start_name, start) in [("cold", &right.log_i), ("warm", &parent)] {
            let (s, info, wall, cpu) = solve(&right, start, &params);
            let diff = s
                .iter()
                .zip(&reference)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0f32, f32::max);
            println!(
                "{name:<30} {start_name:<5} {:>6} {:>9.2e} {:>6} {wall:>9.1} {cpu:>9.1} {diff:>10.2e}",
                info.iterations, info.residual, info.levels
            );
        }
    }
    Ok(())
}
