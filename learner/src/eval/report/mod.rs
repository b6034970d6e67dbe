//! Figures of the paper's §5.6 for a trained model, drawn with plotters as SVG and rendered to
//! PNG with resvg (so the PNGs get real system fonts without a font file in the repository):
//!
//! * Fig. 5.3: learned weights, one bar per feature, coloured and ordered by feature family;
//! * Fig. 5.4: held-out accuracy and perplexity against λ (the cross-validation table), with
//!   ±1 SE bars over folds, the uniform metric and the chosen λ marked ([`lambda_svg`]);
//! * Fig. 5.5: test accuracy and perplexity against the number of training triplets.
//!
//! plus an `index.html` that shows them with the model's summary and the λ search
//! ([`lambda_html`]: warnings, held-out agreement with intervals, the table).

mod charts;
mod lambda;

use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::predict;
use super::triplets::{BootstrapParams, score};
use crate::metric::Model;
use crate::metric::train::{LambdaChoice, TrainParams, train};
use crate::table::FeatureTable;
use crate::triplets::{Triplet, TripletSet};
use crate::{Error, Result};
pub use charts::{curve_svg, svg_to_png, weights_svg};
pub use lambda::{ERROR_BAR, chosen_label, lambda_html, lambda_svg};

/// One point of the learning curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Training triplets used.
    pub triplets: usize,
    /// λ used (the model's λ per training triplet, times `triplets`).
    pub lambda: f64,
    /// Test accuracy of the learned metric.
    pub accuracy: f64,
    /// Test perplexity of the learned metric.
    pub perplexity: f64,
    /// Test accuracy of uniform weights.
    pub uniform_accuracy: f64,
    /// Test perplexity of uniform weights (scale fitted on the same subset).
    pub uniform_perplexity: f64,
    /// Non-zero weights.
    pub nonzero: usize,
}

/// Trains on nested seeded subsets of `train_set` of each size in `sizes` (λ scaled with the
/// subset so the per-triplet regularisation of `model` is kept; no cross-validation) and scores
/// each on `test`. Sizes above the training-set size are skipped.
pub fn learning_curve(
    model: &Model,
    table: &FeatureTable,
    train_set: &TripletSet,
    test: &[Triplet],
    sizes: &[usize],
    seed: u64,
    on_point: &mut dyn FnMut(usize, usize),
) -> Result<Vec<CurvePoint>> {
    let mut order: Vec<usize> = (0..train_set.triplets.len()).collect();
    order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
    let per_triplet = model.lambda / model.data.triplets.max(1) as f64;
    let sizes: Vec<usize> = sizes
        .iter()
        .copied()
        .filter(|&n| n > 0 && n <= order.len())
        .collect();
    let mut out = Vec::new();
    for (i, &n) in sizes.iter().enumerate() {
        let subset = TripletSet {
            triplets: order[..n].iter().map(|&k| train_set.triplets[k]).collect(),
            ..train_set.clone()
        };
        let lambda = per_triplet * n as f64;
        let params = TrainParams {
            lambda: LambdaChoice::Fixed(lambda),
            zero_threshold: model.zero_threshold,
            ..TrainParams::default()
        };
        let m = train(table, &subset, &params, &mut |_| {})?;
        let none = BootstrapParams {
            resamples: 0,
            seed: 0,
        };
        let learned = score(test, &predict(&m, table, test, &m.weights)?, &none)?;
        let uniform_w = vec![m.uniform_scale; m.weights.len()];
        let uniform = score(test, &predict(&m, table, test, &uniform_w)?, &none)?;
        out.push(CurvePoint {
            triplets: n,
            lambda,
            accuracy: learned.raw.accuracy.value,
            perplexity: learned.raw.perplexity.value,
            uniform_accuracy: uniform.raw.accuracy.value,
            uniform_perplexity: uniform.raw.perplexity.value,
            nonzero: m.nonzero,
        });
        on_point(i + 1, sizes.len());
    }
    Ok(out)
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|source| Error::CannotWrite {
        path: path.to_path_buf(),
        source,
    })
}

