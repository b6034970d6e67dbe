//! Parameter sweep of the clustering method on an MIT-style folder (development aid):
//! `cargo run --release --example mit_sweep -- DIR [retinex|color-retinex]`. Prints the mean LMSE per
//! setting of the clustering method, of Retinex, or of Color Retinex's two thresholds.

use decompose::clustering::{self, ClusteringParams};
use decompose::io::{self, LoadOptions};
use decompose::metrics;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).ok_or("usage: mit_sweep DIR")?;
    let lin = LoadOptions {
        linear: true,
        ..Default::default()
    };
    let mut objects = Vec::new();
    for e in std::fs::read_dir(&dir)? {
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
    let base = ClusteringParams::default();
    let variants: Vec<(String, ClusteringParams)> = match std::env::args().nth(2).as_deref() {
        Some("probe") => vec![
            ("default".into(), base.clone()),
            (
                "t_l=0".into(),
                ClusteringParams {
                    t_l: 0.0,
                    ..base.clone()
                },
            ),
            (
                "partners=2".into(),
                ClusteringParams {
                    max_reflectance_partners: 2,
                    ..base.clone()
                },
            ),
            (
                "median=9".into(),
                ClusteringParams {
                    median_size: 9,
                    ..base.clone()
                },
            ),
            (
                "l_max=1".into(),
                ClusteringParams {
                    l_max_fraction: 1.0,
                    ..base.clone()
                },
            ),
            (
                "l_min=0.05".into(),
                ClusteringParams {
                    l_min_fraction: 0.05,
                    ..base.clone()
                },
            ),
        ],
        Some("robust") => {
            let mut v = vec![("default".to_string(), base.clone())];
            for cauchy in [false, true] {
                for delta in [0.02f32, 0.05, 0.1, 0.2, 0.4] {
                    for it in [3usize, 10] {
                        v.push((
                            format!("{} d={delta} it={it}", if cauchy { "cau" } else { "l1" }),
                            ClusteringParams {
                                robust_iterations: it,
                                robust_delta: delta,
                                robust_cauchy: cauchy,
                                ..base.clone()
                            },
                        ));
                    }
                }
            }
            v
        }
        Some("partners") => [(8usize, 2usize), (8, 1), (4, 1), (2, 1), (2, 2), (4, 2)]
            .into_iter()
            .map(|(n, it)| {
                (
                    format!("partners={n} irls={it}"),
                    ClusteringParams {
                        max_reflectance_partners: n,
                        robust_iterations: it,
                        ..base.clone()
                    },
                )
            })
            .collect(),
        Some("groups") => {
            let mut v = vec![("default".to_string(), base.clone())];
            for within in [false, true] {
                for q in [None, Some(0.9f32), Some(0.98), Some(1.0)] {
                    v.push((
                        format!("within={within} q={q:?}"),
                        ClusteringParams {
                            reflectance_within_groups: within,
                            group_highlight_quantile: q,
                            ..base.clone()
                        },
                    ));
                }
            }
            v
        }
        Some("chroma") => {
            let mut v = Vec::new();
            for chromaticity_features in [false, true] {
                for k in [20usize, 30] {
                    for lambda_fraction in [0.2f32, 0.5] {
                        v.push((
                            format!(
                                "chroma={chromaticity_features} k={k} lambda={lambda_fraction}"
                            ),
                            ClusteringParams {
                                chromaticity_features,
                                k,
                                lambda_fraction,
                                ..base.clone()
                            },
                        ));
                    }
                }
            }
            v
        }
        // Defaults under five k-means seeds: the spread shows how much of a difference between
        // settings is initialisation noise.
        _ => (0..5)
            .map(|seed| {
                (
                    format!("seed={seed}"),
                    ClusteringParams {
                        seed,
                        ..base.clone()
                    },
                )
            })
            .collect(),
    };
    if std::env::args().nth(2).as_deref() == Some("retinex") {
        use decompose::retinex::{self, RetinexParams, Strokes};
        let b = RetinexParams::default();
        let variants = [
            ("default", b.clone()),
            (
                "omega=3",
                RetinexParams {
                    omega: 3.0,
                    ..b.clone()
                },
            ),
            (
                "omega=10",
                RetinexParams {
                    omega: 10.0,
                    ..b.clone()
                },
            ),
            (
                "omega=1",
                RetinexParams {
                    omega: 1.0,
                    ..b.clone()
                },
            ),
            (
                "omega=0.3",
                RetinexParams {
                    omega: 0.3,
                    ..b.clone()
                },
            ),
            (
                "omega=10,t=1e-4",
                RetinexParams {
                    omega: 10.0,
                    t: 1e-4,
                    ..b.clone()
                },
            ),
            (
                "omega=10,t=3e-3",
                RetinexParams {
                    omega: 10.0,
                    t: 3e-3,
                    ..b.clone()
                },
            ),
        ];
        for (name, p) in variants {
            let mut sum = 0.0;
            for (_, input, gr, gs, mask) in &objects {
                let (d, _) =
                    retinex::decompose(input, Some(mask), &Strokes::default(), &p, &mut |_| {})?;
                sum += metrics::score(&d.reflectance, &d.shading, gr, gs, mask)?.lmse;
            }
            println!("{name:<12} mean {:.4}", sum / objects.len() as f64);
        }
        return Ok(());
    }
    if std::env::args().nth(2).as_deref() == Some("color-retinex") {
        use decompose::color_retinex::{self, ColorRetinexParams};
        for g in [0.075, 0.5, 1.0, 2.0] {
            for c in [0.01, 0.03, 0.04, 0.06] {
                let p = ColorRetinexParams {
                    threshold_gray: g,
                    threshold_color: c,
                    ..Default::default()
                };
                let mut sum = 0.0;
                for (_, input, gr, gs, mask) in &objects {
                    let (d, _) = color_retinex::decompose(input, Some(mask), &p, &mut |_| {})?;
                    sum += metrics::score(&d.reflectance, &d.shading, gr, gs, mask)?.lmse;
                }
                println!("gray {g} color {c}: mean {:.4}", sum / objects.len() as f64);
            }
        }
        return Ok(());
    }
    for (name, p) in variants {
        let mut line = String::new();
        let mut sum = 0.0;
        for (obj, input, gr, gs, mask) in &objects {
            let out = clustering::decompose(input, Some(mask), &p, &mut |_| {})?;
            let d = &out.decomposition;
            let s = metrics::score(&d.reflectance, &d.shading, gr, gs, mask)?;
            sum += s.lmse;
            line += &format!(" {}={:.4}", &obj[..3.min(obj.len())], s.lmse);
        }
        println!("{name:<16} mean {:.4} |{line}", sum / objects.len() as f64);
    }
    Ok(())
}
