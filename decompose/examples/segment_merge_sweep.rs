//! Sweep of the mean-colour merge threshold of the reflectance clusters (development aid for
//! `video::segment::MeanMergeParams::threshold`):
//! `cargo run --release --example segment_merge_sweep`.
//!
//! On six seeded synthetic scenes (`synthetic::scene`, 200×150, exact albedo), the first
//! frame's pipeline: Retinex reflectance, Felzenszwalb–Huttenlocher with the thesis' setting,
//! then the merge at each threshold. Prints the number of clusters and the adjusted Rand index
//! against the true regions (8-connected pieces of equal albedo).

use decompose::retinex::{RetinexParams, Strokes, decompose};
use decompose::synthetic::scene;
use decompose::video::segment::{
    FelzenszwalbParams, MeanMergeParams, adjusted_rand_index, felzenszwalb, merge_by_mean,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let thresholds = [0.0, 5.0 / 255.0, 0.03, 0.05, 0.08, 0.1, 0.15, 0.2];
    let seeds = 1..=6u64;
    let mut ari_sum = vec![0.0; thresholds.len()];
    let mut clusters = vec![0usize; thresholds.len()];
    for seed in seeds.clone() {
        let t = scene(200, 150, seed);
        // σ = 0 and a vanishing K join exactly the equal neighbours: the true regions.
        let exact = FelzenszwalbParams {
            sigma: 0.0,
            k: 1e-9,
            min_size: 1,
        };
        let truth = felzenszwalb(&t.reflectance, &exact)?;
        let (d, _) = decompose(
            &t.input,
            None,
            &Strokes::default(),
            &RetinexParams::default(),
            &mut |_| {},
        )?;
        let segments = felzenszwalb(&d.reflectance, &FelzenszwalbParams::default())?;
        print!(
            "seed {seed}: {} true regions, {} segments",
            truth.count, segments.count
        );
        for (k, &threshold) in thresholds.iter().enumerate() {
            let m = merge_by_mean(&segments, &d.reflectance, &MeanMergeParams { threshold })?;
            let ari = adjusted_rand_index(&m, &truth)?;
            ari_sum[k] += ari;
            clusters[k] += m.count;
            print!(" | {threshold:.3}: {} ({ari:.3})", m.count);
        }
        println!();
    }
    let n = seeds.count() as f64;
    println!("threshold  mean clusters  mean ARI");
    for (k, threshold) in thresholds.iter().enumerate() {
        println!(
            "{threshold:9.4}  {:13.1}  {:8.3}",
            clusters[k] as f64 / n,
            ari_sum[k] / n
        );
    }
    Ok(())
}
