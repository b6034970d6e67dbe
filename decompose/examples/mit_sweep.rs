//! Parameter sweep of the clustering method on an MIT-style folder (development aid):
//! `cargo run --release --example mit_sweep -- DIR`. Prints the mean LMSE per setting.

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
    let variants: Vec<(String, ClusteringParams)> = vec![
        ("default".into(), base.clone()),
        (
            "skip=2".into(),
            ClusteringParams {
                border_skip: 2,
                ..base.clone()
            },
        ),
        (
            "skip=3".into(),
            ClusteringParams {
                border_skip: 3,
                ..base.clone()
            },
        ),
        (
            "skip=4".into(),
            ClusteringParams {
                border_skip: 4,
                ..base.clone()
            },
        ),
        (
            "skip=2,win=5".into(),
            ClusteringParams {
                border_skip: 2,
                border_window: 5,
                ..base.clone()
            },
        ),
        (
            "skip=3,win=5".into(),
            ClusteringParams {
                border_skip: 3,
                border_window: 5,
                ..base.clone()
            },
        ),
        (
            "skip=2,thin=1".into(),
            ClusteringParams {
                border_skip: 2,
                thin_ratio: 1.0,
                ..base.clone()
            },
        ),
    ];
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
