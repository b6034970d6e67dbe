//! Leave-one-object-out cross-validation of the clustering method's parameters on an MIT-style
//! folder (issue 19): for each object, the setting with the lowest mean LMSE on the *other*
//! objects is chosen from a grid and scored on the held-out one. Prints, per object, the
//! in-sample score of the defaults, the setting chosen without it and its held-out score, then
//! the means: the cross-validated figure is the one to compare with other methods.
//!
//! `cargo run --release -p decompose --example mit_cv -- ../shared/data/mit-intrinsic-dev
//! .cache/rendered-scenes/tune` (several folders are pooled; the means are also given per
//! folder).
//!
//! The grid (144 settings) spans the choices made on these objects: the chroma features, `k`,
//! `λ`, the robust passes and how groups of clusters cut off by the mask are levelled
//! (`reflectance_within_groups` with `group_highlight_quantile`); every other parameter keeps
//! its default.

use rayon::prelude::*;

use decompose::clustering::{self, ClusteringParams};
use decompose::io::{self, LoadOptions};
use decompose::metrics;

type Object = (
    String,
    decompose::image::Image,
    decompose::image::Image,
    decompose::image::Image,
    decompose::image::Mask,
);

fn load(dir: &str) -> Result<Vec<Object>, Box<dyn std::error::Error>> {
    let lin = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let mut objects = Vec::new();
    for e in std::fs::read_dir(dir)? {
        let p = e?.path();
        if p.join("reflectance.png").exists() {
            objects.push((
                p.file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
                io::load_rgb(p.join("diffuse.png"), lin)?,
                io::load_rgb(p.join("reflectance.png"), lin)?,
                io::load_gray(p.join("shading.png"), lin)?,
                io::load_mask(p.join("mask.png"))?,
            ));
        }
    }
    objects.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(objects)
}

fn grid() -> Vec<(String, ClusteringParams)> {
    let base = ClusteringParams::default();
    let mut out = Vec::new();
    for chromaticity_features in [false, true] {
        for k in [10, 20, 30, 45] {
            for lambda_fraction in [0.2, 0.5, 0.8] {
                for robust_iterations in [0, 2] {
                    for (within, quantile) in [(false, None), (true, Some(0.9)), (true, Some(0.98))]
                    {
                        out.push((
                            format!(
                                "chroma={chromaticity_features} k={k} lambda={lambda_fraction} \
                                 irls={robust_iterations} groups={within}/{quantile:?}"
                            ),
                            ClusteringParams {
                                chromaticity_features,
                                k,
                                lambda_fraction,
                                robust_iterations,
                                reflectance_within_groups: within,
                                group_highlight_quantile: quantile,
                                ..base.clone()
                            },
                        ));
                    }
                }
            }
        }
    }
    out
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dirs: Vec<String> = std::env::args().skip(1).collect();
    if dirs.is_empty() {
        return Err("usage: mit_cv DIR... (MIT-style folders: one folder per object)".into());
    }
    let mut objects = Vec::new();
    let mut set_of = Vec::new();
    for (d, dir) in dirs.iter().enumerate() {
        let objs = load(dir)?;
        set_of.extend(std::iter::repeat_n(d, objs.len()));
        objects.extend(objs);
    }
    if objects.len() < 3 {
        return Err(format!("need at least 3 objects, found {}", objects.len()).into());
    }
    let settings = grid();
    let defaults = ClusteringParams::default();
    eprintln!("{} settings × {} objects …", settings.len(), objects.len());
    // scores[s][o]: LMSE of setting s on object o.
    let score = |p: &ClusteringParams, o: &Object| -> Result<f64, String> {
        let out =
            clustering::decompose(&o.1, Some(&o.4), p, &mut |_| {}).map_err(|e| e.to_string())?;
        let d = &out.decomposition;
        Ok(metrics::score(&d.reflectance, &d.shading, &o.2, &o.3, &o.4)
            .map_err(|e| e.to_string())?
            .lmse)
    };
    let scores: Vec<Vec<f64>> = settings
        .par_iter()
        .map(|(_, p)| objects.iter().map(|o| score(p, o)).collect())
        .collect::<Result<_, _>>()?;
    let default_scores: Vec<f64> = objects
        .iter()
        .map(|o| score(&defaults, o))
        .collect::<Result<_, _>>()?;
    let n = objects.len();
    let mean_without = |s: usize, held: usize| -> f64 {
        (0..n)
            .filter(|&o| o != held)
            .map(|o| scores[s][o])
            .sum::<f64>()
            / (n - 1) as f64
    };
    println!(
        "{:<10} {:>10} {:>10}  chosen without it",
        "object", "defaults", "held-out"
    );
    let (mut sum_cv, mut sum_in) = (0.0, 0.0);
    let mut per_set = vec![(0.0, 0.0, 0usize); dirs.len()];
    for held in 0..n {
        let best = (0..settings.len())
            .min_by(|&a, &b| mean_without(a, held).total_cmp(&mean_without(b, held)))
            .unwrap_or(0);
        sum_cv += scores[best][held];
        sum_in += default_scores[held];
        let set = &mut per_set[set_of[held]];
        set.0 += default_scores[held];
        set.1 += scores[best][held];
        set.2 += 1;
        println!(
            "{:<10} {:>10.5} {:>10.5}  {}",
            objects[held].0, default_scores[held], scores[best][held], settings[best].0
        );
    }
    let best_in = (0..settings.len())
        .min_by(|&a, &b| {
            let m = |s: usize| scores[s].iter().sum::<f64>();
            m(a).total_cmp(&m(b))
        })
        .unwrap_or(0);
    println!(
        "mean       {:>10.5} {:>10.5}  (defaults in-sample; leave-one-object-out)",
        sum_in / n as f64,
        sum_cv / n as f64
    );
    for (dir, (i, cv, c)) in dirs.iter().zip(&per_set) {
        let c = (*c).max(1) as f64;
        println!(
            "{:<10} {:>10.5} {:>10.5}  ({dir})",
            "set mean",
            i / c,
            cv / c
        );
    }
    let mut ranked: Vec<usize> = (0..settings.len()).collect();
    ranked.sort_by(|&a, &b| {
        let m = |s: usize| scores[s].iter().sum::<f64>();
        m(a).total_cmp(&m(b))
    });
    for &s in ranked.iter().take(8) {
        let per: Vec<String> = (0..dirs.len())
            .map(|d| {
                let v: Vec<f64> = (0..n)
                    .filter(|&o| set_of[o] == d)
                    .map(|o| scores[s][o])
                    .collect();
                format!("{:.5}", v.iter().sum::<f64>() / v.len().max(1) as f64)
            })
            .collect();
        println!(
            "in-sample {:.5} per set [{}]  {}",
            scores[s].iter().sum::<f64>() / n as f64,
            per.join(" "),
            settings[s].0
        );
    }
    println!(
        "best setting in-sample: {} mean {:.5}",
        settings[best_in].0,
        scores[best_in].iter().sum::<f64>() / n as f64
    );
    Ok(())
}