/// Writes `<name>.svg` and `<name>.png` into `dir`; returns the file stem.
fn write_chart(dir: &Path, name: &str, svg: &str) -> Result<String> {
    write(&dir.join(format!("{name}.svg")), svg.as_bytes())?;
    let png_path = dir.join(format!("{name}.png"));
    let png = svg_to_png(svg, &png_path)?;
    write(&png_path, &png)?;
    Ok(name.to_owned())
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Writes the figures and `index.html` into `dir` (created if needed); `extra_html` is inserted
/// verbatim after the summary (e.g. evaluation tables). Returns the files written.
pub fn write_report(
    dir: &Path,
    model: &Model,
    curve: Option<&[CurvePoint]>,
    extra_html: &str,
) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).map_err(|source| Error::CannotWrite {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut charts = vec![(
        write_chart(dir, "weights", &weights_svg(model)?)?,
        "Fig. 5.3 — learned weights by feature family",
    )];
    if let Some(cv) = &model.cv {
        charts.push((
            write_chart(dir, "lambda", &lambda_svg(cv)?)?,
            "Fig. 5.4 — held-out accuracy and perplexity against λ (±1 SE over folds; the \
             chosen λ in red, uniform weights dashed)",
        ));
    }
    if let Some(points) = curve
        && !points.is_empty()
    {
        charts.push((
            write_chart(dir, "learning_curve", &curve_svg(points)?)?,
            "Fig. 5.5 — learning curve",
        ));
        let json = serde_json::to_string_pretty(points).map_err(|source| Error::Json {
            path: dir.join("learning_curve.json"),
            source,
        })?;
        write(&dir.join("learning_curve.json"), json.as_bytes())?;
    }
    let mut top: Vec<(&String, f64)> = model
        .feature_names
        .iter()
        .zip(model.weights.iter().copied())
        .filter(|(_, w)| *w > 0.0)
        .collect();
    top.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut html = String::from(
        "<!doctype html><meta charset=\"utf-8\"><title>Style metric report</title>\
         <style>body{font-family:sans-serif;max-width:1040px;margin:2em auto}\
         table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}\
         img{max-width:100%}tr.chosen{font-weight:bold;background:#fdecea}\
         p.warning{background:#fff3cd;border:1px solid #e0c060;padding:4px 8px}</style>\
         <h1>Style metric report</h1>",
    );
    html.push_str(&format!(
        "<p>λ = {:.4} · {} of {} weights non-zero (threshold {}) · {} training triplets over {} \
         items · solver {:?}: {} iterations, {} evaluations, objective {:.6}, converged {} ({}) · \
         data sha256 <code>{}</code></p>",
        model.lambda,
        model.nonzero,
        model.weights.len(),
        model.zero_threshold,
        model.data.triplets,
        model.data.items,
        model.solver.solver,
        model.solver.iterations,
        model.solver.evaluations,
        model.solver.objective,
        model.solver.converged,
        html_escape(&model.solver.reason),
        model.data.sha256
    ));
    html.push_str(extra_html);
    if let Some(cv) = &model.cv {
        html.push_str(&lambda_html(cv));
    }
    for (name, caption) in &charts {
        html.push_str(&format!(
            "<figure><img src=\"{name}.svg\" alt=\"{caption}\"><figcaption>{caption} \
             (<a href=\"{name}.png\">PNG</a>)</figcaption></figure>"
        ));
    }
    html.push_str("<h2>Non-zero weights</h2><table><tr><th>feature</th><th>weight</th></tr>");
    for (name, w) in top {
        html.push_str(&format!(
            "<tr><td style=\"text-align:left\">{}</td><td>{w:.4}</td></tr>",
            html_escape(name)
        ));
    }
    html.push_str("</table>");
    write(&dir.join("index.html"), html.as_bytes())?;
    let mut files = vec![dir.join("index.html")];
    for (name, _) in &charts {
        files.push(dir.join(format!("{name}.svg")));
        files.push(dir.join(format!("{name}.png")));
    }
    Ok(files)
}
